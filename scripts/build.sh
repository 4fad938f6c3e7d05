#!/usr/bin/env bash
# Configures (once) and builds drivegw in build/ with Ninja and ccache. Extra args: ninja targets.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${BUILD_DIR:-build}
export CCACHE_DIR=${CCACHE_DIR:-$HOME/.cache/ccache}
if [ ! -f "$BUILD_DIR/build.ninja" ]; then
  cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=${BUILD_TYPE:-RelWithDebInfo}
fi
# Two cores; Beast translation units need ~1 GB each, so two jobs is the ceiling.
ninja -C "$BUILD_DIR" -j "${JOBS:-2}" "$@"
