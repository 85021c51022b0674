#!/usr/bin/env bash
# Real-phone camera effects against the ideal camera, on the same plots: each plot is rendered
# with the ideal camera, with each effect of the `main` phone preset alone (rolling shutter,
# residual distortion, focus breathing, wind), with the whole preset, with the preset and
# in-camera stabilisation, with the `wide` preset (100°), and with that preset's focus locked
# (`wide-locked`: no breathing) processed with `--focal fixed`, as the README advises for that
# lens; every render goes through `process`
# with the truth's calibration (the lens as a calibration gives it; for `wide`, what `stemmap
# calibrate --lens wide` makes of the simulated board video of its lens), the measured camera height and, for the rolling shutter, the
# preset's readout (`--readout-ms`). Reports per plot and variant recall, precision, DBH MAE and
# bias, position RMSE and the camera-up error, the pooled figures per variant and, stem by stem
# against the ideal camera, how far each variant moves the DBH of the stems both list.
# Usage: bench/phone.sh [BUILD_DIR] [DATA_DIR]
#   SEEDS or FRESH=N and KINDS as in bench/plots.sh; SIZE (default 960x540) and FPS (default 15);
#   VARIANTS: the cameras to run, by name (default all; e.g. "ideal main" for more plots).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
source "$here/common.sh"
size=${SIZE:-960x540}
fps=${FPS:-15}
width=${size%x*}
height=${size#*x}
# name : simulate flags : process flags
variants=(
  "ideal::"
  "shutter:--readout-ms 25:--readout-ms 25"
  "distortion:--k1 0.02 --k2 -0.01:"
  "breathing:--breathing-pct 0.7:"
  "wind:--wind 0.5:"
  "main:--phone main:--readout-ms 25"
  "main-stabilised:--phone main --stabilisation:--readout-ms 25"
  "wide:--phone wide:--readout-ms 30"
  "wide-locked:--phone wide --breathing-pct 0:--readout-ms 30 --focal fixed"
)

rows="$data/phone_rows.txt"
: > "$rows"
for kind in $kinds; do
  for seed in $seeds; do
    for v in "${variants[@]}"; do
      IFS=: read -r name sim_flags proc_flags <<< "$v"
      case " ${VARIANTS:-$name} " in *" $name "*) ;; *) continue ;; esac
      dir="$data/$kind-$seed/$name"
      mkdir -p "$dir"
      if [ ! -f "$dir/video.mp4" ]; then
        "$bin" --log-level warn simulate --seed "$seed" --kind "$kind" --width "$width" \
          --height "$height" --fps "$fps" --stills 0 $sim_flags --out "$dir" > "$dir.simulate.log" 2>&1
      fi
      # The phone's calibration, as `stemmap calibrate` gives it with stabilisation off (as the
      # README says to calibrate): the stabilised video's crop is not in it. The wide lens is
      # calibrated by `stemmap calibrate --lens wide` from the simulated board video of its lens.
      calib_from="$dir/truth.json"
      case "$name" in *-stabilised) calib_from="$data/$kind-$seed/main/truth.json" ;; esac
      if [ "${name%%-*}" = wide ]; then
        board="$data/$kind-$seed/wide/board"  # one board video of the lens for both
        if [ ! -f "$board/calibration.yaml" ]; then
          "$bin" --log-level warn simulate --checkerboard --phone wide --seed "$seed" \
            --width "$width" --height "$height" --out "$board" > "$dir.board.log" 2>&1
          "$bin" --log-level warn calibrate "$board/video.mp4" --lens wide \
            --out "$board/calibration.yaml" >> "$dir.board.log" 2>&1
        fi
        cp "$board/calibration.yaml" "$dir/calibration.yaml"
      else
        python3 "$here/truth_calibration.py" "$calib_from" "$dir/calibration.yaml"
      fi
      if [ ! -f "$dir/run/trees.csv" ]; then
        height_m=$(python3 -c "import json;print(json.load(open('$dir/truth.json'))['camera_height_m'])")
        "$bin" --log-level info process "$dir/video.mp4" --arm-radius 1.0 \
          --calibration "$dir/calibration.yaml" --camera-height "$height_m" --no-report \
          $proc_flags --out "$dir/run" > "$dir.process.log" 2>&1 || true
      fi
      if [ -f "$dir/run/trees.csv" ]; then
        "$bin" --log-level warn evaluate --truth "$dir/truth.json" --pred "$dir/run/trees.csv" \
          --trajectory "$dir/run/trajectory.tum" --out "$dir/eval" > /dev/null 2>&1 || true
      fi
      warned=$(grep -ci "stabilis" "$dir.process.log" || true)
      echo "$kind-$seed $name $dir $warned" >> "$rows"
    done
  done
done

python3 - "$rows" <<'PY'
import json, math, sys
rows = [l.split() for l in open(sys.argv[1]) if l.strip()]
def load(d):
    try:
        return json.load(open(f"{d}/eval/evaluation.json"))
    except (OSError, ValueError):
        return None
print("| plot | camera | recall | precision | DBH MAE (cm) | DBH bias (cm) | position RMSE (cm) | camera-up error (°) | stabilisation warned |")
print("|---|---|---|---|---|---|---|---|---|")
pooled = {}
for plot, name, d, warned in rows:
    e = load(d)
    if e is None:
        print(f"| {plot} | {name} | failed | | | | | | |")
        continue
    t, tr = e["raw"], e.get("trajectory", {})
    print(f"| {plot} | {name} | {t['recall']:.3f} | {t['precision']:.3f} | {t['dbh']['mae_cm']:.2f} | "
          f"{t['dbh']['bias_cm']:+.2f} | {100 * t['position_rmse_m']:.1f} | "
          f"{tr.get('mean_up_error_deg', float('nan')):.2f} | {'yes' if int(warned) else 'no'} |")
    p = pooled.setdefault(name, {"tp": 0, "truth": 0, "pred": 0, "abs": 0.0, "bias": 0.0, "sq": 0.0, "up": []})
    m = t["n_matched"]
    p["tp"] += m; p["truth"] += t["n_truth"]; p["pred"] += t["n_predicted"]
    p["abs"] += t["dbh"]["mae_cm"] * m; p["bias"] += t["dbh"]["bias_cm"] * m
    p["sq"] += t["position_rmse_m"] ** 2 * m; p["up"].append(tr.get("mean_up_error_deg", float("nan")))
print()
print("| camera | plots | recall | precision | DBH MAE (cm) | DBH bias (cm) | position RMSE (cm) | mean camera-up error (°) |")
print("|---|---|---|---|---|---|---|---|")
for name, p in pooled.items():
    n = max(1, p["tp"])
    print(f"| {name} | {len(p['up'])} | {p['tp'] / max(1, p['truth']):.3f} | {p['tp'] / max(1, p['pred']):.3f} | "
          f"{p['abs'] / n:.2f} | {p['bias'] / n:+.2f} | {100 * math.sqrt(p['sq'] / n):.1f} | "
          f"{sum(p['up']) / len(p['up']):.2f} |")

# Paired with the ideal camera, stem by stem: on the stems both runs list, how far each effect
# moves a stem's DBH. A stem the detector reads one way or the other on a knife edge moves a
# plot's MAE by tenths of a centimetre; the median shift and the mean signed shift show what the
# camera itself does.
print()
print("| camera | stems listed by both | mean DBH shift (cm) | median abs shift (cm) | shifts > 1 cm | MAE ideal / camera on them (cm) |")
print("|---|---|---|---|---|---|")
ideal = {}
for plot, name, d, _ in rows:
    e = load(d)
    if name == "ideal" and e is not None:
        ideal[plot] = {q["truth_id"]: q for q in e["raw"]["pairs"]}
shifts = {}
for plot, name, d, _ in rows:
    e = load(d)
    if name == "ideal" or e is None or plot not in ideal:
        continue
    s = shifts.setdefault(name, [])
    for q in e["raw"]["pairs"]:
        i = ideal[plot].get(q["truth_id"])
        if i is not None:
            s.append((q["predicted_dbh_cm"] - i["predicted_dbh_cm"],
                      abs(i["predicted_dbh_cm"] - i["truth_dbh_cm"]),
                      abs(q["predicted_dbh_cm"] - q["truth_dbh_cm"])))
for name, s in shifts.items():
    if not s:
        continue
    ds = sorted(abs(x[0]) for x in s)
    med = ds[len(ds) // 2] if len(ds) % 2 else 0.5 * (ds[len(ds) // 2 - 1] + ds[len(ds) // 2])
    print(f"| {name} | {len(s)} | {sum(x[0] for x in s) / len(s):+.2f} | {med:.2f} | "
          f"{sum(1 for x in ds if x > 1.0)} | {sum(x[1] for x in s) / len(s):.2f} / "
          f"{sum(x[2] for x in s) / len(s):.2f} |")
PY
