#!/usr/bin/env bash
# Builds the libFuzzer targets (tests/fuzz, clang, ASan + UBSan) in build-asan/, the build
# scripts/sanitize.sh makes for the whole suite (after it, nothing is left to build), and runs
# each for SECONDS (default 60), FUZZ_PARALLEL (default: the number of cores, at most the number
# of targets) at a time. Fails on any crash, hang, leak or sanitizer report.
#   scripts/fuzz.sh [SECONDS]
# Each target starts from its seed corpus tests/fuzz/corpus/<target>/ (kept in the repository,
# never written by this script) plus what earlier runs found in build-asan/corpus/<target>/.
# A crashing input is written to build-asan/artifacts/; reproduce it with
#   build-asan/tests/fuzz/<target>_fuzz build-asan/artifacts/<file>
# Environment: GREYBENCH_CMAKE_ARGS (extra CMake arguments), GREYBENCH_JOBS (build jobs, nproc),
# FUZZ_PARALLEL (targets run at once), FUZZ_ARGS (extra libFuzzer flags, e.g. "-jobs=2").
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
seconds=${1:-60}
build=build-asan
jobs=${GREYBENCH_JOBS:-$(nproc)}
parallel=${FUZZ_PARALLEL:-$(nproc)}
# cli drives the whole command line (tests/fuzz/cli_fuzz.cpp); mdf4 the ASAM MDF 4 reader
# (tests/fuzz/mdf4_fuzz.cpp). On CI's 2 cores the five targets run in three rounds of SECONDS.
targets=(csv model project cli mdf4)

if ! command -v clang++ >/dev/null; then
  echo "fuzz.sh: clang++ is needed (apt-get install clang libclang-rt-dev)" >&2
  exit 2
fi
# The libFuzzer runtime is in libclang-rt-<version>-dev; the normal build does not need it.
if ! echo 'extern "C" int LLVMFuzzerTestOneInput(const char*, unsigned long) { return 0; }' |
    clang++ -x c++ -fsanitize=fuzzer - -o /dev/null 2>/dev/null; then
  echo "fuzz.sh: installing the libFuzzer runtime (libclang-rt-dev)"
  sudo=""
  [ "$(id -u)" -ne 0 ] && sudo="sudo"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends libclang-rt-dev
fi

# The configuration of scripts/sanitize.sh (the same build directory must not be configured two
# ways): -O1 -gline-tables-only, assertions on (no NDEBUG): an assertion reached from a file is
# a bug too.
CXX=clang++ cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -gline-tables-only" -DGREYBENCH_FUZZ=ON \
  -DGREYBENCH_BUILD_BENCHMARKS=OFF ${GREYBENCH_CMAKE_ARGS:-} >/dev/null
cmake --build "$build" -j "$jobs" --target "${targets[@]/%/_fuzz}"

export ASAN_OPTIONS="detect_leaks=1"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1"
mkdir -p "$build/artifacts"
# One target: its log in $build/<target>.log, its exit status in $build/<target>.rc.
run() {
  local t=$1
  local corpus=$build/corpus/$t
  mkdir -p "$corpus"
  local dict=()
  [ -f "tests/fuzz/$t.dict" ] && dict=(-dict="tests/fuzz/$t.dict")
  # rss_limit and timeout: a slow or memory-hungry input is a failure too. cli's inputs are whole
  # commands, whose fits take seconds under the sanitizers (a sweep of 3 files about 6 s).
  local timeout=10
  [ "$t" = cli ] && timeout=25
  local rc=0
  "$build/tests/fuzz/${t}_fuzz" "$corpus" "tests/fuzz/corpus/$t" "${dict[@]}" \
    -max_total_time="$seconds" -timeout="$timeout" -rss_limit_mb=2048 -max_len=8192 \
    -artifact_prefix="$root/$build/artifacts/$t-" -print_final_stats=1 ${FUZZ_ARGS:-} \
    >"$build/$t.log" 2>&1 || rc=$?
  echo "$rc" >"$build/$t.rc"
}

rm -f "$build"/*.rc
status=0
running=0
for t in "${targets[@]}"; do
  echo "fuzz.sh: $t for ${seconds} s"
  run "$t" &
  running=$((running + 1))
  if [ "$running" -ge "$parallel" ]; then
    wait -n || true
    running=$((running - 1))
  fi
done
wait
for t in "${targets[@]}"; do
  echo "fuzz.sh: $t:"
  grep -E "DONE|^stat::(number_of_executed_units|peak_rss_mb|new_units_added)" "$build/$t.log" || true
  if [ "$(cat "$build/$t.rc" 2>/dev/null || echo 1)" -ne 0 ]; then
    tail -n 60 "$build/$t.log" >&2
    echo "fuzz.sh: $t FAILED (log: $build/$t.log, input in $build/artifacts/)" >&2
    status=1
  fi
done
[ "$status" -eq 0 ] && echo "fuzz.sh: no crash in ${targets[*]} (${seconds} s each)"
exit "$status"
