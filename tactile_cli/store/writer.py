"""Write tactile HDF5 files atomically: temporary file, validation, then rename.

Every file the toolkit writes goes through :class:`StoreWriter`. Data go into a hidden
temporary file in the output's folder; on :meth:`StoreWriter.commit` the file is closed,
validated against the schema and renamed over the output in one ``os.replace``. Any
exception (including ``KeyboardInterrupt``) deletes the temporary file and leaves an
earlier output untouched.

Compression uses only HDF5's built-in filters (shuffle + gzip), so any HDF5 reader can
open the files (frame chunks at level 1 are deflated by ISA-L, whose zlib streams the
gzip filter reads like any other: :mod:`.deflate`).
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import threading
import zlib
from collections import deque
from collections.abc import Collection, Mapping, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import h5py
import numpy as np

from .._version import __version__
from ..errors import InputError, SchemaError
from ..interrupt import raise_if_requested
from .atomic import (
    LIVE_TEMPORARIES,
    check_output_file,
    remove_stale_temporaries,
    swap_into_place,
    temporary_path,
    write_error,
)
from .deflate import deflate_chunk
from .provenance import current_command, sha256_of, utc_now
from .spec import load_spec
from .trials import attr_value
from .validate import validate_file

#: Events per chunk of a 1-D event column (the t column: 512 KiB before compression). A
#: windowed read inflates whole chunks, so smaller chunks read a 50 ms window faster (5 ms
#: against 9 ms at 1 << 18 for 50k events) for 1 % more bytes; a chunk is one deflate job.
EVENT_CHUNK = 1 << 16
#: Target bytes per chunk of a 2-D signal dataset.
SIGNAL_CHUNK_BYTES = 1 << 18

_STR = h5py.string_dtype("utf-8")

_NAME_OK = re.compile(r"[^A-Za-z0-9_.\-]+")


def safe_name(name: str) -> str:
    """An HDF5 link name from free text: letters, digits, ``_ . -`` only."""
    cleaned = _NAME_OK.sub("_", name).strip("_")
    return cleaned or "unnamed"


@dataclass(frozen=True)
class Compression:
    """HDF5 built-in compression settings for data datasets."""

    level: int | None = 1  # gzip level 0-9, or None; level 1 is ~1/4 of raw events and fastest

    def kwargs(self) -> dict[str, Any]:
        if self.level is None:
            return {}
        return {"compression": "gzip", "compression_opts": self.level, "shuffle": True}


#: gzip level 1 with shuffle: events at ~1/4 of raw size, fastest of the gzip levels
DEFAULT_COMPRESSION = Compression()


def validate_and_swap(tmp: Path, dest: Path, *, verified: Collection[str] = (), breaks: str,
                      outcome: str, in_place: bool = False) -> None:
    """Validate the finished temporary file ``tmp``, flush it to disk and rename it over
    ``dest`` in one ``os.replace``; on any error or interrupt delete ``tmp`` (``dest`` is
    untouched) and re-raise. A schema violation is a :class:`SchemaError` "``breaks`` (the
    first violations); ``outcome``". ``verified`` is passed to :func:`validate_file`.
    ``in_place``: ``dest`` is the input being updated (:class:`~.update.DerivedUpdate`),
    so the input guard does not refuse it."""
    try:
        report = validate_file(tmp, verified=verified)
        if not report.ok:
            lines = "; ".join(" ".join(str(v).split()) for v in report.violations[:5])
            more = len(report.violations) - 5
            raise SchemaError(f"{breaks} ({lines}{f'; and {more} more' if more > 0 else ''}); "
                              f"{outcome}")
        with open(tmp, "rb") as f:  # the data reach the disk before the rename
            os.fsync(f.fileno())
        if in_place:
            raise_if_requested()
            try:
                os.replace(tmp, dest)
            except OSError as exc:
                raise write_error(exc, dest) from None
        else:
            swap_into_place(tmp, dest)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    finally:
        LIVE_TEMPORARIES.discard(tmp)


class _Digest:
    """The SHA-256 of one source file. A file of :data:`THREAD_BYTES` or more is hashed in a
    daemon thread while the ingest reads it (hashlib releases the GIL on large blocks), so
    the 2-3 s a 1 GB recording takes to hash overlap the reading instead of adding to it;
    :meth:`result` waits for it. A smaller file is hashed at once."""

    THREAD_BYTES = 8 << 20
    BLOCK = 1 << 22

    def __init__(self, path: Path, size: int):
        self._value: str | None = None
        self._error: BaseException | None = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        if size < self.THREAD_BYTES:
            self._value = sha256_of(path)
            return
        self._thread = threading.Thread(target=self._run, args=(path,), daemon=True,
                                        name="tactile-sha256")
        self._thread.start()

    def _run(self, path: Path) -> None:
        try:
            h = hashlib.sha256()
            with open(path, "rb") as f:
                while (chunk := f.read(self.BLOCK)) and not self._stop.is_set():
                    h.update(chunk)
            self._value = h.hexdigest()
        except BaseException as exc:  # re-raised in the caller's thread by result()
            self._error = exc

    def result(self) -> str:
        """The hex digest (waits for the thread); a read error is raised here."""
        if self._thread is not None:
            while self._thread.is_alive():
                raise_if_requested()
                self._thread.join(0.1)
        if self._error is not None:
            raise self._error
        if self._stop.is_set() or self._value is None:
            raise RuntimeError("the source's SHA-256 was cancelled")
        return self._value

    def cancel(self) -> None:
        """Stop hashing (the writer was aborted)."""
        self._stop.set()


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
        compression: Compression = DEFAULT_COMPRESSION,
    ):
        self.out = Path(out)
        if self.out.is_dir():  # before the `overwrite=True` hint, which would not help
            raise InputError("output is a folder; give a file name ending in .h5", path=self.out)
        check_output_file(self.out, overwrite=overwrite)
        self.tmp = temporary_path(self.out)
        remove_stale_temporaries(self.out)
        self.compression = compression
        #: datasets whose content the write path already checked with the schema's rules
        self.verified: set[str] = set()
        self._sources: list[tuple[str, int, _Digest]] = []
        self._source_index: dict[str, int] = {}
        self._committed = False
        spec = load_spec()
        LIVE_TEMPORARIES.add(self.tmp)  # registered before it exists: no unguarded window
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
        self.h5.create_group("sensors", track_order=True)  # keep the order of the inputs
        self.h5.create_group("trials", track_order=True)
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
        for _, _, digest in self._sources:
            digest.cancel()
        if self._h5 is not None:
            try:
                self._h5.close()
            finally:
                self._h5 = None
        self.tmp.unlink(missing_ok=True)
        LIVE_TEMPORARIES.discard(self.tmp)

    def commit(self) -> Path:
        """Close, validate and atomically move the file into place; returns its path."""
        raise_if_requested()
        h5 = self.h5
        src = h5["provenance/sources"]
        src.create_dataset(
            "path", data=np.array([s[0] for s in self._sources], dtype=object), dtype=_STR
        )
        src.create_dataset(
            "size_bytes", data=np.array([s[1] for s in self._sources], dtype=np.int64)
        )
        src.create_dataset(
            "sha256", data=np.array([s[2].result() for s in self._sources], dtype=object),
            dtype=_STR
        )
        h5.close()
        self._h5 = None
        validate_and_swap(self.tmp, self.out, verified=self.verified,
                          breaks=f"{self.out}: the file to be written breaks the schema",
                          outcome="nothing was written")
        self._committed = True
        return self.out

    # -- content --------------------------------------------------------------------
    def add_source(self, path: str | Path) -> int:
        """Record a source file (path as given, size, SHA-256); returns its index. The
        SHA-256 of a large file is computed in a thread while the caller reads the file
        (:class:`_Digest`) and written at :meth:`commit`."""
        key = str(path)
        if key not in self._source_index:
            p = Path(path)
            size = p.stat().st_size
            self._source_index[key] = len(self._sources)
            self._sources.append((key, size, _Digest(p, size)))
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
            units = (
                [channel_units] * len(names)
                if isinstance(channel_units, str) or channel_units is None
                else list(channel_units)
            )
            group.create_dataset("channel_names", data=np.array(names, dtype=object), dtype=_STR)
            group.create_dataset(
                "channel_units", data=np.array([u or "" for u in units], dtype=object), dtype=_STR
            )
        if channel_delays_s is not None:
            group.create_dataset(
                "channel_delays_s", data=np.asarray(channel_delays_s, dtype=np.float64)
            )
        if taxel_positions_m is not None:
            group.create_dataset(
                "taxel_positions_m", data=np.asarray(taxel_positions_m, dtype=np.float64)
            )
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
            group.attrs["source_index"] = np.asarray(sources, dtype=np.int64)  # see set_sources
        for key, value in extra_attrs.items():
            group.attrs[key] = value
        lab = group.create_group("labels")
        for key, value in (labels or {}).items():
            lab.attrs[safe_name(key)] = value
        writer = TrialWriter(self, group)
        if annotations:
            writer.set_annotations(annotations)
        return writer

    @property
    def trial_names(self) -> list[str]:
        """Names of the trials started so far, in the order they were started."""
        return list(self.h5["trials"].keys())

    def trial_writer(self, name: str) -> TrialWriter:
        """The writer of trial ``name``, started earlier (by a format reader, say), to add
        labels or annotations to it; KeyError when no trial of that name was started."""
        trials = self.h5["trials"]
        if name not in trials:
            raise KeyError(f"no trial {name!r} in the file being written")
        return TrialWriter(self, trials[name])


class TrialWriter:
    """Writes the data of one trial: events, signal streams, image frames."""

    def __init__(self, store: StoreWriter, group: h5py.Group):
        self.store = store
        self.group = group

    @property
    def name(self) -> str:
        return self.group.name.rsplit("/", 1)[1]

    def _extend_duration(self, duration_s: float) -> None:
        self.group.attrs["duration_s"] = max(
            float(self.group.attrs["duration_s"]), float(duration_s)
        )

    def set_sources(self, indices: Sequence[int]) -> None:
        """Point the trial at its source files (indices returned by ``add_source``), for
        readers that hash sources while they stream the data."""
        self.group.attrs["source_index"] = np.asarray(indices, dtype=np.int64)

    def set_labels(self, **labels: str | int | float) -> None:
        for key, value in labels.items():
            self.group["labels"].attrs[safe_name(key)] = value

    @property
    def labels(self) -> dict[str, Any]:
        """The labels set so far, decoded as :func:`~tactile_cli.store.trials.attr_value`
        does (bytes as str, numpy scalars as Python ones)."""
        return {k: attr_value(v) for k, v in self.group["labels"].attrs.items()}

    @property
    def split(self) -> str:
        """The trial's split so far: ``"train"``, ``"val"``, ``"test"`` or ``""`` (none)."""
        return str(attr_value(self.group.attrs.get("split", "")))

    def set_split(self, split: str) -> None:
        """Assign the trial to a split (the group attribute ``split``): one of the schema's
        values train, val, test, or ``""`` for none; ValueError for anything else."""
        allowed = load_spec().enums["split"]
        if split not in allowed:
            raise ValueError(f"split {split!r} is not one of {', '.join(map(repr, allowed))}")
        self.group.attrs["split"] = split

    @property
    def has_annotations(self) -> bool:
        """Whether the trial's annotations were written (they are written once)."""
        return "annotations" in self.group

    def set_annotations(self, annotations: Sequence[tuple[float, float, str]]) -> None:
        """Write the trial's annotated intervals ``(start_s, end_s, label)``, seconds from
        the trial's time origin, in the order given (``/trials/<trial>/annotations``:
        ``start_s``, ``end_s`` float64, ``label`` UTF-8 strings). ValueError when the trial
        already has annotations."""
        if self.has_annotations:
            raise ValueError(f"trial {self.name!r} already has annotations")
        ann = self.group.create_group("annotations")
        ann.create_dataset("start_s", data=np.array([a[0] for a in annotations],
                                                    dtype=np.float64))
        ann.create_dataset("end_s", data=np.array([a[1] for a in annotations],
                                                  dtype=np.float64))
        ann.create_dataset("label", data=np.array([a[2] for a in annotations], dtype=object),
                           dtype=_STR)

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
    ) -> h5py.Group:
        """Write one sampled stream; returns its group (for extra attributes).

        data: (n_samples, n_channels) values in the sensor's channel units (stored float32).
        t_s: (n_samples,) seconds from the trial's time origin, non-decreasing.
        sample_labels: name -> (values (n_samples,), class names or None for numeric labels).
        """
        raise_if_requested()
        data = np.asarray(data, dtype=np.float32)
        if data.ndim == 1:
            data = data[:, None]
        t_s = np.asarray(t_s, dtype=np.float64)
        signals = (
            self.group["signals"]
            if "signals" in self.group
            else self.group.create_group("signals", track_order=True)
        )
        group = signals.create_group(safe_name(stream))
        group.attrs["sensor"] = safe_name(sensor)
        rows = max(1, min(len(data), SIGNAL_CHUNK_BYTES // (4 * max(1, data.shape[1]))))
        comp = self.store.compression.kwargs()
        chunks = (rows, data.shape[1]) if comp and len(data) else None
        group.create_dataset("data", data=data, chunks=chunks, **(comp if len(data) else {}))
        group.create_dataset("t_s", data=t_s, **(comp if len(t_s) else {}))
        for name, (values, classes) in (sample_labels or {}).items():
            labels_group = group.require_group("sample_labels")
            ds = labels_group.create_dataset(
                safe_name(name), data=np.asarray(values), **(comp if len(values) else {})
            )
            if classes is not None:
                ds.attrs["classes"] = np.array(list(classes), dtype=object)
        if len(t_s):
            self._extend_duration(t_s[-1] - min(0.0, float(t_s[0])))
        return group

    def signal(self, stream: str, *, sensor: str, n_channels: int) -> SignalAppender:
        """An appender for one sampled stream of this trial, written in blocks as it comes:
        memory holds the caller's block, not the stream (:meth:`write_signal` writes one
        held in memory)."""
        return SignalAppender(self, stream, sensor, n_channels)

    def write_frames(
        self, *, sensor: str, images: np.ndarray, t_s: np.ndarray, reference: np.ndarray
    ) -> None:
        """Write a whole image sequence held in memory (:meth:`frames` streams a long one).

        images: (n_frames, height, width, 3) uint8 RGB; reference: (height, width, 3) uint8,
        the no-contact frame; t_s: (n_frames,) seconds from the trial's time origin.
        """
        appender = self.frames(sensor, reference=reference)
        appender.append(images, t_s)
        appender.close()

    def frames(self, sensor: str, *, reference: np.ndarray) -> FrameAppender:
        """An appender for this trial's image sequence from ``sensor`` (a visuotactile
        sensor); ``reference`` is the (height, width, 3) uint8 no-contact frame, which fixes
        the frame size. Memory stays bounded by the batch the caller appends."""
        return FrameAppender(self, sensor, reference)


class FrameAppender:
    """Append the frames of one image sequence in batches (one frame per HDF5 chunk).

    Datasets of ``/trials/{trial}/frames``: ``images`` (n_frames, height, width, 3) uint8
    RGB, ``t_s`` (n_frames,) float64 seconds from the trial's time origin, and
    ``reference`` (height, width, 3) uint8. :meth:`close` sets the trial duration.
    Wrong shapes, dtypes or times are programming errors here (``ValueError``): readers
    check user files first and raise :class:`InputError` naming the file.

    Why it is fast: with compression on, each frame (one chunk) is deflated in the
    process-wide pool of :class:`EventAppender` (the compressors run without the GIL, so
    the cores compress while the caller decodes its next frames) and the main thread writes
    the finished chunks in frame order with HDF5's direct chunk write. Each chunk is a zlib
    stream HDF5's shuffle + gzip filters read (shuffle leaves 1-byte elements as they are):
    at gzip level 1 made by ISA-L, about 6 times as fast as zlib; at other levels byte for
    byte what HDF5's own filter writes (:mod:`.deflate`); a frame chunk is never partial.
    The result does not depend on the pool size (each chunk is compressed alone and
    written at its own place). Chunks still in flight are written by :meth:`close`.
    """

    #: float64 timestamps per chunk of ``t_s`` (8 KiB; uncompressed chunks are allocated whole)
    TIME_CHUNK = 1024
    #: Frames being deflated at once per pool worker (bounds the memory they hold).
    IN_FLIGHT_PER_WORKER = 4

    def __init__(self, trial: TrialWriter, sensor: str, reference: np.ndarray):
        reference = np.asarray(reference)
        if reference.dtype != np.uint8 or reference.ndim != 3 or reference.shape[2] != 3:
            raise ValueError(
                f"`reference` must be (height, width, 3) uint8, got shape "
                f"{reference.shape} dtype {reference.dtype}"
            )
        self.trial = trial
        self.frame_shape: tuple[int, int, int] = tuple(reference.shape)  # type: ignore[assignment]
        self.group = trial.group.create_group("frames")
        self.group.attrs["sensor"] = sensor
        comp = trial.store.compression.kwargs()
        self._images = self.group.create_dataset(
            "images",
            shape=(0, *self.frame_shape),
            maxshape=(None, *self.frame_shape),
            dtype=np.uint8,
            chunks=(1, *self.frame_shape),
            **comp,
        )
        self._t_s = self.group.create_dataset(
            "t_s", shape=(0,), maxshape=(None,), dtype=np.float64, chunks=(self.TIME_CHUNK,)
        )
        self.group.create_dataset("reference", data=reference)
        self.n = 0
        self.t_first: float | None = None
        self.t_last: float | None = None
        self._level = trial.store.compression.level  # None: h5py writes the frames raw
        # (frame index, deflate job), in write order
        self._pending: deque[tuple[int, Future[bytes]]] = deque()
        self._max_pending = self.IN_FLIGHT_PER_WORKER * EventAppender._pool_size()

    def append(self, images: np.ndarray, t_s: np.ndarray) -> None:
        """Append frames: images (k, height, width, 3) uint8 RGB (or one (height, width, 3)
        frame), t_s (k,) seconds, finite and not earlier than the previous frame."""
        raise_if_requested()
        images = np.asarray(images)
        if images.ndim == 3:
            images = images[None]
        t_s = np.atleast_1d(np.asarray(t_s, dtype=np.float64))
        if images.dtype != np.uint8 or images.shape[1:] != self.frame_shape:
            raise ValueError(
                f"`images` must be (k, {', '.join(map(str, self.frame_shape))}) uint8 "
                f"like the reference, got shape {images.shape} dtype {images.dtype}"
            )
        if t_s.shape != (len(images),):
            raise ValueError(
                f"`t_s` has shape {t_s.shape}, expected ({len(images)},): one time per frame"
            )
        if len(t_s) == 0:
            return
        if not np.isfinite(t_s).all():
            raise ValueError("`t_s` has non-finite values (NaN or inf)")
        previous = self.t_last if self.t_last is not None else t_s[0]
        if (np.diff(t_s, prepend=previous) < 0).any():
            raise ValueError("`t_s` decreases; frame times must not decrease")
        start, k = self.n, len(images)
        self._images.resize((start + k, *self.frame_shape))
        if self._level is None:
            self._images[start:] = images
        else:
            pool = EventAppender._executor()
            for i in range(k):  # tobytes: the caller may reuse its array after this returns
                frame = np.ascontiguousarray(images[i]).tobytes()
                self._pending.append((start + i, pool.submit(deflate_chunk, frame,
                                                             self._level)))
                self._write_ready(self._max_pending)
        self._t_s.resize((start + k,))
        self._t_s[start:] = t_s
        if self.t_first is None:
            self.t_first = float(t_s[0])
        self.t_last = float(t_s[-1])
        self.n += k

    def _write_ready(self, keep: int) -> None:
        """Write deflated frames in order until at most ``keep`` jobs are in flight."""
        while len(self._pending) > keep:
            index, job = self._pending.popleft()
            self._images.id.write_direct_chunk((index, 0, 0, 0), job.result())

    def close(self) -> int:
        """Write the frames still being deflated and set the trial duration (as for
        signals: from min(0, first time) to the last time); returns the frame count."""
        self._write_ready(0)
        # append checked shape, dtype and time order (finite, non-decreasing) of every frame
        # before it was written, and the deflated chunks come straight from zlib, so the
        # commit need not inflate the frames again to validate them (as for events)
        self.trial.store.verified.update(f"{self.group.name}/{c}" for c in ("images", "t_s"))
        if self.t_first is not None and self.t_last is not None:
            self.trial._extend_duration(self.t_last - min(0.0, self.t_first))
        return self.n


class SignalAppender:
    """Append the samples of one sampled stream in blocks (``/trials/{trial}/signals/
    {stream}``: ``data`` (n_samples, n_channels) float32, ``t_s`` (n_samples,) float64
    seconds from the trial's time origin), chunked and compressed as
    :meth:`TrialWriter.write_signal` does, so a reader cannot tell the two apart.

    Times may go back between or within blocks: :attr:`back` counts the samples whose stamp
    is earlier than the one before, and :meth:`close` either sorts the stream by time
    (``sort=True``, stable; this reads the stream's values back, 4 bytes per value) or
    leaves the decision to the caller, who refuses the input. :meth:`close` sets the trial
    duration.

    Why it is fast: a block of :attr:`chunk_rows` rows that starts on a chunk boundary (what
    a caller that appends whole chunks gives) is shuffled and deflated in the store's pool,
    as frames are (:class:`FrameAppender`, :mod:`.deflate`), and written with HDF5's direct
    chunk write in row order; any other block goes through h5py's own filters, after the
    chunks in flight. Wide streams (a 1,200-value taxel array at 1 kHz is 4.8 MB/s) would
    otherwise spend most of an ingest in the main thread's zlib."""

    def __init__(self, trial: TrialWriter, stream: str, sensor: str, n_channels: int):
        if n_channels < 1:
            raise ValueError(f"`n_channels` must be at least 1, got {n_channels}")
        self.trial = trial
        self.n_channels = int(n_channels)
        signals = (trial.group["signals"] if "signals" in trial.group
                   else trial.group.create_group("signals", track_order=True))
        self.group = signals.create_group(safe_name(stream))
        self.group.attrs["sensor"] = safe_name(sensor)
        comp = trial.store.compression.kwargs()
        rows = self.chunk_rows = max(1, SIGNAL_CHUNK_BYTES // (4 * self.n_channels))
        self._level = trial.store.compression.level
        self._pending: deque[tuple[int, Future[bytes]]] = deque()  # (first row, deflate job)
        self._max_pending = FrameAppender.IN_FLIGHT_PER_WORKER * EventAppender._pool_size()
        self._data = self.group.create_dataset(
            "data", shape=(0, self.n_channels), maxshape=(None, self.n_channels),
            dtype=np.float32, chunks=(rows, self.n_channels), **comp)
        self._t_s = self.group.create_dataset(
            "t_s", shape=(0,), maxshape=(None,), dtype=np.float64,
            chunks=(FrameAppender.TIME_CHUNK * 8,), **comp)
        self.n = 0
        self.back = 0
        self._times: list[np.ndarray] = []  # times not yet written (less than a chunk)
        self._n_times = 0
        self._last: float | None = None
        self._finite = True  # every value appended is finite
        self._increasing = True  # every time is later than the one before

    def append(self, data: np.ndarray, t_s: np.ndarray) -> None:
        """Append samples: data (k, n_channels) values in the sensor's units (stored
        float32), t_s (k,) finite seconds."""
        raise_if_requested()
        data = np.asarray(data, dtype=np.float32)
        t_s = np.atleast_1d(np.asarray(t_s, dtype=np.float64))
        if data.ndim != 2 or data.shape[1] != self.n_channels or len(data) != len(t_s):
            raise ValueError(f"`data` must be (k, {self.n_channels}) with one time per row, "
                             f"got {data.shape} and {t_s.shape} times")
        if len(t_s) == 0:
            return
        if not np.isfinite(t_s).all():
            raise ValueError("`t_s` has non-finite values (NaN or inf)")
        step = np.diff(t_s, prepend=self._last if self._last is not None else t_s[0] - 1.0)
        self.back += int(np.count_nonzero(step < 0))
        self._increasing = self._increasing and bool((step > 0).all())
        self._finite = self._finite and bool(np.isfinite(data).all())
        self._last = float(t_s[-1])
        start, k = self.n, len(t_s)
        self._data.resize((start + k, self.n_channels))
        if self._level is not None and k == self.chunk_rows and start % k == 0:
            own = np.array(data, dtype=np.float32, order="C")  # the caller may reuse `data`
            self._pending.append((start, EventAppender._executor().submit(
                self._shuffle_deflate, own, self._level)))
            self._write_ready(self._max_pending)
        else:
            self._write_ready(0)
            self._data[start:] = data
        self._times.append(t_s.copy())
        self._n_times += k
        if self._n_times >= self._t_s.chunks[0]:
            self._write_times()
        self.n += k

    def _write_times(self) -> None:
        """Write the times held back (one h5py write per chunk of times, not per block)."""
        if not self._times:
            return
        t_s = np.concatenate(self._times)
        start = self._t_s.shape[0]
        self._t_s.resize((start + len(t_s),))
        self._t_s[start:] = t_s
        self._times, self._n_times = [], 0

    @staticmethod
    def _shuffle_deflate(chunk: np.ndarray, level: int) -> bytes:
        """One (chunk_rows, n_channels) float32 chunk as HDF5's shuffle (byte 0 of every
        value, then byte 1, ...) and gzip filters store it; runs in the pool."""
        return deflate_chunk(np.ascontiguousarray(chunk.view(np.uint8).reshape(-1, 4).T), level)

    def _write_ready(self, keep: int) -> None:
        """Write deflated chunks in row order until at most ``keep`` jobs are in flight."""
        while len(self._pending) > keep:
            row, job = self._pending.popleft()
            self._data.id.write_direct_chunk((row, 0), job.result())

    def close(self, *, sort: bool = False) -> np.ndarray:
        """Finish the stream (sorted by time when ``sort`` and a stamp went back); returns
        its times (n_samples,) in seconds, as stored."""
        self._write_ready(0)
        self._write_times()
        t_s = self._t_s[:]
        if sort and self.back:
            order = np.argsort(t_s, kind="stable")
            t_s = t_s[order]
            self._t_s[:] = t_s
            self._data[:] = self._data[:][order]
            self._increasing = bool((np.diff(t_s) > 0).all())
        # what the schema's value scans check was checked on the way in: the commit need not
        # inflate the stream again (as for frames and events); otherwise it finds what broke
        if self._increasing:
            self.trial.store.verified.add(f"{self._t_s.name}")
        if self._finite:
            self.trial.store.verified.add(f"{self._data.name}")
        if len(t_s):
            self.trial._extend_duration(t_s[-1] - min(0.0, float(t_s.min())))
        return t_s


#: Timestamps below this (2**40 us, about 12.7 days) are taken as relative to the trial
#: start; later ones as a clock with an epoch (camera or Unix time).
RELATIVE_TIME_LIMIT_US = 1 << 40


def event_time_origin_us(t_first_us: int) -> int:
    """The event timestamp at a trial's time 0, from its first event: 0 when that is below
    :data:`RELATIVE_TIME_LIMIT_US` (the times are already relative to the trial start),
    else the first timestamp itself (epoch times: the trial starts at its first event)."""
    return 0 if 0 <= t_first_us < RELATIVE_TIME_LIMIT_US else int(t_first_us)


class EventAppender:
    """Append address events in chunks, checking them as they arrive.

    Columns are stored as one 1-D dataset each: ``x``, ``y`` (uint16 px), ``t`` (int64 us),
    ``p`` (int8, -1/+1), chunked by :data:`EVENT_CHUNK` events. :meth:`close` writes
    ``ms_to_idx``, the index from milliseconds since the first event to the first event
    index (as the DSEC format keeps).

    Why it is fast: events are staged into whole chunks; each chunk is shuffled (HDF5's
    byte transpose) and deflated in a thread pool, where zlib runs without the GIL, so the
    cores compress while the caller parses its next block; the main thread writes the
    finished chunks in order with HDF5's direct chunk write. The stored bytes are exactly
    those HDF5's own shuffle + gzip filters produce (zlib ``compress2`` at the same level,
    last chunk zero-padded like HDF5's fill value), so any HDF5 reader opens the file.
    """

    _COLUMNS: ClassVar[tuple[tuple[str, type[np.integer]], ...]] = (
        ("x", np.uint16),
        ("y", np.uint16),
        ("t", np.int64),
        ("p", np.int8),
    )
    _pool: ClassVar[ThreadPoolExecutor | None] = None
    _pool_pid: ClassVar[int] = 0
    _pool_lock: ClassVar[threading.Lock] = threading.Lock()
    #: Longest trial in microseconds (24 h): ``ms_to_idx`` holds one int64 per millisecond,
    #: so one absurd timestamp (nanoseconds read as microseconds, a corrupt value) would
    #: otherwise ask for gigabytes instead of raising an error.
    MAX_SPAN_US: ClassVar[int] = 24 * 3600 * 10**6

    def __init__(self, trial: TrialWriter, sensor: str):
        self.trial = trial
        self.sensor = sensor
        sensor_group = trial.store.h5["sensors"][sensor]
        self.width = int(sensor_group.attrs["width_px"])
        self.height = int(sensor_group.attrs["height_px"])
        self.group = trial.group.create_group("events")
        self.group.attrs["sensor"] = sensor
        comp = trial.store.compression.kwargs()
        self._level = trial.store.compression.level  # None: chunks are stored raw
        self._ds = {
            name: self.group.create_dataset(
                name, shape=(0,), maxshape=(None,), dtype=dtype, chunks=(EVENT_CHUNK,), **comp
            )
            for name, dtype in self._COLUMNS
        }
        self.n = 0
        self.t_first: int | None = None
        self.t_last: int | None = None
        self._ms_index: list[np.ndarray] = []
        self._next_ms = 0  # the next millisecond boundary whose first index is unknown
        self._stage = {name: np.empty(EVENT_CHUNK, dtype) for name, dtype in self._COLUMNS}
        self._spare: dict[str, list[np.ndarray]] = {name: [] for name, _ in self._COLUMNS}
        self._fill = 0  # events waiting in the staging buffers
        self._next_chunk = 0  # index of the chunk the staging buffers will become
        self._extent = 0  # current length of the datasets
        # (column, chunk index, buffer, deflate job or None when stored raw), in write order
        self._pending: deque[tuple[str, int, np.ndarray, Future[bytes] | None]] = deque()
        # enough chunks in flight to keep every worker busy, few enough to bound memory
        self._max_pending = 8 * self._pool_size()

    def append(
        self,
        x: np.ndarray,
        y: np.ndarray,
        t: np.ndarray,
        p: np.ndarray,
        *,
        source: str | Path | None = None,
        first_row: int = 0,
        row_label: str = "row",
    ) -> None:
        """Check and append one chunk of any length.

        x, y: (n,) integer pixel coordinates; t: (n,) integer microseconds, non-decreasing
        across chunks; p: (n,) polarity already in {-1, +1}. ``source`` and ``first_row``
        locate errors (row numbers count from ``first_row`` for the chunk's first event).
        The arrays are copied before this returns, so the caller may reuse them.
        """
        raise_if_requested()
        n = len(t)
        if not (len(x) == len(y) == len(p) == n):
            raise InputError(
                f"event columns differ in length (x {len(x)}, y {len(y)}, t {n}, p {len(p)})",
                path=source,
            )
        if n == 0:
            return
        x, y, t, p = np.asarray(x), np.asarray(y), np.asarray(t), np.asarray(p)
        for name, values, unit in (
            ("x", x, "px"),
            ("y", y, "px"),
            ("t", t, "microseconds"),
            ("p", p, "-1/+1"),
        ):
            if values.dtype.kind not in "iufb":
                raise InputError(
                    f"column {name} has dtype {values.dtype}; expected integers ({unit})",
                    path=source,
                )
            if values.dtype.kind == "f":
                # the integer cast would truncate 3.5 to 3 and turn NaN into garbage silently
                fraction = values != np.trunc(values)
                if fraction.any():
                    i = int(np.flatnonzero(fraction)[0])
                    raise InputError(
                        f"{name} = {values[i]} is not a whole number ({unit})",
                        path=source,
                        where=f"{row_label} {first_row + i}",
                    )
        if t.dtype == np.uint64 and t.max() > np.iinfo(np.int64).max:
            fail_at = int(np.flatnonzero(t > np.iinfo(np.int64).max)[0])
            raise InputError(
                f"timestamp {t[fail_at]} us does not fit int64",
                path=source,
                where=f"{row_label} {first_row + fail_at}",
            )
        t = t.astype(np.int64, copy=False)
        self._check(x, y, t, p, source, first_row, row_label)
        start = self.n
        t_first = int(t[0]) if self.t_first is None else self.t_first
        if int(t[-1]) - t_first > self.MAX_SPAN_US:
            i = int(np.flatnonzero(t - t_first > self.MAX_SPAN_US)[0])
            raise InputError(
                f"timestamp {t[i]} us is {(int(t[i]) - t_first) / 3.6e9:.1f} h after "
                f"the first event ({t_first} us); a trial may span at most "
                f"{self.MAX_SPAN_US / 3.6e9:.0f} h: are the times in microseconds?",
                path=source,
                where=f"{row_label} {first_row + i}",
            )
        self.t_first = t_first
        self.t_last = int(t[-1])
        # first index of every millisecond boundary reached inside this chunk
        last_ms = (self.t_last - self.t_first) // 1000
        if last_ms >= self._next_ms:
            edges = self.t_first + 1000 * np.arange(self._next_ms, last_ms + 1, dtype=np.int64)
            self._ms_index.append(start + np.searchsorted(t, edges, side="left"))
            self._next_ms = int(last_ms) + 1
        self.n += n
        self._stage_events({"x": x, "y": y, "t": t, "p": p}, n)

    def _check(self, x, y, t, p, source, first_row, row_label) -> None:
        def fail(mask: np.ndarray, what: str) -> None:
            i = int(np.flatnonzero(mask)[0])
            raise InputError(what, path=source, where=f"{row_label} {first_row + i}")

        # min/max first: one pass each, no temporaries; the mask only to name the row
        if x.min() < 0 or x.max() >= self.width:
            bad = (x < 0) | (x >= self.width)
            fail(
                bad,
                f"x = {x[np.flatnonzero(bad)[0]]} is outside the sensor (width {self.width} px)",
            )
        if y.min() < 0 or y.max() >= self.height:
            bad = (y < 0) | (y >= self.height)
            fail(
                bad,
                f"y = {y[np.flatnonzero(bad)[0]]} is outside the sensor (height {self.height} px)",
            )
        if p.min() < -1 or p.max() > 1 or not p.all():
            bad = (p != 1) & (p != -1)
            fail(bad, f"polarity {p[np.flatnonzero(bad)[0]]} is not -1/+1 after conversion")
        back = t[1:] < t[:-1]
        if back.any():
            i = int(np.flatnonzero(back)[0])
            raise InputError(
                f"timestamp {t[i + 1]} us is earlier than the previous {t[i]} us "
                "(timestamps must not decrease)",
                path=source,
                where=f"{row_label} {first_row + i + 1}",
            )
        if self.t_last is not None and t[0] < self.t_last:
            raise InputError(
                f"timestamp {t[0]} us is earlier than the previous {self.t_last} us "
                "(timestamps must not decrease)",
                path=source,
                where=f"{row_label} {first_row}",
            )

    # -- chunk pipeline ---------------------------------------------------------------
    def _stage_events(self, columns: dict[str, np.ndarray], n: int) -> None:
        pos = 0
        while pos < n:
            take = min(EVENT_CHUNK - self._fill, n - pos)
            for name, values in columns.items():
                np.copyto(
                    self._stage[name][self._fill : self._fill + take],
                    values[pos : pos + take],
                    casting="unsafe",
                )  # ranges were checked, the casts are exact
            self._fill += take
            pos += take
            if self._fill == EVENT_CHUNK:
                self._submit_chunk()

    def _submit_chunk(self) -> None:
        k = self._next_chunk
        for name, dtype in self._COLUMNS:
            buf = self._stage[name]
            job = (
                None
                if self._level is None
                else self._executor().submit(self._deflate, buf, self._level)
            )
            self._pending.append((name, k, buf, job))
            spare = self._spare[name]
            self._stage[name] = spare.pop() if spare else np.empty(EVENT_CHUNK, dtype)
        self._next_chunk += 1
        self._fill = 0
        self._write_ready(self._max_pending)

    def _write_ready(self, keep: int) -> None:
        """Write finished chunks in order until at most ``keep`` jobs are in flight."""
        while len(self._pending) > keep:
            name, k, buf, job = self._pending.popleft()
            data = buf if job is None else job.result()
            needed = min((k + 1) * EVENT_CHUNK, self.n)
            if needed > self._extent:  # a direct chunk write needs the chunk inside the extent
                for ds in self._ds.values():
                    ds.resize((needed,))
                self._extent = needed
            self._ds[name].id.write_direct_chunk((k * EVENT_CHUNK,), data)
            self._spare[name].append(buf)

    @staticmethod
    def _deflate(buf: np.ndarray, level: int) -> bytes:
        """One chunk encoded as HDF5's shuffle then deflate filters encode it.

        buf: (EVENT_CHUNK,) column values. Shuffle writes byte 0 of every element, then
        byte 1, ...; deflate is zlib ``compress2`` (zlib header and Adler-32) at ``level``.
        """
        if buf.itemsize > 1:
            buf = np.ascontiguousarray(buf.view(np.uint8).reshape(-1, buf.itemsize).T)
        return zlib.compress(buf, level)

    @staticmethod
    def _pool_size() -> int:
        try:
            return max(1, len(os.sched_getaffinity(0)))  # the CPUs this process may use
        except AttributeError:  # not on Linux
            return max(1, os.cpu_count() or 1)

    @classmethod
    def _executor(cls) -> ThreadPoolExecutor:
        """The process-wide deflate pool, created on first use (and again after a fork,
        whose child does not inherit the parent's threads)."""
        with cls._pool_lock:
            if cls._pool is None or cls._pool_pid != os.getpid():
                cls._pool = ThreadPoolExecutor(
                    max_workers=cls._pool_size(), thread_name_prefix="tactile-deflate"
                )
                cls._pool_pid = os.getpid()
            return cls._pool

    def close(self, *, t_origin_us: int | None = None) -> int:
        """Write the last chunk, the millisecond index, the time origin and the trial
        duration; returns the event count.

        ``t_origin_us`` is the event timestamp at the trial's time 0 (attribute
        ``t_origin_us``); ``None`` applies :func:`event_time_origin_us` to the first event.
        The duration runs from the earlier of the origin and the first event to the last.
        """
        if self._fill:
            for name, _ in self._COLUMNS:
                self._stage[name][self._fill :] = 0  # HDF5's fill value, as its own filter pads
            self._submit_chunk()
        self._write_ready(0)
        self._stage.clear()
        self._spare.clear()
        idx = np.concatenate(self._ms_index) if self._ms_index else np.zeros(0, dtype=np.int64)
        self.group.create_dataset("ms_to_idx", data=idx.astype(np.int64))
        # _check applied the schema's content rules (ranges, polarity, time order) to every
        # event before it was written, so the commit need not inflate these columns again
        self.trial.store.verified.update(f"{self.group.name}/{c}" for c in ("x", "y", "t", "p"))
        self.group.attrs["ms_index_origin_us"] = np.int64(self.t_first or 0)
        if self.t_first is not None and self.t_last is not None:
            origin = event_time_origin_us(self.t_first) if t_origin_us is None else t_origin_us
            self.group.attrs["t_origin_us"] = np.int64(origin)
            self.trial._extend_duration((self.t_last - min(origin, self.t_first)) * 1e-6)
        return self.n
