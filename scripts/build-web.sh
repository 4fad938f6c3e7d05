#!/usr/bin/env bash
# Builds the dashboard: npm ci (only when node_modules is missing or package-lock.json changed)
# and npm run build in web/, giving web/dist, which CMake embeds into drivegw (decision 505).
# Without web/package.json there is nothing to build: drivegw then embeds no files and answers
# GET / with 503 "dashboard not built".
set -euo pipefail
scripts=$(cd "$(dirname "$0")" && pwd)
cd "$scripts/../web" 2>/dev/null || { echo "build-web: no web/ directory, skipped"; exit 0; }
if [ ! -f package.json ]; then
  echo "build-web: web/package.json missing, dashboard not built (GET / answers 503)"
  exit 0
fi
"$scripts/npm-ci-once.sh" build-web .
echo "build-web: npm run build"
npm run build
# A stamp CMake can depend on: its time says when dist was last written.
touch dist/.build-stamp
