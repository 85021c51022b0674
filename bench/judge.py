#!/usr/bin/env python3
"""Judges stemmap's tree lists on simulated plots against the numbers of issue-level targets.

Usage: bench/judge.py DATA_DIR [--run process] [--plots managed-1 ...]
For each plot DATA/<kind>-<seed> with RUN/trees.csv and RUN/summary.json (as bench/plots.sh
leaves them; `stemmap stems --from` can write another RUN from the same cloud), runs
`stemmap evaluate` on the reported list (DBH >= 10 cm within 10 m) and pools, per kind and over
all plots:
- recall, precision, DBH MAE / MARE, position RMSE;
- recall on the stems at least half of whose breast-height section some frame shows (nearer stems
  and saplings cut it; bench/stem_visibility.py), and on the rest;
- the share of DBH errors within +-2 dbh_sd_cm (overall and by flag), and of listed stems that are
  stems at each confidence;
- how often the truth's stems/ha, basal area/ha and QMD (DBH >= min_dbh, within the plot radius)
  fall inside the reported 95 % intervals;
- the local ground under each matched stem against the truth's (rms, and the share within 5 cm).
"""
import argparse, csv, json, math, os, subprocess, sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from stem_visibility import extent, quat_forward_xy, uncovered_share  # noqa: E402


def best_visible_share(t, tree, step=3):
    half_fov = math.radians(t["intrinsics"]["hfov_deg"]) / 2
    stems = [(s["id"], (s["x_m"], s["y_m"]), s["dbh_cm"] / 200.0) for s in t["trees"]]
    saplings = t["saplings"] if isinstance(t["saplings"], list) else []
    blockers = stems + [(-s["id"], (s["x_m"], s["y_m"]), s["dbh_cm"] / 200.0) for s in saplings]
    c, r = (tree["x_m"], tree["y_m"]), tree["dbh_cm"] / 200.0
    best = 0.0
    for f in t["poses"][::step]:
        cam = f["t_xyz"][:2]
        iv, d = extent(cam, c, r)
        if iv is None:
            continue
        off = abs(math.remainder((iv[0] + iv[1]) / 2 - quat_forward_xy(f["q_xyzw"]), 2 * math.pi))
        if off + (iv[1] - iv[0]) / 2 > half_fov:
            continue
        covers = []
        for bid, bc, br in blockers:
            if bid == tree["id"]:
                continue
            biv, bd = extent(cam, bc, br)
            if biv is not None and bd < d:
                covers.append(biv)
        best = max(best, uncovered_share(iv, covers))
    return best


def stem_ground_errors(truth, pairs, pred, run):
    """The local ground under each matched stem less the truth's (m): both lists give the
    breast-height point, whose height less the breast height is the ground. `pairs`: evaluate's
    matched pairs; `pred`: the run's trees.csv rows by tree_id; `run`: its folder."""
    opts_path = f"{run}/process_options.json"
    breast_m = (json.load(open(opts_path))["measure"]["stems"]["breast_height_m"]
                if os.path.exists(opts_path) else 1.37)
    truth_by_id = {x["id"]: x for x in truth["trees"]}
    return [float(pred[p["predicted_id"]]["z_m"]) - breast_m -
            (truth_by_id[p["truth_id"]]["z_m"] - truth["breast_height_m"]) for p in pairs]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("data")
    ap.add_argument("--run", default="process")
    ap.add_argument("--plots", nargs="*")
    ap.add_argument("--bin", default="build/src/stemmap/cli/stemmap")
    a = ap.parse_args()
    plots = a.plots or sorted(p for p in os.listdir(a.data)
                              if os.path.exists(os.path.join(a.data, p, a.run, "trees.csv")))
    pooled = {}
    for plot in plots:
        kind = plot.rsplit("-", 1)[0]
        d = os.path.join(a.data, plot)
        run = os.path.join(d, a.run)
        subprocess.run([a.bin, "--log-level", "warn", "evaluate", "--truth", f"{d}/truth.json",
                        "--pred", f"{run}/trees.csv", "--min-dbh", "10", "--plot-radius", "10",
                        "--out", f"{run}/eval_reported"], check=True, stdout=subprocess.DEVNULL)
        e = json.load(open(f"{run}/eval_reported/evaluation.json"))["raw"]
        t = json.load(open(f"{d}/truth.json"))
        pred = {int(r["tree_id"]): r for r in csv.DictReader(open(f"{run}/trees.csv"))}
        plot_summary = json.load(open(f"{run}/summary.json"))["plot"]
        ground = stem_ground_errors(t, e["pairs"], pred, run)
        matched_truth = {p["truth_id"] for p in e["pairs"]}
        for k in (kind, "all"):
            s = pooled.setdefault(k, {"plots": 0, "truth": 0, "pred": 0, "pairs": [], "half": [0, 0],
                                      "less": [0, 0], "conf": {}, "figs": [0, 0, 0]})
            s["plots"] += 1
            s["truth"] += e["n_truth"]
            s["pred"] += e["n_predicted"]
            for p in e["pairs"]:
                s["pairs"].append((p, pred[p["predicted_id"]]))
            s.setdefault("ground", []).extend(ground)
            for tree in t["trees"]:
                if tree["dbh_cm"] < 10 or math.hypot(tree["x_m"], tree["y_m"]) > 10:
                    continue
                group = "half" if best_visible_share(t, tree) >= 0.5 else "less"
                s[group][0] += 1
                s[group][1] += tree["id"] in matched_truth
            matched_pred = {p["predicted_id"] for p in e["pairs"]}
            for pid, r in pred.items():
                if float(r["distance_m"]) > 10 or float(r["dbh_cm"]) < 10:
                    continue
                c = s["conf"].setdefault(r["confidence"], [0, 0])
                c[0] += 1
                c[1] += pid in matched_pred
            # The truth's figures against the reported intervals.
            radius, min_dbh = plot_summary["radius_m"], plot_summary["min_dbh_cm"]
            true = [x["dbh_cm"] for x in t["trees"]
                    if x["dbh_cm"] >= min_dbh and math.hypot(x["x_m"], x["y_m"]) <= radius]
            area_ha = math.pi * radius ** 2 / 1e4
            figs = (len(true) / area_ha, sum(math.pi * (x / 200) ** 2 for x in true) / area_ha,
                    math.sqrt(sum(x * x for x in true) / len(true)) if true else 0.0)
            for i, key in enumerate(("stems_per_ha_95", "basal_area_m2_per_ha_95", "qmd_cm_95")):
                lo, hi = plot_summary[key]
                s["figs"][i] += lo <= figs[i] <= hi
    print("| kind | plots | recall | recall, half visible | recall, less | precision | DBH MAE (cm) | MARE (%) | position RMSE (cm) | ±2 SD coverage | truth in 95 % interval: stems/ha, BA, QMD | stem ground error: rms (cm), within 5 cm |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for k in sorted(pooled, key=lambda k: (k == "all", k)):
        s = pooled[k]
        pairs = s["pairs"]
        err = [float(r["dbh_cm"]) - p["truth_dbh_cm"] for p, r in pairs]
        within = sum(abs(x) <= 2 * float(r["dbh_sd_cm"]) for x, (p, r) in zip(err, pairs))
        mae = sum(map(abs, err)) / len(err) if err else 0
        mare = 100 * sum(abs(x) / p["truth_dbh_cm"] for x, (p, r) in zip(err, pairs)) / max(1, len(err))
        pos = 100 * math.sqrt(sum(p["position_error_m"] ** 2 for p, r in pairs) / max(1, len(pairs)))
        h, l = s["half"], s["less"]
        g = s.get("ground", [])
        ground_rms_cm = 100 * math.sqrt(sum(x * x for x in g) / max(1, len(g)))
        ground_within = sum(abs(x) <= 0.05 for x in g) / max(1, len(g))
        print(f"| {k} | {s['plots']} | {len(pairs) / s['truth']:.3f} ({len(pairs)}/{s['truth']}) | "
              f"{h[1] / max(1, h[0]):.3f} ({h[1]}/{h[0]}) | {l[1] / max(1, l[0]):.3f} ({l[1]}/{l[0]}) | "
              f"{len(pairs) / max(1, s['pred']):.3f} | {mae:.2f} | {mare:.2f} | {pos:.1f} | "
              f"{within / max(1, len(pairs)):.2f} ({within}/{len(pairs)}) | "
              f"{s['figs'][0]}, {s['figs'][1]}, {s['figs'][2]} of {s['plots']} | "
              f"{ground_rms_cm:.1f}, {ground_within:.2f} |")
    s = pooled.get("all")
    if not s:
        return
    print("\n| flag | stems | ±2 SD coverage | MAE (cm) |")
    print("|---|---|---|---|")
    groups = {}
    for p, r in s["pairs"]:
        for f in (r["flags"].split(";") if r["flags"] else ["(none)"]):
            groups.setdefault(f, []).append((float(r["dbh_cm"]) - p["truth_dbh_cm"], float(r["dbh_sd_cm"])))
    for f, v in sorted(groups.items()):
        cov = sum(abs(x) <= 2 * sd for x, sd in v) / len(v)
        print(f"| {f} | {len(v)} | {cov:.2f} | {sum(abs(x) for x, _ in v) / len(v):.2f} |")
    print("\n| confidence | listed (≥ 10 cm, ≤ 10 m) | of which stems |")
    print("|---|---|---|")
    for c, (n, ok) in sorted(s["conf"].items()):
        print(f"| {c} | {n} | {ok / n:.2f} |")


if __name__ == "__main__":
    main()
