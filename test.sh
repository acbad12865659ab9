#!/usr/bin/env bash
# The test suite, exactly as CI runs it: ./test.sh [pytest options]
# Creates .venv if needed, installs rockjax with its test dependencies, runs pytest
# (slow tests are skipped by default; run them with ./test.sh -m slow).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")"
. .ci/ensure-venv tests
exec .venv/bin/python -m pytest "$@"
