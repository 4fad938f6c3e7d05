#!/usr/bin/env bash
# Builds the dashboard: npm ci (only when node_modules is missing or package-lock.json changed)
# and npm run build in web/, giving web/dist, which CMake embeds into drivegw (decision 505).
# Without web/package.json there is nothing to build: drivegw then embeds no files and answers
# GET / with 503 "dashboard not built".
set -euo pipefail
cd "$(dirname "$0")/../web" 2>/dev/null || { echo "build-web: no web/ directory, skipped"; exit 0; }
if [ ! -f package.json ]; then
  echo "build-web: web/package.json missing, dashboard not built (GET / answers 503)"
  exit 0
fi
for tool in node npm; do
  if ! command -v "$tool" >/dev/null 2>&1; then
    echo "build-web: $tool not found; the dashboard needs Node.js and npm (scripts/install-deps.sh installs them)" >&2
    exit 1
  fi
done
# node_modules/.package-lock.json is npm's own record of what it installed; compare our copy of
# the lock file with a stamp instead, so an edited lock file re-runs npm ci.
stamp=node_modules/.drivegw-lock-stamp
if [ ! -d node_modules ] || [ ! -f "$stamp" ] || ! cmp -s package-lock.json "$stamp"; then
  echo "build-web: npm ci"
  npm ci --no-audit --no-fund
  cp package-lock.json "$stamp"
fi
echo "build-web: npm run build"
npm run build
# A stamp CMake can depend on: its time says when dist was last written.
touch dist/.build-stamp
