#!/usr/bin/env python3
"""Robustness of greybench's estimator from generic start values.

Generates about 50 identification problems, deterministic from fixed seeds, fits each one with
`greybench-cli estimate` from GENERIC start values, and checks whether that fit reaches the best
optimum known for the problem.

Problems (written into --workdir):
  fuel film dyno    `greybench-cli dyno fuel --point P --seed S`, the six Table 2 points
                    (f1 f2 f3 f4 f7 f8) x seeds 1..3 (18 problems)
  fuel film random  `greybench-cli simulate assets/models/fuel_film.json` with parameters drawn over
                    the Table 2 ranges (X down to 0.05), PRBS input as on the dyno (bias 1/Kb +/- 10 %,
                    order 6, bit 0.5 s, Ts 0.0125 s, 125 s = 10 000 rows), and a true output delay of
                    2..7 samples applied by shifting the output column: y_k = h(x_{k-d}) (12 problems)
  crankshaft        `greybench-cli dyno crankshaft --seed S`, seeds 1..10 (10 problems)
  thermal           a 3-state house model (room air, walls, floor; heater and outdoor temperature
                    inputs; the room temperature measured), written to the workdir as JSON and
                    simulated from PRBS inputs with parameters drawn around a nominal house (12 problems)

Each problem is fitted twice (`estimate MODEL DATA --threads 1`, under `nice -n 10`):
  (a) generic: fuel film with bench/models/fuel_film_generic.json (delay scanned 0..10), crankshaft
      and thermal with the generic-start models of GENERIC_STARTS below;
  (b) truth:   the same model (same bounds) started at the true values, the delay fixed at the truth.
The reference optimum is the better log-likelihood of (a) and (b). The generic fit "reaches the best
optimum" when its log-likelihood >= best - LOGLIK_TOL (0.01).

Comparable log-likelihoods: with the delay scanned over [0, 10] the estimator scores every candidate
on the observations k >= 10 (user guide §1); with a fixed delay d it would score k >= d. The
truth fit of a fuel-film problem therefore reads a copy of the data whose first 10 outputs are NA
(missing), so both fits use the same observations. (`loglik` at the generic estimate with the delay
fixed on that copy reproduces the generic fit's log-likelihood to the last digit.) The script checks
that both fits report the same n_obs and flags a problem where they do not.

Prints a Markdown table per family and every problem that did not reach the best optimum; --csv
writes the raw rows.

Run (from the repository root):
    python3 bench/robustness.py --csv /tmp/robustness.csv
    python3 bench/robustness.py --quick            # 4 problems, to check the script
Options: --cli PATH, --workdir DIR (default: a fresh temporary directory), --csv FILE, --jobs N
(fits run in N parallel processes; default 1), --quick.
"""

import argparse
import concurrent.futures
import copy
import csv
import json
import math
import os
import random
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DEFAULT_CLI = "/work/main/build/app/greybench-cli"
FUEL_MODEL = os.path.join(REPO, "assets", "models", "fuel_film.json")
FUEL_GENERIC_MODEL = os.path.join(REPO, "bench", "models", "fuel_film_generic.json")
CRANK_MODEL = os.path.join(REPO, "assets", "models", "crankshaft.json")

LOGLIK_TOL = 0.01  # a generic fit reaches the best optimum if loglik >= best - LOGLIK_TOL
FIT_TIMEOUT_S = 1800  # one estimate run; a run past this is recorded as an error
NICE = ["nice", "-n", "10"] if shutil.which("nice") else []

FUEL_POINTS = ["f1", "f2", "f3", "f4", "f7", "f8"]
FUEL_DYNO_SEEDS = [1, 2, 3]
FUEL_RANDOM_SEEDS = list(range(1, 13))
CRANK_SEEDS = list(range(1, 11))
THERMAL_SEEDS = list(range(1, 13))
QUICK = {"fuel_dyno": [("f1", 1)], "fuel_random": [1], "crankshaft": [1], "thermal": [1]}

FUEL_TS = 0.0125  # s, as the dyno records
FUEL_DURATION = 125.0  # s: 10 000 rows
FUEL_MAX_DELAY = 10  # the generic model scans the delay over 0..10 samples

# Ranges for the random fuel-film problems: the spread of docs/case-study-table2.csv, rounded
# outwards, except X, drawn from 0.05 up. Variances are drawn log-uniformly.
FUEL_RANGES = {
    "tau_fv": (0.07, 0.10, "lin"),
    "tau_ff": (0.33, 0.50, "lin"),
    "X": (0.05, 0.18, "lin"),
    "Kb": (0.65, 1.20, "lin"),
    "s11": (1.0e-3, 1.6e-2, "log"),
    "s12": (1.5e-4, 1.8e-3, "log"),
    "s2": (5.0e-5, 1.2e-4, "log"),
}
FUEL_DELAY_RANGE = (2, 7)  # true delay in samples

# Generic start values and bounds: (start, lower, upper). Round, order-of-magnitude values, wide
# bounds, chosen without looking at any fit. The fuel-film entry documents the existing model
# file (used as is); crankshaft and thermal build their generic models from these entries.
GENERIC_STARTS = {
    "fuel film (bench/models/fuel_film_generic.json, delay scanned 0..10)": {
        "tau_fv": (0.05, 0.001, 2.0),
        "tau_ff": (0.5, 0.01, 5.0),
        "X": (0.3, 0.0, 1.0),
        "Kb": (1.0, 0.1, 5.0),
        "s11": (1e-3, 1e-9, 1.0),
        "s12": (1e-3, 1e-9, 1.0),
        "s2": (1e-3, 1e-9, 1.0),
        "mfi0": (1.2, 0.01, 10.0),
    },
    "crankshaft": {  # assets/models/crankshaft.json with these values and bounds
        "tau_f": (1.0, 0.01, 100.0),  # s
        "Je": (1.0, 0.001, 100.0),  # N m s/rpm
        "Gp": (1.0, 0.01, 100.0),  # N m/kPa
        "Kn": (0.01, 1e-6, 1.0),  # kPa/rpm
        "Ktheta": (1.0, 0.01, 100.0),  # kPa/deg
        "s1": (10.0, 1e-6, 1e6),  # rpm^2/s
        "s21": (10.0, 1e-6, 1e6),  # rpm^2
        "s22": (1.0, 1e-6, 1e6),  # kPa^2
    },
    "thermal": {  # THERMAL_MODEL below with these values and bounds
        "Ci": (1.0, 0.001, 100.0),  # kWh/K, room air
        "Cw": (1.0, 0.001, 100.0),  # kWh/K, walls
        "Cf": (1.0, 0.001, 100.0),  # kWh/K, floor
        "Riw": (1.0, 0.01, 100.0),  # K/kW, air - walls
        "Rwa": (1.0, 0.01, 100.0),  # K/kW, walls - outdoor
        "Rif": (1.0, 0.01, 100.0),  # K/kW, air - floor
        "si": (0.01, 1e-8, 10.0),  # K^2/h
        "sw": (0.01, 1e-8, 10.0),  # K^2/h
        "sf": (0.01, 1e-8, 10.0),  # K^2/h
        "sy": (0.01, 1e-8, 10.0),  # K^2
        "Ti0": (20.0, -20.0, 60.0),  # degC
        "Tw0": (20.0, -20.0, 60.0),  # degC
        "Tf0": (20.0, -20.0, 60.0),  # degC
    },
}

# Thermal model (time in hours, temperatures in degC, power in kW): heater Ph into the room air,
# outdoor temperature Ta through the walls; room air - floor exchange; the room air is measured.
THERMAL_MODEL = {
    "greybench_model": 1,
    "name": "House: room air, walls, floor (robustness study)",
    "states": ["Ti", "Tw", "Tf"],
    "inputs": ["Ph", "Ta"],
    "outputs": ["Troom"],
    "parameters": {},  # filled from GENERIC_STARTS["thermal"] or the truth
    "drift": {
        "Ti": "((Tw - Ti)/Riw + (Tf - Ti)/Rif + Ph)/Ci",
        "Tw": "((Ti - Tw)/Riw + (Ta - Tw)/Rwa)/Cw",
        "Tf": "(Ti - Tf)/(Rif*Cf)",
    },
    "diffusion": {"Ti": "sqrt(si)", "Tw": "sqrt(sw)", "Tf": "sqrt(sf)"},
    "observation": {"Troom": "Ti"},
    "measurement_variance": {"Troom": "sy"},
    "initial_state": {"Ti": "Ti0", "Tw": "Tw0", "Tf": "Tf0"},
    "initial_covariance": "ctsm",
    "input_hold": "zoh",
}
# Nominal house; each random problem scales it (physical parameters by 0.5..2, variances by 0.3..3).
THERMAL_NOMINAL = {
    "Ci": 0.2, "Cw": 4.0, "Cf": 1.5, "Riw": 1.5, "Rwa": 8.0, "Rif": 0.8,
    "si": 0.01, "sw": 0.002, "sf": 0.002, "sy": 0.01,
}
THERMAL_TS = 0.1  # h (6 min)
THERMAL_DURATION = 336.0  # h (two weeks, 3360 rows)

FAMILIES = ["fuel film dyno", "fuel film random", "crankshaft", "thermal"]


# ---------------------------------------------------------------------------------------------
# Running the CLI


class CliError(RuntimeError):
    """The CLI failed while generating a problem: carries its exact message."""


def run_cli(cli, args, log_path=None, timeout=None):
    """Runs `nice -n 10 cli args...`; returns (exit code, stdout, stderr)."""
    cmd = NICE + [cli] + [str(a) for a in args]
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
        rc, out, err = proc.returncode, proc.stdout, proc.stderr
    except subprocess.TimeoutExpired:
        rc, out, err = -1, "", f"timed out after {timeout} s"
    if log_path:
        with open(log_path, "w") as f:
            f.write("$ " + " ".join(cmd) + "\n" + out + "\n--- stderr ---\n" + err)
    return rc, out, err


def run_cli_checked(cli, args):
    rc, out, err = run_cli(cli, args)
    if rc != 0:
        raise CliError(f"greybench-cli {' '.join(map(str, args))}: exit {rc}: {err.strip()}")
    return out


# ---------------------------------------------------------------------------------------------
# Files


def read_csv(path):
    """(comment lines, header, rows as lists of strings) of a greybench CSV."""
    comments, header, rows = [], None, []
    with open(path) as f:
        for line in f:
            line = line.rstrip("\n")
            if not line:
                continue
            if line.startswith("#"):
                comments.append(line)
            elif header is None:
                header = line.split(",")
            else:
                rows.append(line.split(","))
    return comments, header, rows


def write_csv(path, comments, header, rows):
    with open(path, "w") as f:
        for c in comments:
            f.write(c + "\n")
        f.write(",".join(header) + "\n")
        for r in rows:
            f.write(",".join(r) + "\n")


def mask_first_outputs(src, dst, outputs, n):
    """Copy of a data file with the first n values of each output column set to NA."""
    comments, header, rows = read_csv(src)
    cols = [header.index(o) for o in outputs]
    for r in rows[:n]:
        for c in cols:
            r[c] = "NA"
    write_csv(dst, comments + [f"# robustness.py: first {n} outputs masked (NA)"], header, rows)


def parse_truth(path):
    """The `# truth: a = 1.2 s, b = 3, ...` line of a dyno CSV as {name: value}."""
    with open(path) as f:
        for line in f:
            if line.startswith("# truth:"):
                return {k: float(v) for k, v in re.findall(r"(\w+) = ([-+0-9.eE]+)", line)}
    raise CliError(f"{path}: no '# truth:' line")


def load_json(path):
    with open(path) as f:
        return json.load(f)


def write_json(path, obj):
    with open(path, "w") as f:
        json.dump(obj, f, indent=1)
        f.write("\n")


def inside(value, lower, upper):
    """value if it lies strictly inside (lower, upper), else moved just inside (a start on a
    bound is a poor start)."""
    if lower < value < upper:
        return value
    if value <= lower:
        return lower * 1.01 if lower > 0 else lower + 1e-6 * (upper - lower)
    return upper * 0.99 if upper > 0 else upper - 1e-6 * (upper - lower)


def with_values(model, values, delay=None):
    """Copy of a model with the given start values (kept inside the bounds) and a fixed delay."""
    m = copy.deepcopy(model)
    for name, v in values.items():
        p = m["parameters"][name]
        m["parameters"][name]["value"] = inside(v, p.get("lower", -math.inf),
                                                p.get("upper", math.inf))
    if delay is not None:
        m["output_delay"] = {o: int(delay) for o in m["output_delay"]}
    return m


def generic_parameters(starts, base=None):
    params = {}
    for name, (v, lo, hi) in starts.items():
        p = dict(base.get(name, {})) if base else {}
        p.update({"value": v, "lower": lo, "upper": hi})
        params[name] = p
    return params


# ---------------------------------------------------------------------------------------------
# Problem generation. A problem is a dict: name, family, data, generic model, truth model, truth
# data (the data the truth fit reads), truth values and delay.


def fuel_dyno_problem(cli, wd, point, seed):
    name = f"fuel_{point}_s{seed}"
    data = os.path.join(wd, "data", name + ".csv")
    run_cli_checked(cli, ["dyno", "fuel", "--point", point, "--seed", seed, "--out", data])
    truth = parse_truth(data)
    _, header, rows = read_csv(data)
    ts = float(rows[1][0]) - float(rows[0][0])
    delay = int(round(truth.pop("delay") / ts))
    truth["mfi0"] = float(rows[0][header.index("mfi")])  # the record starts at the bias
    return fuel_problem_files(wd, name, "fuel film dyno", data, truth, delay)


def fuel_random_problem(cli, wd, seed):
    name = f"fuel_rand_s{seed}"
    rng = random.Random(1000 + seed)
    truth = {}
    for p, (lo, hi, scale) in FUEL_RANGES.items():
        if scale == "log":
            truth[p] = math.exp(rng.uniform(math.log(lo), math.log(hi)))
        else:
            truth[p] = rng.uniform(lo, hi)
    delay = rng.randint(*FUEL_DELAY_RANGE)
    bias = 1.0 / truth["Kb"]  # lambda about 1, as on the dyno
    u = os.path.join(wd, "data", name + "_u.csv")
    run_cli_checked(cli, ["prbs", "--order", 6, "--period", 0.5, "--ts", FUEL_TS,
                          "--duration", FUEL_DURATION, "--low", 0.9 * bias, "--high", 1.1 * bias,
                          "--name", "mfi", "--seed", 1 + (seed * 7) % 63, "--out", u])
    _, uh, urows = read_csv(u)
    truth["mfi0"] = float(urows[0][uh.index("mfi")])  # start in equilibrium with the first input
    sim = os.path.join(wd, "data", name + "_sim.csv")
    sets = []
    for p, v in truth.items():
        sets += ["--set", f"{p}={v!r}"]
    run_cli_checked(cli, ["simulate", FUEL_MODEL, "--inputs", u] + sets
                    + ["--seed", 100 + seed, "--out", sim])
    # The delay: y_k = h(x_{k-d}) + e_k. The first d outputs have no x to come from: NA.
    comments, header, rows = read_csv(sim)
    col = header.index("ilambda")
    y = [r[col] for r in rows]
    for k, r in enumerate(rows):
        r[col] = y[k - delay] if k >= delay else "NA"
    data = os.path.join(wd, "data", name + ".csv")
    desc = ", ".join(f"{p} = {v:.6g}" for p, v in truth.items())
    write_csv(data, comments + [f"# robustness.py truth: {desc}, delay = {delay} samples"],
              header, rows)
    return fuel_problem_files(wd, name, "fuel film random", data, truth, delay)


def fuel_problem_files(wd, name, family, data, truth, delay):
    generic = load_json(FUEL_GENERIC_MODEL)
    truth_model = os.path.join(wd, "models", name + "_truth.json")
    write_json(truth_model, with_values(generic, truth, delay))
    truth_data = os.path.join(wd, "data", name + "_masked.csv")
    mask_first_outputs(data, truth_data, generic["outputs"], FUEL_MAX_DELAY)
    return {"name": name, "family": family, "data": data, "generic_model": FUEL_GENERIC_MODEL,
            "truth_model": truth_model, "truth_data": truth_data, "truth": truth,
            "truth_delay": delay}


def crank_generic_model(wd):
    path = os.path.join(wd, "models", "crankshaft_generic.json")
    if not os.path.exists(path):
        m = load_json(CRANK_MODEL)
        m["name"] = "Crankshaft speed, generic start values and bounds (robustness study)"
        m["parameters"] = generic_parameters(GENERIC_STARTS["crankshaft"], m["parameters"])
        write_json(path, m)
    return path


def crank_problem(cli, wd, seed):
    name = f"crank_s{seed}"
    data = os.path.join(wd, "data", name + ".csv")
    run_cli_checked(cli, ["dyno", "crankshaft", "--seed", seed, "--out", data])
    truth = parse_truth(data)
    generic = crank_generic_model(wd)
    truth_model = os.path.join(wd, "models", name + "_truth.json")
    write_json(truth_model, with_values(load_json(generic), truth))
    return {"name": name, "family": "crankshaft", "data": data, "generic_model": generic,
            "truth_model": truth_model, "truth_data": data, "truth": truth, "truth_delay": None}


def thermal_models(wd):
    """(reference model for simulation, generic-start model) paths."""
    ref = os.path.join(wd, "models", "thermal.json")
    gen = os.path.join(wd, "models", "thermal_generic.json")
    if not os.path.exists(gen):
        m = copy.deepcopy(THERMAL_MODEL)
        m["parameters"] = generic_parameters(GENERIC_STARTS["thermal"])
        write_json(gen, m)
        nominal = dict(THERMAL_NOMINAL, Ti0=20.0, Tw0=12.0, Tf0=18.0)
        m = with_values(m, nominal)
        m["name"] = "House: room air, walls, floor (nominal values)"
        write_json(ref, m)
    return ref, gen


def thermal_problem(cli, wd, seed):
    name = f"thermal_s{seed}"
    ref, generic = thermal_models(wd)
    rng = random.Random(2000 + seed)
    truth = {}
    for p, v in THERMAL_NOMINAL.items():
        f = (0.3, 3.0) if p.startswith("s") else (0.5, 2.0)
        truth[p] = v * math.exp(rng.uniform(math.log(f[0]), math.log(f[1])))
    truth["Ti0"] = rng.uniform(17.0, 23.0)
    truth["Tw0"] = rng.uniform(5.0, 15.0)
    truth["Tf0"] = rng.uniform(15.0, 22.0)
    ph = os.path.join(wd, "data", name + "_Ph.csv")
    ta = os.path.join(wd, "data", name + "_Ta.csv")
    run_cli_checked(cli, ["prbs", "--order", 8, "--period", 1.0, "--ts", THERMAL_TS,
                          "--duration", THERMAL_DURATION, "--low", 1.0, "--high", 3.0,
                          "--name", "Ph", "--seed", 1 + (seed * 37) % 255, "--out", ph])
    run_cli_checked(cli, ["prbs", "--order", 5, "--period", 6.0, "--ts", THERMAL_TS,
                          "--duration", THERMAL_DURATION, "--low", -5.0, "--high", 5.0,
                          "--name", "Ta", "--seed", 1 + (seed * 11) % 31, "--out", ta])
    _, h1, r1 = read_csv(ph)
    _, h2, r2 = read_csv(ta)
    if len(r1) != len(r2) or any(a[0] != b[0] for a, b in zip(r1, r2)):
        raise CliError(f"{ph} and {ta}: the two PRBS files have different time columns")
    u = os.path.join(wd, "data", name + "_u.csv")
    write_csv(u, [], ["t", "Ph", "Ta"],
              [[a[0], a[h1.index("Ph")], b[h2.index("Ta")]] for a, b in zip(r1, r2)])
    data = os.path.join(wd, "data", name + ".csv")
    sets = []
    for p, v in truth.items():
        sets += ["--set", f"{p}={v!r}"]
    run_cli_checked(cli, ["simulate", ref, "--inputs", u] + sets
                    + ["--seed", 300 + seed, "--out", data])
    truth_model = os.path.join(wd, "models", name + "_truth.json")
    write_json(truth_model, with_values(load_json(generic), truth))
    return {"name": name, "family": "thermal", "data": data, "generic_model": generic,
            "truth_model": truth_model, "truth_data": data, "truth": truth, "truth_delay": None}


def make_problems(cli, wd, quick):
    """(problems, generation errors)."""
    for sub in ("data", "models", "fits"):
        os.makedirs(os.path.join(wd, sub), exist_ok=True)
    fuel_dyno = QUICK["fuel_dyno"] if quick else [(p, s) for s in FUEL_DYNO_SEEDS
                                                  for p in FUEL_POINTS]
    jobs = [(fuel_dyno_problem, (p, s)) for p, s in fuel_dyno]
    jobs += [(fuel_random_problem, (s,)) for s in (QUICK["fuel_random"] if quick
                                                   else FUEL_RANDOM_SEEDS)]
    jobs += [(crank_problem, (s,)) for s in (QUICK["crankshaft"] if quick else CRANK_SEEDS)]
    jobs += [(thermal_problem, (s,)) for s in (QUICK["thermal"] if quick else THERMAL_SEEDS)]
    problems, errors = [], []
    for fn, args in jobs:
        try:
            problems.append(fn(cli, wd, *args))
        except CliError as e:
            errors.append(str(e))
            print("generation error: " + str(e), file=sys.stderr)
    return problems, errors


# ---------------------------------------------------------------------------------------------
# Fitting


def fit(cli, model, data, out):
    """One `estimate` run: {"rc", "stderr", "result" (the result JSON or None)}."""
    if os.path.exists(out):
        os.remove(out)
    rc, _, err = run_cli(cli, ["estimate", model, data, "--threads", 1, "--out", out],
                         log_path=out[:-5] + ".log", timeout=FIT_TIMEOUT_S)
    result = None
    if os.path.exists(out):
        try:
            result = load_json(out)
        except ValueError:
            pass
    return {"rc": rc, "stderr": err.strip(), "result": result}


def fit_problem(cli, wd, p):
    fits = os.path.join(wd, "fits")
    return (fit(cli, p["generic_model"], p["data"], os.path.join(fits, p["name"] + "_generic.json")),
            fit(cli, p["truth_model"], p["truth_data"], os.path.join(fits, p["name"] + "_truth.json")))


def delay_estimate(result):
    if not result or not result.get("output_delay"):
        return None
    return next(iter(result["output_delay"].values())).get("estimate")


def fit_message(f):
    """The fit's message; the CLI's stderr when it wrote no result."""
    if f["result"] is not None:
        return f["result"].get("message", "")
    return f"exit {f['rc']}: {f['stderr']}"


def make_row(p, generic, truth):
    g, t = generic["result"], truth["result"]
    g_ll = g.get("loglik") if g else None
    t_ll = t.get("loglik") if t else None
    finite = [v for v in (g_ll, t_ll) if v is not None and math.isfinite(v)]
    best = max(finite) if finite else None
    reached = g_ll is not None and best is not None and g_ll >= best - LOGLIK_TOL
    note = ""
    if g and t and g.get("n_obs") != t.get("n_obs"):
        note = f"n_obs differ: generic {g.get('n_obs')}, truth {t.get('n_obs')} (logliks not comparable)"
    return {
        "name": p["name"], "family": p["family"],
        "generic_loglik": g_ll, "truth_loglik": t_ll, "best_loglik": best,
        "gap": (best - g_ll) if g_ll is not None and best is not None else None,
        "reached_best": reached,
        "converged": bool(g and g.get("converged")),
        "truth_converged": bool(t and t.get("converged")),
        "elapsed_s": g.get("elapsed_s") if g else None,
        "iterations": g.get("iterations") if g else None,
        "evaluations": g.get("evaluations") if g else None,
        "truth_elapsed_s": t.get("elapsed_s") if t else None,
        "n_obs": g.get("n_obs") if g else None,
        "true_delay": p["truth_delay"], "generic_delay": delay_estimate(g) if p["truth_delay"] is not None else None,
        "generic_rc": generic["rc"], "truth_rc": truth["rc"],
        "message": fit_message(generic), "truth_message": fit_message(truth),
        "note": note,
    }


# ---------------------------------------------------------------------------------------------
# Report


def fmt(v, digits=2):
    return "-" if v is None else f"{v:.{digits}f}"


def summary_line(label, rows):
    n = len(rows)
    reached = sum(r["reached_best"] for r in rows)
    conv = sum(r["converged"] for r in rows)
    times = [r["elapsed_s"] for r in rows if r["elapsed_s"] is not None]
    iters = [r["iterations"] for r in rows if r["iterations"] is not None]
    pct = 100.0 * reached / n if n else 0.0
    return (f"| {label} | {n} | {reached} ({pct:.0f} %) | {conv} | "
            f"{fmt(statistics.median(times) if times else None)} | "
            f"{fmt(max(times) if times else None)} | "
            f"{fmt(statistics.median(iters) if iters else None, 0)} |")


def report(rows, gen_errors):
    lines = [
        f"Generic fit reaches the best optimum: loglik >= max(generic, truth-start) - {LOGLIK_TOL}.",
        "",
        "| family | problems | reached best | converged | median fit time (s) | max fit time (s) "
        "| median iterations |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for fam in FAMILIES:
        fam_rows = [r for r in rows if r["family"] == fam]
        if fam_rows:
            lines.append(summary_line(fam, fam_rows))
    lines.append(summary_line("**total**", rows))
    lines.append("")
    failures = [r for r in rows if not r["reached_best"]]
    lines.append(f"Problems that did not reach the best optimum: {len(failures)}")
    for r in failures:
        delay = ("" if r["true_delay"] is None else
                 f"delay generic {r['generic_delay']} / true {r['true_delay']}; ")
        lines.append(f"- {r['name']}: generic loglik {fmt(r['generic_loglik'], 3)}, "
                     f"best {fmt(r['best_loglik'], 3)} (gap {fmt(r['gap'], 3)}); {delay}"
                     f"converged {r['converged']}; message: {r['message']}")
    notes = [r for r in rows if r["note"] or r["generic_rc"] != 0 or r["truth_rc"] != 0]
    if notes:
        lines.append("")
        lines.append("Non-zero exit codes and other notes:")
        for r in notes:
            lines.append(f"- {r['name']}: generic exit {r['generic_rc']} ({r['message']}); "
                         f"truth exit {r['truth_rc']} ({r['truth_message']}) {r['note']}".rstrip())
    if gen_errors:
        lines.append("")
        lines.append("CLI errors while generating problems (exact messages):")
        lines += [f"- {e}" for e in gen_errors]
    return "\n".join(lines)


def write_rows(path, rows):
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        for r in rows:
            w.writerow({k: ("" if v is None else v) for k, v in r.items()})


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cli", default=DEFAULT_CLI, help="greybench-cli (default: %(default)s)")
    ap.add_argument("--workdir", help="where problems and fits go (default: a fresh temp dir)")
    ap.add_argument("--csv", help="write the raw rows here")
    ap.add_argument("--jobs", type=int, default=1, help="fits in parallel processes (default 1)")
    ap.add_argument("--quick", action="store_true", help="4 problems only, to check the script")
    args = ap.parse_args()

    start = time.monotonic()
    cli = os.path.abspath(args.cli)
    if not os.access(cli, os.X_OK):
        ap.error(f"--cli {cli}: not an executable file")
    wd = os.path.abspath(args.workdir) if args.workdir else tempfile.mkdtemp(
        prefix="greybench-robustness-")
    os.makedirs(wd, exist_ok=True)
    print(f"workdir: {wd}", file=sys.stderr)

    problems, gen_errors = make_problems(cli, wd, args.quick)
    print(f"{len(problems)} problems generated in {time.monotonic() - start:.1f} s; fitting "
          f"with {args.jobs} job(s)", file=sys.stderr)

    rows = [None] * len(problems)
    with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        futures = {pool.submit(fit_problem, cli, wd, p): i for i, p in enumerate(problems)}
        for done, fut in enumerate(concurrent.futures.as_completed(futures), 1):
            i = futures[fut]
            rows[i] = make_row(problems[i], *fut.result())
            r = rows[i]
            print(f"[{done}/{len(problems)}] {r['name']}: generic {fmt(r['generic_loglik'], 3)} "
                  f"truth {fmt(r['truth_loglik'], 3)} reached={r['reached_best']} "
                  f"({fmt(r['elapsed_s'])} s)", file=sys.stderr)

    if args.csv:
        write_rows(args.csv, rows)
    print(report(rows, gen_errors))
    print(f"\nTotal wall time: {time.monotonic() - start:.1f} s "
          f"({len(problems)} problems, {2 * len(problems)} fits, --jobs {args.jobs})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
