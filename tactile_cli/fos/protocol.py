"""The ``tactile fit-fos`` protocol: which counts go into which fit (paper 000, sec. 4.2).

For every trial (all trials of a file are fitted at once, padded to ``(n_trials, n_points)``
with a mask, by :func:`tactile_cli.fos.fit_pulse` / :func:`~tactile_cli.fos.fit_ramp`):

1. **Press** ``[press_start, slip_start)``: the bins whose centre lies in the region, with
   ``t = bin centre - press_start``. Fitted with the pulse response of eq. 16, the press
   length T fitted too, or known when ``press_duration_s`` is given.
2. **Slip** ``[slip_start, release_start)``: the system is linear, so the counts there are
   the tail of the press response plus the slip's ramp response. The press fit is
   extrapolated into the slip region (eq. 16 at ``bin centre - press_start`` with the
   fitted alpha, tau and T) and subtracted; eq. 17 is fitted to the rest with
   ``t = bin centre - slip_start``. A trial whose press fit failed has no tail to subtract:
   its slip is reported as ``press_failed``, not fitted. (So ``kind="slip"`` fits the press
   as well, and reports only the slip.)
3. **Model order**: with ``order=True`` each region is also fitted with the second-order
   alternative and :func:`tactile_cli.fos.select_order` gives the verdict by BIC
   (``first_order``, ``second_order``, for step curves ``relaxation``, or ``undecided``;
   ``not_tested`` without it). The
   first-order results are those of the same call (identical to ``fit_pulse``/``fit_ramp``).

A failed fit is kept in the results with its status (parameters NaN), never dropped.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from .fit import FitOptions, FitStatus, FosFitResult, fit_pulse, fit_ramp, fit_step
from .models import first_order_response
from .order import select_order
from .regions import TrialRegions

#: Status of a slip fit skipped because the trial's press fit failed.
PRESS_FAILED = "press_failed"
PRESS_FAILED_MESSAGE = ("the press fit failed, so its tail cannot be subtracted from the slip "
                        "region; the slip was not fitted")
#: Status of a trial whose regions could not be found (the segmentation failed).
NO_REGIONS = "no_regions"
#: Verdict when the model order was not tested.
NOT_TESTED = "not_tested"
#: Model fitted to each region.
REGION_MODELS = {"press": "pulse", "slip": "ramp"}
#: The unit of counts and of their alpha.
COUNT_UNITS = "events/bin"
#: A curve's unit when neither the caller nor its file names one.
DEFAULT_UNITS = "units"


@dataclass(frozen=True)
class RegionFits:
    """The fits of one region (or of one CSV curve) over all trials; arrays have n rows.

    ``t_s`` and ``y`` are exactly what was fitted: ``(n, n_points)`` seconds from the region
    start and events per bin (slip: after the press tail was subtracted), padded with zeros
    where ``mask`` is False. ``start_s``/``end_s``: the region in trial seconds.
    ``status`` is the fit's :class:`~tactile_cli.fos.FitStatus` value, ``press_failed`` or
    ``no_regions``; ``detail`` (n,) a trial-specific explanation (e.g. the segmentation's
    message) or ``""``. ``units``: the unit of ``y`` and alpha per row (``"events/bin"``
    for counts; a curve's own unit).
    """

    region: str
    model: str
    trials: tuple[str, ...]
    start_s: np.ndarray
    end_s: np.ndarray
    t_s: np.ndarray
    y: np.ndarray
    mask: np.ndarray
    fit: FosFitResult
    verdict: np.ndarray
    delta_bic: np.ndarray
    status: np.ndarray
    detail: np.ndarray | None = None
    units: tuple[str, ...] | None = None
    #: Step fits with the order tested: ``relax_fraction``, ``relax_tau_s`` and
    #: ``rise_tau_s`` (n,) of :class:`tactile_cli.fos.OrderSelection` (NaN unless the
    #: verdict is ``relaxation``); None otherwise.
    relaxation: dict[str, np.ndarray] | None = None

    def __len__(self) -> int:
        return len(self.trials)

    @property
    def ok(self) -> np.ndarray:
        """(n,) bool: the fit converged."""
        return self.status == FitStatus.CONVERGED.value

    def unit(self, i: int) -> str:
        """The unit of row ``i``'s response and alpha."""
        return COUNT_UNITS if self.units is None else self.units[i]

    def message(self, i: int) -> str:
        """What the status of trial ``i`` means."""
        status = str(self.status[i])
        detail = "" if self.detail is None else str(self.detail[i])
        if status == PRESS_FAILED:
            return PRESS_FAILED_MESSAGE
        if status == NO_REGIONS:
            return (f"no press and slip regions ({detail}); annotate the trial "
                    "(`tactile ingest --annotations FILE`)")
        return FitStatus(status).message

    def curve(self, i: int, t_s: ArrayLike) -> np.ndarray:
        """The fitted first-order response of trial ``i`` at ``t_s`` (s from the region
        start), events per bin; NaN where the fit did not converge."""
        f = self.fit
        duration = f.duration_s[i] if self.model == "pulse" else None
        return first_order_response(self.model, np.asarray(t_s, dtype=np.float64), f.alpha[i],
                                    f.tau_s[i], duration)


def _region_arrays(trials: Sequence[TrialRegions], region: str, width: int = 1
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[np.ndarray]]:
    """Padded (n, n_points) times from the region start, counts and mask, plus each trial's
    bin indices in the region; ``n_points`` is the longest region, at least ``width``."""
    idx = [np.flatnonzero(tr.in_region(region)) for tr in trials]
    n_points = max(1, width, max(len(i) for i in idx))
    t = np.zeros((len(trials), n_points))
    y = np.zeros((len(trials), n_points))
    m = np.zeros((len(trials), n_points), bool)
    for row, (tr, i) in enumerate(zip(trials, idx, strict=True)):
        t[row, :len(i)] = tr.t_s[i] - tr.region(region)[0]
        y[row, :len(i)] = tr.net[i]
        m[row, :len(i)] = True
    return t, y, m, idx


def region_arrays(trials: Sequence[TrialRegions], region: str
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(t_s, y, mask)`` of one region of every trial, as the fits take them: (n_trials,
    n_points) seconds from the region start, net events per bin (not press-corrected) and
    bool, padded with zeros / False."""
    t, y, m, _ = _region_arrays(trials, region)
    return t, y, m


def _fit(model: str, t: np.ndarray, y: np.ndarray, m: np.ndarray, *,
         duration_s: ArrayLike | None, order: bool, options: FitOptions
         ) -> tuple[FosFitResult, np.ndarray, np.ndarray]:
    """First-order fit, verdict and delta BIC of one model over all rows."""
    fit, verdict, delta, _ = _fit_shaped(model, t, y, m, duration_s=duration_s, order=order,
                                         options=options)
    return fit, verdict, delta


def _fit_shaped(model: str, t: np.ndarray, y: np.ndarray, m: np.ndarray, *,
                duration_s: ArrayLike | None, order: bool, options: FitOptions
                ) -> tuple[FosFitResult, np.ndarray, np.ndarray, dict[str, np.ndarray] | None]:
    """:func:`_fit`, and the relaxation columns of step fits whose order was tested."""
    if order:
        sel = select_order(model, t, y, m, duration_s=duration_s if model == "pulse" else None,
                           criterion="bic", options=options)
        shape = None
        if sel.relax_fraction is not None:
            shape = {"relax_fraction": sel.relax_fraction, "relax_tau_s": sel.relax_tau_s,
                     "rise_tau_s": sel.rise_tau_s}
        return sel.first, sel.verdict.astype(str), sel.delta_bic, shape
    if model == "pulse":
        fit = fit_pulse(t, y, m, duration_s=duration_s, options=options)
    elif model == "ramp":
        fit = fit_ramp(t, y, m, options=options)
    else:
        fit = fit_step(t, y, m, options=options)
    return fit, np.full(len(fit), NOT_TESTED), np.full(len(fit), np.nan), None


def _check_duration(press_duration_s: float | None) -> None:
    if press_duration_s is not None and not (np.isfinite(press_duration_s)
                                             and press_duration_s > 0):
        raise ValueError(f"`press_duration_s` (={press_duration_s}) must be a positive number "
                         "of seconds (None fits T).")


def fit_regions(
    trials: Sequence[TrialRegions],
    *,
    regions: Sequence[str] = ("press", "slip"),
    press_duration_s: float | None = None,
    order: bool = True,
    options: FitOptions | None = None,
) -> dict[str, RegionFits]:
    """Fit the press and/or slip regions of all ``trials`` at once (see the module doc).

    ``regions``: a subset of ``("press", "slip")``; the press is fitted whenever the slip
    is (its tail is subtracted), but only the regions asked for are returned.
    ``press_duration_s``: the known press length T in seconds; None fits it.
    ``order``: also fit the second order and give the BIC verdict.
    """
    unknown = [r for r in regions if r not in REGION_MODELS]
    if unknown or not regions:
        raise ValueError(f"`regions` (={list(regions)}) must be a non-empty subset of "
                         f"{tuple(REGION_MODELS)}.")
    if not trials:
        raise ValueError("`trials` is empty: nothing to fit.")
    _check_duration(press_duration_s)
    options = options or FitOptions()
    names = tuple(tr.trial for tr in trials)
    found = np.array([tr.has_regions for tr in trials])
    detail = np.array([tr.regions_note for tr in trials], dtype=object)
    out: dict[str, RegionFits] = {}

    # Both regions padded to one width, so that every fit of the file runs through the
    # same compiled solver (its shape is bucketed by the number of points).
    width = max(int(tr.in_region(r).sum()) for tr in trials for r in ("press", "slip"))
    t, y, m, _ = _region_arrays(trials, "press", width)
    press_fit, verdict, delta = _fit("pulse", t, y, m, duration_s=press_duration_s,
                                     order=order and "press" in regions, options=options)
    starts = np.array([tr.press_s[0] for tr in trials])
    ends = np.array([tr.press_s[1] for tr in trials])
    press = RegionFits("press", "pulse", names, starts, ends, t, y, m, press_fit,
                       np.where(found, verdict, "undecided"), delta,
                       np.where(found, press_fit.status.astype(str), NO_REGIONS), detail)
    if "press" in regions:
        out["press"] = press
    if "slip" not in regions:
        return out

    t, y, m, idx = _region_arrays(trials, "slip", width)
    for row, (tr, i) in enumerate(zip(trials, idx, strict=True)):
        # the press response continues into the slip region (linear superposition)
        tail = press.curve(row, tr.t_s[i] - tr.press_s[0])
        y[row, :len(i)] = tr.net[i] - np.where(press.ok[row], tail, 0.0)
    m &= press.ok[:, None]
    slip_fit, verdict, delta = _fit("ramp", t, y, m, duration_s=None, order=order,
                                    options=options)
    status = np.where(press.ok, slip_fit.status.astype(str),
                      np.where(found, PRESS_FAILED, NO_REGIONS))
    verdict = np.where(press.ok, verdict, "undecided")
    starts = np.array([tr.slip_s[0] for tr in trials])
    ends = np.array([tr.slip_s[1] for tr in trials])
    out["slip"] = RegionFits("slip", "ramp", names, starts, ends, t, y, m, slip_fit, verdict,
                             delta, status, detail)
    return out


def fit_curves(
    curves: Sequence[tuple[ArrayLike, ArrayLike]],
    *,
    model: str,
    names: Sequence[str] | None = None,
    units: Sequence[str] | None = None,
    press_duration_s: float | None = None,
    order: bool = True,
    options: FitOptions | None = None,
) -> RegionFits:
    """Fit several response curves (e.g. users' two-column CSVs) with ``model`` in
    ``("pulse", "step", "ramp")``, all in one batched fit: ``curves`` is a sequence of
    ``(t_s, x)``, (n_i,) seconds from each input's start and the response. ``names`` label
    the rows (default ``curve_0``, ...), ``units`` give each response's unit (default
    ``"units"``). For ``"pulse"``, ``press_duration_s`` is the known T (None fits it)."""
    if model not in ("pulse", "step", "ramp"):
        raise ValueError(f"`model` (={model!r}) must be 'pulse', 'step' or 'ramp'.")
    if not curves:
        raise ValueError("`curves` is empty: nothing to fit.")
    _check_duration(press_duration_s)
    n = len(curves)
    names = tuple(names) if names is not None else tuple(f"curve_{i}" for i in range(n))
    units = tuple(units) if units is not None else (DEFAULT_UNITS,) * n
    if len(names) != n or len(units) != n:
        raise ValueError(f"`names` ({len(names)}) and `units` ({len(units)}) must have one "
                         f"entry per curve ({n}).")
    arrays = [(np.asarray(t, dtype=np.float64), np.asarray(x, dtype=np.float64))
              for t, x in curves]
    for i, (ti, xi) in enumerate(arrays):
        if ti.ndim != 1 or ti.shape != xi.shape:
            raise ValueError(f"curve {i}: `t_s` {ti.shape} and `x` {xi.shape} must be (n,) "
                             "arrays of the same length.")
    width = max(len(t) for t, _ in arrays)
    t, y, m = np.zeros((n, width)), np.zeros((n, width)), np.zeros((n, width), bool)
    for row, (ti, xi) in enumerate(arrays):
        t[row, :len(ti)], y[row, :len(xi)], m[row, :len(ti)] = ti, xi, True
    fit, verdict, delta, shape = _fit_shaped(model, t, y, m, duration_s=press_duration_s,
                                             order=order, options=options or FitOptions())
    starts = np.array([ti[0] for ti, _ in arrays])
    ends = np.array([ti[-1] for ti, _ in arrays])
    return RegionFits("curve", model, names, starts, ends, t, y, m, fit, verdict, delta,
                      fit.status.astype(str), units=units, relaxation=shape)


def fit_curve(
    t_s: ArrayLike,
    x: ArrayLike,
    *,
    model: str,
    name: str = "curve",
    units: str = DEFAULT_UNITS,
    press_duration_s: float | None = None,
    order: bool = True,
    options: FitOptions | None = None,
) -> RegionFits:
    """Fit one response curve: :func:`fit_curves` of ``[(t_s, x)]``."""
    return fit_curves([(t_s, x)], model=model, names=[name], units=[units],
                      press_duration_s=press_duration_s, order=order, options=options)


__all__ = ["COUNT_UNITS", "DEFAULT_UNITS", "NOT_TESTED", "NO_REGIONS", "PRESS_FAILED",
           "REGION_MODELS", "RegionFits", "fit_curve", "fit_curves", "fit_regions",
           "region_arrays"]
