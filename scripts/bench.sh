#!/usr/bin/env bash
# Runs every benchmark in bench/ (issue 10) on the built tree and collects their @result lines
# (bench/report.h) into bench/results/latest.json and the results table of docs/performance.md
# (between the bench:results markers).
#
#   scripts/bench.sh            full runs: minutes; the numbers of record (quiet machine!)
#   scripts/bench.sh --smoke    seconds per benchmark, only proves they work (ctest does this)
#
# Benchmarks print ratios against baselines measured in the same run; absolute times on this
# 2-core machine drift with its load, ratios much less.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${BUILD_DIR:-build}
MODE=full
[ "${1:-}" = "--smoke" ] && MODE=smoke
OUT=${BENCH_OUT:-bench/results/latest.json}
LOG_DIR=$(mktemp -d /tmp/drivegw-bench.XXXXXX)
trap 'rm -rf "$LOG_DIR"' EXIT

# name | full-mode arguments | smoke-mode arguments. Every benchmark binary in bench/CMakeLists.txt
# that reports a target is listed here; bench/list.txt is the single list (one line each).
mapfile -t BENCHES < <(grep -v '^\s*#' bench/list.txt | sed '/^\s*$/d')
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
  if ! "$bin" $args | tee "$LOG_DIR/$name.log"; then
    echo "bench: $name failed" >&2
    status=1
  fi
done
python3 scripts/bench_collect.py "$MODE" "$OUT" "$LOG_DIR"/*.log
[ "$MODE" = full ] && python3 scripts/bench_collect.py --table "$OUT" docs/performance.md
exit $status
