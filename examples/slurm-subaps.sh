#!/bin/bash
# Per-sub-aperture effective read noise of a large sCMOS map as a Slurm job array.
#
# Each array task runs one shard (sub-apertures whose index is K-1 modulo N) and appends its
# finished sub-apertures to parts/subaps-K-of-N.part as they complete; a task that is
# preempted or times out resumes where it stopped when resubmitted with the same options.
# When every task is done, one merge writes the FITS images, the CSV, the chart and the
# summary, identical to a single unsharded run:
#
#   sbatch examples/slurm-subaps.sh                 # the array (N = 64 shards)
#   sbatch --dependency=afterok:<jobid> --wrap \
#     "detnoise subaps-merge parts --out subaps-map"
#
# Shards share the `parts` directory (a shared file system); every task must use the same
# map, grid and Monte-Carlo options (the part file's header binds them, and a merge refuses
# parts of another job).
#SBATCH --job-name=detnoise-subaps
#SBATCH --array=1-64
#SBATCH --cpus-per-task=8
#SBATCH --time=04:00:00
#SBATCH --output=logs/subaps-%A_%a.log

set -euo pipefail
N=64
MAP=${MAP:-rms_e.fits}          # e-, e.g. rms_e.fits from `detnoise darks` or `report`
GRID=${GRID:-16}                # SIZE[,PITCH[,X0,Y0]] in px

detnoise --threads "${SLURM_CPUS_PER_TASK}" subaps \
  --map "${MAP}" --subap-grid "${GRID}" \
  --spot airy:2 --signal 50 --seed 1 \
  --shard "${SLURM_ARRAY_TASK_ID}/${N}" \
  --out parts
