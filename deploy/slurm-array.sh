#!/bin/bash
# A Slurm array job rendering a camsim dataset: task i renders shard i of the array's tasks
# (every index equal to i modulo the task count), one process per task, each calibrating its
# cameras once. /data is a shared file system; put the spec at /data/spec.toml.
#   sbatch deploy/slurm-array.sh
# then: camsim dataset --index-manifest /data/out
# Software: a camsim binary on the PATH (module load camsim, or cargo install --path camsim),
# or the container: replace `camsim` below with
#   apptainer exec --bind /data docker://camsim:latest camsim
#SBATCH --job-name=camsim-dataset
#SBATCH --array=0-63
#SBATCH --cpus-per-task=2
#SBATCH --mem=2G
#SBATCH --time=04:00:00
#SBATCH --requeue
set -euo pipefail
camsim dataset --spec /data/spec.toml --out /data/out --shard "$SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT" --threads "${SLURM_CPUS_PER_TASK:-1}"
# One sample per task instead (an array as long as the dataset):
# camsim dataset --spec /data/spec.toml --out /data/out --index "$SLURM_ARRAY_TASK_ID" --threads "${SLURM_CPUS_PER_TASK:-1}"
