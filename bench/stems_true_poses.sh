#!/usr/bin/env bash
# The stem stage alone: reruns `stemmap process --from-track` on each plot's earlier
# `bench/plots.sh` run with its keyframes moved to their true poses (the simulator's), and scores
# the tree list beside the one from the estimated poses. What changes is what the trajectory's
# errors cost; what stays is the stem stage's own.
# Usage: bench/stems_true_poses.sh [BUILD_DIR] [DATA_DIR]   (SEEDS, KINDS as in bench/plots.sh)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
source "$here/common.sh"

echo "| plot | poses | recall | precision | DBH MAE (cm) | bias (cm) | MARE (%) | position RMSE (cm) | wall (s) |"
echo "|---|---|---|---|---|---|---|---|---|"
for kind in $kinds; do
  for seed in $seeds; do
    plot="$data/$kind-$seed"
    if [ ! -f "$plot/process/keyframes.tum" ]; then
      echo "| $kind-$seed | no bench/plots.sh run in $plot/process |||||||"
      continue
    fi
    truth_track="$plot/true_poses_track"
    mkdir -p "$truth_track"
    cp "$plot/process/summary.json" "$truth_track/summary.json"
    python3 - "$plot/process/keyframes.tum" "$plot/trajectory_truth.tum" "$truth_track/keyframes.tum" <<'PY'
import sys
est, truth, out = sys.argv[1:]
rows = lambda f: [l.split() for l in open(f) if l.strip() and not l.startswith("#")]
true_at = {round(float(r[0]), 4): r for r in rows(truth)}
with open(out, "w") as f:
    f.write("# t tx ty tz qx qy qz qw (world_from_camera, OpenCV camera axes)\n")
    for r in rows(est):
        t = min(true_at, key=lambda s: abs(s - float(r[0])))
        f.write(" ".join([r[0]] + true_at[t][1:]) + "\n")
PY
    out="$plot/process_true_poses"
    rm -rf "$out"
    /usr/bin/time -v "$bin" --log-level warn process "$plot/video.mp4" --from-track "$truth_track" \
      --out "$out" > "$plot.true_poses.log" 2> "$plot.true_poses.time"
    wall=$(seconds "$plot.true_poses.time")
    for run in process process_true_poses; do
      "$bin" --log-level warn evaluate --truth "$plot/truth.json" --pred "$plot/$run/trees.csv" \
        --min-dbh 10 --plot-radius 10 --out "$plot/$run/eval_reported" > /dev/null
      python3 - "$kind-$seed" "$run" "$wall" "$plot/$run" <<'PY'
import json, sys
name, run, wall, out = sys.argv[1:]
e = json.load(open(f"{out}/eval_reported/evaluation.json"))["raw"]
d = e["dbh"]
label = "estimated" if run == "process" else "true"
print(f"| {name} | {label} | {e['recall']:.3f} | {e['precision']:.3f} | {d['mae_cm']:.2f} | "
      f"{d['bias_cm']:+.2f} | {d['mare_pct']:.2f} | {100 * e['position_rmse_m']:.1f} | "
      f"{float(wall):.1f} |" if label == "true" else
      f"| {name} | {label} | {e['recall']:.3f} | {e['precision']:.3f} | {d['mae_cm']:.2f} | "
      f"{d['bias_cm']:+.2f} | {d['mare_pct']:.2f} | {100 * e['position_rmse_m']:.1f} | |")
PY
    done
  done
done
