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
being read, never a library traceback.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any, NamedTuple

import h5py
import numpy as np

from ..errors import InputError
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
            attrs = self._group.attrs
            self.sensor_name = str(attr_value(attrs["sensor"]))
            self._index_origin_us = int(attrs["ms_index_origin_us"])
            self.origin_us = int(attrs["t_origin_us"] if "t_origin_us" in attrs
                                 else self._index_origin_us)
            self._ms_to_idx = self._group["ms_to_idx"][()]
            self.t_last_us = int(self._t[self.n_events - 1]) if self.n_events else self.origin_us
        duration_s = trial.duration_s
        last_s = (self.t_last_us + 1 - self.origin_us) * 1e-6 if self.n_events else 0.0
        self.end_s = max(duration_s, last_s)

    @cached_property
    def sensor(self) -> Sensor:
        """The event camera (its grid and optics)."""
        return self.trial.file.sensor(self.sensor_name)

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
            return EventWindow(g["x"][lo:hi].astype(np.int64), g["y"][lo:hi].astype(np.int64),
                               g["t"][lo:hi].astype(np.int64), g["p"][lo:hi])

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
        """``(t_us, p)`` arrays of at most ``block`` events each, from index ``start``."""
        g = self._group
        for a in range(start, self.n_events, block):
            b = min(a + block, self.n_events)
            with _reading(self.path, self.where):
                yield g["t"][a:b], g["p"][a:b]


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
            return float(self._group.attrs.get("duration_s", 0.0))

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
            starts, ends = ann["start_s"][()], ann["end_s"][()]
            labels = ann["label"].asstr()[()]
            return [Annotation(float(s), float(e), str(lab))
                    for s, e, lab in zip(starts, ends, labels, strict=True)]

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
            data = group["data"][rows]
            t_s = np.asarray(group["t_s"][rows], dtype=np.float64)
            attrs = {k: attr_value(v) for k, v in group.attrs.items()}
            labels: dict[str, SampleLabel] = {}
            if "sample_labels" in group:
                for key, ds in group["sample_labels"].items():
                    classes = (tuple(str(attr_value(c)) for c in ds.attrs["classes"])
                               if "classes" in ds.attrs else None)
                    labels[key] = SampleLabel(ds[rows], classes)
        if data.ndim != 2:
            raise InputError(f"data has shape {data.shape}; expected (n_samples, n_channels)",
                             path=self.path, where=f"{where}/data")
        names = sensor.channel_names or tuple(f"ch{k}" for k in range(data.shape[1]))
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
        if not self.path.exists():
            raise InputError("file not found", path=self.path)
        if self.path.is_dir():
            raise InputError("is a folder, not a tactile HDF5 file", path=self.path)
        try:
            self.schema_version = check_readable(self.path)
            self._h5 = h5py.File(self.path, "r")
        except OSError as exc:
            raise InputError(f"not a readable HDF5 file ({_flat(exc)})", path=self.path) from None
        self._sensors: dict[str, Sensor] = {}

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
            names = tuple(str(c) for c in g["channel_names"].asstr()[()]) \
                if "channel_names" in g else ()
            units = tuple(str(c) for c in g["channel_units"].asstr()[()]) \
                if "channel_units" in g else ()
            sensor = Sensor(
                name=name, kind=str(attrs.get("kind", "")),
                sample_rate_hz=float(attrs.get("sample_rate_hz", 0.0)),
                channel_names=names, channel_units=units,
                width_px=int(attrs["width_px"]) if "width_px" in attrs else None,
                height_px=int(attrs["height_px"]) if "height_px" in attrs else None,
                attrs=attrs,
            )
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
        return Derived(where, cols, attrs)


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
           "is_hdf5", "open_file", "unknown_trial"]
