#!/usr/bin/env bash
# Configures (once) and builds drivegw in build/ with Ninja and ccache. Extra args: ninja targets.
# PRESET=asan configures from CMakePresets.json instead (ASan+UBSan in build-asan/, decision
# 1411); BUILD_DIR then defaults to build-<preset>. BUILD_DIR/CMAKE_ARGS alone work as before.
set -euo pipefail
cd "$(dirname "$0")/.."
PRESET=${PRESET:-}
if [ -n "$PRESET" ] && [ "$PRESET" != default ]; then
  BUILD_DIR=${BUILD_DIR:-build-$PRESET}
fi
BUILD_DIR=${BUILD_DIR:-build}
export CCACHE_DIR=${CCACHE_DIR:-$HOME/.cache/ccache}
# Fresh clones in other directories (CI) still hit the cache: paths are hashed relative.
export CCACHE_BASEDIR=${CCACHE_BASEDIR:-$PWD}
export CCACHE_NOHASHDIR=true
export CCACHE_MAXSIZE=${CCACHE_MAXSIZE:-12G}
if [ ! -f "$BUILD_DIR/build.ninja" ]; then
  # CMAKE_ARGS: extra cache settings, e.g. -DDGW_TESTS=OFF (docker/Dockerfile).
  # shellcheck disable=SC2086
  if [ -n "$PRESET" ]; then
    cmake --preset "$PRESET" -B "$BUILD_DIR" ${CMAKE_ARGS:-}
  else
    cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=${BUILD_TYPE:-RelWithDebInfo} ${CMAKE_ARGS:-}
  fi
fi
# The dashboard first: web/dist is embedded into drivegw (decision 505).
scripts/build-web.sh
# Two cores; Beast translation units need ~1 GB each, so two jobs is the ceiling.
ninja -C "$BUILD_DIR" -j "${JOBS:-2}" "$@"
