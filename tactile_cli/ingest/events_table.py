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
  non-integer value is an error. Blank lines at the very end of the file are ignored.
- Polarity is either 0/1 or -1/+1; the convention is detected once per file from the
  first 0 or -1, and any later value outside it (``2``, or a ``-1`` in a 0/1 file) is an
  error. Stored polarity is always -1/+1 (0 becomes -1).
- Timestamps must not decrease; pixels must lie inside the sensor.

NPY rules: a 1-D structured array with integer fields ``t``, ``x``, ``y``, ``p`` (``p`` may be
bool); missing or extra fields are errors. A plain 2-D (n, 4) array is refused, because
its column order would be a guess. Error locations are 0-based array indices
(``index 17``), as numpy counts.

CSV parsing uses pandas' C engine with explicit int64 dtypes on blocks of whole lines;
when a block fails, a line-by-line pass over that block finds the first bad line, so the
fast path never needs to track lines itself.
"""

from __future__ import annotations

import csv
import io
import re
import warnings
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import NoReturn

import numpy as np
import pandas as pd

from ..errors import InputError
from ..progress import Progress
from ..store.writer import StoreWriter, safe_name
from . import IngestOptions

COLUMNS = ("t", "x", "y", "p")
DEFAULT_SENSOR = "event_camera"

#: CSV bytes parsed per block for each event of ``IngestOptions.chunk_events`` (a
#: ``t,x,y,p`` line with absolute microsecond times is about 26 bytes).
_CSV_BYTES_PER_EVENT = 26
#: Longest header line or data line accepted; a longer one means this is not an event CSV.
_MAX_LINE_BYTES = 1 << 16
_INT = re.compile(r"\s*[+-]?\d+(\.0*)?\s*")  # what pandas' C engine accepts as an int64
_INT64 = np.iinfo(np.int64)


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


def sensor_size(options: IngestOptions, what: str) -> tuple[int, int]:
    """(width, height) in px from ``--width``/``--height``, which ``what`` files lack."""
    if options.width_px is None or options.height_px is None:
        raise InputError(f"{what} files do not record the sensor size; pass --width and --height "
                         "(pixels), e.g. --width 320 --height 240")
    for flag, value in (("--width", options.width_px), ("--height", options.height_px)):
        if value < 1 or value > 65536:
            raise InputError(f"{flag} (={value}) must be between 1 and 65536 px")
    return int(options.width_px), int(options.height_px)


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
        if self.name is None:
            first = np.flatnonzero((p == 0) | (p == -1))
            if first.size:
                i = int(first[0])
                self.name = "0/1" if p[i] == 0 else "-1/+1"
                self.where = f"{row_label} {first_row + i}"
        low = 0 if self.name == "0/1" else -1
        if self.name is None:  # only 1s (or invalid values) so far
            bad = p != 1
        else:
            bad = (p != low) & (p != 1)
        if bad.any():
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
def ingest_events_csv(inputs: list[Path], writer: StoreWriter, options: IngestOptions,
                      progress: Progress) -> None:
    """Add one trial per CSV file of events (columns t, x, y, p; see the module docstring)."""
    width, height = sensor_size(options, "event CSV")
    sensor = event_sensor(writer, options.sensor_name or DEFAULT_SENSOR, width_px=width,
                          height_px=height, description="events from CSV (t us, x px, y px, p)")
    progress.start(sum(_regular_file(p).stat().st_size for p in inputs), "events CSV")
    block_bytes = max(_MAX_LINE_BYTES, options.chunk_events * _CSV_BYTES_PER_EVENT)
    for path in inputs:
        source = writer.add_source(path)
        events = writer.trial(path.stem, sources=[source]).events(sensor)
        polarity = PolarityConvention()
        for first_line, table, n_bytes in read_csv_blocks(path, block_bytes=block_bytes):
            p = polarity.to_pm1(table["p"], path=path, first_row=first_line, row_label="line")
            events.append(table["x"], table["y"], table["t"], p, source=path,
                          first_row=first_line, row_label="line")
            progress.advance(n_bytes)
        if events.close() == 0:
            raise InputError("no events after the header", path=path, where="line 2")
    progress.finish()


def read_csv_blocks(path: Path, *, block_bytes: int = 1 << 25
                    ) -> Iterator[tuple[int, dict[str, np.ndarray], int]]:
    """Parse an event CSV block by block.

    Yields ``(first_line, columns, n_bytes)``: the file line number of the block's first
    row (the header is line 1), ``{"t", "x", "y", "p"}`` -> (n,) int64 arrays, and the
    bytes the block took in the file. Raises InputError naming the first bad line.
    """
    with open(path, "rb") as f:
        names = _read_header(f, path)
        header_bytes = f.tell()
        end = _data_end(f, path)
        f.seek(header_bytes)
        dtypes = dict.fromkeys(names, np.int64)
        line = 2
        carry = b""
        pos = header_bytes
        while pos < end or carry:
            data = f.read(min(block_bytes, end - pos)) if pos < end else b""
            pos += len(data)
            buf = carry + data
            if pos >= end:  # the last block; its last line may lack a newline
                block, carry = (buf if buf.endswith(b"\n") else buf + b"\n"), b""
            else:
                cut = buf.rfind(b"\n") + 1
                if cut == 0:
                    if len(buf) > _MAX_LINE_BYTES:
                        raise InputError(f"line is longer than {_MAX_LINE_BYTES} bytes; an event "
                                         "CSV has one short t,x,y,p line per event", path=path,
                                         where=f"line {line}")
                    carry = buf
                    continue
                block, carry = buf[:cut], buf[cut:]
            columns = _parse_block(block, names, dtypes, path, line)
            n_rows = len(columns["t"])
            yield line, columns, len(block)
            line += n_rows


def _read_header(f: io.BufferedReader, path: Path) -> list[str]:
    raw = f.readline(_MAX_LINE_BYTES)
    if not raw:
        raise InputError("file is empty; expected a header line naming t, x, y, p", path=path)
    text = raw.decode("utf-8-sig", errors="replace").rstrip("\r\n")
    names = [c.strip() for c in next(csv.reader([text]))] if text.strip() else []
    missing = [c for c in COLUMNS if c not in names]
    extra = [c for c in names if c not in COLUMNS]
    if missing:
        hint = "" if set(names) & set(COLUMNS) else " (the first line must be a header: t,x,y,p)"
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


def _data_end(f: io.BufferedReader, path: Path) -> int:
    """File offset after the last non-blank byte (blank lines at the end are ignored)."""
    size = f.seek(0, io.SEEK_END)
    tail_start = max(0, size - _MAX_LINE_BYTES)
    f.seek(tail_start)
    tail = f.read()
    return tail_start + len(tail.rstrip(b" \t\r\n"))


def _parse_block(block: bytes, names: list[str], dtypes: dict[str, type], path: Path,
                 first_line: int) -> dict[str, np.ndarray]:
    raw = np.frombuffer(block, dtype=np.uint8)
    n_lines = int(np.count_nonzero(raw == ord("\n")))
    try:
        with warnings.catch_warnings():
            # pandas warns, then drops data, when a first line has extra fields
            warnings.simplefilter("error")
            table = pd.read_csv(io.BytesIO(block), header=None, names=names, dtype=dtypes,
                                engine="c", na_filter=False, skip_blank_lines=False,
                                index_col=False)
    except (ValueError, OverflowError, TypeError, Warning) as exc:
        _raise_first_bad_line(block, names, path, first_line, exc)
    # pandas drops an empty trailing field silently; counting separators catches it
    n_commas = int(np.count_nonzero(raw == ord(",")))
    if len(table) != n_lines or n_commas != (len(names) - 1) * n_lines:
        _raise_first_bad_line(block, names, path, first_line, None)
    return {name: table[name].to_numpy() for name in COLUMNS}


def _raise_first_bad_line(block: bytes, names: list[str], path: Path, first_line: int,
                          exc: BaseException | None) -> NoReturn:
    """Find the first line of ``block`` that breaks the CSV rules and raise for it."""
    for k, raw_line in enumerate(block.split(b"\n")[:-1]):
        where = f"line {first_line + k}"
        text = raw_line.decode("utf-8", errors="replace").rstrip("\r")
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
def ingest_events_npy(inputs: list[Path], writer: StoreWriter, options: IngestOptions,
                      progress: Progress) -> None:
    """Add one trial per .npy structured array of events (fields t, x, y, p)."""
    width, height = sensor_size(options, "event NPY")
    sensor = event_sensor(writer, options.sensor_name or DEFAULT_SENSOR, width_px=width,
                          height_px=height, description="events from NPY (t us, x px, y px, p)")
    progress.start(sum(_regular_file(p).stat().st_size for p in inputs), "events NPY")
    for path in inputs:
        dtype, n, offset = _npy_layout(path)
        source = writer.add_source(path)
        events = writer.trial(path.stem, sources=[source]).events(sensor)
        polarity = PolarityConvention()
        chunk = max(1, options.chunk_events)
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
                events.append(block["x"], block["y"], block["t"], p, source=path,
                              first_row=start, row_label="index")
                progress.advance(block.nbytes)
        if events.close() == 0:
            raise InputError("the array holds no events", path=path)
    progress.finish()


def _npy_layout(path: Path) -> tuple[np.dtype, int, int]:
    """(dtype, event count, byte offset of the data) of an event .npy file."""
    _regular_file(path)
    try:
        array = np.load(path, mmap_mode="r", allow_pickle=False)
    except (ValueError, OSError, EOFError) as exc:
        raise InputError(f"not a readable .npy array ({str(exc).splitlines()[0]})",
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


__all__ = ["ingest_events_csv", "ingest_events_npy", "read_csv_blocks", "event_sensor",
           "sensor_size", "PolarityConvention"]
