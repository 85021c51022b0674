#!/usr/bin/env python3
"""Tree-by-tree comparison of a `stemmap process` run with a simulated plot's truth.

Usage: bench/stem_detail.py PLOT_DIR [RUN_SUBDIR=process]
Truth trees with DBH >= 10 cm within 10.5 m, matched greedily to PLOT_DIR/RUN_SUBDIR/trees.csv
within 0.5 m (nearest first). Per tree: distance, azimuth, true DBH, caliper width across the line of sight from the centre
(`wide`, what a silhouette shows of an elliptic stem), reported / tangent / slice
DBH (stems_detail.csv), error, position error, lean, axis ratio and flags; then the unmatched
stems within 10 m and MAE, bias and position RMSE within 10 m.
"""
import csv, json, math, sys
plot = sys.argv[1]; sub = sys.argv[2] if len(sys.argv) > 2 else 'process'
t = json.load(open(f'{plot}/truth.json'))
truth = [x for x in t['trees'] if x['dbh_cm'] >= 10 and math.hypot(x['x_m'], x['y_m']) <= 10.5]
pred = list(csv.DictReader(open(f'{plot}/{sub}/trees.csv')))
try:
    det = {r['tree_id']: r for r in csv.DictReader(open(f'{plot}/{sub}/stems_detail.csv'))}
except FileNotFoundError:
    det = {}
pairs = []
for i, x in enumerate(truth):
    for j, p in enumerate(pred):
        d = math.hypot(x['x_m'] - float(p['x_m']), x['y_m'] - float(p['y_m']))
        if d < 0.5: pairs.append((d, i, j))
pairs.sort(); ti, pj, match = set(), set(), {}
for d, i, j in pairs:
    if i in ti or j in pj: continue
    ti.add(i); pj.add(j); match[i] = j
print(f"{'id':>3} {'dist':>5} {'az':>6} {'true':>5} {'wide':>5} {'out':>5} {'tan':>5} {'slc':>5} {'err':>5} {'pos_cm':>6} {'lean':>4} {'ratio':>5}  flags")
errs, poss, werrs = [], [], []
for i, x in sorted(enumerate(truth), key=lambda e: e[1]['distance_m']):
    r = math.hypot(x['x_m'], x['y_m'])
    if i not in match:
        print(f"{x['id']:>3} {r:5.2f} {x['azimuth_deg']:6.1f} {x['dbh_cm']:5.1f}  MISSED"); continue
    p = pred[match[i]]; dd = det.get(p['tree_id'], {})
    e = float(p['dbh_cm']) - x['dbh_cm']; pe = 100 * math.hypot(x['x_m'] - float(p['x_m']), x['y_m'] - float(p['y_m']))
    wide = x.get('width_from_centre_cm', float('nan'))
    if r <= 10 : errs.append(e); poss.append(pe); werrs.append(float(p['dbh_cm']) - wide)
    print(f"{x['id']:>3} {r:5.2f} {x['azimuth_deg']:6.1f} {x['dbh_cm']:5.1f} {wide:5.1f} {float(p['dbh_cm']):5.1f} {float(dd.get('dbh_tangent_cm','nan')):5.1f} {float(dd.get('dbh_slice_cm','nan')):5.1f} {e:+5.1f} {pe:6.1f} {x['lean_deg']:4.1f} {x['minor_cm']/x['major_cm']:5.2f}  {p['flags']}")
for j, p in enumerate(pred):
    r = math.hypot(float(p['x_m']), float(p['y_m']))
    if j not in pj and r <= 10: print(f"FP {r:5.2f} dbh {p['dbh_cm']} flags {p['flags']}")
if errs:
    print(f"MAE {sum(map(abs,errs))/len(errs):.2f} bias {sum(errs)/len(errs):+.2f} posRMSE {math.sqrt(sum(e*e for e in poss)/len(poss)):.1f} cm  n={len(errs)}")
    print(f"against the width seen from the centre: MAE {sum(map(abs,werrs))/len(werrs):.2f} bias {sum(werrs)/len(werrs):+.2f}")
