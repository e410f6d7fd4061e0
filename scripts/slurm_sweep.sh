#!/usr/bin/env bash
# Frequency sweep on a cluster: one nonlinear coupled run per frequency and waveform, dealt to
# the MPI ranks (mpi4py), e.g.  sbatch --ntasks=26 scripts/slurm_sweep.sh cases/fixed_head_3Hz
# Locally the same works with:  mpiexec -n 4 .venv/bin/fsi-sweep CASE --method transient
# Each run's OpenFOAM may itself use several ranks (fluid.processes, mpirun): give it
# --cpus-per-task accordingly. Submit from the repository root (sbatch runs a spool copy of
# this script: the repository is found from $SLURM_SUBMIT_DIR). Every finished point's row is
# in OUTPUT/sweep.csv at once; after a time limit or scancel, submit again with --resume to
# run only the missing points. srun needs an mpi4py built against the cluster's MPI (and,
# with Open MPI, srun --mpi=pmix): a mismatch stops every task in one line.
#SBATCH --job-name=fish-sweep
#SBATCH --ntasks=26
#SBATCH --cpus-per-task=1
#SBATCH --time=24:00:00
set -euo pipefail
if [[ -n "${SLURM_SUBMIT_DIR:-}" ]]; then
  cd "$SLURM_SUBMIT_DIR"  # where sbatch ran; the case path is relative to it
else
  cd "$(dirname "$0")/.."
fi
if [[ ! -x .venv/bin/fsi-sweep ]]; then
  echo "error: no .venv/bin/fsi-sweep in $PWD: submit from the repository root (after scripts/setup.sh)" >&2
  exit 2
fi
CASE="${1:-cases/fixed_head_3Hz}"
shift || true
srun .venv/bin/fsi-sweep "$CASE" --method transient --frequencies 1:25:2 \
  --waveforms sine,square "$@"
