#!/usr/bin/env bash
# ctest deploy.kubernetes: npm ci here (only when node_modules is missing or package-lock.json
# changed; the stamp logic of scripts/build-web.sh), then validate deploy/kubernetes and run the
# self-test that proves each rule rejects its fixtures/bad-*.yaml.
set -euo pipefail
cd "$(dirname "$0")"
for tool in node npm; do
  if ! command -v "$tool" >/dev/null 2>&1; then
    echo "deploy.kubernetes: $tool not found (scripts/install-deps.sh installs Node.js and npm)" >&2
    exit 1
  fi
done
stamp=node_modules/.drivegw-lock-stamp
if [ ! -d node_modules ] || [ ! -f "$stamp" ] || ! cmp -s package-lock.json "$stamp"; then
  echo "deploy.kubernetes: npm ci"
  npm ci --no-audit --no-fund
  cp package-lock.json "$stamp"
fi
node validate.mjs
node validate.mjs --self-test
