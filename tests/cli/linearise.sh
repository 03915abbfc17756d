#!/usr/bin/env bash
# greybench-cli linearise and dyno engine: the nonlinear virtual dyno's record has the columns the
# mean-value engine model reads; a fit's result file names its model file; the linearisation at a
# Table 2 point gives the fuel film's parameters with the delta method's standard errors (a
# quantity that is a parameter carries the parameter's SE); bad points and quantities are bad
# input (exit 2) naming what is wrong, a quantity that is not finite at the point a numerical
# failure (exit 1), a model that uses the time t is refused; the result, the model and an earlier
# --out are left byte for byte as they were.
# Usage: linearise.sh GREYBENCH_CLI TEST_DATA_DIR
set -u
cli=$1
assets=$(cd "$(dirname "$0")/../../assets" && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
source "$(dirname "${BASH_SOURCE[0]}")/expect.bash"

# The dyno: a short record at f1 and a sweep; the model's log-likelihood on it is finite.
check "dyno engine writes a record" "$cli" dyno engine --point f1 --duration 2 --out "$tmp/f1.csv"
check "its header" grep -q '^t,alpha,mfi,Tl,N,Pman,ilambda$' "$tmp/f1.csv"
check "its tag" grep -q '"operating_point": {"name": "f1", "n_rpm": 2931, "alpha_deg": 29.5}' "$tmp/f1.csv"
check "a sweep" "$cli" dyno engine --path 'f3;n=3000,alpha=30' --hold 1 --ramp 1 --out "$tmp/sweep.csv"
expect 2 "--path: operating point 'f9'" -- dyno engine --path f3,f9 --out "$tmp/x.csv"
expect 2 "give both n \(rpm\) and alpha" -- dyno engine --point n=3000 --out "$tmp/x.csv"
check "the Pade sensor, on a finer grid" "$cli" dyno engine --point f1 --duration 2 \
  --lambda-sensor pade --oversample 20 --out "$tmp/pade.csv"
check "... says so, and how to regenerate it" bash -c "grep -q '^# lambda sensor: the \[3/3\] Pade' '$tmp/pade.csv' &&
  grep -q -- '--oversample 20 --lambda-sensor pade --seed 1' '$tmp/pade.csv' &&
  grep -q '0.000625 s grid' '$tmp/pade.csv'"
expect 2 "--lambda-sensor: only the engine experiment" -- dyno fuel --lambda-sensor pade --out "$tmp/x.csv"
expect 2 "--lambda-sensor: delay not in" -- dyno engine --lambda-sensor delay --out "$tmp/x.csv"
expect 2 "--oversample: '5000' is not a whole number in \\[1, 1000\\]" -- dyno engine --oversample 5000 --out "$tmp/x.csv"
check "the model reads it" bash -c "'$cli' loglik '$assets/models/engine_mvem.json' '$tmp/f1.csv' | grep -q '\"filter\":\"ekf\"'"

# A result file at the model's start values with 1 % standard errors, uncorrelated, naming its
# model file.
python3 - "$assets/models/engine_mvem.json" "$tmp/result.json" <<'PY'
import json, sys, os
m = json.load(open(sys.argv[1]))
r = {"greybench_result": 1, "model": m["name"], "n_obs": 1,
     "model_file": os.path.relpath(sys.argv[1], os.path.dirname(sys.argv[2])), "parameters": {}}
for k, v in m["parameters"].items():
    r["parameters"][k] = {"estimate": v["value"], "std_error": abs(v["value"]) * 0.01 or 0.01,
                          "fixed": False}
names = list(m["parameters"])  # uncorrelated, said so: a result without it is refused
r["correlation"] = {"names": names,
                    "matrix": [[float(a == b) for b in names] for a in names]}
json.dump(r, open(sys.argv[2], "w"))
PY
out=$("$cli" linearise "$tmp/result.json" --point N=2931,alpha=29.5,ilambda=1 \
  --quantity 'tau_ff=-1/A_mff_mff' --quantity 'delay=cd/n' --out "$tmp/lin.json")
check "linearise succeeds" test $? -eq 0
check "prints A" grep -q '^A = df/dx' <<<"$out"
check "tau_ff is the parameter with its SE" grep -Eq 'tau_ff +0\.5 \(0\.005\)' <<<"$out"
check "the JSON" python3 - "$tmp/lin.json" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
assert j["greybench_linearisation"] == 1
assert len(j["A"]["value"]) == 7 and len(j["B"]["value"][0]) == 3
assert abs(j["quantities"]["delay"]["value"] - 150 / 2931) < 1e-12
assert abs(j["steady_state"]["n"]["value"] - 2931) < 1e-6
assert abs(j["quantities"]["tau_ff"]["std_error"] - 0.005) < 1e-9
PY
expect 2 "'alpa' is not a state, input or output of the model \(did you mean 'alpha'\?\)" -- \
  linearise "$tmp/result.json" --point N=2931,alpa=29.5,ilambda=1
expect 2 "give 1 more value" -- linearise "$tmp/result.json" --point N=2931,alpha=29.5
expect 2 "quantity tau: unknown name 'A_mff_mf'" -- \
  linearise "$tmp/result.json" --point N=2931,alpha=29.5,ilambda=1 --quantity 'tau=-1/A_mff_mf'
python3 -c "import json,sys; j=json.load(open(sys.argv[1])); del j['model_file']; json.dump(j, open(sys.argv[2],'w'))" \
  "$tmp/result.json" "$tmp/nomodel.json"
expect 2 "nomodel.json: model_file: .*give it with --model" -- \
  linearise "$tmp/nomodel.json" --point N=2931,alpha=29.5,ilambda=1
check "--model instead" "$cli" linearise "$tmp/nomodel.json" --model "$assets/models/engine_mvem.json" \
  --point N=2931,alpha=29.5,ilambda=1 --out "$tmp/lin2.json"

# Hostile points and quantities: refused (exit 2), or not finite at the point (exit 1), naming
# what; the result file, the model and the earlier --out byte for byte as they were.
kept=("$tmp/result.json" "$assets/models/engine_mvem.json" "$tmp/lin.json")
lin=(linearise "$tmp/result.json" --out "$tmp/lin.json")
expect_kept 2 "linearise --point: the value is empty" -- "${lin[@]}" --point ''
expect_kept 2 "operating point: 'N' is not NAME=VALUE" -- "${lin[@]}" --point N,alpha=29.5,ilambda=1
expect_kept 2 "operating point: N: '' is not a finite number" -- "${lin[@]}" --point N=,alpha=29.5,ilambda=1
expect_kept 2 "operating point: N: 'nan' is not a finite number" -- "${lin[@]}" --point N=nan,alpha=29.5,ilambda=1
expect_kept 2 "operating point: alpha: 'inf' is not a finite number" -- "${lin[@]}" --point N=2931,alpha=inf,ilambda=1
expect_kept 2 "an empty item" -- "${lin[@]}" --point N=2931,alpha=29.5,ilambda=1,
expect_kept 2 "'speed' is not a state, input or output" -- "${lin[@]}" --point speed=2931,alpha=29.5,ilambda=1
expect_kept 2 "'N' is given twice" -- "${lin[@]}" --point N=2931,alpha=29.5,N=3000
point=(--point N=2931,alpha=29.5,ilambda=1)
expect_kept 1 "the linearisation is not finite at this point: quantity q = 1/\\(alpha - 29.5\\) is inf" -- \
  "${lin[@]}" "${point[@]}" --quantity 'q=1/(alpha - 29.5)'
expect_kept 1 "quantity q = log\\(0\\*n\\) is -inf" -- "${lin[@]}" "${point[@]}" --quantity 'q=log(0*n)'
expect_kept 1 "quantity q = sqrt\\(-n\\) is -?nan" -- "${lin[@]}" "${point[@]}" --quantity 'q=sqrt(-n)'
expect_kept 2 "quantity q is given twice" -- "${lin[@]}" "${point[@]}" --quantity q=cd --quantity q=n
expect_kept 2 "quantity 'tau ff=cd': the name 'tau ff' is not a name" -- "${lin[@]}" "${point[@]}" --quantity 'tau ff=cd'
expect_kept 2 "quantity q: no expression after '='" -- "${lin[@]}" "${point[@]}" --quantity 'q='
expect_kept 2 "quantity q: unknown name 'nn'" -- "${lin[@]}" "${point[@]}" --quantity 'q=1/nn'
# A model whose drift uses the time t: no steady state (it was taken at t = 0, silently).
python3 - "$assets/models/engine_mvem.json" "$tmp/timed.json" <<'PY'
import json, sys
m = json.load(open(sys.argv[1]))
m["drift"]["mff"] = "(" + m["drift"]["mff"] + ") * (1 + 0.01*sin(t))"
json.dump(m, open(sys.argv[2], "w"))
PY
kept+=("$tmp/timed.json")
expect_kept 2 "timed.json: drift.mff: .* uses the time t: a model that changes with time has no steady state" -- \
  "${lin[@]}" --model "$tmp/timed.json" "${point[@]}"

summary linearise
