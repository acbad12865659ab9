#!/usr/bin/env bash
# The documentation site: ./docs.sh builds it into site/ (mkdocs build --strict: a broken link, a
# docstring griffe cannot parse or a notebook cell that raises fails the build);
# ./docs.sh serve previews it at http://127.0.0.1:8000 and rebuilds on every change.
# Further options go to mkdocs (./docs.sh --site-dir DIR, ./docs.sh serve --dev-addr HOST:PORT).
# Creates .venv if needed and installs rockjax with its docs dependencies.
# The notebooks are executed before they are rendered (a few minutes on 2 cores) and kept in
# .cache/rockjax-docs/ until they or rockjax's sources change; ROCKJAX_DOCS_EXECUTE=0 renders
# them without outputs (a quick preview of the prose), ROCKJAX_DOCS_EXECUTE=reuse keeps the last
# executed copies even after rockjax changed (a preview while editing the code).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")"
. .ci/ensure-venv docs
export NO_MKDOCS_2_WARNING=1 # mkdocs-material's notice about its successor, on every build
case "${1:-}" in
    serve)
        shift
        exec .venv/bin/mkdocs serve "$@"
        ;;
    build)
        shift
        exec .venv/bin/mkdocs build --strict "$@"
        ;;
    *) exec .venv/bin/mkdocs build --strict "$@" ;;
esac
