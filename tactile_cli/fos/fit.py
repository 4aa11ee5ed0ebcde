"""Batched least-squares fits of the FOS press and slip models (paper 000, sec. 4.2, eqs. 16-17).

Every trial of a file is fitted at once: the trials are padded to ``(n_trials, n_points)``
with a boolean mask for ragged lengths, cut into chunks of ``chunk_size`` trials, and each
chunk runs one jit-compiled, vmapped Levenberg-Marquardt solve (optimistix) in float64. A
vmapped solver loop runs every trial for as many steps as the slowest one, so the work is
arranged for few and uniform step counts:

- Variable projection: the models are linear in the gains ``alpha``, so for given time
  constants the gains are solved in closed form and only ``log(tau)`` (and ``log(T)`` when
  the pulse duration is fitted) is iterated: one or two unknowns instead of two to five.
- Data-driven starts, no hand-tuned guesses: ``tau`` from the 63 % rise time (or, for a
  pulse, the 37 % decay time after T, which does not depend on the plateau being reached),
  ``T`` from the peak time, the ramp's ``tau`` from the time-axis crossing of its asymptote.
- Residuals are scaled by the data's RMS so the solver tolerances are scale free.

After the solve, the standard errors come from the Jacobian of the full model in natural
parameters (gains, tau in s, T in s) at the solution, ``s^2 (J^T J)^-1`` with
``s^2 = RSS / (n - p)``. A fit is only ``converged`` when the solver says so *and* the
solution passes checks that an optimiser's own stopping rule does not make: finite values
and standard errors, time constants inside their bounds, a Gauss-Newton step from the
solution smaller than a tenth of the standard error (a stationary point, not a stall) and a
residual no larger than at the data-driven start. Anything else is a per-trial status (see
:class:`FitStatus`); one bad trial never raises for the batch, and by default the parameters
of a trial that did not converge are NaN.

float64: the fits run inside ``jax.enable_x64(True)``, a context manager, so importing this
package changes no global JAX setting; results are returned as numpy float64 arrays.
"""

from __future__ import annotations

import enum
import functools
import math
from dataclasses import dataclass, fields, replace
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from numpy.typing import ArrayLike

from .models import KINDS, Kind, unit_response


class FitStatus(enum.StrEnum):
    """Outcome of one trial's fit; only ``CONVERGED`` carries parameters by default."""

    CONVERGED = "converged"
    MAX_STEPS = "max_steps"
    NONFINITE = "nonfinite"
    SOLVER_ERROR = "solver_error"
    OUT_OF_RANGE = "out_of_range"
    NOT_AT_MINIMUM = "not_at_minimum"
    ILL_CONDITIONED = "ill_conditioned"
    BAD_INPUT = "bad_input"

    @property
    def message(self) -> str:
        return _MESSAGES[self]


_MESSAGES = {
    FitStatus.CONVERGED: "the solver converged to a stationary point inside the bounds",
    FitStatus.MAX_STEPS: "the solver ran out of steps; raise `max_steps` or check the start",
    FitStatus.NONFINITE: "NaN or inf in the solution or its standard errors",
    FitStatus.SOLVER_ERROR: "the solver stopped with an error (divergence or linear solve)",
    FitStatus.OUT_OF_RANGE: "a time constant or the duration ran outside its bounds "
                            "(`tau_bounds_s`); the data do not determine it",
    FitStatus.NOT_AT_MINIMUM: "the solver stopped away from a minimum, or at a worse one than "
                              "the data-driven start reaches; refit without `tau0_s`",
    FitStatus.ILL_CONDITIONED: "the parameters are not separately identifiable "
                               "(Jacobian at the solution is rank deficient)",
    FitStatus.BAD_INPUT: "NaN/inf or negative times, times not increasing, too few points, "
                         "all-zero counts or a non-positive duration",
}
_STATUS_BY_CODE = tuple(FitStatus)
_CODE = {s: i for i, s in enumerate(_STATUS_BY_CODE)}
#: Pad n_points to a multiple of this, so files of similar length share one compilation.
_POINT_BUCKET = 32
#: A fit is at a stationary point when a Gauss-Newton step from it is below this many SEs.
_STATIONARY_SE = 0.1
#: Variance inflation (diagonal of the inverse of the column-scaled J^T J) above which the
#: parameters count as not separately identifiable.
_MAX_INFLATION = 1e8


@dataclass(frozen=True)
class _Config:
    """Static part of a batched fit: one compiled solver per distinct config and shape."""

    kind: str
    order: int  # number of first-order modes: 1 (FOS) or 2 (second-order alternative)
    fit_duration: bool
    rtol: float
    atol: float
    max_steps: int

    @property
    def n_nonlinear(self) -> int:
        return self.order + int(self.fit_duration)

    @property
    def n_params(self) -> int:
        return 2 * self.order + int(self.fit_duration)


#: Result fields that are only meaningful for a converged fit.
_FIT_FIELDS = ("alpha", "tau_s", "duration_s", "alpha_se", "tau_se_s", "duration_se_s", "rss",
               "residual_std", "pearson_r", "aic", "bic")


@dataclass(frozen=True)
class FosFitResult:
    """Per-trial results of a batched fit; every array has ``n_trials`` rows.

    For ``order == 1`` the parameter arrays are ``(n_trials,)``; for ``order == 2`` ``alpha``,
    ``tau_s`` and their standard errors are ``(n_trials, 2)``, fast mode first. Parameters of
    trials whose ``status`` is not ``"converged"`` are NaN unless the fit was run with
    ``keep_failed=True``. ``alpha`` is in events per bin, times in seconds.
    """

    kind: str
    order: int
    duration_fitted: bool
    alpha: np.ndarray
    tau_s: np.ndarray
    duration_s: np.ndarray  #: T, known or fitted (NaN for step and ramp)
    alpha_se: np.ndarray
    tau_se_s: np.ndarray
    duration_se_s: np.ndarray  #: NaN unless T was fitted
    residual_std: np.ndarray  #: sqrt(RSS / (n - p)), events per bin
    pearson_r: np.ndarray  #: Pearson R between data and fit, as the paper reports it
    rss: np.ndarray  #: residual sum of squares, (events per bin)^2
    aic: np.ndarray  #: n log(RSS/n) + 2k, k = n_params + 1 (the noise variance)
    bic: np.ndarray  #: n log(RSS/n) + k log(n)
    n_points: np.ndarray  #: valid (masked-in) points per trial
    n_params: int
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
        """A copy with the parameters and statistics of non-converged trials set to NaN."""
        bad = ~self.ok
        nan = {}
        for key in _FIT_FIELDS:
            v = getattr(self, key).copy()
            v[bad] = np.nan
            nan[key] = v
        return replace(self, **nan)

    def to_records(self) -> list[dict[str, Any]]:
        """One JSON-ready dict per trial (NaN becomes None; order-2 arrays become lists)."""
        names = [f.name for f in fields(self)
                 if isinstance(getattr(self, f.name), np.ndarray)]
        scalars = {"kind": self.kind, "order": self.order, "n_params": self.n_params,
                   "duration_fitted": self.duration_fitted}
        return [dict(scalars, trial=i, **{k: _plain(getattr(self, k)[i]) for k in names})
                for i in range(len(self))]


def _plain(v: Any) -> Any:
    """numpy scalar or small array -> JSON-ready Python value."""
    if isinstance(v, np.ndarray):
        return [_plain(x) for x in v]
    v = v.item() if isinstance(v, np.generic) else v
    return None if isinstance(v, float) and not math.isfinite(v) else v


# --------------------------------------------------------------------------- jax core
def _unpack(cfg: _Config, theta: jax.Array, duration: jax.Array) -> tuple[jax.Array, jax.Array]:
    taus = jnp.exp(theta[: cfg.order])
    return taus, (jnp.exp(theta[cfg.order]) if cfg.fit_duration else duration)


def _design(cfg: _Config, t: jax.Array, taus: jax.Array, duration: jax.Array) -> jax.Array:
    """(n_points, order) unit responses; a step has no duration (the T -> inf limit)."""
    dur = duration if cfg.kind == "pulse" else None
    return jnp.stack([unit_response(cfg.kind, t, taus[k], dur) for k in range(cfg.order)], -1)


def _gains(basis: jax.Array, y: jax.Array, m: jax.Array) -> jax.Array:
    """Closed-form least-squares gains for a given basis (the variable projection).

    Written out for one and two modes: a LAPACK solve inside the solver loop would cost
    more compile time than the whole 2 x 2 algebra.
    """
    bm = basis * m[:, None]
    gram, rhs = bm.T @ bm, bm.T @ y
    if basis.shape[1] == 1:
        return rhs / gram[0]
    # The ridge only matters when the two modes coincide (singular gram); it splits the gain.
    a, b, d = gram[0, 0], gram[0, 1], gram[1, 1]
    ridge = 1e-12 * (a + d)
    a, d = a + ridge, d + ridge
    det = a * d - b * b
    return jnp.stack([d * rhs[0] - b * rhs[1], a * rhs[1] - b * rhs[0]]) / det


def _residual(cfg: _Config, theta: jax.Array, args: tuple) -> jax.Array:
    t, y, m, duration, scale = args
    taus, dur = _unpack(cfg, theta, duration)
    basis = _design(cfg, t, taus, dur)
    return (y - basis @ _gains(basis, y, m)) * m * scale


@functools.cache
def _solver_residual(cfg: _Config) -> Any:
    """The residual with a hand-set JVP: ``J @ dtheta`` with J (n_points, n_nonlinear).

    Plain autodiff would make the linearisation keep every (n_points,) intermediate of the
    model, and a vmapped while loop copies (selects) its whole carry on every step; with
    this rule the carry holds just J, which made a 1024-trial chunk ~3x faster per step and
    quicker to compile.
    """
    base = functools.partial(_residual, cfg)

    @jax.custom_jvp
    def residual(theta: jax.Array, args: tuple) -> jax.Array:
        return base(theta, args)

    @residual.defjvp
    def _jvp(primals: tuple, tangents: tuple) -> tuple[jax.Array, jax.Array]:
        theta, args = primals
        return base(theta, args), jax.jacfwd(base)(theta, args) @ tangents[0]

    return residual


def _first_index(cond: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Index of the first True, and whether there is one."""
    return jnp.argmax(cond), jnp.any(cond)


def _moving_sum(x: jax.Array, half: int = 2) -> jax.Array:
    """Sum over a centred window of 2 half + 1 points (shifted adds: cheaper to compile than
    a convolution)."""
    padded = jnp.pad(x, half)
    return sum(padded[k: k + x.shape[0]] for k in range(2 * half + 1))


def _start(cfg: _Config, t: jax.Array, y: jax.Array, m: jax.Array, duration: jax.Array,
           bounds: jax.Array) -> jax.Array:
    """Data-driven start (log tau [, log T]) of the first-order model of one trial."""
    valid = m > 0
    smooth = _moving_sum(y * m) / jnp.maximum(_moving_sum(m), 1.0)  # 5-bin masked mean
    t_last = jnp.max(jnp.where(valid, t, -jnp.inf))
    if cfg.kind == "ramp":
        # For t >> tau the ramp response is alpha (t - tau) / tau: its asymptote crosses the
        # time axis at t = tau. Fit a line to the second half of the region.
        w = m * (t >= 0.5 * t_last)
        sw = jnp.maximum(jnp.sum(w), 1.0)
        tm, ym = jnp.sum(w * t) / sw, jnp.sum(w * smooth) / sw
        slope = jnp.sum(w * (t - tm) * (smooth - ym)) / jnp.sum(w * (t - tm) ** 2)
        tau = tm - ym / slope
        tau = jnp.where(jnp.isfinite(tau) & (tau > 0), tau, 0.25 * t_last)
        dur = duration
    else:
        peak_i = jnp.argmax(jnp.where(valid, smooth, -jnp.inf))
        peak = smooth[peak_i]
        i_rise, has_rise = _first_index(valid & (smooth >= (1 - np.exp(-1)) * peak))
        t_rise = jnp.where(has_rise, t[i_rise], 0.25 * t_last)  # 63 % rise time
        # After T a pulse decays as exp(-(t - T)/tau) from wherever it got to, so the 37 %
        # decay time does not need the plateau reached; use it when the data show it.
        i_fall, has_fall = _first_index(valid & (t > t[peak_i]) & (smooth <= np.exp(-1) * peak))
        t_fall = t[i_fall]
        if cfg.kind == "step":
            tau, dur = t_rise, jnp.inf
        elif cfg.fit_duration:  # falls to 37 % one tau after T: T = t_fall - t_rise
            tau = t_rise
            dur = jnp.where(has_fall, t_fall - t_rise, t[peak_i])
        else:
            dur = duration
            tau = jnp.where(has_fall & (t_fall > dur), t_fall - dur, t_rise)
    tau = jnp.clip(tau, 2.0 * bounds[0], 0.5 * bounds[1])
    if cfg.fit_duration:
        dur = jnp.clip(dur, bounds[2], bounds[3])
        return jnp.log(jnp.stack([tau, dur]))
    return jnp.log(tau)[None]


def _widen(cfg: _Config, theta1: jax.Array) -> jax.Array:
    """Two-mode start from a one-mode start: modes at tau/2 and 2 tau, same T."""
    if cfg.order == 1:
        return theta1
    spread = jnp.array([-np.log(2.0), np.log(2.0)])
    return jnp.concatenate([theta1[:1] + spread, theta1[1:]])


def _fit_one(cfg: _Config, t: jax.Array, y: jax.Array, m: jax.Array, duration: jax.Array,
             theta_user: jax.Array, bounds: jax.Array) -> dict[str, jax.Array]:
    """Start, solve and assess one trial (vmapped over trials by the caller)."""
    n = jnp.sum(m)
    scale = 1.0 / jnp.sqrt(jnp.sum(m * y * y) / n)
    args = (t, y, m, duration, scale)
    theta_data = _widen(cfg, _start(cfg, t, y, m, duration, bounds))
    theta0 = jnp.where(jnp.isfinite(theta_user), theta_user, theta_data)
    sol = optx.least_squares(
        _solver_residual(cfg), optx.LevenbergMarquardt(rtol=cfg.rtol, atol=cfg.atol),
        theta0, args=args, max_steps=cfg.max_steps, throw=False)
    taus, dur = _unpack(cfg, sol.value, duration)
    if cfg.order == 2:  # the modes are interchangeable: report the fast one first
        taus = jnp.sort(taus)
    basis = _design(cfg, t, taus, dur)
    gains = _gains(basis, y, m)
    fit = basis @ gains
    resid = (y - fit) * m
    rss = resid @ resid

    # Standard errors from the full model in natural parameters (gains, taus, [T]).
    def model(p: jax.Array) -> jax.Array:
        d = p[2 * cfg.order] if cfg.fit_duration else duration
        return _design(cfg, t, p[cfg.order: 2 * cfg.order], d) @ p[: cfg.order]

    p_hat = jnp.concatenate([gains, taus] + ([dur[None]] if cfg.fit_duration else []))
    jac = jax.jacfwd(model)(p_hat) * m[:, None]
    col = jnp.sqrt(jnp.sum(jac * jac, axis=0))
    col = jnp.where(col > 0, col, 1.0)
    jtj = (jac / col).T @ (jac / col)  # column-scaled, so its condition number is meaningful
    jtj_inv = jnp.linalg.inv(jtj)
    # Variance inflation: 1 for orthogonal parameters, huge when they trade off.
    inflation = jnp.max(jnp.diag(jtj_inv))
    s2 = rss / (n - cfg.n_params)
    se = jnp.sqrt(s2 * jnp.diag(jtj_inv)) / col
    # Distance to a stationary point: the Gauss-Newton step in gains and taus (T excluded:
    # the model has a kink in T at every sample time, so a minimum in T can sit on a kink).
    k = 2 * cfg.order
    sub = jac[:, :k] / col[:k]
    gn_step = jnp.linalg.solve(sub.T @ sub, sub.T @ resid) / col[:k]

    fm, ym = jnp.sum(fit * m) / n, jnp.sum(y * m) / n
    pearson = (jnp.sum(m * (y - ym) * (fit - fm))
               / jnp.sqrt(jnp.sum(m * (y - ym) ** 2) * jnp.sum(m * (fit - fm) ** 2)))
    n_free = cfg.n_params + 1  # + the noise variance
    aic = n * jnp.log(rss / n) + 2 * n_free
    bic = n * jnp.log(rss / n) + n_free * jnp.log(n)

    start_cost = jnp.sum(_residual(cfg, theta_data, args) ** 2)
    end_cost = jnp.sum(_residual(cfg, sol.value, args) ** 2)
    in_bounds = jnp.all((taus >= bounds[0]) & (taus <= bounds[1]))
    if cfg.fit_duration:
        in_bounds &= (dur >= bounds[2]) & (dur <= bounds[3])
    stationary = jnp.all(jnp.abs(gn_step) <= _STATIONARY_SE * se[:k] + 10 * cfg.rtol * jnp.abs(p_hat[:k]))
    not_worse = end_cost <= start_cost * (1 + 1e-9) + 1e-300
    finite = jnp.all(jnp.isfinite(p_hat)) & jnp.isfinite(rss)

    code = jnp.select(
        [sol.result == optx.RESULTS.nonlinear_max_steps_reached,
         (sol.result == optx.RESULTS.nonfinite) | ~finite,
         sol.result != optx.RESULTS.successful,
         ~in_bounds,
         ~(jnp.all(jnp.isfinite(se)) & (inflation < _MAX_INFLATION)),
         ~(stationary & not_worse)],
        [_CODE[s] for s in (FitStatus.MAX_STEPS, FitStatus.NONFINITE, FitStatus.SOLVER_ERROR,
                            FitStatus.OUT_OF_RANGE, FitStatus.ILL_CONDITIONED,
                            FitStatus.NOT_AT_MINIMUM)],
        _CODE[FitStatus.CONVERGED])
    o = cfg.order
    return {
        "alpha": gains, "tau_s": taus, "duration_s": dur * jnp.ones(()),
        "alpha_se": se[:o], "tau_se_s": se[o: 2 * o],
        "duration_se_s": se[2 * o] if cfg.fit_duration else jnp.nan * jnp.ones(()),
        "rss": rss, "residual_std": jnp.sqrt(s2), "pearson_r": pearson, "aic": aic, "bic": bic,
        "code": code, "n_steps": sol.stats["num_steps"],
        "start_tau_s": jnp.exp(theta0[:o]),
        "start_duration_s": jnp.exp(theta0[o]) if cfg.fit_duration else jnp.nan * jnp.ones(()),
    }


@functools.cache
def _compiled(cfg: _Config) -> Any:
    return jax.jit(jax.vmap(functools.partial(_fit_one, cfg)))


# --------------------------------------------------------------------------- numpy shell
def _per_trial(name: str, value: ArrayLike | None, n_trials: int, width: int = 0) -> np.ndarray:
    """A scalar or per-trial option as (n_trials,) float64, or (n_trials, width) if width.

    With ``width`` a value of shape (n_trials,) fills every column when width is 1, and one
    of shape (width,) applies to every trial.
    """
    shape = (n_trials, width) if width else (n_trials,)
    if value is None:
        return np.full(shape, np.nan)
    arr = np.asarray(value, dtype=np.float64)
    if width == 1 and arr.shape == (n_trials,):
        arr = arr[:, None]
    try:
        return np.broadcast_to(arr, shape).copy()
    except ValueError:
        raise ValueError(f"`{name}` has shape {arr.shape}; expected a scalar or {shape} "
                         "(one value per trial).") from None


def _positive_log(name: str, values: np.ndarray) -> np.ndarray:
    """log of user starting values (NaN = not given), which must be positive seconds."""
    given = ~np.isnan(values)
    if np.any(given & ~(values > 0)) or np.any(given & ~np.isfinite(values)):
        raise ValueError(f"`{name}` (={values[given & ~(values > 0)][:3]}...) must be positive "
                         "finite seconds (NaN means: use the data-driven start).")
    return np.log(np.where(given, values, 1.0)) + np.where(given, 0.0, np.nan)


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
    t = np.broadcast_to(t, y.shape)
    m = np.ones(y.shape, bool) if mask is None else np.asarray(mask)
    if m.shape != y.shape or m.dtype != bool:
        raise ValueError(f"`mask` has shape {m.shape} and dtype {m.dtype}; expected bool "
                         f"{y.shape} like `y` (True where a point is real).")
    return t, y, m


def _fit(cfg: _Config, t_s: ArrayLike, y: ArrayLike, mask: ArrayLike | None, *,
         duration_s: ArrayLike | None, tau0_s: ArrayLike | None,
         duration0_s: ArrayLike | None, tau_bounds_s: tuple[float, float] | None,
         chunk_size: int, keep_failed: bool) -> FosFitResult:
    if cfg.kind not in KINDS:
        raise ValueError(f"`kind` (={cfg.kind!r}) must be one of {KINDS}.")
    if chunk_size < 1:
        raise ValueError(f"`chunk_size` (={chunk_size}) must be a positive number of trials.")
    t, y, m = _prepare(t_s, y, mask)
    n_trials, n_points = y.shape
    known_dur = _per_trial("duration_s", duration_s, n_trials)
    theta_user = _positive_log("tau0_s", _per_trial("tau0_s", tau0_s, n_trials, cfg.order))
    if cfg.fit_duration:
        theta_user = np.concatenate([theta_user, _positive_log(
            "duration0_s", _per_trial("duration0_s", duration0_s, n_trials, 1))], axis=1)

    # Per-trial input checks: a bad trial is flagged, the batch goes on.
    with np.errstate(invalid="ignore"):
        tv, yv = np.where(m, t, 0.0), np.where(m, y, 0.0)
        bad = ~np.all(np.isfinite(tv) & np.isfinite(yv), axis=1)
        bad |= m.sum(axis=1) < cfg.n_params + 2
        # valid times must be >= 0 (from the region start) and strictly increasing
        before = np.maximum.accumulate(np.where(m, tv, -np.inf), axis=1)
        bad |= np.any(tv < 0, axis=1) | np.any(m[:, 1:] & (tv[:, 1:] <= before[:, :-1]), axis=1)
        bad |= ~np.any(yv != 0, axis=1)
        if cfg.kind == "pulse" and not cfg.fit_duration:
            bad |= ~(np.isfinite(known_dur) & (known_dur > 0))

    # Substitute a clean, quickly converging problem for bad trials so they cannot hold up a
    # chunk (a vmapped loop runs until its slowest trial stops); their results are discarded.
    n_pad = -(-max(n_points, 1) // _POINT_BUCKET) * _POINT_BUCKET
    chunk = min(chunk_size, max(8, 1 << max(n_trials - 1, 0).bit_length()))
    n_rows = -(-max(n_trials, 1) // chunk) * chunk
    tt = np.zeros((n_rows, n_pad))
    yy = np.zeros((n_rows, n_pad))
    mm = np.zeros((n_rows, n_pad))
    tt[:n_trials, :n_points], yy[:n_trials, :n_points], mm[:n_trials, :n_points] = tv, yv, m
    dummy = np.ones(n_rows, bool)
    dummy[:n_trials] = bad
    grid = np.arange(n_pad, dtype=np.float64)
    tt[dummy], mm[dummy] = grid, 1.0
    yy[dummy] = 1000.0 * unit_response("pulse" if cfg.kind == "pulse" else cfg.kind,
                                       grid, n_pad / 8, n_pad / 2)
    dur_rows = np.full(n_rows, n_pad / 2)
    dur_rows[:n_trials] = np.where(bad, n_pad / 2, known_dur)
    theta_rows = np.full((n_rows, cfg.n_nonlinear), np.nan)
    theta_rows[:n_trials] = np.where(bad[:, None], np.nan, theta_user)

    # Bounds: tau between half a bin and five times the region; a fitted T strictly inside.
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

    fn = _compiled(cfg)
    with jax.enable_x64(True):
        outs = [fn(*(jnp.asarray(a[s: s + chunk]) for a in (tt, yy, mm, dur_rows, theta_rows,
                                                              bounds)))
                for s in range(0, n_rows, chunk)]  # dispatched asynchronously, gathered below
        out = {k: np.concatenate([np.asarray(o[k]) for o in outs])[:n_trials] for k in outs[0]}

    code = np.where(bad, _CODE[FitStatus.BAD_INPUT], out.pop("code"))
    status = np.array([s.value for s in _STATUS_BY_CODE])[code]
    for key in _FIT_FIELDS + ("start_tau_s", "start_duration_s"):
        v = out[key].astype(np.float64)
        if cfg.order == 1 and v.ndim == 2:
            v = v[:, 0]
        v[bad] = np.nan  # results of the substitute problem
        out[key] = v
    if cfg.kind != "pulse":
        out["duration_s"][:] = np.nan
    result = FosFitResult(kind=cfg.kind, order=cfg.order, duration_fitted=cfg.fit_duration,
                          n_points=m.sum(axis=1), n_params=cfg.n_params, status=status, **out)
    return result if keep_failed else result.drop_failed()


# --------------------------------------------------------------------------- public API
_OPTIONS_DOC = """
    Parameters
    ----------
    t_s:
        (n_points,) or (n_trials, n_points) float times in seconds from the region start.
    y:
        (n_trials, n_points) event counts per bin, padded for ragged trials.
    mask:
        (n_trials, n_points) bool, True where a point is real; None means all are.
    tau0_s:
        Starting tau in seconds, a scalar or one per trial; NaN or None: data-driven.
        For testing robustness; a fit that ends worse than the data-driven start would
        reach is flagged ``not_at_minimum``.
    tau_bounds_s:
        (low, high) seconds a converged tau must lie in; default per trial from half a
        bin to five times the region length (outside them the data cannot tell tau).
    max_steps, rtol, atol:
        Levenberg-Marquardt limits; tolerances act on log(tau) and on residuals scaled
        by the data's RMS.
    chunk_size:
        Trials per compiled, vmapped solve.
    keep_failed:
        Keep the last iterate of trials that did not converge instead of NaN.
"""


def _make_config(kind: str, order: int, fit_duration: bool, max_steps: int, rtol: float,
                 atol: float) -> _Config:
    if max_steps < 1:
        raise ValueError(f"`max_steps` (={max_steps}) must be at least 1.")
    if not (rtol > 0 and atol > 0):
        raise ValueError(f"`rtol` (={rtol}) and `atol` (={atol}) must be positive.")
    return _Config(kind, order, fit_duration, float(rtol), float(atol), int(max_steps))


def fit_pulse(
    t_s: ArrayLike, y: ArrayLike, mask: ArrayLike | None = None, *,
    duration_s: ArrayLike | None = None, tau0_s: ArrayLike | None = None,
    duration0_s: ArrayLike | None = None, tau_bounds_s: tuple[float, float] | None = None,
    max_steps: int = 64, rtol: float = 1e-4, atol: float = 1e-4, chunk_size: int = 1024,
    keep_failed: bool = False,
) -> FosFitResult:
    """Fit the pulse response of eq. 16 to press regions, all trials at once.

    ``duration_s`` is the known press length T in seconds (scalar or one per trial);
    None fits T as well (starting at the peak time, or at ``duration0_s``); a fitted T must
    lie between one bin and one bin before the region's end.
    """
    cfg = _make_config("pulse", 1, duration_s is None, max_steps, rtol, atol)
    return _fit(cfg, t_s, y, mask, duration_s=duration_s, tau0_s=tau0_s,
                duration0_s=duration0_s, tau_bounds_s=tau_bounds_s, chunk_size=chunk_size,
                keep_failed=keep_failed)


def fit_step(
    t_s: ArrayLike, y: ArrayLike, mask: ArrayLike | None = None, *,
    tau0_s: ArrayLike | None = None, tau_bounds_s: tuple[float, float] | None = None,
    max_steps: int = 64, rtol: float = 1e-4, atol: float = 1e-4, chunk_size: int = 1024,
    keep_failed: bool = False,
) -> FosFitResult:
    """Fit the step response ``alpha (1 - exp(-t/tau))`` (eq. 16 for T -> inf)."""
    cfg = _make_config("step", 1, False, max_steps, rtol, atol)
    return _fit(cfg, t_s, y, mask, duration_s=None, tau0_s=tau0_s, duration0_s=None,
                tau_bounds_s=tau_bounds_s, chunk_size=chunk_size, keep_failed=keep_failed)


def fit_ramp(
    t_s: ArrayLike, y: ArrayLike, mask: ArrayLike | None = None, *,
    tau0_s: ArrayLike | None = None, tau_bounds_s: tuple[float, float] | None = None,
    max_steps: int = 64, rtol: float = 1e-4, atol: float = 1e-4, chunk_size: int = 1024,
    keep_failed: bool = False,
) -> FosFitResult:
    """Fit the ramp response of eq. 17 to slip regions, all trials at once."""
    cfg = _make_config("ramp", 1, False, max_steps, rtol, atol)
    return _fit(cfg, t_s, y, mask, duration_s=None, tau0_s=tau0_s, duration0_s=None,
                tau_bounds_s=tau_bounds_s, chunk_size=chunk_size, keep_failed=keep_failed)


def fit_second_order(
    kind: Kind, t_s: ArrayLike, y: ArrayLike, mask: ArrayLike | None = None, *,
    duration_s: ArrayLike | None = None, tau0_s: ArrayLike | None = None,
    duration0_s: ArrayLike | None = None, tau_bounds_s: tuple[float, float] | None = None,
    max_steps: int = 64, rtol: float = 1e-4, atol: float = 1e-4, chunk_size: int = 1024,
    keep_failed: bool = False,
) -> FosFitResult:
    """Fit the two-mode (second-order) alternative of ``kind`` (see :mod:`.models`).

    ``tau0_s`` is (n_trials, 2), (2,) or None; by default the modes start at half and twice
    the data-driven first-order tau. For a pulse, ``duration_s=None`` fits T as well.
    """
    cfg = _make_config(kind, 2, kind == "pulse" and duration_s is None, max_steps, rtol, atol)
    return _fit(cfg, t_s, y, mask, duration_s=duration_s, tau0_s=tau0_s,
                duration0_s=duration0_s, tau_bounds_s=tau_bounds_s, chunk_size=chunk_size,
                keep_failed=keep_failed)


for _f in (fit_pulse, fit_step, fit_ramp, fit_second_order):
    _f.__doc__ = (_f.__doc__ or "") + _OPTIONS_DOC
