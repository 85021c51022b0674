#!/usr/bin/env bash
# `stemmap batch --task` under GNU parallel, as docs/batch.md says to run a manifest: every row a
# task, then the summary. The rows here are one finished plot and two whose videos are missing,
# so the test checks the spreading, the resumption and the failure records, not the processing.
set -euo pipefail
stemmap=$1
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
cat > "$dir/plots.csv" <<CSV
plot_id,video,arm_radius_m,hfov_deg,calibration,camera_height_m,plot_centre,first_bearing_deg
done,done.mp4,,,,,42.31 -2.52,10
missing,nowhere.mp4,,,,,,
gone,gone.mp4,,,,,,
CSV
mkdir -p "$dir/out/done"
echo '{"command": "process"}' > "$dir/out/done/stemmap_run.json"
echo '{"plot": {"stems": 1, "stems_per_ha": 31.8, "basal_area_m2_per_ha": 2.0, "qmd_cm": 28.0}}' \
  > "$dir/out/done/summary.json"
printf 'tree_id,x_m,y_m,dbh_cm,dbh_sd_cm,lat,lon\n1,1,2,28.0,0.7,42.31001,-2.52002\n' \
  > "$dir/out/done/trees.csv"
rows=$(($(wc -l < "$dir/plots.csv") - 1))
# A failed plot makes its task exit non-zero; the others go on (--halt never).
parallel --will-cite --halt never -j2 "$stemmap" --log-level error batch "$dir/plots.csv" --out "$dir/out" \
  --task {} ::: $(seq "$rows") > /dev/null 2>&1 || true
"$stemmap" --log-level error batch "$dir/plots.csv" --out "$dir/out" --summary > /dev/null
grep -q '^done,finished,1,31.8,2.000,28.0,' "$dir/out/batch_summary.csv"
grep -q '^missing,failed,' "$dir/out/batch_summary.csv"
grep -q '^gone,failed,' "$dir/out/batch_summary.csv"
test -f "$dir/out/missing.failed.json"
test -f "$dir/out/plots.gpkg"
echo "parallel batch: 3 rows, 1 finished, 2 failed as expected"
