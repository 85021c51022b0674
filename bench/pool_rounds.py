#!/usr/bin/env python3
"""Pools the untouched fresh-plot rounds of docs/benchmarks.md's pooled table.

Usage: bench/pool_rounds.py [docs/benchmarks.md]
Reads every row of "Pooled fresh plots over commits" whose first cell says "(untouched" (each
round judged once with the frozen binary of its commit, before anything was looked into) and
pools them: recall, precision (false stems recovered from each round's precision and hits),
MARE and position RMSE weighted by each round's hits, and ±2 SD coverage. A round's per-kind
MAE is not pooled (the table does not give its hits per kind); the range over rounds is printed.
"""
import math
import re
import sys

path = sys.argv[1] if len(sys.argv) > 1 else "docs/benchmarks.md"
text = open(path).read()
section = text[text.index("## Pooled fresh plots over commits"):]
section = section[:section.index("\n## ", 1)]


def count(cell):
    m = re.search(r"\((\d+)/(\d+)\)", cell)
    return int(m[1]), int(m[2])


rounds = plots = hits = truths = false_stems = covered = judged = 0
mare_sum = pos2_sum = 0.0
mae = {"managed": [], "natural": []}
for line in section.splitlines():
    if not line.startswith("| `") or "(untouched" not in line:
        continue
    cells = [c.strip() for c in line.strip().strip("|").split("|")]
    tp, n_truth = count(cells[2])
    precision = float(cells[4])
    rounds += 1
    plots += sum(int(x) for x in cells[1].split("/"))
    hits += tp
    truths += n_truth
    false_stems += round(tp / precision - tp)
    mare_sum += float(cells[6]) * tp
    pos2_sum += float(cells[7]) ** 2 * tp
    c, n = count(cells[8])
    covered += c
    judged += n
    for kind, value in zip(("managed", "natural"), cells[5].split("/")):
        mae[kind].append(float(value))

if not rounds:
    sys.exit(f"pool_rounds: no untouched round in {path}")
print(f"| rounds | plots | recall | precision | MARE (%) | position RMSE (cm) | ±2 SD coverage "
      f"| DBH MAE per round, managed / natural (cm) |")
print("|---|---|---|---|---|---|---|---|")
print(f"| {rounds} | {plots} | {hits / truths:.3f} ({hits}/{truths}) | "
      f"{hits / (hits + false_stems):.3f} ({false_stems} false) | {mare_sum / hits:.2f} | "
      f"{math.sqrt(pos2_sum / hits):.2f} | {covered / judged:.3f} ({covered}/{judged}) | "
      f"median {sorted(mae['managed'])[len(mae['managed']) // 2]:.2f} / "
      f"{sorted(mae['natural'])[len(mae['natural']) // 2]:.2f}, "
      f"{min(mae['managed']):.2f}–{max(mae['managed']):.2f} / "
      f"{min(mae['natural']):.2f}–{max(mae['natural']):.2f} |")

# The rounds' own tables ("**Fresh plots from `X`**" and its "| all |" row, in benchmarks.md and
# the log) give DBH MAE over both kinds and the stem ground's error, pooled here by hits.
rows = []
for doc in (path, path.replace("benchmarks.md", "benchmarks-log.md")):
    try:
        lines = open(doc).read().splitlines()
    except FileNotFoundError:
        continue
    commit = None
    for line in lines:
        m = re.match(r"\*\*Fresh plots from `(\w+)`", line)
        if m:
            commit = m[1]
        elif commit and line.startswith("| all |"):
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if cells[2].startswith("`"):  # a row per binary: the round's own is the untouched one
                if cells[2].strip("`") != commit:
                    continue
                del cells[2]
            tp = count(cells[2])[0]
            offset = 1 if "(" in cells[3] else 0  # tables with a half-visible column
            ground = re.fullmatch(r"([\d.]+), (0\.\d\d|1\.00)", cells[8 + offset])
            if ground:  # older tables lay their columns out otherwise
                rows.append((commit, tp, float(cells[4 + offset]), ground))
            commit = None
if rows:
    hits = sum(tp for _, tp, _, _ in rows)
    mae = sum(tp * m for _, tp, m, _ in rows) / hits
    g_rms = math.sqrt(sum(tp * float(g[1]) ** 2 for _, tp, _, g in rows) / hits)
    g_within = sum(tp * float(g[2]) for _, tp, _, g in rows) / hits
    print()
    print("| rounds with their own table | hits | DBH MAE, both kinds (cm) "
          "| stem ground error: rms (cm), within 5 cm |")
    print("|---|---|---|---|")
    print(f"| {len(rows)} (`{rows[-1][0]}` to `{rows[0][0]}`) | {hits} | {mae:.2f} | "
          f"{g_rms:.1f}, {g_within:.2f} |")
