#!/usr/bin/env bash
# The test suite: set up (if needed), ruff (lint, format), mypy (types), then pytest. Extra
# arguments go to pytest.
# The cluster-sweep test starts a real one-node SLURM (tests/test_sweep_cluster.py): as root,
# SLURM and munge are installed for it when missing (about 10 s; without them it is skipped).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
if [ "$(id -u)" -eq 0 ] && ! command -v slurmctld >/dev/null 2>&1; then
  echo "test: installing SLURM and munge for the cluster-sweep test" >&2
  DEBIAN_FRONTEND=noninteractive apt-get install -y -q slurm-wlm munge libpmix-dev >/dev/null \
    || echo "test: SLURM could not be installed; the cluster-sweep test will be skipped" >&2
fi
# lint and format first: seconds, and a failure names the file and line
PY_PATHS="fsi_orchestrator solid_adapter fluid_adapter fishfsi turek_hron tests benchmarks"
echo "test: ruff check and ruff format --check on $PY_PATHS" >&2
.venv/bin/ruff check $PY_PATHS
.venv/bin/ruff format --check $PY_PATHS
# types: the four packages and turek_hron, strict on the core (pyproject.toml [tool.mypy])
echo "test: mypy (pyproject.toml [tool.mypy])" >&2
.venv/bin/mypy
exec .venv/bin/python -m pytest "$@"
