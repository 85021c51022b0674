#!/usr/bin/env bash
# The plots of ../shared/samples (another renderer, with its truth): `stemmap process` on each as a
# user would run it (their camera, arm and nothing else: no --camera-height), scored by
# `stemmap evaluate` for stems with DBH >= 10 cm and >= 7 cm within 10 m, with the ground found
# under the tripod and at each matched stem against the truth. Report apart from bench/plots.sh;
# these plots are a check, not a target.
# Usage: bench/samples.sh [BUILD_DIR] [OUT_DIR]   (SAMPLES: the samples folder)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
build=${1:-build}
out_root=${2:-/tmp/stemmap-samples}
samples=${SAMPLES:-$here/../../shared/samples}
bin="$build/src/stemmap/cli/stemmap"
mkdir -p "$out_root"
echo "| sample | DBH ≥ | recall | precision | DBH MAE (cm) | MARE (%) | position RMSE (cm) | ±2 SD coverage | camera height error (cm): sparse / cloud | stem ground error, rms, max (cm) | wall (s) |"
echo "|---|---|---|---|---|---|---|---|---|---|---|"
for dir in "$samples"/*/; do
  name=$(basename "$dir")
  out="$out_root/$name"
  python3 "$here/truth_calibration.py" "$dir/ground_truth.json" "$out_root/$name.yaml"
  arm=$(python3 -c "import json;print(json.load(open('$dir/ground_truth.json'))['arm_radius_m'])")
  rm -rf "$out"
  start=$(date +%s.%N)
  if ! "$bin" --log-level warn process "$dir/video.mp4" --arm-radius "$arm" \
      --calibration "$out_root/$name.yaml" --out "$out" > "$out_root/$name.log" 2>&1; then
    echo "| $name | failed: $(tail -1 "$out_root/$name.log") |||||||||"
    continue
  fi
  wall=$(python3 -c "import time;print(f'{time.time() - $start:.0f}')")
  for min_dbh in 10 7; do
    "$bin" --log-level warn evaluate --truth "$dir/ground_truth.json" --pred "$out/trees.csv" \
      --min-dbh "$min_dbh" --plot-radius 10 --out "$out/eval_$min_dbh" > /dev/null
    python3 - "$name" "$min_dbh" "$dir/ground_truth.json" "$out" "$wall" <<'PY'
import csv, json, math, sys
name, min_dbh, truth_path, out, wall = sys.argv[1:]
truth = json.load(open(truth_path))
e = json.load(open(f"{out}/eval_{min_dbh}/evaluation.json"))["raw"]
summary = json.load(open(f"{out}/summary.json"))
options = json.load(open(f"{out}/process_options.json"))
breast_m = options["measure"]["stems"]["breast_height_m"]
# The plot frame's origin is the estimated ground under the tripod: the truth's ground, in it,
# lies this much higher.
origin_m = summary["track"]["camera_height_m"] - truth["camera_height_m"]
cam_err = 100 * origin_m
cloud_cam = summary["stems"].get("camera_height_m")
cloud_err = f"{100 * (cloud_cam - truth['camera_height_m']):+.1f}" if cloud_cam else ""
pred = list(csv.DictReader(open(f"{out}/trees.csv")))
# Each listed stem against the nearest true one within 0.5 m: the DBH error against its SD, and
# the ground under it.
within, n, ground = 0, 0, []
for p in pred:
    x, y = float(p["x_m"]), float(p["y_m"])
    t = min(truth["trees"], key=lambda t: math.hypot(t["x_m"] - x, t["y_m"] - y))
    if math.hypot(t["x_m"] - x, t["y_m"] - y) > 0.5 or t["dbh_cm"] < float(min_dbh):
        continue
    if math.hypot(t["x_m"], t["y_m"]) > 10:
        continue
    n += 1
    within += abs(float(p["dbh_cm"]) - t["dbh_cm"]) <= 2 * float(p["dbh_sd_cm"])
    ground.append(abs(100 * (float(p["z_m"]) - breast_m - (t["ground_z_m"] + origin_m))))
d = e["dbh"]
cover = f"{within / n:.2f}" if n else ""
g = f"{math.sqrt(sum(e * e for e in ground) / len(ground)):.1f}, {max(ground):.1f}" if ground else ""
print(f"| {name} | {min_dbh} cm | {e['recall']:.3f} | {e['precision']:.3f} | {d['mae_cm']:.2f} | "
      f"{d['mare_pct']:.2f} | {100 * e['position_rmse_m']:.1f} | {cover} | {cam_err:+.1f} / {cloud_err} | {g} | {wall} |")
PY
  done
done
