#!/usr/bin/env bash
# ctest deploy.kubernetes: npm ci here (only when node_modules is missing or package-lock.json
# changed: scripts/npm-ci-once.sh), then validate deploy/kubernetes and run the
# self-test that proves each rule rejects its fixtures/bad-*.yaml.
set -euo pipefail
cd "$(dirname "$0")"
../../scripts/npm-ci-once.sh deploy.kubernetes .
node validate.mjs
node validate.mjs --self-test
