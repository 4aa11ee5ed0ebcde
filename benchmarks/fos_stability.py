"""Where does the FOS fit break down? A sweep of accuracy and failure rate.

Starting from paper-like press trials (eq. 16 pulse, known T = half the region, 150 bins of
20 ms, alpha in [1365, 2280] events per bin, tau in [0.25, 0.35] s, Poisson noise), one
factor at a time is varied:

- noise: Poisson noise scaled by k (``y = mu + k (P(mu) - mu)``);
- points: bins per region (region = points x 20 ms, T = half of it);
- start: tau0 = true tau x f, for the known-T fit and for the fitted-T fit (T0 = true T);
- saturation: the response through ``A tanh(x/A)``, ``A = alpha / r`` (big-force
  flattening); errors are against the linear system's alpha and tau, and the
  model-order choice (:func:`tactile_cli.fos.select_order`, BIC) is reported too.

For every setting: fraction of trials with alpha and tau both within 5 %, fraction
converged, fraction converged but more than 3 standard errors off (silently wrong), median
|tau error|, median Pearson R. The breaking point of an axis is the first setting (walking
away from the baseline) where fewer than 95 % of trials are within 5 %, or more than 5 % are
flagged. Writes benchmarks/figures/fos_stability.png and .json.

    .venv/bin/python benchmarks/fos_stability.py            # 512 trials per setting
    .venv/bin/python benchmarks/fos_stability.py --trials 128 --out /tmp/stab
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from fit_fos import DT_S, make_trials  # noqa: E402

from tactile_cli.fos import fit_pulse, select_order  # noqa: E402

AXES = {
    "noise": [0.5, 1, 2, 4, 8, 16, 32, 64],
    "points": [8, 12, 16, 24, 32, 48, 75, 150, 300],
    "start": [1 / 1000, 1 / 300, 1 / 100, 1 / 30, 1 / 10, 1 / 3, 1, 3, 10, 30, 100, 300, 1000],
    "saturation": [0, 0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0],
}
BASELINE = {"noise": 1, "points": 150, "start": 1, "saturation": 0}
LABELS = {"noise": "noise scale k (1 = Poisson)", "points": "points per region (20 ms bins)",
          "start": "tau0 / true tau", "saturation": "saturation r = alpha / A"}


def _metrics(res, data: dict) -> dict:
    ea = np.abs(res.alpha / data["alpha"] - 1)
    et = np.abs(res.tau_s / data["tau"] - 1)
    z = np.maximum(np.abs(res.alpha - data["alpha"]) / res.alpha_se,
                   np.abs(res.tau_s - data["tau"]) / res.tau_se_s)
    with np.errstate(invalid="ignore"):
        return {
            "within_5pct": float(np.mean((ea <= 0.05) & (et <= 0.05))),
            "converged": float(np.mean(res.ok)),
            "silently_wrong": float(np.mean(res.ok & (z > 3) & ((ea > 0.05) | (et > 0.05)))),
            "off_3se": float(np.mean(res.ok & (z > 3))),
            "median_tau_err": float(np.nanmedian(et)) if res.ok.any() else None,
            "median_r": float(np.nanmedian(res.pearson_r)) if res.ok.any() else None,
            "status": {str(s): int(c) for s, c in zip(*np.unique(res.status, return_counts=True),
                                                      strict=True)},
        }


def run_setting(axis: str, value: float, n_trials: int, seed: int) -> dict:
    n_points = int(value) if axis == "points" else BASELINE["points"]
    duration = 0.5 * n_points * DT_S
    data = make_trials("pulse", n_trials, n_points=n_points, duration_s=duration,
                       noise=value if axis == "noise" else 1.0,
                       saturation=value if axis == "saturation" else 0.0, seed=seed)
    out: dict = {"axis": axis, "value": value}
    if axis == "start":
        tau0 = data["tau"] * value
        known = fit_pulse(data["t"], data["y"], duration_s=duration, tau0_s=tau0)
        fitted = fit_pulse(data["t"], data["y"], tau0_s=tau0, duration0_s=duration)
        out.update(_metrics(known, data))
        out["fitted_T"] = _metrics(fitted, data)
    elif axis == "saturation":
        sel = select_order("pulse", data["t"], data["y"], duration_s=duration)
        out.update(_metrics(sel.first, data))
        out["second_order_chosen"] = float(np.mean(sel.verdict == "second_order"))
        out["second_order_chosen_aic"] = float(np.mean(sel.delta_aic > sel.min_delta))
        out["undecided"] = float(np.mean(sel.verdict == "undecided"))
    else:
        out.update(_metrics(fit_pulse(data["t"], data["y"], duration_s=duration), data))
    return out


def breaking_point(axis: str, rows: list[dict], key: str | None = None) -> dict:
    """First setting away from the baseline, in each direction, that misses the targets."""
    values = AXES[axis]
    base = values.index(BASELINE[axis])
    found = {}
    for direction, idx in (("below", range(base - 1, -1, -1)),
                           ("above", range(base + 1, len(values)))):
        for i in idx:
            m = rows[i] if key is None else rows[i][key]
            if m["within_5pct"] < 0.95 or m["converged"] < 0.95:
                found[direction] = values[i]
                break
    return found


def plot(results: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(11, 8), constrained_layout=True)
    for ax, axis in zip(axes.flat, AXES, strict=True):
        rows = results[axis]
        x = [r["value"] for r in rows]
        xs = [v if v > 0 else 0.1 for v in x] if axis == "saturation" else x
        ax.plot(xs, [r["within_5pct"] for r in rows], "o-", label="alpha, tau within 5 %")
        ax.plot(xs, [r["converged"] for r in rows], "s--", label="converged")
        ax.plot(xs, [r["silently_wrong"] for r in rows], "x:", color="red",
                label="converged, >5 % and >3 SE off")
        if axis == "start":
            ft = [r["fitted_T"] for r in rows]
            ax.plot(xs, [m["within_5pct"] for m in ft], "o-", alpha=0.6,
                    label="fitted T: within 5 %")
            ax.plot(xs, [m["converged"] for m in ft], "s--", alpha=0.6,
                    label="fitted T: converged")
        if axis == "saturation":
            ax.plot(xs, [r["second_order_chosen"] for r in rows], "d-.", color="purple",
                    label="second order chosen (BIC)")
            ax.plot(xs, [r["second_order_chosen_aic"] for r in rows], "d:", color="violet",
                    label="second order chosen (AIC)")
            ax.plot(xs, [r["median_r"] or np.nan for r in rows], "^-", color="gray",
                    label="median Pearson R (FOS)")
            ax.axhline(0.983138, color="gray", lw=0.8, ls="--", label="paper's press R 0.983")
        ax.axhline(0.95, color="k", lw=0.6)
        ax.axvline(BASELINE[axis] if BASELINE[axis] > 0 else 0.1, color="k", lw=0.6, ls=":")
        ax.set_xscale("log")
        ax.set_ylim(-0.03, 1.03)
        ax.set_xlabel(LABELS[axis] + (" (0 drawn at 0.1)" if axis == "saturation" else ""))
        breaks = results["breaking_points"][axis]
        text = ", ".join(f"{k} {v:.3g}" for k, v in breaks.items()) or "nowhere in range"
        ax.set_title(f"{axis}: breaks {text}", fontsize=10)
        ax.legend(fontsize=7, loc="best")
    fig.suptitle("FOS pulse fit (eq. 16) stability, "
                 f"{results['meta']['trials']} trials per point", fontsize=11)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--trials", type=int, default=512, help="trials per setting (default 512)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parent / "figures",
                    help="folder for fos_stability.png and .json (default benchmarks/figures)")
    args = ap.parse_args(argv)
    if args.trials < 8:
        ap.error("--trials must be at least 8")
    args.out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    results: dict = {"meta": {"trials": args.trials, "seed": args.seed,
                              "load_avg": os.getloadavg(), "command": " ".join(sys.argv)}}
    for axis, values in AXES.items():
        results[axis] = [run_setting(axis, v, args.trials, args.seed + i)
                         for i, v in enumerate(values)]
    results["breaking_points"] = {a: breaking_point(a, results[a]) for a in AXES}
    results["breaking_points_fitted_T_start"] = breaking_point("start", results["start"],
                                                               "fitted_T")
    results["meta"]["seconds"] = time.perf_counter() - t0

    for axis in AXES:
        print(f"\n{axis} ({LABELS[axis]}); breaks at {results['breaking_points'][axis]}")
        print(f"{'value':>8} | {'in 5%':>6} | {'conv.':>6} | {'>3SE&>5%':>8} | "
              f"{'med|dtau|':>9} | {'med R':>7} | extra")
        for r in results[axis]:
            extra = ""
            if axis == "start":
                m = r["fitted_T"]
                extra = f"fitted T: in 5% {m['within_5pct']:.3f}, conv. {m['converged']:.3f}"
            if axis == "saturation":
                extra = (f"2nd order chosen: BIC {r['second_order_chosen']:.3f}, "
                         f"AIC {r['second_order_chosen_aic']:.3f}")
            tau_err = r["median_tau_err"]
            print(f"{r['value']:>8.4g} | {r['within_5pct']:>6.3f} | {r['converged']:>6.3f} | "
                  f"{r['silently_wrong']:>8.3f} | "
                  f"{'n/a' if tau_err is None else f'{100 * tau_err:.2f}%':>9} | "
                  f"{r['median_r'] or float('nan'):>7.4f} | {extra}")
    print(f"\nfitted-T start sweep breaks at {results['breaking_points_fitted_T_start']}")
    (args.out / "fos_stability.json").write_text(json.dumps(results, indent=2))
    plot(results, args.out / "fos_stability.png")
    print(f"wrote {args.out / 'fos_stability.png'} and .json in "
          f"{results['meta']['seconds']:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
