#!/usr/bin/env bash
# greybench-cli dyno --live: the live fuel experiment streamed as CSV. Without faults its rows are
# the batch record's, byte for byte; --fault steps, ramps and clears show in the --truth columns
# and change the output only from their time on; --speed paces the rows; a reader that goes away
# ends the run with exit 0; bad fault specs are errors naming the argument. Every dyno experiment's
# options: a value that is 0, negative, NaN, inf, empty or not whole is refused naming the option
# and its range (never taken for the default), an option the experiment would ignore is refused,
# the record's limits are refused with the limit, faults beyond 100 times nominal are refused; each
# refusal leaves an earlier record byte for byte as it was.
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
expect 2 "--speed: '-1' is not a number >= 0" -- dyno fuel --live --speed -1
expect 2 "--fault requires --live" -- dyno fuel --fault '5:X*2' --out "$tmp/x.csv"
expect 2 "--live streams the fuel experiment, not crankshaft" -- dyno crankshaft --live
expect 2 "dyno: --out is required" -- dyno fuel

# --- the options' values: 0, negative, NaN, inf, empty or not whole never become the default -----
# Each refusal leaves an earlier record (the --out given) byte for byte as it was.
"$cli" dyno fuel --duration 1 --out "$tmp/earlier.csv"
kept=("$tmp/earlier.csv")
out=(--out "$tmp/earlier.csv")
expect_kept 2 "--duration: '0' is not a number of seconds > 0" -- dyno engine --duration 0 "${out[@]}"
expect_kept 2 "--duration: 'nan' is not a number of seconds > 0" -- dyno fuel --duration nan "${out[@]}"
expect_kept 2 "--duration: 'inf' is not a number of seconds > 0" -- dyno crankshaft --duration inf "${out[@]}"
expect_kept 2 "--duration: '' is not a number of seconds > 0" -- dyno square-wave --duration '' "${out[@]}"
expect_kept 2 "--oversample: '0' is not a whole number in \[1, 1000\]" -- dyno engine --oversample 0 "${out[@]}"
expect_kept 2 "--oversample: '2.5' is not a whole number in \[1, 1000\]" -- dyno fuel --oversample 2.5 "${out[@]}"
expect_kept 2 "--oversample: '5000' is not a whole number" -- dyno fuel --oversample 5000 "${out[@]}"
expect_kept 2 "--sample-time: '0' is not a number of seconds in \[0.001, 1\]" -- dyno engine --sample-time 0 "${out[@]}"
expect_kept 2 "--bit-period: '0' is not a number of seconds > 0" -- dyno engine --bit-period 0 "${out[@]}"
expect_kept 2 "--bit-period: '-0.5' is not a number of seconds > 0" -- dyno crankshaft --bit-period -0.5 "${out[@]}"
expect_kept 2 "--order: '0' is not a whole number in \[2, 24\]" -- dyno engine --order 0 "${out[@]}"
expect_kept 2 "--order: '25' is not a whole number in \[2, 24\]" -- dyno fuel --order 25 "${out[@]}"
expect_kept 2 "--throttle-amplitude: '-1' is not a number of degrees in \[0, 10\]" -- dyno engine --throttle-amplitude -1 "${out[@]}"
expect_kept 2 "--throttle-amplitude: 'nan' is not a number of degrees" -- dyno engine --throttle-amplitude nan "${out[@]}"
expect_kept 2 "--hold: '-1' is not a number of seconds >= 0" -- dyno engine --path f1,f3 --hold -1 "${out[@]}"
expect_kept 2 "--ramp: '0' is not a number of seconds > 0" -- dyno engine --path f1,f3 --ramp 0 "${out[@]}"
expect_kept 2 "--seed: '-1' is not a whole number in \[0, 18446744073709551615\]" -- dyno fuel --seed -1 "${out[@]}"
expect_kept 2 "--seed: '' is not a whole number" -- dyno fuel --seed '' "${out[@]}"
expect_kept 2 "--speed: 'nan' is not a number >= 0" -- dyno fuel --live --speed nan --duration 1 "${out[@]}"
expect_kept 2 "--duration 1e\+300: expected seconds > 0 giving at most 9.01e\+15 samples \(leave --duration out" -- \
  dyno fuel --live --speed 0 --duration 1e300 "${out[@]}"
# --throttle-amplitude 0 is the paper's experiment (fuel PRBS only), not the default.
"$cli" dyno engine --point f1 --duration 1 --throttle-amplitude 0 --out "$tmp/still.csv"
check "--throttle-amplitude 0: the throttle is still" bash -c \
  "grep -q 'throttle +/- 0 deg PRBS' '$tmp/still.csv' && grep -v '^#' '$tmp/still.csv' | tail -n +2 | cut -d, -f2 | sort -u | wc -l | grep -qx 1"

# --- options the experiment would ignore are refused -----------------------------------------------
expect_kept 2 "--point and --path: give one" -- dyno engine --point f1 --path f1,f3 "${out[@]}"
expect_kept 2 "--hold: only a sweep \(--path\) takes it" -- dyno engine --point f1 --hold 5 "${out[@]}"
expect_kept 2 "--ramp: only a sweep \(--path\) takes it" -- dyno engine --ramp 5 "${out[@]}"
expect_kept 2 "--path 'f1': a sweep needs two points or more \(for one, use --point\)" -- dyno engine --path f1 "${out[@]}"
expect_kept 2 "--sample-time: only the engine experiment takes it, not fuel" -- dyno fuel --sample-time 0.01 "${out[@]}"
expect_kept 2 "--hold-speed: only the engine experiment takes it, not crankshaft" -- dyno crankshaft --hold-speed "${out[@]}"
expect_kept 2 "--throttle-amplitude: only the engine experiment takes it, not fuel" -- dyno fuel --throttle-amplitude 2 "${out[@]}"
expect_kept 2 "--path: only the engine experiment takes it, not fuel" -- dyno fuel --path f1,f3 "${out[@]}"
expect_kept 2 "--point: only the fuel and engine experiments take it, not crankshaft" -- dyno crankshaft --point f1 "${out[@]}"
expect_kept 2 "--order: only the fuel, crankshaft and engine experiments take it, not square-wave" -- dyno square-wave --order 5 "${out[@]}"
expect_kept 2 "--constant-load: only the crankshaft experiment takes it, not engine" -- dyno engine --constant-load "${out[@]}"
expect_kept 2 "--lambda-sensor: only the engine experiment takes it, not fuel" -- dyno fuel --lambda-sensor exact "${out[@]}"
expect_kept 2 "--truth requires --live" -- dyno fuel --truth "${out[@]}"
expect_kept 2 "--live streams the fuel experiment, not engine" -- dyno engine --live "${out[@]}"

# --- limits: refused with the limit before anything runs or is allocated ----------------------------
expect_kept 2 "--duration 1000000 at a sample time of 0.0125 s is 8e\+07 samples; at most 1e\+07 are recorded \(a duration of at most 125000 s\)" -- \
  dyno fuel --duration 1e6 "${out[@]}"
expect_kept 2 "--duration 100000 at a sample time of 0.0125 s and --oversample 1000 is 8e\+09 steps of the simulated world; at most 1e\+08 are taken \(at this --oversample a duration of at most 1250 s; at this duration --oversample at most 12\)" -- \
  dyno square-wave --duration 1e5 --oversample 1000 "${out[@]}"
expect_kept 2 "the sweep's 2 points at 1e\+12 s each|the sweep's 2 points at 1000000000000 s each" -- \
  dyno engine --path f1,f3 --hold 1e12 "${out[@]}"
expect_kept 2 "--oversample 1000 at a sample time of 0.001 s: the simulated world's step would be 1e-06 s, below 1e-05 s \(at this sample time --oversample at most 100\)" -- \
  dyno engine --sample-time 0.001 --oversample 1000 --duration 1 "${out[@]}"
expect_kept 2 "--sample-time 0.05 with oversample 10: the simulated engine's step would be 0.005 s, longer than 0.0025 s .*give --oversample 20 or more" -- \
  dyno engine --sample-time 0.05 "${out[@]}"
expect_kept 2 "--bit-period 0.001: shorter than the sample time 0.0125 s" -- dyno fuel --bit-period 0.001 "${out[@]}"
expect_kept 2 "--duration 1e-12 gives no sample \\(a sample every 0.0125 s\\)" -- dyno fuel --duration 1e-12 "${out[@]}"
expect_kept 2 "--speed 1e-09: expected a factor of real time of at least 1e-06 \\(or 0" -- dyno fuel --live --speed 1e-9 "${out[@]}"
check "a sweep with a ramp of 1e-300 s runs (the path's position was cast from 1e300)" \
  "$cli" dyno engine --path f1,f3 --hold 0 --ramp 1e-300 --duration 1 --out "$tmp/jump.csv"
check "--sample-time 0.05 with --oversample 20 is taken" \
  "$cli" dyno engine --sample-time 0.05 --oversample 20 --duration 1 --out "$tmp/coarse.csv"

# --- faults that make no physical sense (they wrote NaN or inf rows with exit 0) ---------------------
expect 2 "--fault '1:tau_ff\*1e-320': tau_ff would become .* a fault may take it to 0.01..100 times that" -- \
  dyno fuel --live --speed 0 --duration 2 --fault '1:tau_ff*1e-320'
expect 2 "--fault '1:gain\*1e308': gain would become 8.421e\+307" -- dyno fuel --live --speed 0 --duration 2 --fault '1:gain*1e308'
expect 2 "--fault '1:tau_ff\*20': tau_ff would become 75 \(3.75 x 20\), 200 times" -- \
  dyno fuel --live --speed 0 --duration 2 --fault '0.5:tau_ff*10' --fault '1:tau_ff*20'
expect 2 "--fault '1:X\*nan': the factor 'nan' is not a number" -- dyno fuel --live --fault '1:X*nan'
expect 2 "--fault '1:tau_ff\*2/-1': the ramp '-1' is not a number of seconds >= 0" -- dyno fuel --live --fault '1:tau_ff*2/-1'
live --speed 0 --duration 2 --fault '0.5:tau_ff*100' --fault '1:gain*0.01' >"$tmp/far.csv"
check "faults up to 100 times the nominal values run" test $? -eq 0
check "... every row finite" bash -c "! grep -v '^#' '$tmp/far.csv' | grep -qi 'nan\|inf'"

summary
