#!/usr/bin/env bash
# Several videos of one plot: each stand captured five times (three start directions from its
# centre, two tripods about a metre off), each video processed, the five runs merged by
# `stemmap merge`. Reports per stand the registration error of each run against the simulated
# truth (the captures' poses in the stand) and, across the five runs, the median per-tree SD of
# DBH and position. Usage: bench/repeatability.sh [BUILD_DIR] [DATA_DIR]
#   SEEDS or FRESH=N and KINDS as in bench/plots.sh; fresh stands render at 1080p, 15 fps.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
source "$here/common.sh"
sim_args=${SIM_ARGS:---fps 15}
# name start_deg centre_offset
captures="a:0:0,0 b:120:0,0 c:240:0,0 d:60:0.8,0.6 e:300:-0.9,0.4"

echo "| stand | run | start (°) | tripod offset (m) | registration error: turn (°) / shift (cm) | stems matched | residual (cm) |"
echo "|---|---|---|---|---|---|---|"
for kind in $kinds; do
  for seed in $seeds; do
    stand="$data/repeat-$kind-$seed"
    mkdir -p "$stand"
    runs=()
    for c in $captures; do
      IFS=: read -r name start offset <<< "$c"
      dir="$stand/$name"
      if [ ! -f "$dir/video.mp4" ]; then
        "$bin" --log-level warn simulate --seed "$seed" --kind "$kind" $sim_args \
          --start-deg "$start" --centre-offset="$offset" --out "$dir" > "$dir.simulate.log" 2>&1
        python3 "$here/truth_calibration.py" "$dir/truth.json" "$dir/calibration.yaml"
      fi
      if [ ! -f "$dir/run/trees.csv" ]; then
        height=$(python3 -c "import json;print(json.load(open('$dir/truth.json'))['camera_height_m'])")
        "$bin" --log-level warn process "$dir/video.mp4" --arm-radius 1.0 \
          --calibration "$dir/calibration.yaml" --camera-height "$height" --no-report \
          --out "$dir/run" > "$dir.process.log" 2>&1
      fi
      runs+=("$dir/run")
    done
    "$bin" --log-level warn merge "${runs[@]}" --out "$stand/merged" > "$stand.merge.log"
    python3 - "$stand" "$kind-$seed" $captures <<'PY'
import json, math, sys
stand, label, captures = sys.argv[1], sys.argv[2], sys.argv[3:]
merged = json.load(open(f"{stand}/merged/merge.json"))
def pose(name):
    p = json.load(open(f"{stand}/{name}/truth.json"))["stand_from_plot"]
    return math.radians(p["yaw_deg"]), p["x_m"], p["y_m"]
y1, x1, v1 = pose(captures[0].split(":")[0])
for k, c in enumerate(captures):
    name, start, offset = c.split(":")
    if k == 0:
        print(f"| {label} | {name} | {start} | {offset} | reference | | |")
        continue
    yk, xk, vk = pose(name)
    # run 1's plot frame from run k's: rotate by yk - y1, translate by R(-y1)(ck - c1).
    true_yaw = math.degrees(yk - y1)
    dx, dy = xk - x1, vk - v1
    tx, ty = math.cos(-y1) * dx - math.sin(-y1) * dy, math.sin(-y1) * dx + math.cos(-y1) * dy
    r = merged["runs"][k]
    d_yaw = (r["yaw_deg"] - true_yaw + 180) % 360 - 180
    d_t = math.hypot(r["translation_m"][0] - tx, r["translation_m"][1] - ty)
    print(f"| {label} | {name} | {start} | {offset} | {d_yaw:+.3f} / {100 * d_t:.1f} | "
          f"{r['matched']} ({100 * r['matched_share']:.0f} %) | {100 * r['rms_m']:.1f} |")
print(f"| {label} | across the 5 runs | | | median per-tree DBH SD {merged['median_dbh_sd_cm']:.2f} cm, "
      f"position SD {100 * merged['median_position_sd_m']:.1f} cm | {merged['trees_in_every_run']} "
      f"of {merged['trees']} trees in every run | |")
PY
  done
done
