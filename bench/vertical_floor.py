#!/usr/bin/env python3
"""How close to the true vertical the trunks of a simulated plot can bring "up".

`stemmap track` takes "up" from the trunks' edges (src/stemmap/track/vertical.cc): each edge's
plane through the camera contains the vertical if the trunk stands straight. Trunks lean (0-4° in
the simulator, each its own way), so whatever weights the trunks get, the estimate is off by their
weighted mean lean. This script replays that estimator on the edges a run logged, with the edges
grouped by the truth's trunks instead of the tracker's grouping (an oracle), every trunk within a
range weighted equally, and prints the up error of each beside the error the truth's leans alone
would leave the same estimator (see lean_only): what is left is the trunks' own lean.

Input per plot: DATA/PLOT/truth.json, trajectory_truth.tum, and in TRACK_DIR/PLOT the run's
keyframes.tum and summary.json, with TRACK_DIR/PLOT.segments holding its
`--log-level trace` lines "vertical segment: view K n NX NY NZ origin OX OY dir DX DY".

Usage: bench/vertical_floor.py DATA TRACK_DIR PLOT...   (needs numpy: Debian python3-numpy)
"""
import json
import math
import re
import sys

import numpy as np


def tum(path):
    return np.array([[float(x) for x in line.split()] for line in open(path)
                     if line.strip() and not line.startswith('#')])


def rot(q):  # x y z w
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def chordal_mean(rs):
    u, _, vt = np.linalg.svd(sum(rs))
    m = u @ vt
    return m if np.linalg.det(m) > 0 else u @ np.diag([1, 1, -1]) @ vt


def estimate(normals, weights, inlier_deg=2.0):
    """The tracker's estimator: Tukey-weighted smallest eigenvector of sum w n n^T."""
    up = np.array([0.0, 0.0, 1.0])
    scale = math.sin(math.radians(inlier_deg))
    for _ in range(10):
        r = normals @ up / scale
        w = weights * np.where(np.abs(r) <= 3, (1 - r ** 2 / 9) ** 2, 0.0)
        _, vec = np.linalg.eigh((normals * w[:, None]).T @ normals)
        up = vec[:, 0] if vec[2, 0] > 0 else -vec[:, 0]
    return up


def lean_only(xy, lean, ids):
    """The up error (°) leans alone leave the estimator, trunks weighted equally.

    An edge's plane through the camera holds the trunk's axis, so "up" u = (e, 1) satisfies
    t . e = t . l, with t the horizontal direction across the line of sight and l the trunk's lean
    (small angles): one trunk fixes only the lean across its bearing, and e solves
    (sum t t^T) e = sum t t^T l.
    """
    a, b = np.zeros((2, 2)), np.zeros(2)
    for i in ids:
        t = np.array([-xy[i, 1], xy[i, 0]]) / np.linalg.norm(xy[i])
        a += np.outer(t, t)
        b += t * (t @ lean[i])
    return float(np.linalg.norm(np.linalg.solve(a, b)))


def angle_deg(a, b):
    return math.degrees(math.acos(min(1.0, abs(float(a @ b)))))


def main():
    data, track_dir, plots = sys.argv[1], sys.argv[2], sys.argv[3:]
    seg = re.compile(r'view (\d+) n (\S+) (\S+) (\S+) origin (\S+) (\S+) dir (\S+) (\S+)')
    ranges = (10, 15, 25, 40)
    print('| plot | as tracked (°) | ' + ' | '.join(f'truth trunks ≤ {r} m: up error (°) / from the leans alone (°), trunks'
                                                  for r in ranges) + ' |')
    print('|---|---|' + '---|' * len(ranges))
    for plot in plots:
        rows = [seg.search(line) for line in open(f'{track_dir}/{plot}.segments')]
        rows = np.array([[float(v) for v in m.groups()] for m in rows if m])
        normals, origins, dirs = rows[:, 1:4], rows[:, 4:6], rows[:, 6:8]
        # The true vertical in the run's axis frame: keyframe rotations against the truth's.
        est = tum(f'{track_dir}/{plot}/keyframes.tum')
        truth = tum(f'{data}/{plot}/trajectory_truth.tum')
        fps = json.load(open(f'{data}/{plot}/truth.json'))['fps']
        true_from_est = chordal_mean([rot(truth[int(round(t * fps)), 4:8]) @ rot(q).T
                                      for t, q in zip(est[:, 0], est[:, 4:8])])
        track = json.load(open(f'{track_dir}/{plot}/summary.json'))['track']
        pa = track['plot_from_axis']
        plot_from_axis = rot([pa['qx'], pa['qy'], pa['qz'], pa['qw']])
        up_true = plot_from_axis.T @ true_from_est.T @ np.array([0.0, 0.0, 1.0])
        as_tracked = angle_deg(up_true, plot_from_axis.T @ np.array([0.0, 0.0, 1.0]))
        # Each edge's trunk: the nearest truth stem its horizontal ray passes (plot frame).
        t = json.load(open(f'{data}/{plot}/truth.json'))
        trees = t['trees']
        xy = np.array([[tr['x_m'], tr['y_m']] for tr in trees])
        radius = np.array([tr['dbh_cm'] / 200 for tr in trees])
        dist = np.array([tr['distance_m'] for tr in trees])
        lean = np.array([[tr['lean_deg'] * math.cos(math.radians(tr['lean_azimuth_deg'])),
                          tr['lean_deg'] * math.sin(math.radians(tr['lean_azimuth_deg']))]
                         for tr in trees])
        o_plot = origins @ plot_from_axis[:2, :2].T + np.array(pa['t'][:2])
        d_plot = dirs @ plot_from_axis[:2, :2].T
        d_plot /= np.linalg.norm(d_plot, axis=1)[:, None]
        trunk = -np.ones(len(rows), int)
        for i in range(len(rows)):
            q = xy - o_plot[i]
            along = q @ d_plot[i]
            across = np.abs(q[:, 0] * d_plot[i, 1] - q[:, 1] * d_plot[i, 0])
            hit = np.where((along > 0.3) & (across < radius + 0.08))[0]
            if len(hit):
                trunk[i] = hit[np.argmin(along[hit])]
        cells = [f'{as_tracked:.3f}']
        for r in ranges:
            sel = (trunk >= 0) & (dist[np.maximum(trunk, 0)] <= r)
            _, inv, counts = np.unique(trunk[sel], return_inverse=True, return_counts=True)
            up = estimate(normals[sel], 1.0 / counts[inv])
            cells.append(f'{angle_deg(up_true, up):.3f} / {lean_only(xy, lean, np.unique(trunk[sel])):.3f}'
                         f', {len(counts)}')
        print(f'| {plot} | ' + ' | '.join(cells) + ' |', flush=True)


if __name__ == '__main__':
    main()
