"""Windowed reads of one trial's events, in trial seconds, through the millisecond index.

The spatial chain (frames, ROI centroids, slip rates) walks a trial window by window; this
module opens the file once, resolves the trial's time origin (events attribute
``t_origin_us``, else ``ms_index_origin_us``: the rule of ``tactile_cli.events.accumulate.
trial_origin_us``, repeated so the spatial chain does not import the event-count package
and its model dependencies) and returns the events of ``[t0_s, t1_s)`` with two look-ups
in ``ms_to_idx`` and one slice per column, so memory is bounded by the window.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

from ..errors import InputError
from ..store.reader import attr_value, open_tactile
from ..store.validate import check_readable


@dataclass(frozen=True)
class Sensor:
    """The event camera of a trial: name, grid size and the optics attributes it carries.

    width_px, height_px: sensor grid; optics: ``pixel_pitch_m``, ``focal_length_m`` and
    ``strip_distance_m`` when the sensor group has them (metres), else absent.
    """

    name: str
    width_px: int
    height_px: int
    optics: dict[str, float]


@dataclass(frozen=True)
class EventWindow:
    """Events of one window: x, y (n,) int64 px; t_us (n,) int64 camera clock; p (n,) int8."""

    x: np.ndarray
    y: np.ndarray
    t_us: np.ndarray
    p: np.ndarray

    @property
    def n(self) -> int:
        return int(self.t_us.shape[0])


class TrialEvents:
    """One trial's events, opened for windowed reads; use as a context manager.

    Raises :class:`InputError` for a missing or unreadable file, an unknown trial or a
    trial without events.
    """

    def __init__(self, path: str | Path, trial: str):
        self.path = Path(path)
        self.trial = trial
        if not self.path.exists():
            raise InputError("file not found", path=self.path)
        self._h5 = open_tactile(self.path)
        try:
            self._open()
        except BaseException:
            self._h5.close()
            raise

    def _open(self) -> None:
        trials = self._h5["trials"]
        if self.trial not in trials:
            names = list(trials.keys())
            shown = ", ".join(names[:10]) + (f" and {len(names) - 10} more"
                                             if len(names) > 10 else "")
            raise InputError(f"no trial {self.trial!r}; the file has {len(names)} trial(s): "
                             f"{shown or 'none'}", path=self.path)
        group = trials[self.trial]
        if "events" not in group:
            raise InputError("trial has no events (the spatial chain needs an event-camera "
                             "recording)", path=self.path, where=f"/trials/{self.trial}")
        self._events = group["events"]
        self.n_events = int(self._events["t"].shape[0])
        if self.n_events == 0:
            raise InputError("trial has no events", path=self.path,
                             where=f"/trials/{self.trial}/events")
        sensor_name = attr_value(self._events.attrs["sensor"])
        s = self._h5["sensors"][sensor_name].attrs
        optics = {k: float(s[k]) for k in ("pixel_pitch_m", "focal_length_m", "strip_distance_m")
                  if k in s}
        self.sensor = Sensor(sensor_name, int(s["width_px"]), int(s["height_px"]), optics)
        attrs = self._events.attrs
        self.origin_us = int(attrs["t_origin_us"] if "t_origin_us" in attrs
                             else attrs["ms_index_origin_us"])
        self._index_origin_us = int(self._events.attrs["ms_index_origin_us"])
        self._ms_to_idx = self._events["ms_to_idx"][()]
        t_ds = self._events["t"]
        self.t_last_us = int(t_ds[self.n_events - 1])
        duration_s = float(group.attrs.get("duration_s", 0.0))
        #: trial end in trial seconds: the recorded duration, or the last event if later
        self.end_s = max(duration_s, (self.t_last_us + 1 - self.origin_us) * 1e-6)
        self.labels = {k: attr_value(v) for k, v in group["labels"].attrs.items()} \
            if "labels" in group else {}

    def __enter__(self) -> TrialEvents:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        self._h5.close()

    def _index_at_or_after(self, t_us: int) -> int:
        """Index of the first event with ``t >= t_us`` (exact: the ms index narrows the
        search to one millisecond, a binary search finishes it)."""
        ms = (t_us - self._index_origin_us) // 1000
        if ms <= 0:
            lo = 0
            if t_us <= self._index_origin_us:
                return 0
        elif ms >= self._ms_to_idx.shape[0]:
            return self.n_events
        else:
            lo = int(self._ms_to_idx[ms])
        hi = (int(self._ms_to_idx[ms + 1]) if 0 <= ms + 1 < self._ms_to_idx.shape[0]
              else self.n_events)
        if hi <= lo:
            return lo
        t = self._events["t"][lo:hi]
        return lo + int(np.searchsorted(t, t_us, side="left"))

    def window_us(self, t0_us: int, t1_us: int) -> EventWindow:
        """Events with camera timestamps ``t0_us <= t < t1_us``."""
        lo = self._index_at_or_after(int(t0_us))
        hi = self._index_at_or_after(int(t1_us)) if t1_us > t0_us else lo
        ev = self._events
        return EventWindow(
            ev["x"][lo:hi].astype(np.int64),
            ev["y"][lo:hi].astype(np.int64),
            ev["t"][lo:hi],
            ev["p"][lo:hi],
        )

    def window(self, t0_s: float, t1_s: float) -> EventWindow:
        """Events of ``[t0_s, t1_s)``, seconds from the trial's time origin."""
        return self.window_us(self.to_us(t0_s), self.to_us(t1_s))

    def to_us(self, t_s: float) -> int:
        """Trial seconds -> camera timestamp (us)."""
        return self.origin_us + round(t_s * 1e6)

    def annotations(self) -> list[tuple[float, float, str]]:
        """``(start_s, end_s, label)`` of the trial's annotations (empty when none)."""
        group = self._h5["trials"][self.trial]
        if "annotations" not in group:
            return []
        ann = group["annotations"]
        return [(float(s), float(e), str(lab)) for s, e, lab in
                zip(ann["start_s"][()], ann["end_s"][()], ann["label"].asstr()[()],
                    strict=True)]


def trial_list(path: str | Path) -> list[str]:
    """Names of the trials of a tactile file that have events, in file order."""
    path = Path(path)
    if not path.exists():
        raise InputError("file not found", path=path)
    try:
        check_readable(path)
        with h5py.File(path, "r") as h5:
            return [name for name, g in h5["trials"].items() if "events" in g]
    except OSError as exc:
        raise InputError(f"not a readable HDF5 file ({exc})", path=path) from None


def region_of(
    annotations: list[tuple[float, float, str]], label: str
) -> tuple[float, float] | None:
    """``(start_s, end_s)`` of the first annotation named ``label`` (case-insensitive)."""
    for start_s, end_s, name in annotations:
        if name.strip().lower() == label:
            return start_s, end_s
    return None
