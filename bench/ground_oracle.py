#!/usr/bin/env python3
"""How well the ground under the tripod can be known from what the camera sees.

Usage: bench/ground_oracle.py DATA_DIR [DATA_DIR ...] [--run process]

The camera faces outward at breast height and sees no ground within about 4 m of the tripod.
For each simulated plot DATA/<kind>-<seed> (truth.json, and RUN/summary.json from `stemmap
process`), prints the camera height error three ways:
- oracle: a plane through the true ground at every stem and sapling 4-12 m out (the ground the
  camera does see, without error), extrapolated to the tripod: the error of any estimate that
  takes the unseen ground under the tripod to continue the ground around it;
- sparse: the track's estimate (the plot frame's ground from the sparse points);
- cloud: the ground grid's, from the dense cloud (summary.json stems.camera_height_m).
A run made with --camera-height still reports both estimates (track.camera_height_estimated_m).
Then, per kind, how many plots lie within 5 cm each way and the rms.
"""
import argparse, glob, json, math, os


def plane_at_origin(points):
    """z at (0, 0) of the least-squares plane z = a x + b y + c through `points`."""
    a = [[0.0] * 3 for _ in range(3)]
    b = [0.0] * 3
    for x, y, z in points:
        v = (x, y, 1.0)
        for i in range(3):
            b[i] += v[i] * z
            for j in range(3):
                a[i][j] += v[i] * v[j]
    m = [a[i] + [b[i]] for i in range(3)]
    for i in range(3):
        p = max(range(i, 3), key=lambda k: abs(m[k][i]))
        m[i], m[p] = m[p], m[i]
        for k in range(3):
            if k != i:
                f = m[k][i] / m[i][i]
                for j in range(4):
                    m[k][j] -= f * m[i][j]
    return m[2][3] / m[2][2]


def ground_points(truth, r_min=4.0, r_max=12.0):
    """(x, y, ground z) at the stems and saplings between r_min and r_max from the tripod."""
    bh = truth["breast_height_m"]
    out = []
    for key in ("trees", "saplings"):
        for s in truth.get(key) or []:
            if isinstance(s, dict) and r_min <= math.hypot(s["x_m"], s["y_m"]) <= r_max:
                out.append((s["x_m"], s["y_m"], s["z_m"] - bh))
    return out


def estimates_cm(summary, truth_height_m):
    track = summary.get("track", {})
    if track.get("camera_height_source") == "measured":
        sparse = track.get("camera_height_estimated_m")
    else:
        sparse = track.get("camera_height_m")
    cloud = summary.get("stems", {}).get("camera_height_m")
    err = lambda v: float("nan") if v is None else 100.0 * (v - truth_height_m)
    return err(sparse), err(cloud)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("data", nargs="+")
    ap.add_argument("--run", default="process")
    a = ap.parse_args()
    rows = []
    for data in a.data:
        for plot in sorted(glob.glob(os.path.join(data, "*-*"))):
            summary_path = os.path.join(plot, a.run, "summary.json")
            truth_path = os.path.join(plot, "truth.json")
            if not (os.path.isfile(summary_path) and os.path.isfile(truth_path)):
                continue
            truth = json.load(open(truth_path))
            points = ground_points(truth)
            if len(points) < 4:
                continue
            oracle = -100.0 * plane_at_origin(points)  # the true ground at the tripod is z = 0
            sparse, cloud = estimates_cm(json.load(open(summary_path)), truth["camera_height_m"])
            rows.append((os.path.basename(plot), len(points), oracle, sparse, cloud))
    print("| plot | ground points 4-12 m | camera height error (cm): oracle plane | sparse | cloud |")
    print("|---|---|---|---|---|")
    for r in rows:
        print("| %s | %d | %+.1f | %+.1f | %+.1f |" % r)
    print()
    print("| kind | plots | within 5 cm: oracle / sparse / cloud | rms (cm): oracle / sparse / cloud |")
    print("|---|---|---|---|")
    for kind in ("managed", "natural"):
        sel = [r for r in rows if r[0].startswith(kind)]
        if not sel:
            continue
        within = [sum(abs(r[i]) <= 5.0 for r in sel) for i in (2, 3, 4)]
        rms = [math.sqrt(sum(r[i] ** 2 for r in sel) / len(sel)) for i in (2, 3, 4)]
        print("| %s | %d | %d / %d / %d | %.1f / %.1f / %.1f |" % (kind, len(sel), *within, *rms))


if __name__ == "__main__":
    main()
