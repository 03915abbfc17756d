#!/usr/bin/env bash
# Builds the libFuzzer targets (tests/fuzz, clang, ASan + UBSan) in build-fuzz/ and runs each for
# SECONDS (default 60), one after another. Fails on any crash, hang, leak or sanitizer report.
#   scripts/fuzz.sh [SECONDS]
# Each target starts from its seed corpus tests/fuzz/corpus/<target>/ (kept in the repository,
# never written by this script) plus what earlier runs found in build-fuzz/corpus/<target>/.
# A crashing input is written to build-fuzz/artifacts/; reproduce it with
#   build-fuzz/tests/fuzz/<target>_fuzz build-fuzz/artifacts/<file>
# Environment: GREYBENCH_CMAKE_ARGS (extra CMake arguments), GREYBENCH_JOBS (build jobs, 2),
# FUZZ_ARGS (extra libFuzzer flags, e.g. "-jobs=2").
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
seconds=${1:-60}
build=build-fuzz
jobs=${GREYBENCH_JOBS:-2}
targets=(csv model project)

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

# -O1 -g, assertions on (no NDEBUG): an assertion reached from a file is a bug too.
CXX=clang++ cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g" -DGREYBENCH_FUZZ=ON \
  -DGREYBENCH_BUILD_UI=OFF -DGREYBENCH_BUILD_TESTS=OFF -DGREYBENCH_BUILD_BENCHMARKS=OFF \
  ${GREYBENCH_CMAKE_ARGS:-}
cmake --build "$build" -j "$jobs" --target "${targets[@]/%/_fuzz}"

export ASAN_OPTIONS="detect_leaks=1"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1"
mkdir -p "$build/artifacts"
status=0
for t in "${targets[@]}"; do
  corpus=$build/corpus/$t
  mkdir -p "$corpus"
  dict=()
  [ -f "tests/fuzz/$t.dict" ] && dict=(-dict="tests/fuzz/$t.dict")
  echo "fuzz.sh: $t for ${seconds} s"
  # rss_limit and timeout: a slow or memory-hungry input is a failure too.
  rc=0
  "$build/tests/fuzz/${t}_fuzz" "$corpus" "tests/fuzz/corpus/$t" "${dict[@]}" \
    -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len=8192 \
    -artifact_prefix="$root/$build/artifacts/$t-" -print_final_stats=1 ${FUZZ_ARGS:-} \
    >"$build/$t.log" 2>&1 || rc=$?
  grep -E "DONE|^stat::(number_of_executed_units|peak_rss_mb|new_units_added)" "$build/$t.log" || true
  if [ "$rc" -ne 0 ]; then
    tail -n 60 "$build/$t.log" >&2
    echo "fuzz.sh: $t FAILED (log: $build/$t.log, input in $build/artifacts/)" >&2
    status=1
  fi
done
[ "$status" -eq 0 ] && echo "fuzz.sh: no crash in ${targets[*]} (${seconds} s each)"
exit "$status"
