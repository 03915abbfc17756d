#!/usr/bin/env bash
# greybench-cli on bad input: the exit status (2 bad input, 1 numerical) and a message on stderr
# that names the file and the place (line:column or JSON path). Never a crash, never a hang.
# Usage: errors.sh GREYBENCH_CLI TEST_DATA_DIR
set -u
cli=$1
data=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
source "$(dirname "${BASH_SOURCE[0]}")/expect.bash"

model=$data/cli/fuel.json
csv=$data/cli/fuel.csv

# --- data files (user guide §3) ---------------------------------------------------------
printf 't,ilambda\n0,1\n0.0125,2\n' >"$tmp/no_input.csv"
expect 2 "no_input.csv.*column 'mfi'.*not in the file" -- loglik "$model" "$tmp/no_input.csv"

printf 't,mfi,mfi,ilambda\n0,1,1,1\n0.0125,1,1,2\n' >"$tmp/dup.csv"
expect 2 "dup.csv:1:3: column .mfi. .*more than once" -- loglik "$model" "$tmp/dup.csv"

printf 't,mfi,ilambda\n0,1,1\n0.0125,1,2\n0.025,abc,3\n' >"$tmp/nan.csv"
expect 2 "nan.csv:4:2: .*'abc' is not a number" -- loglik "$model" "$tmp/nan.csv"

printf 't,mfi,ilambda\n0,1,1\n0.0125,1,2\n0.0125,1,3\n' >"$tmp/time.csv"
expect 2 "time.csv:4:1: .*does not increase" -- loglik "$model" "$tmp/time.csv"

printf 't,mfi,ilambda\n0,1,1\n0.0125,,2\n0.025,1,3\n' >"$tmp/missing_input.csv"
expect 2 "missing_input.csv:3:2: .*missing" -- loglik "$model" "$tmp/missing_input.csv"

printf 't,mfi,ilambda\n0,1,1\n0.0125,1\n' >"$tmp/fields.csv"
expect 2 "fields.csv:3(:[0-9]+)?: .*2 fields" -- loglik "$model" "$tmp/fields.csv"

printf 'a,b\n1,2\n' >"$tmp/notime.csv"
expect 2 "notime.csv.*time column" -- loglik "$model" "$tmp/notime.csv"

expect 2 "nowhere.csv.*(cannot|no such)" -- loglik "$model" "$tmp/nowhere.csv"

# --- model files (user guide §2) --------------------------------------------------------
edit() {  # edit NAME PYTHON-EXPRESSION-ON-m: writes $tmp/NAME.json from the fuel model
  python3 - "$model" "$tmp/$1.json" "$2" <<'PY'
import json, sys
m = json.load(open(sys.argv[1]))
exec(sys.argv[3])
json.dump(m, open(sys.argv[2], "w"), indent=1)
PY
}

printf '{"greybench_model": 1,\n "states": ["x"\n' >"$tmp/badjson.json"
expect 2 "badjson.json:3:1: JSON syntax error" -- loglik "$tmp/badjson.json" "$csv"

edit unknown 'm["drift"]["mff"] = "(-mff + X*mfi)/tauff"'
expect 2 "unknown.json: drift.mff, column 16: unknown name 'tauff' \(did you mean 'tau_ff'\?\)" -- loglik "$tmp/unknown.json" "$csv"

edit syntax 'm["observation"]["ilambda"] = "Kb*(mfv + mff"'
expect 2 "syntax.json: observation.ilambda, column [0-9]+: " -- loglik "$tmp/syntax.json" "$csv"

edit inverted 'm["parameters"]["X"]["lower"], m["parameters"]["X"]["upper"] = 1.0, 0.0'
expect 2 "inverted.json: parameters.X: the bounds are inverted" -- loglik "$tmp/inverted.json" "$csv"

edit outside 'm["parameters"]["tau_fv"]["value"] = 3.0'
expect 2 "outside.json: parameters.tau_fv.value: .*outside the bounds" -- loglik "$tmp/outside.json" "$csv"

edit dupname 'm["states"] = ["mfv", "mfv"]'
expect 2 "dupname.json: states\[1\]: 'mfv' is listed twice" -- loglik "$tmp/dupname.json" "$csv"

edit longdelay 'm["output_delay"]["ilambda"] = 500'
expect 2 "longdelay.json: output_delay.ilambda: .*only 40 rows" -- loglik "$tmp/longdelay.json" "$csv"

edit negvar 'm["measurement_variance"]["ilambda"] = "s2 - 1"'
expect 1 "measurement_variance.ilambda .*negative" -- loglik "$tmp/negvar.json" "$csv"

edit unstable 'm["initial_covariance"] = "stationary"; m["drift"]["mff"] = "(mff + X*mfi)/tau_ff"'
expect 1 "stationary.*stable A" -- loglik "$tmp/unstable.json" "$csv"

edit statevar 'm["measurement_variance"]["ilambda"] = "s2*(1 + mff^2)"'
expect 2 "statevar.json: measurement_variance.ilambda, column 9: 'mff' cannot appear here" -- loglik "$tmp/statevar.json" "$csv"

edit badekf 'm["ekf"] = {"ode": "rk4"}'
expect 2 "badekf.json: ekf.ode: expected \"auto\", \"explicit\" or \"bdf\"" -- loglik "$tmp/badekf.json" "$csv"

edit nanekf 'm["drift"]["mff"] = "(-sqrt(mff - 1) + X*mfi)/tau_ff"'
expect 1 "fuel.csv:4: the moment equations could not be integrated from row 1 \(t = 0\) to the next: drift.mff is not a number at these values \(mff = 0" -- loglik "$tmp/nanekf.json" "$csv"

# --- command line ----------------------------------------------------------------------------
expect 2 "--set taufv: the model has no parameter 'taufv' \(did you mean 'tau_fv'\?\)" -- loglik "$model" "$csv" --set taufv=1
expect 2 "--set X: 'abc' is not a number" -- loglik "$model" "$csv" --set X=abc
expect 2 "error: .*" -- loglik
expect 2 "error: .*" -- frobnicate
expect 2 "--order: '40' is not a whole number in \\[2, 24\\]" -- prbs --order 40 --period 1 --ts 0.1 --duration 10 --low 0 --high 1 --out "$tmp/u.csv"

# --- format variants load and give the same log-likelihood -----------------------------------
base=$("$cli" loglik "$model" "$csv")
sed 's/$/\r/' "$csv" >"$tmp/crlf.csv"
{ printf '\xef\xbb\xbf'; cat "$csv"; } >"$tmp/bom.csv"
sed 's/,/;/g' "$csv" >"$tmp/semicolon.csv"
awk -F, 'BEGIN{OFS=","} /^#/ {print; next} {print $0, (NR==3 ? "comment" : "text " NR)}' "$csv" >"$tmp/extra.csv"
for variant in crlf bom semicolon extra; do
  got=$("$cli" loglik "$model" "$tmp/$variant.csv" 2>&1)
  if [ "$got" != "$base" ]; then
    echo "FAIL: $variant.csv gives $got, the plain file $base"
    failures=$((failures + 1))
  else
    passes=$((passes + 1))
  fi
done

summary
