#!/usr/bin/env bash
# greybench-cli monitor (and linearise, which reads the same reference) under hostile input, one
# check per class: --idle 0 or no --idle; a half-written last line when --idle expires; an
# earlier log kept when an input is missing or bad (a followed file whose header cannot be bound
# too); every numeric option out of its range, and a --change too small to test; a reference
# without a correlation matrix, or with a broken or singular one; a --change so large that a
# change shows within a row. Each ends with a clear message and the right exit status, and every
# input file (and the earlier log) is byte for byte as before.
# Usage: monitor_hostile.sh GREYBENCH_CLI TEST_DATA_DIR
set -u
cli=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
source "$(dirname "${BASH_SOURCE[0]}")/expect.bash"
assets=$(cd "$(dirname "${BASH_SOURCE[0]}")/../../assets" && pwd)

# --- the inputs ------------------------------------------------------------------------------------
cp "$assets/models/fuel_film.json" "$tmp/model.json"
cp "$assets/models/engine_mvem.json" "$tmp/engine.json"
cp "$assets/results/engine_mvem.json" "$tmp/engine_fit.json"
model=$tmp/model.json
"$cli" dyno fuel --duration 30 --out "$tmp/ref.csv"
"$cli" estimate "$model" "$tmp/ref.csv" --out "$tmp/ref.json" >/dev/null 2>&1
check "the reference fit is written" test -s "$tmp/ref.json"
"$cli" dyno fuel --duration 5 --seed 3 --out "$tmp/all.csv"
grep -v '^#' "$tmp/all.csv" >"$tmp/rows.csv"
total=$(($(wc -l <"$tmp/rows.csv") - 1))
# The same rows, the last one cut inside its last number (a writer stopped mid-line).
{ head -n -1 "$tmp/rows.csv"; tail -n 1 "$tmp/rows.csv" | head -c -4; } >"$tmp/partial.csv"
python3 - "$tmp" <<'PY'
import json, sys
d = sys.argv[1]
ref = json.load(open(f"{d}/ref.json"))
def write(name, edit, src=ref):
    j = json.loads(json.dumps(src))
    edit(j)
    json.dump(j, open(f"{d}/{name}", "w"))
def no_corr(j): del j["correlation"]
def asym(j): j["correlation"]["matrix"][1][0] = 0.5 * j["correlation"]["matrix"][1][0] + 0.25
def not_psd(j):
    n = j["correlation"]["names"]; m = j["correlation"]["matrix"]
    a, b, c = n.index("tau_ff"), n.index("X"), n.index("Kb")
    m[a][b] = m[b][a] = 0.9; m[b][c] = m[c][b] = 0.9; m[a][c] = m[c][a] = -0.9
def singular(j):
    n = j["correlation"]["names"]
    m = [[float(x == y) for y in n] for x in n]
    a, b = n.index("tau_ff"), n.index("X")
    m[a][b] = m[b][a] = 1.0
    j["correlation"]["matrix"] = m
write("ref_nocorr.json", no_corr)
write("ref_asym.json", asym)
write("ref_notpsd.json", not_psd)
write("ref_singular.json", singular)
write("engine_nocorr.json", no_corr, json.load(open(f"{d}/engine_fit.json")))
PY
sed '1s/mfi/fuel/' "$tmp/rows.csv" >"$tmp/unbound.csv"  # its header lacks the input 'mfi'
printf 'an earlier log\n' >"$tmp/log.jsonl"
inputs=(model.json engine.json engine_fit.json ref.csv ref.json rows.csv partial.csv unbound.csv
  ref_nocorr.json ref_asym.json ref_notpsd.json ref_singular.json engine_nocorr.json log.jsonl)
(cd "$tmp" && sha256sum "${inputs[@]}") >"$tmp/before.sha256"
ref=$tmp/ref.json

# --- 1. --idle: 0 is not "never"; without it the file is followed until interrupted ---------------
for v in 0 -1 nan inf; do
  expect 2 "monitor: --idle must be a positive, finite number of seconds .*not $v|--idle: $v is not a finite number" -- \
    monitor "$model" --reference "$ref" --follow "$tmp/rows.csv" --idle="$v"
done
expect 2 "monitor: --idle is for --follow" -- monitor "$model" --reference "$ref" --idle 1 -
# Started in the background; once it has logged as many updates as a run that stops after --idle
# (waited for up to 60 s: a loaded machine or the sanitizers' build may be slow to get there), it
# must still be running, following the file.
timeout 60 "$cli" monitor "$model" --reference "$ref" --follow "$tmp/rows.csv" --idle 0.3 \
  --out "$tmp/finite.jsonl" 2>/dev/null
updates=$(wc -l <"$tmp/finite.jsonl")
"$cli" monitor "$model" --reference "$ref" --follow "$tmp/rows.csv" \
  --out "$tmp/forever.jsonl" 2>/dev/null &
follower=$!
for _ in $(seq 600); do
  [ "$(wc -l 2>/dev/null <"$tmp/forever.jsonl" || echo 0)" -ge "$updates" ] && break
  sleep 0.1
done
logged=$(wc -l 2>/dev/null <"$tmp/forever.jsonl" || echo 0)
sleep 0.5
check "without --idle it follows the file until interrupted (still running after the last row)" \
  kill -0 "$follower"
kill "$follower" 2>/dev/null
wait "$follower" 2>/dev/null
check "... having logged the rows meanwhile ($logged updates of $updates)" test "$logged" -ge "$updates" -a "$updates" -gt 0

# --- 2. a half-written last line when --idle expires is not a row --------------------------------
timeout 30 "$cli" monitor "$model" --reference "$ref" --follow "$tmp/partial.csv" --idle 0.3 \
  --out "$tmp/partial.jsonl" 2>"$tmp/err"
check "monitor --follow with a cut last line exits 0" test $? -eq 0
check "it says the last line was incomplete and not used" grep -Eq \
  "partial.csv:$((total + 1)): the last line is incomplete \(no line end came before reading stopped\): not used; row skipped" \
  "$tmp/err"
check "the rows before it are all read ($((total - 1)))" grep -q "$((total - 1)) rows, " "$tmp/err"

# --- 3. an earlier log is kept when an input is missing or bad ------------------------------------
out=(--out "$tmp/log.jsonl")
expect 2 "no-such.csv: cannot open the file" -- \
  monitor "$model" --reference "$ref" --follow "$tmp/no-such.csv" "${out[@]}"
expect 2 "cannot follow the file: it is a folder" -- \
  monitor "$model" --reference "$ref" --follow "$tmp" "${out[@]}"
expect 2 "no-such-model.json" -- \
  monitor "$tmp/no-such-model.json" --reference "$ref" --follow "$tmp/rows.csv" "${out[@]}"
expect 2 "no-such-ref.json" -- \
  monitor "$model" --reference "$tmp/no-such-ref.json" --follow "$tmp/rows.csv" "${out[@]}"
expect 2 "unbound.csv:1: column 'mfi' \(an input of the model\) is not in the file" -- \
  monitor "$model" --reference "$ref" --follow "$tmp/unbound.csv" "${out[@]}"
expect 2 "ref_nocorr.json: correlation" -- \
  monitor "$model" --reference "$tmp/ref_nocorr.json" --follow "$tmp/rows.csv" "${out[@]}"
expect 2 "--change must be" -- \
  monitor "$model" --reference "$ref" --follow "$tmp/rows.csv" --change 0 "${out[@]}"
check "the earlier log is as it was" test "$(cat "$tmp/log.jsonl")" = "an earlier log"

# --- 4. every numeric option in its range, named with it -----------------------------------------
run=(monitor "$model" --reference "$ref" --follow "$tmp/rows.csv" --idle 0.2)
for v in 0 1.5 -0.5 nan; do
  expect 2 "monitor: --forgetting must be in \(0, 1\], not $v|--forgetting: $v is not a finite number" -- \
    "${run[@]}" --forgetting="$v"
done
for v in 0 -1 nan inf; do
  expect 2 "monitor: --false-alarms must be a positive, finite number per hour, not $v|--false-alarms: $v is not a finite number" -- \
    "${run[@]}" --false-alarms="$v"
done
for v in 0 -0.25 nan inf; do
  expect 2 "monitor: --change must be a positive, finite relative change .*not $v|--change: $v is not a finite number" -- \
    "${run[@]}" --change="$v"
done
expect 2 "a change of [a-zA-Z0-9_]+ by .* is too small to test: .*ask for a larger change" -- \
  "${run[@]}" --change 1e-7 "${out[@]}"
expect 2 "the score test of .* sums blocks of .* rows .*ask for a larger change or fewer false alarms" -- \
  "${run[@]}" --change 0.1 --false-alarms 1000
for v in 0 -3; do
  expect 2 "monitor: --every must be at least 1, not $v" -- "${run[@]}" --every="$v"
done

# --- 5. the reference's correlation matrix --------------------------------------------------------
expect 2 "ref_nocorr.json: correlation: the result gives standard errors of [0-9]+ parameters .*no correlation matrix.*run estimate again with this version" -- \
  monitor "$model" --reference "$tmp/ref_nocorr.json" -
expect 2 "engine_nocorr.json: correlation: .*no correlation matrix" -- \
  linearise "$tmp/engine_nocorr.json" --model "$tmp/engine.json" --point N=2931,alpha=29.5,ilambda=1
expect 2 "ref_asym.json: correlation.matrix\[1\]\[0\]: .*a correlation matrix is symmetric" -- \
  monitor "$model" --reference "$tmp/ref_asym.json" -
expect 2 "ref_notpsd.json: correlation.matrix: is not positive semi-definite" -- \
  monitor "$model" --reference "$tmp/ref_notpsd.json" -
expect 2 "ref_singular.json: correlation: the reference's correlations make tau_ff and X linearly dependent" -- \
  monitor "$model" --reference "$tmp/ref_singular.json" -
timeout 30 "$cli" monitor "$model" --reference "$tmp/ref_singular.json" --track Kb - \
  <"$tmp/rows.csv" >/dev/null 2>"$tmp/err"
check "a singular reference still monitors parameters outside the combination" test $? -eq 0

# --- 6. a --change so large that it shows within a row: the test is designed for less -------------
timeout 60 "$cli" monitor "$model" --reference "$ref" --change 100 --false-alarms 20 - \
  <"$tmp/ref.csv" >/dev/null 2>"$tmp/err"
check "monitor --change 100 exits 0" test $? -eq 0
check "it says the tests are designed for less than --change asks" \
  grep -q "(--change asks 1e+04 %: a larger change shows within too few rows" "$tmp/err"
alarms=$(grep -c "ALARM: .* has moved" "$tmp/err")
check "on the reference's own 30 s, at most 1 parameter alarm (designed 0.08; got $alarms)" \
  test "$alarms" -le 1

# --- every input as before ------------------------------------------------------------------------
check "every input file is byte for byte as before" bash -c "cd '$tmp' && sha256sum -c --quiet before.sha256"

summary monitor_hostile
