#!/usr/bin/env bash
# Tree-list benchmark: `stemmap process` on simulated plots (rendered once into DATA and reused),
# scored by `stemmap evaluate` for trees with DBH >= 10 cm within 10 m, for each DBH estimator.
# Usage: bench/plots.sh [BUILD_DIR] [DATA_DIR]
#   SEEDS (or FRESH=N: N seeds from the commit hash), KINDS, HEIGHT_SOURCE, SIM_ARGS as in
#   bench/trajectory.sh.
# One run per plot (timed, its times on the first row); every estimator is scored from that run's
# stems_detail.csv, so all see the same detections and positions.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
source "$here/common.sh"

echo "| plot | estimator | recall | precision | DBH MAE (cm) | RMSE (cm) | bias (cm) | MARE (%) | position RMSE (cm) | wall (s): total / track / dense / stems+tangent | peak RSS (MiB) |"
echo "|---|---|---|---|---|---|---|---|---|---|---|"
for kind in $kinds; do
  for seed in $seeds; do
    prepare_plot "$kind" "$seed" || continue
    out="$plot/process"
    run_stage process "$out" 10 || continue
    # One trees.csv per estimator, from the same detections.
    python3 - "$out" <<'PY'
import csv, sys
out = sys.argv[1]
rows = list(csv.DictReader(open(f"{out}/stems_detail.csv")))
trees = {r["tree_id"]: r for r in csv.DictReader(open(f"{out}/trees.csv"))}
for est in ("tangent", "slice", "circle"):
    with open(f"{out}/trees_{est}.csv", "w") as f:
        f.write("tree_id,x_m,y_m,z_m,dbh_cm,dbh_sd_cm,distance_m,azimuth_deg,n_views,flags\n")
        for r in rows:
            d = float(r[f"dbh_{est}_cm"])
            if d <= 0:  # no tangent fit for this stem: its reported value stands in
                d = float(trees[r["tree_id"]]["dbh_cm"])
            t = trees[r["tree_id"]]
            f.write(f"{r['tree_id']},{t['x_m']},{t['y_m']},{t['z_m']},{d},0,{t['distance_m']},"
                    f"{t['azimuth_deg']},{t['n_views']},{t['flags']}\n")
PY
    for est in slice tangent circle; do
      "$bin" --log-level warn evaluate --truth "$plot/truth.json" --pred "$out/trees_$est.csv" \
        --min-dbh 10 --plot-radius 10 --out "$out/eval_$est" > /dev/null
      python3 - "$kind-$seed" "$est" "$wall" "$rss" "$out" <<'PY'
import json, sys
name, est, wall, rss, out = sys.argv[1:]
e = json.load(open(f"{out}/eval_{est}/evaluation.json"))["raw"]
s = json.load(open(f"{out}/summary.json"))["timing_s"]
d = e["dbh"]
timing = (f"{float(wall):.1f} / {s['track_s']:.1f} / {s['dense_s']:.1f} / "
          f"{s['stems_s']:.1f}") if est == "slice" else ""
print(f"| {name} | {est} | {e['recall']:.3f} | {e['precision']:.3f} | {d['mae_cm']:.2f} | "
      f"{d['rmse_cm']:.2f} | {d['bias_cm']:+.2f} | {d['mare_pct']:.2f} | "
      f"{100 * e['position_rmse_m']:.1f} | {timing} | {rss if est == 'slice' else ''} |")
PY
    done
  done
done
