#!/bin/bash
#SBATCH --job-name=panoconv
#SBATCH --array=0-15
#SBATCH --cpus-per-task=8
#SBATCH --mem=2G
#SBATCH --time=02:00:00
#SBATCH --requeue
# One shard of a conversion: a Slurm array task, or a pod of a Kubernetes Indexed Job.
set -euo pipefail
# The shard count is fixed here, never read from the array: a re-submitted task
# (sbatch --array=7) sees SLURM_ARRAY_TASK_COUNT=1.
SHARDS="${PANOCONV_SHARDS:-16}"
INDEX="${SLURM_ARRAY_TASK_ID:-${JOB_COMPLETION_INDEX:?no shard index}}"
# --resume makes a requeued, restarted or re-submitted task continue where it stopped.
exec "${PANOCONV:-panoconv}" kitti --to equirect \
  --input "${PANOCONV_INPUT:-/data/kitti}" --output "${PANOCONV_OUTPUT:-/data/kitti_equi}" \
  --jobs "${PANOCONV_JOBS:-${SLURM_CPUS_PER_TASK:-$(nproc)}}" --quiet --resume \
  --shard "$INDEX/$SHARDS"
