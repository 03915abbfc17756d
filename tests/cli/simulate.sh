#!/usr/bin/env bash
# greybench-cli simulate and prbs under hostile input: every numeric option is a finite number in
# its range (0, negative, NaN, inf, empty or not whole is refused naming the option and the range,
# never taken for the default); a path that is not finite is a numerical failure (exit 1) naming
# the row, not written. Each refusal leaves the inputs and an earlier output byte for byte as they
# were.
# Usage: simulate.sh GREYBENCH_CLI TEST_DATA_DIR
set -u
cli=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
source "$(dirname "${BASH_SOURCE[0]}")/expect.bash"

# --- prbs ------------------------------------------------------------------------------------------
"$cli" prbs --order 5 --period 1 --ts 0.1 --duration 10 --low 0 --high 1 --out "$tmp/u.csv"
check "prbs writes 100 rows" test "$(grep -vc '^#' "$tmp/u.csv")" -eq 101
kept=("$tmp/u.csv")
prbs() { expect_kept 2 "$1" -- prbs --out "$tmp/u.csv" "${@:2}"; }
ok=(--period 1 --ts 0.1 --duration 10 --low 0 --high 1)
prbs "--order: '0' is not a whole number in \[2, 24\]" --order 0 "${ok[@]}"
prbs "--order: '2.5' is not a whole number in \[2, 24\]" --order 2.5 "${ok[@]}"
prbs "--order: '' is not a whole number" --order '' "${ok[@]}"
prbs "--period: '0' is not a number > 0" --order 5 --period 0 --ts 0.1 --duration 10 --low 0 --high 1
prbs "--period: 'nan' is not a number > 0" --order 5 --period nan --ts 0.1 --duration 10 --low 0 --high 1
prbs "--ts: '' is not a number > 0" --order 5 --period 1 --ts '' --duration 10 --low 0 --high 1
prbs "--ts: '-0.1' is not a number > 0" --order 5 --period 1 --ts -0.1 --duration 10 --low 0 --high 1
prbs "--duration: 'inf' is not a number > 0" --order 5 --period 1 --ts 0.1 --duration inf --low 0 --high 1
prbs "--low: 'nan' is not a finite number" --order 5 --period 1 --ts 0.1 --duration 10 --low nan --high 1
prbs "--high: '' is not a finite number" --order 5 --period 1 --ts 0.1 --duration 10 --low 0 --high ''
prbs "--low 1 and --high 1: the same level" --order 5 --period 1 --ts 0.1 --duration 10 --low 1 --high 1
prbs "--seed: '-1' is not a whole number in \[0, 4294967295\]" --order 5 "${ok[@]}" --seed -1
prbs "--seed: '4294967296' is not a whole number in \[0, 4294967295\]" --order 5 "${ok[@]}" --seed 4294967296
prbs "prbs --name: the value is empty" --order 5 "${ok[@]}" --name ''
prbs "--name 't': expected a column name" --order 5 "${ok[@]}" --name t
prbs "--name 'a,b': expected a column name" --order 5 "${ok[@]}" --name a,b
prbs "--duration 1e-300 at --ts 0.1 gives no sample" --order 5 --period 1 --ts 0.1 --duration 1e-300 --low 0 --high 1
prbs "would give more than 50 million samples" --order 5 --period 1 --ts 1e-6 --duration 1e3 --low 0 --high 1
prbs "the bit period 0.01 is shorter than the sample time 0.1" --order 5 --period 0.01 --ts 0.1 --duration 10 --low 0 --high 1

# --- simulate --------------------------------------------------------------------------------------
# dx = a x dt from x0 = 1: x(t) = e^t passes the largest double after t = 709.78.
cat >"$tmp/grow.json" <<'JSON'
{"greybench_model": 1, "states": ["x"], "inputs": ["u"], "outputs": ["y"],
 "parameters": {"a": {"value": 1, "fixed": true}, "r": {"value": 0.01, "fixed": true}},
 "drift": {"x": "a*x + 0*u"}, "observation": {"y": "x"}, "measurement_variance": {"y": "r"},
 "initial_state": {"x": "1"}, "initial_covariance": {"x": "0"}}
JSON
python3 -c "print('t,u'); [print(f'{k},0') for k in range(801)]" >"$tmp/in.csv"
"$cli" simulate "$tmp/grow.json" --inputs "$tmp/in.csv" --set a=-1 --out "$tmp/sim.csv"
check "a stable path is simulated" test "$(grep -vc '^#' "$tmp/sim.csv")" -eq 802
# --deterministic: the noise-free response from x0, e^{-t} exactly (a linear model's exact
# discretisation), the same for any seed; with a result file, at its estimates.
"$cli" simulate "$tmp/grow.json" --inputs "$tmp/in.csv" --set a=-1 --deterministic \
  --out "$tmp/det.csv"
check "the deterministic response is e^-t" python3 - "$tmp/det.csv" <<'PY'
import csv, math, sys
rows = [r for r in csv.DictReader(l for l in open(sys.argv[1]) if not l.startswith("#"))]
for r in rows[:50]:
    t, y = float(r["t"]), float(r["y"])
    assert abs(y - math.exp(-t)) <= 1e-14 * max(1.0, math.exp(-t)), (t, y)
PY
# The same model through the EKF's moment equations (a nonlinear term u x^2, zero at u = 0):
# e^{-t} to the ODE tolerance.
sed 's/"a\*x + 0\*u"/"a*x + u*x^2"/' "$tmp/grow.json" >"$tmp/grow_nl.json"
"$cli" simulate "$tmp/grow_nl.json" --inputs "$tmp/in.csv" --set a=-1 --deterministic \
  --out "$tmp/det_nl.csv"
check "the nonlinear deterministic response is e^-t to the tolerance" python3 - "$tmp/det_nl.csv" <<'PY'
import csv, math, sys
rows = [r for r in csv.DictReader(l for l in open(sys.argv[1]) if not l.startswith("#"))]
assert any("moment equations' mean" in l for l in open(sys.argv[1]) if l.startswith("#"))
for r in rows[:30]:
    t, y = float(r["t"]), float(r["y"])
    assert abs(y - math.exp(-t)) <= 1e-8, (t, y)
PY
cat >"$tmp/fit.json" <<'JSON'
{"greybench_result": 1, "converged": true, "loglik": 1, "n_obs": 801,
 "parameters": {"a": {"estimate": -0.5, "fixed": true}, "r": {"estimate": 0.01, "fixed": true}}}
JSON
"$cli" simulate "$tmp/grow.json" --inputs "$tmp/in.csv" --result "$tmp/fit.json" \
  --deterministic --out "$tmp/det_fit.csv"
check "--result gives the estimates" python3 - "$tmp/det_fit.csv" <<'PY'
import csv, math, sys
rows = [r for r in csv.DictReader(l for l in open(sys.argv[1]) if not l.startswith("#"))]
assert abs(float(rows[10]["y"]) - math.exp(-5)) <= 1e-14, rows[10]
PY
kept=("$tmp/grow.json" "$tmp/in.csv" "$tmp/sim.csv" "$tmp/fit.json")
expect_kept 2 "--seed: a deterministic response \(--deterministic\) draws no noise" -- \
  simulate "$tmp/grow.json" --inputs "$tmp/in.csv" --set a=-1 --deterministic --seed 3 \
  --out "$tmp/sim.csv"
expect_kept 2 "--out .*is the --result file" -- simulate "$tmp/grow.json" --inputs "$tmp/in.csv" \
  --result "$tmp/fit.json" --out "$tmp/fit.json"
expect_kept 2 "in.csv:1:2: JSON syntax error" -- simulate "$tmp/grow.json" --inputs "$tmp/in.csv" \
  --result "$tmp/in.csv" --out "$tmp/sim.csv"
sim=(simulate "$tmp/grow.json" --inputs "$tmp/in.csv" --out "$tmp/sim.csv")
expect_kept 1 "in.csv:712: the simulated state number 1 is inf at t = 710: the model's path is not finite" -- "${sim[@]}"
expect_kept 2 "--seed: '' is not a whole number" -- "${sim[@]}" --set a=-1 --seed ''
expect_kept 2 "--seed: '-5' is not a whole number" -- "${sim[@]}" --set a=-1 --seed -5
expect_kept 2 "--set a: the value must be a finite number" -- "${sim[@]}" --set a=nan
# A nonlinear model whose path leaves its domain: the entry that broke it, by name.
sed 's/"a\*x + 0\*u"/"-sqrt(x) + 0*u"/; s/"x": "1"}, "initial_covariance"/"x": "0.01"}, "initial_covariance"/' \
  "$tmp/grow.json" >"$tmp/drain.json"
kept+=("$tmp/drain.json")
expect_kept 1 "drift.x is not a number" -- simulate "$tmp/drain.json" --inputs "$tmp/in.csv" --out "$tmp/sim.csv"

summary simulate
