"""First-order-system (FOS) response models of the press and slip regions, and their
second-order alternative.

Paper 000, sec. 4.2: the event count of a pressing region follows the pulse response of a
first-order system (eq. 16), the plain step response being its limit T -> infinity, and the
event count of a slipping region follows its ramp response (eq. 17)::

    pulse (eq. 16):  x(t) = alpha (1 - exp(-t/tau))                      0 <= t < T
                     x(t) = alpha (exp(-(t - T)/tau) - exp(-t/tau))      t >= T
    step:            x(t) = alpha (1 - exp(-t/tau))
    ramp (eq. 17):   x(t) = alpha (t/tau - 1 + exp(-t/tau))

Units everywhere: ``t_s``, ``tau_s`` and ``duration_s`` (T) in seconds from the region start;
``alpha`` in events per bin (the paper counts events in 20 ms bins), so a response is in
events per bin too.

The second-order alternative is the general linear second-order system
``alpha (1 + lead s) / (tau^2 s^2 + 2 zeta tau s + 1)``: ``tau = 1/omega_n`` in s, damping
ratio ``zeta``, and a zero with time constant ``lead_s``. With ``lead = 0`` it is the
textbook second-order system (an overshoot for ``zeta < 1``, an S-shaped rise with a sharp
knee for ``zeta >= 1``); with two real poles and a zero it is any sum of two first-order
modes (a fast rise with a slow creep or sag, or a saturating rise). It contains the FOS
exactly (the zero cancelling one pole), which is what an information criterion between the
two needs. It is linear in ``alpha`` and ``alpha * lead``. Its parameters are written with
(tau, zeta) rather than two time constants so that critical damping, where two real time
constants merge and a fit would stall on the ridge, is an ordinary point.

Every function works on numpy arrays (returns numpy) and on jax arrays or tracers (returns
jax); parameters broadcast against ``t_s``. The models are linear in ``alpha``, which the
fitter exploits (variable projection: :mod:`tactile_cli.fos.fit`).
"""

from __future__ import annotations

import sys
from typing import Any, Literal

import numpy as np

Kind = Literal["step", "pulse", "ramp"]
#: The response kinds, in the order the fitter numbers them.
KINDS: tuple[str, ...] = ("step", "pulse", "ramp")


def _xp(*arrays: Any) -> Any:
    """jax.numpy if any argument is a jax array or tracer, else numpy.

    jax is not imported here: an argument can only be a jax array if the caller imported
    jax already, so numpy-only users (the scene, synth) do not pay jax's import time.
    """
    jax = sys.modules.get("jax")
    if jax is not None and any(isinstance(a, jax.Array) for a in arrays):
        import jax.numpy as jnp

        return jnp
    return np


def unit_response(kind: Kind, t_s: Any, tau_s: Any, duration_s: Any = None) -> Any:
    """Response of a unit-gain first-order system (``alpha = 1``), shape of the broadcast inputs.

    ``kind`` is ``"step"``, ``"pulse"`` (needs ``duration_s``, the pulse length T in s) or
    ``"ramp"``. Written in forms that stay accurate for ``t << tau`` and ``t >> T``: the pulse
    is ``(1 - exp(-min(t, T)/tau)) * exp(-max(t - T, 0)/tau)``, equal to eq. 16 on both
    branches and to the step for ``T = inf``.
    """
    xp = _xp(t_s, tau_s, duration_s)
    if kind == "step":
        return -xp.expm1(-t_s / tau_s)
    if kind == "pulse":
        if duration_s is None:
            raise ValueError("`duration_s` (=None) is required for kind='pulse'; "
                             "use kind='step' for an unending press.")
        rise = -xp.expm1(-xp.minimum(t_s, duration_s) / tau_s)
        return rise * xp.exp(-xp.maximum(t_s - duration_s, 0.0) / tau_s)
    if kind == "ramp":
        return t_s / tau_s + xp.expm1(-t_s / tau_s)
    raise ValueError(f"`kind` (={kind!r}) must be one of {KINDS}.")


def step_response(t_s: Any, alpha: Any, tau_s: Any) -> Any:
    """Step response ``alpha (1 - exp(-t/tau))``, events per bin (eq. 16 for T -> inf)."""
    return alpha * unit_response("step", t_s, tau_s)


def pulse_response(t_s: Any, alpha: Any, tau_s: Any, duration_s: Any) -> Any:
    """Pulse response of eq. 16 in events per bin: a press of ``duration_s`` seconds (T)."""
    return alpha * unit_response("pulse", t_s, tau_s, duration_s)


def ramp_response(t_s: Any, alpha: Any, tau_s: Any) -> Any:
    """Ramp response of eq. 17, ``alpha (t/tau - 1 + exp(-t/tau))``, in events per bin."""
    return alpha * unit_response("ramp", t_s, tau_s)


def first_order_response(
    kind: Kind, t_s: Any, alpha: Any, tau_s: Any, duration_s: Any = None
) -> Any:
    """``alpha * unit_response(kind, ...)``: eq. 16, its step limit or eq. 17 by ``kind``."""
    return alpha * unit_response(kind, t_s, tau_s, duration_s)


def _damped_pair(xp: Any, t_s: Any, tau_s: Any, zeta: Any) -> tuple[Any, Any, Any]:
    """``exp(-a t) cosh(q t)``, ``exp(-a t) sinh(q t)/q`` and ``a`` for the pole pair
    ``-a +- q`` of ``1/(tau^2 s^2 + 2 zeta tau s + 1)``, stable for every damping.

    Overdamped (q real) in terms of the slow rate ``a - q`` (no exp overflow however large a
    gets near the first-order limit); underdamped (q imaginary) with cos and sinc; both are
    analytic in q^2, so values and derivatives join at critical damping.
    """
    a = zeta / tau_s
    q2 = a * a - 1.0 / (tau_s * tau_s)
    q = xp.sqrt(xp.maximum(q2, 1e-300))  # evaluated on both sides of a `where`: keep finite
    w = xp.sqrt(xp.maximum(-q2, 1e-300))
    slow = 1.0 / (tau_s * tau_s * (a + q))  # a - q without cancellation
    x = 2.0 * q * t_s
    x_safe = xp.where(x > 1e-8, x, 1.0)
    phi = xp.where(x > 1e-8, -xp.expm1(-x_safe) / x_safe, 1.0 - 0.5 * x)  # (1 - e^-x)/x
    e_slow = xp.exp(-slow * t_s)
    e_a = xp.exp(-a * t_s)
    over = q2 > 0
    cosh_part = xp.where(over, 0.5 * e_slow * (1.0 + xp.exp(-x)), e_a * xp.cos(w * t_s))
    sinh_part = xp.where(over, e_slow * t_s * phi, e_a * t_s * xp.sinc(w * t_s / np.pi))
    return cosh_part, sinh_part, a


def second_order_basis(
    kind: Kind, t_s: Any, tau_s: Any, zeta: Any, duration_s: Any = None
) -> tuple[Any, Any]:
    """Response ``b`` of ``1/(tau^2 s^2 + 2 zeta tau s + 1)`` to the input of ``kind``, and
    its time derivative ``db/dt`` (the response to the same input through ``s/(...)``).

    ``tau_s`` is 1/omega_n in s, ``zeta`` the damping ratio (< 1 overshoots, > 1 two real
    poles). The ramp response is divided by ``2 zeta tau`` (the sum of the time constants)
    so that, like eq. 17, its gain is in events per bin. For ``zeta -> inf`` at fixed
    ``2 zeta tau``, ``b`` tends to the first-order response with that time constant.
    """
    xp = _xp(t_s, tau_s, zeta, duration_s)
    if kind not in KINDS:
        raise ValueError(f"`kind` (={kind!r}) must be one of {KINDS}.")

    def step_and_impulse(t: Any) -> tuple[Any, Any]:
        cosh_part, sinh_part, a = _damped_pair(xp, t, tau_s, zeta)
        return 1.0 - cosh_part - a * sinh_part, sinh_part / (tau_s * tau_s)

    if kind == "step":
        return step_and_impulse(t_s)
    if kind == "pulse":
        if duration_s is None:
            raise ValueError("`duration_s` (=None) is required for kind='pulse'.")
        on, on_rate = step_and_impulse(t_s)
        off, off_rate = step_and_impulse(xp.maximum(t_s - duration_s, 0.0))
        return on - off, on_rate - off_rate
    # ramp: the integral of the step response, t - 2 zeta tau + tau^2 e^-at (2a cosh + ...)
    cosh_part, sinh_part, a = _damped_pair(xp, t_s, tau_s, zeta)
    lag = 2.0 * zeta * tau_s
    tail = tau_s * tau_s * (2.0 * a * cosh_part + (2.0 * a * a - 1.0 / (tau_s * tau_s))
                            * sinh_part)
    return (t_s - lag + tail) / lag, (1.0 - cosh_part - a * sinh_part) / lag


def second_order_response(
    kind: Kind, t_s: Any, alpha: Any, tau_s: Any, zeta: Any, duration_s: Any = None,
    lead_s: Any = 0.0,
) -> Any:
    """Second-order response ``alpha (1 + lead s) / (tau^2 s^2 + 2 zeta tau s + 1)``, events
    per bin: ``alpha (b + lead db/dt)`` with ``b`` from :func:`second_order_basis`."""
    b, rate = second_order_basis(kind, t_s, tau_s, zeta, duration_s)
    return alpha * (b + lead_s * rate)
