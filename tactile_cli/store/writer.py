"""Write tactile HDF5 files atomically: temporary file, validation, then rename.

Every file the toolkit writes goes through :class:`StoreWriter`. Data go into a hidden
temporary file in the output's folder; on :meth:`StoreWriter.commit` the file is closed,
validated against the schema and renamed over the output in one ``os.replace``. Any
exception (including ``KeyboardInterrupt``) deletes the temporary file and leaves an
earlier output untouched.

Compression uses only HDF5's built-in filters (shuffle + gzip), so any HDF5 reader can
open the files.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import json
import os
import re
import shlex
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from .._version import __version__
from ..errors import InputError, SchemaError
from .spec import load_spec
from .validate import validate_file

#: Elements per chunk of a 1-D event column (int64: 2 MiB before compression).
EVENT_CHUNK = 1 << 18
#: Target bytes per chunk of a 2-D signal dataset.
SIGNAL_CHUNK_BYTES = 1 << 18

_STR = h5py.string_dtype("utf-8")
_NAME_OK = re.compile(r"[^A-Za-z0-9_.\-]+")


def safe_name(name: str) -> str:
    """An HDF5 link name from free text: letters, digits, ``_ . -`` only."""
    cleaned = _NAME_OK.sub("_", name).strip("_")
    return cleaned or "unnamed"


def utc_now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")


def current_command() -> str:
    """The command line of this process, shell-quoted (recorded as provenance)."""
    argv = list(sys.argv)
    if argv and argv[0].endswith(("tactile", "__main__.py")):
        argv[0] = "tactile"
    return " ".join(shlex.quote(a) for a in argv)


def sha256_of(path: str | Path, *, block: int = 1 << 22) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while chunk := f.read(block):
            h.update(chunk)
    return h.hexdigest()


@dataclass(frozen=True)
class Compression:
    """HDF5 built-in compression settings for data datasets."""

    level: int | None = 4  # gzip level 0-9, or None for no compression

    def kwargs(self) -> dict[str, Any]:
        if self.level is None:
            return {}
        return {"compression": "gzip", "compression_opts": self.level, "shuffle": True}


class StoreWriter:
    """Build one tactile HDF5 file and move it into place only when it is valid.

    Use as a context manager; call :meth:`commit` at the end of the ``with`` block::

        with StoreWriter(out, command=cmd) as w:
            w.add_source(raw)
            w.add_sensor("dvs", kind="event_camera", sample_rate_hz=0, width_px=320, height_px=240)
            trial = w.trial("rec1", labels={"object": "box"})
            ev = trial.events("dvs"); ev.append(x, y, t, p); ev.close()
            w.commit()

    Leaving the block without :meth:`commit` (or with an exception) removes the
    temporary file.
    """

    def __init__(
        self,
        out: str | Path,
        *,
        command: str | None = None,
        config: Mapping[str, Any] | None = None,
        overwrite: bool = False,
        compression: Compression = Compression(),
    ):
        self.out = Path(out)
        if self.out.exists() and not overwrite:
            raise InputError("output exists; pass --overwrite to replace it", path=self.out)
        if self.out.is_dir():
            raise InputError("output is a folder; give a file name ending in .h5", path=self.out)
        if not self.out.parent.exists():
            raise InputError("output folder does not exist", path=self.out.parent)
        self.tmp = self.out.with_name(f".{self.out.name}.tmp-{os.getpid()}")
        self.compression = compression
        self._sources: list[tuple[str, int, str]] = []
        self._source_index: dict[str, int] = {}
        self._committed = False
        spec = load_spec()
        self._h5: h5py.File | None = h5py.File(self.tmp, "w", libver="latest")
        try:
            self._write_header(spec, command, config)
        except BaseException:
            self.abort()
            raise

    def _write_header(self, spec, command: str | None, config: Mapping[str, Any] | None) -> None:
        root = self.h5["/"]
        root.attrs["schema_name"] = spec.name
        root.attrs["schema_version"] = spec.version
        root.attrs["created_utc"] = utc_now()
        root.attrs["tool_name"] = "tactile-cli"
        root.attrs["tool_version"] = __version__
        root.attrs["command"] = command if command is not None else current_command()
        if config is not None:
            root.attrs["config_json"] = json.dumps(config, sort_keys=True, default=str)
        self.h5.create_group("schema").create_dataset("spec_json", data=spec.raw_json, dtype=_STR)
        self.h5.create_group("sensors")
        self.h5.create_group("trials")
        self.h5.create_group("provenance/sources")

    # -- context management -------------------------------------------------------
    def __enter__(self) -> StoreWriter:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if not self._committed:
            self.abort()

    @property
    def h5(self) -> h5py.File:
        if self._h5 is None:
            raise RuntimeError("the writer is closed")
        return self._h5

    def abort(self) -> None:
        """Close and delete the temporary file; the output path is not touched."""
        if self._h5 is not None:
            try:
                self._h5.close()
            finally:
                self._h5 = None
        self.tmp.unlink(missing_ok=True)

    def commit(self) -> Path:
        """Close, validate and atomically move the file into place; returns its path."""
        h5 = self.h5
        src = h5["provenance/sources"]
        src.create_dataset("path", data=np.array([s[0] for s in self._sources], dtype=object), dtype=_STR)
        src.create_dataset("size_bytes", data=np.array([s[1] for s in self._sources], dtype=np.int64))
        src.create_dataset("sha256", data=np.array([s[2] for s in self._sources], dtype=object), dtype=_STR)
        h5.close()
        self._h5 = None
        try:
            report = validate_file(self.tmp)
            if not report.ok:
                lines = "; ".join(str(v) for v in report.violations[:5])
                more = len(report.violations) - 5
                raise SchemaError(f"{self.out}: the file to be written breaks the schema ({lines}"
                                  f"{f'; and {more} more' if more > 0 else ''}); nothing was written")
            os.replace(self.tmp, self.out)
        except BaseException:
            self.tmp.unlink(missing_ok=True)
            raise
        self._committed = True
        return self.out

    # -- content --------------------------------------------------------------------
    def add_source(self, path: str | Path) -> int:
        """Record a source file (path as given, size, SHA-256); returns its index."""
        key = str(path)
        if key not in self._source_index:
            p = Path(path)
            self._source_index[key] = len(self._sources)
            self._sources.append((key, p.stat().st_size, sha256_of(p)))
        return self._source_index[key]

    def add_sensor(
        self,
        name: str,
        *,
        kind: str,
        sample_rate_hz: float,
        channel_names: Sequence[str] | None = None,
        channel_units: Sequence[str] | str | None = None,
        channel_delays_s: Sequence[float] | None = None,
        width_px: int | None = None,
        height_px: int | None = None,
        taxel_positions_m: np.ndarray | None = None,
        description: str = "",
        **extra_attrs: float | int | str,
    ) -> str:
        """Describe a sensor once per file; returns its (sanitised) name.

        ``channel_units`` may be one string applied to every channel.
        """
        name = safe_name(name)
        group = self.h5["sensors"].create_group(name)
        group.attrs["kind"] = kind
        group.attrs["sample_rate_hz"] = float(sample_rate_hz)
        if description:
            group.attrs["description"] = description
        if width_px is not None:
            group.attrs["width_px"] = int(width_px)
        if height_px is not None:
            group.attrs["height_px"] = int(height_px)
        for key, value in extra_attrs.items():
            if value is not None:
                group.attrs[key] = value
        if channel_names is not None:
            names = list(channel_names)
            units = [channel_units] * len(names) if isinstance(channel_units, str) or channel_units is None \
                else list(channel_units)
            group.create_dataset("channel_names", data=np.array(names, dtype=object), dtype=_STR)
            group.create_dataset("channel_units", data=np.array([u or "" for u in units], dtype=object),
                                 dtype=_STR)
        if channel_delays_s is not None:
            group.create_dataset("channel_delays_s", data=np.asarray(channel_delays_s, dtype=np.float64))
        if taxel_positions_m is not None:
            group.create_dataset("taxel_positions_m", data=np.asarray(taxel_positions_m, dtype=np.float64))
        return name

    def sensor_attr(self, sensor: str, key: str) -> Any:
        return self.h5["sensors"][sensor].attrs.get(key)

    def trial(
        self,
        name: str,
        *,
        labels: Mapping[str, str | int | float] | None = None,
        split: str = "",
        sources: Sequence[int] = (),
        annotations: Sequence[tuple[float, float, str]] = (),
        **extra_attrs: Any,
    ) -> TrialWriter:
        """Start a trial group; names that already exist get a numeric suffix."""
        base = safe_name(name)
        trials = self.h5["trials"]
        final, k = base, 1
        while final in trials:
            k += 1
            final = f"{base}_{k}"
        group = trials.create_group(final)
        group.attrs["split"] = split
        group.attrs["duration_s"] = 0.0
        if sources:
            group.attrs["source_index"] = np.asarray(sources, dtype=np.int64)
        for key, value in extra_attrs.items():
            group.attrs[key] = value
        lab = group.create_group("labels")
        for key, value in (labels or {}).items():
            lab.attrs[safe_name(key)] = value
        if annotations:
            ann = group.create_group("annotations")
            ann.create_dataset("start_s", data=np.array([a[0] for a in annotations], dtype=np.float64))
            ann.create_dataset("end_s", data=np.array([a[1] for a in annotations], dtype=np.float64))
            ann.create_dataset("label", data=np.array([a[2] for a in annotations], dtype=object), dtype=_STR)
        return TrialWriter(self, group)


class TrialWriter:
    """Writes the data of one trial: events, signal streams, image frames."""

    def __init__(self, store: StoreWriter, group: h5py.Group):
        self.store = store
        self.group = group

    @property
    def name(self) -> str:
        return self.group.name.rsplit("/", 1)[1]

    def _extend_duration(self, duration_s: float) -> None:
        self.group.attrs["duration_s"] = max(float(self.group.attrs["duration_s"]), float(duration_s))

    def set_labels(self, **labels: str | int | float) -> None:
        for key, value in labels.items():
            self.group["labels"].attrs[safe_name(key)] = value

    def events(self, sensor: str) -> EventAppender:
        """An appender for this trial's event stream from ``sensor`` (an event camera)."""
        return EventAppender(self, sensor)

    def write_signal(
        self,
        stream: str,
        *,
        sensor: str,
        data: np.ndarray,
        t_s: np.ndarray,
        sample_labels: Mapping[str, tuple[np.ndarray, Sequence[str] | None]] | None = None,
    ) -> None:
        """Write one sampled stream.

        data: (n_samples, n_channels) values in the sensor's channel units (stored float32).
        t_s: (n_samples,) seconds from the trial's time origin, non-decreasing.
        sample_labels: name -> (values (n_samples,), class names or None for numeric labels).
        """
        data = np.asarray(data, dtype=np.float32)
        if data.ndim == 1:
            data = data[:, None]
        t_s = np.asarray(t_s, dtype=np.float64)
        group = self.group.require_group("signals").create_group(safe_name(stream))
        group.attrs["sensor"] = sensor
        rows = max(1, min(len(data), SIGNAL_CHUNK_BYTES // (4 * max(1, data.shape[1]))))
        comp = self.store.compression.kwargs()
        chunks = (rows, data.shape[1]) if comp and len(data) else None
        group.create_dataset("data", data=data, chunks=chunks, **(comp if len(data) else {}))
        group.create_dataset("t_s", data=t_s, **(comp if len(t_s) else {}))
        for name, (values, classes) in (sample_labels or {}).items():
            labels_group = group.require_group("sample_labels")
            ds = labels_group.create_dataset(safe_name(name), data=np.asarray(values),
                                             **(comp if len(values) else {}))
            if classes is not None:
                ds.attrs["classes"] = np.array(list(classes), dtype=object)
        if len(t_s):
            self._extend_duration(t_s[-1] - min(0.0, float(t_s[0])))

    def write_frames(self, *, sensor: str, images: np.ndarray, t_s: np.ndarray,
                     reference: np.ndarray) -> None:
        """Write an image sequence.

        images: (n_frames, height, width, 3) uint8 RGB; reference: (height, width, 3) uint8,
        the no-contact frame; t_s: (n_frames,) seconds from the trial's time origin.
        """
        group = self.group.create_group("frames")
        group.attrs["sensor"] = sensor
        images = np.asarray(images, dtype=np.uint8)
        comp = self.store.compression.kwargs()
        chunks = (1, *images.shape[1:]) if images.size else None
        group.create_dataset("images", data=images, chunks=chunks, **(comp if images.size else {}))
        group.create_dataset("t_s", data=np.asarray(t_s, dtype=np.float64))
        group.create_dataset("reference", data=np.asarray(reference, dtype=np.uint8))
        if len(t_s):
            self._extend_duration(float(t_s[-1]))


class EventAppender:
    """Append address events in chunks, checking them as they arrive.

    Columns are stored as one 1-D dataset each: ``x``, ``y`` (uint16 px), ``t`` (int64 us),
    ``p`` (int8, -1/+1). :meth:`close` writes ``ms_to_idx``, the index from milliseconds
    since the first event to the first event index (as the DSEC format keeps).
    """

    def __init__(self, trial: TrialWriter, sensor: str):
        self.trial = trial
        self.sensor = sensor
        sensor_group = trial.store.h5["sensors"][sensor]
        self.width = int(sensor_group.attrs["width_px"])
        self.height = int(sensor_group.attrs["height_px"])
        self.group = trial.group.create_group("events")
        self.group.attrs["sensor"] = sensor
        comp = trial.store.compression.kwargs()
        self._ds = {
            name: self.group.create_dataset(name, shape=(0,), maxshape=(None,), dtype=dtype,
                                            chunks=(EVENT_CHUNK,), **comp)
            for name, dtype in (("x", np.uint16), ("y", np.uint16), ("t", np.int64), ("p", np.int8))
        }
        self.n = 0
        self.t_first: int | None = None
        self.t_last: int | None = None
        self._ms_index: list[np.ndarray] = []
        self._next_ms = 0  # the next millisecond boundary whose first index is unknown

    def append(self, x: np.ndarray, y: np.ndarray, t: np.ndarray, p: np.ndarray, *,
               source: str | Path | None = None, first_row: int = 0, row_label: str = "row") -> None:
        """Check and append one chunk.

        x, y: pixel coordinates; t: microseconds, non-decreasing across chunks;
        p: polarity already in {-1, +1}. ``source`` and ``first_row`` locate errors
        (row numbers count from ``first_row`` for the chunk's first event).
        """
        n = len(t)
        if not (len(x) == len(y) == len(p) == n):
            raise InputError(f"event columns differ in length (x {len(x)}, y {len(y)}, t {n}, p {len(p)})",
                             path=source)
        if n == 0:
            return
        x = np.asarray(x)
        y = np.asarray(y)
        t = np.asarray(t, dtype=np.int64)
        p = np.asarray(p)
        self._check(x, y, t, p, source, first_row, row_label)
        start = self.n
        for name, values in (("x", x), ("y", y), ("t", t), ("p", p)):
            ds = self._ds[name]
            ds.resize((start + n,))
            ds[start:] = values.astype(ds.dtype, copy=False)
        if self.t_first is None:
            self.t_first = int(t[0])
        self.t_last = int(t[-1])
        # first index of every millisecond boundary reached inside this chunk
        last_ms = (self.t_last - self.t_first) // 1000
        if last_ms >= self._next_ms:
            edges = self.t_first + 1000 * np.arange(self._next_ms, last_ms + 1, dtype=np.int64)
            self._ms_index.append(start + np.searchsorted(t, edges, side="left"))
            self._next_ms = int(last_ms) + 1
        self.n += n

    def _check(self, x, y, t, p, source, first_row, row_label) -> None:
        def fail(mask: np.ndarray, what: str) -> None:
            i = int(np.flatnonzero(mask)[0])
            raise InputError(what.format(i=i), path=source, where=f"{row_label} {first_row + i}")

        bad = (x < 0) | (x >= self.width)
        if bad.any():
            fail(bad, f"x = {x[np.flatnonzero(bad)[0]]} is outside the sensor (width {self.width} px)")
        bad = (y < 0) | (y >= self.height)
        if bad.any():
            fail(bad, f"y = {y[np.flatnonzero(bad)[0]]} is outside the sensor (height {self.height} px)")
        bad = (p != 1) & (p != -1)
        if bad.any():
            fail(bad, f"polarity {p[np.flatnonzero(bad)[0]]} is not -1/+1 after conversion")
        back = np.diff(t) < 0
        if back.any():
            i = int(np.flatnonzero(back)[0])
            raise InputError(f"timestamp {t[i + 1]} us is earlier than the previous {t[i]} us "
                             "(timestamps must not decrease)", path=source,
                             where=f"{row_label} {first_row + i + 1}")
        if self.t_last is not None and t[0] < self.t_last:
            raise InputError(f"timestamp {t[0]} us is earlier than the previous {self.t_last} us "
                             "(timestamps must not decrease)", path=source, where=f"{row_label} {first_row}")

    def close(self) -> int:
        """Write the millisecond index and the trial duration; returns the event count."""
        idx = np.concatenate(self._ms_index) if self._ms_index else np.zeros(0, dtype=np.int64)
        self.group.create_dataset("ms_to_idx", data=idx.astype(np.int64))
        self.group.attrs["ms_index_origin_us"] = np.int64(self.t_first or 0)
        if self.t_first is not None and self.t_last is not None:
            self.trial._extend_duration((self.t_last - self.t_first) * 1e-6)
        return self.n
