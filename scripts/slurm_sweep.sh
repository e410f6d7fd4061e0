#!/usr/bin/env bash
# Frequency sweep on a cluster: one nonlinear coupled run per frequency and waveform, dealt to
# the MPI ranks (mpi4py), e.g.  sbatch --ntasks=26 scripts/slurm_sweep.sh cases/fixed_head_3Hz
# Locally the same works with:  mpiexec -n 4 .venv/bin/fsi-sweep CASE --method transient
# Each run's OpenFOAM may itself use several ranks (fluid.processes, mpirun): give it
# --cpus-per-task accordingly.
#SBATCH --job-name=fish-sweep
#SBATCH --ntasks=26
#SBATCH --cpus-per-task=1
#SBATCH --time=24:00:00
set -euo pipefail
cd "$(dirname "$0")/.."
CASE="${1:-cases/fixed_head_3Hz}"
shift || true
srun .venv/bin/fsi-sweep "$CASE" --method transient --frequencies 1:25:2 \
  --waveforms sine,square "$@"
