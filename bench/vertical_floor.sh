#!/usr/bin/env bash
# What the trunks' own leans leave of the vertical: `stemmap track` on the simulated plots with its
# trunk edges logged, then bench/vertical_floor.py (the up estimator replayed on the truth's trunks).
# Usage: bench/vertical_floor.sh [BUILD_DIR] [DATA_DIR]   (SEEDS, KINDS as in bench/trajectory.sh)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
source "$here/common.sh"
runs="$data/vertical_floor"
mkdir -p "$runs"
plots=()
for kind in $kinds; do
  for seed in $seeds; do
    prepare_plot "$kind" "$seed" || continue
    name="$kind-$seed"
    rm -rf "${runs:?}/$name"
    "$bin" --log-level trace track "$plot/video.mp4" --arm-radius "$arm" \
      --calibration "$plot/calibration.yaml" "${measured[@]}" --out "$runs/$name" 2>&1 |
      grep "vertical segment:" > "$runs/$name.segments" || { echo "track failed: $name" >&2; continue; }
    plots+=("$name")
  done
done
python3 "$here/vertical_floor.py" "$data" "$runs" "${plots[@]}"
