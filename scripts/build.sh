#!/usr/bin/env bash
# Configures (once) and builds drivegw in build/ with Ninja and ccache. Extra args: ninja targets.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${BUILD_DIR:-build}
export CCACHE_DIR=${CCACHE_DIR:-$HOME/.cache/ccache}
# Fresh clones in other directories (CI) still hit the cache: paths are hashed relative.
export CCACHE_BASEDIR=${CCACHE_BASEDIR:-$PWD}
export CCACHE_NOHASHDIR=true
export CCACHE_MAXSIZE=${CCACHE_MAXSIZE:-5G}
if [ ! -f "$BUILD_DIR/build.ninja" ]; then
  # CMAKE_ARGS: extra cache settings, e.g. -DDGW_TESTS=OFF (docker/Dockerfile).
  # shellcheck disable=SC2086
  cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=${BUILD_TYPE:-RelWithDebInfo} ${CMAKE_ARGS:-}
fi
# The dashboard first: web/dist is embedded into drivegw (decision 505).
scripts/build-web.sh
# Two cores; Beast translation units need ~1 GB each, so two jobs is the ceiling.
ninja -C "$BUILD_DIR" -j "${JOBS:-2}" "$@"
