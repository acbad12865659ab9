#!/usr/bin/env bash
# The test suite, exactly as CI runs it: ./test.sh [pytest options]
# Creates .venv if needed, installs rockjax with its test dependencies, runs pytest on every
# core (pytest-xdist, one test file per worker: module fixtures are built once; pass -n 0 for a
# single process). Slow tests are skipped by default; run them with ./test.sh -m slow.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")"
. .ci/ensure-venv tests
exec .venv/bin/python -m pytest -n auto --dist loadfile "$@"
