#!/usr/bin/env python3
"""How a run's stem ranges follow its refined focal length.

Usage: bench/range_bias.py PLOT_DIR[:RUN_SUBDIR]...   (RUN_SUBDIR defaults to `run`)

Each PLOT_DIR holds a simulated plot's truth.json; its run's summary.json gives the focal length
the bundle adjustment refined (track.camera.fx) and trees.csv the stems. Truth stems of DBH >= 7
cm within 10 m are matched to the nearest listed stem within 0.3 m. Per run: the truth's and the
refined focal length and their difference (%), the least-squares slope of the stems' relative
range error over their distance (% per m, through the origin), the range errors' RMS and the
mean error across the line of sight (cm).

Why the slope: seen from a camera on an arm of radius R, a stem d out shifts in the picture by
the turn and by its parallax R/d per radian of turn; a focal length short by a share e reads every
shift short by e, which the fit takes as parallax, and the range comes out short by about
e d / R of itself. A slope of -0.1 % per m is 8 cm at 8 m.
"""
import csv
import json
import math
import sys


def run(arg):
    plot, _, sub = arg.partition(':')
    sub = sub or 'run'
    truth = json.load(open(f'{plot}/truth.json'))
    fx_true = truth['intrinsics']['fx']
    fx_run = json.load(open(f'{plot}/{sub}/summary.json'))['track']['camera']['fx']
    stems = [t for t in truth['trees']
             if t['dbh_cm'] >= 7 and math.hypot(t['x_m'], t['y_m']) <= 10]
    listed = [(float(r['x_m']), float(r['y_m'])) for r in csv.DictReader(open(f'{plot}/{sub}/trees.csv'))]
    dist, rel, across = [], [], []
    for t in stems:
        if not listed:
            break
        x, y = min(listed, key=lambda p: math.hypot(p[0] - t['x_m'], p[1] - t['y_m']))
        dx, dy = x - t['x_m'], y - t['y_m']
        if math.hypot(dx, dy) > 0.3:
            continue
        d = math.hypot(t['x_m'], t['y_m'])
        ux, uy = t['x_m'] / d, t['y_m'] / d
        dist.append(d)
        rel.append((dx * ux + dy * uy) / d)
        across.append(-dx * uy + dy * ux)
    if not dist:
        print(f'{plot}:{sub}: no stem matched')
        return
    slope = sum(d * e for d, e in zip(dist, rel)) / sum(d * d for d in dist)
    rms = math.sqrt(sum((e * d) ** 2 for d, e in zip(dist, rel)) / len(dist))
    print(f'| {plot}:{sub} | {fx_true:.2f} | {fx_run:.2f} | {100 * (fx_run / fx_true - 1):+.3f} | '
          f'{len(dist)} | {100 * slope:+.3f} | {100 * rms:.1f} | {100 * sum(across) / len(across):+.1f} |')


print('| run | focal, truth (px) | focal, refined (px) | focal error (%) | stems | range error '
      'slope (% per m) | range error RMS (cm) | mean error across (cm) |')
print('|---|---|---|---|---|---|---|---|')
for a in sys.argv[1:]:
    run(a)
