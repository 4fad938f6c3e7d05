#!/usr/bin/env bash
# Runs every benchmark in bench/ (issue 10) on the built tree and collects their @result lines
# (bench/report.h) into bench/results/latest.json and the results table of docs/performance.md
# (between the bench:results markers).
#
#   scripts/bench.sh            full runs: minutes; the numbers of record (quiet machine!)
#   scripts/bench.sh --smoke    seconds per benchmark, only proves they work (ctest does this)
#
# Environment: BUILD_DIR (default build), BENCH_OUT (default bench/results/latest.json),
# BENCH_TIMEOUT_S (per benchmark; default 1800 full, 120 smoke), BENCH_LIST (default bench/list.txt: another list of the same format runs only its benchmarks;
# the ctest bench.runner uses a short one). Only a full run with the default list and output
# rewrites the table in docs/performance.md.
#
# Benchmarks print ratios against baselines measured in the same run; absolute times on this
# 2-core machine drift with its load, ratios much less.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${BUILD_DIR:-build}
MODE=full
[ "${1:-}" = "--smoke" ] && MODE=smoke
OUT=${BENCH_OUT:-bench/results/latest.json}
LIST=${BENCH_LIST:-bench/list.txt}
# A hanging benchmark must not hang the run (nor ctest's bench.runner): per benchmark, seconds.
TIMEOUT_S=${BENCH_TIMEOUT_S:-$([ "$MODE" = full ] && echo 1800 || echo 120)}
if [ ! -r "$LIST" ]; then
  echo "bench: list $LIST not readable" >&2
  exit 2
fi
LOG_DIR=$(mktemp -d /tmp/drivegw-bench.XXXXXX)
trap 'rm -rf "$LOG_DIR"' EXIT

# name | full-mode arguments | smoke-mode arguments. Every benchmark binary in bench/CMakeLists.txt
# that reports a target is listed here; bench/list.txt is the single list (one line each).
mapfile -t BENCHES < <(grep -v '^\s*#' "$LIST" | sed '/^\s*$/d')
status=0
for line in "${BENCHES[@]}"; do
  IFS='|' read -r name full smoke <<<"$line"
  name=$(echo "$name" | xargs)
  args=$([ "$MODE" = full ] && echo "$full" || echo "$smoke")
  bin=$BUILD_DIR/bench/$name
  if [ ! -x "$bin" ]; then
    echo "bench: $name not built ($bin)" >&2
    status=1
    continue
  fi
  echo "== $name $args"
  # shellcheck disable=SC2086
  if ! timeout --kill-after=10 "$TIMEOUT_S" "$bin" $args | tee "$LOG_DIR/$name.log"; then
    echo "bench: $name failed" >&2
    status=1
  fi
done
shopt -s nullglob
python3 scripts/bench_collect.py "$MODE" "$OUT" "$LOG_DIR"/*.log
if [ "$MODE" = full ] && [ -z "${BENCH_LIST:-}" ] && [ -z "${BENCH_OUT:-}" ]; then
  python3 scripts/bench_collect.py --table "$OUT" docs/performance.md
fi
exit $status
