#!/usr/bin/env python3
"""Exported FMUs run by the FMI reference simulator against greybench's own response (issue 38).

    bench/fmu_fmusim.py --cli build/app/greybench-cli --fmusim /tmp/fmusim/fmusim [--keep DIR]

fmusim (../shared/peers/fmusim, built by its build.sh outside ../shared) is a check tool, never a
dependency: this script is run by hand, not by the tests or CI. For each case it exports the
fitted model's FMU (`export-fmu`), runs it through fmusim with the record's inputs as Model
Exchange (CVODE at --tolerance 1e-10) and as Co-Simulation (greybench's Dormand-Prince inside
fmi2DoStep, at the model's "ekf" tolerances, one communication step per sample), and compares the
outputs at the record's times with `greybench-cli simulate --deterministic --result` (the exact
discretisation of a linear model, the error-controlled moment equations' mean of any other).

The inputs are held (zoh): each sample's row is repeated at the next sample's time with the old
values, an input event, so fmusim holds the input over the interval and restarts CVODE there. A
model with the first-order hold (the fuel film, the crankshaft, the engine) is compared with its
hold set to zoh, in a copy of its model file: fmusim has no way to drive a ramped input. Its
Model Exchange loop sets the inputs only at communication points (CVODE's right-hand side does
not apply them), and its Co-Simulation sets no input derivatives (fmi2SetRealInputDerivatives);
greybench's own test drives the ramp (tests/core/fmu_test.cpp).
The FMU has no output delay: its output at t_k is compared with greybench's at row k + d.
fmusim samples a Co-Simulation FMU after fmi2DoStep and before it sets the next inputs, so an
output with direct feedthrough (the crankshaft's Pman = -Kn N + Ktheta theta) shows the previous
sample's input there: in Co-Simulation such an output is compared at the rows where its inputs
did not change (the "rows" column counts the rows compared).

The error of an output is max_k |y_fmu - y_gb| / max_k |y_gb| (relative to the output's size on
the record); the issue asks for 1e-6.

The virtual sensors (export-fmu --virtual-sensor) of the fuel film (linear, ilambda delayed by 5
samples, first-order hold), the crankshaft (linear, P0 "stationary") and the engine model
(nonlinear, three outputs) run through fmusim's
Co-Simulation with the record's u and y, and their outputs are compared with `greybench-cli
predict --result --states`: the filtered states, the one-step predictions and their sd, the
innovations (the issue asks for 1e-8 on the filtered states). After fmi2DoStep from row k the
filtered states are those of row k - D (D the largest delay: the filter waits for the rows it
needs), the innovations those of row k - D + d, and the predictions those of row k + 1, the row
fmusim records them at. With the first-order hold (both cases) the prediction of a state after
the newest row holds its input, since fmusim gives no input derivatives: the engine's
predictions, of the next row, differ from greybench's by that. greybench's fit leaves the first
rows of an output whose delay it scanned unused (as many as the range's largest delay), so the
sensor is given them as not valid.
"""
import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
import zipfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# name, model, result (None: fitted here from the project), data record, project for the fit
CASES = [
    ("fuel_film", "assets/models/fuel_film.json", "assets/results/fuel_f1.json",
     "assets/data/fuel_f1.csv", None),
    ("crankshaft", "assets/models/crankshaft.json", None, "assets/data/crankshaft.csv",
     "assets/projects/crankshaft.json"),
    ("cascaded_tanks", "assets/models/cascaded_tanks.json", "tests/data/tanks/estimates.json",
     "assets/data/tanks_estimation.csv", None),
    ("engine_mvem", "assets/models/engine_mvem.json", "assets/results/engine_mvem.json",
     "assets/data/engine_sweep.csv", None),
]


def run(cmd, **kw):
    started = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, **kw)
    if proc.returncode != 0:
        sys.exit(f"failed ({proc.returncode}): {' '.join(cmd)}\n{proc.stdout}{proc.stderr}")
    return time.perf_counter() - started


def read_csv(path):
    with open(path) as f:
        rows = [r for r in csv.reader(line for line in f if not line.startswith("#"))]
    header = [h.strip().strip('"') for h in rows[0]]
    cols = {h: [] for h in header}
    for r in rows[1:]:
        for h, v in zip(header, r):
            cols[h].append(float(v) if v not in ("", "NA", "nan", "NaN") else float("nan"))
    return cols


def write_inputs(path, t, inputs, stepped):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["time"] + list(inputs))
        for k in range(len(t)):
            row = [inputs[name][k] for name in inputs]
            if stepped and k > 0:  # the old values up to t_k, then the new ones: an input event
                w.writerow([repr(t[k])] + [repr(inputs[name][k - 1]) for name in inputs])
            w.writerow([repr(t[k])] + [repr(v) for v in row])


def feedthrough(fmu_path, spec):
    """Per output, the inputs it depends on directly (the model description's dependencies)."""
    with zipfile.ZipFile(fmu_path) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    names = [v.get("name") for v in root.iter("ScalarVariable")]
    out = {}
    for unknown in root.find("ModelStructure").find("Outputs") or []:
        deps = [names[int(i) - 1] for i in (unknown.get("dependencies") or "").split()]
        out[names[int(unknown.get("index")) - 1]] = [d for d in deps if d in spec["inputs"]]
    return out


def compare(gb, fmu, outputs, delays, t, skip_changed=None):
    """Per output, max |fmu - gb| / max |gb| over the rows greybench has a value for (and, for
    an output in `skip_changed`, at which none of the inputs it names changed)."""
    errors = {}
    fmu_t = fmu["time"]
    for o in outputs:
        d = delays.get(o, 0)
        # fmusim's rows: one per communication point (more at input events in Model Exchange);
        # the last row at each sample time is the value after it.
        at = {}
        for k, tk in enumerate(fmu_t):
            at[round(tk, 9)] = fmu[o][k]
        worst, size, n = 0.0, 0.0, 0
        for k in range(len(t) - d):
            ref = gb[o][k + d]
            value = at.get(round(t[k], 9))
            if value is None or ref != ref:
                continue
            if skip_changed and k > 0 and any(u[k] != u[k - 1] for u in skip_changed.get(o, [])):
                continue
            worst = max(worst, abs(value - ref))
            size = max(size, abs(ref))
            n += 1
        errors[o] = (worst / size if size > 0 else worst, n)
    return errors


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cli", default=os.path.join(ROOT, "build/app/greybench-cli"))
    ap.add_argument("--fmusim", default="/tmp/fmusim/fmusim")
    ap.add_argument("--keep", help="a directory for the FMUs and CSV files (default: temporary)")
    ap.add_argument("--tolerance", type=float, default=1e-10, help="CVODE's relative tolerance")
    args = ap.parse_args()
    work = args.keep or tempfile.mkdtemp(prefix="greybench-fmusim-")
    os.makedirs(work, exist_ok=True)
    print(f"{'case':16} {'hold':4} {'interface':10} {'output':8} {'rows':>6} {'max rel. error':>14} "
          f"{'fmusim s':>8}")
    worst_all = 0.0
    for name, model, result, data, project in CASES:
        model = os.path.join(ROOT, model)
        data = os.path.join(ROOT, data)
        if result is None:
            result = os.path.join(work, f"{name}_fit.json")
            run([args.cli, "estimate", os.path.join(ROOT, project), "--out", result])
        else:
            result = os.path.join(ROOT, result)
        spec = json.load(open(model))
        res = json.load(open(result))
        delays = {o: v.get("estimate", 0) or 0 for o, v in res.get("output_delay", {}).items()}
        record = read_csv(data)
        t = record["t"] if "t" in record else record["time"]
        inputs = {u: record[u] for u in spec["inputs"]}
        ts = t[1] - t[0]
        for hold in ["zoh"]:
            tag = f"{name}_{hold}"
            model_used = model
            if hold != spec.get("input_hold", "zoh"):
                model_used = os.path.join(work, f"{tag}.json")
                with open(model_used, "w") as f:
                    json.dump(dict(spec, input_hold=hold), f)
            fmu = os.path.join(work, f"{name}.fmu")
            run([args.cli, "export-fmu", result, "--model", model_used, "--out", fmu])
            through = feedthrough(fmu, spec)
            gb_csv = os.path.join(work, f"{tag}_greybench.csv")
            run([args.cli, "simulate", model_used, "--inputs", data, "--result", result,
                 "--deterministic", "--out", gb_csv])
            gb = read_csv(gb_csv)
            in_csv = os.path.join(work, f"{tag}_inputs.csv")
            write_inputs(in_csv, t, inputs, stepped=True)
            for interface in ["me", "cs"]:
                out_csv = os.path.join(work, f"{tag}_{interface}.csv")
                cmd = [args.fmusim, "--interface-type", interface, "--start-time", repr(t[0]),
                       "--stop-time", repr(t[-1]), "--output-interval", repr(ts),
                       "--input-file", in_csv, "--output-file", out_csv]
                if interface == "me":
                    cmd += ["--solver", "cvode", "--tolerance", repr(args.tolerance)]
                cmd.append(fmu)
                seconds = run(cmd)
                skip = None
                if interface == "cs":
                    skip = {o: [inputs[u] for u in us] for o, us in through.items()}
                errors = compare(gb, read_csv(out_csv), spec["outputs"], delays, t, skip)
                for o, (err, n) in errors.items():
                    worst_all = max(worst_all, err)
                    print(f"{name:16} {hold:4} {interface:10} {o:8} {n:6d} {err:14.2e} "
                          f"{seconds:8.2f}")
    print(f"largest relative error: {worst_all:.2e} (the issue asks for 1e-6)")
    worst_sensor = virtual_sensors(args, work)
    print(f"virtual sensors, largest relative error of the filtered states: {worst_sensor:.2e} "
          "(the issue asks for 1e-8)")
    if not args.keep:
        print(f"files in {work}")
    return 0 if worst_all <= 1e-6 and worst_sensor <= 1e-8 else 1


SENSORS = [
    ("fuel_film", "assets/models/fuel_film.json", "assets/results/fuel_f1.json",
     "assets/data/fuel_f1.csv"),
    # the fit the first part made (initial_covariance "stationary")
    ("crankshaft", "assets/models/crankshaft.json", "crankshaft_fit.json",
     "assets/data/crankshaft.csv"),
    ("engine_mvem", "assets/models/engine_mvem.json", "assets/results/engine_mvem.json",
     "assets/data/engine_sweep.csv"),
]


def virtual_sensors(args, work):
    print(f"\n{'virtual sensor':16} {'column':22} {'rows':>6} {'max rel. error':>14} {'fmusim s':>8}")
    worst_states = 0.0
    for name, model, result, data in SENSORS:
        model, data = os.path.join(ROOT, model), os.path.join(ROOT, data)
        result = os.path.join(ROOT if result.startswith("assets/") else work, result)
        spec = json.load(open(model))
        res = json.load(open(result))
        delays = {o: v.get("estimate", 0) or 0 for o, v in res.get("output_delay", {}).items()}
        d = [delays.get(o, 0) for o in spec["outputs"]]
        first = [spec.get("output_delay", {}).get(o, {}).get("max", d[i]) if isinstance(
            spec.get("output_delay", {}).get(o), dict) else d[i] for i, o in enumerate(spec["outputs"])]
        lag = max(d)
        fmu = os.path.join(work, f"{name}_sensor.fmu")
        run([args.cli, "export-fmu", result, "--model", model, "--virtual-sensor", "--out", fmu])
        states_csv = os.path.join(work, f"{name}_states.csv")
        pred_csv = os.path.join(work, f"{name}_pred.csv")
        run([args.cli, "predict", model, data, "--result", result, "--states", states_csv,
             "--out", pred_csv])
        st, pr = read_csv(states_csv), read_csv(pred_csv)
        record = read_csv(data)
        t = record["t"] if "t" in record else record["time"]
        in_csv = os.path.join(work, f"{name}_sensor_inputs.csv")
        with open(in_csv, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["time"] + spec["inputs"] + spec["outputs"] +
                       [o + "_valid" for o in spec["outputs"]])
            for k in range(len(t)):
                ys = [record[o][k] for o in spec["outputs"]]
                valid = [1 if k >= first[i] and ys[i] == ys[i] else 0 for i in range(len(ys))]
                w.writerow([repr(t[k])] + [repr(record[u][k]) for u in spec["inputs"]] +
                           [repr(y) if y == y else "0" for y in ys] + valid)
        out_csv = os.path.join(work, f"{name}_sensor.csv")
        seconds = run([args.fmusim, "--interface-type", "cs", "--start-time", repr(t[0]),
                       "--stop-time", repr(t[-1]), "--output-interval", repr(t[1] - t[0]),
                       "--input-file", in_csv, "--output-file", out_csv, fmu])
        f = read_csv(out_csv)

        def compare(column, reference, shift, only=None):
            worst, size, n = 0.0, 0.0, 0
            for r in range(len(f["time"])):
                g = r + shift
                if f["ready"][r] < 0.5 or g < 0 or g >= len(reference) or reference[g] != reference[g]:
                    continue
                if only and not only(g):
                    continue
                worst = max(worst, abs(f[column][r] - reference[g]))
                size = max(size, abs(reference[g]))
                n += 1
            return (worst / size if size > 0 else worst), n

        rows = []
        for x in spec["states"]:
            for col in (x + "_filtered", x + "_filtered_sd"):
                err, n = compare(col, st[col], -(lag + 1))
                if col.endswith("_filtered"):
                    worst_states = max(worst_states, err)
                rows.append((col, n, err))
        for i, o in enumerate(spec["outputs"]):
            for col, ref, shift in ((o + "_pred", pr[o + "_pred"], 0), (o + "_sd", pr[o + "_sd"], 0)):
                err, n = compare(col, ref, shift)
                rows.append((col, n, err))
            err, n = compare(o + "_residual", pr[o + "_residual"], -(lag + 1) + d[i],
                             only=lambda g, i=i: g >= first[i])
            rows.append((o + "_residual", n, err))
        for col, n, err in rows:
            print(f"{name:16} {col:22} {n:6d} {err:14.2e} {seconds:8.2f}")
    return worst_states


if __name__ == "__main__":
    sys.exit(main())
