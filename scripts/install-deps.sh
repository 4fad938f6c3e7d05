#!/usr/bin/env bash
# Installs what drivegw needs on Debian 12 and is missing; idempotent (apt skips what is there).
#   scripts/install-deps.sh           everything: build, tests, browser, qemu, Docker (README, CI)
#   scripts/install-deps.sh --build   only what builds drivegw and drivegw-sim with -DDGW_TESTS=OFF
#                                     (the build stage of docker/Dockerfile)
set -euo pipefail
BUILD_PKGS=(build-essential cmake ninja-build pkg-config ccache
  libgrpc++-dev protobuf-compiler-grpc libprotobuf-dev protobuf-compiler
  libboost-dev libboost-system-dev libsqlite3-dev libyaml-cpp-dev nlohmann-json3-dev
  libssl-dev golang-grpc-gateway)
TEST_PKGS=(clang sqlite3 libgtest-dev libgmock-dev libbenchmark-dev
  # scripts/fuzz.sh: libFuzzer builds (-DDGW_FUZZ=ON, a separate clang tree); gcc builds never
  # need these.
  clang-14 libfuzzer-14-dev
  python3-grpcio curl openssl
  python3-can python3-msgpack
  qemu-system-x86 busybox-static cpio kmod xz-utils
  chromium
  # tests/docker: a private dockerd, compose 1.29 and a locally made debian:bookworm-slim base.
  docker.io docker-compose debootstrap)
case "${1:-}" in
  --build) PKGS=("${BUILD_PKGS[@]}") ;;
  "") PKGS=("${BUILD_PKGS[@]}" "${TEST_PKGS[@]}") ;;
  *) echo "usage: $0 [--build]" >&2; exit 2 ;;
esac
# The dashboard (web/, scripts/build-web.sh) needs Node.js and npm; a newer one installed
# outside apt (nvm, NodeSource) is kept, Debian's packages only fill the gap.
command -v node >/dev/null 2>&1 || PKGS+=(nodejs)
command -v npm >/dev/null 2>&1 || PKGS+=(npm)
missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PKGS[@]} packages present"
  exit 0
fi
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO=sudo
echo "install-deps: installing ${missing[*]}"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
