# Shared by the bench scripts (sourced): settings, plot preparation and timing.
# Expects `here` (the bench folder) and the positional BUILD_DIR / DATA_DIR.
build=${1:-build}
data=${2:-/tmp/stemmap-bench-plots}
bin="$build/src/stemmap/cli/stemmap"
seeds=${SEEDS:-1 2 3 4 5}
# FRESH=N: instead of SEEDS, N seeds drawn from the commit's hash, so every commit is judged on
# plots nobody tuned to (the tuning seeds are 1-5; these are 6 digits). The same commit gives
# the same seeds.
if [ -n "${FRESH:-}" ]; then
  commit=$(git -C "$here/.." rev-parse HEAD)
  seeds=$(python3 -c "
import hashlib, sys
h = hashlib.sha256(sys.argv[1].encode()).digest()
print(' '.join(str(100000 + int.from_bytes(h[3 * i:3 * i + 3], 'big') % 900000)
               for i in range(int(sys.argv[2]))))" "$commit" "$FRESH")
  echo "fresh seeds from commit ${commit:0:7}: $seeds" >&2
fi
# Fresh plots are rendered at 15 fps: the tracker (track_fps 15) tracks the same instants of a
# 30-fps video, so only the other frames' render time is saved (measured on a 14-s clip: 153 of
# 162 keyframes at the same instants, 7 mm apart on average; docs/benchmarks.md).
if [ -n "${FRESH:-}" ] && [ -z "${SIM_ARGS+x}" ]; then SIM_ARGS="--fps 15"; fi
kinds=${KINDS:-managed natural}
height_source=${HEIGHT_SOURCE:-measured}
mkdir -p "$data"

seconds() {  # GNU time's wall clock (h:mm:ss or m:ss.ss) in seconds
  grep "Elapsed (wall clock)" "$1" | awk '{print $NF}' |
    awk -F: '{ if (NF==3) print $1*3600+$2*60+$3; else print $1*60+$2 }'
}

# prepare_plot KIND SEED: renders DATA/KIND-SEED once (timed: DATA/KIND-SEED.simulate.log ends
# with GNU time's report), writes its calibration file and sets `plot`, `arm` and `measured` (the
# --camera-height flag, or nothing). Fails if rendering fails.
prepare_plot() {
  plot="$data/$1-$2"
  if [ ! -f "$plot/video.mp4" ]; then
    /usr/bin/time -v "$bin" --log-level warn simulate --seed "$2" --kind "$1" --out "$plot" \
      --stills 0 ${SIM_ARGS:-} > /dev/null 2> "$plot.simulate.log" ||
      { echo "simulate failed: $plot" >&2; return 1; }
  fi
  python3 "$here/truth_calibration.py" "$plot/truth.json" "$plot/calibration.yaml"
  arm=$(python3 -c "import json;print(json.load(open('$plot/truth.json'))['arm_radius_m'])")
  measured=()
  if [ "$height_source" = measured ]; then
    measured=(--camera-height "$(python3 -c "import json;print(json.load(open('$plot/truth.json'))['camera_height_m'])")")
  fi
}

# run_stage STAGE OUT COLUMNS: times `stemmap STAGE` on the prepared plot into OUT; on failure
# prints a table row with the error (COLUMNS empty cells after it) and returns 1.
run_stage() {
  rm -rf "$2"
  if ! /usr/bin/time -v "$bin" --log-level warn "$1" "$plot/video.mp4" --arm-radius "$arm" \
      --calibration "$plot/calibration.yaml" "${measured[@]}" --out "$2" \
      > "$plot.$1.log" 2> "$plot.$1.time"; then
    echo "| $(basename "$plot") | failed: $(grep -m1 'stemmap:' "$plot.$1.time" || tail -1 "$plot.$1.time") $(printf '|%.0s' $(seq "$3"))"
    return 1
  fi
  wall=$(seconds "$plot.$1.time")
  rss=$(grep "Maximum resident" "$plot.$1.time" | awk '{print int($NF/1024)}')
}
