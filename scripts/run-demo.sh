#!/usr/bin/env bash
# Installs what is missing, builds, and starts drivegw with its embedded demo (simulated LinMot
# drives on loopback UDP, SQLite under ./data). Extra args go to drivegw (e.g. --config FILE).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
scripts/build.sh drivegw
exec build/server/drivegw "$@"
