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

The second-order alternative is the sum of two first-order modes with free gains,
``alpha[0] * unit(t; tau[0]) + alpha[1] * unit(t; tau[1])``: a transfer function with two
real poles and one zero. It contains the classic overdamped second-order system
``K / ((tau0 s + 1)(tau1 s + 1))`` (gains of opposite sign, an S-shaped rise) and a fast
rise followed by a slow creep or sag (the "big force" responses of paper fig. 11), and it
nests the first-order model (one gain zero), which is what an information criterion needs.

Every function works on numpy arrays (returns numpy) and on jax arrays or tracers (returns
jax); parameters broadcast against ``t_s``. The models are linear in ``alpha``, which the
fitter exploits (variable projection: :mod:`tactile_cli.fos.fit`).
"""

from __future__ import annotations

from typing import Any, Literal

import jax
import jax.numpy as jnp
import numpy as np

Kind = Literal["step", "pulse", "ramp"]
#: The response kinds, in the order the fitter numbers them.
KINDS: tuple[str, ...] = ("step", "pulse", "ramp")


def _xp(*arrays: Any) -> Any:
    """jax.numpy if any argument is a jax array or tracer, else numpy."""
    return jnp if any(isinstance(a, jax.Array) for a in arrays) else np


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
    """Step response ``alpha (1 - exp(-t/tau))`` in events per bin (the T -> inf limit of eq. 16)."""
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


def second_order_response(
    kind: Kind, t_s: Any, alpha: Any, tau_s: Any, duration_s: Any = None
) -> Any:
    """Two first-order modes with free gains, in events per bin.

    ``alpha`` and ``tau_s`` have a last axis of length 2 (the two modes); ``t_s`` and
    ``duration_s`` broadcast against the leading axes. Returns
    ``alpha[..., 0] unit(t; tau[..., 0]) + alpha[..., 1] unit(t; tau[..., 1])``.
    """
    return (first_order_response(kind, t_s, alpha[..., 0], tau_s[..., 0], duration_s)
            + first_order_response(kind, t_s, alpha[..., 1], tau_s[..., 1], duration_s))
