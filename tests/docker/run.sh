#!/usr/bin/env bash
# Docker stage of scripts/test.sh (issue 9): a private dockerd, the image built from
# docker/Dockerfile, the compose demo (docker/compose.yaml) up, one move per family through REST
# from the host, the audit rows in the mounted database, then everything down again.
#
#   tests/docker/run.sh            (root: it starts dockerd; ends "docker: N passed, M failed")
#
# dockerd keeps its images and BuildKit's compiler cache in DGW_DOCKER_ROOT (default
# ~/.cache/drivegw/docker), so a later run rebuilds only what changed; its socket, exec root and
# pid file are private to this run, and it is stopped by its PID at the end.
set -euo pipefail
cd "$(dirname "$0")/../.."
REPO=$PWD
if [ "$(id -u)" -ne 0 ]; then
  echo "docker: needs root to start dockerd; docker: 0 passed, 1 failed" >&2
  exit 1
fi
for tool in dockerd docker-compose debootstrap python3; do
  command -v "$tool" >/dev/null || { echo "docker: $tool missing (scripts/install-deps.sh)" >&2; exit 1; }
done
# Debian's CLI (20.10) builds with the daemon's BuildKit; a newer docker CLI elsewhere in PATH
# would want the buildx plugin. docker-compose calls whichever `docker` comes first.
export PATH=/usr/bin:/usr/sbin:$PATH
ROOT=${DGW_DOCKER_ROOT:-$HOME/.cache/drivegw/docker}
RUN_DIR=$(mktemp -d /tmp/drivegw-docker.XXXXXX)
export DOCKER_HOST=unix://$RUN_DIR/docker.sock
export DOCKER_BUILDKIT=1
PROJECT=drivegw-test-$$
passed=0
failed=0
DOCKERD_PID=""

cleanup() {
  set +e
  if [ -n "$DOCKERD_PID" ]; then
    (cd docker && docker-compose -p "$PROJECT" down -v --timeout 20 >/dev/null 2>&1)
    kill "$DOCKERD_PID" 2>/dev/null
    for _ in $(seq 1 60); do kill -0 "$DOCKERD_PID" 2>/dev/null || break; sleep 0.5; done
    kill -9 "$DOCKERD_PID" 2>/dev/null
  fi
  rm -rf "$RUN_DIR"
}
trap cleanup EXIT

step() {  # step NAME COMMAND...: one counted check
  local name=$1
  shift
  local t0=$SECONDS
  if "$@"; then
    passed=$((passed + 1))
    echo "docker: PASS $name ($((SECONDS - t0)) s)"
  else
    failed=$((failed + 1))
    echo "docker: FAIL $name ($((SECONDS - t0)) s)"
    return 1
  fi
}

finish() {
  echo "docker: $passed passed, $failed failed"
  [ "$failed" -eq 0 ]
}

mkdir -p "$ROOT"
dockerd --data-root "$ROOT" --exec-root "$RUN_DIR/exec" -H "$DOCKER_HOST" \
  --pidfile "$RUN_DIR/docker.pid" >"$RUN_DIR/dockerd.log" 2>&1 &
DOCKERD_PID=$!
for _ in $(seq 1 60); do docker version >/dev/null 2>&1 && break; sleep 0.5; done
if ! docker version >/dev/null 2>&1; then
  tail -20 "$RUN_DIR/dockerd.log" >&2
  failed=1
  finish || exit 1
fi

VERSION=$(git describe --tags --always --dirty 2>/dev/null || echo dev)
REVISION=$(git rev-parse HEAD 2>/dev/null || echo unknown)
TAG=drivegw:test-$$
build_image() {
  docker/make-base-image.sh debian:bookworm-slim &&
    docker build -f docker/Dockerfile -t "$TAG" --progress=plain \
      --secret id=ca-certificates,src=/etc/ssl/certs/ca-certificates.crt \
      --build-arg VERSION="$VERSION" --build-arg REVISION="$REVISION" \
      --build-arg CREATED="$(date -u +%Y-%m-%dT%H:%M:%SZ)" --build-arg SOURCE="$REPO" \
      . >"$RUN_DIR/build.log" 2>&1 ||
    { tail -40 "$RUN_DIR/build.log" >&2; return 1; }
}
step "image builds from docker/Dockerfile" build_image || finish || exit 1

image_checks() {
  local size user labels
  size=$(docker image inspect -f '{{.Size}}' "$TAG")
  user=$(docker image inspect -f '{{.Config.User}}' "$TAG")
  labels=$(docker image inspect -f '{{json .Config.Labels}}' "$TAG")
  echo "docker: image $TAG: $((size / 1000000)) MB, user $user"
  echo "docker: labels $labels"
  [ "$size" -lt 200000000 ] || { echo "docker: image is $size bytes, target < 200 MB" >&2; return 1; }
  [ "$user" = "drivegw:drivegw" ] || { echo "docker: runs as '$user', not drivegw" >&2; return 1; }
  for key in version revision source created; do
    grep -q "\"org.opencontainers.image.$key\"" <<<"$labels" || { echo "docker: label $key missing" >&2; return 1; }
  done
  grep -q "\"org.opencontainers.image.revision\":\"$REVISION\"" <<<"$labels" ||
    { echo "docker: revision label is not $REVISION" >&2; return 1; }
  # The programs start in the runtime image (every shared library is there).
  docker run --rm --entrypoint drivegw-sim "$TAG" --help >/dev/null 2>&1 &&
    docker run --rm "$TAG" --help >/dev/null 2>&1
}
step "runtime image: < 200 MB, non-root, OCI labels, programs start" image_checks || true

# A free host port pair, so a gateway running on this host is no obstacle.
free_port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }
export DRIVEGW_VERSION=test-$$
export DRIVEGW_HTTP_PORT DRIVEGW_GRPC_PORT DRIVEGW_DATA
DRIVEGW_HTTP_PORT=$(free_port)
DRIVEGW_GRPC_PORT=$(free_port)
DRIVEGW_DATA=$RUN_DIR/data
install -d -o 10001 -g 10001 "$DRIVEGW_DATA"

compose_up() {
  (cd docker && docker-compose -p "$PROJECT" up -d) >"$RUN_DIR/compose.log" 2>&1 ||
    { cat "$RUN_DIR/compose.log" >&2; return 1; }
  local cid status=""
  cid=$(cd docker && docker-compose -p "$PROJECT" ps -q gateway)
  for _ in $(seq 1 90); do
    status=$(docker inspect -f '{{.State.Health.Status}}' "$cid")
    [ "$status" = healthy ] && break
    sleep 1
  done
  echo "docker: gateway container $status"
  [ "$status" = healthy ] || { (cd docker && docker-compose -p "$PROJECT" logs --tail 40) >&2; return 1; }
  [ "$(docker exec "$cid" id -u)" = 10001 ]
}
step "docker-compose up: gateway healthy (HEALTHCHECK drivegw health), non-root" compose_up || true

scenario() {
  python3 tests/docker/scenario.py "$DRIVEGW_HTTP_PORT" "$DRIVEGW_DATA" ||
    { (cd docker && docker-compose -p "$PROJECT" logs --tail 30) >&2; return 1; }
}
step "one move per family through REST from the host, audit rows in the mounted database" scenario || true

compose_down() {
  (cd docker && docker-compose -p "$PROJECT" down -v --timeout 20) >>"$RUN_DIR/compose.log" 2>&1 &&
    [ -z "$(docker ps -q --filter "label=com.docker.compose.project=$PROJECT")" ] &&
    # The gateway stopped cleanly on SIGTERM: the database it leaves passes SQLite's own check.
    python3 -c "import sqlite3,sys; r=sqlite3.connect(sys.argv[1]).execute('PRAGMA integrity_check').fetchone()[0]; print('docker: integrity_check', r); sys.exit(r!='ok')" "$DRIVEGW_DATA/drivegw.db"
}
step "docker-compose down -v, database intact" compose_down || true
docker image rm "$TAG" >/dev/null 2>&1 || true
# Bounded cache across runs (old layers; the ccache mount stays below CCACHE_MAXSIZE anyway).
docker builder prune -f --keep-storage 6gb >/dev/null 2>&1 || true
finish
