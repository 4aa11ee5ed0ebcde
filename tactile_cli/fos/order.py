"""Model order: is a first-order system enough for a trial, or does it need a second order?

Paper 000, sec. 4.2 fits a first-order system (FOS) to every press and slip region, but
notes that the "big" press responses carry "nonlinear, unmodeled dynamics" (fig. 11). Per
trial this module fits the FOS (eq. 16, its step limit, or eq. 17) and the nested
two-mode alternative of :mod:`tactile_cli.fos.models`, and compares them by an
information criterion: ``aic = n log(RSS/n) + 2k`` or ``bic = n log(RSS/n) + k log n``.

Verdicts, per trial:

- ``"first_order"``: the second-order fit does not improve the criterion by ``min_delta``.
- ``"second_order"``: it does; the FOS is not enough for this trial.
- ``"undecided"``: the first-order fit itself failed, or the second-order fit failed while
  the evidence it reached is not conclusive (a better second-order optimum might exist).

The models are nested (a two-mode fit with one gain zero is the FOS), so the best
second-order RSS is never above the FOS RSS. A second-order fit that did not converge
still reached a real RSS, an upper bound on its optimum: when even that beats the FOS by
``min_delta`` the verdict is ``second_order``. The reverse does not hold, and a failed
second-order fit that does not beat the FOS gives ``undecided``, except when it failed by
running a time constant out of range or by becoming unidentifiable: those are how a
superfluous second mode fails (its gain goes to zero or it merges with the first), which is
itself the sign that one mode is enough.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike

from .fit import FitStatus, FosFitResult, _Config, _fit, _make_config
from .models import Kind

Criterion = Literal["aic", "bic"]
#: Second-order failure modes that mean "the second mode is superfluous".
_DEGENERATE = (FitStatus.OUT_OF_RANGE.value, FitStatus.ILL_CONDITIONED.value)


@dataclass(frozen=True)
class OrderSelection:
    """Per-trial model-order verdicts with both fits; arrays have ``n_trials`` rows."""

    criterion: str
    min_delta: float
    first: FosFitResult
    second: FosFitResult
    delta: np.ndarray  #: criterion(first) - criterion(second); > 0 favours second order
    verdict: np.ndarray  #: "first_order" | "second_order" | "undecided"

    @property
    def first_order_enough(self) -> np.ndarray:
        """(n_trials,) bool: True where the verdict is ``first_order``."""
        return self.verdict == "first_order"

    def to_records(self) -> list[dict[str, Any]]:
        """One JSON-ready dict per trial: verdict, delta and both fits (prefixed)."""
        out = []
        for i, (r1, r2) in enumerate(zip(self.first.to_records(), self.second.to_records(),
                                         strict=True)):
            d = float(self.delta[i])
            row: dict[str, Any] = {"trial": i, "verdict": str(self.verdict[i]),
                                   "criterion": self.criterion,
                                   "delta": d if np.isfinite(d) else None}
            row.update({f"first_{k}": v for k, v in r1.items() if k != "trial"})
            row.update({f"second_{k}": v for k, v in r2.items() if k != "trial"})
            out.append(row)
        return out


def select_order(
    kind: Kind, t_s: ArrayLike, y: ArrayLike, mask: ArrayLike | None = None, *,
    duration_s: ArrayLike | None = None, criterion: Criterion = "bic", min_delta: float = 2.0,
    tau_bounds_s: tuple[float, float] | None = None, max_steps: int = 64,
    rtol: float = 1e-4, atol: float = 1e-4, chunk_size: int = 1024,
) -> OrderSelection:
    """Fit first- and second-order models of ``kind`` to every trial and choose per trial.

    ``kind``, ``t_s``, ``y``, ``mask``, ``duration_s`` and the solver options are as for
    :func:`tactile_cli.fos.fit_pulse`; ``duration_s=None`` fits T in both models. The
    second-order fit starts from the first-order tau (modes at half and twice it).
    ``min_delta`` is the improvement of the criterion the second order must reach (2 is
    "positive evidence" on the usual scales).
    """
    if criterion not in ("aic", "bic"):
        raise ValueError(f"`criterion` (={criterion!r}) must be 'aic' or 'bic'.")
    if not min_delta >= 0:
        raise ValueError(f"`min_delta` (={min_delta}) must be >= 0.")
    fit_duration = kind == "pulse" and duration_s is None
    common = dict(duration_s=duration_s, tau_bounds_s=tau_bounds_s, chunk_size=chunk_size)

    def config(order: int) -> _Config:
        return _make_config(kind, order, fit_duration, max_steps, rtol, atol)

    first = _fit(config(1), t_s, y, mask, tau0_s=None, duration0_s=None, keep_failed=False,
                 **common)
    tau1 = first.tau_s[:, None] * np.array([0.5, 2.0])  # NaN rows: data-driven start
    second = _fit(config(2), t_s, y, mask, tau0_s=tau1,
                  duration0_s=first.duration_s if fit_duration else None, keep_failed=True,
                  **common)
    ic1, ic2 = getattr(first, criterion), getattr(second, criterion)
    delta = ic1 - ic2
    ok1, ok2 = first.ok, second.ok
    degenerate = np.isin(second.status, _DEGENERATE)
    second_wins = ok1 & np.isfinite(delta) & (delta > min_delta)
    first_wins = ok1 & ~second_wins & (ok2 | degenerate)
    verdict = np.where(second_wins, "second_order",
                       np.where(first_wins, "first_order", "undecided"))
    # The second fit kept its last iterate for the evidence above; report it like any fit.
    return OrderSelection(criterion=criterion, min_delta=float(min_delta), first=first,
                          second=second.drop_failed(), delta=np.where(ok1, delta, np.nan), verdict=verdict)
