#!/usr/bin/env bash
# greybench-cli export-fmu: a fit's model as an FMI 2.0 FMU. A fit of the fuel film exports to a
# zip with the model description and the linux64 binary; the result's model is found from the
# result; bad input (no model named, not a result, --out onto an input, an unknown interface) is
# exit 2 naming it, a missing C compiler exit 1, and neither leaves a file or changes an input.
# (tests/core/fmu_test.cpp drives the FMU itself.)
# Usage: export_fmu.sh GREYBENCH_CLI TEST_DATA_DIR
set -u
cli=$1
assets=$(cd "$(dirname "$0")/../../assets" && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
source "$(dirname "${BASH_SOURCE[0]}")/expect.bash"
EXPECT_TIMEOUT=60

cp "$assets/models/fuel_film.json" "$assets/data/fuel_f1.csv" "$tmp/"
"$cli" estimate "$tmp/fuel_film.json" "$tmp/fuel_f1.csv" --out "$tmp/fit.json" >/dev/null 2>&1
check "the fit for the export" test -s "$tmp/fit.json"

expect 0 '' -- export-fmu "$tmp/fit.json" --out "$tmp/fuel.fmu"
check "the FMU holds its model description, binary and sources" python3 - "$tmp/fuel.fmu" <<'PY'
import sys, zipfile
z = zipfile.ZipFile(sys.argv[1])
names = set(z.namelist())
need = {"modelDescription.xml", "binaries/linux64/fuel.so", "sources/fuel.c",
        "sources/fmi2Functions.h", "sources/LICENSE.txt"}
assert need <= names, names
assert z.testzip() is None
d = z.read("modelDescription.xml").decode()
assert 'modelIdentifier="fuel"' in d and 'causality="parameter"' in d, d[:400]
PY
expect 0 '' -- export-fmu "$tmp/fit.json" --model "$tmp/fuel_film.json" --interface cs \
  --out "$tmp/cs_only.fmu"
check "a Co-Simulation FMU describes no Model Exchange" python3 - "$tmp/cs_only.fmu" <<'PY'
import sys, zipfile
d = zipfile.ZipFile(sys.argv[1]).read("modelDescription.xml").decode()
assert "<CoSimulation" in d and "<ModelExchange" not in d
PY

expect 0 '' -- export-fmu "$tmp/fit.json" --virtual-sensor --out "$tmp/sensor.fmu"
check "a virtual sensor is the filter's Co-Simulation FMU" python3 - "$tmp/sensor.fmu" <<'PY'
import sys, zipfile
d = zipfile.ZipFile(sys.argv[1]).read("modelDescription.xml").decode()
assert "<CoSimulation" in d and "<ModelExchange" not in d
for name in ("mff_filtered", "mff_filtered_sd", "mfv_predicted", "ilambda_pred", "ilambda_sd",
             "ilambda_residual", "ilambda_valid", "ready"):
    assert f'name="{name}"' in d, name
PY

kept=("$tmp/fit.json" "$tmp/fuel_film.json" "$tmp/fuel_f1.csv")
expect_kept 2 "--interface me: a virtual sensor is a Co-Simulation FMU" -- export-fmu \
  "$tmp/fit.json" --virtual-sensor --interface me --out "$tmp/x.fmu"
sed 's/"initial_covariance": *"ctsm"/"initial_covariance": "stationary"/' "$tmp/fuel_film.json" \
  >"$tmp/stationary.json"
expect 0 '' -- export-fmu "$tmp/fit.json" --model "$tmp/stationary.json" --virtual-sensor \
  --out "$tmp/stationary.fmu"
expect_kept 2 'out' -- export-fmu "$tmp/fit.json" --out "$tmp/fit.json"
expect_kept 2 'out' -- export-fmu "$tmp/fit.json" --out "$tmp/fuel_film.json"
python3 - "$tmp/fit.json" "$tmp/nameless.json" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
r.pop("model_file", None)
r.pop("project_file", None)
json.dump(r, open(sys.argv[2], "w"))
PY
expect 2 'nameless.json.*names no model or project file.*--model' -- \
  export-fmu "$tmp/nameless.json" --out "$tmp/x.fmu"
expect 2 'greybench_result' -- export-fmu "$tmp/fuel_film.json" --out "$tmp/x.fmu"
expect 2 'interface' -- export-fmu "$tmp/fit.json" --interface xx --out "$tmp/x.fmu"
export GREYBENCH_CC=/nonexistent/cc
expect 1 'cannot run the C compiler' -- export-fmu "$tmp/fit.json" --out "$tmp/x.fmu"
unset GREYBENCH_CC
check "a failed export leaves no file" test ! -e "$tmp/x.fmu"

summary export-fmu
