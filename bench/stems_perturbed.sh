#!/usr/bin/env bash
# How stable the tree list is: reruns `stemmap process --from-track` on each plot's earlier
# `bench/plots.sh` run with its keyframe poses moved by small seeded noise (default 0.5 mm and
# 0.005° per axis, a tenth of the trajectory's own error), and pools the tree-list figures per
# kind for every draw. A figure that moves much between draws rests on stems whose outcome turns
# on such differences.
# Usage: bench/stems_perturbed.sh [BUILD_DIR] [DATA_DIR]
#   SEEDS, KINDS as in bench/plots.sh; DRAWS (default "1 2 3"), POS_M, ROT_DEG.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
source "$here/common.sh"
draws=${DRAWS:-1 2 3}
pos_m=${POS_M:-0.0005}
rot_deg=${ROT_DEG:-0.005}

for draw in $draws; do
  for kind in $kinds; do
    for seed in $seeds; do
      plot="$data/$kind-$seed"
      if [ ! -f "$plot/process/keyframes.tum" ]; then
        echo "no bench/plots.sh run in $plot/process" >&2
        continue
      fi
      track="$plot/perturbed_track_$draw"
      mkdir -p "$track"
      cp "$plot/process/summary.json" "$track/summary.json"
      python3 - "$plot/process/keyframes.tum" "$track/keyframes.tum" "$draw" "$pos_m" "$rot_deg" <<'PY'
import math, random, sys
src, dst, draw, pos_m, rot_deg = sys.argv[1], sys.argv[2], int(sys.argv[3]), float(sys.argv[4]), float(sys.argv[5])
rng = random.Random(draw)
def qmul(a, b):  # (x, y, z, w)
    ax, ay, az, aw = a; bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz)
with open(dst, "w") as f:
    f.write("# t tx ty tz qx qy qz qw (world_from_camera, OpenCV camera axes)\n")
    for line in open(src):
        if line.startswith("#") or not line.strip():
            continue
        v = [float(x) for x in line.split()]
        t = [v[1 + i] + rng.gauss(0, pos_m) for i in range(3)]
        w = [math.radians(rng.gauss(0, rot_deg)) for _ in range(3)]
        a = math.sqrt(sum(x * x for x in w))
        s = math.sin(a / 2) / a if a > 0 else 0.5
        q = qmul((w[0] * s, w[1] * s, w[2] * s, math.cos(a / 2)), tuple(v[4:8]))
        f.write(f"{v[0]:.6f} " + " ".join(f"{x:.10f}" for x in t + list(q)) + "\n")
PY
      out="$data/perturbed_$draw/$kind-$seed/process"
      rm -rf "$out"
      mkdir -p "$out"
      "$bin" --log-level warn process "$plot/video.mp4" --from-track "$track" --out "$out" \
        --no-report > /dev/null 2> "$out.log" || { echo "failed: $kind-$seed draw $draw" >&2; continue; }
      "$bin" --log-level warn evaluate --truth "$plot/truth.json" --pred "$out/trees.csv" \
        --min-dbh 10 --plot-radius 10 --out "$out/eval_tangent" > /dev/null
    done
  done
  echo "Draw $draw (keyframes moved by N(0, $pos_m m), N(0, $rot_deg°) per axis):"
  echo
  python3 "$here/pool.py" "$data/perturbed_$draw"
  echo
done
