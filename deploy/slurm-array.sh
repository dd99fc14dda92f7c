#!/bin/sh
# litesim bulk run as a Slurm job array: 8 tasks, one shard each.
#   sbatch deploy/slurm-array.sh
#   (afterwards) litesim merge results/shard-* -o results/merged
#SBATCH --job-name=litesim-batch
#SBATCH --array=0-7
#SBATCH --cpus-per-task=2
#SBATCH --mem=512M
#SBATCH --requeue
# --resume makes a requeued task skip the runs it already wrote.
exec litesim batch examples/scenarios/*.osc --seeds 1..10000 -q \
    --shard "${SLURM_ARRAY_TASK_ID}/8" --resume -o "results/shard-${SLURM_ARRAY_TASK_ID}"
