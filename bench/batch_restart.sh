#!/usr/bin/env bash
# A 10-plot batch killed halfway and started again, against the same batch run through: the
# restart must redo no finished plot and end with the same summary table. Small, short captures
# (480x270, 14 s) keep it to minutes; the point is the batch, not the tree lists.
# Usage: bench/batch_restart.sh [BUILD_DIR] [DATA_DIR]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
bin="${1:-build}/src/stemmap/cli/stemmap"
data=${2:-/tmp/stemmap-batch}
mkdir -p "$data/plots"
manifest="$data/plots.csv"
echo "plot_id,video,arm_radius_m,hfov_deg,calibration,camera_height_m,plot_centre,first_bearing_deg" > "$manifest"
for i in $(seq 10); do
  p="$data/plots/p$i"
  if [ ! -f "$p/video.mp4" ]; then
    "$bin" --log-level warn simulate --seed $((900 + i)) --kind managed --width 480 --height 270 \
      --fps 15 --seconds 14 --turns 1.1 --stills 0 --out "$p" > /dev/null 2>&1
    python3 "$here/truth_calibration.py" "$p/truth.json" "$p/calibration.yaml"
  fi
  height=$(python3 -c "import json;print(json.load(open('$p/truth.json'))['camera_height_m'])")
  echo "p$i,plots/p$i/video.mp4,1.0,,plots/p$i/calibration.yaml,$height,42.3 $(python3 -c "print(-2.5 + $i * 0.01)"),0" >> "$manifest"
done

# Killed once half the plots are finished, then started again.
rm -rf "$data/killed" "$data/through"
"$bin" --log-level warn batch "$manifest" --out "$data/killed" > "$data/killed.log" 2>&1 &
pid=$!
while [ "$(ls "$data"/killed/*/stemmap_run.json 2> /dev/null | wc -l)" -lt 5 ]; do sleep 1; done
kill -TERM "$pid"
wait "$pid" || true
before=$(ls "$data"/killed/*/stemmap_run.json | wc -l)
"$bin" --log-level warn batch "$manifest" --out "$data/killed" > "$data/restart.log" 2>&1
now=$(grep -o '([0-9]* now)' "$data/restart.log" | tr -dc 0-9)
# The same batch run through.
"$bin" --log-level warn batch "$manifest" --out "$data/through" > "$data/through.log" 2>&1
same=no
cmp -s "$data/killed/batch_summary.csv" "$data/through/batch_summary.csv" && same=yes
echo "| plots | finished when killed | run again after the restart | redone | summary table identical |"
echo "|---|---|---|---|---|"
echo "| 10 | $before | $now | $((before + now - 10 > 0 ? before + now - 10 : 0)) | $same |"
