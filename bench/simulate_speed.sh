#!/usr/bin/env bash
# Times `stemmap simulate` for the clip sizes the tests and benchmarks use, and reports peak RSS.
# Usage: bench/simulate_speed.sh [BUILD_DIR] [OUT_DIR]
set -euo pipefail
build=${1:-build}
out=${2:-/tmp/stemmap-bench-sim}
bin="$build/src/stemmap/cli/stemmap"
mkdir -p "$out"
echo "| clip | kind | seed | frames | wall (s) | s/frame | peak RSS (MiB) |"
echo "|---|---|---|---|---|---|---|"
run() {  # label kind seed args...
  local label=$1 kind=$2 seed=$3; shift 3
  local log="$out/$label-$kind-$seed.time"
  /usr/bin/time -v "$bin" --log-level warn simulate --seed "$seed" --kind "$kind" \
    --out "$out/$label-$kind-$seed" --stills 0 "$@" > /dev/null 2> "$log"
  local wall rss frames
  wall=$(grep "Elapsed (wall clock)" "$log" | awk '{print $NF}' | awk -F: '{ if (NF==3) print $1*3600+$2*60+$3; else print $1*60+$2 }')
  rss=$(grep "Maximum resident" "$log" | awk '{print int($NF/1024)}')
  frames=$(python3 -c "import json;print(json.load(open('$out/$label-$kind-$seed/truth.json'))['frame_count'])")
  echo "| $label | $kind | $seed | $frames | $wall | $(python3 -c "print(f'{$wall/$frames:.3f}')") | $rss |"
}
for kind in managed natural; do
  run 10s-540p "$kind" 1 --width 960 --height 540 --fps 30 --seconds 10
done
if [ "${FULL:-0}" = 1 ]; then
  for kind in managed natural; do run 45s-1080p "$kind" 1 --seconds 45; done
fi
