#!/usr/bin/env bash
# The main job: set up (if needed), then run cases/fixed_head_3Hz. Extra arguments go to fsi-run.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
# --overwrite: the main job is rerun on purpose (with --resume it continues instead)
exec .venv/bin/fsi-run cases/fixed_head_3Hz --overwrite "$@"
