#!/usr/bin/env bash
# greybench-cli on numerical faults (issue 8): non-finite numbers in data cells, parameter values,
# --set and expressions, a degenerate innovation variance, an estimate on its bound, and output
# files that cannot be written. Each gives the exit status of user guide §4 (2 bad input,
# 1 numerical) with a message naming the place, or a flagged result; never a crash or a hang,
# never a NaN printed as a number, never a half-written or stray file.
# Usage: faults.sh GREYBENCH_CLI TEST_DATA_DIR
set -u
cli=$1
data=$2
tmp=$(mktemp -d)
trap 'chmod -R u+w "$tmp"; rm -rf "$tmp"' EXIT
EXPECT_TIMEOUT=60
source "$(dirname "${BASH_SOURCE[0]}")/expect.bash"

model=$data/cli/fuel.json
csv=$data/cli/fuel.csv

edit() {  # edit NAME PYTHON-STATEMENTS-ON-m: writes $tmp/NAME.json from the fuel model
  python3 - "$model" "$tmp/$1.json" "$2" <<'PY'
import json, sys
m = json.load(open(sys.argv[1]))
exec(sys.argv[3])
json.dump(m, open(sys.argv[2], "w"), indent=1)
PY
}

# --- non-finite data cells -------------------------------------------------------------------
printf 't,mfi,ilambda\n0,1,1\n0.0125,1,2\n0.025,inf,3\n' >"$tmp/inf_input.csv"
expect 2 "inf_input.csv:4:2: .*'inf' is not finite" -- loglik "$model" "$tmp/inf_input.csv"
printf 't,mfi,ilambda\n0,1,1\n0.0125,1,-1e999\n0.025,1,3\n' >"$tmp/inf_output.csv"
expect 2 "inf_output.csv:3:3: .*'-1e999' is not finite" -- loglik "$model" "$tmp/inf_output.csv"
printf 't,mfi,ilambda\n0,1,1\n0.0125,NaN,2\n0.025,1,3\n' >"$tmp/nan_input.csv"
expect 2 "nan_input.csv:3:2: .*missing" -- loglik "$model" "$tmp/nan_input.csv"

# --- non-finite parameter values in the model file and on the command line ---------------------
sed 's/"value": 0.175,/"value": 1e999,/' "$model" >"$tmp/inf_value.json"
expect 2 "inf_value.json:10:[0-9]+: the number 1e999 is out of range for a double" -- loglik "$tmp/inf_value.json" "$csv"
sed 's/"lower": 0.005,/"lower": -1e999,/' "$model" >"$tmp/inf_bound.json"
expect 2 "inf_bound.json:8:[0-9]+: the number -?1e999 is out of range for a double" -- estimate "$tmp/inf_bound.json" "$csv"
expect 2 "--set X: the value must be a finite number" -- loglik "$model" "$csv" --set X=nan
expect 2 "--set X: the value must be a finite number" -- loglik "$model" "$csv" --set X=inf
expect 2 "--set X: the value must be a finite number" -- estimate "$model" "$csv" --set X=-infinity
expect 2 "--set X: '1e999' is out of the range" -- loglik "$model" "$csv" --set X=1e999

# --- expressions that are not finite at the given values -------------------------------------
edit logneg 'm["diffusion"]["mfv"] = "sqrt(log(s11))"'
expect 1 "diffusion.mfv is not a number at these parameter values \(s11 = 0.001098\)" -- loglik "$tmp/logneg.json" "$csv"
edit divzero 'm["parameters"]["z"] = {"value": 0, "fixed": True}; m["observation"]["ilambda"] = "Kb*(mfv + mff) + 1/z"'
expect 1 "observation.ilambda is infinite at these parameter values \(z = 0\)" -- loglik "$tmp/divzero.json" "$csv"
expect 1 "start values.*diffusion.mfv is not a number" -- estimate "$tmp/logneg.json" "$csv"
expect 1 "diffusion.mfv is not a number" -- predict "$tmp/logneg.json" "$csv" --out "$tmp/p.csv"
check "no prediction file after a failure" test ! -e "$tmp/p.csv"

# --- an innovation variance that is not positive ----------------------------------------------
edit exact 'm["diffusion"] = {"mfv": "0", "mff": "0"}; m["measurement_variance"]["ilambda"] = "0"; m["initial_covariance"] = {"mfv": "0", "mff": "0"}'
expect 1 "fuel.csv:[0-9]+: the innovation variance of output 'ilambda' at row 3 .* not positive" -- loglik "$tmp/exact.json" "$csv"

# --- an estimate on its bound: flagged, no standard error, no NaN anywhere ---------------------
edit bound 'm["parameters"]["s2"] = {"value": 1e-6, "lower": 1e-9, "upper": 1e-5}'
timeout 120 "$cli" estimate "$tmp/bound.json" "$csv" --out "$tmp/bound_result.json" >"$tmp/bound.txt" 2>&1
check "estimate with a parameter at its bound exits 0 or 1" test $? -le 1
check "the result flags s2 at its bound with a null standard error" python3 - "$tmp/bound_result.json" <<'PY'
import json, math, sys
r = json.load(open(sys.argv[1]))
s2 = r["parameters"]["s2"]
assert s2["at_bound"] is True and s2["std_error"] is None and s2["t_value"] is None, s2
assert abs(s2["estimate"] - 1e-5) < 1e-12, s2
assert any("s2 is at its upper bound" in w for w in r["warnings"]), r["warnings"]
def finite(v):
    if isinstance(v, float): assert math.isfinite(v), v
    elif isinstance(v, dict): [finite(x) for x in v.values()]
    elif isinstance(v, list): [finite(x) for x in v]
finite(r)
PY
check "the report prints no NaN" bash -c "! grep -Eiw 'nan' '$tmp/bound.txt'"

# --- output files that cannot be written --------------------------------------------------------
expect 2 "$tmp/nowhere/r.json: cannot write the file" -- estimate "$model" "$csv" --out "$tmp/nowhere/r.json"
mkdir "$tmp/occupied.csv" && touch "$tmp/occupied.csv/keep"
expect 2 "occupied.csv: cannot replace the file" -- predict "$model" "$csv" --out "$tmp/occupied.csv"
check "the directory in the way is untouched" test -e "$tmp/occupied.csv/keep"
check "no temporary file is left behind" bash -c "! ls -A '$tmp' | grep -q tmp-greybench"
# A directory nobody can write to, root included (/proc).
expect 2 "/proc/greybench-faults.csv: cannot write the file" -- predict "$model" "$csv" --out /proc/greybench-faults.csv
if [ "$(id -u)" -ne 0 ]; then  # as root, permissions do not stop a write
  mkdir "$tmp/readonly" && "$cli" predict "$model" "$csv" --out "$tmp/readonly/p.csv" >/dev/null
  cp "$tmp/readonly/p.csv" "$tmp/before.csv" && chmod a-w "$tmp/readonly"
  expect 2 "readonly/p.csv: cannot write the file" -- predict "$model" "$csv" --set X=0.3 --out "$tmp/readonly/p.csv"
  check "the old prediction file is intact" cmp -s "$tmp/readonly/p.csv" "$tmp/before.csv"
fi

# A long run with an output that cannot be written says so before the run, not after it.
expect 2 "/proc/greybench-faults.json: cannot write the file" -- estimate "$model" "$csv" --out /proc/greybench-faults.json
check "estimate refuses the --out before fitting (no report)" \
  bash -c "[ -z \"\$('$cli' estimate '$model' '$csv' --out /proc/greybench-faults.json 2>/dev/null)\" ]"
expect 2 "occupied.csv: cannot replace the file: Is a directory" -- sweep "$model" "$csv" --out-csv "$tmp/occupied.csv"
check "sweep refuses the --out-csv before fitting (no table)" \
  bash -c "[ -z \"\$('$cli' sweep '$model' '$csv' --out-csv '$tmp/occupied.csv' 2>/dev/null)\" ]"
check "the early check leaves no temporary file" bash -c "! ls -A '$tmp' | grep -q tmp-greybench"

# Files that cannot be read to their end: a device that never ends, a folder.
expect 2 "/dev/zero: cannot read the file: it is a device or a pipe" -- loglik /dev/zero "$csv"
expect 2 "/dev/zero: cannot read the file: it is a device or a pipe" -- loglik "$model" /dev/zero
expect 2 "$tmp: cannot read the file: it is a folder" -- loglik "$tmp" "$csv"
mkfifo "$tmp/pipe.json"
expect 2 "pipe.json: cannot read the file: it is a device or a pipe" -- loglik "$tmp/pipe.json" "$csv"

summary
