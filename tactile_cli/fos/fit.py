"""Batched least-squares fits of the FOS press and slip models (paper 000, sec. 4.2, eqs. 16-17)
and of their second-order alternative.

Every trial of a file is fitted at once: the trials are padded to ``(n_trials, n_points)``
with a boolean mask for ragged lengths, then to whole chunks of ``chunk_size`` (64) trials
and to a bucketed number of points (32, 48, 64, 96, 128, ...), and each chunk runs the one
compiled solver of :mod:`tactile_cli.fos.solver`: a vmapped optimistix Levenberg-Marquardt
(or Gauss-Newton) solve in float64. Every model (pulse, step, ramp; first or second order;
T known or fitted) runs through that same program, its model a run-time input, so one
compilation serves every fit of a file and every file of similar length, and
:mod:`tactile_cli.fos.compile_cache` keeps it for later processes. A vmapped solver loop runs
every trial of a chunk for as many steps as its slowest one, so the work is arranged for few
and uniform step counts:

- Variable projection: the models are linear in the gain ``alpha`` (and, for the second
  order, in ``alpha * lead``), so for given time constants the gains are solved in closed
  form and only ``log(tau)`` (or the two log-coefficients of the second-order
  denominator), plus ``log(T)`` when the pulse duration is fitted, is iterated.
- Data-driven starts, no hand-tuned guesses: ``tau`` from the 63 % rise time or, for a
  pulse, the 37 % decay time after T (which does not need the plateau reached); ``T`` from
  where the fall crosses 37 %, minus ``tau``; the ramp's ``tau`` from the time-axis
  crossing of its asymptote.
- Residuals are scaled by the data's RMS so that the tolerances are scale free.

Everything around the solve is numpy here, not compiled: inputs, starts, the polish of a
fitted T, and the assessment. Standard errors come from the Jacobian of the model in its
natural parameters (alpha, [lead in s,] tau in s, [zeta,] [T in s]) at the solution:
``s^2 (J^T J)^-1`` with ``s^2 = RSS / (n - p)``. A fit is ``converged`` only when the solver
says so *and* the solution passes checks that the solver's stopping rule does not make:
finite values and standard errors, time constants inside their bounds, identifiable
parameters, a Gauss-Newton step from the solution below a tenth of a standard error (a
minimum, not a stall) and a residual no larger than at the data-driven start. Anything else
is a per-trial :class:`FitStatus` (a ramp that stalls on flattening counts is
``saturated``); one bad trial never raises for the batch, and by default a trial that did
not converge has NaN parameters.

float64: the solves run inside ``jax.enable_x64(True)``, a context manager, so importing or
calling this module changes no global JAX setting; results are numpy float64 arrays.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Mapping
from dataclasses import dataclass, fields, replace
from typing import Any, Literal

import jax
import numpy as np
from numpy.typing import ArrayLike

from . import solver
from .models import KINDS, Kind, second_order_basis, unit_response
from .solver import SolverSpec, first_order_terms, gains, unpack


class FitStatus(enum.StrEnum):
    """Outcome of one trial's fit; only ``CONVERGED`` carries parameters by default."""

    CONVERGED = "converged"
    MAX_STEPS = "max_steps"
    SATURATED = "saturated"
    NONFINITE = "nonfinite"
    SOLVER_ERROR = "solver_error"
    OUT_OF_RANGE = "out_of_range"
    ILL_CONDITIONED = "ill_conditioned"
    NOT_AT_MINIMUM = "not_at_minimum"
    BAD_INPUT = "bad_input"

    @property
    def message(self) -> str:
        return _MESSAGES[self]


_MESSAGES = {
    FitStatus.CONVERGED: "the solver converged to a minimum inside the bounds",
    FitStatus.MAX_STEPS: "the solver ran out of steps; raise `max_steps` or check the start",
    FitStatus.SATURATED: "the counts flatten towards the end of the region: the response is "
                         "saturated, not first-order, so no ramp (eq. 17) fits it and more "
                         "solver steps would not help (the solver ran out of steps)",
    FitStatus.NONFINITE: "NaN or inf in the solution",
    FitStatus.SOLVER_ERROR: "the solver stopped with an error (divergence or linear solve)",
    FitStatus.OUT_OF_RANGE: "a time constant or the duration ran outside its bounds "
                            "(`tau_bounds_s`): the data do not determine it",
    FitStatus.ILL_CONDITIONED: "the parameters are not separately identifiable (the "
                               "Jacobian at the solution is near rank deficient)",
    FitStatus.NOT_AT_MINIMUM: "the solver stopped away from a minimum, or at a worse one than "
                              "the data-driven start reaches; refit without `tau0_s`",
    FitStatus.BAD_INPUT: "NaN/inf or negative times, times not increasing, too few points, "
                         "all-zero counts or a non-positive duration",
}
_STATUS_BY_CODE = tuple(FitStatus)
_CODE = {s: i for i, s in enumerate(_STATUS_BY_CODE)}
#: A fit is at a minimum when a Gauss-Newton step from it is below this many SEs.
_STATIONARY_SE = 0.1
#: Largest variance inflation (diagonal of the inverse of the column-scaled J^T J) of
#: parameters that still count as separately identifiable.
_MAX_INFLATION = 1e8


@dataclass(frozen=True)
class _Config:
    """One batched fit: the model, and the solver settings (:attr:`static`)."""

    kind: str
    order: int  # 1: first-order system; 2: the second-order alternative
    fit_duration: bool
    solver: str
    rtol: float
    atol: float
    max_steps: int

    @property
    def n_nonlinear(self) -> int:
        """Iterated parameters: tau, or (tau, zeta); plus T when fitted."""
        return self.order + int(self.fit_duration)

    @property
    def n_params(self) -> int:
        """All fitted parameters: the gains (alpha [, alpha * lead]) and the iterated ones."""
        return 2 * self.order + int(self.fit_duration)

    @property
    def static(self) -> SolverSpec:
        """The compiled program's specialisation (the model is a run-time input of it)."""
        return SolverSpec(self.solver, self.max_steps)


#: Result fields that are only meaningful for a converged fit.
_FIT_FIELDS = ("alpha", "tau_s", "zeta", "lead_s", "duration_s", "alpha_se", "tau_se_s",
               "zeta_se", "lead_se_s", "duration_se_s", "rss", "residual_std", "pearson_r",
               "aic", "bic")


@dataclass(frozen=True)
class FosFitResult:
    """Per-trial results of a batched fit; every array is ``(n_trials,)``.

    ``alpha`` is in events per bin, times in seconds. For ``order == 2`` (the second-order
    system of :func:`tactile_cli.fos.models.second_order_response`) ``tau_s`` is 1/omega_n,
    ``zeta`` the damping ratio and ``lead_s`` the zero's time constant; for ``order == 1``
    those two are NaN. Parameters and
    statistics of trials whose ``status`` is not ``"converged"`` are NaN unless the fit was
    run with ``keep_failed=True``.
    """

    kind: str
    order: int
    duration_fitted: bool
    n_params: int
    alpha: np.ndarray
    tau_s: np.ndarray
    zeta: np.ndarray
    lead_s: np.ndarray
    duration_s: np.ndarray  #: T, known or fitted (NaN for step and ramp)
    alpha_se: np.ndarray
    tau_se_s: np.ndarray
    zeta_se: np.ndarray
    lead_se_s: np.ndarray
    duration_se_s: np.ndarray  #: NaN unless T was fitted
    residual_std: np.ndarray  #: sqrt(RSS / (n - p)), events per bin
    pearson_r: np.ndarray  #: Pearson R between data and fit, as the paper reports it
    rss: np.ndarray  #: residual sum of squares, (events per bin)^2
    aic: np.ndarray  #: n log(RSS/n) + 2k with k = n_params + 1 (the noise variance)
    bic: np.ndarray  #: n log(RSS/n) + k log(n)
    n_points: np.ndarray  #: valid (masked-in) points per trial
    tau_min_s: np.ndarray  #: lower bound a converged time constant had to respect
    tau_max_s: np.ndarray  #: upper bound
    status: np.ndarray  #: FitStatus values as str
    n_steps: np.ndarray  #: solver steps taken
    start_tau_s: np.ndarray  #: starting tau (data-driven unless `tau0_s` was given)
    start_duration_s: np.ndarray  #: starting T (NaN unless T was fitted)

    @property
    def ok(self) -> np.ndarray:
        """(n_trials,) bool, True where the fit converged."""
        return self.status == FitStatus.CONVERGED.value

    def __len__(self) -> int:
        return len(self.status)

    def drop_failed(self) -> FosFitResult:
        """A copy with the parameters and statistics of non-converged trials set to NaN
        (a known duration, an input, is kept)."""
        bad = ~self.ok
        nan = {}
        for key in _FIT_FIELDS:
            if key == "duration_s" and not self.duration_fitted:
                continue
            v = getattr(self, key).copy()
            v[bad] = np.nan
            nan[key] = v
        return replace(self, **nan)

    def to_records(self) -> list[dict[str, Any]]:
        """One JSON-ready dict per trial (NaN becomes None)."""
        names = [f.name for f in fields(self) if isinstance(getattr(self, f.name), np.ndarray)]
        scalars = {"kind": self.kind, "order": self.order, "n_params": self.n_params,
                   "duration_fitted": self.duration_fitted}
        return [dict(scalars, trial=i, **{k: _plain(getattr(self, k)[i]) for k in names})
                for i in range(len(self))]


def _plain(v: Any) -> Any:
    """numpy scalar -> JSON-ready Python value."""
    v = v.item() if isinstance(v, np.generic) else v
    return None if isinstance(v, float) and not math.isfinite(v) else v


# --------------------------------------------------------------------------- numpy core
#: Largest variance inflation, and the Gauss-Newton step threshold, are above; these are
#: the relative steps of the finite differences of the model (central for the standard
#: errors, forward for the polish of a fitted T).
_FD_REL = 1e-5
_FD_POLISH = 1e-7


def _bucket(n: int) -> int:
    """Padded length for ``n`` points: the next of 32, 48, 64, 96, 128, 192, ... (a power of
    two or 1.5 times one), so that regions of similar length share one compilation and
    padding costs at most half the work."""
    size = 32
    while size < n:
        size = size * 3 // 2 if size & (size - 1) == 0 else size * 4 // 3
    return size


def _second_basis(cfg: _Config, t: np.ndarray, tau: np.ndarray, zeta: np.ndarray,
                  dur: np.ndarray) -> np.ndarray:
    """(n, n_points, 2) second-order basis at per-trial (n,) parameters (numpy)."""
    col = (slice(None), None)
    with np.errstate(all="ignore"):
        return np.stack(second_order_basis(cfg.kind, t, tau[col], zeta[col],
                                           dur[col] if cfg.kind == "pulse" else None), axis=-1)


def _model(cfg: _Config, theta: np.ndarray, t: np.ndarray, y: np.ndarray, m: np.ndarray,
           duration: np.ndarray, *, jacobian: bool = False) -> dict[str, np.ndarray]:
    """The projected model at ``theta`` (n, 3), numpy: ``tau``, ``zeta``, ``duration``,
    gains ``alpha`` and ``lead`` (n,), masked residual ``resid`` (n, p); with ``jacobian``
    also ``columns``, the Jacobian of ``alpha (b0 + lead b1)`` in each natural parameter
    (n, p), masked. First-order derivatives are exact; second-order ones central
    differences."""
    tau, zeta, dur = unpack(theta, duration, cfg.order == 2, cfg.fit_duration, xp=np)
    col = (slice(None), None)
    out = {"tau": tau, "zeta": zeta, "duration": dur}
    with np.errstate(all="ignore"):
        if cfg.order == 1:
            b, b_tau, b_dur = first_order_terms(t, tau, dur, cfg.kind == "ramp", xp=np)
            alpha = np.sum(m * b * y, axis=1) / np.sum(m * b * b, axis=1)
            out.update(alpha=alpha, lead=np.zeros_like(alpha), resid=(y - alpha[col] * b) * m)
            if jacobian:
                out["columns"] = {"alpha": b * m, "tau": alpha[col] * b_tau * m,
                                  "duration": alpha[col] * b_dur * m}
            return out
        b = _second_basis(cfg, t, tau, zeta, dur)
        g = gains(b, y, m, xp=np)
        alpha, lead = g[:, 0], g[:, 1] / g[:, 0]
        out.update(alpha=alpha, lead=lead,
                   resid=(y - b[..., 0] * g[:, :1] - b[..., 1] * g[:, 1:]) * m)
        if jacobian:
            columns = {"alpha": (b[..., 0] + lead[col] * b[..., 1]) * m,
                       "lead": alpha[col] * b[..., 1] * m}
            for name in ("tau", "zeta", "duration"):
                h = _FD_REL * out[name]
                up, down = dict(out), dict(out)
                up[name], down[name] = out[name] + h, out[name] - h
                db = (_second_basis(cfg, t, up["tau"], up["zeta"], up["duration"])
                      - _second_basis(cfg, t, down["tau"], down["zeta"], down["duration"])
                      ) / (2 * h)[:, None, None]
                columns[name] = alpha[col] * (db[..., 0] + lead[col] * db[..., 1]) * m
            out["columns"] = columns
    return out


def _cost(cfg: _Config, theta: np.ndarray, *args: np.ndarray) -> np.ndarray:
    """(n,) residual sum of squares of the projected model at ``theta``."""
    return np.sum(_model(cfg, theta, *args)["resid"] ** 2, axis=1)


def _moving_sum(x: np.ndarray, half: int = 2) -> np.ndarray:
    """Sum over a centred window of 2 half + 1 points along the last axis."""
    padded = np.pad(x, ((0, 0), (half, half)))
    return sum(padded[:, k: k + x.shape[1]] for k in range(2 * half + 1))


def _starts(cfg: _Config, t: np.ndarray, y: np.ndarray, m: np.ndarray, duration: np.ndarray,
            bounds: np.ndarray) -> np.ndarray:
    """(n, 3) data-driven starts in solver coordinates (see :func:`~.solver.unpack`)."""
    rows = np.arange(len(t))
    valid = m > 0
    with np.errstate(all="ignore"):
        smooth = _moving_sum(y * m) / np.maximum(_moving_sum(m), 1.0)  # 5-bin masked mean
        t_last = np.max(np.where(valid, t, -np.inf), axis=1)
        dur = np.full(len(t), np.nan)
        if cfg.kind == "ramp":
            # For t >> tau the ramp response is alpha (t - tau) / tau: its asymptote crosses
            # the time axis at t = tau. Fit a line to the second half of the region.
            w = m * (t >= 0.5 * t_last[:, None])
            sw = np.maximum(w.sum(axis=1), 1.0)[:, None]
            tm, ym = (w * t).sum(axis=1)[:, None] / sw, (w * smooth).sum(axis=1)[:, None] / sw
            slope = ((w * (t - tm) * (smooth - ym)).sum(axis=1)
                     / (w * (t - tm) ** 2).sum(axis=1))
            tau = tm[:, 0] - ym[:, 0] / slope
            tau = np.where(np.isfinite(tau) & (tau > 0), tau, 0.25 * t_last)
        else:
            peak_i = np.argmax(np.where(valid, smooth, -np.inf), axis=1)
            peak = smooth[rows, peak_i][:, None]
            rise = valid & (smooth >= (1 - np.exp(-1)) * peak)
            t_rise = np.where(rise.any(axis=1), t[rows, np.argmax(rise, axis=1)], 0.25 * t_last)
            # After T a pulse decays as exp(-(t - T)/tau) from wherever it got to, so the 37 %
            # decay time does not need the plateau reached: use it when the data show it.
            fall = valid & (t > t[rows, peak_i][:, None]) & (smooth <= np.exp(-1) * peak)
            has_fall, t_fall = fall.any(axis=1), t[rows, np.argmax(fall, axis=1)]
            if cfg.kind == "step":
                tau = t_rise
            elif cfg.fit_duration:  # the fall reaches 37 % one tau after T
                tau = t_rise
                dur = np.where(has_fall, t_fall - t_rise, t[rows, peak_i])
            else:
                tau = np.where(has_fall & (t_fall > duration), t_fall - duration, t_rise)
        tau = np.clip(tau, 2.0 * bounds[:, 0], 0.5 * bounds[:, 1])
        theta = np.zeros((len(t), 3))
        # Order 2 starts with real poles at tau and tau/4, so that the closed-form gains can
        # cancel the fast one with the zero: the start is then at least as good as the FOS.
        if cfg.order == 2:
            theta[:, 0], theta[:, 1] = np.log(1.25 * tau), 2.0 * np.log(0.5 * tau)
        else:
            theta[:, 0] = np.log(tau)
        if cfg.fit_duration:
            theta[:, 2] = np.log(np.clip(dur, bounds[:, 2], bounds[:, 3]))
    return theta


def _small_solve(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Batched ``a^-1 b`` for symmetric positive definite (n, k, k) ``a`` and (n, k) ``b``
    through the eigendecomposition: inf or NaN where ``a`` is singular, never an error."""
    ok = np.all(np.isfinite(a), axis=(1, 2))
    w, v = np.linalg.eigh(np.where(ok[:, None, None], a, np.eye(a.shape[1])))
    with np.errstate(all="ignore"):
        inv_w = np.where(w > 0, 1.0 / w, np.inf)
        x = np.einsum("nij,nj,nkj,nk->ni", v, inv_w, v, b)
    return np.where(ok[:, None], x, np.nan)


def _small_inverse(a: np.ndarray) -> np.ndarray:
    """Batched inverse of symmetric positive definite (n, k, k) ``a`` (inf/NaN if singular)."""
    ok = np.all(np.isfinite(a), axis=(1, 2))
    w, v = np.linalg.eigh(np.where(ok[:, None, None], a, np.eye(a.shape[1])))
    with np.errstate(all="ignore"):
        inv = np.einsum("nij,nj,nkj->nik", v, np.where(w > 0, 1.0 / w, np.inf), v)
    return np.where(ok[:, None, None], inv, np.nan)


def _polish(cfg: _Config, theta: np.ndarray, t: np.ndarray, y: np.ndarray, m: np.ndarray,
            duration: np.ndarray, n_iter: int = 3) -> np.ndarray:
    """A few Gauss-Newton steps in the shape coordinates with T held where the solver left it.

    The pulse model has a kink in T at every sample time. Where the fitted T sits on one,
    Levenberg-Marquardt's trust region collapses for all coordinates at once and can stop
    with tau short of its optimum for that T; these steps finish tau, and are kept only
    where they lower the residual. (Forward differences of the projected residual.)
    """
    k = cfg.order  # shape coordinates
    args = (t, y, m, duration)
    shape = theta.copy()
    with np.errstate(all="ignore"):
        for _ in range(n_iter):
            r = _model(cfg, shape, *args)["resid"]
            jac = []
            for j in range(k):
                moved = shape.copy()
                moved[:, j] += _FD_POLISH
                jac.append((_model(cfg, moved, *args)["resid"] - r) / _FD_POLISH)
            gram = np.array([[np.sum(a * b, axis=1) for b in jac] for a in jac]).transpose(2, 0, 1)
            rhs = np.stack([np.sum(a * r, axis=1) for a in jac], axis=1)
            shape[:, :k] -= _small_solve(gram, rhs)
        better = _cost(cfg, shape, *args) < _cost(cfg, theta, *args)
    better &= np.all(np.isfinite(shape), axis=1)
    return np.where(better[:, None], shape, theta)


def _in_bounds(cfg: _Config, tau: np.ndarray, zeta: np.ndarray, lead: np.ndarray,
               dur: np.ndarray, bounds: np.ndarray) -> np.ndarray:
    lo, hi = bounds[:, 0], bounds[:, 1]
    with np.errstate(all="ignore"):
        if cfg.order == 1:
            ok = (tau >= lo) & (tau <= hi)
        else:  # fast time constant ~tau/(2 zeta), sum 2 zeta tau, envelope decay tau/zeta, zero
            ok = ((tau / (2 * zeta) >= lo) & (2 * zeta * tau <= hi) & (tau / zeta <= hi)
                  & (np.abs(lead) <= hi))
        if cfg.fit_duration:
            ok &= (dur >= bounds[:, 2]) & (dur <= bounds[:, 3])
    return ok


def _gram(columns: list[np.ndarray]) -> np.ndarray:
    """(n, k, k) Gram matrices of k (n, p) columns."""
    k = len(columns)
    gram = np.empty((len(columns[0]), k, k))
    for i in range(k):
        for j in range(i, k):
            gram[:, i, j] = gram[:, j, i] = np.sum(columns[i] * columns[j], axis=1)
    return gram


def _assess(cfg: _Config, theta: np.ndarray, theta_data: np.ndarray, from_data: np.ndarray,
            solver_code: np.ndarray, t: np.ndarray, y: np.ndarray, m: np.ndarray,
            duration: np.ndarray, bounds: np.ndarray) -> dict[str, np.ndarray]:
    """Parameters, standard errors, statistics and the status code of every trial.

    Standard errors from the Jacobian of the model ``alpha (b0 + lead b1)`` in its natural
    parameters (alpha, lead in s, tau in s, zeta, T in s; those the model has):
    ``s^2 (J^T J)^-1`` with ``s^2 = RSS / (n - p)``. ``from_data`` (n,) bool: the solve
    started at ``theta_data``; Levenberg-Marquardt never ends above its start there, so
    only the other trials (and every Gauss-Newton one) are checked against it.
    """
    args = (t, y, m, duration)
    model = _model(cfg, theta, *args, jacobian=True)
    alpha, lead, tau, zeta, dur = (model[k] for k in ("alpha", "lead", "tau", "zeta",
                                                      "duration"))
    resid = model["resid"]
    n = m.sum(axis=1)
    names = ["alpha"] + (["lead"] if cfg.order == 2 else []) + ["tau"] + (
        ["zeta"] if cfg.order == 2 else []) + (["duration"] if cfg.fit_duration else [])
    with np.errstate(all="ignore"):
        rss = np.sum(resid * resid, axis=1)
        fit = (y - resid) * m
        columns = [model["columns"][k] for k in names]
        norms = np.sqrt(np.stack([np.sum(c * c, axis=1) for c in columns], axis=1))
        norms = np.where(norms > 0, norms, 1.0)
        # column-scaled: the inverse Gram diagonal is then the variance inflation
        gram = _gram(columns) / (norms[:, :, None] * norms[:, None, :])
        inflation = np.diagonal(_small_inverse(gram), axis1=1, axis2=2)
        s2 = rss / (n - cfg.n_params)
        se = np.sqrt(s2[:, None] * inflation) / norms
        p_hat = np.stack([model[k] for k in names], axis=1)
        # Distance to a minimum: the Gauss-Newton step in all parameters but T (the pulse
        # has a kink in T at every sample time, so a minimum in T may sit on a kink).
        k = 2 * cfg.order
        rhs = np.stack([np.sum(c * resid, axis=1) for c in columns[:k]], axis=1) / norms[:, :k]
        gn_step = _small_solve(gram[:, :k, :k], rhs) / norms[:, :k]
        stationary = np.all(np.abs(gn_step) <= _STATIONARY_SE * se[:, :k]
                            + 10 * cfg.rtol * np.abs(p_hat[:, :k]), axis=1)
        check = ~from_data if cfg.solver == "levenberg_marquardt" else np.ones_like(from_data)
        start_cost = np.zeros_like(rss)
        if check.any():
            start_cost[check] = _cost(cfg, theta_data[check], *(a[check] for a in args))
        not_worse = ~check | (rss <= start_cost * (1 + 1e-9))
        identifiable = np.all(np.isfinite(se), axis=1) & (np.max(inflation, axis=1)
                                                          < _MAX_INFLATION)
        code = np.select(
            [solver_code == solver.MAX_STEPS,
             (solver_code == solver.NONFINITE) | ~np.all(np.isfinite(p_hat), axis=1),
             solver_code != solver.SUCCESS,
             ~_in_bounds(cfg, tau, zeta, lead, dur, bounds),
             ~identifiable,
             ~(stationary & not_worse)],
            [_CODE[s] for s in (FitStatus.MAX_STEPS, FitStatus.NONFINITE, FitStatus.SOLVER_ERROR,
                                FitStatus.OUT_OF_RANGE, FitStatus.ILL_CONDITIONED,
                                FitStatus.NOT_AT_MINIMUM)],
            _CODE[FitStatus.CONVERGED])
        fm = (np.sum(fit, axis=1) / n)[:, None]
        ym = (np.sum(y * m, axis=1) / n)[:, None]
        pearson = (np.sum(m * (y - ym) * (fit - fm), axis=1)
                   / np.sqrt(np.sum(m * (y - ym) ** 2, axis=1)
                             * np.sum(m * (fit - fm) ** 2, axis=1)))
        n_free = cfg.n_params + 1  # + the noise variance
        aic = n * np.log(rss / n) + 2 * n_free
        bic = n * np.log(rss / n) + n_free * np.log(n)
    nan = np.full(len(alpha), np.nan)
    se_of = dict(zip(names, se.T, strict=True))
    return {
        "alpha": alpha, "tau_s": tau, "zeta": zeta if cfg.order == 2 else nan,
        "lead_s": lead if cfg.order == 2 else nan, "duration_s": dur,
        "alpha_se": se_of["alpha"], "tau_se_s": se_of["tau"], "zeta_se": se_of.get("zeta", nan),
        "lead_se_s": se_of.get("lead", nan), "duration_se_s": se_of.get("duration", nan),
        "rss": rss, "residual_std": np.sqrt(s2), "pearson_r": pearson, "aic": aic, "bic": bic,
        "code": code,
    }


def _per_trial(name: str, value: ArrayLike | None, n_trials: int) -> np.ndarray:
    """A scalar or per-trial option as (n_trials,) float64; None gives NaN."""
    if value is None:
        return np.full(n_trials, np.nan)
    arr = np.asarray(value, dtype=np.float64)
    if arr.shape not in ((), (n_trials,)):
        raise ValueError(f"`{name}` has shape {arr.shape}; expected a scalar or ({n_trials},), "
                         "one value per trial.")
    return np.broadcast_to(arr, (n_trials,)).copy()


def _user_start(name: str, value: ArrayLike | None, n_trials: int) -> np.ndarray:
    """(n_trials,) user starting values; NaN means: use the data-driven start."""
    v = _per_trial(name, value, n_trials)
    given = ~np.isnan(v)
    if np.any(given & ~((v > 0) & np.isfinite(v))):
        raise ValueError(f"`{name}` (={v[given & ~(v > 0)][:3]}...) must be positive and "
                         "finite (NaN means: use the data-driven start).")
    return v


def _prepare(t_s: ArrayLike, y: ArrayLike, mask: ArrayLike | None
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    y = np.asarray(y, dtype=np.float64)
    if y.ndim != 2:
        raise ValueError(f"`y` has shape {y.shape}; expected (n_trials, n_points) event counts "
                         "per bin (pad ragged trials and pass `mask`).")
    t = np.asarray(t_s, dtype=np.float64)
    if t.shape not in (y.shape[1:], y.shape):
        raise ValueError(f"`t_s` has shape {t.shape}; expected ({y.shape[1]},) or {y.shape} "
                         "like `y`.")
    m = np.ones(y.shape, bool) if mask is None else np.asarray(mask)
    if m.shape != y.shape or m.dtype != bool:
        raise ValueError(f"`mask` has shape {m.shape} and dtype {m.dtype}; expected bool "
                         f"{y.shape} like `y` (True where a point is real).")
    return np.broadcast_to(t, y.shape), y, m


def _bad_trials(cfg: _Config, t: np.ndarray, y: np.ndarray, m: np.ndarray,
                known_dur: np.ndarray) -> np.ndarray:
    """(n_trials,) bool: inputs no fit can use. Flagged per trial, never raised."""
    with np.errstate(invalid="ignore"):
        bad = ~np.all(np.isfinite(t) & np.isfinite(y), axis=1)
        bad |= m.sum(axis=1) < cfg.n_params + 2
        # valid times must be >= 0 (from the region start) and strictly increasing
        before = np.maximum.accumulate(np.where(m, t, -np.inf), axis=1)
        bad |= np.any(t < 0, axis=1) | np.any(m[:, 1:] & (t[:, 1:] <= before[:, :-1]), axis=1)
        bad |= ~np.any(y != 0, axis=1)
        if cfg.kind == "pulse" and not cfg.fit_duration:
            bad |= ~(np.isfinite(known_dur) & (known_dur > 0))
    return bad


def _flattens(t_s: np.ndarray, y: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """(n,) bool: the counts flatten, the sign of saturation in a ramp region.

    ``t_s``, ``y``, ``mask`` (n, n_points). The valid points of each trial are cut into
    thirds and a line fitted to each: the counts flatten when the last third rises at less
    than half the steeper of the first two. A ramp response (eq. 17) is convex, its slope
    never falls; on the marker-event scene the ratio is 0.99-1.10 for every unsaturated slip
    and 0.13-0.25 for the saturated ones.
    """
    out = np.zeros(len(y), bool)
    for i in range(len(y)):  # a handful of failed trials: a loop over trials, not samples
        t, v = t_s[i][mask[i]], y[i][mask[i]]
        if len(t) < 9:
            continue
        thirds = np.array_split(np.arange(len(t)), 3)
        slopes = [np.polyfit(t[k], v[k], 1)[0] for k in thirds]
        out[i] = max(slopes[:2]) > 0 and slopes[2] < 0.5 * max(slopes[:2])
    return out


def _fit(cfg: _Config, t_s: ArrayLike, y: ArrayLike, mask: ArrayLike | None, *,
         duration_s: ArrayLike | None, tau0_s: ArrayLike | None, zeta0: ArrayLike | None,
         duration0_s: ArrayLike | None, tau_bounds_s: tuple[float, float] | None,
         chunk_size: int, keep_failed: bool, min_points: int = 0) -> FosFitResult:
    t, y, m = _prepare(t_s, y, mask)
    n_trials, n_points = y.shape
    known_dur = _per_trial("duration_s", duration_s, n_trials)
    tv, yv = np.where(m, t, 0.0), np.where(m, y, 0.0)
    bad = _bad_trials(cfg, tv, yv, m, known_dur)

    # Starting values in solver coordinates (see `solver.unpack`); NaN: data-driven.
    theta_user = np.full((n_trials, solver.N_THETA), np.nan)
    tau0 = _user_start("tau0_s", tau0_s, n_trials)
    if cfg.order == 2:
        zeta = _user_start("zeta0", zeta0, n_trials)
        theta_user[:, 0], theta_user[:, 1] = np.log(2 * zeta * tau0), 2 * np.log(tau0)
    else:
        theta_user[:, 0] = np.log(tau0)
    if cfg.fit_duration:
        theta_user[:, 2] = np.log(_user_start("duration0_s", duration0_s, n_trials))

    # Pad to whole chunks of a bucketed length. Bad trials get a clean, quickly converging
    # substitute problem so that they cannot hold up a chunk (a vmapped loop runs until its
    # slowest trial stops); their results are discarded.
    n_pad = _bucket(max(n_points, min_points, 1))
    chunk = chunk_size  # every call the same shape: one compilation for every batch size
    n_rows = -(-max(n_trials, 1) // chunk) * chunk
    tt, yy, mm = (np.zeros((n_rows, n_pad)) for _ in range(3))
    tt[:n_trials, :n_points], yy[:n_trials, :n_points], mm[:n_trials, :n_points] = tv, yv, m
    dummy = np.ones(n_rows, bool)
    dummy[:n_trials] = bad
    grid = np.arange(n_pad, dtype=np.float64)
    tt[dummy], mm[dummy] = grid, 1.0
    yy[dummy] = 1000.0 * unit_response(cfg.kind, grid, n_pad / 8, n_pad / 2)
    # T is an input only for a pulse of known length; a step is the pulse with T = inf.
    known = cfg.kind == "pulse" and not cfg.fit_duration
    dur_rows = np.full(n_rows, n_pad / 2 if known else np.inf)
    if known:
        dur_rows[:n_trials] = np.where(bad, n_pad / 2, known_dur)

    # Bounds: tau from half a bin to five times the region; a fitted T strictly inside.
    t_last = np.max(np.where(mm > 0, tt, -np.inf), axis=1)
    t_first = np.min(np.where(mm > 0, tt, np.inf), axis=1)
    dt = (t_last - t_first) / (mm.sum(axis=1) - 1)  # mean spacing of the valid points
    bounds = np.stack([0.5 * dt, 5.0 * (t_last + dt), dt, t_last - dt], axis=1)
    if tau_bounds_s is not None:
        lo, hi = (float(b) for b in tau_bounds_s)
        if not 0 < lo < hi:
            raise ValueError(f"`tau_bounds_s` (={tau_bounds_s}) must be (low, high) seconds "
                             "with 0 < low < high.")
        bounds[~dummy, 0], bounds[~dummy, 1] = lo, hi
    theta_data = _starts(cfg, tt, yy, mm, dur_rows, bounds)
    theta0 = theta_data.copy()
    theta0[:n_trials] = np.where(np.isfinite(theta_user) & ~bad[:, None], theta_user,
                                 theta_data[:n_trials])

    theta, solver_code, n_steps = run_solver(
        cfg.static, (tt, yy, mm, dur_rows, theta0),
        (cfg.kind == "ramp", cfg.order == 2, cfg.fit_duration), chunk=chunk,
        tolerances=_tolerances(cfg))
    keep = slice(0, n_trials)
    args = (tt[keep], yy[keep], mm[keep], dur_rows[keep])
    theta = theta[keep]
    if cfg.fit_duration:
        theta = _polish(cfg, theta, *args)
    from_data = ~np.any(np.isfinite(theta_user), axis=1) | bad
    out = _assess(cfg, theta, theta_data[keep], from_data, solver_code[keep], *args,
                  bounds[keep])
    code = np.where(bad, _CODE[FitStatus.BAD_INPUT], out.pop("code"))
    if cfg.kind == "ramp" and cfg.order == 1:  # a stalled ramp on flattening counts
        stalled = np.flatnonzero(code == _CODE[FitStatus.MAX_STEPS])
        code[stalled[_flattens(tv[stalled], yv[stalled], m[stalled])]] = _CODE[
            FitStatus.SATURATED]
    start_tau, _, start_dur = unpack(theta0[keep], dur_rows[keep], cfg.order == 2,
                                     cfg.fit_duration, xp=np)
    out["start_tau_s"] = start_tau
    out["start_duration_s"] = start_dur if cfg.fit_duration else np.full(n_trials, np.nan)
    for key in _FIT_FIELDS + ("start_tau_s", "start_duration_s"):
        out[key] = np.asarray(out[key], dtype=np.float64).copy()
        out[key][bad] = np.nan  # results of the substitute problem
    if cfg.kind != "pulse":
        out["duration_s"][:] = np.nan
    result = FosFitResult(
        kind=cfg.kind, order=cfg.order, duration_fitted=cfg.fit_duration,
        n_params=cfg.n_params, n_points=m.sum(axis=1), n_steps=n_steps[keep],
        tau_min_s=np.where(bad, np.nan, bounds[keep, 0]),
        tau_max_s=np.where(bad, np.nan, bounds[keep, 1]),
        status=np.array([s.value for s in _STATUS_BY_CODE])[code], **out)
    return result if keep_failed else result.drop_failed()


#: Tolerance floor of solves that iterate a pulse's T (see :func:`_tolerances`).
_KINKED_TOL = 1e-4


def _tolerances(cfg: _Config) -> tuple[float, float]:
    """The compiled solve's (rtol, atol): the configured ones, except where T is fitted.

    The pulse has a kink in T at every sample time, so its least-squares T is only defined
    to the sample grid and Levenberg-Marquardt's trust region collapses there; tight
    tolerances would then spend every step of ``max_steps`` and fail good fits. Those solves
    stop at ``_KINKED_TOL`` at the tightest and :func:`_polish` finishes the smooth
    coordinates (tau, zeta and so the gains) with T held, to the precision of the others.
    """
    if cfg.fit_duration:
        return max(cfg.rtol, _KINKED_TOL), max(cfg.atol, _KINKED_TOL)
    return cfg.rtol, cfg.atol


def run_solver(spec: SolverSpec, arrays: tuple[np.ndarray, ...], flags: tuple[bool, ...], *,
               chunk: int, tolerances: tuple[float, float]
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Run the compiled solver over whole chunks of ``chunk`` rows: ``arrays`` are (t, y, m,
    duration, theta0) as :func:`tactile_cli.fos.solver.chunk_function` takes them and
    ``tolerances`` (rtol, atol) its run-time stopping tolerances; returns (theta, code,
    n_steps) for every row."""
    from .compile_cache import solver_program

    n_rows, n_points = arrays[0].shape
    fn = solver_program(spec, chunk, n_points)
    flag_args = tuple(np.bool_(f) for f in flags) + tuple(np.float64(x) for x in tolerances)
    with jax.enable_x64(True):
        # All chunks are dispatched before any result is read, so they queue back to back.
        outs = [fn(*(a[s: s + chunk] for a in arrays), *flag_args)
                for s in range(0, n_rows, chunk)]
        theta, code, steps = (np.concatenate([np.asarray(o[i]) for o in outs])
                              for i in range(3))
    return theta, code, steps


# --------------------------------------------------------------------------- public API
Solver = Literal["levenberg_marquardt", "gauss_newton"]
#: Names :attr:`FitOptions.p0` takes: the gain, the time constant and the pulse duration.
P0_NAMES = ("alpha", "tau", "T")


@dataclass(frozen=True)
class FitOptions:
    """Solver settings shared by every fit; checked when constructed.

    ``solver``: optimistix ``LevenbergMarquardt`` (default: converges from starts 100x off)
    or ``GaussNewton`` (about half the compile and run time, but from starts that far off
    it diverges; those trials are flagged, not kept). ``max_steps``, ``rtol``, ``atol``:
    solver limits, the tolerances acting on log(tau) (a step stops the solve when it moves
    every coordinate by less than ``atol + rtol |coordinate|``) and on residuals scaled by
    the data's RMS. The tolerances are run-time inputs of the compiled program (changing
    them compiles nothing). The defaults (1e-10) put the fitted parameters within a relative
    1e-9 or so of the least-squares minimum on well-posed problems, ill-conditioned ones
    such as NIST's Misra1a and BoxBOD included (``tests/fos/test_precision.py``); 1e-4 (the
    old default) stopped at about 5 significant digits. The extra steps cost little: a
    chunk's solve is short next to the rest of a fit. ``chunk_size``: trials per compiled,
    vmapped solve; every batch is padded to whole chunks, so one compilation serves every
    batch size (a chunk runs as many steps as its slowest trial; 64 ran fastest per trial
    on 2 CPU cores, 1024 1.7x slower).

    ``p0``: user starting values of the first-order fits, a mapping of parameter names to
    values, used where a fit function is not given its own ``tau0_s``/``duration0_s``:
    ``"tau"`` (s) and ``"T"`` (s, the pulse duration when it is fitted). ``"alpha"`` is
    accepted too but does not steer anything: the gains are solved in closed form for every
    tau (variable projection), so only the time constants are iterated. Trials without a
    given value start from the data-driven values; the second-order alternative always
    starts from the data.
    """

    solver: Solver = "levenberg_marquardt"
    max_steps: int = 64
    rtol: float = 1e-10
    atol: float = 1e-10
    chunk_size: int = 64
    p0: Mapping[str, float] | None = None

    def __post_init__(self) -> None:
        if self.solver not in ("levenberg_marquardt", "gauss_newton"):
            raise ValueError(f"`solver` (={self.solver!r}) must be 'levenberg_marquardt' or "
                             "'gauss_newton'.")
        if self.max_steps < 1:
            raise ValueError(f"`max_steps` (={self.max_steps}) must be at least 1.")
        if not (self.rtol > 0 and self.atol > 0):
            raise ValueError(f"`rtol` (={self.rtol}) and `atol` (={self.atol}) must be "
                             "positive.")
        if self.chunk_size < 1:
            raise ValueError(f"`chunk_size` (={self.chunk_size}) must be a positive number "
                             "of trials.")
        if not (math.isfinite(self.rtol) and math.isfinite(self.atol)
                and self.rtol < 1 and self.atol < 1):
            raise ValueError(f"`rtol` (={self.rtol}) and `atol` (={self.atol}) must be finite "
                             "and below 1.")
        if self.p0 is not None:
            p0 = dict(self.p0)
            for name, value in p0.items():
                if name not in P0_NAMES:
                    raise ValueError(f"`p0` names {name!r}; the starting values are "
                                     f"{', '.join(P0_NAMES)}.")
                value = float(value)
                if not math.isfinite(value) or (name != "alpha" and value <= 0):
                    raise ValueError(f"`p0` {name}={value:g} must be "
                                     + ("finite." if name == "alpha" else
                                        "positive and finite (seconds)."))
                p0[name] = value
            object.__setattr__(self, "p0", tuple(sorted(p0.items())))

    def start(self, name: str) -> float | None:
        """The user's starting value of ``name`` in :attr:`p0`, else None."""
        return None if self.p0 is None else dict(self.p0).get(name)


_ARGS_DOC = """
    Parameters
    ----------
    t_s:
        (n_points,) or (n_trials, n_points) times in seconds from the region start.
    y:
        (n_trials, n_points) event counts per bin, padded for ragged trials.
    mask:
        (n_trials, n_points) bool, True where a point is real; None means all are.
    tau0_s:
        Starting tau in seconds, a scalar or one per trial; None or NaN: data-driven. Meant
        for robustness tests; a fit that ends worse than the data-driven start would is
        flagged ``not_at_minimum``.
    tau_bounds_s:
        (low, high) seconds a converged time constant must lie in; default per trial from
        half a bin to five times the region length (outside, the data cannot tell tau).
    keep_failed:
        Keep the last iterate of trials that did not converge instead of NaN.
    options:
        :class:`FitOptions` (solver, limits, chunk size); None: the defaults.
"""


def _make_config(kind: str, order: int, fit_duration: bool, options: FitOptions) -> _Config:
    if kind not in KINDS:
        raise ValueError(f"`kind` (={kind!r}) must be one of {KINDS}.")
    return _Config(kind, order, fit_duration, options.solver, float(options.rtol),
                   float(options.atol), int(options.max_steps))


def fit_pulse(
    t_s: ArrayLike, y: ArrayLike, mask: ArrayLike | None = None, *,
    duration_s: ArrayLike | None = None, tau0_s: ArrayLike | None = None,
    duration0_s: ArrayLike | None = None, tau_bounds_s: tuple[float, float] | None = None,
    keep_failed: bool = False, options: FitOptions | None = None,
) -> FosFitResult:
    """Fit the pulse response of eq. 16 to press regions, all trials at once.

    ``duration_s`` is the known press length T in seconds (a scalar or one per trial);
    None fits T as well, starting from the data or from ``duration0_s``. A fitted T must
    lie between one bin after the start and one bin before the end of the region.
    """
    options = options or FitOptions()
    cfg = _make_config("pulse", 1, duration_s is None, options)
    tau0_s = options.start("tau") if tau0_s is None else tau0_s
    duration0_s = options.start("T") if duration0_s is None else duration0_s
    return _fit(cfg, t_s, y, mask, duration_s=duration_s, tau0_s=tau0_s, zeta0=None,
                duration0_s=duration0_s, tau_bounds_s=tau_bounds_s,
                chunk_size=options.chunk_size, keep_failed=keep_failed)


def fit_step(
    t_s: ArrayLike, y: ArrayLike, mask: ArrayLike | None = None, *,
    tau0_s: ArrayLike | None = None, tau_bounds_s: tuple[float, float] | None = None,
    keep_failed: bool = False, options: FitOptions | None = None,
) -> FosFitResult:
    """Fit the step response ``alpha (1 - exp(-t/tau))`` (eq. 16 for T -> inf)."""
    options = options or FitOptions()
    tau0_s = options.start("tau") if tau0_s is None else tau0_s
    return _fit(_make_config("step", 1, False, options), t_s, y, mask, duration_s=None,
                tau0_s=tau0_s, zeta0=None, duration0_s=None, tau_bounds_s=tau_bounds_s,
                chunk_size=options.chunk_size, keep_failed=keep_failed)


def fit_ramp(
    t_s: ArrayLike, y: ArrayLike, mask: ArrayLike | None = None, *,
    tau0_s: ArrayLike | None = None, tau_bounds_s: tuple[float, float] | None = None,
    keep_failed: bool = False, options: FitOptions | None = None,
) -> FosFitResult:
    """Fit the ramp response of eq. 17 to slip regions, all trials at once."""
    options = options or FitOptions()
    tau0_s = options.start("tau") if tau0_s is None else tau0_s
    return _fit(_make_config("ramp", 1, False, options), t_s, y, mask, duration_s=None,
                tau0_s=tau0_s, zeta0=None, duration0_s=None, tau_bounds_s=tau_bounds_s,
                chunk_size=options.chunk_size, keep_failed=keep_failed)


def fit_second_order(
    kind: Kind, t_s: ArrayLike, y: ArrayLike, mask: ArrayLike | None = None, *,
    duration_s: ArrayLike | None = None, tau0_s: ArrayLike | None = None,
    zeta0: ArrayLike | None = None, duration0_s: ArrayLike | None = None,
    tau_bounds_s: tuple[float, float] | None = None, keep_failed: bool = False,
    options: FitOptions | None = None,
) -> FosFitResult:
    """Fit the second-order alternative ``alpha (1 + lead s) / (tau^2 s^2 + 2 zeta tau s + 1)``
    (see :func:`tactile_cli.fos.models.second_order_response`) to regions of ``kind``.

    By default it starts with real poles at the data-driven first-order tau and at a
    quarter of it (``tau0_s = tau/2``, ``zeta0 = 1.25``); ``tau0_s`` and ``zeta0`` (both, or
    neither) override that. The zero is solved in closed form with the gain. For a pulse,
    ``duration_s=None`` fits T as well.
    """
    if (tau0_s is None) != (zeta0 is None):
        raise ValueError("`tau0_s` and `zeta0` start the second-order fit together: give both "
                         "or neither.")
    options = options or FitOptions()
    cfg = _make_config(kind, 2, kind == "pulse" and duration_s is None, options)
    return _fit(cfg, t_s, y, mask, duration_s=duration_s, tau0_s=tau0_s, zeta0=zeta0,
                duration0_s=duration0_s, tau_bounds_s=tau_bounds_s,
                chunk_size=options.chunk_size, keep_failed=keep_failed)


for _f in (fit_pulse, fit_step, fit_ramp, fit_second_order):
    _f.__doc__ = (_f.__doc__ or "") + _ARGS_DOC
