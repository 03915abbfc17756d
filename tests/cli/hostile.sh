#!/usr/bin/env bash
# greybench-cli under hostile input, the second round (docs/quality.md): outputs onto inputs,
# numeric options that are empty, 0, negative, NaN or huge, result files that do not match the
# model or each other, records without an observation, models with nothing to estimate, and
# errors that must name the right file. Every case ends with a message and a non-zero exit where
# nothing valid can be produced, and every input file keeps every byte (sha256 before and after).
# Usage: hostile.sh GREYBENCH_CLI TEST_DATA_DIR
set -u
cli=$1
data=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
source "$(dirname "${BASH_SOURCE[0]}")/expect.bash"

cp "$data/cli/fuel.json" "$tmp/m.json"
cp "$data/cli/fuel.csv" "$tmp/d.csv"
cd "$tmp" || exit 2
"$cli" estimate m.json d.csv --starts-on-bound 0 --out fit.json >/dev/null
"$cli" estimate m.json d.csv --starts-on-bound 0 --set X=0.1 --out fit2.json >/dev/null
mkdir -p in

# The inputs every case below reads, with their checksums; `unchanged` compares them.
sha256sum m.json d.csv fit.json fit2.json >sums
unchanged() { sha256sum --quiet -c sums; }

# refused CODE REGEX -- ARGS...: the CLI refuses with CODE and a message matching REGEX, and no
# input changed.
refused() {
  expect "$@"
  check "inputs unchanged after: ${*:4}" unchanged
}

# --- 1. outputs onto inputs (the output guard) -----------------------------------------------
refused 2 "--out m.json is the model file: writing it would destroy that input" -- \
  estimate m.json d.csv --out m.json
refused 2 "--out d.csv is the data file" -- estimate m.json d.csv --out d.csv
refused 2 "--out ./d.csv is the data file \(d.csv\)" -- estimate m.json d.csv --out ./d.csv
refused 2 "--out fit.json is the --start result file" -- \
  estimate m.json d.csv --start fit.json --out fit.json
refused 2 "--checkpoint c.json is also the path of --out" -- \
  estimate m.json d.csv --out c.json --checkpoint c.json
ln -s m.json link.json
refused 2 "--out link.json is the model file \(m.json\)" -- estimate m.json d.csv --out link.json
ln d.csv hard.csv
refused 2 "--out hard.csv is the data file \(d.csv\)" -- estimate m.json d.csv --out hard.csv
refused 2 "--states p.csv is also the path of --out" -- \
  predict m.json d.csv --out p.csv --states p.csv
refused 2 "--out fit.json is the --result file" -- \
  predict m.json d.csv --result fit.json --out fit.json
refused 2 "--out fit.json is the --result file" -- \
  diagnose m.json d.csv --result fit.json --out fit.json
refused 2 "--out-md t.csv is also the path of --out-csv" -- \
  sweep m.json d.csv --out-csv t.csv --out-md t.csv
refused 2 "--out-csv d.csv is the data file" -- sweep m.json d.csv --out-csv d.csv
refused 2 "--out d.csv is the --inputs file" -- simulate m.json --inputs d.csv --out d.csv
refused 2 "--out d.csv is the --follow file" -- \
  monitor m.json --reference fit.json --follow d.csv --idle 1 --out d.csv
refused 2 "--out fit.json is the --reference file" -- \
  monitor m.json --reference fit.json --follow d.csv --idle 1 --out fit.json
refused 2 "--out fit.json is the result file" -- linearise fit.json --point mfi=1 --out fit.json
refused 2 "--out m.json is the model file" -- linearise fit.json --point mfi=1 --out m.json
# A project and every file it names.
printf '{"greybench_project": 1, "model": "m.json", "datasets": ["d.csv"],\n "diagram": "g.json"}\n' \
  >p.json
printf '{"greybench_diagram": 1, "blocks": []}\n' >g.json
sha256sum p.json g.json >>sums
refused 2 "--out p.json is the project file" -- export-model p.json --out p.json
refused 2 "--out m.json is the project's model file" -- export-model p.json --out m.json
refused 2 "--out g.json is the project's diagram file" -- export-model p.json --out g.json
check "no temporary is left behind" test -z "$(ls | grep tmp-greybench)"

# Outputs that are not regular files are written through, never renamed over.
mkfifo pipe
(cat pipe >from_pipe) &
"$cli" predict m.json d.csv --result fit.json --out pipe
check "predict writes through a FIFO (exit 0)" test $? -eq 0
wait
check "the FIFO is still a FIFO" test -p pipe
check "what went through the FIFO is the predictions" grep -q "^t,ilambda,ilambda_pred" from_pipe
ln -s /dev/null null
"$cli" estimate m.json d.csv --starts-on-bound 0 --out null >/dev/null
check "estimate --out a link to /dev/null leaves the link" test -L null
check "/dev/null is still a device" test -c /dev/null
echo old >target.csv
ln -s target.csv via.csv
"$cli" predict m.json d.csv --result fit.json --out via.csv
check "--out through a symlink keeps the link" test -L via.csv
check "and replaces the file it names" grep -q "^t,ilambda,ilambda_pred" target.csv

# --- 2. numeric options: empty, 0, negative, NaN, huge ---------------------------------------
refused 2 "estimate --out: the value is empty" -- estimate m.json d.csv --out ""
refused 2 "estimate --out -: estimate writes files, not standard output" -- \
  estimate m.json d.csv --out -
refused 2 "predict --states -: predict writes files" -- \
  predict m.json d.csv --out p.csv --states -
refused 2 "--threads: '0' is not a whole number in \[1, 1024\]" -- estimate m.json d.csv --threads 0
refused 2 "--threads: '-2' is not a whole number in \[1, 1024\]" -- \
  estimate m.json d.csv --threads -2
refused 2 "--multistart: '1000000000' is not a whole number in \[0, 10000\]" -- \
  estimate m.json d.csv --multistart 1000000000
refused 2 "--max-evaluations: '0' is not a whole number in \[1, " -- \
  estimate m.json d.csv --max-evaluations 0
refused 2 "--ftol: 'nan' is not a number in \[0, 0.1\]" -- estimate m.json d.csv --ftol nan
refused 2 "--ftol: '2' is not a number in \[0, 0.1\]" -- estimate m.json d.csv --ftol 2
refused 2 "--profile-level: 'nan' is not a number in \[0.5, 0.9999\]" -- \
  estimate m.json d.csv --profile-intervals --profile-level nan
refused 2 "--profile-level requires --profile-intervals" -- \
  estimate m.json d.csv --profile-level 0.9
refused 2 "--steady-window: 'inf' is not a number > 0" -- \
  estimate m.json d.csv --steady-start --steady-window inf
refused 2 "--steady-window: '0' is not a number > 0" -- \
  estimate m.json d.csv --steady-start --steady-window 0
refused 2 "--steady-window requires --steady-start" -- estimate m.json d.csv --steady-window 3
refused 2 "--simulate-after: '0' is not a whole number >= 1" -- \
  predict m.json d.csv --simulate-after 0 --out p.csv
refused 2 "--max-lag: '0' is not a whole number >= 1" -- \
  diagnose m.json d.csv --max-lag 0 --out g2.json
refused 2 "--repeat: '0' is not a whole number in \[1, 10000\]" -- bench m.json d.csv --repeat 0
refused 2 "--parallel: '0' is not a whole number in \[1, 1024\]" -- \
  sweep m.json d.csv --parallel 0
refused 2 "--set X: the value must be a finite number" -- loglik m.json d.csv --set X=nan

# --- 3. result files that do not match -------------------------------------------------------
python3 - <<'PY'
import json
r = json.load(open("fit.json"))
del r["parameters"]["tau_ff"]
json.dump(r, open("in/missing.json", "w"), indent=1)
r = json.load(open("fit.json"))
r["partial"] = True
json.dump(r, open("in/partial.json", "w"), indent=1)
PY
sha256sum in/* >>sums
refused 2 "in/missing.json: parameters: no estimate of the model's free parameter 'tau_ff'" -- \
  predict m.json d.csv --result in/missing.json --out p.csv
refused 2 "in/missing.json: parameters: no estimate of the model's free parameter 'tau_ff'" -- \
  estimate m.json d.csv --start in/missing.json
"$cli" estimate m.json d.csv --start in/missing.json --set tau_ff=0.4 --starts-on-bound 0 >/dev/null
check "--set supplies the parameter the result lacks (exit 0)" test $? -eq 0
# compare: other data, not nested, a checkpoint.
python3 - <<'PY'
import json
m = json.load(open("m.json"))
m["parameters"]["X"] = {"value": 0.1, "fixed": True}
json.dump(m, open("in/x_fixed.json", "w"), indent=1)
m = json.load(open("m.json"))
m["parameters"]["tau_fv"]["fixed"] = True
m["parameters"]["tau_ff"]["fixed"] = True
json.dump(m, open("in/taus_fixed.json", "w"), indent=1)
PY
"$cli" estimate in/x_fixed.json d.csv --starts-on-bound 0 --out restricted.json >/dev/null
"$cli" compare restricted.json fit.json >compare.txt
check "compare of nested fits to the same data runs the test" grep -q "degrees of freedom = 1" compare.txt
head -30 d.csv >short.csv
"$cli" estimate in/x_fixed.json short.csv --starts-on-bound 0 --out other_data.json >/dev/null
"$cli" estimate in/taus_fixed.json d.csv --starts-on-bound 0 --out not_nested.json >/dev/null
sha256sum short.csv other_data.json not_nested.json restricted.json >>sums
refused 2 "no likelihood-ratio test: they were fitted to different data: other_data.json has" -- \
  compare fit.json other_data.json
refused 2 "the models are not nested: 'X' is free in not_nested.json .* but fixed in restricted.json" -- \
  compare not_nested.json restricted.json
refused 2 "in/partial.json: partial: a partial result" -- compare in/partial.json fit.json

# --- 4. records without an observation, models with nothing to estimate ----------------------
awk -F, 'BEGIN{OFS=","} /^#/ || /^t,/ {print; next} {$3="NA"; print}' d.csv >in/no_obs.csv
sha256sum in/no_obs.csv >>sums
refused 2 "in/no_obs.csv: no observation: every value of the output 'ilambda' is missing" -- \
  estimate m.json in/no_obs.csv
refused 2 "in/no_obs.csv: no observation" -- loglik m.json in/no_obs.csv
python3 - <<'PY'
import json
m = json.load(open("m.json"))
for p in m["parameters"].values():
    p["fixed"] = True
json.dump(m, open("in/all_fixed.json", "w"), indent=1)
PY
sha256sum in/all_fixed.json >>sums
refused 2 "nothing to estimate: every parameter of the model .*all_fixed.json is fixed" -- \
  estimate in/all_fixed.json d.csv
refused 2 "nothing to estimate" -- sweep in/all_fixed.json d.csv
# With a delay range the delay is the one unknown: estimated alone (this crashed), and its log L
# is loglik's at that delay.
python3 - <<'PY'
import json
m = json.load(open("in/all_fixed.json"))
m["output_delay"]["ilambda"] = {"min": 0, "max": 4}
json.dump(m, open("in/delay_only.json", "w"), indent=1)
PY
sha256sum in/delay_only.json >>sums
"$cli" estimate in/delay_only.json d.csv --out delay_only.json >/dev/null
check "estimate with only a delay to estimate exits 0" test $? -eq 0
"$cli" loglik in/delay_only.json d.csv >delay_only_loglik.json
check "its delay and log L are loglik's profile maximum" python3 - <<'PY'
import json
r = json.load(open("delay_only.json"))
l = json.load(open("delay_only_loglik.json"))
assert r["n_free"] == 1, r["n_free"]
assert r["output_delay"]["ilambda"]["estimate"] == l["output_delay"]["ilambda"]["estimate"]
assert abs(r["loglik"] - l["loglik"]) <= 1e-9 * abs(l["loglik"]), (r["loglik"], l["loglik"])
PY

# --- 5. messages that name the right file and place ------------------------------------------
refused 2 "--trend: 'Y' is not a parameter of the model m.json" -- \
  sweep m.json d.csv --trend Y:alpha_deg
refused 2 "d.csv: --trend X:alpha_deg: the data file's operating point has no tag 'alpha_deg'" -- \
  sweep m.json d.csv --trend X:alpha_deg
refused 2 "--delay-parameter: 'c_d' is not a parameter" -- sweep m.json d.csv --delay-parameter c_d
# A nonlinear model whose observation is not finite at one row of the data: the model file and
# its JSON path, then where in the data.
python3 - <<'PY'
import json
m = json.load(open("m.json"))
m["observation"]["ilambda"] = "Kb*(mfv + mff) + log(mfi - 1.0)"
json.dump(m, open("in/log_obs.json", "w"), indent=1)
PY
sha256sum in/log_obs.json >>sums
refused 1 "in/log_obs.json: .*observation.*ilambda.* \(at d.csv line [0-9]+, t = " -- \
  loglik in/log_obs.json d.csv

summary hostile
