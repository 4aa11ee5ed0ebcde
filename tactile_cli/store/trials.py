"""The one trial reader: open a tactile HDF5 file once and hand out :class:`Trial` objects.

Every package that reads recordings goes through this module; no module outside
``store/`` imports h5py. A :class:`TactileFile` is opened once (schema version gate
included) and used as a context manager; its :class:`Trial` objects read labels,
annotations, the split, events (windows by trial time through ``ms_to_idx``), sampled
streams (data, time base, rate, channel names and units, per-sample labels) and frames
(one at a time, never the whole sequence) lazily, and the file's derived groups
(``/derived/<kind>/<name>``) are read as columns.

Time origin, one rule for every reader: a trial's time 0 is the events attribute
``t_origin_us`` (the camera timestamp at trial time 0, written by ingest), else
``ms_index_origin_us`` (the first event, files written before that attribute). Event
windows, annotations, ``t_s`` of signals and frames are all in seconds from that origin.

Errors: a missing node, a wrong dtype or an HDF5 read failure (a corrupt chunk, a bad
checksum) is one :class:`~tactile_cli.errors.InputError` naming the file and the HDF5 path
being read, never a library traceback. Content that ``tactile validate`` rejects is refused
where it is read anyway, with cheap vectorised checks: retyped sensor attributes, events
outside the sensor, out of time order or of a polarity other than -1/+1, non-finite or
non-numeric samples, time bases that do not increase, class codes outside their classes,
annotations that end before they start. The message names the HDF5 path and points at
``tactile validate``, which lists every problem of the file.
"""

from __future__ import annotations

import re
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any, NamedTuple

import h5py
import numpy as np

from ..errors import InputError
from ..input_guard import note_input
from .spec import load_spec
from .validate import check_readable

#: Events read per block by :meth:`TrialEvents.blocks` (9 MiB of ``t`` and ``p``).
READ_BLOCK = 1 << 20


def attr_value(value: Any) -> Any:
    """An HDF5 attribute (or string dataset element) as a plain Python value: bytes
    decoded as UTF-8, numpy scalars as Python scalars, arrays as lists of such values."""
    if isinstance(value, bytes):
        return value.decode("utf-8", "replace")
    if isinstance(value, np.ndarray):
        return [attr_value(v) for v in value.tolist()]
    if isinstance(value, np.generic):
        return value.item()
    return value


def _flat(exc: BaseException) -> str:
    """An HDF5 or OS error message on one line."""
    return " ".join(str(exc).split()) or exc.__class__.__name__


@contextmanager
def _reading(path: Path, where: str) -> Iterator[None]:
    """Turn a failure to read ``where`` (missing node, wrong type, corrupt data) into one
    :class:`InputError` line naming the file and the HDF5 path."""
    try:
        yield
    except InputError:
        raise
    except KeyError as exc:
        raise InputError(f"missing ({_flat(exc)}); check the file with `tactile validate`",
                         path=path, where=where) from None
    except (OSError, RuntimeError, ValueError, TypeError, IndexError, AttributeError) as exc:
        raise InputError(f"cannot be read ({exc.__class__.__name__}: {_flat(exc)}); check the "
                         "file with `tactile validate`", path=path, where=where) from None


#: An annotation may start this long (plus the trial's length again) after the trial's
#: recorded end (hand-made annotations may outlast a short recording); one that starts
#: later is damage (intervals shifted off the trial's clock).
ANNOTATION_SLACK_S = 60.0

#: Rates above this are damage, not a sensor (the schema's maximum of ``sample_rate_hz``).
MAX_RATE_HZ = 1e9

#: Appended to a content error: the validator lists every problem, not only the first.
_SEE_VALIDATE = "`tactile validate FILE` lists every problem of the file"


def _content_error(path: Path, where: str, what: str) -> InputError:
    """Content the schema forbids, found while reading ``where``."""
    return InputError(f"{what}; {_SEE_VALIDATE}", path=path, where=where)


def _is_int(value: Any) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) \
        and not isinstance(value, (bool, np.bool_))


def _number_attr(path: Path, where: str, attrs: dict[str, Any], key: str,
                 default: float | None = None, *, minimum: float | None = None,
                 maximum: float | None = None) -> float:
    """Attribute ``key`` as a finite float (``default`` when absent)."""
    if key not in attrs and default is not None:
        return default
    if key not in attrs:
        raise _content_error(path, where, f"attribute {key!r} is missing")
    value = attrs[key]
    if not _is_number(value) or not np.isfinite(value):
        raise _content_error(path, where, f"attribute {key!r} is {value!r}; expected a finite "
                                          "number")
    if minimum is not None and value < minimum:
        raise _content_error(path, where, f"attribute {key!r} is {value!r}; expected a number "
                                          f">= {minimum}")
    if maximum is not None and value > maximum:
        raise _content_error(path, where, f"attribute {key!r} is {value!r}; expected at most "
                                          f"{maximum:g}")
    return float(value)


def _strings(path: Path, where: str, ds: h5py.Dataset) -> tuple[str, ...]:
    """A 1-D string dataset as a tuple of str."""
    if h5py.check_string_dtype(ds.dtype) is None or ds.ndim != 1:
        raise _content_error(path, where, f"holds {ds.dtype} of shape {ds.shape}; expected a "
                                          "1-D list of strings")
    return tuple(str(c) for c in ds.asstr()[()])


def _check_columns(path: Path, where: str, columns: dict[str, np.ndarray]) -> None:
    """1-D columns of one length (a table read from a group)."""
    lengths = {k: (v.shape[0] if v.ndim else None) for k, v in columns.items()}
    if len({n for n in lengths.values()}) > 1:
        desc = ", ".join(f"{k}={'scalar' if n is None else n}" for k, n in lengths.items())
        raise _content_error(path, where, f"columns of unequal length ({desc})")


def unknown_trial(path: str | Path, trial: str, names: Sequence[str]) -> InputError:
    """The error for a trial name that is not in the file, listing (some of) its trials."""
    shown = ", ".join(names[:10]) + (f" and {len(names) - 10} more" if len(names) > 10 else "")
    return InputError(f"no trial {trial!r}; the file has {len(names)} trial(s): "
                      f"{shown or 'none'}", path=path)


class Annotation(NamedTuple):
    """One annotated interval of a trial, seconds from the trial's time origin."""

    start_s: float
    end_s: float
    label: str


@dataclass(frozen=True)
class Sensor:
    """One ``/sensors/<name>`` group.

    sample_rate_hz: 0 for event cameras. channel_names, channel_units: one per channel
    (empty for sensors without channels). width_px, height_px: camera grid, None for
    sensors without one. attrs: every attribute, decoded (``bin_s``, optics, ...).
    """

    name: str
    kind: str
    sample_rate_hz: float
    channel_names: tuple[str, ...] = ()
    channel_units: tuple[str, ...] = ()
    width_px: int | None = None
    height_px: int | None = None
    attrs: dict[str, Any] = field(default_factory=dict)

    @property
    def optics(self) -> dict[str, float]:
        """``pixel_pitch_m``, ``focal_length_m``, ``strip_distance_m`` where present (m)."""
        return {k: float(self.attrs[k]) for k in ("pixel_pitch_m", "focal_length_m",
                                                   "strip_distance_m") if k in self.attrs}


@dataclass(frozen=True)
class SampleLabel:
    """Per-sample labels of a stream: values (n,) and their class names (None when the
    values are numbers rather than class codes)."""

    values: np.ndarray
    classes: tuple[str, ...] | None


@dataclass(frozen=True)
class Signal:
    """One sampled stream ``/trials/<trial>/signals/<name>``.

    data: (n_samples, n_channels) float32 in ``channel_units``. t_s: (n_samples,) float64
    seconds from the trial's time origin. sensor: the stream's sensor. channel_names,
    channel_units: of the columns in ``data`` (a selection when channels were asked for).
    sample_labels: name -> :class:`SampleLabel`. attrs: the stream group's attributes.
    """

    name: str
    where: str
    sensor: Sensor
    data: np.ndarray
    t_s: np.ndarray
    channel_names: tuple[str, ...]
    channel_units: tuple[str, ...]
    sample_labels: dict[str, SampleLabel]
    attrs: dict[str, Any]

    @property
    def sample_period_s(self) -> float:
        """Seconds between samples: the sensor's rate, else the stream's ``bin_s``
        attribute (or its sensor's), else the median step of ``t_s`` (NaN with fewer than
        two samples)."""
        if self.sensor.sample_rate_hz > 0:
            return 1.0 / self.sensor.sample_rate_hz
        for attrs in (self.attrs, self.sensor.attrs):
            if float(attrs.get("bin_s", 0) or 0) > 0:
                return float(attrs["bin_s"])
        if self.t_s.shape[0] < 2:
            return float("nan")
        return float(np.median(np.diff(self.t_s)))

    @property
    def sample_rate_hz(self) -> float:
        """``1 / sample_period_s``."""
        return 1.0 / self.sample_period_s


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
    """The events of one trial, for windowed and block reads (nothing is read up front
    but the millisecond index and a few attributes).

    origin_us: camera timestamp of the trial's time 0. n_events: events stored.
    t_last_us: timestamp of the last event. end_s: trial end in trial seconds (the
    recorded duration, or just after the last event when that is later).
    """

    def __init__(self, trial: Trial):
        self.trial = trial
        self.path = trial.path
        self.where = f"{trial.where}/events"
        with _reading(self.path, self.where):
            self._group = trial._group["events"]
            self._t = self._group["t"]
            self.n_events = int(self._t.shape[0])
            for col in ("x", "y", "t", "p"):
                ds = self._group[col]
                if ds.ndim != 1 or ds.dtype.kind not in "iu":
                    raise _content_error(self.path, f"{self.where}/{col}",
                                         f"holds {ds.dtype} of shape {ds.shape}; expected 1-D "
                                         "integers")
                if ds.shape[0] != self.n_events:
                    raise _content_error(self.path, f"{self.where}/{col}",
                                         f"has {ds.shape[0]} events, t has {self.n_events}")
            attrs = {k: attr_value(v) for k, v in self._group.attrs.items()}
            self.sensor_name = str(attrs["sensor"])
            for key in ("ms_index_origin_us", "t_origin_us"):
                if key in attrs and not _is_int(attrs[key]):
                    raise _content_error(self.path, self.where, f"attribute {key!r} is "
                                         f"{attrs[key]!r}; expected an integer (us)")
            self._index_origin_us = int(attrs["ms_index_origin_us"])
            self.origin_us = int(attrs["t_origin_us"] if "t_origin_us" in attrs
                                 else self._index_origin_us)
            self._ms_to_idx = self._group["ms_to_idx"][()]
            self.t_last_us = int(self._t[self.n_events - 1]) if self.n_events else self.origin_us
        idx = self._ms_to_idx
        if idx.ndim != 1 or idx.dtype.kind not in "iu" or (idx.size and (
                idx[0] != 0 or (np.diff(idx) < 0).any() or idx[-1] > self.n_events)):
            raise _content_error(self.path, f"{self.where}/ms_to_idx",
                                 "must be 1-D integers starting at 0, never decreasing and at "
                                 "most the event count")
        self._check_index_ends()
        duration_s = trial.duration_s
        last_s = (self.t_last_us + 1 - self.origin_us) * 1e-6 if self.n_events else 0.0
        self.end_s = max(duration_s, last_s)

    def _check_index_ends(self) -> None:
        """The first and last entries of the ms index point at the first event at or after
        their millisecond (as `tactile validate` checks on a sample of entries): events
        shifted away from the trial's clock (damage) are refused on open, reading four
        events at most."""
        idx, n = self._ms_to_idx, self.n_events
        if not n or not idx.size:
            return
        for k in sorted({0, idx.size - 1}):
            i, edge = int(idx[k]), self._index_origin_us + 1000 * k
            with _reading(self.path, f"{self.where}/t"):
                at = int(self._t[i]) if i < n else None
                before = int(self._t[i - 1]) if i > 0 else None
            if (at is not None and at < edge) or (before is not None and before >= edge):
                bad, value = (i, at) if at is not None and at < edge else (i - 1, before)
                raise _content_error(self.path, f"{self.where}/t", f"event {bad} at {value} us "
                                     f"does not fit the millisecond index (entry {k} of "
                                     f"ms_to_idx starts at {edge} us, ms_index_origin_us + "
                                     f"{k} ms): the event times are off the trial's clock")

    @cached_property
    def sensor(self) -> Sensor:
        """The event camera (its grid and optics)."""
        return self.trial.file.sensor(self.sensor_name)

    def _check_block(self, start: int, t: np.ndarray, p: np.ndarray,
                     x: np.ndarray | None = None, y: np.ndarray | None = None,
                     prev_t: int | None = None) -> None:
        """Events ``start:start + len(t)`` as the schema has them: ``t`` non-decreasing
        (``prev_t``: the event before), ``p`` in {-1, +1}, ``x``/``y`` inside the sensor."""
        def first(bad: np.ndarray) -> int:
            return int(np.flatnonzero(bad)[0])

        def fail(col: str, i: int, what: str) -> InputError:
            return _content_error(self.path, f"{self.where}/{col}", f"event {start + i}: {what}")

        # reductions first (no temporary masks); the mask only to name the first bad event
        if p.size and (p.min() < -1 or p.max() > 1 or not p.all()):
            i = first((p != 1) & (p != -1))
            raise fail("p", i, f"polarity {p[i]} is not -1 or +1")
        if t.size:
            if prev_t is not None and t[0] < prev_t:
                raise fail("t", 0, f"time {t[0]} us comes after a later time ({prev_t} us); "
                                   "events must be sorted by time")
            back = t[1:] < t[:-1]
            if back.any():
                i = first(back) + 1
                raise fail("t", i, f"time {t[i]} us comes after a later time ({t[i - 1]} us); "
                                   "events must be sorted by time")
        for col, v, key in (("x", x, "width_px"), ("y", y, "height_px")):
            limit = getattr(self.sensor, key) if v is not None and v.size else None
            if limit is not None and v.max() >= limit:
                i = first(v >= limit)
                raise fail(col, i, f"{col} = {v[i]} is outside the sensor ({key} {limit} of "
                                   f"/sensors/{self.sensor.name})")

    def to_us(self, t_s: float) -> int:
        """Trial seconds -> camera timestamp (us)."""
        return self.origin_us + round(t_s * 1e6)

    def index_at_or_after(self, t_us: int) -> int:
        """Index of the first event with ``t >= t_us``: the ms index narrows the search to
        one millisecond, a binary search in that millisecond finishes it."""
        t_us = int(t_us)
        ms = (t_us - self._index_origin_us) // 1000
        if t_us <= self._index_origin_us:
            return 0
        if ms >= self._ms_to_idx.shape[0]:
            return self.n_events
        lo = int(self._ms_to_idx[ms])
        hi = (int(self._ms_to_idx[ms + 1]) if ms + 1 < self._ms_to_idx.shape[0]
              else self.n_events)
        if hi <= lo:
            return lo
        with _reading(self.path, f"{self.where}/t"):
            t = self._t[lo:hi]
        return lo + int(np.searchsorted(t, t_us, side="left"))

    def slice(self, lo: int, hi: int) -> EventWindow:
        """Events ``lo:hi`` in storage order."""
        g = self._group
        with _reading(self.path, self.where):
            w = EventWindow(g["x"][lo:hi].astype(np.int64), g["y"][lo:hi].astype(np.int64),
                            g["t"][lo:hi].astype(np.int64), g["p"][lo:hi])
        self._check_block(lo, w.t_us, w.p, w.x, w.y)
        return w

    def window_us(self, t0_us: int, t1_us: int) -> EventWindow:
        """Events with camera timestamps ``t0_us <= t < t1_us``."""
        lo = self.index_at_or_after(t0_us)
        hi = self.index_at_or_after(t1_us) if t1_us > t0_us else lo
        return self.slice(lo, hi)

    def window(self, t0_s: float, t1_s: float) -> EventWindow:
        """Events of ``[t0_s, t1_s)``, seconds from the trial's time origin."""
        return self.window_us(self.to_us(t0_s), self.to_us(t1_s))

    def all(self) -> EventWindow:
        """Every event of the trial (memory grows with the recording: prefer windows or
        :meth:`blocks` for long ones)."""
        return self.slice(0, self.n_events)

    def blocks(self, start: int = 0, block: int = READ_BLOCK
               ) -> Iterator[tuple[np.ndarray, np.ndarray]]:
        """``(t_us, p)`` arrays of at most ``block`` events each, from index ``start``.

        ``x`` and ``y`` are read too, only to refuse events outside the sensor (a count
        of such events would be a count of damage)."""
        g = self._group
        prev: int | None = None
        for a in range(start, self.n_events, block):
            b = min(a + block, self.n_events)
            with _reading(self.path, self.where):
                t, p, x, y = g["t"][a:b], g["p"][a:b], g["x"][a:b], g["y"][a:b]
            self._check_block(a, t, p, x, y, prev_t=prev)
            prev = int(t[-1]) if t.size else prev
            yield t, p


class Frames:
    """The image frames of one trial, read one at a time.

    n_frames; t_s (n_frames,) float64 seconds from the trial's time origin; shape
    ``(height, width, 3)``; :attr:`reference` the no-contact frame (uint8). Iterating
    yields ``(t_s, image)`` pairs, each image read when it is reached.
    """

    def __init__(self, trial: Trial):
        self.path = trial.path
        self.where = f"{trial.where}/frames"
        with _reading(self.path, self.where):
            self._group = trial._group["frames"]
            self._images = self._group["images"]
            self.n_frames = int(self._images.shape[0])
            self.shape = tuple(int(s) for s in self._images.shape[1:])
            self.t_s = np.asarray(self._group["t_s"][()], dtype=np.float64)
            self.sensor_name = str(attr_value(self._group.attrs.get("sensor", "")))
        for name, ndim in (("images", 4), ("reference", 3)):
            with _reading(self.path, f"{self.where}/{name}"):
                ds = self._group[name] if name in self._group else None
                if ds is not None and (ds.dtype != np.uint8 or ds.ndim != ndim
                                       or ds.shape[-1] != 3):
                    raise _content_error(self.path, f"{self.where}/{name}", f"holds {ds.dtype} "
                                         f"of shape {ds.shape}; expected uint8 RGB images ("
                                         f"{'n_frames, ' if ndim == 4 else ''}height, width, 3)")
        if self._images.ndim != 4 or self.t_s.shape != (self.n_frames,):
            raise _content_error(self.path, self.where, f"images {self._images.shape} and t_s "
                                 f"{self.t_s.shape} do not match (n_frames, height, width, 3)")
        with _reading(self.path, f"{self.where}/reference"):
            ref = self._group["reference"] if "reference" in self._group else None
        if ref is not None and tuple(ref.shape) != self.shape:
            raise _content_error(self.path, f"{self.where}/reference", f"is {tuple(ref.shape)}; "
                                 f"the images are {self.shape} (height, width, 3)")
        if not np.isfinite(self.t_s).all() or (np.diff(self.t_s) < 0).any():
            raise _content_error(self.path, f"{self.where}/t_s", "frame times must be finite "
                                 "and must not decrease")

    def __len__(self) -> int:
        return self.n_frames

    @cached_property
    def reference(self) -> np.ndarray:
        """(height, width, 3) uint8 no-contact frame."""
        with _reading(self.path, f"{self.where}/reference"):
            return self._group["reference"][()]

    def __getitem__(self, k: int) -> np.ndarray:
        """Frame ``k``: (height, width, 3) uint8."""
        if not -self.n_frames <= k < self.n_frames:
            raise IndexError(f"frame {k} of {self.n_frames}")
        with _reading(self.path, f"{self.where}/images"):
            return self._images[k]

    def __iter__(self) -> Iterator[tuple[float, np.ndarray]]:
        for k in range(self.n_frames):
            yield float(self.t_s[k]), self[k]


class Trial:
    """One ``/trials/<name>`` group of an open :class:`TactileFile`; valid while the file
    is open. Attributes are read when first asked for."""

    def __init__(self, file: TactileFile, name: str):
        self.file = file
        self.name = name
        self.path = file.path
        self.where = f"/trials/{name}"
        with _reading(self.path, self.where):
            self._group = file._h5["trials"][name]

    def __repr__(self) -> str:
        return f"Trial({self.path.name!r}, {self.name!r})"

    @property
    def key(self) -> str:
        """``<file name>/<trial>``: how a trial is named across files."""
        return f"{self.path.name}/{self.name}"

    @cached_property
    def labels(self) -> dict[str, Any]:
        """The trial's labels (``labels`` attributes), decoded; empty when it has none."""
        with _reading(self.path, f"{self.where}/labels"):
            if "labels" not in self._group:
                return {}
            return {k: attr_value(v) for k, v in self._group["labels"].attrs.items()}

    @cached_property
    def split(self) -> str:
        """``"train"``, ``"val"``, ``"test"`` or ``""`` (not assigned)."""
        with _reading(self.path, self.where):
            return str(attr_value(self._group.attrs.get("split", "")))

    @cached_property
    def duration_s(self) -> float:
        """The recorded duration, seconds (0 when not recorded)."""
        with _reading(self.path, self.where):
            attrs = {"duration_s": attr_value(self._group.attrs["duration_s"])} \
                if "duration_s" in self._group.attrs else {}
        return _number_attr(self.path, self.where, attrs, "duration_s", minimum=0.0)

    @cached_property
    def attrs(self) -> dict[str, Any]:
        """Every attribute of the trial group, decoded."""
        with _reading(self.path, self.where):
            return {k: attr_value(v) for k, v in self._group.attrs.items()}

    @cached_property
    def annotations(self) -> list[Annotation]:
        """The trial's annotated intervals in file order (empty when it has none)."""
        where = f"{self.where}/annotations"
        with _reading(self.path, where):
            if "annotations" not in self._group:
                return []
            ann = self._group["annotations"]
            starts = np.asarray(ann["start_s"][()], dtype=np.float64)
            ends = np.asarray(ann["end_s"][()], dtype=np.float64)
            labels = _strings(self.path, f"{where}/label", ann["label"])
        _check_columns(self.path, where, {"start_s": starts, "end_s": ends,
                                          "label": np.asarray(labels)})
        bad = ~np.isfinite(starts) | ~np.isfinite(ends) | (ends < starts)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise _content_error(self.path, where, f"row {i} ({labels[i]!r}) runs from "
                                 f"{float(starts[i])!r} s to {float(ends[i])!r} s; an interval "
                                 "needs finite times and must not end before it starts")
        end_s = self._recorded_end_s() if starts.size else 0.0
        late = starts > 2 * end_s + ANNOTATION_SLACK_S
        if end_s > 0 and late.any():
            i = int(np.flatnonzero(late)[0])
            raise _content_error(self.path, where, f"row {i} ({labels[i]!r}) starts at "
                                 f"{float(starts[i])!r} s, after the trial's end ({end_s:g} s: "
                                 "its duration_s, last event or last sample)")
        return [Annotation(float(s), float(e), str(lab))
                for s, e, lab in zip(starts, ends, labels, strict=True)]

    def _recorded_end_s(self) -> float:
        """The trial's end, seconds: the latest of its ``duration_s``, its last event and
        the last sample of each stream (0 when none is known); reads a few values only."""
        end_s = self.duration_s
        if self.has_events:
            end_s = max(end_s, self.events.end_s)
        for name in self.signal_names:
            where = f"{self.where}/signals/{name}/t_s"
            with _reading(self.path, where):
                ds = self._group["signals"][name]["t_s"]
                last = ds[-1] if ds.ndim == 1 and ds.shape[0] and ds.dtype.kind in "iuf" \
                    else None
            if last is not None and np.isfinite(last):
                end_s = max(end_s, float(last))
        return end_s

    def annotation(self, label: str) -> Annotation | None:
        """The first annotation named ``label`` (case and surrounding spaces ignored)."""
        want = label.strip().lower()
        return next((a for a in self.annotations if a.label.strip().lower() == want), None)

    # -- events ------------------------------------------------------------------------------
    @property
    def has_events(self) -> bool:
        """Whether the trial has an events group (it may still hold no event)."""
        return "events" in self._group

    @cached_property
    def events(self) -> TrialEvents:
        """The trial's events; InputError when it has none."""
        if not self.has_events:
            raise InputError("trial has no events (an event-camera recording is needed)",
                             path=self.path, where=self.where)
        return TrialEvents(self)

    # -- sampled streams ---------------------------------------------------------------------
    @cached_property
    def signal_names(self) -> list[str]:
        """Names of the trial's sampled streams, in file order."""
        with _reading(self.path, f"{self.where}/signals"):
            return list(self._group["signals"].keys()) if "signals" in self._group else []

    def has_signal(self, name: str) -> bool:
        return name in self.signal_names

    def signal_sensor(self, name: str) -> Sensor:
        """The sensor of stream ``name`` (reads no samples)."""
        where = f"{self.where}/signals/{name}"
        self._require_signal(name)
        with _reading(self.path, where):
            sensor = str(attr_value(self._group["signals"][name].attrs["sensor"]))
        return self.file.sensor(sensor)

    def _require_signal(self, name: str) -> None:
        if name not in self.signal_names:
            raise InputError(f"trial has no stream {name!r} (streams: "
                             f"{', '.join(self.signal_names) or 'none'})",
                             path=self.path, where=self.where)

    def sample_labels(self, name: str) -> dict[str, SampleLabel]:
        """The per-sample labels of stream ``name`` without its samples: label name ->
        :class:`SampleLabel` (all samples). InputError naming the dataset when one is not
        a 1-D dataset of numbers or holds a class code outside its classes."""
        self._require_signal(name)
        where = f"{self.where}/signals/{name}"
        with _reading(self.path, where):
            labels = _read_sample_labels(self.path, where, self._group["signals"][name],
                                         slice(None))
        for key, lab in labels.items():
            _check_codes(self.path, f"{where}/sample_labels/{key}", lab)
        return labels

    def signal(self, name: str, *, channels: Sequence[str] | None = None,
               rows: slice | None = None) -> Signal:
        """Stream ``name``: its samples (all channels, or the named ``channels`` in that
        order), time base, sensor with rate, channel names and units, and per-sample
        labels. ``rows`` reads a slice of samples only. InputError naming the stream when
        it, a channel or a dataset is missing."""
        self._require_signal(name)
        where = f"{self.where}/signals/{name}"
        sensor = self.signal_sensor(name)
        rows = rows if rows is not None else slice(None)
        with _reading(self.path, where):
            group = self._group["signals"][name]
            for key in ("data", "t_s"):
                kind = group[key].dtype.kind
                if kind not in "iuf":
                    raise _content_error(self.path, f"{where}/{key}", f"holds {group[key].dtype}; "
                                         "expected numbers")
            data = group["data"][rows]
            t_s = np.asarray(group["t_s"][rows], dtype=np.float64)
            attrs = {k: attr_value(v) for k, v in group.attrs.items()}
            labels = _read_sample_labels(self.path, where, group, rows)
        if data.ndim != 2:
            raise InputError(f"data has shape {data.shape}; expected (n_samples, n_channels)",
                             path=self.path, where=f"{where}/data")
        _check_samples(self.path, where, data, t_s, labels)
        if "sample_rate_hz" in attrs:
            rate = _number_attr(self.path, where, attrs, "sample_rate_hz", maximum=MAX_RATE_HZ)
            if rate <= 0:
                raise _content_error(self.path, where, f"attribute 'sample_rate_hz' is {rate!r}; "
                                     "expected a rate > 0")
        if not sensor.channel_names:
            raise _content_error(self.path, f"{where}/data", f"has {data.shape[1]} columns but "
                                 f"sensor {sensor.name!r} names no channels (channel_names)")
        names = sensor.channel_names
        units = sensor.channel_units or ("",) * len(names)
        if len(names) != data.shape[1]:
            raise InputError(f"data has {data.shape[1]} channels but sensor {sensor.name!r} "
                             f"names {len(names)}", path=self.path, where=f"{where}/data")
        if channels is not None:
            columns = []
            for ch in channels:
                if ch not in names:
                    raise InputError(f"channel {ch!r} is not a channel of sensor "
                                     f"{sensor.name!r} (channels: {', '.join(names)})",
                                     path=self.path, where=where)
                columns.append(names.index(ch))
            data = data[:, columns]
            names = tuple(names[c] for c in columns)
            units = tuple(units[c] for c in columns) if len(units) > max(columns, default=-1) \
                else ("",) * len(columns)
        return Signal(name, where, sensor, np.asarray(data, dtype=np.float32), t_s,
                      tuple(names), tuple(units), labels, attrs)

    # -- frames ------------------------------------------------------------------------------
    @property
    def has_frames(self) -> bool:
        return "frames" in self._group

    def frames(self) -> Frames:
        """The trial's image frames (read lazily); InputError when it has none."""
        if not self.has_frames:
            raise InputError("trial has no frames (an image-sequence recording is needed)",
                             path=self.path, where=self.where)
        return Frames(self)


def _class_names(path: Path, where: str, value: Any) -> tuple[str, ...]:
    names = attr_value(value)
    names = names if isinstance(names, list) else [names]
    if not all(isinstance(c, str) for c in names):
        raise _content_error(path, where, f"attribute 'classes' is {names!r}; expected strings")
    return tuple(names)


def _read_sample_labels(path: Path, where: str, group: h5py.Group,
                        rows: slice) -> dict[str, SampleLabel]:
    """The ``sample_labels`` of the stream group ``group`` at ``where`` (rows ``rows``);
    call inside :func:`_reading`."""
    labels: dict[str, SampleLabel] = {}
    if "sample_labels" not in group:
        return labels
    for key, ds in group["sample_labels"].items():
        lwhere = f"{where}/sample_labels/{key}"
        if not isinstance(ds, h5py.Dataset) or ds.dtype.kind not in "iuf" or ds.ndim != 1:
            raise _content_error(path, lwhere, "expected a 1-D dataset of numbers")
        classes = (_class_names(path, lwhere, ds.attrs["classes"])
                   if "classes" in ds.attrs else None)
        labels[key] = SampleLabel(ds[rows], classes)
    return labels


def _check_codes(path: Path, where: str, label: SampleLabel) -> None:
    """Class codes inside their classes (-1: unlabelled); numeric labels pass."""
    if label.classes is None:
        return
    v = np.asarray(label.values)
    k = len(label.classes)
    bad = ((v != np.round(v)) | (v < -1) | (v >= k))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise _content_error(path, where, f"sample {i} has class code {v[i].item()!r}; codes "
                             f"are 0..{k - 1} of its {k} classes, or -1 (unlabelled)")


def _check_samples(path: Path, where: str, data: np.ndarray, t_s: np.ndarray,
                   labels: dict[str, SampleLabel]) -> None:
    """A stream's samples as the schema has them: one time per row, finite data, a strictly
    increasing finite time base, class codes inside their classes (-1: unlabelled)."""
    if t_s.ndim != 1 or t_s.shape[0] != data.shape[0]:
        raise _content_error(path, f"{where}/t_s", f"has shape {t_s.shape}; data has "
                             f"{data.shape[0]} rows")
    finite = np.isfinite(data)
    if not finite.all():
        r, c = (int(v[0]) for v in np.nonzero(~finite))
        raise _content_error(path, f"{where}/data", f"row {r}, column {c} is "
                             f"{float(data[r, c])!r}; samples must be finite")
    steps = np.diff(t_s)
    if not np.isfinite(t_s).all() or not (steps > 0).all():
        bad = ~np.isfinite(t_s)
        bad[1:] |= ~(steps > 0)
        i = int(np.flatnonzero(bad)[0])
        raise _content_error(path, f"{where}/t_s", f"time {float(t_s[i])!r} s at row {i} "
                             + ("is not finite" if not np.isfinite(t_s[i]) else
                                f"does not come after {float(t_s[i - 1])!r} s")
                             + "; a time base must increase")
    for key, lab in labels.items():
        v = np.asarray(lab.values)
        if v.shape[0] != data.shape[0]:
            raise _content_error(path, f"{where}/sample_labels/{key}", f"has {v.shape[0]} "
                                 f"values; the stream has {data.shape[0]} samples")
        _check_codes(path, f"{where}/sample_labels/{key}", lab)


@dataclass(frozen=True)
class Source:
    """One row of ``/provenance/sources``."""

    path: str
    size_bytes: int
    sha256: str


@dataclass(frozen=True)
class Derived:
    """One ``/derived/<kind>/<name>`` group: its datasets as columns (strings decoded)
    and its attributes."""

    where: str
    columns: dict[str, np.ndarray]
    attrs: dict[str, Any]


class TactileFile:
    """A tactile HDF5 file opened for reading, once; use as a context manager.

    InputError (one line naming the file) when it is missing, not HDF5, or of a schema
    version this tool cannot read.
    """

    def __init__(self, path: str | Path):
        self.path = Path(path)
        note_input(self.path, tree=False)
        self.schema_version, self._h5 = open_checked(self.path)
        self._sensors: dict[str, Sensor] = {}
        for group in ("sensors", "trials"):  # an empty list of trials must not pass for one
            try:
                with _reading(self.path, f"/{group}"):
                    if not isinstance(self._h5.get(group), h5py.Group):
                        raise _content_error(self.path, f"/{group}", "required group is missing")
            except InputError:
                self._h5.close()
                raise

    def __enter__(self) -> TactileFile:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        self._h5.close()

    def __repr__(self) -> str:
        return f"TactileFile({str(self.path)!r})"

    @cached_property
    def attrs(self) -> dict[str, Any]:
        """The root attributes (schema, tool version, command, config), decoded."""
        with _reading(self.path, "/"):
            return {k: attr_value(v) for k, v in self._h5.attrs.items()}

    @cached_property
    def trial_names(self) -> list[str]:
        """Trial names in file order (empty when the file has no trials)."""
        with _reading(self.path, "/trials"):
            return list(self._h5["trials"].keys()) if "trials" in self._h5 else []

    def trial(self, name: str) -> Trial:
        """Trial ``name``; InputError listing the file's trials when it has none such."""
        if name not in self.trial_names:
            raise unknown_trial(self.path, name, self.trial_names)
        return Trial(self, name)

    def trials(self, names: Sequence[str] | None = None) -> list[Trial]:
        """The named trials (each once, in the order given), or all in file order."""
        wanted = list(dict.fromkeys(names)) if names else self.trial_names
        return [self.trial(n) for n in wanted]

    def __iter__(self) -> Iterator[Trial]:
        return iter(self.trials())

    @cached_property
    def sensor_names(self) -> list[str]:
        with _reading(self.path, "/sensors"):
            return list(self._h5["sensors"].keys()) if "sensors" in self._h5 else []

    def sensor(self, name: str) -> Sensor:
        """Sensor ``name``; InputError when the file has none such."""
        if name in self._sensors:
            return self._sensors[name]
        where = f"/sensors/{name}"
        if name not in self.sensor_names:
            raise InputError(f"no sensor {name!r} (sensors: "
                             f"{', '.join(self.sensor_names) or 'none'})",
                             path=self.path, where=where)
        with _reading(self.path, where):
            g = self._h5["sensors"][name]
            attrs = {k: attr_value(v) for k, v in g.attrs.items()}
            names = _strings(self.path, f"{where}/channel_names", g["channel_names"]) \
                if "channel_names" in g else ()
            units = _strings(self.path, f"{where}/channel_units", g["channel_units"]) \
                if "channel_units" in g else ()
        kind = attrs.get("kind")
        kinds = load_spec().enums["sensor_kind"]
        if kind not in kinds:
            raise _content_error(self.path, where, f"attribute 'kind' is {kind!r}; expected one "
                                 f"of {', '.join(kinds)}")
        rate = _number_attr(self.path, where, attrs, "sample_rate_hz", minimum=0.0,
                            maximum=MAX_RATE_HZ)
        if rate == 0 and kind != "event_camera":
            raise _content_error(self.path, where, f"attribute 'sample_rate_hz' is 0 for a "
                                 f"sensor of kind {kind!r}; a sampled sensor needs a rate > 0")
        grid = {}
        for key in ("width_px", "height_px"):
            value = attrs.get(key)
            if value is not None and (not _is_int(value) or value < 1):
                raise _content_error(self.path, where, f"attribute {key!r} is {value!r}; "
                                     "expected a whole number of pixels >= 1")
            if value is None and kind in ("event_camera", "visuotactile"):
                raise _content_error(self.path, where, f"attribute {key!r} is missing; a "
                                     f"sensor of kind {kind} needs its pixel grid")
            grid[key] = None if value is None else int(value)
        if units and len(units) != len(names):
            raise _content_error(self.path, f"{where}/channel_units", f"has {len(units)} "
                                 f"units for {len(names)} channel names")
        sensor = Sensor(name=name, kind=kind, sample_rate_hz=rate, channel_names=names,
                        channel_units=units, width_px=grid["width_px"],
                        height_px=grid["height_px"], attrs=attrs)
        self._sensors[name] = sensor
        return sensor

    @cached_property
    def sources(self) -> list[Source]:
        """``/provenance/sources`` rows (empty when the file records none)."""
        where = "/provenance/sources"
        with _reading(self.path, where):
            if f"{where}/path" not in self._h5:
                return []
            g = self._h5[where]
            paths = [str(attr_value(p)) for p in g["path"][()]]
            sizes = g["size_bytes"][()] if "size_bytes" in g else np.zeros(len(paths), int)
            shas = [str(attr_value(s)) for s in g["sha256"][()]] if "sha256" in g \
                else [""] * len(paths)
        return [Source(p, int(s), h) for p, s, h in zip(paths, sizes, shas, strict=True)]

    def has_derived(self, kind: str, name: str) -> bool:
        return f"/derived/{kind}/{name}" in self._h5

    def derived(self, kind: str, name: str, *, columns: Sequence[str] | None = None,
                strings: Sequence[str] = ()) -> Derived:
        """Group ``/derived/<kind>/<name>``: the named ``columns`` (all datasets when None;
        those in ``strings`` decoded as str) and its attributes. InputError naming the
        group, or the first missing column, when absent."""
        where = f"/derived/{kind}/{name}"
        if where not in self._h5:
            raise InputError(f"no {where}", path=self.path)
        with _reading(self.path, where):
            g = self._h5[where]
            keys = list(columns) if columns is not None else [
                k for k, v in g.items() if isinstance(v, h5py.Dataset)]
            missing = [k for k in keys if k not in g]
            if missing:
                raise InputError(f"column {missing[0]!r} is missing", path=self.path,
                                 where=where)
            cols = {k: (g[k].asstr()[()] if k in strings else g[k][()]) for k in keys}
            attrs = {k: attr_value(v) for k, v in g.attrs.items()}
        if kind == "fits":  # a fits group is a table, one row per trial
            _check_columns(self.path, where, {k: np.asarray(v) for k, v in cols.items()})
        return Derived(where, cols, attrs)


def open_checked(path: Path) -> tuple[str, h5py.File]:
    """(schema version, open h5py file) of a tactile file, after the version gate; a path
    that is missing, a folder, not HDF5 or damaged is one :class:`InputError` saying what
    to do (see :func:`unreadable_error`)."""
    if not path.exists():
        if path.is_symlink():
            raise InputError("is a symbolic link that does not resolve (broken, or a loop)",
                             path=path)
        raise InputError("file not found", path=path)
    if path.is_dir():
        raise folder_error(path)
    try:
        version = check_readable(path)
        return version, h5py.File(path, "r")
    except (OSError, RuntimeError, ValueError, KeyError, TypeError) as exc:
        raise unreadable_error(path, exc) from None


#: Suffixes of raw recordings that `tactile ingest` converts, and what a file of each is.
_RAW_SUFFIXES = {".aedat4": "an AEDAT4 recording", ".csv": "a CSV table",
                 ".npy": "a NumPy array"}
#: Parts of an HDF5 library message that name its C internals (``sblock->base_addr = 0``).
_C_DETAIL = re.compile(r",?\s*[\w.]*(->|addr)[\w.>-]*\s*=\s*\w+")


def folder_error(path: Path) -> InputError:
    """The error for a folder given where a tactile HDF5 file is expected: names the .h5
    files inside it, or the command that makes one from the recordings in it."""
    h5_files = sorted(p.name for p in path.iterdir()
                      if p.suffix.lower() in (".h5", ".hdf5") and not p.name.startswith("."))
    if h5_files:
        shown = ", ".join(h5_files[:3]) + (", ..." if len(h5_files) > 3 else "")
        return InputError(f"is a folder, not a tactile HDF5 file; give one of the files in it "
                          f"({shown})", path=path)
    return InputError("is a folder, not a tactile HDF5 file; make one from the recordings in "
                      f"it with `tactile ingest {path} --out FILE.h5`", path=path)


def unreadable_error(path: Path, exc: BaseException) -> InputError:
    """One line for a file the HDF5 library cannot open, without its C details: not HDF5
    at all (a raw recording, say), cut short, or damaged; each says what to do."""
    detail = _flat(exc)
    if path.is_file() and path.stat().st_size == 0:
        return InputError("not a readable HDF5 file (the file is empty); write it again with "
                          "the command that made it", path=path)
    if not is_hdf5(path):
        raw = _RAW_SUFFIXES.get(path.suffix.lower())
        if raw is not None:
            return InputError(f"not a readable HDF5 file (no HDF5 signature: {raw}); convert "
                              f"it with `tactile ingest {path} --out FILE.h5` and give that "
                              "file", path=path)
        return InputError("not a readable HDF5 file (no HDF5 signature: another format, or a "
                          "damaged file); give a file that `tactile ingest` wrote", path=path)
    cut = re.search(r"truncated file: eof = (\d+).*stored_eof = (\d+)", detail)
    if cut:
        return InputError(f"not a readable HDF5 file (cut short: {int(cut[1]):,} of "
                          f"{int(cut[2]):,} bytes); copy it again, or write it again with the "
                          "command that made it", path=path)
    return InputError(f"not a readable HDF5 file (damaged: {_C_DETAIL.sub('', detail)}); copy "
                      "it again, or write it again with the command that made it", path=path)


def open_file(path: str | Path) -> TactileFile:
    """Open a tactile HDF5 file for reading (see :class:`TactileFile`)."""
    return TactileFile(path)


def is_hdf5(path: str | Path) -> bool:
    """Whether ``path`` is an HDF5 file (by its signature; False for a missing file)."""
    try:
        return bool(h5py.is_hdf5(str(path)))
    except OSError:
        return False


__all__ = ["READ_BLOCK", "Annotation", "Derived", "EventWindow", "Frames", "SampleLabel",
           "Sensor", "Signal", "Source", "TactileFile", "Trial", "TrialEvents", "attr_value",
           "folder_error", "is_hdf5", "open_checked", "open_file", "unknown_trial",
           "unreadable_error"]
