#!/usr/bin/env bash
# The quality gates of docs/quality.md, as CI runs them after the test suite:
#   1. scripts/sanitize.sh       one clang build with ASan + UBSan + libFuzzer's instrumentation
#                                (build-asan/), and the whole test suite under the sanitizers
#   2. scripts/fuzz.sh SECONDS   each libFuzzer target for SECONDS (default 60), built by 1
#   3. scripts/static-checks.sh  the include order of core/ and ui/, clang-tidy and cppcheck on
#                                core/ (needs build/, from dev.sh),
#                                in the background beside 1 and 2 at nice 19
# Installs what the gates need and the normal set-up does not (clang with the libFuzzer runtime,
# clang-tidy, cppcheck) with apt-get when missing. Runs every gate even when one fails, prints a
# summary with each gate's time, and exits 1 if any failed.
#   scripts/quality.sh [SECONDS]
set -uo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}

packages=(clang libclang-rt-dev clang-format clang-tidy cppcheck)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "quality: installing ${missing[*]}"
  sudo=""
  [ "$(id -u)" -ne 0 ] && sudo="sudo"
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends \
    "${missing[@]}" || exit 2
fi
if [ ! -f build/compile_commands.json ]; then
  echo "quality: build/ is not configured; run scripts/dev.sh build first" >&2
  exit 2
fi

summary=()
status=0
gate() {
  local name=$1
  shift
  echo "quality: === $name: $*"
  local start=$SECONDS rc=0
  "$@" || rc=$?
  local took=$((SECONDS - start))
  if [ "$rc" -eq 0 ]; then
    summary+=("passed  $name ($((took / 60)) min $((took % 60)) s)")
  else
    summary+=("FAILED  $name, exit $rc ($((took / 60)) min $((took % 60)) s)")
    status=1
  fi
}
# The static checks need only build/ and run beside the other gates at the lowest priority: they
# take the CPU the sanitizer build and suite leave idle (link steps, the suite's last tests, the
# fuzz targets that run alone) and yield it otherwise. Their output is printed when they end.
# Their time is taken when they end (written by the background job), not when the summary
# collects them after the last gate.
static_log=$(mktemp)
static_end=$(mktemp)
static_start=$(date +%s)
(
  nice -n 19 env JOBS="$(nproc)" scripts/static-checks.sh build >"$static_log" 2>&1
  rc=$?
  date +%s >"$static_end"
  exit "$rc"
) &
static_pid=$!

gate sanitizers scripts/sanitize.sh
gate fuzzing scripts/fuzz.sh "$seconds"

echo "quality: === static-checks: scripts/static-checks.sh build (beside the gates above, nice 19)"
static_rc=0
wait "$static_pid" || static_rc=$?
cat "$static_log"
static_done=$(cat "$static_end")
[ -n "$static_done" ] || static_done=$(date +%s)
took=$((static_done - static_start))
rm -f "$static_log" "$static_end"
if [ "$static_rc" -eq 0 ]; then
  summary+=("passed  static-checks (ended $((took / 60)) min $((took % 60)) s after the gates started, beside them)")
else
  summary+=("FAILED  static-checks, exit $static_rc (ended $((took / 60)) min $((took % 60)) s after the gates started)")
  status=1
fi

echo "quality: summary (gate, wall time)"
printf '  %s\n' "${summary[@]}"
echo "  all gates: $((SECONDS / 60)) min $((SECONDS % 60)) s"
exit "$status"
