#!/usr/bin/env bash
# One Slurm job-array task per manifest row: each task processes its own plot with
# `stemmap batch --task`, so the cluster's scheduler spreads the plots over its nodes.
#   sbatch --array=1-$(($(wc -l < plots.csv) - 1)) scripts/slurm-batch.sh plots.csv results/
# When every task has ended: stemmap batch plots.csv --out results/ --summary
#SBATCH --job-name=stemmap
#SBATCH --cpus-per-task=2
#SBATCH --mem=4G
#SBATCH --time=00:30:00
set -euo pipefail
manifest=$1
out=$2
stemmap=${STEMMAP:-stemmap}
exec "$stemmap" batch "$manifest" --out "$out" --task "$SLURM_ARRAY_TASK_ID"
