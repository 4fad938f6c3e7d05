#!/usr/bin/env bash
# Builds every libFuzzer target (tests/fuzz/*_fuzz.cpp) in a clang tree of its own and runs each
# for a given time (docs/reliability.md "Fuzzing", decision 1402).
#   scripts/fuzz.sh 60                  60 s per target, every target
#   scripts/fuzz.sh 300 rest_body stober   only these targets (names without _fuzz)
# Env: FUZZ_JOBS (ninja -j, default 1), FUZZ_BUILD (default <repo>/build-fuzz), FUZZ_CC/FUZZ_CXX
# (default clang-14/clang++-14; scripts/install-deps.sh installs them with libfuzzer-14-dev),
# FUZZ_NO_BUILD=1 (run the binaries already built), FUZZ_REPORT (default findings/report.md).
#
# build-fuzz/ is separate from build/ by necessity: libFuzzer needs clang (-fsanitize=fuzzer)
# and every library is instrumented (-DDGW_FUZZ=ON), the normal build is gcc. Each target starts
# from a scratch copy of its committed corpus (tests/fuzz/corpus/<name>/), so the committed
# corpus grows only when someone copies an input in on purpose. Crash, leak, timeout and OOM
# inputs land in build-fuzz/findings/<name>-*, each run's log in build-fuzz/findings/<name>.log,
# and a Markdown table of the run (target, seconds, executions, exec/s, corpus size before and
# after, findings) in build-fuzz/findings/report.md. Exit 1 when anything was found.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
SECONDS_PER_TARGET=${1:?usage: scripts/fuzz.sh SECONDS [TARGET...]}
shift
BUILD=${FUZZ_BUILD:-$ROOT/build-fuzz}
export CCACHE_DIR=${CCACHE_DIR:-$HOME/.cache/ccache} CCACHE_BASEDIR=$ROOT CCACHE_NOHASHDIR=true
# UBSan reports must stop the run (the build uses the recovering default); leaks are findings.
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1}

if [ ! -f "$BUILD/build.ninja" ]; then
  cmake -S "$ROOT" -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DDGW_FUZZ=ON \
    -DCMAKE_C_COMPILER="${FUZZ_CC:-clang-14}" -DCMAKE_CXX_COMPILER="${FUZZ_CXX:-clang++-14}"
fi
if [ $# -gt 0 ]; then
  targets=("$@")
else
  mapfile -t targets < <(cd "$ROOT/tests/fuzz" && ls ./*_fuzz.cpp | sed 's#^\./##; s#_fuzz\.cpp$##')
fi
if [ -z "${FUZZ_NO_BUILD:-}" ]; then
  nice ninja -C "$BUILD" -j"${FUZZ_JOBS:-1}" "${targets[@]/%/_fuzz}"
fi

findings=$BUILD/findings
mkdir -p "$findings"
report=${FUZZ_REPORT:-$findings/report.md}
{
  echo "| target | seconds | executions | exec/s | corpus (seeds → after run) | findings |"
  echo "|---|---|---|---|---|---|"
} >"$report"
found=0
for t in "${targets[@]}"; do
  work=$(mktemp -d "$BUILD/fuzz-work-$t.XXXXXX")
  cp -r "$ROOT/tests/fuzz/corpus/$t/." "$work/"
  rm -f "$work"/*.md
  seeds=$(find "$work" -type f | wc -l)
  log=$findings/$t.log
  echo "fuzz: $t for ${SECONDS_PER_TARGET}s (log $log)"
  rc=0
  nice "$BUILD/tests/fuzz/${t}_fuzz" -max_total_time="$SECONDS_PER_TARGET" -timeout=10 \
    -rss_limit_mb=2048 -print_final_stats=1 -artifact_prefix="$findings/$t-" "$work" \
    >"$log" 2>&1 || rc=$?
  execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || true)
  rate=$(grep -o 'stat::average_exec_per_sec: *[0-9]*' "$log" | grep -o '[0-9]*$' || true)
  after=$(find "$work" -type f | wc -l)
  n=$(find "$findings" -maxdepth 1 -name "$t-*" -type f | wc -l)
  what=none
  if [ "$rc" -ne 0 ] || [ "$n" -gt 0 ]; then
    found=1
    what="$n input(s), exit $rc: $(grep -m1 -oE 'ERROR: [A-Za-z]+: [^ ]+|runtime error: .*' "$log" || echo see log)"
  fi
  echo "| $t | $SECONDS_PER_TARGET | ${execs:-?} | ${rate:-?} | $seeds → $after | $what |" >>"$report"
  rm -rf "$work"
done
cat "$report"
exit $found
