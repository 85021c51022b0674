#!/usr/bin/env bash
# Focus breathing, keyframe by keyframe: short captures (1.1 turns in 20 s, 960x540, 15 fps)
# rendered with a fixed focus and with the autofocus's focal length breathing by BREATHING %
# (`stemmap simulate --breathing-pct`), each processed as it is (breathing corrected where tracking
# finds it) and with the correction turned off (`breathing_min_keyframes` out of reach, through
# `--options`). Prints, per clip and run: how many keyframes strayed and by how much at most,
# whether the correction was kept, ATE and camera-up error of the whole trajectory, and recall,
# precision, DBH MAE / bias and position RMSE of the tree list (DBH >= 7 cm within 10 m).
# Usage: bench/breathing.sh [BUILD_DIR] [DATA_DIR]
#   SEEDS (default "4 6"), KINDS (default managed), BREATHING (default "0 1 3"), SIZE (default
#   960x540) and CLIP_SECONDS (default 20).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
SEEDS=${SEEDS:-4 6}
KINDS=${KINDS:-managed}
source "$here/common.sh"
size=${SIZE:-960x540}
duration_s=${CLIP_SECONDS:-20}
printf 'tree_id,x_m,y_m,z_m,dbh_cm,dbh_sd_cm,distance_m,azimuth_deg,n_views,flags\n' > "$data/no_trees.csv"

echo "| clip | breathing (%) | run | keyframes straying > 0.5 % | largest stray (%) | corrected | ATE (cm) | up error (°) | recall | precision | DBH MAE (cm) | DBH bias (cm) | position RMSE (cm) |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|"
for kind in $kinds; do
  for seed in $seeds; do
    for pct in ${BREATHING:-0 1 3}; do
      dir="$data/$kind-$seed-breathing-$pct"
      if [ ! -f "$dir/video.mp4" ]; then
        "$bin" --log-level warn simulate --seed "$seed" --kind "$kind" --width "${size%x*}" \
          --height "${size#*x}" --fps 15 --seconds "$duration_s" --turns 1.1 --stills 0 \
          --breathing-pct "$pct" --out "$dir" > "$dir.simulate.log" 2>&1
      fi
      python3 "$here/truth_calibration.py" "$dir/truth.json" "$dir/calibration.yaml"
      height_m=$(python3 -c "import json;print(json.load(open('$dir/truth.json'))['camera_height_m'])")
      if [ ! -f "$dir/as_is/trees.csv" ]; then
        "$bin" --log-level warn process "$dir/video.mp4" --arm-radius 1.0 --no-report \
          --calibration "$dir/calibration.yaml" --camera-height "$height_m" --out "$dir/as_is" \
          > "$dir.as_is.log" 2>&1 || true
      fi
      if [ -f "$dir/as_is/process_options.json" ] && [ ! -f "$dir/off/trees.csv" ]; then
        python3 - "$dir/as_is/process_options.json" "$dir/off_options.json" <<'PY'
import json, sys
o = json.load(open(sys.argv[1]))
def off(x):
    if isinstance(x, dict):
        for k, v in x.items():
            if k == "breathing_min_keyframes":
                x[k] = 1000000
            else:
                off(v)
off(o)
json.dump(o, open(sys.argv[2], "w"), indent=1)
PY
        "$bin" --log-level warn process "$dir/video.mp4" --options "$dir/off_options.json" \
          --no-report --out "$dir/off" > "$dir.off.log" 2>&1 || true
      fi
      for run in as_is off; do
        if [ ! -f "$dir/$run/trees.csv" ]; then
          echo "| $kind-$seed | $pct | $run | failed | | | | | | | | | |"
          continue
        fi
        "$bin" --log-level warn evaluate --truth "$dir/truth.json" --pred "$dir/$run/trees.csv" \
          --trajectory "$dir/$run/trajectory.tum" --out "$dir/$run/eval" > /dev/null 2>&1 || true
        python3 - "$kind-$seed" "$pct" "$run" "$dir/$run" <<'PY'
import json, sys
name, pct, run, d = sys.argv[1:]
s = json.load(open(f"{d}/summary.json"))["track"]
e = json.load(open(f"{d}/eval/evaluation.json"))
t, tr = e["raw"], e["trajectory"]
print(f"| {name} | {pct} | {run} | {s['breathing_keyframes']} | {s['keyframe_focal_max_stray_pct']:.2f} | "
      f"{'yes' if s['breathing_corrected'] else 'no'} | {100 * tr['ate_rmse_m']:.2f} | "
      f"{tr['mean_up_error_deg']:.2f} | {t['recall']:.3f} | {t['precision']:.3f} | "
      f"{t['dbh']['mae_cm']:.2f} | {t['dbh']['bias_cm']:+.2f} | {100 * t['position_rmse_m']:.1f} |")
PY
      done
    done
  done
done
