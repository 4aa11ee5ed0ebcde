"""What a run's network was fed: the stream, its sample period, channel names and units.

Issue 10, item 3. A model trained on 100 Hz taxels gives a silently wrong answer on 8 kHz
data, or on data whose channels are other quantities. ``tactile train`` records the
:class:`InputSpec` of its training data in ``run.json`` (key ``input``); ``tactile
evaluate`` and ``tactile perturb`` refuse data whose sample period differs from it by more
than :data:`PERIOD_RTOL_MAX` (0.5 %) or whose selected channel names (in model order) or
units differ, and ``tactile compare`` refuses an evaluation whose metrics file records such
data. Between :data:`PERIOD_RTOL` (0.1 %) and 0.5 % the data are accepted with a note naming
the file and both rates (:func:`period_notes`): two recordings of one sensor differ that
much by their clocks (Xela sessions of one set at 59.78 and 59.88 Hz, each rate a median
over its file); another rate setting differs by 1 % or more.

The sample period of a trial is read with the stream (:func:`.data.read_trials`): the
sensor's ``sample_rate_hz`` when > 0, else the ``bin_s`` attribute of the stream or its
sensor, else the median step of ``t_s``; for event counts computed on the fly from events,
the config's ``data.bin_s``. Every trial of the files of one command must agree as well.
A trial whose period cannot be known (fewer than two samples and no rate attribute) is
left out of these checks; it gives no window longer than one sample anyway.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import InputError
from .data import TrialSeries

#: Largest relative difference of two sample periods that counts as the same rate.
PERIOD_RTOL = 1e-3
#: Largest relative difference accepted at all (with a note above :data:`PERIOD_RTOL`).
PERIOD_RTOL_MAX = 5e-3


@dataclass(frozen=True)
class InputSpec:
    """The input stream of a run (``run.json`` key ``input``) or of evaluation data.

    sample_period_s: seconds between samples (bin width for event counts); None when no
    trial tells it. channels, units: the selected channels in the order the model sees
    them, and their units as recorded in ``/sensors/<sensor>/channel_units`` (``""`` where
    the file records none). origin: ``"signal"`` (a stored stream) or ``"events"``
    (counted on the fly).
    """

    stream: str
    sample_period_s: float | None
    channels: tuple[str, ...]
    units: tuple[str, ...]
    sensor: str = ""
    origin: str = "signal"

    @property
    def sample_rate_hz(self) -> float | None:
        p = self.sample_period_s
        return None if p is None else 1.0 / p

    def as_dict(self) -> dict[str, Any]:
        return {"stream": self.stream, "sensor": self.sensor, "origin": self.origin,
                "sample_period_s": self.sample_period_s, "sample_rate_hz": self.sample_rate_hz,
                "channels": list(self.channels), "units": list(self.units)}

    @classmethod
    def from_dict(cls, d: Any, *, path: str | Path | None = None,
                  where: str = "input") -> InputSpec:
        """Read the ``input`` record back; a malformed one is an InputError naming
        ``path`` and the key."""
        try:
            if not isinstance(d, dict):
                raise TypeError("not a mapping")
            period = d["sample_period_s"]
            period = None if period is None else float(period)
            if period is not None and not (math.isfinite(period) and period > 0):
                raise ValueError(f"sample_period_s (={period}) must be > 0")
            channels = tuple(str(c) for c in d["channels"])
            units = tuple(str(u) for u in d["units"])
            if len(units) != len(channels):
                raise ValueError(f"{len(units)} units for {len(channels)} channels")
            return cls(str(d["stream"]), period, channels, units, str(d.get("sensor", "")),
                       str(d.get("origin", "signal")))
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"`{where}` is not a valid input record ({exc}); re-create the "
                             "run with `tactile train`", path=path) from None


def period_text(period_s: float | None) -> str:
    """``0.000125 s (8000 Hz)``; ``unknown`` for None."""
    if period_s is None or not math.isfinite(period_s):
        return "unknown"
    return f"{period_s:.6g} s ({1.0 / period_s:.6g} Hz)"


def same_period(a: float, b: float, rtol: float = PERIOD_RTOL) -> bool:
    """``a`` within ``rtol`` (default :data:`PERIOD_RTOL`) of ``b`` (relative to ``b``)."""
    return abs(a - b) <= rtol * abs(b)


def period_notes(trials: Sequence[TrialSeries], ref: float | None, whose: str) -> list[str]:
    """One note per file whose trials' sample period differs from ``ref`` by more than
    :data:`PERIOD_RTOL` (accepted up to :data:`PERIOD_RTOL_MAX`); ``whose``: what ``ref``
    is (``"the run's"``, ``"the first file's"``)."""
    if ref is None:
        return []
    seen: dict[tuple[str, float], None] = {}
    for t in trials:
        p = _period(t)
        if p is not None and not same_period(p, ref):
            seen.setdefault((str(t.file), p), None)
    return [f"{file}: sample period {period_text(p)} differs from {whose} {period_text(ref)} "
            f"by {100 * abs(p - ref) / ref:.2f} % (accepted up to "
            f"{100 * PERIOD_RTOL_MAX:g} %, as two clocks of one sensor differ; a window of "
            "the same samples spans that much more or less time)" for file, p in seen]


def _where(trial: TrialSeries, stream: str) -> str:
    if trial.origin == "events":
        return f"/trials/{trial.trial}/events (counted as {stream})"
    if trial.origin == "frames":
        return f"/trials/{trial.trial}/frames"
    return f"/trials/{trial.trial}/signals/{stream}"


def _period(trial: TrialSeries) -> float | None:
    p = trial.sample_period_s
    return p if math.isfinite(p) and p > 0 else None


def _names(values: Sequence[str]) -> str:
    return "[" + ", ".join(values) + "]"


def input_spec(trials: Sequence[TrialSeries], stream: str) -> InputSpec:
    """The input shared by every trial of ``trials`` (of one command's files).

    Raises :class:`InputError` naming the file and stream of the first trial whose sample
    period differs from the first known one by more than 0.5 % (:data:`PERIOD_RTOL_MAX`;
    :func:`period_notes` names those above 0.1 %), or whose channels or units differ from
    the first trial's.
    """
    if not trials:
        raise InputError("no trials to take the input stream from")
    first = trials[0]
    ref = next((t for t in trials if _period(t) is not None), first)
    ref_period = _period(ref)
    for t in trials:
        p = _period(t)
        if ref_period is not None and p is not None and not same_period(p, ref_period,
                                                                        PERIOD_RTOL_MAX):
            raise InputError(
                f"sample period {period_text(p)} differs from {period_text(ref_period)} "
                f"of {ref.key} by more than {100 * PERIOD_RTOL_MAX:g} %; resample the files "
                "to one rate or use them in separate runs", path=t.file, where=_where(t, stream))
        if t.channel_units != first.channel_units:
            raise InputError(
                f"channel units {_names(t.channel_units)} differ from "
                f"{_names(first.channel_units)} of {first.key} (channels "
                f"{_names(t.channel_names)}); convert the files to one unit or use them in "
                "separate runs", path=t.file, where=_where(t, stream))
    return InputSpec(stream, ref_period, first.channel_names,
                     first.channel_units, first.sensor, first.origin)


def mismatch(data: InputSpec, trained: InputSpec) -> tuple[str, str] | None:
    """How ``data`` differ from the run's input ``trained``: (what differs, with both
    values; what to do), or None when the sample periods are within 0.5 %
    (:data:`PERIOD_RTOL_MAX`; or one is unknown) and the channel names (order included) and
    units are equal."""
    p, ref = data.sample_period_s, trained.sample_period_s
    if p is not None and ref is not None and not same_period(p, ref, PERIOD_RTOL_MAX):
        return (f"sample period {period_text(p)} differs from the run's {period_text(ref)} "
                f"by more than {100 * PERIOD_RTOL_MAX:g} %", f"resample the data to "
                f"{1.0 / ref:.6g} Hz or retrain on it")
    if data.channels != trained.channels:
        return (f"channels {_names(data.channels)} differ from the run's "
                f"{_names(trained.channels)}", "rename the data's channels to the run's or "
                "retrain on it")
    if data.units != trained.units:
        return (f"channel units {_names(data.units)} of {_names(data.channels)} differ from "
                f"the run's {_names(trained.units)}", "convert the data to the run's units or "
                "retrain on it")
    return None


def trial_input(trial: TrialSeries, stream: str) -> InputSpec:
    """The :class:`InputSpec` of one trial."""
    return InputSpec(stream, _period(trial), trial.channel_names, trial.channel_units,
                     trial.sensor, trial.origin)


def check_input(trials: Sequence[TrialSeries], trained: InputSpec) -> None:
    """Raise :class:`InputError` for the first trial that is not data of the run's input
    (see :func:`mismatch`). The message names the file, the stream, both values and what
    to do (resample, or retrain)."""
    for t in trials:
        found = mismatch(trial_input(t, trained.stream), trained)
        if found is not None:
            raise InputError(f"{found[0]}; {found[1]}", path=t.file,
                             where=_where(t, trained.stream))


def unchecked_note(data: InputSpec, run_path: str | Path) -> str:
    """The note of an evaluation of a run whose run.json records no input."""
    return (f"{run_path}: run.json records no input sample period or channels (trained "
            f"before they were recorded), so the data's sample period "
            f"{period_text(data.sample_period_s)} "
            f"and channels {_names(data.channels)} were not checked against the training "
            "data's; retrain with this version to have them checked")


def checked_input(trials: Sequence[TrialSeries], stream: str, trained: InputSpec | None,
                  run_path: str | Path) -> tuple[InputSpec, list[str]]:
    """The data's :class:`InputSpec` after the checks of ``tactile evaluate`` and
    ``tactile perturb``: every trial against the run's input (when the run records one)
    and against each other. Returns the spec and the notes to report (one when the run
    records no input, so nothing was checked against it; one per file whose sample period
    is accepted but not the run's, :func:`period_notes`)."""
    if trained is not None:
        check_input(trials, trained)
    spec = input_spec(trials, stream)
    if trained is None:
        return spec, [unchecked_note(spec, run_path)]
    return spec, period_notes(trials, trained.sample_period_s, "the run's")


def input_record(spec: InputSpec, trained: InputSpec | None) -> dict[str, Any]:
    """The ``input`` entry of metrics.json and perturb.json: the data's input and
    ``checked_against_run`` (false for a run whose run.json records no input)."""
    return {**spec.as_dict(), "checked_against_run": trained is not None}


__all__ = ["PERIOD_RTOL", "PERIOD_RTOL_MAX", "InputSpec", "check_input", "checked_input",
           "input_record", "period_notes",
           "input_spec", "mismatch", "period_text", "same_period", "trial_input",
           "unchecked_note"]
