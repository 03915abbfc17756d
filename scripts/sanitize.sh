#!/usr/bin/env bash
# Builds greybench, its whole test suite and the libFuzzer targets with clang, AddressSanitizer
# (leak checking included) and UndefinedBehaviorSanitizer in build-asan/, runs ctest, and fails on
# any test failure or any sanitizer report.
#   scripts/sanitize.sh            configure, build, test
# One build serves two gates (docs/quality.md): everything is compiled with
# -fsanitize=address,undefined (GREYBENCH_FUZZ=ON), the file readers of core/ with libFuzzer's
# coverage instrumentation (-fsanitize=fuzzer-no-link) too, so the fuzz targets that
# scripts/fuzz.sh runs are built here, from the same objects. -O1 -gline-tables-only:
# libFuzzer's usual level, and line tables are all a stack trace needs (full -g made the build
# three times as long). Assertions stay on (no NDEBUG). The filter loops have fixed-size
# instantiations for 1 and 2 states only (GREYBENCH_FIXED_STATES; 1-8 in the release build): the
# same code, a third of its compile time; larger models run the dynamic-size loop here.
# Tests whose point under the sanitizers is the code path run on smaller data here
# (core/util/sanitizers.h: kSanitized); each says so, and the few skipped there say why. Tests
# labelled not_sanitized (goldens that estimate or run, whose code other tests run under the
# sanitizers; tests/ui/CMakeLists.txt says which) are left out.
# Reports are written to build-asan/sanitizer-logs/ (one file per reporting process) as well as
# to stderr, so a report from a process whose exit status a test expects to be non-zero (the
# command-line error tests) still fails the run. Leaks inside Mesa/GLFW/X11 (system libraries the
# UI tests load) are suppressed by tests/sanitize/lsan.supp; our code is never suppressed.
# Environment: GREYBENCH_CMAKE_ARGS (extra CMake arguments), GREYBENCH_JOBS (jobs, default nproc).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
build=build-asan
jobs=${GREYBENCH_JOBS:-$(nproc)}

if ! command -v clang++ >/dev/null; then
  echo "sanitize.sh: clang++ is needed (apt-get install clang libclang-rt-dev)" >&2
  exit 2
fi
start=$SECONDS
CXX=clang++ cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -gline-tables-only" -DGREYBENCH_FUZZ=ON \
  -DGREYBENCH_BUILD_BENCHMARKS=OFF -DGREYBENCH_UNITY=ON -DGREYBENCH_UNITY_CORE=ON \
  -DGREYBENCH_FIXED_STATES=2 \
  ${GREYBENCH_CMAKE_ARGS:-}
cmake --build "$build" -j "$jobs"
echo "sanitize.sh: build took $(( (SECONDS - start) / 60 )) min $(( (SECONDS - start) % 60 )) s"

logs=$root/$build/sanitizer-logs
rm -rf "$logs"
mkdir -p "$logs"
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=0:log_path=$logs/asan:log_exe_name=1"
export LSAN_OPTIONS="suppressions=$root/tests/sanitize/lsan.supp:print_suppressions=0"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1:log_path=$logs/ubsan:log_exe_name=1"

start=$SECONDS
status=0
ctest --test-dir "$build" --output-on-failure -j "$jobs" --timeout 1200 -LE not_sanitized ||
  status=$?
echo "sanitize.sh: the suite took $(( (SECONDS - start) / 60 )) min $(( (SECONDS - start) % 60 )) s"

reports=$(find "$logs" -type f | sort)
if [ -n "$reports" ]; then
  echo "sanitize.sh: sanitizer reports:" >&2
  for f in $reports; do
    echo "==== $f" >&2
    cat "$f" >&2
  done
  status=1
fi
if [ "$status" -eq 0 ]; then
  echo "sanitize.sh: all tests passed with no sanitizer report"
fi
exit "$status"
