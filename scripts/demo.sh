#!/usr/bin/env bash
# Builds stemmap and runs it on a simulated demo plot: simulate a short capture, track the camera,
# and score the trajectory (the stem stages plug in here as they land).
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build build
out=demo
./build/src/stemmap/cli/stemmap simulate --seed 1 --kind managed --width 960 --height 540 \
  --fps 15 --seconds 12 --turns 1.1 --out "$out"
# The field of view and arm height a forester would know for their phone and tripod.
hfov=$(python3 -c "import json;print(json.load(open('$out/truth.json'))['intrinsics']['hfov_deg'])")
height=$(python3 -c "import json;print(json.load(open('$out/truth.json'))['camera_height_m'])")
./build/src/stemmap/cli/stemmap track "$out/video.mp4" --arm-radius 1.0 --hfov "$hfov" \
  --camera-height "$height" --out "$out/run"
# A tree list in the documented trees.csv format, written from the truth, exercises the evaluator.
python3 - "$out" <<'PY'
import json, math, sys
out = sys.argv[1]
truth = json.load(open(f"{out}/truth.json"))
with open(f"{out}/truth_trees.csv", "w") as f:
    f.write("tree_id,x_m,y_m,z_m,dbh_cm,dbh_sd_cm,distance_m,azimuth_deg,n_views,flags\n")
    for t in truth["trees"]:
        f.write(f"{t['id']},{t['x_m']:.3f},{t['y_m']:.3f},{t['z_m']:.3f},{t['dbh_cm']:.2f},0,"
                f"{t['distance_m']:.3f},{t['azimuth_deg']:.2f},0,truth\n")
PY
./build/src/stemmap/cli/stemmap evaluate --truth "$out/truth.json" --pred "$out/truth_trees.csv" \
  --trajectory "$out/run/trajectory.tum" --out "$out"
echo "demo: video, truth and stills are in $out/, the tracked trajectory in $out/run/"
