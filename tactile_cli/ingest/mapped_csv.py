"""Sampled-signal CSVs of any sensor, described by a YAML mapping, into the tactile store.

The mapping (:mod:`tactile_cli.ingest.mapping`, documented in ``configs/mapping_example.yaml``)
says which paths are trials, which columns are time, channels and labels, the rates, units
and sensor kinds. The ingest runs in two passes:

1. **Plan**: find every trial, resolve its files, read every header and check that each
   named column exists and that all trials have the same channels. Nothing is parsed yet,
   so a typo in the mapping fails in a second, naming the file and the mapping key.
2. **Read and write**: per trial, parse each file once (pandas C engine with explicit
   settings, after a vectorised check that every row has exactly the header's field count,
   so a short row is an error with its line number, never NaN-filled; a file with quote
   characters is split by the csv module instead, honouring standard CSV quoting), build
   the time bases, and write one signal stream per mapping stream.

Time bases are seconds from the trial's first sample: the earliest first time of the
trial's column-timed streams (one clock); evenly spaced streams start at 0. Epoch time
columns record the origin in the trial attribute ``time_origin_unix_s``. Each signal group
records its per-trial nominal rate in the attribute ``sample_rate_hz``; the sensor's
``sample_rate_hz`` is the median over trials. The validated mapping is stored as JSON in
the root attribute ``mapping_json``.
"""

from __future__ import annotations

import csv
import fnmatch
import io
import re
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..config_file import decode_utf8, os_error, read_bytes
from ..errors import InputError
from ..natural import natural_key
from ..progress import Progress
from ..store.writer import StoreWriter, safe_name
from .contract import FormatOptions, IngestFormat, RecordingSummary
from .csv_records import QUOTE_BYTE, csv_records, first_record, record_cells
from .mapping import (
    ROW_FIELD,
    STEM_FIELD,
    CsvDialect,
    CsvMapping,
    Stream,
    load_mapping,
    render,
)
from .stamps import SettledStamps, StampError, settle_stamps, stamp_stats

if TYPE_CHECKING:
    import pandas as pd

#: Text values parsed as NaN (then refused as non-finite, with their line and column).
NAN_TOKENS = ("nan", "NaN", "NAN", "-nan", "-NaN", "-NAN")
#: Header names listed in a "column not found" message.
MAX_NAMES_SHOWN = 12

#: Key of a ``layout: rows`` table in a trial's files (no stream template is empty).
TABLE = ""
#: Nominal rate of one-sample streams (``rows_are: trials``): the schema wants a rate > 0.
ROW_RATE_HZ = 1.0


# -- CSV tables -------------------------------------------------------------------------------
@dataclass(frozen=True)
class CsvTable:
    """Columns of one parsed CSV file.

    columns: name -> (n_rows,) float64 (numeric columns, all finite) or object (text);
    first_data_line: 1-based line number of data row 0 in the file; row_lines: (n_rows,)
    1-based line each data row starts on when the file uses quoting (a quoted field may
    span lines), else None (data row i is on line ``first_data_line + i``).
    """

    path: Path
    names: tuple[str, ...]
    columns: dict[str, np.ndarray]
    n_rows: int
    first_data_line: int
    row_lines: np.ndarray | None = None

    def line(self, row: int) -> int:
        """1-based file line of data row ``row`` (where it starts)."""
        if self.row_lines is not None:
            return int(self.row_lines[row])
        return self.first_data_line + int(row)


def read_csv_header(path: Path, dialect: CsvDialect) -> list[str]:
    """The column names of a CSV file: its first record, or ``dialect.column_names``."""
    if not dialect.header:
        return list(dialect.column_names or [])
    try:
        with open(path, "rb") as f:
            first = first_record(f)
    except OSError as exc:
        raise os_error(exc, path, "CSV file") from None
    return _header_names(first, path, dialect)


def _header_names(first: bytes, path: Path, dialect: CsvDialect) -> list[str]:
    """The checked column names of a header record given as bytes."""
    return _checked_names(record_cells(first, path, delimiter=dialect.delimiter), path, dialect)


def _checked_names(cells: list[str], path: Path, dialect: CsvDialect) -> list[str]:
    """Header cells as column names: none empty, none repeated (a trailing delimiter's
    empty last cell dropped)."""
    if len(cells) <= 1 and not "".join(cells).strip():
        raise InputError("the header line is empty (set `header: false` and `column_names` "
                         "in the mapping if the file has no header)", path=path, where="line 1")
    names = [n.strip() for n in cells]
    if dialect.trailing_delimiter and len(names) > 1 and names[-1] == "":
        names.pop()
    if "" in names:
        raise InputError(f"header column {names.index('') + 1} has no name", path=path,
                         where="line 1")
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise InputError(f"header repeats column names: {', '.join(dup)}", path=path,
                         where="line 1")
    return names


def _line_bounds(buf: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start and end (exclusive, without ``\\r\\n``) offsets of every line of ``buf``."""
    nl = np.flatnonzero(buf == 10)
    ends = nl if len(buf) == 0 or buf[-1] == 10 else np.append(nl, len(buf))
    starts = np.concatenate(([0], nl + 1))[: len(ends)]
    cr = (ends > starts) & (buf[np.maximum(ends - 1, 0)] == 13)
    return starts, ends - cr


def read_csv_table(
    path: Path,
    dialect: CsvDialect,
    *,
    numeric: Sequence[str] = (),
    text: Sequence[str] = (),
    final_newline: bool = False,
) -> CsvTable:
    """Parse the named columns of a delimited file, checking every row first.

    numeric: columns parsed as float64, which must all be finite (``nan``/``-nan`` and
    ``inf`` are errors naming line and column); text: columns kept as strings.
    Every data row must hold exactly as many fields as the header (plus one empty field
    with ``trailing_delimiter``); blank lines are allowed only at the end of the file, NUL
    bytes nowhere. final_newline: the last line must end with a line break (for files that a
    program wrote, where a last line without one is a row cut short).
    Standard CSV quoting is honoured (a quoted field may hold the delimiter, doubled quotes
    and line breaks): a file without any quote character takes the vectorised path, one with
    quotes is split by the csv module (:mod:`tactile_cli.ingest.csv_records`).
    Raises :class:`InputError` naming the file, line and column.
    """
    raw = read_bytes(path, "CSV file")
    buf = np.frombuffer(raw, dtype=np.uint8)
    if len(buf) and buf.max() >= 0x80:  # not plain ASCII: every byte must be UTF-8
        decode_utf8(raw, path)
    starts, ends = _line_bounds(buf)
    nonblank = np.flatnonzero(ends > starts)
    if len(nonblank) == 0:
        raise InputError("the file is empty", path=path)
    nul = np.flatnonzero(buf == 0)
    if len(nul):
        raise InputError("NUL bytes in the line (binary data, or a damaged file); a CSV file is "
                         "plain text", path=path,
                         where=f"line {int(np.searchsorted(starts, nul[0], side='right'))}")
    if final_newline and buf[-1] not in (10, 13):  # else a cut row would pass as complete
        raise InputError("the last line does not end with a line break: the file looks cut "
                         "short; if the line is complete, end the file with a newline",
                         path=path, where=f"line {len(starts)}")
    wanted = list(dict.fromkeys([*numeric, *text]))
    if np.any(buf == QUOTE_BYTE):
        table = _read_quoted(raw, path, dialect, wanted, set(numeric))
    else:
        n_lines = int(nonblank[-1]) + 1  # trailing blank lines are dropped
        table = _read_plain(raw, buf, starts[:n_lines], ends[:n_lines], path, dialect, wanted,
                            set(numeric))
    for c in numeric:
        values = table.columns[c]
        notfinite = np.flatnonzero(~np.isfinite(values))
        if len(notfinite):
            i = int(notfinite[0])
            raise InputError(f"column {c!r} holds {values[i]} (values must be finite; leave the "
                             "column out of the mapping if it is not measured)",
                             path=path, where=f"line {table.line(i)}, column {c!r}")
    return table


def _read_plain(raw: bytes, buf: np.ndarray, starts: np.ndarray, ends: np.ndarray, path: Path,
                dialect: CsvDialect, wanted: list[str], numeric: set[str]) -> CsvTable:
    """The fast path for files without quotes: fields counted per line with numpy, then
    parsed by pandas' C engine. starts, ends: byte bounds of the lines up to the last
    non-blank one."""
    if dialect.header:
        names = _header_names(raw[starts[0]:ends[0]], path, dialect)
        skip = 1
    else:
        names = list(dialect.column_names or [])
        skip = 0
    _check_wanted(names, wanted, path, dialect)
    d_starts, d_ends = starts[skip:], ends[skip:]
    n_rows = len(d_starts)
    if n_rows == 0:
        raise InputError("the file has a header but no data rows", path=path)
    blank = np.flatnonzero(d_ends == d_starts)
    if len(blank):
        raise _blank_line_error(path, skip + int(blank[0]) + 1)
    delim = ord(dialect.delimiter)
    dpos = np.flatnonzero(buf[: ends[-1]] == delim)
    fields = np.searchsorted(dpos, d_ends) - np.searchsorted(dpos, d_starts) + 1
    bad = np.flatnonzero(fields != len(names) + int(dialect.trailing_delimiter))
    if len(bad):
        i = int(bad[0])
        raise _field_count_error(int(fields[i]), names, dialect, path, skip + i + 1)
    if dialect.trailing_delimiter:
        no_trail = np.flatnonzero(buf[d_ends - 1] != delim)
        if len(no_trail):
            raise _no_trailing_delimiter_error(path, skip + int(no_trail[0]) + 1)
    body = io.BytesIO(raw[d_starts[0]: ends[-1]])
    columns = _parse_columns(body, path, dialect, names, wanted, numeric, n_rows,
                             lambda row: skip + row + 1, quoted=False,
                             encoding="utf-8-sig" if skip == 0 else "utf-8")
    return CsvTable(path=path, names=tuple(names), columns=columns, n_rows=n_rows,
                    first_data_line=skip + 1)


def _read_quoted(raw: bytes, path: Path, dialect: CsvDialect, wanted: list[str],
                 numeric: set[str]) -> CsvTable:
    """The path for files with quote characters: records split by the csv module (a record
    may span lines) for the same checks as the fast path, by the line a record starts on;
    then the values parsed by pandas' C engine with quoting."""
    text = decode_utf8(raw, path)  # drops a byte order mark
    header: list[str] | None = None
    lines: list[int] = []  # where each data record starts
    fields: list[int] = []
    filled_last: list[bool] = []  # the last field is not empty
    for line, cells in csv_records(text, path, delimiter=dialect.delimiter):
        if dialect.header and header is None:
            header = cells
            continue
        lines.append(line)
        fields.append(len(cells))
        filled_last.append(bool(cells) and cells[-1] != "")
    while fields and fields[-1] == 0:  # trailing blank lines are dropped
        lines.pop(), fields.pop(), filled_last.pop()
    names = (_checked_names(header or [], path, dialect) if dialect.header
             else list(dialect.column_names or []))
    _check_wanted(names, wanted, path, dialect)
    if not fields:
        raise InputError("the file has a header but no data rows", path=path)
    row_lines = np.array(lines, dtype=np.int64)
    counts = np.array(fields, dtype=np.int64)
    blank = np.flatnonzero(counts == 0)
    if len(blank):
        raise _blank_line_error(path, int(row_lines[blank[0]]))
    bad = np.flatnonzero(counts != len(names) + int(dialect.trailing_delimiter))
    if len(bad):
        i = int(bad[0])
        raise _field_count_error(int(counts[i]), names, dialect, path, int(row_lines[i]))
    if dialect.trailing_delimiter and any(filled_last):
        raise _no_trailing_delimiter_error(path, lines[filled_last.index(True)])
    start = 0
    for _ in range(lines[0] - 1):  # the data start after the header's lines
        start = text.index("\n", start) + 1
    body = io.StringIO(text[start:].rstrip("\r\n") + "\n", newline="")
    columns = _parse_columns(body, path, dialect, names, wanted, numeric, len(lines),
                             lambda row: lines[row], quoted=True)
    return CsvTable(path=path, names=tuple(names), columns=columns, n_rows=len(lines),
                    first_data_line=lines[0], row_lines=row_lines)


def _parse_columns(body: io.BytesIO | io.StringIO, path: Path, dialect: CsvDialect,
                   names: list[str], wanted: list[str], numeric: set[str], n_rows: int,
                   line_of: Callable[[int], int], *, quoted: bool,
                   encoding: str | None = None) -> dict[str, np.ndarray]:
    """The wanted columns of the data rows in ``body`` (rows already checked for their field
    count), parsed by pandas' C engine: numeric ones as float64, the rest as text.
    line_of: file line of data row i, for the error at a cell that is not a number."""
    index = {n: i for i, n in enumerate(names)}
    dtypes = {index[c]: (np.float64 if c in numeric else object) for c in wanted}
    read_kwargs: dict[str, Any] = dict(
        sep=dialect.delimiter, header=None, usecols=sorted(dtypes), engine="c",
        keep_default_na=False, quoting=csv.QUOTE_MINIMAL if quoted else csv.QUOTE_NONE,
        on_bad_lines="error", skip_blank_lines=False)
    if encoding is not None:
        read_kwargs["encoding"] = encoding
    import pandas as pd  # imported on first use: `tactile --help` does not load it

    try:
        frame = pd.read_csv(body, dtype=dtypes, na_values=list(NAN_TOKENS), **read_kwargs)
    except ValueError as exc:
        body.seek(0)
        _locate_bad_number(pd.read_csv(body, dtype=object, na_filter=False, **read_kwargs),
                           [c for c in wanted if c in numeric], index, path, line_of, exc)
        raise  # _locate_bad_number always raises
    if len(frame) != n_rows:  # the checks before make this impossible; keep the reader honest
        raise InputError(f"parsed {len(frame)} rows but the file has {n_rows}", path=path)
    return {c: frame[index[c]].to_numpy().astype(np.float64 if c in numeric else object,
                                                 copy=False) for c in wanted}


def _check_wanted(names: list[str], wanted: list[str], path: Path, dialect: CsvDialect) -> None:
    missing = [c for c in wanted if c not in names]
    if missing:
        raise InputError(f"column {missing[0]!r} is not in the file (columns: "
                         f"{_shown(names)})", path=path, where="line 1" if dialect.header else None)


def _blank_line_error(path: Path, line: int) -> InputError:
    return InputError("blank line inside the data (only the end of a file may be blank)",
                      path=path, where=f"line {line}")


def _field_count_error(fields: int, names: list[str], dialect: CsvDialect, path: Path,
                       line: int) -> InputError:
    """The error for a row of ``fields`` fields (a trailing delimiter's field included)."""
    got = fields - int(dialect.trailing_delimiter)
    hint = ""
    if got == len(names) + 1 and not dialect.trailing_delimiter:
        hint = "; if every row ends with the delimiter, set `trailing_delimiter: true`"
    elif got < len(names):
        hint = " (a short or cut-off row)"
    return InputError(f"row has {got} fields, expected {len(names)} like the "
                      f"{'header' if dialect.header else '`column_names`'}{hint}",
                      path=path, where=f"line {line}")


def _no_trailing_delimiter_error(path: Path, line: int) -> InputError:
    return InputError("row does not end with the delimiter (`trailing_delimiter: true`): a "
                      "field is missing inside it", path=path, where=f"line {line}")


def _to_float(cells: np.ndarray) -> tuple[np.ndarray, int | None]:
    """(n,) text cells as float64 (NaN tokens as NaN) and the index of the first cell that
    is not a number (None when all are)."""
    import pandas as pd

    text = cells.astype(str)
    values = pd.to_numeric(pd.Series(text), errors="coerce").to_numpy(dtype=np.float64)
    bad = np.flatnonzero(np.isnan(values) & ~np.isin(text, NAN_TOKENS))
    return values, (int(bad[0]) if len(bad) else None)


def _bad_number_error(column: str, cell: str, path: Path, line: int) -> InputError:
    what = ("an empty field (a missing value or a stray delimiter)" if cell.strip() == ""
            else f"{cell!r}, which is not a number")
    return InputError(f"column {column!r} holds {what}", path=path,
                      where=f"line {line}, column {column!r}")


def _locate_bad_number(frame: pd.DataFrame, numeric: list[str], index: dict[str, int], path: Path,
                       line_of: Callable[[int], int], exc: Exception) -> None:
    """Raise an InputError at the first numeric-column cell that is not a number."""
    first: tuple[int, str, str] | None = None
    for c in numeric:
        cells = frame[index[c]].to_numpy(dtype=object)
        _, bad = _to_float(cells)
        if bad is not None and (first is None or bad < first[0]):
            first = (bad, c, str(cells[bad]))
    if first is None:
        raise InputError(f"cannot parse the file ({exc})", path=path) from None
    row, c, cell = first
    raise _bad_number_error(c, cell, path, line_of(row)) from None


def _shown(names: Sequence[str]) -> str:
    head = ", ".join(names[:MAX_NAMES_SHOWN])
    return head + (f", ... ({len(names)} in all)" if len(names) > MAX_NAMES_SHOWN else "")


def path_order(path: Path) -> tuple[Any, ...]:
    """Sort key of trial paths: :func:`~tactile_cli.natural.natural_key` of the whole path
    (``mat2`` before ``mat10``, letter case ignored, so folders sort before their
    neighbours' files as they do by name)."""
    return natural_key(path.as_posix())


# -- plan ------------------------------------------------------------------------------------
@dataclass
class TrialPlan:
    """One trial found and checked before any data are parsed.

    files: file template -> path; channels: stream name -> selected column names.
    """

    name: str
    path: Path
    labels: dict[str, str | int | float]
    files: dict[str, Path]
    channels: dict[str, list[str]] = field(default_factory=dict)


def plan_trials(inputs: Sequence[Path], mapping: CsvMapping, mapping_path: Path) -> list[TrialPlan]:
    """Find every trial, resolve its files and check every column the mapping names."""
    layout = mapping.trials
    rx = re.compile(layout.pattern) if layout.pattern else None
    plans: list[TrialPlan] = []
    seen: dict[Path, Path] = {}
    for inp in inputs:
        for found in _find_trial_paths(inp, mapping):
            key = found.resolve()
            if key in seen:
                raise InputError(f"this trial is found twice (also from input {seen[key]}); "
                                 "give inputs that do not overlap", path=found)
            seen[key] = inp
            fields = {STEM_FIELD: found.name if layout.layout == "folder" else found.stem}
            if rx is not None:
                m = rx.search(found.as_posix())
                if m is None:
                    raise InputError(f"the trial path does not match `trials.pattern` "
                                     f"{layout.pattern!r} in {mapping_path}", path=found)
                fields.update({k: v or "" for k, v in m.groupdict().items()})
            folder = found if layout.layout == "folder" else found.parent
            per_row = layout.row_trials  # names come per row (see _write_row_trials)
            name = (render(layout.name, fields) if layout.name and not per_row
                    else fields[STEM_FIELD])
            labels: dict[str, str | int | float] = {**layout.labels}
            labels.update({k: v for k, v in fields.items() if k != STEM_FIELD})
            files = {}
            for s in mapping.streams:
                for template, key in s.templates():
                    path = folder / render(template, fields)
                    if not path.is_file():
                        raise InputError(f"file of trial {name!r} not found (named by "
                                         f"`streams.{s.name}.{key}` {template!r} in "
                                         f"{mapping_path})", path=path)
                    files[template] = path
            if layout.layout == "rows":
                files[TABLE] = found  # the table itself: its label and group columns
            plans.append(TrialPlan(name=name, path=found, labels=labels, files=files))
    if not plans:
        raise InputError("no trials found", path=inputs[0] if inputs else None)
    _check_columns(plans, mapping, mapping_path)
    return plans


def _find_trial_paths(inp: Path, mapping: CsvMapping) -> list[Path]:
    layout = mapping.trials
    if layout.layout in ("file", "rows"):
        if inp.is_file():
            return [inp]
        found = sorted((p for p in inp.glob(layout.glob) if p.is_file()), key=path_order)
        if not found:
            raise InputError(f"no file matches `trials.glob` {layout.glob!r} here", path=inp)
        return found
    if not inp.is_dir():
        raise InputError("the mapping's trials are folders (`layout: folder`); give folders",
                         path=inp)
    found = sorted((p for p in inp.glob(layout.glob) if p.is_dir()), key=path_order)
    if found:
        return found
    first = mapping.streams[0].file
    if "{" not in first and (inp / first).is_file():
        return [inp]  # the input is itself one trial folder
    raise InputError(f"no folder matches `trials.glob` {layout.glob!r} here, and the folder "
                     f"itself has no {first!r}", path=inp)


def _check_columns(plans: list[TrialPlan], mapping: CsvMapping, mapping_path: Path) -> None:
    headers: dict[Path, list[str]] = {}

    def header(plan: TrialPlan, template: str) -> list[str]:
        path = plan.files[template]
        if path not in headers:
            headers[path] = read_csv_header(path, mapping.dialect(template))
        return headers[path]

    def need(plan: TrialPlan, template: str, column: str, key: str) -> None:
        names = header(plan, template)
        if column not in names:
            raise InputError(f"column {column!r} (named by `{key}` in {mapping_path}) is not in "
                             f"the file (columns: {_shown(names)})", path=plan.files[template],
                             where="line 1" if mapping.dialect(template).header else None)

    first_channels: dict[str, tuple[list[str], Path]] = {}
    for plan in plans:
        for s in mapping.streams:
            key = f"streams.{s.name}"
            names = header(plan, s.file)
            chosen: list[str] = []
            for entry in s.channels:
                if any(ch in entry for ch in "*?["):
                    hits = [n for n in names if fnmatch.fnmatchcase(n, entry)]
                    if not hits:
                        raise InputError(f"pattern {entry!r} (in `{key}.channels` of "
                                         f"{mapping_path}) matches no column (columns: "
                                         f"{_shown(names)})", path=plan.files[s.file],
                                         where="line 1" if mapping.dialect(s.file).header
                                         else None)
                else:
                    need(plan, s.file, entry, f"{key}.channels")
                    hits = [entry]
                for h in hits:
                    if h in chosen:
                        raise InputError(f"column {h!r} is selected twice by `{key}.channels` "
                                         f"in {mapping_path}", path=plan.files[s.file])
                    chosen.append(h)
            _check_stream_shape(s, chosen, mapping_path, plan.files[s.file])
            if s.name in first_channels and first_channels[s.name][0] != chosen:
                ref_cols, ref_path = first_channels[s.name]
                raise InputError(f"stream {s.name!r} has columns {_shown(chosen)} here but "
                                 f"{_shown(ref_cols)} in {ref_path}; all trials of a stream "
                                 "need the same channels", path=plan.files[s.file])
            first_channels.setdefault(s.name, (chosen, plan.files[s.file]))
            plan.channels[s.name] = chosen
            if s.time is not None and s.time.column is not None:
                need(plan, s.time.file or s.file, s.time.column, f"{key}.time.column")
            if s.time is not None and s.time.rate_from is not None:
                need(plan, s.time.rate_from.file, s.time.rate_from.column,
                     f"{key}.time.rate_from.column")
            for lab in s.sample_labels:
                need(plan, lab.file or s.file, lab.column, f"{key}.sample_labels.{lab.name}.column")
        for column in mapping.trials.label_columns:
            need(plan, TABLE, column, "trials.label_columns")
        if mapping.trials.group is not None:
            need(plan, TABLE, mapping.trials.group, "trials.group")


def _check_stream_shape(s: Stream, chosen: list[str], mapping_path: Path, path: Path) -> None:
    if s.channel_names is not None and len(s.channel_names) != len(chosen):
        raise InputError(f"`streams.{s.name}.channel_names` has {len(s.channel_names)} names "
                         f"but `channels` selects {len(chosen)} columns in {mapping_path}",
                         path=path)
    for name in output_channels(s, chosen):
        unit_of(s, name, mapping_path)


def output_channels(s: Stream, columns: list[str]) -> list[str]:
    """The stream's output channel names for its selected columns."""
    if s.unroll is not None:
        return [s.unroll.channel]
    return list(s.channel_names) if s.channel_names is not None else list(columns)


def unit_of(s: Stream, channel: str, mapping_path: Path) -> str:
    """The unit of one output channel (``units`` is one string or ``{glob: unit}``)."""
    if isinstance(s.units, str):
        return s.units
    for pattern, unit in s.units.items():
        if fnmatch.fnmatchcase(channel, pattern):
            return unit
    raise InputError(f"no pattern of `streams.{s.name}.units` ({', '.join(s.units)}) matches "
                     f"channel {channel!r}; add one", path=mapping_path)


# -- read and write --------------------------------------------------------------------------
class MappedCsvOptions(FormatOptions):
    """Options of the mapped-CSV format."""

    mapping: Path | None = None
    """The YAML mapping file that says which files are trials and which columns are time,
    channels and labels (see configs/mapping_example.yaml); required to ingest, optional to
    describe (without one, ``tactile info`` lists the CSV columns)."""


@dataclass
class _StreamData:
    data: np.ndarray  # (n, c) float64 in the channel units
    t_raw_s: np.ndarray | None  # (n,) seconds on the trial clock, before the origin shift
    t_s: np.ndarray | None  # (n,) seconds from 0 for evenly spaced streams
    rate_hz: float  # nominal rate of the output samples
    labels: dict[str, tuple[np.ndarray, list[str] | None]]
    stamps: SettledStamps | None = None  # the stamp policy's result (time columns only)


def load_plans(inputs: Sequence[Path], options: MappedCsvOptions
               ) -> tuple[Path, CsvMapping, list[TrialPlan]]:
    """The mapping file, the mapping and every trial's plan (headers checked)."""
    if options.mapping is None:
        raise InputError("the mapped-csv format needs a mapping file: pass `mapping='FILE.yaml'` "
                         "(see configs/mapping_example.yaml)")
    mapping_path = Path(options.mapping)
    mapping = load_mapping(mapping_path)
    return mapping_path, mapping, plan_trials(inputs, mapping, mapping_path)


def ingest_mapped_csv(inputs: Sequence[Path], options: MappedCsvOptions, writer: StoreWriter,
                      progress: Progress) -> list[str]:
    """Ingest CSV recordings described by the mapping file ``options.mapping``.

    Trials become groups named by ``trials.name`` (default file stem or folder name), with
    the trial labels of the mapping; each stream becomes ``signals/<stream>`` with its
    sensor in ``/sensors``. Every file read is recorded as a source. Returns one note per
    file whose columns no stream, time base or label reads ("left out: ...", also in the
    file attribute ``columns_left_out``; nothing is dropped silently), and one per stream
    whose repeated or out-of-order stamps a ``time.stamps`` policy handled.
    """
    from .mapped_csv_describe import unread_columns

    mapping_path, mapping, plans = load_plans(inputs, options)
    writer.h5.attrs["mapping_json"] = mapping.model_dump_json()
    left_out = unread_columns(plans[0], mapping)
    writer.h5.attrs["columns_left_out"] = "; ".join(left_out) or "none"
    rates: dict[str, list[float]] = {s.name: [] for s in mapping.streams}
    met: dict[str, list[tuple[str, SettledStamps]]] = {s.name: [] for s in mapping.streams}
    progress.start(sum(len(set(p.files.values())) for p in plans), "reading CSV files")
    for plan in plans:
        tables = read_tables(plan, mapping, progress)
        sources = [writer.add_source(p) for p in dict.fromkeys(plan.files.values())]
        streams = {s.name: _stream_data(s, plan, tables, mapping_path) for s in mapping.streams}
        timed = [d.t_raw_s[0] for d in streams.values() if d.t_raw_s is not None]
        origin = float(min(timed)) if timed else 0.0
        extra = {}
        if timed and any(s.time is not None and s.time.epoch for s in mapping.streams):
            extra["time_origin_unix_s"] = origin
        if mapping.trials.row_trials:
            _write_row_trials(writer, plan, mapping, tables, streams, sources)
            continue
        labels = {**plan.labels, **_table_labels(plan, mapping, tables)}
        trial = writer.trial(plan.name, labels=labels, sources=sources, **extra)
        for s in mapping.streams:
            d = streams[s.name]
            t_s = d.t_raw_s - origin if d.t_raw_s is not None else d.t_s
            group = trial.write_signal(s.name, sensor=safe_name(s.sensor_name), data=d.data,
                                       t_s=t_s, sample_labels=d.labels)
            group.attrs["sample_rate_hz"] = d.rate_hz
            rates[s.name].append(d.rate_hz)
            if d.stamps is not None and s.time is not None and s.time.stamps != "refuse":
                _record_stamps(group.attrs, s.time.stamps, d.stamps)
                if d.stamps.n_repeated or d.stamps.n_out_of_order:
                    met[s.name].append((trial.name, d.stamps))
    for s in mapping.streams:
        names = output_channels(s, plans[0].channels[s.name])
        rate_hz = float(np.median(rates[s.name])) if rates[s.name] else ROW_RATE_HZ
        description = s.description
        if mapping.trials.row_trials:
            description = (f"{description}; " if description else "") + \
                "one sample per trial (a table row); sample_rate_hz is nominal"
        writer.add_sensor(s.sensor_name, kind=s.kind, sample_rate_hz=rate_hz,
                          channel_names=names,
                          channel_units=[unit_of(s, n, mapping_path) for n in names],
                          description=description)
    progress.finish()
    return [*(f"left out: {line} (read in the first trial's files; every trial's share "
              "their columns)" for line in left_out),
            *(_stamps_note(s.name, s.time.stamps, met[s.name], len(plans))
              for s in mapping.streams if s.time is not None and met[s.name])]


#: Trials a stamps note names before "and N more".
MAX_TRIALS_NOTED = 5


def _record_stamps(attrs: Any, policy: str, stamps: SettledStamps) -> None:
    """The policy and what it met, as attributes of the stream's group (in every trial, so
    a file says which policy its times went through even where nothing was late)."""
    attrs["stamps_policy"] = policy
    attrs["stamps_repeated"] = stamps.n_repeated
    attrs["stamps_out_of_order"] = stamps.n_out_of_order
    attrs["stamps_dropped"] = stamps.n_dropped


def _stamps_note(stream: str, policy: str, met: list[tuple[str, SettledStamps]],
                 n_trials: int) -> str:
    """One line: how many trials of ``stream`` had late stamps, what the policy did, and
    the first few trials with their counts."""
    def counts(st: SettledStamps) -> str:
        parts = [f"{n} {what}" for n, what in ((st.n_repeated, "repeated"),
                                              (st.n_out_of_order, "out of order")) if n]
        return " and ".join(parts)

    dropped = sum(st.n_dropped for _, st in met)
    did = {"drop_repeats": f"{dropped} sample(s) dropped, the first of each stamp kept",
           "keep_last": f"{dropped} sample(s) dropped, the last of each stamp kept",
           "spread": "every sample kept, spread evenly between neighbouring stamps"}[policy]
    shown = ", ".join(f"{name} {counts(st)}" for name, st in met[:MAX_TRIALS_NOTED])
    more = f" and {len(met) - MAX_TRIALS_NOTED} more" if len(met) > MAX_TRIALS_NOTED else ""
    return (f"stream {stream!r}: {len(met)} of {n_trials} trial(s) had repeated or "
            f"out-of-order time stamps ({shown}{more}); `stamps: {policy}`: {did} (each trial "
            "records them in the stream attributes stamps_repeated, stamps_out_of_order, "
            "stamps_dropped)")


def read_tables(plan: TrialPlan, mapping: CsvMapping, progress: Progress) -> dict[str, CsvTable]:
    """Parse every file of a trial once, with all the columns any stream needs from it."""
    numeric: dict[str, list[str]] = {t: [] for t in plan.files}
    text: dict[str, list[str]] = {t: [] for t in plan.files}
    for s in mapping.streams:
        numeric[s.file] += plan.channels[s.name]
        if s.time is not None and s.time.column is not None:
            numeric[s.time.file or s.file].append(s.time.column)
        if s.time is not None and s.time.rate_from is not None:
            numeric[s.time.rate_from.file].append(s.time.rate_from.column)
        for lab in s.sample_labels:
            (text if lab.classes is not None else numeric)[lab.file or s.file].append(lab.column)
    if TABLE in plan.files:
        text[TABLE] += mapping.trials.label_column_names
    # columns per file: two templates (a stream's file and the rows table) may name one file
    num_of: dict[Path, list[str]] = {}
    txt_of: dict[Path, list[str]] = {}
    for template, path in plan.files.items():
        num_of.setdefault(path, []).extend(numeric[template])
        txt_of.setdefault(path, []).extend(text[template])
    tables: dict[str, CsvTable] = {}
    by_path: dict[Path, CsvTable] = {}
    for template, path in plan.files.items():
        if path not in by_path:
            num = list(dict.fromkeys(num_of[path]))
            txt = [c for c in dict.fromkeys(txt_of[path]) if c not in num]
            by_path[path] = read_csv_table(path, mapping.dialect(template), numeric=num, text=txt)
            progress.advance(1)
        tables[template] = by_path[path]
    return tables


def _stream_data(s: Stream, plan: TrialPlan, tables: dict[str, CsvTable],
                 mapping_path: Path) -> _StreamData:
    table = tables[s.file]
    n = table.n_rows
    joined = [table]
    if s.time is not None and s.time.column is not None and s.time.file is not None:
        joined.append(tables[s.time.file])
    joined += [tables[lab.file] for lab in s.sample_labels if lab.file is not None]
    if len({t.n_rows for t in joined}) > 1:
        unique = {t.path: t for t in joined}.values()
        counts = ", ".join(f"{t.path.name} {t.n_rows} rows" for t in unique)
        raise InputError(f"the files of trial {plan.name!r} joined row by row for stream "
                         f"{s.name!r} differ in row count ({counts}); they must have one row "
                         "per sample", path=plan.path)
    data = np.column_stack([table.columns[c] for c in plan.channels[s.name]])
    if s.time is None:  # rows_are: trials: row i is the one sample of its own trial, at 0 s
        labels = {lab.name: _label_values(lab.classes, tables[lab.file or s.file], lab.column)
                  for lab in s.sample_labels}
        return _StreamData(data=data, t_raw_s=None, t_s=np.zeros(n), rate_hz=ROW_RATE_HZ,
                           labels=labels)
    rate_hz = s.time.sample_rate_hz
    if s.time.rate_from is not None:
        rate_hz = _value_from(tables[s.time.rate_from.file], s.time.rate_from.column)
    t_raw = t_even = None
    settled = None
    if s.time.column is not None:
        settled = _settled_times(s, tables[s.time.file or s.file], rate_hz)
        t_raw = settled.t
    labels = {lab.name: _label_values(lab.classes, tables[lab.file or s.file], lab.column)
              for lab in s.sample_labels}
    if settled is not None and settled.keep is not None:
        data = data[settled.keep]
        labels = {k: (v[settled.keep], c) for k, (v, c) in labels.items()}
    if t_raw is not None:
        if rate_hz is None:
            steps = np.diff(t_raw)
            step = float(np.median(steps)) if len(steps) else 0.0
            rate_hz = 1.0 / step if step > 0 else 0.0
    else:
        if rate_hz is None:  # the mapping model requires a time column or a rate
            raise RuntimeError(f"stream {s.name!r} has neither a time column nor a rate")
        t_even = np.arange(n, dtype=np.float64) / rate_hz
    if s.unroll is not None:
        m = data.shape[1]
        base = t_raw if t_raw is not None else t_even
        data, t_new = _unroll(data, base, rate_hz, s, table)
        if t_raw is not None:
            t_raw = t_new
        else:
            t_even = t_new
        labels = {k: (np.repeat(v, m), c) for k, (v, c) in labels.items()}
        rate_hz = rate_hz * m
    return _StreamData(data=data, t_raw_s=t_raw, t_s=t_even, rate_hz=float(rate_hz),
                       labels=labels, stamps=settled)


def _settled_times(s: Stream, ttab: CsvTable, rate_hz: float | None) -> SettledStamps:
    """The stream's times in seconds after its ``time.stamps`` policy; the default
    ``refuse`` raises at the first stamp that goes back (else the first repeated one),
    naming its line."""
    assert s.time is not None and s.time.column is not None
    column = s.time.column
    raw = ttab.columns[column]
    t = raw * s.time.seconds_per_unit
    stats = stamp_stats(t)
    if stats.n_late and s.time.stamps == "refuse":
        hint = (f"; or give `streams.{s.name}.time.stamps` in the mapping (drop_repeats, "
                "keep_last or spread) to keep the recording")
        if stats.first_out_of_order is not None:
            i = stats.first_out_of_order
            raise InputError(f"time goes back from {float(raw[i - 1])!r} (line "
                             f"{ttab.line(i - 1)}) to {float(raw[i])!r}; timestamps must not "
                             f"decrease{hint}", path=ttab.path,
                             where=f"line {ttab.line(i)}, column {column!r}")
        i = stats.first_repeated
        assert i is not None
        raise InputError(f"time stamp {float(raw[i])!r} repeats the one on line "
                         f"{ttab.line(i - 1)}; "
                         f"timestamps must increase{hint}", path=ttab.path,
                         where=f"line {ttab.line(i)}, column {column!r}")
    try:
        return settle_stamps(t, s.time.stamps,
                             last_interval=1.0 / rate_hz if rate_hz else None)
    except StampError as exc:
        raise InputError(f"cannot spread the stamps of column {column!r} ({exc}); give "
                         f"`streams.{s.name}.time.sample_rate_hz`, or another `stamps` policy",
                         path=ttab.path) from None


def _write_row_trials(writer: StoreWriter, plan: TrialPlan, mapping: CsvMapping,
                      tables: dict[str, CsvTable], streams: dict[str, _StreamData],
                      sources: list[int]) -> None:
    """``rows_are: trials``: one trial per table row, each stream one sample at t = 0 s,
    the row's label and group columns as trial labels (see :func:`row_trials`)."""
    for i, name, labels in row_trials(plan, mapping, tables):
        trial = writer.trial(name, labels=labels, sources=sources, table_row=i + 1)
        for s in mapping.streams:
            d = streams[s.name]
            sample_labels = {k: (v[i:i + 1], c) for k, (v, c) in d.labels.items()}
            trial.write_signal(s.name, sensor=safe_name(s.sensor_name), data=d.data[i:i + 1],
                               t_s=np.zeros(1), sample_labels=sample_labels)


def row_trials(plan: TrialPlan, mapping: CsvMapping, tables: dict[str, CsvTable]
               ) -> Iterator[tuple[int, str, dict[str, str | int | float]]]:
    """``rows_are: trials``: (row index, trial name, trial labels) of every table row. Names
    come from ``trials.name`` (fields ``{row}``, the label columns, the regex groups,
    ``{stem}``), by default ``<stem>_<row>``; labels are the plan's and the row's label and
    group columns."""
    table = tables[TABLE]
    columns = {c: [_label_value(v, c, table, i) for i, v in enumerate(table.columns[c])]
               for c in mapping.trials.label_column_names}
    template = mapping.trials.name or f"{{{STEM_FIELD}}}_{{{ROW_FIELD}}}"
    base = {k: str(v) for k, v in plan.labels.items()}
    base[STEM_FIELD] = plan.path.stem
    for i in range(table.n_rows):
        row_labels = {c: values[i] for c, values in columns.items()}
        fields = {**base, **{c: str(v) for c, v in row_labels.items()}, ROW_FIELD: str(i + 1)}
        yield i, render(template, fields), {**plan.labels, **row_labels}


def _label_value(cell: object, column: str, table: CsvTable, row: int) -> str | int | float:
    """A label cell as a trial label: a number when it reads as one, else the text."""
    text = str(cell).strip()
    if not text:
        raise InputError(f"empty label cell; every row needs a value in column {column!r}",
                         path=table.path, where=f"line {table.line(row)}, column {column!r}")
    for cast in (int, float):
        try:
            value = cast(text)
        except ValueError:
            continue
        if cast is float and not np.isfinite(value):
            raise InputError(f"label {text!r} is not a finite number", path=table.path,
                             where=f"line {table.line(row)}, column {column!r}")
        return value
    return text


def _table_labels(plan: TrialPlan, mapping: CsvMapping,
                  tables: dict[str, CsvTable]) -> dict[str, str | int | float]:
    """``rows_are: samples``: the label and group columns, which must hold one value in the
    whole table (they label the one trial)."""
    if TABLE not in tables:
        return {}
    table = tables[TABLE]
    out: dict[str, str | int | float] = {}
    for c in mapping.trials.label_column_names:
        cells = table.columns[c].astype(str)
        differ = np.flatnonzero(cells != cells[0])
        if len(differ):
            i = int(differ[0])
            here, first = str(cells[i]), str(cells[0])
            raise InputError(f"column {c!r} holds {here!r} here but {first!r} on line "
                             f"{table.line(0)}; with `rows_are: samples` the table is one "
                             "trial, so a label column holds one value (use `rows_are: "
                             "trials` for one trial per row)", path=table.path,
                             where=f"line {table.line(i)}, column {c!r}")
        out[c] = _label_value(cells[0], c, table, 0)
    return out


def _unroll(data: np.ndarray, t_row: np.ndarray, row_rate_hz: float, s: Stream,
            table: CsvTable) -> tuple[np.ndarray, np.ndarray]:
    """(n, m) rows of m consecutive samples -> (n*m, 1) samples and (n*m,) times.

    Sample k of row i is at t_i + k/m * (t_{i+1} - t_i); the last row repeats the
    previous interval (or 1/row rate for a one-row file).
    """
    n, m = data.shape
    if n >= 2:
        last_step = t_row[-1] - t_row[-2]
    elif row_rate_hz > 0:
        last_step = 1.0 / row_rate_hz
    else:
        raise InputError(f"stream {s.name!r}: cannot unroll a single row without a rate; give "
                         "`time.sample_rate_hz`", path=table.path)
    t_ext = np.append(t_row, t_row[-1] + last_step)
    t = np.interp(np.arange(n * m, dtype=np.float64) / m, np.arange(n + 1, dtype=np.float64), t_ext)
    return data.reshape(n * m, 1), t


def _value_from(table: CsvTable, column: str) -> float:
    if table.n_rows != 1:
        raise InputError(f"a rate is read from column {column!r}, so the file must have exactly "
                         f"one data row; it has {table.n_rows}", path=table.path)
    value = float(table.columns[column][0])
    if not value > 0:
        raise InputError(f"rate {value} Hz in column {column!r} is not positive", path=table.path,
                         where=f"line {table.line(0)}, column {column!r}")
    return value


def _label_values(classes: list[str] | None, table: CsvTable,
                  column: str) -> tuple[np.ndarray, list[str] | None]:
    """(n,) label values: float64 for numeric labels, integer codes for categorical ones."""
    values = table.columns[column]
    if classes is None:
        return values, None
    k = len(classes)
    dtype = np.int8 if k <= 127 else np.int32
    if values.dtype.kind == "f":
        codes = values
        bad = np.flatnonzero((codes != np.round(codes)) | (codes < 0) | (codes >= k))
        if len(bad):
            i = int(bad[0])
            raise InputError(f"label {codes[i]!r} is not a class code 0..{k - 1} of classes "
                             f"{', '.join(classes)}", path=table.path,
                             where=f"line {table.line(i)}, column {column!r}")
        return codes.astype(dtype), classes
    text = values.astype(str)
    uniq, inverse = np.unique(text, return_inverse=True)
    lookup = np.empty(len(uniq), dtype=dtype)
    for j, u in enumerate(uniq.tolist()):  # over distinct values, not samples
        code = _class_code(u, classes)
        if code is None:
            i = int(np.flatnonzero(inverse == j)[0])
            raise InputError(f"label {u!r} is not one of the classes {', '.join(classes)} (nor "
                             f"a code 0..{k - 1})", path=table.path,
                             where=f"line {table.line(i)}, column {column!r}")
        lookup[j] = code
    return lookup[inverse], classes


def _class_code(value: str, classes: list[str]) -> int | None:
    value = value.strip()
    if value in classes:
        return classes.index(value)
    try:
        number = float(value)
    except ValueError:
        return None
    if number.is_integer() and 0 <= number < len(classes):
        return int(number)
    return None


class MappedCsvFormat(IngestFormat[MappedCsvOptions]):
    """Sampled-signal CSVs of any sensor, described by a YAML mapping (module docstring)."""

    name = "mapped-csv"
    title = "mapped CSV"
    summary = ("sampled-signal CSVs of any sensor described by a YAML mapping (`mapping`): "
               "files, folders or tables with one row per trial (`layout: rows`)")
    suffixes = (".csv", ".tsv")
    Options = MappedCsvOptions
    claim_option = "mapping"  # the mapping says what the files are, whatever their suffix

    def sniff(self, path: Path) -> bool:
        if not path.is_dir():
            return path.suffix.lower() in self.suffixes
        try:  # a folder with CSV files in it, or in its subfolders (first hit only)
            return next((True for p in path.rglob("*.csv") if not p.name.startswith(".")),
                        False)
        except OSError:
            return False

    def describe(self, path: Path, options: MappedCsvOptions) -> RecordingSummary:
        from .mapped_csv_describe import describe_mapped_csv

        return describe_mapped_csv(path, options, self)

    def read(self, inputs: Sequence[Path], options: MappedCsvOptions, writer: StoreWriter,
             progress: Progress) -> list[str]:
        return ingest_mapped_csv(inputs, options, writer, progress)


MAPPED_CSV = MappedCsvFormat()

__all__ = ["MAPPED_CSV", "CsvTable", "MappedCsvFormat", "MappedCsvOptions", "TrialPlan",
           "ingest_mapped_csv", "load_plans", "path_order", "plan_trials", "read_csv_header",
           "read_csv_table", "read_tables", "row_trials"]
