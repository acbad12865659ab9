#!/usr/bin/env bash
# The main job: ./run.sh [--quick] [more `rockjax demo` options, see ./run.sh --help]
# Needs only Python >= 3.11 with pip; the first run creates .venv and installs rockjax into it.
# Figures, CSV time histories and results.json go to out/ (or --out DIR).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")"
. .ci/ensure-venv core
exec .venv/bin/rockjax demo --out out "$@"
