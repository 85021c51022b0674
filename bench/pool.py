#!/usr/bin/env python3
"""Pools `stemmap evaluate` results over plots, by stand kind.

Usage: bench/pool.py DATA_DIR [ESTIMATOR=tangent]
Reads DATA_DIR/<kind>-<seed>/process/eval_<ESTIMATOR>/evaluation.json (as bench/plots.sh writes
them) and prints, per kind, recall, precision, DBH MAE, median |error|, RMSE, bias and MARE, and
position RMSE and median over every hit of every plot together.
"""
import glob, json, math, os, statistics, sys

data = sys.argv[1]
est = sys.argv[2] if len(sys.argv) > 2 else "tangent"
kinds = {}
for path in sorted(glob.glob(f"{data}/*-*/process/eval_{est}/evaluation.json")):
    plot = os.path.basename(os.path.dirname(os.path.dirname(os.path.dirname(path))))
    kinds.setdefault(plot.rsplit("-", 1)[0], []).append((plot, json.load(open(path))["raw"]))
print("| kind | plots | recall | precision | DBH MAE (cm) | median (cm) | RMSE (cm) | bias (cm) "
      "| MARE (%) | position RMSE / median (cm) |")
print("|---|---|---|---|---|---|---|---|---|---|")
for kind, runs in sorted(kinds.items()):
    pairs = [p for _, r in runs for p in r["pairs"]]
    n_truth = sum(r["n_truth"] for _, r in runs)
    n_pred = sum(r["n_predicted"] for _, r in runs)
    if not pairs:
        print(f"| {kind} | {len(runs)} | 0/{n_truth} | | | | | | | |")
        continue
    err = [p["predicted_dbh_cm"] - p["truth_dbh_cm"] for p in pairs]
    rel = [abs(e) / p["truth_dbh_cm"] for e, p in zip(err, pairs)]
    pos = [100 * p["position_error_m"] for p in pairs]
    print(f"| {kind} | {len(runs)} | {len(pairs) / n_truth:.3f} ({len(pairs)}/{n_truth}) | "
          f"{len(pairs) / n_pred:.3f} | {sum(map(abs, err)) / len(err):.2f} | "
          f"{statistics.median(map(abs, err)):.2f} | "
          f"{math.sqrt(sum(e * e for e in err) / len(err)):.2f} | {sum(err) / len(err):+.2f} | "
          f"{100 * sum(rel) / len(rel):.2f} | "
          f"{math.sqrt(sum(p * p for p in pos) / len(pos)):.1f} / {statistics.median(pos):.1f} |")
