#!/usr/bin/env python3
"""How much of each truth stem the camera ever sees at breast height, from the truth alone.

For every frame (every `--step`-th) the stem's horizontal angular extent at breast height, seen
from the camera centre, is cut by the extents of the nearer stems and saplings; what is left,
as a share of the stem's width, is its visible share in that frame (0 outside the horizontal
field of view). A stem that no frame shows whole can only be found from a sliver.

Usage: bench/stem_visibility.py DATA [--plots managed-1 ...] [--min-dbh 10] [--radius 10]
Prints a Markdown table of the stems (DBH >= min, within radius) whose best share is under
`--whole` (0.9), with the frames (every step-th) that have them in view, and that show at
least half of them and at least 0.9 of them.
"""
import argparse
import json
import math
import os


def extent(cam_xy, centre_xy, radius_m):
    """Bearing interval (lo, hi) of a circle seen from cam_xy, or None if the camera is inside."""
    dx, dy = centre_xy[0] - cam_xy[0], centre_xy[1] - cam_xy[1]
    d = math.hypot(dx, dy)
    if d <= radius_m:
        return None, d
    half = math.asin(radius_m / d)
    b = math.atan2(dy, dx)
    return (b - half, b + half), d


def uncovered_share(interval, covers):
    lo, hi = interval
    pieces = [(lo, hi)]
    for c_lo, c_hi in covers:
        # Bring the cover next to the interval (bearings wrap).
        shift = round(((lo + hi) - (c_lo + c_hi)) / 2 / (2 * math.pi)) * 2 * math.pi
        c_lo, c_hi = c_lo + shift, c_hi + shift
        nxt = []
        for a, b in pieces:
            if c_hi <= a or c_lo >= b:
                nxt.append((a, b))
                continue
            if c_lo > a:
                nxt.append((a, c_lo))
            if c_hi < b:
                nxt.append((c_hi, b))
        pieces = nxt
    return sum(b - a for a, b in pieces) / (hi - lo)


def quat_forward_xy(q_xyzw):
    """Horizontal direction of the camera's z axis (OpenCV) in the world."""
    x, y, z, w = q_xyzw
    # Third column of the rotation matrix.
    fx = 2 * (x * z + w * y)
    fy = 2 * (y * z - w * x)
    return math.atan2(fy, fx)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("data")
    ap.add_argument("--plots", nargs="*")
    ap.add_argument("--min-dbh", type=float, default=10.0)
    ap.add_argument("--radius", type=float, default=10.0)
    ap.add_argument("--step", type=int, default=3)
    ap.add_argument("--whole", type=float, default=0.9)
    a = ap.parse_args()
    plots = a.plots or sorted(p for p in os.listdir(a.data)
                              if os.path.exists(os.path.join(a.data, p, "truth.json")))
    print("| plot | tree | DBH (cm) | distance (m) | best visible share | frames in view | with >= half | with >= 0.9 |")
    print("|---|---|---|---|---|---|---|---|")
    for plot in plots:
        t = json.load(open(os.path.join(a.data, plot, "truth.json")))
        half_fov = math.radians(t["intrinsics"]["hfov_deg"]) / 2
        stems = [(s["id"], (s["x_m"], s["y_m"]), s["dbh_cm"] / 200.0) for s in t["trees"]]
        saplings = t["saplings"] if isinstance(t["saplings"], list) else []
        blockers = stems + [(-s["id"], (s["x_m"], s["y_m"]), s["dbh_cm"] / 200.0) for s in saplings]
        frames = t["poses"][:: a.step]
        for sid, c, r in stems:
            tree = next(s for s in t["trees"] if s["id"] == sid)
            if tree["dbh_cm"] < a.min_dbh or math.hypot(*c) > a.radius:
                continue
            best, half_frames, whole_frames, in_view = 0.0, 0, 0, 0
            for f in frames:
                cam = f["t_xyz"][:2]
                iv, d = extent(cam, c, r)
                if iv is None:
                    continue
                heading = quat_forward_xy(f["q_xyzw"])
                off = abs(math.remainder((iv[0] + iv[1]) / 2 - heading, 2 * math.pi))
                if off + (iv[1] - iv[0]) / 2 > half_fov:
                    continue
                covers = []
                for bid, bc, br in blockers:
                    if bid == sid:
                        continue
                    biv, bd = extent(cam, bc, br)
                    if biv is not None and bd < d:
                        covers.append(biv)
                share = uncovered_share(iv, covers)
                in_view += 1
                whole_frames += share >= 0.9
                best = max(best, share)
                half_frames += share >= 0.5
            if best < a.whole:
                print(f"| {plot} | {sid} | {tree['dbh_cm']:.1f} | {math.hypot(*c):.2f} | "
                      f"{best:.2f} | {in_view} | {half_frames} | {whole_frames} |")


if __name__ == "__main__":
    main()
