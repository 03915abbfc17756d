#!/usr/bin/env bash
# greybench-cli dyno --live: the live fuel experiment streamed as CSV. Without faults its rows are
# the batch record's, byte for byte; --fault steps, ramps and clears show in the --truth columns
# and change the output only from their time on; --speed paces the rows; a reader that goes away
# ends the run with exit 0; bad fault specs are errors naming the argument.
# Usage: dyno.sh GREYBENCH_CLI TEST_DATA_DIR
set -u
cli=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
source "$(dirname "${BASH_SOURCE[0]}")/expect.bash"
live() { timeout 10 "$cli" dyno fuel --live "$@" 2>"$tmp/err"; }

# --- without faults: the batch record's rows -----------------------------------------------------
live --speed 0 --duration 2 >"$tmp/live.csv"
check "--live exits 0" test $? -eq 0 -a ! -s "$tmp/err"
"$cli" dyno fuel --duration 2 --out "$tmp/batch.csv"
check "--live rows equal the batch record's" \
  cmp -s <(grep -v '^#' "$tmp/live.csv") <(grep -v '^#' "$tmp/batch.csv")
check "--live: 160 rows after the header" test "$(grep -vc '^#' "$tmp/live.csv")" -eq 161

# --- faults: the truth columns follow them; the output changes only from their time on ----------
# rows FILE: the CSV's rows as dicts of floats
rows_py='
import csv, sys
def rows(path):
    lines = [l for l in open(path) if not l.startswith("#")]
    return [{k: float(v) for k, v in r.items()} for r in csv.DictReader(lines)]
'
live --speed 0 --duration 2 --truth --fault 1:tau_ff*1.5 >"$tmp/step.csv"
check "a step in tau_ff at 1 s" python3 -c "$rows_py
plain, step = rows('$tmp/live.csv'), rows('$tmp/step.csv')
assert list(step[0]) == ['t', 'mfi', 'ilambda', 'true_tau_ff', 'true_X', 'true_delay', 'true_Kb']
assert len(step) == 160
for p, s in zip(plain, step):
    assert s['true_tau_ff'] == (0.5625 if s['t'] >= 1 else 0.375), s
    assert (s['true_X'], s['true_delay'], s['true_Kb']) == (0.175, 0.0625, 0.8421), s
    assert s['mfi'] == p['mfi'], s
    if s['t'] <= 1: assert s['ilambda'] == p['ilambda'], (s, p)
assert any(s['ilambda'] != p['ilambda'] for p, s in zip(plain, step))
"

live --speed 0 --duration 2 --truth --fault 0.5:tau_ff*2/1 --fault 0.5:gain*0.9 \
  --fault 0.75:X*2 --fault 0.75:delay*2 --fault 1.75:clear >"$tmp/ramp.csv"
check "a ramp, steps and a clear" python3 -c "$rows_py
by_t = {r['t']: r for r in rows('$tmp/ramp.csv')}
assert abs(by_t[1.0]['true_tau_ff'] - 0.5625) < 1e-15, by_t[1.0]
assert by_t[1.5]['true_tau_ff'] == 0.75 and by_t[1.7375]['true_tau_ff'] == 0.75
assert by_t[0.4875]['true_Kb'] == 0.8421 and by_t[0.5]['true_Kb'] == 0.8421 * 0.9
assert by_t[0.75]['true_X'] == 0.35 and by_t[0.75]['true_delay'] == 0.125
assert by_t[1.75]['true_tau_ff'] == 0.375 and by_t[1.75]['true_X'] == 0.175
assert by_t[1.75]['true_delay'] == 0.0625 and by_t[1.75]['true_Kb'] == 0.8421
"

# --- the same run twice gives the same rows; --out writes them to a file -------------------------
live --speed 0 --duration 2 --truth --fault 0.5:tau_ff*2/1 --fault 0.5:gain*0.9 \
  --fault 0.75:X*2 --fault 0.75:delay*2 --fault 1.75:clear --out "$tmp/again.csv"
check "--out: the same rows again" cmp -s "$tmp/ramp.csv" "$tmp/again.csv"

# --- pacing ----------------------------------------------------------------------------------------
start=$(date +%s%N)
live --duration 0.5 >/dev/null
ms=$((($(date +%s%N) - start) / 1000000))
check "--speed 1 (default) takes real time: 0.5 s of data in $ms ms" test "$ms" -ge 450 -a "$ms" -lt 3000
start=$(date +%s%N)
live --speed 5 --duration 1 >/dev/null
ms=$((($(date +%s%N) - start) / 1000000))
check "--speed 5: 1 s of data in $ms ms" test "$ms" -ge 180 -a "$ms" -lt 1500

# --- without end, until the reader goes away: exit 0, nothing on stderr ----------------------------
timeout 10 "$cli" dyno fuel --live --speed 0 2>"$tmp/err" | head -n 20 >/dev/null
status=${PIPESTATUS[0]}
check "a reader that goes away ends the run with exit 0 (got $status)" test "$status" -eq 0
check "... quietly" test ! -s "$tmp/err"

# --- bad input -------------------------------------------------------------------------------------
expect 2 "--fault '60': expected TIME:PARAMETER\*FACTOR\[/RAMP\]" -- dyno fuel --live --fault 60
expect 2 "--fault '-1:X\*2': the time '-1' is not a number of seconds >= 0" -- dyno fuel --live --fault=-1:X*2
expect 2 "--fault '5:tauff\*2': unknown parameter 'tauff'" -- dyno fuel --live --fault '5:tauff*2'
expect 2 "--fault '5:tau_ff\*abc': the factor 'abc' is not a number" -- dyno fuel --live --fault '5:tau_ff*abc'
expect 2 "--fault '5:tau_ff\*2/x': the ramp 'x' is not a number" -- dyno fuel --live --fault '5:tau_ff*2/x'
expect 2 "--fault '5:tau_ff\*0': the factor of tau_ff must be a finite number > 0" -- dyno fuel --live --fault '5:tau_ff*0'
expect 2 "--fault '9:X\*3': X would become 1.05 \(0.35 x 3\): it must stay within \[0, 1\]" -- dyno fuel --live --fault '5:X*2' --fault '9:X*3'
expect 2 "--fault '5:delay\*100': .*longer than the 1 s the delay line holds" -- dyno fuel --live --fault '5:delay*100'
expect 2 "--fault '3:gain\*2': 3 s is not before the end of the run \(--duration 2\)" -- dyno fuel --live --duration 2 --fault '3:gain*2'
expect 2 "--speed -1: expected a factor of real time >= 0" -- dyno fuel --live --speed -1
expect 2 "--fault requires --live" -- dyno fuel --fault '5:X*2' --out "$tmp/x.csv"
expect 2 "--live streams the fuel experiment, not crankshaft" -- dyno crankshaft --live
expect 2 "dyno: --out is required" -- dyno fuel

summary
