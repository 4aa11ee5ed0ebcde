"""Event streams from tables: CSV files with columns t, x, y, p and NumPy .npy structured arrays.

One trial per input file (named after the file stem), all from one event-camera sensor
(``--sensor``, default ``event_camera``) whose size comes from ``--width`` and ``--height``:
neither format records it. Files are read in blocks, so memory stays bounded whatever
their length.

CSV rules (each broken rule is an :class:`~tactile_cli.errors.InputError` naming the file
and the line, where line 1 is the header):

- The first line is a header naming exactly the columns ``t``, ``x``, ``y``, ``p`` in any
  order. A missing column is an error naming it; extra columns are errors naming them too
  (dropping data without a word is worse than asking the user to remove a column).
- Every data line holds one integer per column (``t`` in microseconds, ``x``/``y`` in
  pixels): a short line, an extra field (a trailing comma included), an empty line or a
  non-integer value is an error (surrounding spaces, quotes and a trailing ``.0`` are
  accepted, as pandas reads them). Blank lines at the very end of the file are ignored.
- Polarity is either 0/1 or -1/+1; the convention is detected once per file from the
  first 0 or -1, and any later value outside it (``2``, or a ``-1`` in a 0/1 file) is an
  error. Stored polarity is always -1/+1 (0 becomes -1).
- Timestamps must not decrease; pixels must lie inside the sensor.

Time origin (events attribute ``t_origin_us``, the timestamp at the trial's time 0): 0 when
the first timestamp is below 2**40 us (times relative to the trial start, as ``tactile
simulate marker-events`` writes them), else the first timestamp (epoch times); see
:func:`~tactile_cli.store.writer.event_time_origin_us`.

NPY rules: a 1-D structured array with integer fields ``t``, ``x``, ``y``, ``p`` (``p`` may be
bool); missing or extra fields are errors. A plain 2-D (n, 4) array is refused, because
its column order would be a guess. Error locations are 0-based array indices
(``index 17``), as numpy counts.

CSV parsing uses pandas' C engine with explicit int64 dtypes on 4 MiB blocks of whole
lines, a few blocks ahead in a thread pool (its tokenizer and integer conversion release
the GIL), while the appender checks and compresses earlier blocks and the source's
SHA-256 is computed alongside. When a block fails, a line-by-line pass over that block
alone finds the first bad line, so the fast path never tracks lines itself.
"""

from __future__ import annotations

import csv
import io
import os
import re
import threading
import tokenize
from collections import deque
from collections.abc import Generator, Iterator, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import NoReturn

import numpy as np

from ..config_file import decode_utf8
from ..errors import InputError
from ..progress import Progress
from ..store.writer import StoreWriter, TrialWriter, event_time_origin_us, safe_name
from .contract import (
    FormatOptions,
    IngestFormat,
    RecordingSummary,
    StreamSummary,
    TrialSummary,
)

COLUMNS = ("t", "x", "y", "p")
DEFAULT_SENSOR = "event_camera"

#: CSV bytes parsed per block for each event of ``EventTableOptions.chunk_events`` (a
#: ``t,x,y,p`` line with absolute microsecond times is about 26 bytes) ...
_CSV_BYTES_PER_EVENT = 26
#: ... up to this many: larger blocks are slower, not faster (fresh multi-MiB buffers
#: cost page faults: reading 540 MB took 0.9 s in 32 MiB blocks, 0.09 s in 4 MiB ones).
_CSV_BLOCK_BYTES = 1 << 22
#: Longest header line or data line accepted; a longer one means this is not an event CSV.
_MAX_LINE_BYTES = 1 << 16
_INT = re.compile(r"\s*[+-]?\d+(\.0*)?\s*")  # what pandas' C engine accepts as an int64
_INT64 = np.iinfo(np.int64)
#: Blocks parsed ahead of the one being appended (each holds its text and its columns).
_BLOCKS_AHEAD = 3
_POOL: ThreadPoolExecutor | None = None
_POOL_PID = 0
_POOL_LOCK = threading.Lock()
#: Magic bytes every .npy file starts with.
NPY_MAGIC = b"\x93NUMPY"


class EventTableOptions(FormatOptions):
    """Options of the event CSV and NPY formats."""

    width_px: int | None = None
    """Event sensor width in px (required: event tables do not record it)."""
    height_px: int | None = None
    """Event sensor height in px (required: event tables do not record it)."""
    sensor_name: str | None = None
    """Name of the event-camera sensor (default ``event_camera``)."""
    chunk_events: int = 1 << 20
    """Events read per block while streaming (memory stays bounded by it)."""


# -- shared by the event readers ------------------------------------------------------------
def event_sensor(writer: StoreWriter, name: str, *, width_px: int, height_px: int,
                 description: str = "", source: str | Path | None = None) -> str:
    """Add an event-camera sensor once per file, or reuse it when an earlier input added it
    with the same size; returns its (sanitised) name."""
    key = safe_name(name)
    sensors = writer.h5["sensors"]
    if key not in sensors:
        return writer.add_sensor(name, kind="event_camera", sample_rate_hz=0.0, width_px=width_px,
                                 height_px=height_px, description=description)
    attrs = sensors[key].attrs
    have = (int(attrs.get("width_px", -1)), int(attrs.get("height_px", -1)))
    if have != (width_px, height_px):
        raise InputError(f"sensor {key!r} is {width_px}x{height_px} px here but "
                         f"{have[0]}x{have[1]} px in an earlier input; ingest them separately "
                         "or name the sensors apart", path=source)
    return key


def link_source(trial: TrialWriter, hashing: Future[int]) -> None:
    """Point a trial at its source file once ``writer.add_source`` has run in the pool.

    The SHA-256 of a large input takes a second per ~1.3 GB; started in the pool when the
    file is opened, it runs while the file is parsed and compressed instead of before.
    """
    trial.set_sources([hashing.result()])


def sensor_size(options: EventTableOptions | FormatOptions, what: str,
                path: Path | None = None) -> tuple[int, int]:
    """(width, height) in px from ``--width``/``--height``, which ``what`` files lack."""
    width_px, height_px = getattr(options, "width_px", None), getattr(options, "height_px", None)
    if width_px is None or height_px is None:
        raise InputError(f"{what} files do not record the sensor size; pass `width_px` and "
                         "`height_px` (pixels), e.g. `width_px=320` `height_px=240`", path=path)
    for flag, value in (("`width_px`", width_px), ("`height_px`", height_px)):
        if value < 1 or value > 65536:
            raise InputError(f"{flag} (={value}) must be between 1 and 65536 px")
    return int(width_px), int(height_px)


@dataclass
class PolarityConvention:
    """The polarity convention of one file, fixed by its first 0 or -1.

    ``name`` is ``"0/1"`` or ``"-1/+1"`` once detected (``None`` while only 1s were seen);
    ``where`` is the location that fixed it (``"line 17"``).
    """

    name: str | None = None
    where: str | None = None

    def to_pm1(self, p: np.ndarray, *, path: str | Path, first_row: int,
               row_label: str) -> np.ndarray:
        """(n,) polarity of the file's convention as (n,) int8 -1/+1; raises InputError
        naming the first value outside it."""
        p = np.asarray(p)
        if p.size == 0:
            return p.astype(np.int8)
        if self.name is None:
            first = np.flatnonzero((p == 0) | (p == -1))
            if first.size:
                i = int(first[0])
                self.name = "0/1" if p[i] == 0 else "-1/+1"
                self.where = f"{row_label} {first_row + i}"
        low = 0 if self.name == "0/1" else -1
        # reductions first (no temporaries); the mask only to name the bad row
        if self.name is None:  # only 1s (or invalid values) so far
            ok = p.min() == 1 and p.max() == 1
        else:
            ok = p.min() >= low and p.max() <= 1 and (low == 0 or np.count_nonzero(p) == p.size)
        if not ok:
            bad = p != 1 if self.name is None else (p != low) & (p != 1)
            i = int(np.flatnonzero(bad)[0])
            value = p[i]
            if self.name is None:
                what = f"polarity {value} is neither 0/1 nor -1/+1"
            elif value in (0, -1):
                what = (f"polarity {value} mixes conventions: this file uses {self.name} "
                        f"(from {self.where}); use one of 0/1 or -1/+1 throughout")
            else:
                what = f"polarity {value} is outside this file's convention {self.name}"
            raise InputError(what, path=path, where=f"{row_label} {first_row + i}")
        if self.name == "0/1":
            return (2 * p.astype(np.int8) - 1).astype(np.int8)
        return p.astype(np.int8, copy=False)


# -- CSV ------------------------------------------------------------------------------------
def ingest_events_csv(inputs: Sequence[Path], options: EventTableOptions, writer: StoreWriter,
                      progress: Progress) -> list[str]:
    """Add one trial per CSV file of events (columns t, x, y, p; see the module docstring)."""
    width, height = sensor_size(options, "event CSV", inputs[0])
    sensor = event_sensor(writer, options.sensor_name or DEFAULT_SENSOR, width_px=width,
                          height_px=height, description="events from CSV (t us, x px, y px, p)")
    progress.start(sum(_regular_file(p).stat().st_size for p in inputs), "events CSV")
    block_bytes = max(_MAX_LINE_BYTES,
                      min(_CSV_BLOCK_BYTES, options.chunk_events * _CSV_BYTES_PER_EVENT))
    for path in inputs:
        hashing = _parse_pool().submit(writer.add_source, path)
        trial = writer.trial(path.stem)
        events = trial.events(sensor)
        polarity = PolarityConvention()
        for first_line, table, n_bytes in read_csv_blocks(path, block_bytes=block_bytes):
            p = polarity.to_pm1(table["p"], path=path, first_row=first_line, row_label="line")
            events.append(table["x"], table["y"], table["t"], p, source=path,
                          first_row=first_line, row_label="line")
            progress.advance(n_bytes)
        if events.close() == 0:
            raise InputError("no events after the header", path=path, where="line 2")
        link_source(trial, hashing)
    progress.finish()
    return []


def read_csv_blocks(path: Path, *, block_bytes: int = _CSV_BLOCK_BYTES
                    ) -> Iterator[tuple[int, dict[str, np.ndarray], int]]:
    """Parse an event CSV block by block.

    Yields ``(first_line, columns, n_bytes)`` in file order: the file line number of the
    block's first row (the header is line 1), ``{"t", "x", "y", "p"}`` -> (n,) int64
    arrays, and the bytes the block took in the file. Raises InputError naming the first
    bad line. Blocks are parsed ahead in a thread pool (pandas' C tokenizer and integer
    conversion run without the GIL), at most :data:`_BLOCKS_AHEAD` at a time, so memory
    stays bounded.
    """
    import pandas  # noqa: F401  (imported here, once, not by the workers; NPY needs none)

    with open(path, "rb") as f:
        names = _read_header(f, path)
        dtypes = dict.fromkeys(names, np.int64)
        pending: deque[tuple[bytes, Future[_Parsed]]] = deque()
        line = 2
        for block in _line_blocks(f, path, block_bytes):
            pending.append((block, _parse_pool().submit(_parse_block, block, names, dtypes)))
            if len(pending) < _BLOCKS_AHEAD:
                continue
            line = yield from _finish_block(*pending.popleft(), names, path, line)
        while pending:
            line = yield from _finish_block(*pending.popleft(), names, path, line)


def _finish_block(block: bytes, job: Future[_Parsed], names: list[str], path: Path, line: int
                  ) -> Generator[tuple[int, dict[str, np.ndarray], int], None, int]:
    """Yield one parsed block (or raise for its first bad line); returns the next line."""
    parsed = job.result()
    if parsed.columns is None:
        _raise_first_bad_line(block, names, path, line, parsed.error)
    yield line, parsed.columns, len(block)
    return line + len(parsed.columns["t"])


def _line_blocks(f: io.BufferedReader, path: Path, block_bytes: int) -> Iterator[bytes]:
    """The data lines after the header in blocks of whole lines, each ending in a newline.

    Each block's end is found first (the newline after ``block_bytes``), then the block is
    read in one piece: one fresh buffer per block, no carried partial line to join.
    """
    pos = f.tell()
    end = _data_end(f)
    while pos < end:
        stop = pos + block_bytes
        if stop < end:
            f.seek(stop)
            tail = f.read(_MAX_LINE_BYTES)
            newline = tail.find(b"\n")
            if newline < 0:
                raise InputError(f"a line is longer than {_MAX_LINE_BYTES} bytes; an event CSV "
                                 "has one short t,x,y,p line per event", path=path)
            stop += newline + 1
        stop = min(stop, end)
        f.seek(pos)
        block = f.read(stop - pos)
        pos = stop
        yield block if block.endswith(b"\n") else block + b"\n"  # the last line may lack one


def _read_header(f: io.BufferedReader, path: Path) -> list[str]:
    raw = f.readline(_MAX_LINE_BYTES)
    if not raw:
        raise InputError("file is empty; expected a header line naming t, x, y, p", path=path)
    text = decode_utf8(raw, path).rstrip("\r\n")
    names = [c.strip() for c in next(csv.reader([text]))] if text.strip() else []
    missing = [c for c in COLUMNS if c not in names]
    extra = [c for c in names if c not in COLUMNS]
    if missing:
        hint = "" if set(names) & set(COLUMNS) else " (the first line must be a header: t,x,y,p)"
        if not set(names) & {"x", "y", "p"}:  # not an event table at all
            hint += ("; a CSV of another sensor is read with a mapping (`mapping='FILE.yaml'`, "
                     "see configs/mapping_example.yaml)")
        raise InputError(f"missing column{'s' if len(missing) > 1 else ''} "
                         f"{', '.join(map(repr, missing))}; the header names {names}{hint}",
                         path=path, where="line 1")
    if extra:
        raise InputError(f"unexpected column{'s' if len(extra) > 1 else ''} "
                         f"{', '.join(map(repr, extra))}; an event CSV has exactly the columns "
                         "t, x, y, p (any order): remove the others", path=path, where="line 1")
    if len(names) != len(set(names)):
        raise InputError(f"a column is named twice in the header {names}", path=path,
                         where="line 1")
    return names


def _data_end(f: io.BufferedReader) -> int:
    """File offset after the last non-blank byte (blank lines at the end are ignored)."""
    size = f.seek(0, io.SEEK_END)
    tail_start = max(0, size - _MAX_LINE_BYTES)
    f.seek(tail_start)
    tail = f.read()
    return tail_start + len(tail.rstrip(b" \t\r\n"))


@dataclass(frozen=True)
class _Parsed:
    """A parsed block: its columns, or None and the parser's error (None when the block
    parsed but its line or separator count shows a broken line)."""

    columns: dict[str, np.ndarray] | None
    error: BaseException | None = None


def _parse_block(block: bytes, names: list[str], dtypes: dict[str, type]) -> _Parsed:
    """Parse one block of whole lines (runs in the parse pool)."""
    import pandas as pd

    try:
        table = pd.read_csv(io.BytesIO(block), header=None, names=names, dtype=dtypes,
                            engine="c", na_filter=False, skip_blank_lines=False)
    except (ValueError, OverflowError, TypeError, Warning) as exc:
        return _Parsed(None, exc)
    # pandas can take a first column as the index, or drop an empty trailing field,
    # without an error; counting separators catches both (an empty line fails the int
    # parse, so every line gave one row)
    n_commas = int(np.count_nonzero(np.frombuffer(block, dtype=np.uint8) == ord(",")))
    if n_commas != (len(names) - 1) * len(table):
        return _Parsed(None)
    return _Parsed({name: table[name].to_numpy() for name in COLUMNS})


def _parse_pool() -> ThreadPoolExecutor:
    """The process-wide CSV parse pool (made again after a fork, whose child has no
    threads of its parent)."""
    global _POOL, _POOL_PID
    with _POOL_LOCK:
        if _POOL is None or _POOL_PID != os.getpid():
            workers = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") \
                else (os.cpu_count() or 1)
            _POOL = ThreadPoolExecutor(max_workers=max(1, workers),
                                       thread_name_prefix="tactile-csv")
            _POOL_PID = os.getpid()
        return _POOL


def _raise_first_bad_line(block: bytes, names: list[str], path: Path, first_line: int,
                          exc: BaseException | None) -> NoReturn:
    """Find the first line of ``block`` that breaks the CSV rules and raise for it."""
    for k, raw_line in enumerate(block.split(b"\n")[:-1]):
        where = f"line {first_line + k}"
        text = decode_utf8(raw_line, path, first_line=first_line + k).rstrip("\r")
        if not text.strip():
            raise InputError("empty line; every line after the header holds one event t,x,y,p",
                             path=path, where=where)
        fields = next(csv.reader([text]))
        if len(fields) != len(names):
            kind = "short line" if len(fields) < len(names) else "extra field"
            raise InputError(f"{kind}: {len(fields)} fields, expected {len(names)} "
                             f"({','.join(names)})", path=path, where=where)
        for name, field in zip(names, fields, strict=True):
            if not _INT.fullmatch(field):
                raise InputError(f"{name} = {field!r} is not an integer", path=path, where=where)
            value = int(field.strip().split(".")[0])
            if not _INT64.min <= value <= _INT64.max:
                raise InputError(f"{name} = {value} is out of range (int64)", path=path,
                                 where=where)
    last = first_line + block.count(b"\n") - 1
    message = str(exc).strip() if exc is not None else ""
    detail = f" ({message.splitlines()[0]})" if message else ""
    raise InputError(f"cannot parse lines {first_line}-{last} as integers t,x,y,p{detail}",
                     path=path)


# -- NPY ------------------------------------------------------------------------------------
def ingest_events_npy(inputs: Sequence[Path], options: EventTableOptions, writer: StoreWriter,
                      progress: Progress) -> list[str]:
    """Add one trial per .npy structured array of events (fields t, x, y, p)."""
    width, height = sensor_size(options, "event NPY", inputs[0])
    sensor = event_sensor(writer, options.sensor_name or DEFAULT_SENSOR, width_px=width,
                          height_px=height, description="events from NPY (t us, x px, y px, p)")
    progress.start(sum(_regular_file(p).stat().st_size for p in inputs), "events NPY")
    for path in inputs:
        _npy_layout(path)  # refused before the trial is started
        hashing = _parse_pool().submit(writer.add_source, path)
        trial = writer.trial(path.stem)
        events = trial.events(sensor)
        for start, block, p in read_npy_blocks(path, chunk_events=options.chunk_events):
            events.append(block["x"], block["y"], block["t"], p, source=path,
                          first_row=start, row_label="index")
            progress.advance(block.nbytes)
        if events.close() == 0:
            raise InputError("the array holds no events", path=path)
        link_source(trial, hashing)
    progress.finish()
    return []


def read_npy_blocks(path: Path, *, chunk_events: int = 1 << 20
                    ) -> Iterator[tuple[int, np.ndarray, np.ndarray]]:
    """Read an event .npy file block by block: yields ``(first index, block, p)``, the
    block a structured array of at most ``chunk_events`` events (a view of one reused
    buffer) and p its (n,) int8 polarity as -1/+1. Raises InputError for a damaged or cut
    file and for a polarity outside the file's convention."""
    dtype, n, offset = _npy_layout(path)
    polarity = PolarityConvention()
    chunk = max(1, chunk_events)
    buffer = np.empty(min(chunk, n), dtype=dtype)
    with open(path, "rb") as f:
        f.seek(offset)
        for start in range(0, n, chunk):
            block = buffer[:min(chunk, n - start)]
            got = f.readinto(block.view(np.uint8))
            if got != block.nbytes:
                raise InputError(f"file is truncated: its header announces {n} events, the "
                                 f"data end inside event {start + got // dtype.itemsize}",
                                 path=path)
            p = polarity.to_pm1(block["p"].astype(np.int8) if block["p"].dtype == bool
                                else block["p"], path=path, first_row=start, row_label="index")
            yield start, block, p


def _npy_layout(path: Path) -> tuple[np.dtype, int, int]:
    """(dtype, event count, byte offset of the data) of an event .npy file."""
    _regular_file(path)
    try:
        array = np.load(path, mmap_mode="r", allow_pickle=False)
    except (ValueError, OSError, EOFError, SyntaxError, TypeError, OverflowError, MemoryError,
            tokenize.TokenError) as exc:  # a damaged header dict fails in numpy's parser
        detail = " ".join(str(exc).split())[:200] or type(exc).__name__
        raise InputError(f"not a readable .npy array (damaged header or data: {detail})",
                         path=path) from None
    if not isinstance(array, np.memmap):  # an .npz archive
        close = getattr(array, "close", None)
        if close is not None:
            close()
        raise InputError("not a single .npy array (an .npz archive?); save each recording "
                         "with numpy.save", path=path)
    dtype, shape, offset = array.dtype, array.shape, int(array.offset)
    del array  # unmap: the data are read block by block with plain reads
    fields = dtype.names
    if fields is None:
        raise InputError(f"a plain {dtype} array of shape {shape}, not a structured array "
                         "with fields t, x, y, p (column order would be a guess); save one with "
                         "numpy.save(path, numpy.rec.fromarrays([t, x, y, p], names='t,x,y,p'))",
                         path=path)
    if len(shape) != 1:
        raise InputError(f"has shape {shape}; expected a 1-D structured array (one element "
                         "per event)", path=path)
    missing = [c for c in COLUMNS if c not in fields]
    extra = [c for c in fields if c not in COLUMNS]
    if missing:
        raise InputError(f"missing field{'s' if len(missing) > 1 else ''} "
                         f"{', '.join(map(repr, missing))}; the array has fields {list(fields)}",
                         path=path)
    if extra:
        raise InputError(f"unexpected field{'s' if len(extra) > 1 else ''} "
                         f"{', '.join(map(repr, extra))}; an event array has exactly the fields "
                         "t, x, y, p: drop the others", path=path)
    for name in COLUMNS:
        field = dtype.fields[name][0]  # type: ignore[index]
        kinds = "iub" if name == "p" else "iu"
        if field.kind not in kinds or field.shape != ():
            unit = {"t": "integer microseconds", "x": "integer px", "y": "integer px",
                    "p": "integer or bool polarity"}[name]
            raise InputError(f"field {name!r} has dtype {field}; expected {unit}", path=path)
    return dtype, int(shape[0]), offset


def _regular_file(path: Path) -> Path:
    if not path.is_file():
        raise InputError("not a file (a folder?); give event files", path=path)
    return path


# -- describe and the two formats ----------------------------------------------------------
@dataclass
class _EventTally:
    """Counts, time range and pixel range of one event table, block by block."""

    n: int = 0
    t_first: int | None = None
    t_last: int | None = None
    t_max: int | None = None
    out_of_order: int = 0
    x_range: tuple[int, int] | None = None
    y_range: tuple[int, int] | None = None

    def add(self, t: np.ndarray, x: np.ndarray, y: np.ndarray) -> None:
        if not len(t):
            return
        t = np.asarray(t, dtype=np.int64)
        latest = np.maximum.accumulate(t)
        before = np.concatenate(([self.t_max if self.t_max is not None else t[0]],
                                 latest[:-1]))
        self.out_of_order += int(np.count_nonzero(t < before))
        self.n += len(t)
        self.t_first = int(t[0]) if self.t_first is None else self.t_first
        self.t_last = int(t[-1])
        self.t_max = int(latest[-1]) if self.t_max is None else max(self.t_max, int(latest[-1]))
        for name, values in (("x_range", x), ("y_range", y)):
            lo, hi = int(np.min(values)), int(np.max(values))
            have = getattr(self, name)
            setattr(self, name, (lo, hi) if have is None else (min(have[0], lo), max(have[1], hi)))


def _describe_events(path: Path, fmt: IngestFormat, options: EventTableOptions,
                     tally: _EventTally) -> RecordingSummary:
    """The summary of one event table once every block was tallied."""
    notes: list[str] = []
    span_s = None
    if tally.t_first is not None and tally.t_last is not None and tally.t_max is not None:
        span_s = (tally.t_max - tally.t_first) * 1e-6
    stream = StreamSummary(
        name="events", type="events", count=tally.n, unit="events",
        t_first_s=None if tally.t_first is None else tally.t_first * 1e-6,
        t_last_s=None if tally.t_last is None else tally.t_last * 1e-6, span_s=span_s,
        size_bytes=path.stat().st_size, width_px=options.width_px, height_px=options.height_px,
        out_of_order_stamps=tally.out_of_order,
        extra={"t_first_us": tally.t_first, "t_last_us": tally.t_last,
               "x_range": list(tally.x_range) if tally.x_range else None,
               "y_range": list(tally.y_range) if tally.y_range else None,
               "events_per_s": tally.n / span_s if span_s else None})
    if tally.n == 0:
        notes.append("the table holds no events: an ingest refuses it")
    if tally.out_of_order:
        notes.append(f"{tally.out_of_order:,} events are earlier than an event before them: an "
                     "ingest refuses the file (events must be in time order)")
    if tally.x_range and tally.y_range:
        need_w, need_h = tally.x_range[1] + 1, tally.y_range[1] + 1
        if options.width_px is None or options.height_px is None:
            notes.append(f"the table does not record the sensor size; its pixels need at least "
                         f"`width_px={need_w}` `height_px={need_h}`")
        elif tally.x_range[0] < 0 or tally.y_range[0] < 0 or need_w > options.width_px \
                or need_h > options.height_px:
            notes.append(f"pixels x {tally.x_range[0]}..{tally.x_range[1]}, y "
                         f"{tally.y_range[0]}..{tally.y_range[1]} fall outside a "
                         f"{options.width_px}x{options.height_px} px sensor: an ingest refuses "
                         "the file")
    if tally.t_first is not None:
        origin = event_time_origin_us(tally.t_first)
        notes.append(f"trial time 0 is {origin} us "
                     f"({'relative times' if origin == 0 else 'the first event'})")
    size = ({"width_px": str(options.width_px), "height_px": str(options.height_px)}
            if options.width_px is not None and options.height_px is not None
            else {"width_px": "WIDTH", "height_px": "HEIGHT"})
    trial = TrialSummary(name=path.stem, source=str(path), counts={"events": tally.n},
                         duration_s=span_s)
    return RecordingSummary(file=str(path), format=fmt.name, title=fmt.title,
                            size_bytes=path.stat().st_size, streams=[stream], trials=[trial],
                            notes=notes, ingest_options=size)


class EventCsvFormat(IngestFormat[EventTableOptions]):
    """CSV files of events, one per trial (see the module docstring)."""

    name = "events-csv"
    title = "event CSV"
    summary = "CSV files of events with the header t,x,y,p (t in us), one trial per file"
    suffixes = (".csv",)
    Options = EventTableOptions

    def sniff(self, path: Path) -> bool:
        return path.suffix.lower() == ".csv" and not path.is_dir()

    def describe(self, path: Path, options: EventTableOptions) -> RecordingSummary:
        _regular_file(path)
        tally = _EventTally()
        polarity = PolarityConvention()
        for first_line, table, _ in read_csv_blocks(path):
            polarity.to_pm1(table["p"], path=path, first_row=first_line, row_label="line")
            tally.add(table["t"], table["x"], table["y"])
        summary = _describe_events(path, self, options, tally)
        summary.streams[0].extra["polarity"] = polarity.name
        return summary

    def read(self, inputs: Sequence[Path], options: EventTableOptions, writer: StoreWriter,
             progress: Progress) -> list[str]:
        return ingest_events_csv(inputs, options, writer, progress)


class EventNpyFormat(IngestFormat[EventTableOptions]):
    """NumPy structured arrays of events, one per trial (see the module docstring)."""

    name = "events-npy"
    title = "event NPY"
    summary = "NumPy .npy structured arrays of events (fields t, x, y, p), one trial per file"
    suffixes = (".npy",)
    Options = EventTableOptions

    def sniff(self, path: Path) -> bool:
        if path.suffix.lower() == ".npy":
            return not path.is_dir()
        try:
            with open(path, "rb") as f:
                return f.read(len(NPY_MAGIC)) == NPY_MAGIC
        except OSError:
            return False

    def describe(self, path: Path, options: EventTableOptions) -> RecordingSummary:
        tally = _EventTally()
        for _, block, _ in read_npy_blocks(path, chunk_events=options.chunk_events):
            tally.add(block["t"], block["x"], block["y"])
        return _describe_events(path, self, options, tally)

    def read(self, inputs: Sequence[Path], options: EventTableOptions, writer: StoreWriter,
             progress: Progress) -> list[str]:
        return ingest_events_npy(inputs, options, writer, progress)


EVENTS_CSV = EventCsvFormat()
EVENTS_NPY = EventNpyFormat()

__all__ = ["EVENTS_CSV", "EVENTS_NPY", "EventCsvFormat", "EventNpyFormat", "EventTableOptions",
           "ingest_events_csv", "ingest_events_npy", "read_csv_blocks", "read_npy_blocks",
           "event_sensor", "sensor_size", "PolarityConvention"]
