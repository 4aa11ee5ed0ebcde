"""Batched least-squares fits of the FOS press and slip models (paper 000, sec. 4.2, eqs. 16-17)
and of their second-order alternative.

Every trial of a file is fitted at once: the trials are padded to ``(n_trials, n_points)``
with a boolean mask for ragged lengths, cut into chunks of ``chunk_size`` trials, and each
chunk runs one jit-compiled, vmapped Levenberg-Marquardt (or Gauss-Newton) solve of
optimistix in float64. A vmapped solver loop runs every trial of a chunk for as many steps
as its slowest one, so the work is arranged for few and uniform step counts:

- Variable projection: the models are linear in the gain ``alpha`` (and, for the second
  order, in ``alpha * lead``), so for given time constants the gains are solved in closed
  form and only ``log(tau)`` (or the two log-coefficients of the second-order
  denominator), plus ``log(T)`` when the pulse duration is fitted, is iterated.
- Data-driven starts, no hand-tuned guesses: ``tau`` from the 63 % rise time or, for a
  pulse, the 37 % decay time after T (which does not need the plateau reached); ``T`` from
  where the fall crosses 37 %, minus ``tau``; the ramp's ``tau`` from the time-axis
  crossing of its asymptote.
- Residuals are scaled by the data's RMS so that the tolerances are scale free, and the
  residual carries a hand-set JVP so that the solver's loop state stays small.

Standard errors come from the Jacobian of the model in its natural parameters (alpha,
[lead in s,] tau in s, [zeta,] [T in s]) at the solution: ``s^2 (J^T J)^-1`` with
``s^2 = RSS / (n - p)``. A fit is ``converged`` only when the solver says so *and* the
solution passes checks that the solver's stopping rule does not make: finite values and
standard errors, time constants inside their bounds, identifiable parameters, a
Gauss-Newton step from the solution below a tenth of a standard error (a minimum, not a
stall) and a residual no larger than at the data-driven start. Anything else is a
per-trial :class:`FitStatus`; one bad trial never raises for the batch, and by default a
trial that did not converge has NaN parameters.

float64: the fits run inside ``jax.enable_x64(True)``, a context manager, so importing or
calling this module changes no global JAX setting; results are numpy float64 arrays.
"""

from __future__ import annotations

import enum
import functools
import math
from dataclasses import dataclass, fields, replace
from typing import Any, Literal

import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from numpy.typing import ArrayLike

from .models import KINDS, Kind, second_order_basis, unit_response


class FitStatus(enum.StrEnum):
    """Outcome of one trial's fit; only ``CONVERGED`` carries parameters by default."""

    CONVERGED = "converged"
    MAX_STEPS = "max_steps"
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
#: Pad n_points to a multiple of this, so files of similar length share one compilation.
_POINT_BUCKET = 32
#: A fit is at a minimum when a Gauss-Newton step from it is below this many SEs.
_STATIONARY_SE = 0.1
#: Largest variance inflation (diagonal of the inverse of the column-scaled J^T J) of
#: parameters that still count as separately identifiable.
_MAX_INFLATION = 1e8


@dataclass(frozen=True)
class _Config:
    """Static part of a batched fit: one compiled solver per distinct config and shape."""

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


# --------------------------------------------------------------------------- jax core
def _unpack(cfg: _Config, theta: jax.Array, duration: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Solver coordinates -> (tau [, zeta] in natural units, T).

    Order 1 iterates log(tau). Order 2 iterates log(2 zeta tau) and log(tau^2), the
    coefficients of the denominator ``tau^2 s^2 + 2 zeta tau s + 1`` (the sum and the
    product of the time constants when the poles are real).
    """
    if cfg.order == 1:
        shape = jnp.exp(theta[:1])
    else:
        tau = jnp.exp(0.5 * theta[1])
        shape = jnp.stack([tau, jnp.exp(theta[0]) / (2.0 * tau)])
    return shape, (jnp.exp(theta[cfg.order]) if cfg.fit_duration else duration)


def _basis(cfg: _Config, t: jax.Array, shape: jax.Array, duration: jax.Array) -> jax.Array:
    """(n_points, order) responses the gains multiply; a step has no duration (T -> inf)."""
    dur = duration if cfg.kind == "pulse" else None
    if cfg.order == 1:
        return unit_response(cfg.kind, t, shape[0], dur)[:, None]
    return jnp.stack(second_order_basis(cfg.kind, t, shape[0], shape[1], dur), axis=1)


def _gains(basis: jax.Array, y: jax.Array, m: jax.Array) -> jax.Array:
    """Closed-form least-squares gains for a given basis (the variable projection).

    Written out for one and two columns: a LAPACK solve inside the solver loop would cost
    more compile time than the whole 2 x 2 algebra.
    """
    bm = basis * m[:, None]
    gram, rhs = bm.T @ bm, bm.T @ y
    if basis.shape[1] == 1:
        return rhs / gram[0]
    # The ridge only matters where the columns are parallel (the gram is singular).
    a, b, d = gram[0, 0], gram[0, 1], gram[1, 1]
    ridge = 1e-12 * (a + d)
    a, d = a + ridge, d + ridge
    return jnp.stack([d * rhs[0] - b * rhs[1], a * rhs[1] - b * rhs[0]]) / (a * d - b * b)


def _residual(cfg: _Config, theta: jax.Array, args: tuple) -> jax.Array:
    t, y, m, duration, scale = args
    basis = _basis(cfg, t, *_unpack(cfg, theta, duration))
    return (y - basis @ _gains(basis, y, m)) * m * scale


@functools.cache
def _solver_residual(cfg: _Config) -> Any:
    """The residual with a hand-set JVP, ``J @ dtheta`` with J (n_points, n_nonlinear).

    Plain autodiff would make the linearisation keep every (n_points,) intermediate of the
    model, and a vmapped while loop copies (selects) its whole carry on every step; with
    this rule the carry holds just J, which made a 1024-trial chunk about 3x faster per step
    and quicker to compile.
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


def _moving_sum(x: jax.Array, half: int = 2) -> jax.Array:
    """Sum over a centred window of 2 half + 1 points (shifted adds compile faster than a
    convolution)."""
    padded = jnp.pad(x, half)
    return sum(padded[k: k + x.shape[0]] for k in range(2 * half + 1))


def _first_index(cond: jax.Array) -> tuple[jax.Array, jax.Array]:
    """Index of the first True, and whether there is one."""
    return jnp.argmax(cond), jnp.any(cond)


def _start(cfg: _Config, t: jax.Array, y: jax.Array, m: jax.Array, duration: jax.Array,
           bounds: jax.Array) -> jax.Array:
    """Data-driven start in solver coordinates for one trial."""
    valid = m > 0
    smooth = _moving_sum(y * m) / jnp.maximum(_moving_sum(m), 1.0)  # 5-bin masked mean
    t_last = jnp.max(jnp.where(valid, t, -jnp.inf))
    dur = duration
    if cfg.kind == "ramp":
        # For t >> tau the ramp response is alpha (t - tau) / tau: its asymptote crosses the
        # time axis at t = tau. Fit a line to the second half of the region.
        w = m * (t >= 0.5 * t_last)
        sw = jnp.maximum(jnp.sum(w), 1.0)
        tm, ym = jnp.sum(w * t) / sw, jnp.sum(w * smooth) / sw
        slope = jnp.sum(w * (t - tm) * (smooth - ym)) / jnp.sum(w * (t - tm) ** 2)
        tau = tm - ym / slope
        tau = jnp.where(jnp.isfinite(tau) & (tau > 0), tau, 0.25 * t_last)
    else:
        peak_i = jnp.argmax(jnp.where(valid, smooth, -jnp.inf))
        peak = smooth[peak_i]
        i_rise, has_rise = _first_index(valid & (smooth >= (1 - np.exp(-1)) * peak))
        t_rise = jnp.where(has_rise, t[i_rise], 0.25 * t_last)  # 63 % rise time
        # After T a pulse decays as exp(-(t - T)/tau) from wherever it got to, so the 37 %
        # decay time does not need the plateau reached: use it when the data show it.
        i_fall, has_fall = _first_index(valid & (t > t[peak_i]) & (smooth <= np.exp(-1) * peak))
        t_fall = t[i_fall]
        if cfg.kind == "step":
            tau = t_rise
        elif cfg.fit_duration:  # the fall reaches 37 % one tau after T
            tau = t_rise
            dur = jnp.where(has_fall, t_fall - t_rise, t[peak_i])
        else:
            tau = jnp.where(has_fall & (t_fall > dur), t_fall - dur, t_rise)
    tau = jnp.clip(tau, 2.0 * bounds[0], 0.5 * bounds[1])
    # Order 2 starts with real poles at tau and tau/4, so that the closed-form gains can
    # cancel the fast one with the zero: the start is then at least as good as the FOS.
    shape = ([jnp.log(tau)] if cfg.order == 1
             else [jnp.log(1.25 * tau), 2.0 * jnp.log(0.5 * tau)])
    if cfg.fit_duration:
        shape.append(jnp.log(jnp.clip(dur, bounds[2], bounds[3])))
    return jnp.stack(shape)


def _polish_shape(cfg: _Config, theta: jax.Array, args: tuple, n_iter: int = 3) -> jax.Array:
    """A few Gauss-Newton steps in the shape coordinates with T held where the solver left it.

    The pulse model has a kink in T at every sample time. Where the fitted T sits on one,
    Levenberg-Marquardt's trust region collapses for all coordinates at once and can stop
    with tau short of its optimum for that T; these steps finish tau (kept only if they
    lower the residual).
    """
    n_shape = cfg.n_nonlinear - 1
    fixed = replace(cfg, fit_duration=False)

    def resid(shape_coords: jax.Array) -> jax.Array:
        t, y, m, _, scale = args
        return _residual(fixed, shape_coords, (t, y, m, jnp.exp(theta[n_shape]), scale))

    coords = theta[:n_shape]
    for _ in range(n_iter):
        r, jac = resid(coords), jax.jacfwd(resid)(coords)
        coords = coords - _solve_small(jac.T @ jac, jac.T @ r)
    better = jnp.sum(resid(coords) ** 2) < jnp.sum(resid(theta[:n_shape]) ** 2)
    polished = jnp.concatenate([coords, theta[n_shape:]])
    return jnp.where(better & jnp.all(jnp.isfinite(coords)), polished, theta)


def _solve_small(a: jax.Array, b: jax.Array) -> jax.Array:
    """``a^-1 b`` for 1 x 1 and 2 x 2 ``a``, written out (no LAPACK call to compile)."""
    if a.shape[0] == 1:
        return b / a[0, 0]
    det = a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]
    return jnp.stack([a[1, 1] * b[0] - a[0, 1] * b[1], a[0, 0] * b[1] - a[1, 0] * b[0]]) / det


def _in_bounds(cfg: _Config, shape: jax.Array, lead: jax.Array, dur: jax.Array,
               bounds: jax.Array) -> jax.Array:
    lo, hi = bounds[0], bounds[1]
    if cfg.order == 1:
        ok = (shape[0] >= lo) & (shape[0] <= hi)
    else:  # fast time constant ~tau/(2 zeta), sum 2 zeta tau, envelope decay tau/zeta, zero
        tau, zeta = shape[0], shape[1]
        ok = ((tau / (2 * zeta) >= lo) & (2 * zeta * tau <= hi) & (tau / zeta <= hi)
              & (jnp.abs(lead) <= hi))
    if cfg.fit_duration:
        ok &= (dur >= bounds[2]) & (dur <= bounds[3])
    return ok


def _fit_one(cfg: _Config, t: jax.Array, y: jax.Array, m: jax.Array, duration: jax.Array,
             theta_user: jax.Array, bounds: jax.Array) -> dict[str, jax.Array]:
    """Start, solve and assess one trial (vmapped over trials by the caller)."""
    n = jnp.sum(m)
    args = (t, y, m, duration, 1.0 / jnp.sqrt(jnp.sum(m * y * y) / n))
    theta_data = _start(cfg, t, y, m, duration, bounds)
    theta0 = jnp.where(jnp.isfinite(theta_user), theta_user, theta_data)
    solver = (optx.LevenbergMarquardt if cfg.solver == "levenberg_marquardt"
              else optx.GaussNewton)(rtol=cfg.rtol, atol=cfg.atol)
    sol = optx.least_squares(_solver_residual(cfg), solver, theta0, args=args,
                             max_steps=cfg.max_steps, throw=False)
    theta = _polish_shape(cfg, sol.value, args) if cfg.fit_duration else sol.value
    shape, dur = _unpack(cfg, theta, duration)
    basis = _basis(cfg, t, shape, dur)
    gains = _gains(basis, y, m)
    fit = basis @ gains
    resid = (y - fit) * m
    rss = resid @ resid
    alpha = gains[0]
    lead = gains[1] / gains[0] if cfg.order == 2 else jnp.zeros(())

    # Standard errors from the model in natural parameters: alpha [, lead], tau [, zeta] [, T].
    k = 2 * cfg.order  # parameters without T

    def model(p: jax.Array) -> jax.Array:
        b = _basis(cfg, t, p[cfg.order: k], p[k] if cfg.fit_duration else duration)
        return p[0] * (b[:, 0] + (p[1] * b[:, 1] if cfg.order == 2 else 0.0))

    natural = [alpha[None]] + ([lead[None]] if cfg.order == 2 else []) + [shape]
    p_hat = jnp.concatenate(natural + ([dur[None]] if cfg.fit_duration else []))
    jac = jax.jacfwd(model)(p_hat) * m[:, None]
    col = jnp.sqrt(jnp.sum(jac * jac, axis=0))
    col = jnp.where(col > 0, col, 1.0)
    scaled = jac / col  # column-scaled: its inverse Gram diagonal is the variance inflation
    gram_inv = jnp.linalg.inv(scaled.T @ scaled)
    s2 = rss / (n - cfg.n_params)
    se = jnp.sqrt(s2 * jnp.diag(gram_inv)) / col
    # Distance to a minimum: the Gauss-Newton step in all parameters but T (the pulse has a
    # kink in T at every sample time, so a minimum in T may sit on a kink).
    sub = scaled[:, :k]
    gn_step = jnp.linalg.solve(sub.T @ sub, sub.T @ resid) / col[:k]
    stationary = jnp.all(jnp.abs(gn_step)
                         <= _STATIONARY_SE * se[:k] + 10 * cfg.rtol * jnp.abs(p_hat[:k]))
    start_cost = jnp.sum(_residual(cfg, theta_data, args) ** 2)
    end_cost = jnp.sum(_residual(cfg, theta, args) ** 2)
    not_worse = end_cost <= start_cost * (1 + 1e-9)
    identifiable = jnp.all(jnp.isfinite(se)) & (jnp.max(jnp.diag(gram_inv)) < _MAX_INFLATION)
    code = jnp.select(
        [sol.result == optx.RESULTS.nonlinear_max_steps_reached,
         (sol.result == optx.RESULTS.nonfinite) | ~jnp.all(jnp.isfinite(p_hat)),
         sol.result != optx.RESULTS.successful,
         ~_in_bounds(cfg, shape, lead, dur, bounds),
         ~identifiable,
         ~(stationary & not_worse)],
        [_CODE[s] for s in (FitStatus.MAX_STEPS, FitStatus.NONFINITE, FitStatus.SOLVER_ERROR,
                            FitStatus.OUT_OF_RANGE, FitStatus.ILL_CONDITIONED,
                            FitStatus.NOT_AT_MINIMUM)],
        _CODE[FitStatus.CONVERGED])

    fm, ym = jnp.sum(fit * m) / n, jnp.sum(y * m) / n
    pearson = (jnp.sum(m * (y - ym) * (fit - fm))
               / jnp.sqrt(jnp.sum(m * (y - ym) ** 2) * jnp.sum(m * (fit - fm) ** 2)))
    n_free = cfg.n_params + 1  # + the noise variance
    nan = jnp.full((), jnp.nan)
    start_shape, start_dur = _unpack(cfg, theta0, duration)
    return {
        "alpha": alpha, "tau_s": shape[0], "zeta": shape[1] if cfg.order == 2 else nan,
        "lead_s": lead if cfg.order == 2 else nan, "duration_s": dur,
        "alpha_se": se[0], "tau_se_s": se[cfg.order],
        "zeta_se": se[3] if cfg.order == 2 else nan, "lead_se_s": se[1] if cfg.order == 2 else nan,
        "duration_se_s": se[k] if cfg.fit_duration else nan,
        "rss": rss, "residual_std": jnp.sqrt(s2), "pearson_r": pearson,
        "aic": n * jnp.log(rss / n) + 2 * n_free, "bic": n * jnp.log(rss / n) + n_free * jnp.log(n),
        "code": code, "n_steps": sol.stats["num_steps"],
        "start_tau_s": start_shape[0], "start_duration_s": start_dur if cfg.fit_duration else nan,
    }


@functools.cache
def _compiled(cfg: _Config) -> Any:
    return jax.jit(jax.vmap(functools.partial(_fit_one, cfg)))


# --------------------------------------------------------------------------- numpy shell
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


def _fit(cfg: _Config, t_s: ArrayLike, y: ArrayLike, mask: ArrayLike | None, *,
         duration_s: ArrayLike | None, tau0_s: ArrayLike | None, zeta0: ArrayLike | None,
         duration0_s: ArrayLike | None, tau_bounds_s: tuple[float, float] | None,
         chunk_size: int, keep_failed: bool) -> FosFitResult:
    t, y, m = _prepare(t_s, y, mask)
    n_trials, n_points = y.shape
    known_dur = _per_trial("duration_s", duration_s, n_trials)
    tv, yv = np.where(m, t, 0.0), np.where(m, y, 0.0)
    bad = _bad_trials(cfg, tv, yv, m, known_dur)

    # Starting values in solver coordinates (see `_unpack`); NaN: data-driven.
    tau0 = _user_start("tau0_s", tau0_s, n_trials)
    start = [np.log(tau0)]
    if cfg.order == 2:
        zeta = _user_start("zeta0", zeta0, n_trials)
        start = [np.log(2 * zeta * tau0), 2 * np.log(tau0)]
    if cfg.fit_duration:
        start.append(np.log(_user_start("duration0_s", duration0_s, n_trials)))
    theta_user = np.stack(start, axis=1)

    # Pad to whole chunks of a bucketed length. Bad trials get a clean, quickly converging
    # substitute problem so that they cannot hold up a chunk (a vmapped loop runs until its
    # slowest trial stops); their results are discarded.
    n_pad = -(-max(n_points, 1) // _POINT_BUCKET) * _POINT_BUCKET
    chunk = min(chunk_size, max(8, 1 << max(n_trials - 1, 0).bit_length()))
    n_rows = -(-max(n_trials, 1) // chunk) * chunk
    tt, yy, mm = (np.zeros((n_rows, n_pad)) for _ in range(3))
    tt[:n_trials, :n_points], yy[:n_trials, :n_points], mm[:n_trials, :n_points] = tv, yv, m
    dummy = np.ones(n_rows, bool)
    dummy[:n_trials] = bad
    grid = np.arange(n_pad, dtype=np.float64)
    tt[dummy], mm[dummy] = grid, 1.0
    yy[dummy] = 1000.0 * unit_response(cfg.kind, grid, n_pad / 8, n_pad / 2)
    dur_rows = np.full(n_rows, n_pad / 2)
    dur_rows[:n_trials] = np.where(bad, n_pad / 2, known_dur)
    theta_rows = np.full((n_rows, cfg.n_nonlinear), np.nan)
    theta_rows[:n_trials] = np.where(bad[:, None], np.nan, theta_user)

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

    fn = _compiled(cfg)
    with jax.enable_x64(True):
        # All chunks are dispatched before any result is read, so they queue back to back.
        outs = [fn(*(jnp.asarray(a[s: s + chunk])
                     for a in (tt, yy, mm, dur_rows, theta_rows, bounds)))
                for s in range(0, n_rows, chunk)]
        out = {k: np.concatenate([np.asarray(o[k]) for o in outs])[:n_trials] for k in outs[0]}

    code = np.where(bad, _CODE[FitStatus.BAD_INPUT], out.pop("code"))
    for key in _FIT_FIELDS + ("start_tau_s", "start_duration_s"):
        out[key] = out[key].astype(np.float64)
        out[key][bad] = np.nan  # results of the substitute problem
    if cfg.kind != "pulse":
        out["duration_s"][:] = np.nan
    result = FosFitResult(
        kind=cfg.kind, order=cfg.order, duration_fitted=cfg.fit_duration,
        n_params=cfg.n_params, n_points=m.sum(axis=1),
        tau_min_s=np.where(bad, np.nan, bounds[:n_trials, 0]),
        tau_max_s=np.where(bad, np.nan, bounds[:n_trials, 1]),
        status=np.array([s.value for s in _STATUS_BY_CODE])[code], **out)
    return result if keep_failed else result.drop_failed()


# --------------------------------------------------------------------------- public API
Solver = Literal["levenberg_marquardt", "gauss_newton"]


@dataclass(frozen=True)
class FitOptions:
    """Solver settings shared by every fit; checked when constructed.

    ``solver``: optimistix ``LevenbergMarquardt`` (default: converges from starts 100x off)
    or ``GaussNewton`` (about half the compile and run time, but from starts that far off
    it diverges; those trials are flagged, not kept). ``max_steps``, ``rtol``, ``atol``:
    solver limits, the tolerances acting on log(tau) and on residuals scaled by the data's
    RMS. ``chunk_size``: trials per compiled, vmapped solve (a chunk runs as many steps as
    its slowest trial).
    """

    solver: Solver = "levenberg_marquardt"
    max_steps: int = 64
    rtol: float = 1e-4
    atol: float = 1e-4
    chunk_size: int = 1024

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
