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
    .venv/bin/python benchmarks/fit_fos.py --cli --json benchmarks/figures/fit_fos_cli.json

Since issue 13 the library keeps its compiled solver in a cache folder once
``tactile_cli.fos.compile_cache.enable_compilation_cache()`` has been called (the CLI does):
each size is timed with an empty cache ("cold": tracing and XLA compilation in the first
call) and with the cache primed by an earlier process ("cached": the first call loads the
program). "End to end" times whole fresh processes, imports and data included: tactile's
(cold and cached) against one that imports scipy and runs the curve_fit loop.

``--cli`` also times the command: a marker-event scene of ``--groups`` groups (12 trials
each, 2 regions per trial) is simulated and ingested as the Makefile's demo-events target
does, then ``tactile fit-fos FILE --no-write --csv OUT`` (first order and the order
verdict) runs with an empty cache and with a warm one, against a script that reads the same
file with tactile's reader and fits the same regions with curve_fit (press: eq. 16 with T
fitted; slip: eq. 17 after the press tail is subtracted; no order test). Each time is the
median of ``--cli-runs`` runs. ``--json`` then holds ``cli_cold_s``, ``cli_warm_s``,
``curve_fit_cli_s`` and ``ratio_10000_incl_compile`` (curve_fit loop / tactile's first call
with an empty cache, at 10,000 trials, when that size is run).
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
    compilation (or, with a primed cache, loading them) exactly as a user's first call
    does; later calls are warm. The cache is $TACTILE_CACHE_DIR, set by the parent."""
    import jax

    from tactile_cli.fos.compile_cache import enable_compilation_cache

    enable_compilation_cache()

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


def _child_env(cache_dir: Path) -> dict:
    return dict(os.environ, TACTILE_CACHE_DIR=str(cache_dir))


def _wall(cmd: list[str], env: dict) -> tuple[float, str]:
    t0 = time.perf_counter()
    child = subprocess.run(cmd, capture_output=True, text=True, check=True, env=env)
    return time.perf_counter() - t0, child.stdout


def run_size(model: str, n: int, *, repeats: int, seed: int, n_points: int, solver: str,
             processes: int, work: Path) -> dict:
    args = [model, str(n), str(n_points), str(seed), str(repeats), solver]
    child = [sys.executable, __file__, "--_child", *args]
    cold = cached = warm = np.inf
    e2e_cold, e2e_cached, e2e_cf = [], [], []
    primed = work / f"cache-{model}-{solver}"
    subprocess.run(child, capture_output=True, text=True, check=True,
                   env=_child_env(primed))  # prime the cache once
    for k in range(processes):  # other jobs share the machine: keep each best time
        empty = work / f"empty-{n}-{k}"
        wall, out = _wall(child, _child_env(empty))
        timing = json.loads(out.strip().splitlines()[-1])
        cold, warm = min(cold, timing["cold"]), min(warm, timing["warm"])
        e2e_cold.append(wall)
        wall, out = _wall(child, _child_env(primed))
        timing = json.loads(out.strip().splitlines()[-1])
        cached, warm = min(cached, timing["cold"]), min(warm, timing["warm"])
        wall, _ = _wall([sys.executable, __file__, "--_e2e", "tactile", *args], _child_env(primed))
        e2e_cached.append(wall)
        wall, _ = _wall([sys.executable, __file__, "--_e2e", "curve_fit", *args], os.environ)
        e2e_cf.append(wall)
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
        "tactile_cached_s": cached, "compile_s": max(cold - warm, 0.0),
        "curve_fit_trials_per_s": n / cf_time, "tactile_trials_per_s": n / warm,
        "tactile_trials_per_s_incl_compile": n / cold,
        "ratio_warm": cf_time / warm, "ratio_incl_compile": cf_time / cold,
        "ratio_incl_cache_load": cf_time / cached,
        "e2e_tactile_cold_s": float(np.median(e2e_cold)),
        "e2e_tactile_cached_s": float(np.median(e2e_cached)),
        "e2e_curve_fit_s": float(np.median(e2e_cf)),
        "curve_fit_failed": int(cf["failed"].sum()),
        "tactile_failed": int((~res.ok).sum()),
        "tactile_status": {str(s): int(c) for s, c in zip(*np.unique(res.status,
                                                                     return_counts=True),
                                                          strict=True)},
        "tactile_max_steps_taken": int(res.n_steps.max()),
        "curve_fit": _errors(cf["alpha"], cf["tau"], data),
        "tactile": _errors(res.alpha, res.tau_s, data),
    }


def _numpy_starts(model: str, data: dict) -> tuple[np.ndarray, np.ndarray]:
    """tau and T starts from the data alone (63 % rise, 37 % fall), for the end-to-end
    curve_fit process, which does not import tactile's fitter (nor jax)."""
    t, y = data["t"], data["y"]
    peak_i = np.argmax(y, axis=1)
    peak = y[np.arange(len(y)), peak_i][:, None]
    rise = np.argmax(y >= (1 - np.exp(-1)) * peak, axis=1)
    tau0 = np.maximum(t[rise], t[1])
    if model == "ramp":
        tau0 = np.full(len(y), 0.25 * t[-1])
    fall = (t[None, :] > t[peak_i][:, None]) & (y <= np.exp(-1) * peak)
    dur0 = np.where(fall.any(axis=1), t[np.argmax(fall, axis=1)] - tau0, t[peak_i])
    return tau0, np.clip(dur0, t[1], t[-2])


def _e2e(which: str, model: str, n: int, n_points: int, seed: int, solver: str) -> None:
    """A whole user's process: imports, data, fit."""
    data = make_trials(model, n, n_points=n_points, seed=seed)
    if which == "tactile":
        from tactile_cli.fos.compile_cache import enable_compilation_cache

        enable_compilation_cache()
        tactile_fit(model, data, solver)
    else:
        curve_fit_loop(model, data, *_numpy_starts(model, data))


# --------------------------------------------------------------------------- --cli mode
def make_scene(folder: Path, groups: int, seed: int) -> Path:
    """Simulate a marker-event scene and ingest it with its annotations and labels, as the
    Makefile's demo-events target does; returns the HDF5 file."""
    tactile = [str(Path(sys.executable).with_name("tactile"))]
    scene, h5 = folder / "scene", folder / "scene.h5"
    subprocess.run([*tactile, "simulate", "marker-events", "--out", str(scene), "--groups",
                    str(groups), "--seed", str(seed), "--no-progress"], check=True,
                   capture_output=True)
    subprocess.run([*tactile, "ingest", *sorted(str(p) for p in scene.glob("*.npy")),
                    "--width", "640", "--height", "480", "--annotations",
                    str(scene / "annotations.csv"), "--trial-labels", str(scene / "trials.csv"),
                    "--out", str(h5), "--overwrite", "--no-progress"], check=True,
                   capture_output=True)
    return h5


def curve_fit_file(h5: Path, out_csv: Path) -> int:
    """The obvious script: the regions of every trial through tactile's reader, each fitted
    with curve_fit (press: eq. 16 with T fitted; slip: eq. 17 after the press tail is
    subtracted), parameters written to a CSV. Returns the number of fits."""
    import csv as csv_module

    from tactile_cli.fos.models import unit_response
    from tactile_cli.fos.regions import read_trial_regions

    def pulse(t, a, tau, dur):
        return a * unit_response("pulse", t, tau, dur)

    def ramp(t, a, tau):
        return a * unit_response("ramp", t, tau)

    rows = []
    for tr in read_trial_regions(h5):
        press = tr.in_region("press")
        t = tr.t_s[press] - tr.press_s[0]
        y = tr.net[press]
        data = {"t": t, "y": y[None, :]}
        tau0, dur0 = _numpy_starts("pulse", data)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                p, _ = curve_fit(pulse, t, y, p0=[y.max(), tau0[0], dur0[0]])
        except (RuntimeError, ValueError):
            rows.append((tr.trial, "press", np.nan, np.nan))
            continue
        rows.append((tr.trial, "press", p[0], p[1]))
        slip = tr.in_region("slip")
        ts = tr.t_s[slip]
        ys = tr.net[slip] - pulse(ts - tr.press_s[0], *p)
        ts = ts - tr.slip_s[0]
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                q, _ = curve_fit(ramp, ts, ys, p0=[ys.max() / 3, 0.25 * ts[-1]])
            rows.append((tr.trial, "slip", q[0], q[1]))
        except (RuntimeError, ValueError):
            rows.append((tr.trial, "slip", np.nan, np.nan))
    with open(out_csv, "w", newline="") as f:
        writer = csv_module.writer(f)
        writer.writerow(["trial", "region", "alpha", "tau_s"])
        writer.writerows(rows)
    return len(rows)


def run_cli(work: Path, *, groups: int, seed: int, runs: int) -> dict:
    """Median wall times of ``tactile fit-fos`` (empty and warm cache) and of the curve_fit
    script on one simulated scene file."""
    h5 = make_scene(work / "cli", groups, seed)
    tactile = [str(Path(sys.executable).with_name("tactile")), "fit-fos", str(h5),
               "--no-write", "--csv", str(work / "cli" / "fits.csv"), "--overwrite"]
    warm_cache = work / "cli-warm-cache"
    subprocess.run(tactile, check=True, capture_output=True, env=_child_env(warm_cache))
    cold, warm, cf = [], [], []
    for k in range(runs):
        cold.append(_wall(tactile, _child_env(work / f"cli-empty-{k}"))[0])
        warm.append(_wall(tactile, _child_env(warm_cache))[0])
        cf.append(_wall([sys.executable, __file__, "--_curve_fit_file", str(h5),
                         str(work / "cli" / "curve_fit.csv")], os.environ)[0])
    with open(work / "cli" / "fits.csv") as f:
        n_regions = sum(1 for _ in f) - 1
    return {"cli_file_trials": n_regions // 2, "cli_regions": n_regions,
            "cli_cold_s": float(np.median(cold)), "cli_warm_s": float(np.median(warm)),
            "curve_fit_cli_s": float(np.median(cf)), "cli_cold_runs_s": cold,
            "cli_warm_runs_s": warm, "curve_fit_cli_runs_s": cf}


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["--_child"]:  # internal: time tactile in this fresh process
        model, (n, n_points, seed, repeats), solver = argv[1], map(int, argv[2:6]), argv[6]
        print(json.dumps(tactile_timing(model, n, repeats=repeats, seed=seed,
                                        n_points=n_points, solver=solver)))
        return 0
    if argv[:1] == ["--_e2e"]:  # internal: a whole process of tactile or of curve_fit
        which, model, (n, n_points, seed, _), solver = (argv[1], argv[2],
                                                        map(int, argv[3:7]), argv[7])
        _e2e(which, model, n, n_points, seed, solver)
        return 0
    if argv[:1] == ["--_curve_fit_file"]:  # internal: the curve_fit script of --cli
        curve_fit_file(Path(argv[1]), Path(argv[2]))
        return 0
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--model", choices=MODELS, default="pulse",
                    help="pulse (known T, default), pulse_fitted_T, step or ramp")
    ap.add_argument("--sizes", type=int, nargs="+", default=[10, 100, 1000, 10000],
                    help="numbers of trials (default: 10 100 1000 10000)")
    ap.add_argument("--points", type=int, default=150,
                    help="bins of 20 ms per trial (default 150 = 3 s)")
    ap.add_argument("--repeats", type=int, default=2,
                    help="timed runs per fitter and size, best kept (default 2)")
    ap.add_argument("--processes", type=int, default=3,
                    help="fresh processes timing tactile per size, best kept (default 3)")
    ap.add_argument("--solver", choices=("levenberg_marquardt", "gauss_newton"),
                    default="levenberg_marquardt", help="tactile's solver (FitOptions.solver)")
    ap.add_argument("--cli", action="store_true",
                    help="also time `tactile fit-fos` end to end on a simulated scene file "
                         "(empty and warm cache) against a curve_fit script")
    ap.add_argument("--groups", type=int, default=2,
                    help="--cli: scene groups of 12 trials (default 2: 24 trials)")
    ap.add_argument("--cli-runs", type=int, default=5,
                    help="--cli: runs of each command, median kept (default 5)")
    ap.add_argument("--work", type=Path, default=None, metavar="DIR",
                    help="folder for caches and the scene (default: a temporary folder)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", type=Path, default=None, help="also write the results here")
    args = ap.parse_args(argv)
    if min(args.sizes) < 1 or args.repeats < 1 or args.processes < 1 or args.points < 8:
        ap.error("--sizes, --repeats and --processes must be >= 1 and --points >= 8")
    if args.groups < 1 or args.cli_runs < 1:
        ap.error("--groups and --cli-runs must be >= 1")
    import tempfile

    with tempfile.TemporaryDirectory(prefix="fit_fos_bench_") as tmp:
        return _main(args, Path(args.work) if args.work else Path(tmp))


def _main(args: argparse.Namespace, work: Path) -> int:
    work.mkdir(parents=True, exist_ok=True)

    t0 = time.perf_counter()
    import jax  # noqa: F401  (import time is reported, not counted in the fit)

    import tactile_cli.fos  # noqa: F401
    import_s = time.perf_counter() - t0
    load = os.getloadavg()
    print(f"model={args.model} solver={args.solver} points={args.points} "
          f"cores={os.cpu_count()} "
          f"load(1,5,15 min)={load[0]:.2f},{load[1]:.2f},{load[2]:.2f} "
          f"jax+tactile import {import_s:.2f} s")
    rows = [run_size(args.model, n, repeats=args.repeats, seed=args.seed + n,
                     n_points=args.points, solver=args.solver, processes=args.processes,
                     work=work)
            for n in args.sizes]
    head = (f"{'trials':>7} | {'curve_fit/s':>11} | {'tactile/s':>10} {'incl.comp':>10} | "
            f"{'ratio':>6} {'incl.comp':>9} {'cached':>7} | {'compile s':>9} | "
            f"{'e2e s: tac cold/cached, cf':>27} | {'med |dtau| cf/tac':>18} | "
            f"{'med |dalpha| cf/tac':>20} | {'in 5% cf/tac':>13} | {'failed cf/tac':>13}")
    print(head)
    print("-" * len(head))
    for r in rows:
        cf, tc = r["curve_fit"], r["tactile"]
        e2e = (f"{r['e2e_tactile_cold_s']:.2f} / {r['e2e_tactile_cached_s']:.2f}, "
               f"{r['e2e_curve_fit_s']:.2f}")
        print(f"{r['n_trials']:>7} | {r['curve_fit_trials_per_s']:>11.0f} | "
              f"{r['tactile_trials_per_s']:>10.0f} "
              f"{r['tactile_trials_per_s_incl_compile']:>10.0f} | "
              f"{r['ratio_warm']:>6.1f} {r['ratio_incl_compile']:>9.2f} "
              f"{r['ratio_incl_cache_load']:>7.2f} | {r['compile_s']:>9.2f} | {e2e:>27} | "
              f"{_pct(cf['median_tau_err']):>8} /{_pct(tc['median_tau_err']):>8} | "
              f"{_pct(cf['median_alpha_err']):>9} /{_pct(tc['median_alpha_err']):>9} | "
              f"{cf['within_5pct']:>6.3f}/{tc['within_5pct']:>6.3f} | "
              f"{r['curve_fit_failed']:>6}/{r['tactile_failed']:>6}")
    for r in rows:
        print(f"  {r['n_trials']:>6} trials: tactile status {r['tactile_status']}, "
              f"max solver steps {r['tactile_max_steps_taken']}")
    summary: dict = {}
    at_10000 = [r for r in rows if r["n_trials"] == 10000]
    if at_10000:
        summary["ratio_10000_incl_compile"] = at_10000[0]["ratio_incl_compile"]
        summary["ratio_10000_incl_cache_load"] = at_10000[0]["ratio_incl_cache_load"]
    if args.cli:
        summary.update(run_cli(work, groups=args.groups, seed=args.seed, runs=args.cli_runs))
        print(f"tactile fit-fos on a {summary['cli_file_trials']}-trial scene file "
              f"({summary['cli_regions']} regions, first order and order verdict), median of "
              f"{args.cli_runs}: empty cache {summary['cli_cold_s']:.2f} s, warm cache "
              f"{summary['cli_warm_s']:.2f} s; curve_fit script (first order only) "
              f"{summary['curve_fit_cli_s']:.2f} s")
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        meta = {"model": args.model, "solver": args.solver, "points": args.points,
                "repeats": args.repeats, "processes": args.processes, "groups": args.groups,
                "cli_runs": args.cli_runs, "seed": args.seed, "cores": os.cpu_count(),
                "load_avg_start": load, "load_avg_end": os.getloadavg(),
                "import_s": import_s, "python": sys.version.split()[0],
                "machine": platform.machine(), "command": " ".join(sys.argv)}
        args.json.write_text(json.dumps({"meta": meta, **summary, "rows": rows}, indent=2))
        print(f"wrote {args.json}")
    return 0


def _pct(x: float | None) -> str:
    return "n/a" if x is None else f"{100 * x:.2f}%"


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    raise SystemExit(main())
