#!/usr/bin/env bash
# greybench-cli predict and diagnose (user guide §4): the CSV's columns, residual = output -
# prediction, the Gaussian log-likelihood rebuilt from the CSV's predictions and sds equals
# `loglik`, `loglik --gradient` against differences, --set / --result / delay choice, diagnose's JSON
# keys, and bad input.
# Usage: predict.sh GREYBENCH_CLI TEST_DATA_DIR
set -u
cli=$1
data=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
source "$(dirname "${BASH_SOURCE[0]}")/expect.bash"
model=$data/cli/fuel.json
csv=$data/cli/fuel.csv

pass() { passes=$((passes + 1)); }
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }

# check NAME COMMAND...: a check passes when COMMAND exits 0; its output is shown otherwise (this
# script's own, in place of expect.bash's).
check() {
  local name=$1
  shift
  local out
  if out=$("$@" 2>&1); then pass; else fail "$name: $out"; fi
}

# run ARGS...: the CLI with a 20 s limit; stderr to $tmp/err.
run() { timeout 20 "$cli" "$@" 2>"$tmp/err"; }

# expect CODE REGEX -- ARGS...: exit status and stderr of a failing call.
expect() {
  local code=$1 pattern=$2
  shift 3
  local err status
  err=$(timeout 20 "$cli" "$@" 2>&1 >/dev/null)
  status=$?
  if [ "$status" -ne "$code" ] || ! grep -Eq -- "$pattern" <<<"$err"; then
    fail "greybench-cli $*: expected exit $code and /$pattern/, got exit $status: $err"
  else
    pass
  fi
}

# The CSV checks, in Python: header, column count, residual = output - prediction, and the
# log-likelihood Σ -½ [log(2π sd²) + (r/sd)²] over the rows from FIRST on equals LOGLIK.
csv_check() {  # csv_check FILE FIRST LOGLIK
  python3 - "$@" <<'PY'
import csv, math, sys
path, first, loglik = sys.argv[1], int(sys.argv[2]), float(sys.argv[3])
rows = [r for r in csv.reader(l for l in open(path) if not l.startswith("#"))]
header, body = rows[0], rows[1:]
want = ["t", "ilambda", "ilambda_pred", "ilambda_sd", "ilambda_residual"]
assert header == want, f"header {header}, expected {want}"
assert len(body) == 40, f"{len(body)} rows, expected 40"
assert all(len(r) == 5 for r in body), "a row without 5 fields"
num = lambda s: math.nan if s == "NA" else float(s)
ll, used = 0.0, 0
for k, r in enumerate(body):
    t, y, yp, sd, res = map(num, r)
    if math.isnan(res):
        assert math.isnan(y) or math.isnan(yp), f"row {k}: residual missing"
        continue
    assert abs(res - (y - yp)) <= 1e-12 * max(1.0, abs(y)), f"row {k}: {res} != {y} - {yp}"
    assert sd > 0, f"row {k}: sd {sd}"
    if k >= first:
        ll += -0.5 * (math.log(2 * math.pi * sd * sd) + (res / sd) ** 2)
        used += 1
assert abs(ll - loglik) <= 1e-6 * abs(loglik), f"log-likelihood from the CSV {ll}, loglik says {loglik}"
PY
}

# --- predict at the model's values ----------------------------------------------------------
loglik=$(python3 -c 'import json,sys; print(json.load(sys.stdin)["loglik"])' < <("$cli" loglik "$model" "$csv"))
if run predict "$model" "$csv" --out "$tmp/pred.csv"; then pass; else fail "predict: $(cat "$tmp/err")"; fi
check "predict CSV" csv_check "$tmp/pred.csv" 2 "$loglik"
check "predict: the first two rows (delay 2) have no prediction" \
  python3 -c "
import csv; rows = [r for r in csv.reader(l for l in open('$tmp/pred.csv') if not l.startswith('#'))]
assert rows[1][2] == 'NA' and rows[2][2] == 'NA' and rows[3][2] != 'NA', rows[1:4]"

# --- --set changes the predictions and the log-likelihood follows --------------------------
loglik_set=$(python3 -c 'import json,sys; print(json.load(sys.stdin)["loglik"])' < <("$cli" loglik "$model" "$csv" --set X=0.3))
if run predict "$model" "$csv" --set X=0.3 --out "$tmp/pred_set.csv"; then pass; else fail "predict --set: $(cat "$tmp/err")"; fi
check "predict --set CSV" csv_check "$tmp/pred_set.csv" 2 "$loglik_set"
check "predict --set differs" bash -c "! cmp -s '$tmp/pred.csv' '$tmp/pred_set.csv'"

# --- loglik --gradient: every free parameter (natural scale); X against central differences ---
gradient_check() {
  python3 - "$cli" "$model" "$csv" <<'PY'
import json, subprocess, sys
cli, model, csv = sys.argv[1:4]
def loglik(*extra):
    return json.loads(subprocess.run([cli, "loglik", model, csv, *extra], check=True,
                                     capture_output=True, text=True).stdout)
plain, out = loglik(), loglik("--gradient")
assert list(plain) == ["loglik", "n_obs"], plain
assert out["loglik"] == plain["loglik"] and out["n_obs"] == plain["n_obs"], out
assert list(out["gradient"]) == ["tau_fv", "tau_ff", "X", "s11", "s12", "s2"], out  # Kb fixed
h = 1e-4
up, down = loglik("--set", f"X={0.175 + h}")["loglik"], loglik("--set", f"X={0.175 - h}")["loglik"]
g = out["gradient"]["X"]
assert abs((up - down) / (2 * h) - g) <= 1e-5 * max(abs(g), 1.0), (g, (up - down) / (2 * h))
PY
}
check "loglik --gradient" gradient_check

# --- --result: estimates and the delay from a result file; --set still wins -----------------
python3 - "$tmp/result.json" <<'PY'
import json, sys
json.dump({"greybench_result": 1,
           "parameters": {"tau_fv": {"estimate": 0.09}, "X": {"estimate": 0.3},
                          "tau_ff": {"estimate": 0.375}, "s11": {"estimate": 1.098e-3},
                          "s12": {"estimate": 3.91e-4}, "s2": {"estimate": 1.257e-4},
                          "Kb": {"estimate": 0.8421, "fixed": True}},
           "output_delay": {"ilambda": {"estimate": 3, "profile": []}}}, open(sys.argv[1], "w"))
PY
# The model with the delay range 0..5 accepts the result's delay 3.
python3 - "$model" "$tmp/scan.json" <<'PY'
import json, sys
m = json.load(open(sys.argv[1])); m["output_delay"]["ilambda"] = {"min": 0, "max": 5}
json.dump(m, open(sys.argv[2], "w"), indent=1)
PY
if run predict "$tmp/scan.json" "$csv" --result "$tmp/result.json" --set tau_fv=0.1 --out "$tmp/pred_res.csv"; then pass; else fail "predict --result: $(cat "$tmp/err")"; fi
check "predict --result names its values" \
  grep -q "parameters: tau_fv=0.1 tau_ff=0.375 X=0.3 .*" "$tmp/pred_res.csv"
check "predict --result takes the delay" grep -q "ilambda=3 (from the result file)" "$tmp/pred_res.csv"
check "predict --result: no prediction before row 3" \
  python3 -c "
import csv; rows = [r for r in csv.reader(l for l in open('$tmp/pred_res.csv') if not l.startswith('#'))]
assert [r[2] for r in rows[1:4]] == ['NA'] * 3 and rows[4][2] != 'NA', rows[1:5]"

# --- a delay range without a result: the profile-best delay at θ, as loglik chooses it ------
best=$("$cli" loglik "$tmp/scan.json" "$csv" | python3 -c 'import json,sys; print(json.load(sys.stdin)["output_delay"]["ilambda"]["estimate"])')
if run predict "$tmp/scan.json" "$csv" --out "$tmp/pred_scan.csv"; then pass; else fail "predict scan: $(cat "$tmp/err")"; fi
check "predict uses the profile-best delay" grep -q "ilambda=$best (from the profile likelihood" "$tmp/pred_scan.csv"

# --- diagnose --------------------------------------------------------------------------------
if run diagnose "$model" "$csv" --out "$tmp/diag.json" >"$tmp/diag.out"; then pass; else fail "diagnose: $(cat "$tmp/err")"; fi
check "diagnose prints a verdict" grep -Eq "^ilambda: Residuals (look|are not) white" "$tmp/diag.out"
check "diagnose JSON" python3 - "$tmp/diag.json" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
for key in ["greybench_diagnostics", "model", "dataset", "parameters", "output_delay", "loglik",
            "n_obs", "outputs", "verdict", "lag_convention"]:
    assert key in d, f"no '{key}'"
o = d["outputs"]["ilambda"]
for key in ["acf", "pacf", "ccf", "cumulated_periodogram", "ljung_box", "normality", "verdict",
            "white", "normal", "n"]:
    assert key in o, f"no outputs.ilambda.{key}"
K = len(o["acf"]["lag"])
assert K >= 1 and o["acf"]["lag"] == list(range(1, K + 1)) and len(o["acf"]["value"]) == K
assert len(o["pacf"]["value"]) == K and o["acf"]["band"] > 0
c = o["ccf"]["mfi"]
assert c["lag"] == list(range(-K, K + 1)) and len(c["value"]) == 2 * K + 1
assert len(c["prewhitened"]["value"]) == 2 * K + 1
cp = o["cumulated_periodogram"]
q = cp["q"]
assert len(cp["frequency"]) == len(cp["value"]) == len(cp["white"]) == q and q == (o["n"] - 1) // 2
assert abs(cp["value"][-1] - 1) < 1e-12 and cp["band"] > 0
lb = o["ljung_box"]
assert 0 <= lb["p_value"] <= 1 and lb["df"] == lb["lags"]
nm = o["normality"]
assert len(nm["qq"]["theoretical"]) == len(nm["qq"]["sample"]) == o["n"]
assert sum(nm["histogram"]["counts"]) == o["n"]
assert len(nm["histogram"]["edges"]) == len(nm["histogram"]["counts"]) + 1
assert d["output_delay"]["ilambda"] == 2 and d["n_obs"] == 38
PY
if run diagnose "$model" "$csv" --max-lag 5 --lb-lags 4 --out "$tmp/diag5.json" >/dev/null; then pass; else fail "diagnose --max-lag: $(cat "$tmp/err")"; fi
check "diagnose --max-lag/--lb-lags" python3 -c "
import json; o = json.load(open('$tmp/diag5.json'))['outputs']['ilambda']
assert len(o['acf']['value']) == 5 and o['ljung_box']['lags'] == 4"

# --- bad input -------------------------------------------------------------------------------
expect 2 "error: .*--out" -- predict "$model" "$csv"
expect 2 "error: .*--out" -- diagnose "$model" "$csv"
expect 2 "nowhere.csv" -- predict "$model" "$tmp/nowhere.csv" --out "$tmp/x.csv"
echo '{"loglik": 1}' >"$tmp/notresult.json"
expect 2 "notresult.json: not a greybench result file" -- predict "$model" "$csv" --result "$tmp/notresult.json" --out "$tmp/x.csv"
echo '{"greybench_result": 1, "parameters": {"tauff": {"estimate": 1}}}' >"$tmp/other.json"
expect 2 "other.json: parameters.tauff: .*no parameter 'tauff'" -- predict "$model" "$csv" --result "$tmp/other.json" --out "$tmp/x.csv"
python3 - "$tmp/result.json" "$tmp/far.json" <<'PY'
import json, sys
r = json.load(open(sys.argv[1])); r["output_delay"]["ilambda"]["estimate"] = 7
json.dump(r, open(sys.argv[2], "w"))
PY
expect 2 "far.json: output_delay.ilambda.estimate: delay 7 is outside the model's range 0..5" -- diagnose "$tmp/scan.json" "$csv" --result "$tmp/far.json" --out "$tmp/x.json"
expect 2 "max_lag 50 needs more than 50" -- diagnose "$model" "$csv" --max-lag 50 --out "$tmp/x.json"
expect 2 "--set X: 'abc' is not a number" -- predict "$model" "$csv" --set X=abc --out "$tmp/x.csv"
python3 - "$model" "$tmp/negvar.json" <<'PY'
import json, sys
m = json.load(open(sys.argv[1])); m["measurement_variance"]["ilambda"] = "s2 - 1"
json.dump(m, open(sys.argv[2], "w"))
PY
expect 1 "measurement_variance.ilambda .*negative" -- predict "$tmp/negvar.json" "$csv" --out "$tmp/x.csv"

# --- predict --simulate-after N: the outputs after row N are simulated; the RMS it prints is the
# RMS of the CSV's residuals after row N; the same run through the EKF (a diffusion that names
# t, so the model is not linear) agrees to the ODE tolerance ---
simulate_check() {
  python3 - "$cli" "$model" "$csv" "$tmp" <<'PY'
import csv, json, math, subprocess, sys
cli, model, data, tmp = sys.argv[1:5]
def simulate(model_path, out):
    r = subprocess.run([cli, "predict", model_path, data, "--simulate-after", "6", "--out", out],
                       check=True, capture_output=True, text=True)
    return json.loads(r.stdout)
linear = simulate(model, tmp + "/sim.csv")
rows = [r for r in csv.reader(l for l in open(tmp + "/sim.csv") if not l.startswith("#"))]
header, body = rows[0], rows[1:]
res = [float(r[header.index("ilambda_residual")]) for r in body[6:]]
res = [v for v in res if not math.isnan(v)]
rms = math.sqrt(sum(v * v for v in res) / len(res))
out = linear["outputs"]["ilambda"]
assert linear["simulate_after"] == 6 and out["n"] == len(res), (linear, len(res))
assert abs(out["rms"] - rms) < 1e-9 * rms, (out, rms)
m = json.load(open(model))
m["diffusion"] = {k: "(" + v + ")*(1 + 0*t)" for k, v in m["diffusion"].items()}
json.dump(m, open(tmp + "/ekf.json", "w"))
ekf = simulate(tmp + "/ekf.json", tmp + "/sim_ekf.csv")["outputs"]["ilambda"]
assert abs(ekf["rms"] - rms) < 1e-6 * rms and ekf["n"] == out["n"], (ekf, out)
PY
}
check "predict --simulate-after" simulate_check
expect 2 "--simulate-after 40: expected a number of rows from 1 to 39" -- predict "$model" "$csv" --simulate-after 40 --out "$tmp/x.csv"

# --- predict --states: filtered and smoothed states; the smoother ends at the filter's last state,
# never claims more uncertainty than the filter, and the EKF's extended smoother equals the linear
# one on a linear model (forced onto the EKF by a diffusion that depends on t) ---
states_check() {
  python3 - "$cli" "$model" "$csv" "$tmp" <<'PY'
import csv, json, math, subprocess, sys
cli, model, data, tmp = sys.argv[1:5]
def states(model_path, out):
    subprocess.run([cli, "predict", model_path, data, "--out", tmp + "/p.csv", "--states", out],
                   check=True, capture_output=True, text=True)
    rows = [r for r in csv.reader(l for l in open(out) if not l.startswith("#"))]
    return rows[0], [[math.nan if v == "NA" else float(v) for v in r] for r in rows[1:]]
m = json.load(open(model))
header, body = states(model, tmp + "/states.csv")
expected = ["t"]
for x in m["states"]:
    expected += [x + "_filtered", x + "_filtered_sd", x + "_smoothed", x + "_smoothed_sd"]
for o in m["outputs"]:
    expected += [o + "_smoothed", o + "_smoothed_sd"]
assert header == expected, header
for x in m["states"]:
    f, fs, s, ss = (header.index(x + c) for c in ("_filtered", "_filtered_sd", "_smoothed", "_smoothed_sd"))
    assert abs(body[-1][f] - body[-1][s]) <= 1e-12 * abs(body[-1][f]), body[-1]
    assert all(r[ss] <= r[fs] * (1 + 1e-9) for r in body), x
m["diffusion"] = {k: "(" + v + ")*(1 + 0*t)" for k, v in m["diffusion"].items()}
json.dump(m, open(tmp + "/ekf.json", "w"))
header_ekf, body_ekf = states(tmp + "/ekf.json", tmp + "/states_ekf.csv")
assert header_ekf == header
worst = max(abs(a - b) / (1 + abs(b)) for ra, rb in zip(body_ekf, body) for a, b in zip(ra, rb)
            if not math.isnan(b))
assert worst < 1e-6, worst
PY
}
check "predict --states: the filtered and smoothed states, linear and EKF" states_check

# --- the Cascaded Tanks case study (docs/case-study-tanks.md): the bundled model at its recorded
# estimates simulates the benchmark's test record, state from its first 5 samples, with an RMS
# error below the published NLSS2's 0.343 V ---
tanks_check() {
  python3 - "$cli" "$data/../../assets" "$data/tanks/estimates.json" "$tmp" <<'PY'
import json, subprocess, sys
cli, assets, result, tmp = sys.argv[1:5]
r = subprocess.run([cli, "predict", assets + "/models/cascaded_tanks.json",
                    assets + "/data/tanks_test.csv", "--result", result, "--simulate-after", "5",
                    "--out", tmp + "/tanks.csv"], check=True, capture_output=True, text=True)
y = json.loads(r.stdout)["outputs"]["y"]
assert y["n"] == 1019 and y["rms"] < 0.34, y
PY
}
check "Cascaded Tanks: simulation RMS on the test record below 0.34 V" tanks_check

summary
