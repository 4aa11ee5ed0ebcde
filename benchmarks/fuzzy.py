"""Speed of `tactile grade`'s vectorised Mamdani grader against scikit-fuzzy, in one run.

Both grade with the same system: the shipped marker config (configs/grade_marker.yaml, six
trapezoid input terms, six triangle output terms, the Table III rules), the output universe
sampled at the same 1001 even points (plus the terms' knots) and the input universe at 1001
points plus the input knots, so both compute the same numbers (scikit-fuzzy's algorithm:
clip, refine the universe at the clip points, max, exact piecewise-linear centroid).

- scikit-fuzzy: ``ControlSystemSimulation`` one input at a time, as it is used, on
  ``--n-skfuzzy`` inputs (it is slow);
- tactile: :func:`tactile_cli.grade.infer` on ``--n`` inputs at once (best of
  ``--repeat``), at the same resolution and with the continuous centroid;
- agreement: the first ``--n-skfuzzy`` outputs of both must agree to 1e-6.

Targets (issue 5): >= 1,000,000 grades/s and >= 100x scikit-fuzzy. The machine is shared:
the load average at the start and the end is recorded beside the times.

    .venv/bin/python benchmarks/fuzzy.py                  # writes benchmarks/figures/fuzzy.json
    .venv/bin/python benchmarks/fuzzy.py --n 100000 --n-skfuzzy 500 --out /tmp/f.json
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import platform
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tactile_cli.grade import default_config_path, infer, load_config  # noqa: E402
from tactile_cli.grade.reference import (  # noqa: E402
    infer_reference,
    skfuzzy_infer,
    skfuzzy_simulation,
)

TARGET_RATE = 1_000_000
TARGET_RATIO = 100.0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1_000_000, help="inputs graded by tactile")
    ap.add_argument("--n-skfuzzy", type=int, default=3000, help="inputs graded by skfuzzy")
    ap.add_argument("--n-reference", type=int, default=300,
                    help="inputs graded by the per-sample numpy reference")
    ap.add_argument("--resolution", type=int, default=1001)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--out", type=Path,
                    default=Path(__file__).resolve().parent / "figures" / "fuzzy.json")
    args = ap.parse_args()
    load_start = os.getloadavg()

    cfg = load_config(default_config_path())
    system = dataclasses.replace(cfg.system(), resolution=args.resolution)
    continuous = dataclasses.replace(system, resolution=None)
    lo, hi = system.input_range
    rng = np.random.default_rng(0)
    x = rng.uniform(lo - 0.05 * (hi - lo), hi + 0.05 * (hi - lo), args.n)

    try:
        import skfuzzy
    except ImportError as exc:  # report, never pretend
        print(f"scikit-fuzzy is not importable ({exc}); install it with "
              "`.venv/bin/pip install scikit-fuzzy`", file=sys.stderr)
        return 1
    with warnings.catch_warnings():
        # scikit-fuzzy 0.5 passes `out` to np.maximum positionally (deprecated in numpy 2.4)
        warnings.filterwarnings("ignore", "Passing more than 2 positional", DeprecationWarning)
        sim = skfuzzy_simulation(system)
        skfuzzy_infer(sim, x[:20])  # warm-up
        t0 = time.perf_counter()
        sk = skfuzzy_infer(sim, x[:args.n_skfuzzy])
        t_sk = time.perf_counter() - t0

    t0 = time.perf_counter()
    ref = infer_reference(system, x[:args.n_reference])
    t_ref = time.perf_counter() - t0

    infer(system, x[:1000])  # warm-up (caches the closed-form coefficients)
    times, times_cont = [], []
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        res = infer(system, x)
        times.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        res_cont = infer(continuous, x)
        times_cont.append(time.perf_counter() - t0)
    t_tac, t_cont = min(times), min(times_cont)

    diff_sk = float(np.max(np.abs(res.crisp[:args.n_skfuzzy] - sk)))
    diff_ref = float(np.max(np.abs(res.crisp[:args.n_reference] - ref.crisp)))
    diff_cont = float(np.max(np.abs(res.crisp - res_cont.crisp)))
    rate_sk, rate_tac = args.n_skfuzzy / t_sk, args.n / t_tac
    out = {
        "system": {"config": "configs/grade_marker.yaml", "method": system.method,
                   "input_terms": len(system.input_terms),
                   "output_terms": len(system.output_terms), "rules": len(system.rules),
                   "resolution": args.resolution, "universe_points": int(system.universe.size)},
        "skfuzzy": {"version": skfuzzy.__version__, "n": args.n_skfuzzy, "seconds": t_sk,
                    "grades_per_s": rate_sk},
        "reference_per_sample_numpy": {"n": args.n_reference, "seconds": t_ref,
                                       "grades_per_s": args.n_reference / t_ref},
        "tactile": {"n": args.n, "seconds_best": t_tac, "seconds_all": times,
                    "grades_per_s": rate_tac},
        "tactile_continuous_centroid": {"n": args.n, "seconds_best": t_cont,
                                        "grades_per_s": args.n / t_cont,
                                        "max_abs_diff_vs_1001_points": diff_cont},
        "ratio_tactile_over_skfuzzy": rate_tac / rate_sk,
        "max_abs_diff_vs_skfuzzy": diff_sk,
        "max_abs_diff_vs_reference": diff_ref,
        "agree_1e-6": diff_sk <= 1e-6,
        "targets": {"grades_per_s": TARGET_RATE, "ratio": TARGET_RATIO,
                    "rate_met": rate_tac >= TARGET_RATE,
                    "ratio_met": rate_tac / rate_sk >= TARGET_RATIO},
        "machine": {"cpus": os.cpu_count(), "python": platform.python_version(),
                    "numpy": np.__version__, "processor": platform.processor(),
                    "load_average_start": load_start, "load_average_end": os.getloadavg()},
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.out.with_name(f".{args.out.name}.tmp")
    tmp.write_text(json.dumps(out, indent=2) + "\n")
    tmp.replace(args.out)
    print(f"scikit-fuzzy {skfuzzy.__version__}: {args.n_skfuzzy} grades in {t_sk:.2f} s = "
          f"{rate_sk:,.0f} grades/s (one input at a time)")
    print(f"per-sample numpy reference: {args.n_reference / t_ref:,.0f} grades/s")
    print(f"tactile ({system.method}, {args.resolution} points): {args.n:,} grades in "
          f"{t_tac:.3f} s = {rate_tac:,.0f} grades/s (best of {args.repeat})")
    print(f"tactile (continuous centroid): {args.n / t_cont:,.0f} grades/s; differs from the "
          f"1001-point centroid by at most {diff_cont:.2e}")
    print(f"ratio tactile / scikit-fuzzy: {rate_tac / rate_sk:,.0f}x")
    print(f"max |tactile - scikit-fuzzy| = {diff_sk:.2e} (agree to 1e-6: {diff_sk <= 1e-6}); "
          f"max |tactile - reference| = {diff_ref:.2e}")
    print(f"targets: >= {TARGET_RATE:,} grades/s: {out['targets']['rate_met']}; >= "
          f"{TARGET_RATIO:.0f}x: {out['targets']['ratio_met']}; load average "
          f"{load_start[0]:.2f} -> {out['machine']['load_average_end'][0]:.2f} on "
          f"{os.cpu_count()} cores")
    print(f"wrote {args.out}")
    return 0 if diff_sk <= 1e-6 else 1


if __name__ == "__main__":
    raise SystemExit(main())
