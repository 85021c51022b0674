#!/usr/bin/env bash
# Trajectory benchmark: `stemmap track` on simulated 1080p 30 fps plots (rendered once into DATA
# and reused), scored by `stemmap evaluate` against the simulator's truth.
# Usage: bench/trajectory.sh [BUILD_DIR] [DATA_DIR]
#   SEEDS="1 2 3 4 5" KINDS="managed natural"  which plots
#   HEIGHT_SOURCE=measured|estimated           camera height: from the truth, as a forester measures
#                                              it at the tripod, or estimated from the ground in view
#   SIM_ARGS="..."                             extra simulate flags (e.g. a smaller size for a dry run)
# Prints one Markdown row per plot; the camera comes from the truth's intrinsics, written as the
# calibration file a user would make with a checkerboard.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
build=${1:-build}
data=${2:-/tmp/stemmap-bench-plots}
bin="$build/src/stemmap/cli/stemmap"
seeds=${SEEDS:-1 2 3 4 5}
kinds=${KINDS:-managed natural}
height_source=${HEIGHT_SOURCE:-measured}
mkdir -p "$data"
printf 'tree_id,x_m,y_m,z_m,dbh_cm,dbh_sd_cm,distance_m,azimuth_deg,n_views,flags\n' > "$data/no_trees.csv"

seconds() {  # GNU time's wall clock (h:mm:ss or m:ss.ss) in seconds
  grep "Elapsed (wall clock)" "$1" | awk '{print $NF}' |
    awk -F: '{ if (NF==3) print $1*3600+$2*60+$3; else print $1*60+$2 }'
}

echo "| plot | frames | track wall (s) | decode+KLT / loop / BA (s) | peak RSS (MiB) | ATE (cm) | scale (%) | rot mean / max (°) | heading offset / up error (°) | loop before → after (°) | tilt est (°) | height (m) |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|"
for kind in $kinds; do
  for seed in $seeds; do
    plot="$data/$kind-$seed"
    if [ ! -f "$plot/video.mp4" ]; then
      "$bin" --log-level warn simulate --seed "$seed" --kind "$kind" --out "$plot" --stills 0 \
        ${SIM_ARGS:-} > /dev/null 2> "$plot.simulate.log" || { echo "simulate failed: $plot" >&2; continue; }
    fi
    python3 "$here/truth_calibration.py" "$plot/truth.json" "$plot/calibration.yaml"
    extra=()
    if [ "$height_source" = measured ]; then
      extra+=(--camera-height "$(python3 -c "import json;print(json.load(open('$plot/truth.json'))['camera_height_m'])")")
    fi
    arm=$(python3 -c "import json;print(json.load(open('$plot/truth.json'))['arm_radius_m'])")
    out="$plot/track"
    rm -rf "$out"
    if ! /usr/bin/time -v "$bin" --log-level warn track "$plot/video.mp4" --arm-radius "$arm" \
        --calibration "$plot/calibration.yaml" "${extra[@]}" --out "$out" \
        > "$plot.track.log" 2> "$plot.track.time"; then
      echo "| $kind-$seed | failed: $(grep -m1 'stemmap:' "$plot.track.time" || tail -1 "$plot.track.time") |||||||||"
      continue
    fi
    "$bin" --log-level warn evaluate --truth "$plot/truth.json" --pred "$data/no_trees.csv" \
      --trajectory "$out/trajectory.tum" --out "$out/eval" > /dev/null
    wall=$(seconds "$plot.track.time")
    rss=$(grep "Maximum resident" "$plot.track.time" | awk '{print int($NF/1024)}')
    python3 - "$kind-$seed" "$wall" "$rss" "$out" "$plot/truth.json" <<'PY'
import json, sys
name, wall, rss, out, truth = sys.argv[1:]
s = json.load(open(f"{out}/summary.json"))["track"]
e = json.load(open(f"{out}/eval/evaluation.json"))["trajectory"]
t = s["timing_s"]
tilt_true = json.load(open(truth))["rig"]["stand_tilt_deg"]
print(f"| {name} | {s['video']['frames']} | {float(wall):.1f} | "
      f"{t['decode_and_klt_s']:.1f} / {t['loop_detection_s']:.1f} / {t['bundle_adjustment_s']:.1f} | "
      f"{rss} | {100 * e['ate_rmse_m']:.2f} | {e['scale_error_pct']:+.3f} | "
      f"{e['mean_rotation_error_deg']:.3f} / {e['max_rotation_error_deg']:.3f} | "
      f"{e['heading_offset_deg']:+.2f} / {e['mean_up_error_deg']:.2f} | "
      f"{s['loop_error_before_deg']:.2f} → {s['loop_error_after_deg']:.3f} | "
      f"{s['stand_tilt_deg']:.2f} (true {tilt_true:.2f}) | {s['camera_height_m']:.3f} ({s['camera_height_source']}) |")
PY
  done
done
