"""The compiled part of the FOS fits: one optimistix program that iterates every model.

:mod:`tactile_cli.fos.fit` does everything around the solve in numpy (inputs, data-driven
starts, the polish of a fitted T, standard errors and checks); this module holds the one
thing that is compiled: a vmapped optimistix Levenberg-Marquardt (or Gauss-Newton) solve of
the variable-projection residual, float64, for a chunk of ``(n_rows, n_points)`` trials.

One program for all models. The kind (pulse, its step limit T = inf, or ramp), the order
(the FOS of eqs. 16-17 or the second-order alternative) and whether T is iterated are
run-time flags, not compile-time constants: the gains are solved in closed form, so at most
three nonlinear coordinates are iterated, ``(c0, c1, log T)`` (see :func:`unpack`), and a
coordinate a model does not use is held where it starts. Its size is what XLA's compile
time scales with, so each model appears once in it: the first order with its Jacobian
written out, the second order evaluated at four points in one batch (forward differences),
and the linear algebra written out (:mod:`tactile_cli.fos.small_solve`, no LAPACK call, so
that :mod:`tactile_cli.fos.compile_cache` can serialise the program).

optimistix is imported only when a program is traced, so a process that loads a serialised
program does not pay its import.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp

from .models import _damped_pair

#: Solver outcome codes returned per trial.
SUCCESS, MAX_STEPS, NONFINITE, FAILED = 0, 1, 2, 3
#: Iterated coordinates: two shape coordinates and log T.
N_THETA = 3
#: Forward-difference step of the second-order Jacobian, in log units.
_FD_STEP = 1e-7


@dataclass(frozen=True)
class SolverSpec:
    """What a compiled program is specialised on, with the chunk shape: the solver and its
    step limit. Every model runs through the same program, and the stopping tolerances are
    run-time inputs of it too (a new ``rtol``/``atol`` compiles nothing)."""

    solver: str  #: "levenberg_marquardt" or "gauss_newton"
    max_steps: int

    def key(self) -> str:
        """A file-name-safe text naming this spec."""
        return f"{self.solver}-s{self.max_steps}"


class Flags(NamedTuple):
    """The model, as run-time switches of the program: unbatched bool scalars, so that a
    solve runs only the branches it needs."""

    ramp: Any  #: eq. 17 instead of eq. 16 (a step is a pulse with T = inf)
    second: Any  #: the second-order alternative instead of the FOS
    fit_duration: Any  #: T is iterated (else it is the ``duration`` input)


def unpack(theta: Any, duration: Any, second: Any, fit_duration: Any, xp: Any = jnp
           ) -> tuple[Any, Any, Any]:
    """Solver coordinates ``(..., 3)`` -> ``(tau in s, zeta, T in s)``, numpy or jax.

    First order iterates ``c0 = log(tau)`` (zeta is 1, unused). Second order iterates
    ``c0 = log(2 zeta tau)`` and ``c1 = log(tau^2)``, the coefficients of the denominator
    ``tau^2 s^2 + 2 zeta tau s + 1`` (the sum and the product of the time constants when
    the poles are real). ``log T`` when T is fitted, else T is ``duration``.
    """
    c0, c1, c2 = theta[..., 0], theta[..., 1], theta[..., 2]
    tau2 = xp.exp(0.5 * c1)
    tau = xp.where(second, tau2, xp.exp(c0))
    zeta = xp.where(second, xp.exp(c0) / (2.0 * tau2), 1.0)
    return tau, zeta, xp.where(fit_duration, xp.exp(c2), duration)


def _second_basis(t: jax.Array, tau: jax.Array, zeta: jax.Array, dur: jax.Array,
                  ramp: jax.Array) -> jax.Array:
    """(n, 2): :func:`tactile_cli.fos.models.second_order_basis` of the pulse (a step for
    T = inf) or the ramp, from one evaluation of the damped pole pair at the on and off
    times of the pulse."""
    n = t.shape[0]
    cosh_part, sinh_part, a = _damped_pair(jnp, jnp.concatenate([t, jnp.maximum(t - dur, 0.0)]),
                                           tau, zeta)
    step = 1.0 - cosh_part - a * sinh_part
    impulse = sinh_part / (tau * tau)
    lag = 2.0 * zeta * tau
    tail = tau * tau * (2.0 * a * cosh_part[:n] + (2.0 * a * a - 1.0 / (tau * tau))
                        * sinh_part[:n])
    b = jnp.where(ramp, (t - lag + tail) / lag, step[:n] - step[n:])
    rate = jnp.where(ramp, step[:n] / lag, impulse[:n] - impulse[n:])
    return jnp.stack([b, rate], axis=1)


def gains(b: Any, y: Any, m: Any, xp: Any = jnp) -> Any:
    """Closed-form least-squares gains ``(..., 2)`` of a basis ``(..., n, 2)`` for data
    ``y`` and mask ``m`` ``(..., n)``: the variable projection, numpy or jax.

    Written out for two columns (no LAPACK call inside the solver loop). The ridge only
    matters where the columns are parallel or the second is zero (first order: its gain is
    then 0).
    """
    bm = b * m[..., None]
    a = xp.sum(bm[..., 0] ** 2, axis=-1)
    c = xp.sum(bm[..., 0] * bm[..., 1], axis=-1)
    d = xp.sum(bm[..., 1] ** 2, axis=-1)
    r0, r1 = xp.sum(bm[..., 0] * y, axis=-1), xp.sum(bm[..., 1] * y, axis=-1)
    ridge = 1e-12 * (a + d)
    a, d = a + ridge, d + ridge
    det = a * d - c * c
    return xp.stack([(d * r0 - c * r1) / det, (a * r1 - c * r0) / det], axis=-1)


def _second_residual(theta: jax.Array, args: tuple) -> jax.Array:
    """(n_points,) projected residual of the second-order model, scaled, 0 off the mask."""
    t, y, m, duration, scale, _, flags = args
    tau, zeta, dur = unpack(theta, duration, True, flags.fit_duration)
    b = _second_basis(t, tau, zeta, dur, flags.ramp)
    return (y - b @ gains(b, y, m)) * m * scale


def _second_value_and_jacobian(theta: jax.Array, args: tuple) -> tuple[jax.Array, jax.Array]:
    """Residual (n,) and Jacobian rows (3, n) of the second order by forward differences
    (step ``_FD_STEP`` in the log coordinates; relative error ~1e-7, far below what moves
    a step): the residual at four points in one batched evaluation. Forward-mode autodiff
    made the program compile 1.4x slower; central differences took 1.7x the time per step.
    """
    points = jnp.concatenate([theta[None], theta + _FD_STEP * jnp.eye(N_THETA,
                                                                       dtype=theta.dtype)])
    r = jax.vmap(lambda th: _second_residual(th, args))(points)
    return r[0], (r[1:] - r[0]) / _FD_STEP


def first_order_terms(t: Any, tau: Any, dur: Any, ramp: Any, xp: Any = jnp
                      ) -> tuple[Any, Any, Any]:
    """The unit FOS response ``b`` and its partial derivatives in tau and T, numpy or jax.

    ``t`` (..., n) seconds, ``tau`` and ``dur`` (...,) seconds per trial (T = inf: a step),
    ``ramp`` a bool (eq. 17) or, for the pulse, False (eq. 16 in the forms of
    :func:`tactile_cli.fos.models.unit_response`). Returns three (..., n) arrays; the
    derivative in T is 0 for the ramp and after a step. With numpy and a Python bool only
    the model asked for is evaluated.
    """
    tau, dur = tau[..., None], dur[..., None]
    out = []
    if not (isinstance(ramp, bool) and ramp):
        # pulse: (1 - exp(-min(t, T)/tau)) exp(-max(t - T, 0)/tau)
        on = xp.minimum(t, dur)
        off = xp.maximum(t - dur, 0.0)
        rise = -xp.expm1(-on / tau)
        decay = xp.exp(-off / tau)
        out.append((rise * decay, decay * (rise * off - (1.0 - rise) * on) / (tau * tau),
                    xp.where(t > dur, decay / tau, 0.0)))
    if not (isinstance(ramp, bool) and not ramp):  # ramp: t/tau - 1 + exp(-t/tau)
        x = t / tau
        e = xp.expm1(-x)
        out.append((x + e, x * e / tau, xp.zeros_like(x)))
    if len(out) == 1:
        return out[0]
    return tuple(xp.where(ramp, r, p) for p, r in zip(out[0], out[1], strict=True))


def _first_value_and_jacobian(theta: jax.Array, args: tuple) -> tuple[jax.Array, jax.Array]:
    """Residual (n,) and Jacobian rows (3, n) of the FOS, derivatives written out.

    The projected fit is ``g b`` with ``g = <b, y> / <b, b>`` over the mask, and its
    derivative takes ``g``'s along (the exact variable-projection Jacobian), in log tau and
    log T. Written out, the first order costs about one model evaluation per step, and
    compiles to a fraction of the autodiff code.
    """
    t, y, m, duration, scale, _, flags = args
    tau = jnp.exp(theta[0])
    dur = jnp.where(flags.fit_duration, jnp.exp(theta[2]), duration)
    b, b_tau, b_dur = jax.lax.cond(
        flags.ramp, lambda *a: first_order_terms(*a, ramp=True),
        lambda *a: first_order_terms(*a, ramp=False), t, tau, dur)
    bm, w = b * m, m * scale
    s_bb = jnp.sum(bm * b)
    g = jnp.sum(bm * y) / s_bb

    def row(db: jax.Array) -> jax.Array:  # d(residual)/d(coordinate)
        dg = (jnp.sum(m * y * db) - 2.0 * g * jnp.sum(bm * db)) / s_bb
        return -(b * dg + g * db) * w

    dur_row = jnp.where(flags.fit_duration, row(jnp.where(flags.fit_duration, dur, 0.0) * b_dur),
                        0.0)
    return (y - g * b) * w, jnp.stack([row(tau * b_tau), jnp.zeros_like(t), dur_row])


def _residual_base(theta: jax.Array, args: tuple) -> tuple[jax.Array, jax.Array]:
    """Residual (n_points + 3,) and its Jacobian as rows (3, n_points + 3): the projected
    residual
    scaled by the data's RMS (0 off the mask), then ``theta - theta0`` for the coordinates
    the model does not use. Those stay zero and decoupled from the rest, so no step moves
    them, while the Jacobian keeps full rank (undamped Gauss-Newton needs that)."""
    theta0, flags = args[5], args[6]
    value, jac = jax.lax.cond(flags.second, _second_value_and_jacobian,
                              _first_value_and_jacobian, theta, args)
    frozen = jnp.stack([jnp.zeros(()), 1.0 - flags.second, 1.0 - flags.fit_duration]
                       ).astype(theta.dtype)
    return (jnp.concatenate([value, frozen * (theta - theta0)]),
            jnp.concatenate([jac, jnp.diag(frozen)], axis=1))


@jax.custom_jvp
def _residual(theta: jax.Array, args: tuple) -> jax.Array:
    """The residual of :func:`_residual_base` with its Jacobian as the JVP rule.

    Plain autodiff would make the linearisation keep every (n_points,) intermediate of the
    model, and a vmapped while loop copies (selects) its whole carry on every step; with
    this rule the carry holds just J.
    """
    return _residual_base(theta, args)[0]


@_residual.defjvp
def _residual_jvp(primals: tuple, tangents: tuple) -> tuple[jax.Array, jax.Array]:
    value, rows = _residual_base(*primals)
    # J @ dtheta as a sum of the rows: under vmap a matrix product of these thin matrices
    # becomes a batch of tiny products, several times slower on the CPU.
    return value, sum(rows[k] * tangents[0][k] for k in range(N_THETA))


def _solve_one(spec: SolverSpec, t: jax.Array, y: jax.Array, m: jax.Array,
               duration: jax.Array, theta0: jax.Array, flags: Flags, rtol: jax.Array,
               atol: jax.Array) -> tuple[jax.Array, jax.Array, jax.Array]:
    """Solve one trial from ``theta0`` (3,): the solution, an outcome code (:data:`SUCCESS`,
    :data:`MAX_STEPS`, :data:`NONFINITE`, :data:`FAILED`) and the steps taken. ``rtol``
    and ``atol`` are traced scalars: optimistix's Cauchy test only computes with them."""
    import optimistix as optx

    from .small_solve import SmallLeastSquares

    scale = 1.0 / jnp.sqrt(jnp.sum(m * y * y) / jnp.sum(m))
    args = (t, y, m, duration, scale, theta0, flags)
    solver = (optx.LevenbergMarquardt if spec.solver == "levenberg_marquardt"
              else optx.GaussNewton)(rtol=rtol, atol=atol,
                                     linear_solver=SmallLeastSquares())
    sol = optx.least_squares(_residual, solver, theta0, args=args, max_steps=spec.max_steps,
                             throw=False)
    code = jnp.select([sol.result == optx.RESULTS.nonlinear_max_steps_reached,
                       sol.result == optx.RESULTS.nonfinite,
                       sol.result != optx.RESULTS.successful], [MAX_STEPS, NONFINITE, FAILED],
                      SUCCESS)
    return sol.value, code, sol.stats["num_steps"]


def chunk_function(spec: SolverSpec) -> Any:
    """The traceable fit of one chunk: ``(t, y, m, duration, theta0, ramp, second,
    fit_duration, rtol, atol) -> (theta, code, n_steps)`` with ``(n_rows, n_points)``
    float64 t, y and m (1.0 where a point is real), ``(n_rows,)`` duration in s (inf:
    none), ``(n_rows, 3)`` starts, three unbatched bool flags and the two unbatched float64
    stopping tolerances; ``(n_rows, 3)``, ``(n_rows,)``, ``(n_rows,)`` out."""

    def solve(t: jax.Array, y: jax.Array, m: jax.Array, duration: jax.Array,
              theta0: jax.Array, ramp: jax.Array, second: jax.Array,
              fit_duration: jax.Array, rtol: jax.Array, atol: jax.Array
              ) -> tuple[jax.Array, jax.Array, jax.Array]:
        flags = Flags(ramp, second, fit_duration)
        return jax.vmap(lambda *a: _solve_one(spec, *a, flags, rtol, atol))(
            t, y, m, duration, theta0)

    return solve


__all__ = ["FAILED", "MAX_STEPS", "NONFINITE", "N_THETA", "SUCCESS", "Flags", "SolverSpec",
           "chunk_function", "first_order_terms", "gains", "unpack"]
