#!/usr/bin/env bash
# Trajectory benchmark: `stemmap track` on simulated 1080p 30 fps plots (rendered once into DATA
# and reused), scored by `stemmap evaluate` against the simulator's truth.
# Usage: bench/trajectory.sh [BUILD_DIR] [DATA_DIR]
#   SEEDS="1 2 3 4 5" KINDS="managed natural"  which plots
#   HEIGHT_SOURCE=measured|estimated           camera height: from the truth, as a forester measures
#                                              it at the tripod, or estimated from the ground in view
#   SIM_ARGS="..."                             extra simulate flags (e.g. a smaller size for a dry run)
# Prints one Markdown row per plot; the camera comes from the truth's intrinsics, written as the
# calibration file a user would make with a checkerboard.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
source "$here/common.sh"
printf 'tree_id,x_m,y_m,z_m,dbh_cm,dbh_sd_cm,distance_m,azimuth_deg,n_views,flags\n' > "$data/no_trees.csv"

echo "| plot | frames | track wall (s) | decode+KLT / loop / BA (s) | peak RSS (MiB) | ATE (cm) | scale (%) | rot mean / max (°) | heading offset / up error (°) | loop before → after (°) | tilt est (°) | height (m) |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|"
for kind in $kinds; do
  for seed in $seeds; do
    prepare_plot "$kind" "$seed" || continue
    out="$plot/track"
    run_stage track "$out" 9 || continue
    "$bin" --log-level warn evaluate --truth "$plot/truth.json" --pred "$data/no_trees.csv" \
      --trajectory "$out/trajectory.tum" --out "$out/eval" > /dev/null
    python3 - "$kind-$seed" "$wall" "$rss" "$out" "$plot/truth.json" <<'PY'
import json, sys
name, wall, rss, out, truth = sys.argv[1:]
s = json.load(open(f"{out}/summary.json"))["track"]
e = json.load(open(f"{out}/eval/evaluation.json"))["trajectory"]
t = s["timing_s"]
tilt_true = json.load(open(truth))["rig"]["stand_tilt_deg"]
print(f"| {name} | {s['video']['frames']} | {float(wall):.1f} | "
      f"{t['decode_and_klt_s']:.1f} / {t['loop_detection_s']:.1f} / {t['bundle_adjustment_s']:.1f} | "
      f"{rss} | {100 * e['ate_rmse_m']:.2f} | {e['scale_error_pct']:+.3f} | "
      f"{e['mean_rotation_error_deg']:.3f} / {e['max_rotation_error_deg']:.3f} | "
      f"{e['heading_offset_deg']:+.2f} / {e['mean_up_error_deg']:.2f} | "
      f"{s['loop_error_before_deg']:.2f} → {s['loop_error_after_deg']:.3f} | "
      f"{s['stand_tilt_deg']:.2f} (true {tilt_true:.2f}) | {s['camera_height_m']:.3f} ({s['camera_height_source']}) |")
PY
  done
done
