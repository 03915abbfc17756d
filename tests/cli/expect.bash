# The checks the command-line tests share; sourced (not a test itself: CMake runs tests/cli/*.sh).
# The sourcing script sets `cli` (the greybench-cli executable) first, and may set
# EXPECT_TIMEOUT (seconds one run may take; default 10).
failures=0
passes=0

# check DESCRIPTION COMMAND...: runs COMMAND and counts a pass if it succeeds.
check() {
  local what=$1
  shift
  if "$@"; then passes=$((passes + 1)); else echo "FAIL: $what"; failures=$((failures + 1)); fi
}

# expect CODE REGEX -- ARGS...: runs the CLI and checks its exit status and that stderr matches.
expect() {
  local code=$1 pattern=$2
  shift 3
  local err status
  err=$(timeout "${EXPECT_TIMEOUT:-10}" "$cli" "$@" 2>&1 >/dev/null)
  status=$?
  if [ "$status" -ne "$code" ] || ! grep -Eq -- "$pattern" <<<"$err"; then
    echo "FAIL: greybench-cli $*"
    echo "      expected exit $code and /$pattern/, got exit $status: $err"
    failures=$((failures + 1))
  else
    passes=$((passes + 1))
  fi
}

# expect_kept CODE REGEX -- ARGS...: expect, and every file in the script's array `kept` (its
# inputs and earlier outputs) byte for byte as before the run (sha256sum).
expect_kept() {
  local before after
  before=$(sha256sum "${kept[@]}" 2>&1)
  expect "$@"
  after=$(sha256sum "${kept[@]}" 2>&1)
  if [ "$before" != "$after" ]; then
    echo "FAIL: greybench-cli ${*:4}"
    echo "      changed a file it was given: $(diff <(echo "$before") <(echo "$after") | grep '^>')"
    failures=$((failures + 1))
  else
    passes=$((passes + 1))
  fi
}

# summary [NAME]: prints the counts and is the script's exit status: it fails when a check failed
# and when none ran (a script whose checks never ran, say because it lost this file's `source`
# line, would otherwise pass without testing anything).
summary() {
  echo "${1:+$1: }$passes passed, $failures failed"
  [ "$failures" -eq 0 ] && [ "$passes" -gt 0 ]
}
