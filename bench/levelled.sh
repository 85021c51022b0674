#!/usr/bin/env bash
# A levelled tripod against the trunks' vertical, on the same videos: each plot is rendered with
# its tripod levelled (`simulate --stand-tilt`, default 0.1°, a bubble's accuracy) and processed
# twice with the tape's camera height, `--vertical trunks` (the default) and `--vertical axis`.
# Reports per plot and pooled the camera-up error (`evaluate`'s mean over frames), the local
# ground under each matched stem against the truth's (rms, share within 5 cm; as bench/judge.py
# scores it), recall and DBH MAE (DBH >= 10 cm within 10 m).
# Usage: bench/levelled.sh [BUILD_DIR] [DATA_DIR]
#   SEEDS or FRESH=N and KINDS as in bench/plots.sh; STAND_TILT (degrees, default 0.1).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
SIM_ARGS="${SIM_ARGS:---fps 15} --stand-tilt ${STAND_TILT:-0.1}"
source "$here/common.sh"

rows="$data/levelled_rows.txt"
: > "$rows"
for kind in $kinds; do
  for seed in $seeds; do
    prepare_plot "$kind" "$seed" || continue
    for vertical in trunks axis; do
      out="$plot/$vertical"
      if [ ! -f "$out/trees.csv" ]; then
        "$bin" --log-level warn process "$plot/video.mp4" --arm-radius "$arm" \
          --calibration "$plot/calibration.yaml" "${measured[@]}" --vertical "$vertical" \
          --no-report --out "$out" > "$plot.$vertical.log" 2>&1 || true
      fi
      [ -f "$out/trees.csv" ] || { echo "process failed: $out" >&2; continue; }
      "$bin" --log-level warn evaluate --truth "$plot/truth.json" --pred "$out/trees.csv" \
        --trajectory "$out/trajectory.tum" --min-dbh 10 --plot-radius 10 --out "$out/eval" \
        > /dev/null
      echo "$kind-$seed $vertical $plot $out" >> "$rows"
    done
  done
done

python3 - "$rows" "$here" <<'PY'
import csv, json, math, sys
sys.path.insert(0, sys.argv[2])
from judge import stem_ground_errors  # noqa: E402

def ground_errors(plot, out):
    e = json.load(open(f"{out}/eval/evaluation.json"))["raw"]
    t = json.load(open(f"{plot}/truth.json"))
    pred = {int(r["tree_id"]): r for r in csv.DictReader(open(f"{out}/trees.csv"))}
    return stem_ground_errors(t, e["pairs"], pred, out), e

print("| plot | vertical | camera-up error (°) | stem ground error: rms (cm), within 5 cm | recall | DBH MAE (cm) |")
print("|---|---|---|---|---|---|")
pooled = {}
for line in open(sys.argv[1]):
    name, vertical, plot, out = line.split()
    g, e = ground_errors(plot, out)
    up = json.load(open(f"{out}/eval/evaluation.json"))["trajectory"]["mean_up_error_deg"]
    rms = 100 * math.sqrt(sum(x * x for x in g) / max(1, len(g)))
    within = sum(abs(x) <= 0.05 for x in g)
    print(f"| {name} | {vertical} | {up:.2f} | {rms:.1f}, {within}/{len(g)} | {e['recall']:.3f} | "
          f"{e['dbh']['mae_cm']:.2f} |")
    p = pooled.setdefault(vertical, {"up": [], "g": []})
    p["up"].append(up)
    p["g"] += g
print("\n| vertical | plots | mean camera-up error (°) | largest (°) | stem ground error: rms (cm), within 5 cm |")
print("|---|---|---|---|---|")
for vertical, p in pooled.items():
    g = p["g"]
    rms = 100 * math.sqrt(sum(x * x for x in g) / max(1, len(g)))
    within = sum(abs(x) <= 0.05 for x in g) / max(1, len(g))
    print(f"| {vertical} | {len(p['up'])} | {sum(p['up']) / len(p['up']):.2f} | {max(p['up']):.2f} | "
          f"{rms:.1f}, {within:.2f} ({len(g)} stems) |")
PY
