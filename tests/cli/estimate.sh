#!/usr/bin/env bash
# greybench-cli estimate and compare, end to end: simulate data from the fuel-film model, fit it
# and a restricted version (X fixed at a wrong value), and test one against the other.
# Usage: estimate.sh GREYBENCH_CLI TEST_DATA_DIR
set -u
cli=$1
data=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
source "$(dirname "${BASH_SOURCE[0]}")/expect.bash"

"$cli" prbs --order 6 --period 0.5 --ts 0.0125 --duration 50 --low 1.08 --high 1.32 --name mfi \
  --out "$tmp/u.csv"
"$cli" simulate "$data/cli/fuel.json" --inputs "$tmp/u.csv" --seed 4 --out "$tmp/d.csv"

"$cli" estimate "$data/cli/fuel.json" "$tmp/d.csv" --out "$tmp/full.json" >"$tmp/full.txt"
check "estimate exits 0" test $? -eq 0
check "the report has the coefficient table" grep -q "Std. Error" "$tmp/full.txt"
check "the result file is user guide §5" python3 - "$tmp/full.json" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
assert r["greybench_result"] == 1 and r["converged"] is True
for key in ["model", "datasets", "message", "loglik", "n_obs", "n_free", "aic", "bic",
            "iterations", "evaluations", "elapsed_s", "parameters", "correlation",
            "output_delay", "warnings"]:
    assert key in r, key
kb = r["parameters"]["Kb"]
assert kb["fixed"] is True and kb["std_error"] is None and kb["t_value"] is None
x = r["parameters"]["X"]
assert x["std_error"] > 0 and abs(x["estimate"] - 0.175) < 4 * x["std_error"]
assert abs(r["aic"] - (-2 * r["loglik"] + 2 * r["n_free"])) < 1e-6
PY

# The restricted model: X fixed at 0.05.
python3 - "$data/cli/fuel.json" "$tmp/restricted.json" <<'PY'
import json, sys
m = json.load(open(sys.argv[1]))
m["parameters"]["X"] = {"value": 0.05, "fixed": True}
json.dump(m, open(sys.argv[2], "w"))
PY
"$cli" estimate "$tmp/restricted.json" "$tmp/d.csv" --out "$tmp/restricted.json.out" >/dev/null
"$cli" compare "$tmp/restricted.json.out" "$tmp/full.json" >"$tmp/compare.txt"
check "compare exits 0" test $? -eq 0
check "compare reports one degree of freedom" grep -q "degrees of freedom = 1" "$tmp/compare.txt"
check "the full model wins" grep -q "fits significantly better" "$tmp/compare.txt"
"$cli" compare "$tmp/full.json" "$tmp/full.json" >/dev/null 2>"$tmp/err.txt"
check "compare refuses models with equal numbers of parameters" test $? -eq 2
"$cli" compare "$tmp/u.csv" "$tmp/full.json" >/dev/null 2>"$tmp/err.txt"
check "compare refuses a file that is not a result" test $? -eq 2

# Profile likelihood intervals (issue 14): in the result JSON as {"lower", "upper", "level"}, the
# estimate inside; the report prints them beside the Wald intervals.
"$cli" estimate "$data/cli/fuel.json" "$tmp/d.csv" --profile-intervals --profile-level 0.9 \
  --out "$tmp/profile.json" >"$tmp/profile.txt"
check "estimate --profile-intervals exits 0" test $? -eq 0
check "the report has the profile intervals" grep -q "90 % intervals: profile likelihood" "$tmp/profile.txt"
check "every free parameter has its profile interval" python3 - "$tmp/profile.json" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
for name, p in r["parameters"].items():
    if p["fixed"]:
        assert "profile_interval" not in p, name
        continue
    pi = p["profile_interval"]
    assert pi["level"] == 0.9, name
    assert pi["lower"] is None or pi["lower"] <= p["estimate"], name
    assert pi["upper"] is None or pi["upper"] >= p["estimate"], name
    assert pi["lower"] is not None or p["profile"]["lower_at_bound"] or p["at_bound"], name
assert r["starts"]["total"] == 1 and r["starts"]["at_best"] == 1, r["starts"]
PY
# A prior: the result says it is a MAP estimate.
python3 - "$data/cli/fuel.json" "$tmp/prior.json" <<'PY'
import json, sys
m = json.load(open(sys.argv[1]))
m["parameters"]["X"]["prior"] = {"mean": 0.2, "sd": 0.01}
json.dump(m, open(sys.argv[2], "w"))
PY
"$cli" estimate "$tmp/prior.json" "$tmp/d.csv" --out "$tmp/prior.out.json" >"$tmp/prior.txt"
check "a prior gives a MAP estimate" grep -q "MAP estimate" "$tmp/prior.txt"
check "the result has the log posterior" python3 -c "import json,sys; r=json.load(open(sys.argv[1])); assert r['log_posterior'] != r['loglik']" "$tmp/prior.out.json"
python3 - "$data/cli/fuel.json" "$tmp/badprior.json" <<'PY'
import json, sys
m = json.load(open(sys.argv[1]))
m["parameters"]["X"]["prior"] = {"mean": 0.2, "sd": -1}
json.dump(m, open(sys.argv[2], "w"))
PY
"$cli" estimate "$tmp/badprior.json" "$tmp/d.csv" >/dev/null 2>"$tmp/err.txt"
check "a negative prior sd is bad input" test $? -eq 2
check "... named by its path" grep -q "parameters.X.prior.sd" "$tmp/err.txt"

# A sweep of a nonlinear model (the EKF): a tank draining through an orifice, simulated at three
# pump gains k = 0.8, 1.0, 1.2 tagged load = 1, 2, 3; the trend of k against load has slope 0.2.
cat >"$tmp/tank.json" <<'JSON'
{"greybench_model": 1, "states": ["h"], "inputs": ["u"], "outputs": ["y"],
 "parameters": {"k": {"value": 0.5, "lower": 0.01, "upper": 5}, "a": {"value": 0.5, "lower": 0.01, "upper": 5},
   "s": {"value": 0.05, "lower": 1e-4, "upper": 1}, "r": {"value": 0.01, "lower": 1e-6, "upper": 1},
   "h0": {"value": 2.5, "lower": 0.1, "upper": 10}},
 "drift": {"h": "k*u - a*sqrt(h)"}, "diffusion": {"h": "s*sqrt(h)"},
 "observation": {"y": "h + 0.1*h^2"}, "measurement_variance": {"y": "r"}, "initial_state": {"h": "h0"}}
JSON
gains=(0 0.8 1.0 1.2)
for i in 1 2 3; do
  "$cli" prbs --order 6 --period 4 --ts 0.5 --duration 300 --low 0.7 --high 1.3 --seed "$i" \
    --out "$tmp/u$i.csv" >/dev/null
  "$cli" simulate "$tmp/tank.json" --inputs "$tmp/u$i.csv" --set "k=${gains[$i]}" --set a=0.5 \
    --set s=0.08 --set r=0.004 --seed "$i" --out "$tmp/s$i.csv" >/dev/null
  { echo "# greybench: {\"operating_point\": {\"name\": \"p$i\", \"load\": $i}}"; cat "$tmp/s$i.csv"; } \
    >"$tmp/tank$i.csv"
done
"$cli" sweep "$tmp/tank.json" "$tmp/tank1.csv" "$tmp/tank2.csv" "$tmp/tank3.csv" --trend k:load \
  --out-csv "$tmp/tank_sweep.csv" >"$tmp/tank_sweep.txt"
check "a sweep of a nonlinear model" test $? -eq 0
check "... recovers every point's k and the trend against load (slope 0.2 within 3 SE)" python3 - "$tmp/tank_sweep.txt" "$tmp/tank_sweep.csv" <<'PY'
import csv, re, sys
rows = list(csv.DictReader(l for l in open(sys.argv[2]) if not l.startswith("#")))
assert len(rows) == 3, rows
for row, k in zip(rows, (0.8, 1.0, 1.2)):
    assert abs(float(row["k"]) - k) < 4 * float(row["k_se"]), (row, k)
text = open(sys.argv[1]).read()
m = re.search(r"Trend: k = \S+ \(± \S+\) \+ (\S+) \(± (\S+)\) · load", text)
assert m, text
slope, se = float(m.group(1)), float(m.group(2))
assert abs(slope - 0.2) < 3 * se, (slope, se)
PY

# The EKF's exact scores (forward sensitivities) and --score-differences reach the same optimum,
# and the result says which ran.
"$cli" estimate "$tmp/tank.json" "$tmp/tank2.csv" --threads 1 --out "$tmp/tank_exact.json" >/dev/null
# Not under the sanitizers (GREYBENCH_SANITIZED, tests/CMakeLists.txt): the differenced fit is
# the script's slowest there, and its code runs there in EkfScore.* and Estimate.* (core tests).
if [[ ${GREYBENCH_SANITIZED:-0} != 1 ]]; then
"$cli" estimate "$tmp/tank.json" "$tmp/tank2.csv" --threads 1 --score-differences \
  --out "$tmp/tank_diff.json" >"$tmp/tank_diff.txt"
check "--score-differences is said in the report" grep -q "Scores: central differences" "$tmp/tank_diff.txt"
check "exact and differenced scores reach the same optimum" python3 - "$tmp/tank_exact.json" "$tmp/tank_diff.json" <<'PY'
import json, sys
a, b = (json.load(open(f)) for f in sys.argv[1:3])
assert a["filter"]["scores"] == "exact" and b["filter"]["scores"] == "differences", (a["filter"], b["filter"])
assert abs(a["loglik"] - b["loglik"]) < 1e-5, (a["loglik"], b["loglik"])
for name, p in a["parameters"].items():
    q = b["parameters"][name]
    assert abs(p["estimate"] - q["estimate"]) < 1e-2 * p["std_error"], (name, p, q)
    assert abs(p["std_error"] - q["std_error"]) < 1e-2 * p["std_error"], (name, p, q)
PY
fi

# --steady-start: the tank's level (k u / a)^2 from k = 3 (nine times the truth's, k = 1) is moved
# back before the fit, which then reaches the plain fit's optimum; the report and the result say
# what moved. A model whose steady states no free parameter moves is refused with the reason.
"$cli" estimate "$tmp/tank.json" "$tmp/tank2.csv" --threads 1 --set k=3 --steady-start \
  --steady-window 20 --out "$tmp/tank_steady.json" >"$tmp/tank_steady.txt"
check "--steady-start fits" test $? -eq 0
check "... and the report says what moved" grep -q "^Steady-state start: 2 parameters from 15 windows of length 20, .*: k 3 -> " "$tmp/tank_steady.txt"
check "... the result file has it, and the fit is the plain start's optimum" python3 - "$tmp/tank_steady.json" "$tmp/tank_exact.json" <<'PY'
import json, sys
a, b = (json.load(open(f)) for f in sys.argv[1:3])
s = a["steady_start"]
assert sorted(s["parameters"]) == ["a", "k"] and s["parameters"]["k"]["from"] == 3, s
assert s["windows"] == 15 and s["misfit"] < s["misfit_start"], s
assert abs(a["loglik"] - b["loglik"]) < 1e-4, (a["loglik"], b["loglik"])
PY
"$cli" estimate "$data/cli/fuel.json" "$tmp/d.csv" --steady-start >/dev/null 2>"$tmp/err.txt"
check "--steady-start on a model whose steady states no free parameter moves is bad input" test $? -eq 2
check "... saying so" grep -q "no free parameter moves the model's steady states" "$tmp/err.txt"
"$cli" estimate "$tmp/tank.json" "$tmp/tank2.csv" --steady-start --steady-window 0 >/dev/null 2>"$tmp/err.txt"
check "--steady-window 0 is refused" test $? -ne 0

# --start RESULT.json: the fit starts at a result's estimates (here its own optimum: it stays there
# in a few iterations); --set overrides one; a result naming a parameter the model lacks is bad
# input, named by its JSON path.
"$cli" estimate "$tmp/tank.json" "$tmp/tank2.csv" --threads 1 --starts-on-bound 0 \
  --start "$tmp/tank_exact.json" --out "$tmp/tank_restart.json" >/dev/null
check "--start from a result's own optimum stays there" python3 - "$tmp/tank_exact.json" "$tmp/tank_restart.json" <<'PY'
import json, sys
a, b = (json.load(open(f)) for f in sys.argv[1:3])
assert abs(a["loglik"] - b["loglik"]) < 1e-6, (a["loglik"], b["loglik"])
assert b["iterations"] <= 5, b["iterations"]
PY
python3 - "$tmp/tank_exact.json" "$tmp/tank_alien.json" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
r["parameters"]["zeta"] = r["parameters"]["k"]
json.dump(r, open(sys.argv[2], "w"))
PY
"$cli" estimate "$tmp/tank.json" "$tmp/tank2.csv" --start "$tmp/tank_alien.json" >/dev/null 2>"$tmp/alien.txt"
check "--start with a parameter the model lacks is bad input" test $? -eq 2
check "... named by the result file and its JSON path" grep -q "tank_alien.json.*parameters.zeta.*no parameter 'zeta'" "$tmp/alien.txt"

# --progress and --checkpoint: a line per iteration on stderr; the checkpoint is a partial result
# that --start resumes from; the result file names its model file for `linearise`.
"$cli" estimate "$data/cli/fuel.json" "$tmp/d.csv" --progress --checkpoint "$tmp/ck.json" \
  >/dev/null 2>"$tmp/progress.txt"
check "--progress prints the iterations" grep -Eq '^\[ *[0-9.]+ s\] fitting: iteration 1, ' "$tmp/progress.txt"
check "the checkpoint is partial" grep -q '"partial": true' "$tmp/ck.json"
check "--start resumes from it" "$cli" estimate "$data/cli/fuel.json" "$tmp/d.csv" --start "$tmp/ck.json" --max-evaluations 3
check "the result names its model file" grep -q '"model_file": ".*fuel.json"' "$tmp/full.json"

summary
