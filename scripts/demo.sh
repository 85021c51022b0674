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
# A small, short capture (about a minute to render on two cores); the benchmarks use 1080p.
"$bin" simulate --seed 1 --kind managed --width 960 --height 540 --fps 15 --seconds 12 \
  --turns 1.1 --out "$out"
# The field of view and arm height a forester would know for their phone and tripod.
hfov=$(python3 -c "import json;print(json.load(open('$out/truth.json'))['intrinsics']['hfov_deg'])")
height=$(python3 -c "import json;print(json.load(open('$out/truth.json'))['camera_height_m'])")
"$bin" process "$out/video.mp4" --arm-radius 1.0 --hfov "$hfov" --camera-height "$height" \
  --out "$out/run"
"$bin" evaluate --truth "$out/truth.json" --pred "$out/run/trees.csv" \
  --trajectory "$out/run/trajectory.tum" --out "$out/run"
echo "demo: video, truth and stills in $out/; tree list, map, report.html, trajectory and scores in $out/run/"
