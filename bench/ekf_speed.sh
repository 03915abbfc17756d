#!/usr/bin/env bash
# greybench's extended Kalman filter side by side with ctsmTMB's "ekf" (the peer,
# ../shared/peers/ctsmtmb; never a dependency), for docs/benchmarks.md (issue 15). The passes
# alternate between the tools, so a change of load on the shared machine hits both alike.
#
#   bench/ekf_speed.sh [PASSES] [PARTS]     (default 3 and "loglik tanks"; needs build/ and R with
#                                            ctsmTMB; GREYBENCH_CLI overrides build/app/greybench-cli)
#
# PARTS, any of:
#   loglik  PASSES passes over the tank chains of bench/loglik_bench.cpp (2 tanks, 2 tanks + a fast
#           sensor (stiff, 3 states), 10 tanks; 2000 samples of a PRBS every 0.5, simulated here by
#           greybench-cli simulate from the same models, P0 = 1e-4 I in both tools): greybench-cli
#           bench (median of 21 evaluations) and the wall time of loglik --gradient less that of
#           loglik (the 2k shifted filter runs of the central differences); ctsmTMB's tape, fn and
#           AD gradient with its default ODE setting (one RK4 step per interval), and on 2 tanks
#           also with 10 steps (on 10 tanks one step already matches greybench's log L to 1e-3,
#           and 10 would tape for minutes).
#           Once, outside the passes: the stiff model with 200 RK4 steps per interval (the fewest
#           that are stable) on the first 200 samples only, and greybench on the same 200.
#   tanks   the Cascaded Tanks fit from the model file's start values, one fit per tool per pass
#           (TANK_PASSES, default 1): greybench-cli estimate --threads 1 --starts-on-bound 0 (and
#           with its default 8 extra starts where a parameter ends on a bound if TANK_DEFAULT=1,
#           many minutes more); ctsmTMB
#           with one RK4 step per interval (its default) and 10 (0.4 s); each tool's log L at the
#           other's optimum.
#   ou      the Ornstein-Uhlenbeck bias study: OU_REPLICATES (default 50) records of 1000 samples,
#           theta = 1, sigma = 0.5, Delta = 1, r = 0.01 known (simulated exactly by greybench),
#           fitted by greybench (exact filter; and its EKF, forced by a diffusion "sigma + 0*t")
#           and by ctsmTMB's ekf with 1 and 10 RK4 steps per interval.
# R runs with OMP_NUM_THREADS=1 and greybench with one thread (bench and loglik are
# single-threaded; estimate gets --threads 1). Prints each measurement as it goes (one JSON line
# each), then medians; `bench/ekf_speed.sh summary LOG` prints the medians of a saved output again.
set -euo pipefail
cd "$(dirname "$0")/.."
cli=${GREYBENCH_CLI:-build/app/greybench-cli}
export OMP_NUM_THREADS=1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
rscript() { { Rscript bench/ekf_ctsmtmb.R "$@" 2>/dev/null || true; } | { grep '^{' || true; } | tee -a "$tmp/all.jsonl"; }
load() { cut -d' ' -f1 /proc/loadavg; }
summary() {  # summary FILE: medians of the JSON lines a run printed
  python3 - "$1" <<'PY'
import json, statistics, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
med = statistics.median
groups = {}
for r in rows:
    if "ns_per_sample" in r:
        key = (r["model"], r["tool"], r.get("substeps", ""), r["n"])
        groups.setdefault(("loglik",) + key, []).append(r)
    elif "fit" in r or ("substeps" in r and "wall_s" in r and "file" not in r):
        groups.setdefault(("fit", r["tool"], r.get("fit", r.get("substeps"))), []).append(r)
    elif "loglik_at_ctsmTMB_optimum" in r:
        groups.setdefault(("cross", r["ctsmTMB_substeps"]), []).append(r)
    elif "theta" in r and "file" in r:
        groups.setdefault(("ou", r["tool"], r.get("ou", r.get("substeps"))), []).append(r)
for key, v in groups.items():
    if key[0] == "loglik":
        _, model, tool, sub, n = key
        line = (f"{model:14s} {tool:9s} {('RK4 x' + str(sub)) if sub else 'DP5/BDF':8s} n={n}: "
                f"{med(x['ns_per_sample'] for x in v):10.0f} ns/sample, fn {med(x['fn_s'] for x in v)*1e3:9.3f} ms")
        if tool == "ctsmTMB":
            line += (f", gradient {med(x['gr_s'] for x in v)*1e3:9.3f} ms, tape {med(x['tape_s'] for x in v):7.2f} s"
                     f" (setup {med(x['setup_s'] for x in v):6.2f} s)")
        else:
            line += f", gradient's 2k extra runs {med(x['gr_extra_s'] for x in v)*1e3:9.3f} ms (process wall)"
        ll = v[-1]["loglik"]
        print(line + f", log L {'NaN' if ll is None else format(ll, '.4f')}  ({len(v)} passes)")
    elif key[0] == "fit":
        t = "elapsed_s" if key[1] == "greybench" else "wall_s"
        r = v[-1]
        extra = f"nlminb {med(x['nlminb_s'] for x in v):.2f} s, tape {med(x['tape_s'] for x in v):.2f} s, " if key[1] == "ctsmTMB" else ""
        print(f"tanks fit {key[1]:9s} {str(key[2]):8s}: {med(x[t] for x in v):8.2f} s ({extra}log L {r['loglik']}, "
              f"iterations {r['iterations']}, {r.get('converged', r.get('message'))}"
              + (f", log L at greybench's optimum {r['loglik_at_given']}" if 'loglik_at_given' in r else "")
              + f")  ({len(v)} passes)")
    elif key[0] == "cross":
        print(f"greybench's log L at ctsmTMB's optimum (RK4 x{key[1]}): {v[-1]['loglik_at_ctsmTMB_optimum']}")
    elif key[0] == "ou":
        th = [x["theta"] for x in v]; sg = [x["sigma"] for x in v]
        se = lambda a: statistics.stdev(a) / len(a) ** 0.5
        print(f"OU {key[1]:9s} {str(key[2]):7s}: theta {statistics.mean(th):.4f} ± {se(th):.4f} "
              f"(bias {100*(statistics.mean(th)-1):+.1f} %), sigma {statistics.mean(sg):.4f} ± {se(sg):.4f} "
              f"(bias {100*(statistics.mean(sg)/0.5-1):+.1f} %; median {med(sg):.4f}), {len(v)} records, "
              f"median fit {med(x.get('elapsed_s', x.get('wall_s')) for x in v):.3g} s")
PY
}
if [[ ${1:-} == summary ]]; then
  grep '^{' "$2" > "$tmp/all.jsonl"
  summary "$tmp/all.jsonl"
  exit 0
fi
passes=${1:-3}
parts=${2:-"loglik tanks"}

if [[ " $parts " == *" loglik "* ]]; then
  # TankChain(n, fast) of bench/loglik_bench.cpp, with P0 = 1e-4 I (ctsmTMB needs a number)
  python3 - "$tmp" <<'PY'
import json, sys
def chain(n, fast):
    st = [f"h{i}" for i in range(1, n + 1)] + (["m"] if fast else [])
    p = {"k": {"value": 0.5}, "kin": {"value": 0.6}, "s": {"value": 0.02}, "r": {"value": 0.001}}
    if fast: p["tau"] = {"value": 0.002}
    j = {"greybench_model": 1, "states": st, "inputs": ["u"], "outputs": ["y"], "parameters": p,
         "drift": {}, "diffusion": {}, "initial_state": {}}
    for i in range(1, n + 1):
        inflow = "kin*u" if i == 1 else f"k*sqrt(h{i-1})"
        j["drift"][f"h{i}"] = f"{inflow} - k*sqrt(h{i})"
        j["diffusion"][f"h{i}"] = "s"
        j["initial_state"][f"h{i}"] = "1.4"
    if fast:
        j["drift"]["m"] = f"(h{n} - m)/tau"
        j["initial_state"]["m"] = "1.4"
        j["observation"] = {"y": "m"}
    else:
        j["observation"] = {"y": f"h{n}"}
    j["measurement_variance"] = {"y": "r"}
    j["initial_covariance"] = {s: "1e-4" for s in st}
    return j
for n, fast, name in [(2, False, "tanks2"), (2, True, "tanks2+sensor"), (10, False, "tanks10")]:
    json.dump(chain(n, fast), open(f"{sys.argv[1]}/{name}.json", "w"), indent=1)
PY
  "$cli" prbs --order 6 --period 5 --ts 0.5 --duration 1000 --low 0.8 --high 1.2 --out "$tmp/u.csv" >/dev/null
  for m in tanks2 tanks2+sensor tanks10; do
    "$cli" simulate "$tmp/$m.json" --inputs "$tmp/u.csv" --seed 1 --out "$tmp/$m.csv" >/dev/null
  done
  gb_loglik() {  # gb_loglik NAME: greybench's eval time, log L, and the gradient's extra time
    local m=$1 t0 t1 t2
    "$cli" bench "$tmp/$m.json" "$tmp/$m.csv" --repeat 21 > "$tmp/b.json"
    t0=$(date +%s.%N); "$cli" loglik "$tmp/$m.json" "$tmp/$m.csv" > "$tmp/l.json"
    t1=$(date +%s.%N); "$cli" loglik "$tmp/$m.json" "$tmp/$m.csv" --gradient > /dev/null
    t2=$(date +%s.%N)
    python3 -c "
import json, sys
b = json.load(open(sys.argv[1])); l = json.load(open(sys.argv[2]))
t0, t1, t2 = map(float, sys.argv[4:7])
print(json.dumps({'tool': 'greybench', 'model': sys.argv[3], 'n': b['n_obs'], 'fn_s': b['loglik_eval_s'],
                  'ns_per_sample': 1e9 * b['loglik_eval_s'] / b['n_obs'], 'gr_extra_s': (t2 - t1) - (t1 - t0),
                  'loglik': l['loglik']}))" "$tmp/b.json" "$tmp/l.json" "$m" "$t0" "$t1" "$t2" | tee -a "$tmp/all.jsonl"
  }
  for pass in $(seq "$passes"); do
    echo "# loglik pass $pass, load $(load)"
    gb_loglik tanks2
    rscript loglik 2 0 "$tmp/tanks2.csv" 1
    rscript loglik 2 0 "$tmp/tanks2.csv" 10
    gb_loglik tanks2+sensor
    rscript loglik 2 1 "$tmp/tanks2+sensor.csv" 1
    gb_loglik tanks10
    rscript loglik 10 0 "$tmp/tanks10.csv" 1
  done
  echo "# the stiff model, first 200 samples, load $(load)"
  head -n 203 "$tmp/tanks2+sensor.csv" > "$tmp/tanks2+sensor-200.csv"  # 2 comment lines + header
  cp "$tmp/tanks2+sensor.json" "$tmp/tanks2+sensor-200.json"
  gb_loglik tanks2+sensor-200
  rscript loglik 2 1 "$tmp/tanks2+sensor.csv" 200 5 200
fi

if [[ " $parts " == *" tanks "* ]]; then
  model=assets/models/cascaded_tanks.json
  data=assets/data/tanks_estimation.csv
  gb_fit() {  # gb_fit NAME ARGS...: greybench's fit, then ctsmTMB's log L at its optimum
    local name=$1
    shift
    local t0 t1
    t0=$(date +%s.%N)
    "$cli" estimate "$model" "$data" --threads 1 "$@" --out "$tmp/r-$name.json" >/dev/null || true
    t1=$(date +%s.%N)
    python3 -c "
import json, sys
r = json.load(open(sys.argv[1]))
p = {k: v['estimate'] for k, v in r['parameters'].items()}
open(sys.argv[2], 'w').write(''.join(f'{k} {v!r}\n' for k, v in p.items()))
print(json.dumps({'tool': 'greybench', 'fit': sys.argv[3], 'elapsed_s': r['elapsed_s'], 'wall_s': float(sys.argv[5]) - float(sys.argv[4]),
                  'loglik': r['loglik'], 'iterations': r['iterations'], 'evaluations': r['evaluations'],
                  'converged': r['converged'], 'starts': r.get('starts'), **p}))" \
      "$tmp/r-$name.json" "$tmp/at-$name.txt" "$name" "$t0" "$t1" | tee -a "$tmp/all.jsonl"
  }
  ct_fit() {  # ct_fit SUBSTEPS: ctsmTMB's fit (with log L at greybench's last optimum), then
              # greybench's log L at ctsmTMB's optimum
    rscript tanks "$data" "$1" "$tmp/at-single.txt" > "$tmp/ct.jsonl" || true
    cat "$tmp/ct.jsonl"
    python3 - "$tmp/ct.jsonl" "$model" "$data" "$cli" <<'PY' | tee -a "$tmp/all.jsonl" || true
import json, subprocess, sys
lines = open(sys.argv[1]).readlines()
r = json.loads(lines[0]) if lines else {}
names = ["k1", "a1", "k3", "a2", "k4", "kx", "h1max", "h2max", "y0", "r", "h10", "h20"]
if r.get(names[0]) is not None:
    sets = [f"{k}={r[k]!r}" for k in names]
    p = subprocess.run([sys.argv[4], "loglik", sys.argv[2], sys.argv[3], "--set", *sets],
                       capture_output=True, text=True)
    ll = json.loads(p.stdout)["loglik"] if p.returncode == 0 else None
    print(json.dumps({"tool": "greybench", "loglik_at_ctsmTMB_optimum": ll,
                      "ctsmTMB_substeps": r["substeps"], "error": p.stderr.strip()[:200]}))
PY
  }
  for pass in $(seq "${TANK_PASSES:-1}"); do
    echo "# tanks pass $pass, load $(load)"
    gb_fit single --starts-on-bound 0
    ct_fit 1
    if [[ ${TANK_DEFAULT:-0} == 1 ]]; then gb_fit default; fi
    ct_fit 10
  done
fi

if [[ " $parts " == *" ou "* ]]; then
  reps=${OU_REPLICATES:-50}
  cat > "$tmp/ou.json" <<'JSON'
{"greybench_model": 1, "states": ["x"], "inputs": [], "outputs": ["y"],
 "parameters": {"theta": {"value": 1, "lower": 0.01, "upper": 10},
                "sigma": {"value": 0.5, "lower": 0.001, "upper": 5},
                "r": {"value": 0.01, "fixed": true}},
 "drift": {"x": "-theta*x"}, "diffusion": {"x": "sigma"}, "observation": {"y": "x"},
 "measurement_variance": {"y": "r"}, "initial_state": {"x": "0"}, "initial_covariance": {"x": "0.125"}}
JSON
  sed 's/"diffusion": {"x": "sigma"}/"diffusion": {"x": "sigma + 0*t"}/' "$tmp/ou.json" > "$tmp/ou_ekf.json"
  python3 -c "print('t'); [print(i) for i in range(1000)]" > "$tmp/t.csv"
  files=()
  for s in $(seq "$reps"); do
    "$cli" simulate "$tmp/ou.json" --inputs "$tmp/t.csv" --seed "$s" --out "$tmp/ou$s.csv" >/dev/null
    files+=("$tmp/ou$s.csv")
  done
  echo "# OU, $reps records, load $(load)"
  for s in $(seq "$reps"); do
    for v in ou ou_ekf; do
      "$cli" estimate "$tmp/$v.json" "$tmp/ou$s.csv" --threads 1 --starts-on-bound 0 --out "$tmp/r.json" >/dev/null
      python3 -c "
import json, sys
r = json.load(open(sys.argv[1]))
print(json.dumps({'tool': 'greybench', 'ou': sys.argv[2], 'file': sys.argv[3], 'elapsed_s': r['elapsed_s'],
                  'theta': r['parameters']['theta']['estimate'], 'sigma': r['parameters']['sigma']['estimate'],
                  'loglik': r['loglik'], 'converged': r['converged']}))" "$tmp/r.json" "$v" "ou$s.csv" | tee -a "$tmp/all.jsonl"
    done
  done
  rscript ou 1 "${files[@]}"
  rscript ou 10 "${files[@]}"
fi

echo "# medians over the passes (load at the end $(load))"
# (bench/ekf_speed.sh summary FILE: the same summary of a run's printed lines)
summary "$tmp/all.jsonl"
