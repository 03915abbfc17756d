#!/usr/bin/env bash
# Fit times for docs/benchmarks.md (issue 14), measured side by side in one run: the passes
# alternate between the tools, so a change of load on the shared machine hits all alike.
#
#   bench/fit_speed.sh [PASSES]        (default 5; needs build/ and python3-statsmodels)
#
# Per pass:
#   greybench  fuel film f1, generic starts (bench/models/fuel_film_generic.json), delay 0..10
#              with every profile point converged, standard errors: threads 1 and all cores
#   greybench  the same at the fixed delay 5 with mfi0 held at 1.2 (SciPy's problem below)
#   SciPy      L-BFGS-B over statsmodels' filter, fixed delay 5, the same generic start and bounds
#              (bench/baseline_statsmodels.py --fit)
#   greybench  crankshaft (assets/models/crankshaft.json) and building 3 from CTSM-R's neutral
#              start (tests/data/building3/model_start.json)
# Prints each measurement as it goes, then the medians.
set -euo pipefail
cd "$(dirname "$0")/.."
passes=${1:-5}
cli=build/app/greybench-cli
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
python3 - bench/models/fuel_film_generic.json "$tmp/fixed5.json" <<'PY'
import json, sys
m = json.load(open(sys.argv[1]))
m["output_delay"]["ilambda"] = 5
m["parameters"]["mfi0"] = {"value": 1.2, "fixed": True}
json.dump(m, open(sys.argv[2], "w"))
PY

fit() {  # fit NAME ARGS...: the fit's own elapsed_s from its result file
  local name=$1
  shift
  "$cli" estimate "$@" --out "$tmp/r.json" >/dev/null || true
  python3 -c "import json,sys; r=json.load(open(sys.argv[1])); print(sys.argv[2], r['elapsed_s'], r['loglik'], r['iterations'], r['converged'])" "$tmp/r.json" "$name" | tee -a "$tmp/all.txt"
}

for pass in $(seq "$passes"); do
  echo "# pass $pass, load $(cut -d' ' -f1 /proc/loadavg)"
  fit generic-delay0..10-threads1 bench/models/fuel_film_generic.json assets/data/fuel_f1.csv --threads 1
  fit generic-delay0..10-threads0 bench/models/fuel_film_generic.json assets/data/fuel_f1.csv
  fit generic-delay5-mfi0-fixed-threads1 "$tmp/fixed5.json" assets/data/fuel_f1.csv --threads 1
  /usr/bin/python3 bench/baseline_statsmodels.py assets/data/fuel_f1.csv --fit --repeat 1 |
    python3 -c "import json,sys; r=json.load(sys.stdin); print('scipy-lbfgsb-statsmodels-delay5', r['fit_s'], r['loglik'], r['evaluations'], r['success'])" | tee -a "$tmp/all.txt"
  fit crankshaft-threads1 assets/models/crankshaft.json assets/data/crankshaft.csv --threads 1
  fit building3-neutral-threads1 tests/data/building3/model_start.json tests/data/building3/data.csv --threads 1
done
echo "# medians (s), log L, iterations (SciPy: evaluations)"
python3 - "$tmp/all.txt" <<'PY'
import statistics, sys
rows = {}
for line in open(sys.argv[1]):
    name, t, ll, it, ok = line.split()
    rows.setdefault(name, []).append((float(t), float(ll), it, ok))
for name, v in rows.items():
    print(f"{name:40s} {statistics.median(x[0] for x in v):8.3f} s  log L {v[-1][1]:.4f}  "
          f"{v[-1][2]} it  converged {v[-1][3]}  ({len(v)} passes)")
PY
