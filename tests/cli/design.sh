#!/usr/bin/env bash
# greybench-cli design: two designs compared for the fuel film at the f1 estimates (the PRBS of
# the paper against a slow PRBS: the fast time constant's standard error grows more than 2.5
# times, the slow one's about 1.6 times, as the fits on the dyno's records of six seeds say:
# docs/teaching.md); the JSON; --fit's records; bad designs, inputs and models are bad input
# (exit 2) naming what is wrong, and an earlier --out and the model are left as they were.
# Usage: design.sh GREYBENCH_CLI TEST_DATA_DIR
set -u
cli=$1
assets=$(cd "$(dirname "$0")/../../assets" && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
source "$(dirname "${BASH_SOURCE[0]}")/expect.bash"

model=$assets/models/fuel_film.json
result=$assets/results/fuel_f1.json
fast=prbs:order=6,bit=0.5,level=1.186,amplitude=0.1186
slow=prbs:order=6,bit=4,level=1.186,amplitude=0.1186
out=$("$cli" design "$model" --result "$result" --design "$fast" --design "$slow" --out "$tmp/d.json")
check "design succeeds" test $? -eq 0
check "names both designs" grep -q '^B: PRBS n = 6, bit 4, 1.186 ± 0.1186, 10000 samples' <<<"$out"
check "the model's bandwidth" grep -Eq 'bandwidth mfi -> ilambda: 1\.5[0-9]* cycles' <<<"$out"
check "the JSON: the ratios of the lesson" python3 - "$tmp/d.json" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
assert j["greybench_design"] == 1 and j["input"] == "mfi"
a, b = (d["parameters"] for d in j["designs"])
r_fv = b["tau_fv"]["expected_std_error"] / a["tau_fv"]["expected_std_error"]
r_ff = b["tau_ff"]["expected_std_error"] / a["tau_ff"]["expected_std_error"]
assert 2.3 < r_fv < 2.8, r_fv
assert 1.4 < r_ff < 1.8, r_ff
# The fit of the bundled f1 record (the paper's design) gave 0.00189 and 0.0464.
assert abs(a["tau_fv"]["expected_std_error"] / 0.00189 - 1) < 0.1
assert abs(a["tau_ff"]["expected_std_error"] / 0.0464 - 1) < 0.1
assert j["designs"][0]["design"].startswith("prbs:order=6,bit=0.5,seed=1,level=1.186")
PY
out=$("$cli" design "$model" --result "$result" --design "$fast,duration=20" --fit 3)
check "--fit adds the fits' columns" grep -Eq 'fit SE A +spread A' <<<"$out"
check "... and says what they are" grep -q 'A: 3 records simulated from the model' <<<"$out"

kept=("$model" "$tmp/d.json")
expect_kept 2 "--design: input design 'sine:period=1': unknown shape 'sine'" -- \
  design "$model" --design sine:period=1 --out "$tmp/d.json"
expect_kept 2 "'order' must be a whole number from 2 to 24, not 30" -- \
  design "$model" --design prbs:order=30 --out "$tmp/d.json"
expect_kept 2 "bit: the bit period 0.001 is shorter than the sample time 0.0125" -- \
  design "$model" --design prbs:bit=0.001 --out "$tmp/d.json"
expect_kept 2 "--design: give one design, or two to compare" -- \
  design "$model" --design prbs: --design prbs: --design prbs: --out "$tmp/d.json"
expect_kept 2 "--hold 'mfi=1': mfi is the input the design drives" -- \
  design "$model" --design prbs: --hold mfi=1 --out "$tmp/d.json"
expect_kept 2 "--drive 'u': the model has no such input \(its inputs: mfi\)" -- \
  design "$model" --design prbs: --drive u --out "$tmp/d.json"
expect_kept 2 "--out .*the model file" -- design "$model" --design prbs: --out "$model"
expect 2 "the expected information is computed for linear models" -- \
  design "$assets/models/cascaded_tanks_sde.json" --design prbs:
expect 2 "--fit: '0' is not a whole number in \[1, 1000\]" -- design "$model" --design prbs: --fit 0

summary design
