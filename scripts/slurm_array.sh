#!/usr/bin/env bash
# Frequency sweep as a SLURM job array: one point per array task, each its own job (no MPI
# between points, so no mpi4py needed), e.g. the 13 sine and 13 square points of 1:25:2 Hz:
#   sbatch --array=0-25 --cpus-per-task=4 scripts/slurm_array.sh cases/fixed_head_3Hz --output sweep_out
# Task K runs point K (waveforms, then frequencies: fsi-sweep --point K). Its OpenFOAM runs on
# --cpus-per-task ranks (fluid.processes). Every task writes its row into the same --output
# folder, where sweep.csv merges them as they finish. Submit from the repository root; after a
# time limit or scancel, submit the same array again with --resume: finished points are
# skipped, killed ones continue from their checkpoints. Change the points with FREQUENCIES and
# WAVEFORMS in the environment (sbatch --export=ALL,FREQUENCIES=3,5,10 ...) and --array to
# match (0..points-1).
#SBATCH --job-name=fish-point
#SBATCH --array=0-25
#SBATCH --ntasks=1
#SBATCH --cpus-per-task=1
#SBATCH --time=12:00:00
set -euo pipefail
if [[ -n "${SLURM_SUBMIT_DIR:-}" ]]; then
  cd "$SLURM_SUBMIT_DIR"  # where sbatch ran (the script itself runs from a spool copy)
else
  cd "$(dirname "$0")/.."
fi
if [[ ! -x .venv/bin/fsi-sweep ]]; then
  echo "error: no .venv/bin/fsi-sweep in $PWD: submit from the repository root (after scripts/setup.sh)" >&2
  exit 2
fi
if [[ -z "${SLURM_ARRAY_TASK_ID:-}" ]]; then
  echo "error: SLURM_ARRAY_TASK_ID is not set: submit with sbatch --array=0-N" >&2
  exit 2
fi
CASE="${1:-cases/fixed_head_3Hz}"
shift || true
RANKS=()
if [[ "${SLURM_CPUS_PER_TASK:-1}" -gt 1 ]]; then
  RANKS=(--set "fluid.processes=${SLURM_CPUS_PER_TASK}")
fi
exec .venv/bin/fsi-sweep "$CASE" --method transient --frequencies "${FREQUENCIES:-1:25:2}" \
  --waveforms "${WAVEFORMS:-sine,square}" --point "$SLURM_ARRAY_TASK_ID" "${RANKS[@]}" "$@"
