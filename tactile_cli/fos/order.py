"""Model order: is a first-order system enough for a trial, or does it need a second order?

Paper 000, sec. 4.2 fits a first-order system (FOS) to every press and slip region, but
notes that the "big" press responses carry "nonlinear, unmodeled dynamics" (fig. 11). Per
trial this module fits the FOS (eq. 16, its step limit, or eq. 17) and the second-order
alternative ``alpha (1 + lead s) / (tau^2 s^2 + 2 zeta tau s + 1)`` of
:mod:`tactile_cli.fos.models`, and compares them by an information criterion,
``aic = n log(RSS/n) + 2k`` or ``bic = n log(RSS/n) + k log n`` (k counts the noise
variance; the second order has two parameters more).

The FOS is nested in the second order (the zero cancelling a pole), and the second-order
fit starts exactly there: real poles at the first-order tau and at a quarter of it, with
the zero free to cancel the fast one. Levenberg-Marquardt only ever lowers the residual, so
the second-order RSS it reports is never above the FOS RSS, whether or not it converged.
On data a first-order system describes, a second-order fit has a flat direction (where the
zero sits on a pole does not matter) and often ends ``ill_conditioned`` or ``max_steps``
there: its RSS is still a real one, and the comparison still holds.

Verdicts, per trial:

- ``"second_order"``: the second order lowers the criterion by more than ``min_delta``;
  the FOS is not enough for this trial.
- ``"first_order"``: the best second-order fit found from the FOS solution does not.
  (A better second-order optimum far from the FOS solution would be missed; the
  tests and benchmarks/fos_stability.py measure how often that happens for second-order
  and saturating data.)
- ``"relaxation"`` (step responses only): the second order wins, and what it found is a
  first-order rise followed by a slower relaxation back towards a lower level (a press that
  creeps back, as elastomer skins and taxel pads do): two real poles, and a zero slower than
  the slow pole, so the slow mode's share is positive. The step response is then
  ``alpha (1 + c_f exp(-t/tau_f) + c_s exp(-t/tau_s))`` with ``c_s > 0``: the response rises
  with ``tau_f`` (``rise_tau_s``) to about ``alpha (1 + c_s)`` and relaxes with ``tau_s``
  (``relax_tau_s``) by ``relax_fraction = c_s / (1 + c_s)`` of that level. Not first order.
  (Every two-mode relaxation ``a (1 - exp(-t/tau_f)) - b (1 - exp(-t/tau_s))`` is such a
  second-order response, so no separate fit is needed: the criterion already compared it.)
- ``"undecided"``: the first-order fit failed, or the second-order one gave no finite
  residual.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from .fit import FitOptions, FosFitResult, _Config, _fit, _make_config
from .models import Kind

Criterion = Literal["aic", "bic"]


@dataclass(frozen=True)
class OrderSelection:
    """Per-trial model-order verdicts with both fits; arrays have ``n_trials`` rows."""

    criterion: str
    min_delta: float
    first: FosFitResult
    second: FosFitResult  #: NaN parameters where the second-order fit did not converge
    delta_aic: np.ndarray  #: aic(first) - aic(second); > 0 favours the second order
    delta_bic: np.ndarray  #: bic(first) - bic(second)
    verdict: np.ndarray  #: "first_order" | "second_order" | "relaxation" | "undecided"
    #: (n_trials,) for ``relaxation`` verdicts (else NaN): the share of the peak level lost
    #: to the relaxation, its time constant in s, and the rise's time constant in s.
    relax_fraction: np.ndarray | None = None
    relax_tau_s: np.ndarray | None = None
    rise_tau_s: np.ndarray | None = None

    @property
    def delta(self) -> np.ndarray:
        """The difference of the chosen criterion, first minus second order."""
        return self.delta_aic if self.criterion == "aic" else self.delta_bic

    @property
    def first_order_enough(self) -> np.ndarray:
        """(n_trials,) bool: True where the verdict is ``first_order``."""
        return self.verdict == "first_order"

    def to_records(self) -> list[dict[str, Any]]:
        """One JSON-ready dict per trial: verdict, deltas and both fits (prefixed)."""
        out = []
        for i, (r1, r2) in enumerate(zip(self.first.to_records(), self.second.to_records(),
                                         strict=True)):
            row: dict[str, Any] = {"trial": i, "verdict": str(self.verdict[i]),
                                   "criterion": self.criterion, "min_delta": self.min_delta,
                                   "delta_aic": _finite(self.delta_aic[i]),
                                   "delta_bic": _finite(self.delta_bic[i])}
            if self.relax_fraction is not None:
                row.update({"relax_fraction": _finite(self.relax_fraction[i]),
                            "relax_tau_s": _finite(self.relax_tau_s[i]),
                            "rise_tau_s": _finite(self.rise_tau_s[i])})
            row.update({f"first_{k}": v for k, v in r1.items() if k != "trial"})
            row.update({f"second_{k}": v for k, v in r2.items() if k != "trial"})
            out.append(row)
        return out


def _span_s(t_s: ArrayLike, y: ArrayLike, mask: ArrayLike | None) -> np.ndarray:
    """(n_trials,) time from each trial's first to its last valid point (s)."""
    yy = np.atleast_2d(np.asarray(y, dtype=np.float64))
    t = np.broadcast_to(np.asarray(t_s, dtype=np.float64), yy.shape)
    valid = np.ones(yy.shape, bool) if mask is None else \
        np.broadcast_to(np.asarray(mask, dtype=bool), yy.shape)
    with np.errstate(invalid="ignore"):
        hi = np.where(valid, t, -np.inf).max(axis=-1)
        lo = np.where(valid, t, np.inf).min(axis=-1)
    return np.where(np.isfinite(hi - lo), hi - lo, np.nan)


def _lower_rss(a: FosFitResult, b: FosFitResult) -> FosFitResult:
    """Per trial, the fit of ``a`` or ``b`` whose residual is lower (``a`` on ties and where
    ``b`` has none)."""
    take_b = np.isfinite(b.rss) & ~(b.rss >= a.rss)
    if not take_b.any():
        return a
    picked = {}
    for f in fields(a):
        va, vb = getattr(a, f.name), getattr(b, f.name)
        if isinstance(va, np.ndarray) and va.shape[:1] == take_b.shape:
            picked[f.name] = np.where(take_b.reshape((-1,) + (1,) * (va.ndim - 1)), vb, va)
    return replace(a, **picked)


def _finite(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


def _verdicts(first_ok: np.ndarray, delta: np.ndarray, min_delta: float) -> np.ndarray:
    """The verdict rule: second order when it lowers the criterion by more than
    ``min_delta``, first order when it does not, undecided without a usable comparison."""
    usable = first_ok & np.isfinite(delta)
    return np.where(usable & (delta > min_delta), "second_order",
                    np.where(usable, "first_order", "undecided"))


def relaxation_shape(second: FosFitResult) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(relax_fraction, relax_tau_s, rise_tau_s)``, (n_trials,) each, of second-order step
    fits: NaN where the fit did not converge, its poles are complex (zeta < 1) or its slow
    mode does not relax (``c_s <= 0``, see the module doc).

    With real poles ``tau^2 s^2 + 2 zeta tau s + 1 = (1 + tau_f s)(1 + tau_s s)`` and the zero
    ``lead``, the slow mode's coefficient is ``c_s = (lead - tau_s) / (tau_s - tau_f)``, so
    ``relax_fraction = c_s / (1 + c_s) = (lead - tau_s) / (lead - tau_f)``.
    """
    tau, zeta, lead = (np.asarray(a, dtype=np.float64)
                       for a in (second.tau_s, second.zeta, second.lead_s))
    with np.errstate(invalid="ignore", divide="ignore"):
        root = np.sqrt(np.maximum(zeta * zeta - 1.0, 0.0))
        slow = tau * (zeta + root)
        fast = tau / (zeta + root)  # tau^2 / slow, without cancellation
        relaxing = (np.asarray(second.status) == "converged") & (zeta >= 1.0) & (lead > slow) \
            & (slow > fast)
        fraction = (lead - slow) / (lead - fast)
    nan = np.full(tau.shape, np.nan)
    return (np.where(relaxing, fraction, nan), np.where(relaxing, slow, nan),
            np.where(relaxing, fast, nan))


def select_order(
    kind: Kind, t_s: ArrayLike, y: ArrayLike, mask: ArrayLike | None = None, *,
    duration_s: ArrayLike | None = None, criterion: Criterion = "bic", min_delta: float = 2.0,
    tau_bounds_s: tuple[float, float] | None = None, options: FitOptions | None = None,
) -> OrderSelection:
    """Fit first- and second-order models of ``kind`` to every trial and choose per trial.

    ``kind``, ``t_s``, ``y``, ``mask``, ``duration_s`` and the solver options are as for
    :func:`tactile_cli.fos.fit_pulse`; ``duration_s=None`` fits T in both models.
    ``options`` (:class:`tactile_cli.fos.FitOptions`) applies to both fits.
    ``min_delta`` is the improvement of the criterion the second order must reach (2 is
    "positive evidence" on the usual scales). The second fit's own status is reported in
    ``second.status``; its parameters are NaN unless it converged.
    """
    if criterion not in ("aic", "bic"):
        raise ValueError(f"`criterion` (={criterion!r}) must be 'aic' or 'bic'.")
    if not min_delta >= 0:
        raise ValueError(f"`min_delta` (={min_delta}) must be >= 0.")
    fit_duration = kind == "pulse" and duration_s is None
    options = options or FitOptions()
    common = dict(duration_s=duration_s, tau_bounds_s=tau_bounds_s,
                  chunk_size=options.chunk_size)

    def config(order: int) -> _Config:
        return _make_config(kind, order, fit_duration, options)

    first = _fit(config(1), t_s, y, mask, tau0_s=None, zeta0=None, duration0_s=None,
                 keep_failed=False, **common)
    # Second order from the first-order fit: poles at tau and tau/4 (see the module doc).
    second = _fit(config(2), t_s, y, mask, tau0_s=first.tau_s / 2,
                  zeta0=np.where(first.ok, 1.25, np.nan),
                  duration0_s=first.duration_s if fit_duration else None, keep_failed=True,
                  **common)
    if kind == "step":
        # A press that rises and then creeps back over seconds (a taxel pad, xela_press)
        # has its second-order optimum far from the first-order one, where the fit above
        # stays (its RSS no lower: "first order"). A second start at a relaxation, poles at
        # the first-order tau and at a quarter of the trial's span (at least 4 tau), and
        # per trial the start whose fit ends with the lower residual.
        slow = np.maximum(4.0 * first.tau_s, _span_s(t_s, y, mask) / 4.0)
        tau_b = np.sqrt(first.tau_s * slow)
        relax = _fit(config(2), t_s, y, mask, tau0_s=tau_b,
                     zeta0=np.where(first.ok, (first.tau_s + slow) / (2.0 * tau_b), np.nan),
                     duration0_s=None, keep_failed=True, **common)
        second = _lower_rss(second, relax)
    # The second fit kept its last iterate: its residual is real even when it did not
    # converge (see the module doc); it is reported with NaN parameters like any failed fit.
    nan_unless_first = np.where(first.ok, 1.0, np.nan)
    delta_aic = (first.aic - second.aic) * nan_unless_first
    delta_bic = (first.bic - second.bic) * nan_unless_first
    verdict = _verdicts(first.ok, delta_aic if criterion == "aic" else delta_bic, min_delta)
    second = second.drop_failed()
    shape: tuple[np.ndarray | None, ...] = (None, None, None)
    if kind == "step":  # a relaxing step is told apart from other second-order shapes
        fraction, slow, fast = relaxation_shape(second)
        relaxing = (verdict == "second_order") & np.isfinite(fraction)
        verdict = np.where(relaxing, "relaxation", verdict)
        shape = tuple(np.where(relaxing, a, np.nan) for a in (fraction, slow, fast))
    return OrderSelection(
        criterion=criterion, min_delta=float(min_delta), first=first, second=second,
        delta_aic=delta_aic, delta_bic=delta_bic, verdict=verdict, relax_fraction=shape[0],
        relax_tau_s=shape[1], rise_tau_s=shape[2])
