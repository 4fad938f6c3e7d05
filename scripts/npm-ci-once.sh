#!/usr/bin/env bash
# `npm ci` in DIR only when node_modules is missing or DIR/package-lock.json changed since the
# last install; used by scripts/build-web.sh (the dashboard) and tests/kubernetes/run.sh.
#
#   scripts/npm-ci-once.sh LABEL DIR      (LABEL prefixes the messages)
set -euo pipefail
label=$1
cd "$2"
for tool in node npm; do
  if ! command -v "$tool" >/dev/null 2>&1; then
    echo "$label: $tool not found; scripts/install-deps.sh installs Node.js and npm" >&2
    exit 1
  fi
done
# node_modules/.package-lock.json is npm's own record of what it installed; compare our copy of
# the lock file with a stamp instead, so an edited lock file re-runs npm ci.
stamp=node_modules/.drivegw-lock-stamp
if [ ! -d node_modules ] || [ ! -f "$stamp" ] || ! cmp -s package-lock.json "$stamp"; then
  echo "$label: npm ci"
  npm ci --no-audit --no-fund
  cp package-lock.json "$stamp"
fi
