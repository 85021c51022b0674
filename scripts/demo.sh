#!/usr/bin/env bash
# Builds stemmap and runs it on a simulated demo plot: simulate a short capture, make the tree list
# from its video with `stemmap process`, and score that list and the trajectory against the truth.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build build
bin=./build/src/stemmap/cli/stemmap
out=demo
# A capture at the protocol's own speed (one turn in 40-50 s, as the seed draws it) in 1080p at
# 15 fps, as the benchmark's fresh plots: it renders and runs in about seven minutes on two cores.
# (At 540p far stems lose half their stereo depth resolution, and positions beyond 8 m with it.)
"$bin" simulate --seed 1 --kind managed --fps 15 --out "$out"
# The phone's calibration (as `stemmap calibrate` measures it once per phone; here from the
# simulated camera) and the arm height a forester measures at the tripod.
python3 bench/truth_calibration.py "$out/truth.json" "$out/calibration.yaml"
height=$(python3 -c "import json;print(json.load(open('$out/truth.json'))['camera_height_m'])")
# Where the plot lies: a GPS reading of the centre and the compass bearing of the first view, so
# the tree list comes out on the map (trees.gpkg, trees.geojson, cloud.las, bearings in trees.csv).
"$bin" process "$out/video.mp4" --arm-radius 1.0 --calibration "$out/calibration.yaml" --camera-height "$height" \
  --plot-centre 42.3105,-2.5231 --first-bearing 212 --declination 1.5 --export fortls,fsct \
  --out "$out/run"
"$bin" evaluate --truth "$out/truth.json" --pred "$out/run/trees.csv" \
  --trajectory "$out/run/trajectory.tum" --out "$out/run"
echo "demo: video, truth and stills in $out/; tree list, map, report.html, trajectory and scores in $out/run/"
