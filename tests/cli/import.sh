#!/usr/bin/env bash
# A project file in place of MODEL DATA... and its dataset keys (core/data/import.h): a
# headerless file without a time column, a German bench export (';', decimal commas, `Zeit [ms]`)
# and a mapped column give the same fit as the plain CSV; validation records are not fitted;
# predict and diagnose choose a dataset; bad keys are named by their JSON path.
# Usage: import.sh GREYBENCH_CLI TEST_DATA_DIR
set -u
cli=$1
data=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
source "$(dirname "${BASH_SOURCE[0]}")/expect.bash"
cp "$data/cli/fuel.json" "$tmp/model.json"
csv=$(realpath "$data/cli/fuel.csv")

# The same record in other forms, made from the plain CSV (t, mfi, ilambda; 12.5 ms apart).
rows() { grep -v '^#' "$csv" | tail -n +2; }
rows | cut -d, -f2- >"$tmp/headerless.csv"
{
  echo 'Zeit [ms];mfi;ilambda'
  rows | awk -F, '{ printf "%.10g;%s;%s\n", $1 * 1000, $2, $3 }' | tr . ,
} >"$tmp/german.csv"
{
  echo 't,mfi,lambda'
  rows | awk -F, '{ printf "%s,%s,%s\n", $1, $2, ($3 == "NA" ? "NA" : sprintf("%.17g", 1 / $3)) }'
} >"$tmp/lambda.csv"

project() {  # project NAME DATASETS-JSON
  printf '{"greybench_project": 1, "model": "model.json", "datasets": %s}\n' "$2" >"$tmp/$1"
}
quiet() { "$@" >/dev/null 2>&1; }
loglik_of() { "$cli" loglik "$@" 2>&1 | sed 's/.*"loglik":\([^,}]*\).*/\1/'; }
params_of() { "$cli" estimate "$@" 2>&1 | sed -n '/Estimate/,/^p-values/p'; }

reference_loglik=$(loglik_of "$tmp/model.json" "$csv")
reference_fit=$(params_of "$tmp/model.json" "$csv")
check "the reference fit ran" test -n "$reference_fit"

# 1. Headerless, no time column: the keys alone.
project headerless.json \
  '[{"file": "headerless.csv", "header": false, "sample_time": 0.0125, "columns": ["mfi", "ilambda"]}]'
check "a headerless file without time has the plain CSV's log-likelihood" \
  test "$(loglik_of "$tmp/headerless.json")" = "$reference_loglik"
check "and the same estimates" test "$(params_of "$tmp/headerless.json")" = "$reference_fit"

# 2. A German export, every format key detected: ';', decimal commas, time in ms.
project german.json '[{"file": "german.csv"}]'
check "a German export (';', decimal commas, Zeit [ms]) reads as the plain CSV" \
  test "$(loglik_of "$tmp/german.json")" = "$reference_loglik"
project german_plain.json '["german.csv"]'
expect 2 "german.csv:3:1: time '12,5' is not a number" -- \
  loglik "$tmp/german_plain.json"

# 3. A mapped output: ilambda = 1/lambda (equal to the last few digits).
project mapped.json '[{"file": "lambda.csv", "map": {"ilambda": "1/lambda"}}]'
mapped=$(loglik_of "$tmp/mapped.json")
check "a mapped column (ilambda = 1/lambda) gives the log-likelihood to 1e-9" \
  awk -v a="$mapped" -v b="$reference_loglik" 'BEGIN { d = a - b; if (d < 0) d = -d; exit !(d <= 1e-9 * (b < 0 ? -b : b)) }'

# 4. A validation record is not fitted; predict and diagnose choose one.
project two.json '["'"$csv"'", {"file": "german.csv", "role": "validation", "name": "bench"}]'
check "a validation record is not fitted" test "$(params_of "$tmp/two.json")" = "$reference_fit"
"$cli" estimate "$tmp/two.json" --out "$tmp/fit.json" >/dev/null 2>&1
check "the result names the project" grep -q '"project_file": "two.json"' "$tmp/fit.json"
expect 2 "the project has 2 datasets: choose one with --dataset.*2 bench \(validation\)" -- \
  predict "$tmp/two.json" --result "$tmp/fit.json" --out "$tmp/p.csv"
check "predict --dataset bench (a name)" \
  quiet "$cli" predict "$tmp/two.json" --dataset bench --result "$tmp/fit.json" --out "$tmp/p.csv"
check "predict --dataset 2 (a number)" \
  quiet "$cli" predict "$tmp/two.json" --dataset 2 --result "$tmp/fit.json" --out "$tmp/p2.csv"
check "the same predictions by name and by number" cmp -s "$tmp/p.csv" "$tmp/p2.csv"
check "diagnose --dataset german.csv (a file name)" \
  quiet "$cli" diagnose "$tmp/two.json" --dataset german.csv --result "$tmp/fit.json" --out "$tmp/d.json"
expect 2 "--dataset 3: no such dataset" -- \
  predict "$tmp/two.json" --dataset 3 --result "$tmp/fit.json" --out "$tmp/p.csv"
project validation_only.json '[{"file": "german.csv", "role": "validation"}]'
expect 2 'validation_only.json: datasets: every dataset of the project has the role "validation"' -- \
  estimate "$tmp/validation_only.json"

# The simulation's fit % against the CSV it writes: 100 (1 - ||y - ŷ|| / ||y - ȳ||) over rows > N.
"$cli" predict "$tmp/two.json" --dataset 1 --result "$tmp/fit.json" --simulate-after 10 \
  --out "$tmp/sim.csv" >"$tmp/sim.json" 2>&1
fit=$(sed 's/.*"fit_percent":\([^,}]*\).*/\1/' "$tmp/sim.json")
check "predict --simulate-after prints the fit %: $fit" \
  awk -F, -v fit="$fit" '/^#/ { next } !header { header = 1; next } k++ < 10 { next }
    $5 != "NA" && $5 != "" { y[++n] = $2; r2 += $5 * $5; s += $2 }
    END { m = s / n; for (i = 1; i <= n; i++) v += (y[i] - m) ^ 2
          f = 100 * (1 - sqrt(r2 / v)); d = f - fit; if (d < 0) d = -d; exit !(n > 10 && d < 1e-9) }' \
  "$tmp/sim.csv"

# 4a. Two records fitted jointly, each from its own initial state (estimation.initial_states or
# --initial-states): the initial state's own parameters get a copy per record (NAME_r2), the
# result says so, and predict starts record 2 from its copies.
sed -e 's/"initial_state": {"mfv": "0", "mff": "0"}/"initial_state": {"mfv": "v0", "mff": "f0"}/' \
  -e 's/"s2":     {"value": 1.257e-4, "lower": 0}/&, "v0": 0.0, "f0": 0.0/' \
  "$tmp/model.json" >"$tmp/model_x0.json"
printf '{"greybench_project": 1, "model": "model_x0.json", "datasets": ["%s", {"file": "german.csv"}], "estimation": {"initial_states": "per_record"}}\n' \
  "$csv" >"$tmp/records.json"
sed 's/model_x0.json/model.json/' "$tmp/records.json" >"$tmp/records_no_x0.json"
"$cli" estimate "$tmp/records.json" --out "$tmp/records_fit.json" >"$tmp/records.txt" 2>&1
check "per record: a copy of each initial-state parameter for record 2" \
  grep -q '^f0_r2 ' "$tmp/records.txt"
check "per record: the result says how the records started" \
  grep -q '"initial_states": "per_record"' "$tmp/records_fit.json"
"$cli" estimate "$tmp/records.json" --initial-states shared >"$tmp/shared.txt" 2>&1
check "--initial-states shared: no copies" bash -c "! grep -q '_r2 ' '$tmp/shared.txt'"
logl() { sed -n 's/^Log-likelihood: *\([^ ]*\).*/\1/p' "$1"; }
check "per record: a log L at least the shared fit's ($(logl "$tmp/records.txt") >= $(logl "$tmp/shared.txt"))" \
  awk -v a="$(logl "$tmp/records.txt")" -v b="$(logl "$tmp/shared.txt")" 'BEGIN { exit !(a != "" && a >= b - 1e-6) }'
check "per record: predict starts record 2 from its copies" \
  quiet "$cli" predict "$tmp/records.json" --dataset 2 --result "$tmp/records_fit.json" --out "$tmp/r2.csv"
expect 2 'model.json: initial_state: each record from its own initial state needs a free parameter' -- \
  estimate "$tmp/records_no_x0.json" --initial-states per_record
printf '{"greybench_project": 1, "model": "model.json", "datasets": ["german.csv"], "estimation": {"initial_states": "each"}}\n' >"$tmp/bad_states.json"
expect 2 'bad_states.json: estimation.initial_states: expected "shared"' -- \
  loglik "$tmp/bad_states.json"

# 5. Bad keys and values: the project file and the JSON path.
bad() {  # bad PATTERN DATASETS-JSON
  project bad.json "$2"
  expect 2 "$1" -- loglik "$tmp/bad.json"
}
bad 'bad.json: datasets\[0\].decimal: expected "." or ","' '[{"file": "german.csv", "decimal": ";"}]'
bad 'bad.json: datasets\[0\].colour: unknown key' '[{"file": "german.csv", "colour": 1}]'
bad 'bad.json: datasets\[0\].map.ilambda, column 3: column .lamda. is not in the file; its columns are mfi, lambda' \
  '[{"file": "lambda.csv", "map": {"ilambda": "1/lamda"}}]'
bad 'bad.json: datasets\[0\].range: \[0, 0.01\] holds 1 row' '[{"file": "german.csv", "range": [0, 0.01]}]'
bad 'bad.json: datasets\[0\].resample: 0.001 s is shorter than the record.s sample time' \
  '[{"file": "german.csv", "resample": 0.001}]'
bad 'bad.json: datasets\[0\].sample_time: give either "time" \(a column\) or "sample_time"' \
  '[{"file": "german.csv", "time": "Zeit [ms]", "sample_time": 0.1}]'
bad 'bad.json: datasets\[0\]: the dataset names no file' '[{"role": "validation"}]'
bad 'headerless.csv:1: 3 column names are given, but line 1 has 2 fields' \
  '[{"file": "headerless.csv", "header": false, "sample_time": 0.1, "columns": ["a", "b", "c"]}]'
bad 'headerless.csv: column .ilambda. \(an output of the model\) is not in the file; its columns are c1, c2' \
  '[{"file": "headerless.csv", "header": false, "sample_time": 0.1, "map": {"mfi": "c1"}}]'
bad 'bad.json: datasets\[0\]: expected a file name \(a string\) or an object' '[3]'
bad 'model.json|no datasets' '[]'

# 6. Nothing the user had is overwritten: --out on the project or one of its recordings.
kept=("$tmp/two.json" "$tmp/german.csv")
expect_kept 2 "refus|input" -- estimate "$tmp/two.json" --out "$tmp/german.csv"
expect_kept 2 "refus|input" -- estimate "$tmp/two.json" --out "$tmp/two.json"
# ... or on the project's diagram file, which no command reads but the project is made of
# (found by cli_fuzz: `diagnose PROJECT --out DIAGRAM` wrote over it).
echo '{"greybench_diagram": 1, "blocks": []}' >"$tmp/diagram.json"
printf '{"greybench_project": 1, "model": "model.json", "diagram": "diagram.json", "datasets": ["%s"]}\n' \
  "$csv" >"$tmp/with_diagram.json"
"$cli" estimate "$tmp/with_diagram.json" --out "$tmp/fit_d.json" >/dev/null 2>&1
kept=("$tmp/with_diagram.json" "$tmp/diagram.json")
expect_kept 2 "refus|input" -- diagnose "$tmp/with_diagram.json" --result "$tmp/fit_d.json" --out "$tmp/diagram.json"
expect_kept 2 "refus|input" -- predict "$tmp/with_diagram.json" --result "$tmp/fit_d.json" --out "$tmp/diagram.json"
expect_kept 2 "refus|input" -- estimate "$tmp/with_diagram.json" --out "$tmp/diagram.json"

summary import
