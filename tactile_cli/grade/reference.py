"""A straightforward per-sample Mamdani reference, for tests and benchmarks only.

One Python iteration per input, written the plain way, so that :func:`~.fuzzy.infer`
(vectorised, closed form) can be checked against something obviously right:

- ``resolution=M``: scikit-fuzzy's control-system algorithm step by step (sample the
  output terms on the universe, add the points where each term crosses its clip level,
  aggregate with max at those points, integrate the piecewise-linear result exactly);
- ``resolution=None``: the continuous aggregate, integrated exactly between all of its
  kinks (terms' knots, clip points, and every crossing of two clipped terms, found by
  brute force in each interval).

Slow by design (milliseconds per input): never use it in a hot path.
"""

from __future__ import annotations

import numpy as np

from .fuzzy import Inference, MamdaniSystem


def infer_reference(system: MamdaniSystem, x: np.ndarray) -> Inference:
    """Same contract as :func:`tactile_cli.grade.fuzzy.infer`, one input at a time."""
    x = np.asarray(x, dtype=np.float64).reshape(-1)
    n_rules, n_out = len(system.rules), len(system.output_terms)
    crisp = np.empty(x.shape[0])
    firing = np.empty((x.shape[0], n_rules))
    cut = np.zeros((x.shape[0], n_out))
    lo, hi = system.input_range
    for n, xi in enumerate(x):
        xc = min(max(float(xi), lo), hi) if np.isfinite(xi) else float("nan")
        mu = [float(mf(np.array([xc]))[0]) for mf in system.input_mfs]
        for r, (i, o) in enumerate(system.rules):
            firing[n, r] = mu[i]
            cut[n, o] = max(cut[n, o], mu[i]) if np.isfinite(mu[i]) else float("nan")
        h = [float(c) for c in np.minimum(cut[n], 1.0)]  # NaN stays NaN
        if not all(np.isfinite(h)):
            crisp[n] = float("nan")
        elif system.resolution is None:
            crisp[n] = _continuous_centroid(system, h)
        else:
            crisp[n] = _skfuzzy_centroid(system, h)
    return Inference(x=x, crisp=crisp, grade=system.grade_of(crisp), firing=firing, cut=cut)


def _crossings_fast(U: np.ndarray, mu: np.ndarray, level: float) -> list[float]:
    """scikit-fuzzy's ``_interp_universe_fast``: universe values where ``mu`` crosses
    ``level`` (linear interpolation between samples)."""
    idx = np.where(np.diff(mu > level if level == 0 else mu >= level))[0]
    return list(U[idx] + (level - mu[idx]) * (U[idx + 1] - U[idx]) / (mu[idx + 1] - mu[idx]))


def _centroid_of_samples(xs: np.ndarray, ys: np.ndarray) -> float:
    """Centroid of the piecewise-linear function through ``(xs, ys)``, segment by segment
    as scikit-fuzzy's ``centroid`` computes it."""
    sum_moment, sum_area = 0.0, 0.0
    for i in range(1, len(xs)):
        x1, x2, y1, y2 = xs[i - 1], xs[i], ys[i - 1], ys[i]
        if (y1 == y2 == 0.0) or x1 == x2:
            continue
        area = 0.5 * (x2 - x1) * (y1 + y2)
        centre = x1 + (x2 - x1) * (y1 + 2.0 * y2) / (3.0 * (y1 + y2))
        sum_moment += centre * area
        sum_area += area
    return sum_moment / sum_area if sum_area > 0 else float("nan")


def _skfuzzy_centroid(system: MamdaniSystem, h: list[float]) -> float:
    U = system.universe
    sampled = [mf(U) for mf in system.output_mfs]
    extra: list[float] = []
    for mu, level in zip(sampled, h, strict=True):
        extra.extend(_crossings_fast(U, mu, level))
    pts = np.union1d(U, extra)
    agg = np.zeros_like(pts)
    for mu, level in zip(sampled, h, strict=True):
        agg = np.maximum(agg, np.minimum(level, np.interp(pts, U, mu)))
    return _centroid_of_samples(pts, agg)


def _continuous_centroid(system: MamdaniSystem, h: list[float]) -> float:
    lo, hi = system.output_range
    pts = {lo, hi}
    for mf, level in zip(system.output_mfs, h, strict=True):
        a, b, c, d = mf.trapezoid
        pts.update((a, b, c, d, a + level * (b - a), d - level * (d - c)))
    base = sorted(p for p in pts if lo <= p <= hi)

    def clipped(ys: np.ndarray) -> np.ndarray:  # (n_points, n_terms)
        return np.stack([np.minimum(level, mf(ys))
                         for mf, level in zip(system.output_mfs, h, strict=True)], axis=1)

    full = set(base)
    values = clipped(np.array(base))
    for j in range(len(base) - 1):
        u, v = base[j], base[j + 1]
        if v <= u:
            continue
        fu, fv = values[j], values[j + 1]  # every clipped term is linear on [u, v]
        for r in range(len(fu)):
            for s in range(r + 1, len(fu)):
                du, dv = fu[r] - fu[s], fv[r] - fv[s]
                if du * dv < 0:
                    full.add(u + (v - u) * du / (du - dv))
    xs = np.array(sorted(full))
    ys = clipped(xs).max(axis=1)
    return _centroid_of_samples(xs, ys)


def skfuzzy_simulation(system: MamdaniSystem, *, input_points: int = 1001):
    """The same system as a scikit-fuzzy ``ControlSystemSimulation`` (imported lazily; the
    library itself never needs scikit-fuzzy).

    The antecedent universe is ``input_points`` even points over the input range plus the
    input terms' knots (so its sampled piecewise-linear terms are exact), the consequent
    universe :attr:`MamdaniSystem.universe`; defaults everywhere else (min implication, max
    aggregation, centroid, inputs clipped to the universe). Needs ``system.resolution``.
    """
    import skfuzzy as fuzz
    from skfuzzy import control as ctrl

    if system.resolution is None:
        raise ValueError("scikit-fuzzy needs a sampled output universe; set `resolution`")
    lo, hi = system.input_range
    knots = [v for m in system.input_mfs if m.piecewise_linear for v in m.trapezoid]
    x_universe = np.union1d(np.linspace(lo, hi, input_points), np.clip(knots, lo, hi))
    area = ctrl.Antecedent(x_universe, "area")
    force = ctrl.Consequent(system.universe, "force", defuzzify_method="centroid")
    for var, names, mfs in ((area, system.input_terms, system.input_mfs),
                            (force, system.output_terms, system.output_mfs)):
        for name, mf in zip(names, mfs, strict=True):
            u = var.universe
            if mf.kind == "trimf":
                var[name] = fuzz.trimf(u, list(mf.params))
            elif mf.kind == "trapmf":
                var[name] = fuzz.trapmf(u, list(mf.params))
            else:
                var[name] = fuzz.gaussmf(u, *mf.params)
    rules = [ctrl.Rule(area[system.input_terms[i]], force[system.output_terms[o]])
             for i, o in system.rules]
    return ctrl.ControlSystemSimulation(ctrl.ControlSystem(rules))


def skfuzzy_infer(simulation, x: np.ndarray) -> np.ndarray:
    """(n,) crisp outputs of a :func:`skfuzzy_simulation`, one input at a time (as it is
    used)."""
    out = np.empty(len(x))
    for n, value in enumerate(np.asarray(x, dtype=np.float64)):
        simulation.input["area"] = float(value)
        simulation.compute()
        out[n] = simulation.output["force"]
    return out


__all__ = ["infer_reference", "skfuzzy_infer", "skfuzzy_simulation"]
