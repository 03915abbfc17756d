#!/usr/bin/env python3
"""Baseline for docs/benchmarks.md: the fuel-film log-likelihood with statsmodels' Kalman filter.

Builds the same discrete-time model greybench filters for assets/models/truth/fuel_film_f1.json
(2 states, ZOH input, fixed output delay of 5 samples, P0 = Q(Ts) "ctsm"), evaluates its exact
Gaussian log-likelihood with statsmodels, and times that evaluation.

Continuous model at the paper's point f1 (t in s):

    d mfv = (-mfv + (1 - X) mfi) / tau_fv dt + sqrt(s11) dw1
    d mff = (-mff + X mfi) / tau_ff dt       + sqrt(s12) dw2
    ilambda_k = Kb (mfv + mff)(t_{k-5}) + e_k,   e_k ~ N(0, s2)

Discretised exactly over Ts with the input held (ZOH), by matrix exponentials (scipy):

    Phi = e^{A Ts},  Gamma = int_0^Ts e^{As} ds B     (one expm of [[A, B], [0, 0]] Ts)
    Q   = int_0^Ts e^{As} G G' e^{A's} ds             (Van Loan: expm of [[-A, GG'], [0, A']] Ts)
    with G G' = diag(s11, s12).

State-space form handed to statsmodels (state index j = data row j):

    x_{j+1} = Phi x_j + c_j + v_j,  c_j = Gamma u_j (time-varying state intercept), v_j ~ N(0, Q)
    y~_j    = Kb [1 1] x_j + e_j,   y~_j = ilambda_{j+5}   (the delay: row j+5 sees state j)
    x_0 ~ N(x0, Q),  x0 = ((1 - X) mfi0, X mfi0)          ('known' initialisation)

statsmodels' 'known' initialisation is the prior of x_0, which the first observation updates
before the first time update, as in greybench; no burn-in, no Huber term.

Usage (Debian's python3 with python3-statsmodels):
    /usr/bin/python3 bench/baseline_statsmodels.py /tmp/fuel200k.csv --repeat 15
Prints one JSON line: the log-likelihood, the number of observations, the median time of one
evaluation at θ (discretise, set the matrices, filter; reading the data, building the model and a
warm-up run excluded) in s and in ns per data row, and the same for the filter alone.

    /usr/bin/python3 bench/baseline_statsmodels.py assets/data/fuel_f1.csv --fit --repeat 3
fits instead (issue 14's speed comparison): SciPy's L-BFGS-B (gradients by SciPy's finite
differences) over statsmodels' log-likelihood at the fixed delay of 5 samples, from the generic
start values of bench/models/fuel_film_generic.json within its bounds (mfi0 held at 1.2), on the
scaled parameters z = θ / |θ_start| (as greybench scales them). Prints the median wall time of
the fit, the log-likelihood reached, the evaluations and SciPy's message.
"""

import argparse
import json
import sys
import time

import numpy as np
import scipy
import statsmodels
from scipy.linalg import expm
from statsmodels.tsa.statespace.mlemodel import MLEModel

TS = 0.0125  # s, the data's sample interval
DELAY = 5  # samples, output_delay of ilambda
MFI0 = 1.2  # g/s, fixed parameter: the input level the initial state is in equilibrium with
PARAM_NAMES = ["tau_fv", "tau_ff", "X", "Kb", "s11", "s12", "s2"]
F1_VALUES = [0.075, 0.375, 0.175, 0.8421, 1.098e-3, 3.91e-4, 1.257e-4]


def discretize(params, ts):
    """Phi, Gamma (2x1), Q of the fuel-film model over ts (ZOH, Van Loan)."""
    tau_fv, tau_ff, x_frac, _, s11, s12, _ = params
    a = np.diag([-1.0 / tau_fv, -1.0 / tau_ff])
    b = np.array([[(1.0 - x_frac) / tau_fv], [x_frac / tau_ff]])
    gg = np.diag([s11, s12])
    n, m = b.shape

    aug = np.zeros((n + m, n + m))
    aug[:n, :n] = a
    aug[:n, n:] = b
    e = expm(aug * ts)
    phi, gamma = e[:n, :n], e[:n, n:]

    van_loan = np.zeros((2 * n, 2 * n))
    van_loan[:n, :n] = -a
    van_loan[:n, n:] = gg
    van_loan[n:, n:] = a.T
    f = expm(van_loan * ts)
    q = f[n:, n:].T @ f[:n, n:]
    return phi, gamma, 0.5 * (q + q.T)


class FuelFilm(MLEModel):
    """The discretised fuel-film model; exog enters as the state intercept Gamma u_j."""

    def __init__(self, y_shifted, u):
        super().__init__(y_shifted, k_states=2, k_posdef=2)
        self.u = np.asarray(u, dtype=float)
        self.ssm["selection"] = np.eye(2)

    @property
    def param_names(self):
        return PARAM_NAMES

    @property
    def start_params(self):
        return np.array(F1_VALUES)

    def update(self, params, **kwargs):
        params = super().update(params, **kwargs)
        phi, gamma, q = discretize(params, TS)
        x_frac, kb, s2 = params[2], params[3], params[6]
        self.ssm["transition"] = phi
        self.ssm["state_cov"] = q
        self.ssm["state_intercept"] = gamma @ self.u[np.newaxis, :]  # 2 x nobs
        self.ssm["design"] = np.array([[kb, kb]])
        self.ssm["obs_cov"] = np.array([[s2]])
        x0 = np.array([(1.0 - x_frac) * MFI0, x_frac * MFI0])
        self.ssm.initialize_known(x0, q)  # greybench "ctsm": P0 = Q(Ts)


GENERIC_START = [0.05, 0.5, 0.3, 1.0, 1e-3, 1e-3, 1e-3]
GENERIC_BOUNDS = [(0.001, 2.0), (0.01, 5.0), (0.0, 1.0), (0.1, 5.0),
                  (1e-9, 1.0), (1e-9, 1.0), (1e-9, 1.0)]


def fit_lbfgsb(model):
    """SciPy's L-BFGS-B from the generic start on z = θ / |θ_start|; returns (result, loglik)."""
    from scipy.optimize import minimize

    scale = np.abs(np.array(GENERIC_START))
    bounds = [(lo / s, hi / s) for (lo, hi), s in zip(GENERIC_BOUNDS, scale)]

    def objective(z):
        value = model.loglike(z * scale)
        return -value if np.isfinite(value) else 1e300

    r = minimize(objective, np.ones(len(scale)), method="L-BFGS-B", bounds=bounds)
    return r, -r.fun


def read_series(path):
    """t, mfi, ilambda from a greybench CSV ('#' comments, header, NA = missing)."""
    with open(path, encoding="utf-8") as f:
        lines = [line for line in f if not line.startswith("#")]
    columns = lines[0].strip().split(",")
    data = np.genfromtxt(lines[1:], delimiter=",", missing_values="NA", filling_values=np.nan)
    return tuple(data[:, columns.index(name)] for name in ("t", "mfi", "ilambda"))


def median_seconds(fn, repeat):
    """Median wall time of `repeat` calls of fn()."""
    seconds = []
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        seconds.append(time.perf_counter() - start)
    return float(np.median(seconds))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("data", nargs="?", default="/tmp/fuel200k.csv")
    parser.add_argument("--repeat", type=int, default=15, help="timed evaluations (median)")
    parser.add_argument("--fit", action="store_true", help="time a fit instead (see above)")
    args = parser.parse_args(argv)

    t, u, y = read_series(args.data)
    if not np.allclose(np.diff(t), TS, rtol=1e-9, atol=0.0):
        sys.exit(f"{args.data}: the sample interval is not {TS} s throughout")
    # Row j + DELAY observes state j; the state index runs over the rows that have one.
    y_shifted = y[DELAY:]
    u_aligned = u[: len(y_shifted)]
    if np.isnan(y_shifted).any():
        sys.exit(f"{args.data}: missing outputs after the first {DELAY} rows")

    model = FuelFilm(y_shifted, u_aligned)
    if args.fit:
        seconds, last = [], None
        for _ in range(args.repeat):
            start = time.perf_counter()
            last = fit_lbfgsb(model)
            seconds.append(time.perf_counter() - start)
        r, loglik = last
        print(json.dumps({
            "fit_s": float(np.median(seconds)), "fit_s_all": seconds, "loglik": loglik,
            "n_obs": int(y_shifted.size), "evaluations": int(r.nfev), "iterations": int(r.nit),
            "success": bool(r.success), "message": str(r.message),
            "estimate": dict(zip(PARAM_NAMES, (r.x * np.abs(GENERIC_START)).tolist())),
            "versions": {"statsmodels": statsmodels.__version__, "scipy": scipy.__version__,
                         "numpy": np.__version__, "python": sys.version.split()[0]},
        }))
        return
    params = model.start_params
    loglik = model.loglike(params)  # also the warm-up: builds the Cython filter objects
    # The full evaluation at θ (discretise, set the matrices, filter), as greybench times it,
    # and the filter alone on matrices already in place.
    evaluate_s = median_seconds(lambda: model.loglike(params), args.repeat)
    filter_s = median_seconds(model.ssm.loglike, args.repeat)
    results = model.ssm.filter()

    print(json.dumps({
        "loglik": loglik,
        "n_obs": int(y_shifted.size),
        "samples": int(y.size),
        "loglik_eval_s": evaluate_s,
        "ns_per_sample": evaluate_s / y.size * 1e9,
        "filter_only_ns_per_sample": filter_s / y.size * 1e9,
        # statsmodels stops updating P once it reaches steady state (None: it never did here).
        "steady_state_from": int(results.period_converged) if results.converged else None,
        "versions": {"statsmodels": statsmodels.__version__, "scipy": scipy.__version__,
                     "numpy": np.__version__, "python": sys.version.split()[0]},
    }))


if __name__ == "__main__":
    main()
