"""Speed and accuracy of tactile's batched FOS fit against a scipy curve_fit loop.

Fits the same synthetic press (or slip) trials, 100, 1,000 and 10,000 of them by default,
with ``scipy.optimize.curve_fit`` one trial at a time and with
:func:`tactile_cli.fos.fit_pulse` (or ``fit_ramp`` / ``fit_step``) in one batched call, and
prints trials per second for both, the ratio, tactile's compile time separately, the median
parameter errors and the failures of each.

Trials follow paper 000, sec. 4.2: alpha uniform in [1365, 2280] events per bin, tau uniform
in [0.25, 0.35] s, 20 ms bins, Poisson counting noise; presses last ``--duration`` seconds
of a ``--points``-bin region.

Fairness: both fitters get the same data-driven starting values (tactile's, computed from
the data and reported in its result; alpha from the closed-form projection at that tau),
curve_fit runs its default Levenberg-Marquardt with those ``p0``. A curve_fit fit counts as
failed when it raises or returns non-finite parameters or covariance, or tau <= 0. tactile's
time is measured in fresh Python processes (after imports and JAX's backend start-up): the
first call ("cold", tracing and XLA compilation included, as a user's first call) and the
best of ``--repeats`` later calls ("warm"), each the best over ``--processes`` processes
(the machine is shared); compile time = cold - warm.

    .venv/bin/python benchmarks/fit_fos.py                     # pulse, known T
    .venv/bin/python benchmarks/fit_fos.py --model pulse_fitted_T --sizes 100 1000
    .venv/bin/python benchmarks/fit_fos.py --solver gauss_newton
    .venv/bin/python benchmarks/fit_fos.py --compilation-cache /tmp/jax-cache
    .venv/bin/python benchmarks/fit_fos.py --json benchmarks/figures/fit_fos.json
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from scipy.optimize import OptimizeWarning, curve_fit

MODELS = ("pulse", "pulse_fitted_T", "step", "ramp")
DT_S = 0.02


def make_trials(model: str, n_trials: int, *, n_points: int = 150, duration_s: float = 1.5,
                noise: float = 1.0, saturation: float = 0.0, seed: int = 0) -> dict:
    """Synthetic trials of paper 000's press/slip regions with known parameters.

    ``noise`` scales Poisson counting noise (1 = Poisson: ``y = mu + noise (P(mu) - mu)``);
    ``saturation`` r > 0 passes the response through ``A tanh(x / A)`` with ``A = alpha / r``
    (the "big force" flattening); the returned alpha and tau are those of the linear system.
    """
    from tactile_cli.fos import first_order_response

    rng = np.random.default_rng(seed)
    kind = "pulse" if model.startswith("pulse") else model
    alpha = rng.uniform(1365.0, 2280.0, n_trials)
    tau = rng.uniform(0.25, 0.35, n_trials)
    t = np.arange(n_points) * DT_S
    mu = first_order_response(kind, t[None, :], alpha[:, None], tau[:, None],
                              duration_s if kind == "pulse" else None)
    if saturation > 0:
        cap = (alpha / saturation)[:, None]
        mu = cap * np.tanh(mu / cap)
    y = mu + noise * (rng.poisson(mu) - mu)
    return {"t": t, "y": y, "alpha": alpha, "tau": tau, "duration": duration_s, "kind": kind}


def tactile_fit(model: str, data: dict, solver: str = "levenberg_marquardt"):
    from tactile_cli.fos import FitOptions, fit_pulse, fit_ramp, fit_step

    options = FitOptions(solver=solver)
    if model == "pulse":
        return fit_pulse(data["t"], data["y"], duration_s=data["duration"], options=options)
    if model == "pulse_fitted_T":
        return fit_pulse(data["t"], data["y"], options=options)
    return {"step": fit_step, "ramp": fit_ramp}[model](data["t"], data["y"], options=options)


def curve_fit_loop(model: str, data: dict, tau0: np.ndarray, dur0: np.ndarray) -> dict:
    """One curve_fit per trial from the given starts; returns parameters and failures."""
    from tactile_cli.fos import unit_response

    t, y, kind, T = data["t"], data["y"], data["kind"], data["duration"]
    if model == "pulse_fitted_T":
        def f(tt, a, tau, dur):
            return a * unit_response("pulse", tt, tau, dur)
    else:
        def f(tt, a, tau):
            return a * unit_response(kind, tt, tau, T if kind == "pulse" else None)
    n = len(y)
    alpha, tau, failed = np.full(n, np.nan), np.full(n, np.nan), np.zeros(n, bool)
    for i in range(n):
        g = unit_response(kind, t, tau0[i], dur0[i] if model == "pulse_fitted_T" else T)
        p0 = [g @ y[i] / (g @ g), tau0[i]] + ([dur0[i]] if model == "pulse_fitted_T" else [])
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", OptimizeWarning)
                p, cov = curve_fit(f, t, y[i], p0=p0)
        except (RuntimeError, ValueError):
            failed[i] = True
            continue
        if not (np.all(np.isfinite(p)) and np.all(np.isfinite(cov)) and p[1] > 0):
            failed[i] = True
            continue
        alpha[i], tau[i] = p[0], p[1]
    return {"alpha": alpha, "tau": tau, "failed": failed}


def _errors(alpha: np.ndarray, tau: np.ndarray, data: dict) -> dict:
    ea, et = np.abs(alpha / data["alpha"] - 1), np.abs(tau / data["tau"] - 1)
    both = np.maximum(ea, et)
    return {"median_alpha_err": float(np.nanmedian(ea)) if np.any(np.isfinite(ea)) else None,
            "median_tau_err": float(np.nanmedian(et)) if np.any(np.isfinite(et)) else None,
            "within_5pct": float(np.mean(both <= 0.05))}


def tactile_timing(model: str, n: int, *, repeats: int, seed: int, n_points: int,
                   solver: str) -> dict:
    """Time tactile in a fresh Python process: the first call includes tracing and XLA
    compilation exactly as a user's first call does; later calls are warm."""
    import jax

    with jax.enable_x64(True):  # the fit runs in float64; don't count a dtype warm-up
        jax.block_until_ready(jax.jit(lambda x: x + 1)(np.zeros(1)))  # backend start-up
    data = make_trials(model, n, n_points=n_points, seed=seed)
    t0 = time.perf_counter()
    tactile_fit(model, data, solver)
    cold = time.perf_counter() - t0
    warm = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        tactile_fit(model, data, solver)
        warm = min(warm, time.perf_counter() - t0)
    return {"cold": cold, "warm": warm}


def run_size(model: str, n: int, *, repeats: int, seed: int, n_points: int, solver: str,
             cache_dir: Path | None, processes: int) -> dict:
    cmd = [sys.executable, __file__, "--_child", model, str(n), str(n_points), str(seed),
           str(repeats), solver]
    env = dict(os.environ)
    if cache_dir is not None:  # JAX's persistent compilation cache, primed by a first run
        env.update(JAX_COMPILATION_CACHE_DIR=str(cache_dir),
                   JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS="0",
                   JAX_PERSISTENT_CACHE_MIN_ENTRY_SIZE_BYTES="0")
        subprocess.run(cmd, capture_output=True, text=True, check=True, env=env)
    cold = warm = np.inf
    for _ in range(processes):  # other jobs share the machine: keep each best time
        child = subprocess.run(cmd, capture_output=True, text=True, check=True, env=env)
        timing = json.loads(child.stdout.strip().splitlines()[-1])
        cold, warm = min(cold, timing["cold"]), min(warm, timing["warm"])
    data = make_trials(model, n, n_points=n_points, seed=seed)
    res = tactile_fit(model, data, solver)  # the child's data and result, for accuracy
    tau0 = np.where(np.isfinite(res.start_tau_s), res.start_tau_s, 0.3)
    dur0 = np.where(np.isfinite(res.start_duration_s), res.start_duration_s, data["duration"])
    cf_time = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        cf = curve_fit_loop(model, data, tau0, dur0)
        cf_time = min(cf_time, time.perf_counter() - t0)
    return {
        "n_trials": n, "curve_fit_s": cf_time, "tactile_warm_s": warm, "tactile_cold_s": cold,
        "compile_s": max(cold - warm, 0.0),
        "curve_fit_trials_per_s": n / cf_time, "tactile_trials_per_s": n / warm,
        "tactile_trials_per_s_incl_compile": n / cold,
        "ratio_warm": cf_time / warm, "ratio_incl_compile": cf_time / cold,
        "curve_fit_failed": int(cf["failed"].sum()),
        "tactile_failed": int((~res.ok).sum()),
        "tactile_status": {str(s): int(c) for s, c in zip(*np.unique(res.status,
                                                                     return_counts=True),
                                                          strict=True)},
        "tactile_max_steps_taken": int(res.n_steps.max()),
        "curve_fit": _errors(cf["alpha"], cf["tau"], data),
        "tactile": _errors(res.alpha, res.tau_s, data),
    }


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["--_child"]:  # internal: time tactile in this fresh process
        model, (n, n_points, seed, repeats), solver = argv[1], map(int, argv[2:6]), argv[6]
        print(json.dumps(tactile_timing(model, n, repeats=repeats, seed=seed,
                                        n_points=n_points, solver=solver)))
        return 0
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--model", choices=MODELS, default="pulse",
                    help="pulse (known T, default), pulse_fitted_T, step or ramp")
    ap.add_argument("--sizes", type=int, nargs="+", default=[100, 1000, 10000],
                    help="numbers of trials (default: 100 1000 10000)")
    ap.add_argument("--points", type=int, default=150,
                    help="bins of 20 ms per trial (default 150 = 3 s)")
    ap.add_argument("--repeats", type=int, default=2,
                    help="timed runs per fitter and size, best kept (default 2)")
    ap.add_argument("--processes", type=int, default=3,
                    help="fresh processes timing tactile per size, best kept (default 3)")
    ap.add_argument("--solver", choices=("levenberg_marquardt", "gauss_newton"),
                    default="levenberg_marquardt", help="tactile's solver (FitOptions.solver)")
    ap.add_argument("--compilation-cache", type=Path, default=None, metavar="DIR",
                    help="time tactile's first call with JAX's persistent compilation cache "
                         "in DIR, primed by an earlier process (a repeat CLI run); default: "
                         "no cache, a truly cold first call")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", type=Path, default=None, help="also write the results here")
    args = ap.parse_args(argv)
    if min(args.sizes) < 1 or args.repeats < 1 or args.processes < 1 or args.points < 8:
        ap.error("--sizes, --repeats and --processes must be >= 1 and --points >= 8")

    t0 = time.perf_counter()
    import jax  # noqa: F401  (import time is reported, not counted in the fit)

    import tactile_cli.fos  # noqa: F401
    import_s = time.perf_counter() - t0
    load = os.getloadavg()
    print(f"model={args.model} solver={args.solver} points={args.points} "
          f"compilation cache={args.compilation_cache or 'none (cold)'} cores={os.cpu_count()} "
          f"load(1,5,15 min)={load[0]:.2f},{load[1]:.2f},{load[2]:.2f} "
          f"jax+tactile import {import_s:.2f} s")
    rows = [run_size(args.model, n, repeats=args.repeats, seed=args.seed + n,
                     n_points=args.points, solver=args.solver,
                     cache_dir=args.compilation_cache, processes=args.processes)
            for n in args.sizes]
    head = (f"{'trials':>7} | {'curve_fit/s':>11} | {'tactile/s':>10} {'incl.comp':>10} | "
            f"{'ratio':>6} {'incl.comp':>9} | {'compile s':>9} | {'med |dtau| cf/tac':>18} | "
            f"{'med |dalpha| cf/tac':>20} | {'in 5% cf/tac':>13} | {'failed cf/tac':>13}")
    print(head)
    print("-" * len(head))
    for r in rows:
        cf, tc = r["curve_fit"], r["tactile"]
        print(f"{r['n_trials']:>7} | {r['curve_fit_trials_per_s']:>11.0f} | "
              f"{r['tactile_trials_per_s']:>10.0f} "
              f"{r['tactile_trials_per_s_incl_compile']:>10.0f} | "
              f"{r['ratio_warm']:>6.1f} {r['ratio_incl_compile']:>9.2f} | {r['compile_s']:>9.2f} | "
              f"{_pct(cf['median_tau_err']):>8} /{_pct(tc['median_tau_err']):>8} | "
              f"{_pct(cf['median_alpha_err']):>9} /{_pct(tc['median_alpha_err']):>9} | "
              f"{cf['within_5pct']:>6.3f}/{tc['within_5pct']:>6.3f} | "
              f"{r['curve_fit_failed']:>6}/{r['tactile_failed']:>6}")
    for r in rows:
        print(f"  {r['n_trials']:>6} trials: tactile status {r['tactile_status']}, "
              f"max solver steps {r['tactile_max_steps_taken']}")
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        meta = {"model": args.model, "solver": args.solver, "points": args.points,
                "compilation_cache": None if args.compilation_cache is None
                else str(args.compilation_cache), "repeats": args.repeats,
                "processes": args.processes,
                "seed": args.seed, "cores": os.cpu_count(), "load_avg": load,
                "import_s": import_s, "python": sys.version.split()[0],
                "machine": platform.machine(), "command": " ".join(sys.argv)}
        args.json.write_text(json.dumps({"meta": meta, "rows": rows}, indent=2))
        print(f"wrote {args.json}")
    return 0


def _pct(x: float | None) -> str:
    return "n/a" if x is None else f"{100 * x:.2f}%"


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    raise SystemExit(main())
