#!/usr/bin/env python3
"""Silhouette edges found by the tangent-ray fit against the truth's, view by view.

Usage:
  stemmap --log-level trace process PLOT/video.mp4 ... --out OUT 2> LOG
  bench/silhouette_edges.py PLOT_DIR LOG

Each `tangent edge:` trace line is one silhouette (image column at breast height) of one view in
one round of the fit. For every fit start (stem start and starting radius) its last round is
compared with the truth tree nearest the start (within 0.5 m, DBH >= 10 cm): the tree's section,
taken as a circle of the width seen from the plot centre, is projected with the true pose of the
keyframe's frame. Errors are in pixels of the frames the fit used (the video's own resolution
when the front end kept it), positive to the right: a left edge (side 0) with a positive error
and a right edge (side 1) with a negative one sit inside the stem.
"""
import json, math, re, sys

plot, log = sys.argv[1], sys.argv[2]
truth = json.load(open(f'{plot}/truth.json'))
K = truth['intrinsics']
fps = truth['fps']
poses = [list(map(float, l.split())) for l in open(f'{plot}/trajectory_truth.tum')
         if not l.startswith('#')]


def rotation(q):
    x, y, z, w = q
    return [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]


def true_edges(tree, frame):
    """Image columns of the left and right silhouettes of `tree` in `frame` (no distortion)."""
    p = poses[min(frame, len(poses) - 1)]
    c = p[1:4]
    world_from_cam = rotation(p[4:8])

    def column(point):
        d = [point[i] - c[i] for i in range(3)]
        cam = [sum(world_from_cam[i][j] * d[i] for i in range(3)) for j in range(3)]
        return K['fx'] * cam[0] / cam[2] + K['cx']

    x, y, z = tree['x_m'], tree['y_m'], tree['z_m']
    dist = math.hypot(x - c[0], y - c[1])
    r = tree.get('width_from_centre_cm', tree['dbh_cm']) / 200
    alpha = math.asin(min(1.0, r / dist))
    bearing = math.atan2(y - c[1], x - c[0])
    cols = []
    for s in (1, -1):
        phi = bearing + math.pi + s * (math.pi / 2 - alpha)
        cols.append(column((x + r * math.cos(phi), y + r * math.sin(phi), z)))
    return min(cols), max(cols)


pattern = re.compile(r'tangent edge: start \((\S+), (\S+)\) r_start (\S+) round (\d+) '
                     r'keyframe (\d+) t (\S+) side (\d) x (\S+)')
fits = {}
for line in open(log):
    m = pattern.search(line)
    if not m:
        continue
    key = (float(m[1]), float(m[2]), float(m[3]))
    views = fits.setdefault(key, {}).setdefault(int(m[4]), {})
    views.setdefault(int(m[5]), [float(m[6]), None, None])[1 + int(m[7])] = float(m[8])

trees = [t for t in truth['trees'] if t['dbh_cm'] >= 10]
median = lambda v: sorted(v)[len(v) // 2] if v else float('nan')
print(f"{'tree':>4} {'dist':>5} {'az':>6} {'r_start':>7}  {'left err':>8} {'n':>3}  "
      f"{'right err':>9} {'n':>3}   (px; inside: left > 0, right < 0)")
all_left, all_right = [], []
for (sx, sy, r_start), rounds in sorted(fits.items(), key=lambda f: math.hypot(f[0][0], f[0][1])):
    tree = min(trees, key=lambda t: math.hypot(t['x_m'] - sx, t['y_m'] - sy))
    if math.hypot(tree['x_m'] - sx, tree['y_m'] - sy) > 0.5:
        continue
    left, right = [], []
    for t_s, x_left, x_right in rounds[max(rounds)].values():
        tl, tr = true_edges(tree, round(t_s * fps))
        if x_left is not None:
            left.append(x_left - tl)
        if x_right is not None:
            right.append(x_right - tr)
    all_left += left
    all_right += right
    print(f"{tree['id']:>4} {math.hypot(tree['x_m'], tree['y_m']):5.2f} "
          f"{tree['azimuth_deg']:6.1f} {r_start:7.3f}  {median(left):+8.1f} {len(left):>3}  "
          f"{median(right):+9.1f} {len(right):>3}")
print(f"all: left median {median(all_left):+.1f} px (n {len(all_left)}), "
      f"right median {median(all_right):+.1f} px (n {len(all_right)})")
