#!/usr/bin/env bash
# Builds greybench and its whole test suite with AddressSanitizer (leak checking included) and
# UndefinedBehaviorSanitizer in build-asan/, runs ctest, and fails on any test failure or any
# sanitizer report.
#   scripts/sanitize.sh            configure, build, test
# Reports are written to build-asan/sanitizer-logs/ (one file per reporting process) as well as
# to stderr, so a report from a process whose exit status a test expects to be non-zero (the
# command-line error tests) still fails the run. Leaks inside Mesa/GLFW/X11 (system libraries the
# UI tests load) are suppressed by tests/sanitize/lsan.supp; our code is never suppressed.
# Extra CMake arguments: GREYBENCH_CMAKE_ARGS (e.g. -DCMAKE_CXX_COMPILER_LAUNCHER=ccache).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
build=build-asan
jobs=${GREYBENCH_JOBS:-2}

sanitize="-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined"
# -O2 -g: at -O1 Eigen is not inlined and the slowest test takes 281 s instead of 22 s; stack
# traces stay readable with frame pointers. Assertions stay on (no NDEBUG).
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -g" \
  -DCMAKE_CXX_FLAGS="$sanitize" \
  -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" \
  -DGREYBENCH_BUILD_BENCHMARKS=OFF ${GREYBENCH_CMAKE_ARGS:-}
cmake --build "$build" -j "$jobs"

logs=$root/$build/sanitizer-logs
rm -rf "$logs"
mkdir -p "$logs"
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=0:log_path=$logs/asan:log_exe_name=1"
export LSAN_OPTIONS="suppressions=$root/tests/sanitize/lsan.supp:print_suppressions=0"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1:log_path=$logs/ubsan:log_exe_name=1"

status=0
ctest --test-dir "$build" --output-on-failure -j "$jobs" --timeout 1200 || status=$?

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
