#!/usr/bin/env bash
# Installs what is missing, builds everything in one build tree, and runs every test stage.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
scripts/build.sh
echo "== unit, contract and end-to-end tests (ctest) =="
ctest --test-dir "${BUILD_DIR:-build}" --output-on-failure -j 2 --timeout 300
