#!/usr/bin/env bash
# Fit times of nonlinear models with the EKF's exact scores (forward sensitivities, the default)
# against central differences of log L (estimate --score-differences), side by side in one run:
# the two alternate within every pass, so a change of load on the shared machine hits both alike.
#
#   bench/ekf_scores.sh [PASSES]        (default 3; needs build/)
#
# Problems (one thread each, --starts-on-bound 0: one start):
#   bioreactor   CTSM's fed-batch bioreactor from its neutral start (tests/data/bioreactor;
#                3 states, 8 free parameters, 3 outputs)
#   tank         a tank with orifice outflow, level-dependent diffusion and a quadratic sensor,
#                600 samples simulated by greybench, fitted from generic starts (the model of
#                tests/core/ekf_estimate_test.cpp; 1 state, 5 free parameters)
#   tanks-warm   the Cascaded Tanks (assets/models/cascaded_tanks.json; 2 states, 12 free)
#                started 10 % off the recorded optimum (tests/data/tanks/estimates.json)
# Prints each measurement as it goes, then the medians and the ratios.
set -euo pipefail
cd "$(dirname "$0")/.."
passes=${1:-3}
cli=build/app/greybench-cli
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

cat >"$tmp/tank.json" <<'JSON'
{"greybench_model": 1, "states": ["h"], "inputs": ["u"], "outputs": ["y"],
 "parameters": {"k": {"value": 0.3, "lower": 0.01, "upper": 5}, "a": {"value": 0.3, "lower": 0.01, "upper": 5},
   "s": {"value": 0.05, "lower": 1e-4, "upper": 1}, "r": {"value": 0.01, "lower": 1e-6, "upper": 1},
   "h0": {"value": 1.0, "lower": 0.1, "upper": 10}},
 "drift": {"h": "k*u - a*sqrt(h)"}, "diffusion": {"h": "s*sqrt(h)"},
 "observation": {"y": "h + 0.1*h^2"}, "measurement_variance": {"y": "r"}, "initial_state": {"h": "h0"}}
JSON
"$cli" prbs --order 6 --period 4 --ts 0.5 --duration 300 --low 0.7 --high 1.3 --out "$tmp/u.csv" >/dev/null
"$cli" simulate "$tmp/tank.json" --inputs "$tmp/u.csv" --set k=0.8 --set a=0.5 --set s=0.08 \
  --set r=0.004 --set h0=2.5 --seed 3 --out "$tmp/tank.csv" >/dev/null
warm=()
while read -r name value; do warm+=(--set "$name=$value"); done < <(python3 - <<'PY'
import json
r = json.load(open("tests/data/tanks/estimates.json"))
m = json.load(open("assets/models/cascaded_tanks.json"))
for name, p in r["parameters"].items():
    spec = m["parameters"][name]
    if isinstance(spec, dict) and spec.get("fixed"):
        continue
    v = p["estimate"] * 1.1
    lo, hi = spec.get("lower", -1e300), spec.get("upper", 1e300)
    print(name, min(max(v, lo), hi))
PY
)

fit() {  # fit NAME ARGS...: the fit's own elapsed_s, log L, iterations, evaluations, converged
  local name=$1
  shift
  "$cli" estimate "$@" --threads 1 --starts-on-bound 0 --out "$tmp/r.json" >/dev/null || true
  python3 -c "import json,sys; r=json.load(open(sys.argv[1])); print(sys.argv[2], r['elapsed_s'], r['loglik'], r['iterations'], r['evaluations'], r['converged'])" "$tmp/r.json" "$name" | tee -a "$tmp/all.txt"
}

for pass in $(seq "$passes"); do
  echo "# pass $pass, load $(cut -d' ' -f1 /proc/loadavg)"
  for scores in exact differences; do
    flag=()
    [[ $scores == differences ]] && flag=(--score-differences)
    fit "bioreactor-$scores" tests/data/bioreactor/fedbatch.json tests/data/bioreactor/fedbatch.csv "${flag[@]}"
    fit "tank-$scores" "$tmp/tank.json" "$tmp/tank.csv" "${flag[@]}"
    fit "tanks-warm-$scores" assets/models/cascaded_tanks.json assets/data/tanks_estimation.csv "${warm[@]}" "${flag[@]}"
  done
done
echo "# medians (s), log L, iterations, evaluations; ratio differences / exact"
python3 - "$tmp/all.txt" <<'PY'
import statistics, sys
rows = {}
for line in open(sys.argv[1]):
    name, t, ll, it, ev, ok = line.split()
    rows.setdefault(name, []).append((float(t), float(ll), it, ev, ok))
med = {name: statistics.median(x[0] for x in v) for name, v in rows.items()}
for name, v in rows.items():
    print(f"{name:26s} {med[name]:8.3f} s  log L {v[-1][1]:.4f}  {v[-1][2]} it  {v[-1][3]} ev  "
          f"converged {v[-1][4]}  ({len(v)} passes)")
for name in med:
    if name.endswith("-exact"):
        base = name[: -len("-exact")]
        print(f"{base:26s} differences / exact = {med[base + '-differences'] / med[name]:.2f}")
PY
