#!/usr/bin/env bash
# greybench-cli monitor: the condition monitor over rows piped on standard input (the live dyno)
# and over a file another process is still writing (partial lines, a pause, a malformed row):
# one JSON line per update, no row lost or half-parsed, a bad row reported by its line and
# skipped; bad arguments are errors that name what is wrong.
# Usage: monitor.sh GREYBENCH_CLI TEST_DATA_DIR
set -u
cli=$1
data=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
source "$(dirname "${BASH_SOURCE[0]}")/expect.bash"
assets=$(cd "$(dirname "${BASH_SOURCE[0]}")/../../assets" && pwd)
model=$assets/models/fuel_film.json

# A reference: the batch fit of a short record of the dyno (delay held at the paper's 5 samples).
"$cli" dyno fuel --duration 30 --out "$tmp/ref.csv"
"$cli" estimate "$model" "$tmp/ref.csv" --out "$tmp/ref.json" >/dev/null 2>&1
check "the reference fit is written" test -s "$tmp/ref.json"

# --- standard input: the live dyno piped in --------------------------------------------------------
timeout 30 "$cli" dyno fuel --live --speed 0 --duration 10 |
  timeout 30 "$cli" monitor "$model" --reference "$tmp/ref.json" - >"$tmp/log.jsonl" 2>"$tmp/err"
check "monitor - exits 0" test $? -eq 0
delay=$(python3 -c "import json; print(json.load(open('$tmp/ref.json'))['output_delay']['ilambda']['estimate'])")
check "one JSON line per completed row (800 rows, delay $delay)" \
  test "$(wc -l <"$tmp/log.jsonl")" -eq $((800 - delay))
check "the summary line counts the rows" grep -q "800 rows" "$tmp/err"
python3 - "$tmp/log.jsonl" <<'PY'
import json, math, sys
lines = [json.loads(l) for l in open(sys.argv[1])]
keys = {"t", "line", "index", "warming_up", "parameters", "innovations", "cusum", "alarms", "alarm"}
assert all(keys <= set(l) for l in lines), "a line lacks a field"
p = lines[-1]["parameters"]
assert set(p) == {"tau_fv", "tau_ff", "X", "Kb", "s11", "s12", "s2"}, sorted(p)
assert all(math.isfinite(v["estimate"]) and v["sd"] > 0 for v in p.values())
assert lines[0]["warming_up"] and not lines[-1]["warming_up"]
assert [l["index"] for l in lines] == list(range(len(lines)))
PY
check "the log's lines have every field, in order" test $? -eq 0

# --- a file being written: partial lines, a pause, a malformed row ---------------------------------
"$cli" dyno fuel --duration 5 --out "$tmp/all.csv"
grep -v '^#' "$tmp/all.csv" >"$tmp/rows.csv"
total=$(($(wc -l <"$tmp/rows.csv") - 1))
: >"$tmp/growing.csv"
(
  head -c 1000 "$tmp/rows.csv" >>"$tmp/growing.csv"  # ends inside a row
  sleep 0.3
  tail -c +1001 "$tmp/rows.csv" | head -n 100 >>"$tmp/growing.csv"
  echo "2.0001,abc,1.0" >>"$tmp/growing.csv"  # malformed: its input is not a number
  sleep 0.5
  tail -c +1001 "$tmp/rows.csv" | tail -n +101 >>"$tmp/growing.csv"
) &
writer=$!
timeout 30 "$cli" monitor "$model" --reference "$tmp/ref.json" --follow "$tmp/growing.csv" \
  --idle 1.5 --out "$tmp/follow.jsonl" 2>"$tmp/err"
status=$?
wait $writer
check "monitor --follow exits 0 after --idle" test $status -eq 0
check "every row is read ($total), none lost" grep -q "$total rows" "$tmp/err"
bad_line=$(grep -n '^2.0001,abc' "$tmp/growing.csv" | cut -d: -f1)
check "the malformed row is reported by its line ($bad_line) and skipped" \
  grep -Eq "growing.csv:$bad_line:2: .*not a number; row skipped" "$tmp/err"
check "1 row skipped" grep -q "1 rows skipped" "$tmp/err"
check "one JSON line per completed row" test "$(wc -l <"$tmp/follow.jsonl")" -eq $((total - delay))

# --- bad arguments -----------------------------------------------------------------------------
expect 2 "either --follow FILE or -" -- monitor "$model" --reference "$tmp/ref.json"
expect 2 "either --follow FILE or -" -- monitor "$model" --reference "$tmp/ref.json" --follow x.csv -
expect 2 "no-such.json" -- monitor "$model" --reference "$tmp/no-such.json" -
expect 2 "--forgetting must be in \(0, 1\]" -- monitor "$model" --reference "$tmp/ref.json" --forgetting 1.5 -
expect 2 "no-such.csv" -- monitor "$model" --reference "$tmp/ref.json" --follow "$tmp/no-such.csv"

# --- a nonlinear model: the augmented EKF on the Cascaded Tanks' test record, from their recorded
# estimates (tests/data/tanks) ---------------------------------------------------------------------
tanks=$assets/models/cascaded_tanks.json
rows=$(grep -v '^#' "$assets/data/tanks_test.csv" | tail -n +2 | wc -l)
timeout 60 "$cli" monitor "$tanks" --reference "$data/tanks/estimates.json" --track a1,k3 \
  --forgetting 0.99 - <"$assets/data/tanks_test.csv" >"$tmp/tanks.jsonl" 2>"$tmp/tanks.err"
check "monitor of a nonlinear model exits 0" test $? -eq 0
check "it says the augmented EKF runs, tracking a1 and k3" \
  grep -q "augmented extended Kalman filter.*tracking a1, k3" "$tmp/tanks.err"
check "one JSON line per row ($rows)" test "$(wc -l <"$tmp/tanks.jsonl")" -eq "$rows"
python3 - "$tmp/tanks.jsonl" <<'PY'
import json, math, sys
lines = [json.loads(l) for l in open(sys.argv[1])]
p = lines[-1]["parameters"]
assert set(p) == {"a1", "k3"}, sorted(p)
assert all(math.isfinite(v["estimate"]) and v["sd"] > 0 for v in p.values()), p
assert all(0.1 < l["parameters"]["a1"]["estimate"] < 3 for l in lines), "a1 left its bounds"
PY
check "the nonlinear log tracks a1 and k3 inside their bounds" test $? -eq 0
expect 2 "cannot track 'r'.*variance parameter" -- monitor "$tanks" --reference "$data/tanks/estimates.json" --track r -

summary monitor
