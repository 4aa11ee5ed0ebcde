"""Ground truth beside the recordings: ``--annotations FILE.csv`` and ``--trial-labels FILE.csv``.

Both are small CSV files (UTF-8, a header line, comma-separated, standard CSV quoting)
keyed by trial name: the name the trial gets in the output file (the input's file stem,
sanitised as :func:`~tactile_cli.store.writer.safe_name` does). They are read and checked
before any recording is, and applied after the format reader ran:

- annotations: columns exactly ``trial, start_s, end_s, label`` (any order). Each row is
  one time interval in seconds from the trial's time origin: finite numbers with
  ``start_s <= end_s`` and a non-empty label. A trial's rows become
  ``/trials/<trial>/annotations`` in file order; a trial without rows gets none.
- trial labels: a ``trial`` column plus any others; each other column becomes a label
  attribute of that trial (``/trials/<trial>/labels``), numbers stored as numbers (int when
  written as an integer, else float), text as text; empty cells are skipped. A trial has at
  most one row. A label that a reader or ``--label`` already set must agree. ``nan`` and
  ``inf`` are refused, and so is one text cell in a column whose other cells are numbers.
  A column named ``split`` is not a label: it sets the trial's ``split`` attribute, which
  ``tactile train`` uses (``data.split.mode: auto``); its cells are ``train``, ``val``,
  ``test`` or empty (no split), anything else is an error.

Both files hold no NUL bytes and at least one row after the header. A last line without a
line break is accepted (hand-written files often lack one), so a last row cut short inside
its last cell cannot be told from a complete one; a row cut before its last field is
refused for its missing fields.

Every broken rule is an :class:`~tactile_cli.errors.InputError` naming the file and the
line (line 1 is the header), including a row whose trial is not among the ingested trials.
Blank lines at the end of a file are ignored; elsewhere they are errors.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from ..config_file import read_text
from ..errors import InputError
from ..store.spec import load_spec
from ..store.writer import StoreWriter, safe_name
from .csv_records import csv_records

ANNOTATION_COLUMNS = ("trial", "start_s", "end_s", "label")
#: The trial-labels column that sets the trial's split attribute instead of a label.
SPLIT_COLUMN = "split"
#: Its values (the schema's ``split`` values but the empty one, which an empty cell gives).
SPLITS = tuple(s for s in load_spec().enums["split"] if s)
_INT = re.compile(r"[+-]?\d+")
_FLOAT = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?")


@dataclass(frozen=True)
class Annotations:
    """Parsed annotations: trial -> [(start_s, end_s, label, line)] in file order."""

    path: Path
    rows: dict[str, list[tuple[float, float, str, int]]] = field(default_factory=dict)


@dataclass(frozen=True)
class TrialLabels:
    """Parsed trial labels: trial -> ({label: value}, line), and trial -> split (train, val
    or test) for the trials whose ``split`` cell is not empty."""

    path: Path
    rows: dict[str, tuple[dict[str, str | int | float], int]] = field(default_factory=dict)
    splits: dict[str, str] = field(default_factory=dict)


def _rows(path: Path, what: str) -> Iterator[tuple[int, list[str]]]:
    """``(line, cells)`` of every record of a CSV file, the header first: the line the
    record starts on (a quoted cell may span lines) and its cells, unquoted."""
    text = read_text(path, f"{what} file")
    body = text.rstrip("\r\n \t")
    if not body or not body.splitlines()[0].strip():
        raise InputError(f"{what} file is empty; expected a header line", path=path)
    if "\0" in text:
        raise InputError("NUL bytes in the line (binary data, or a damaged file); the "
                         f"{what} file must be plain UTF-8 text", path=path,
                         where=f"line {text[:text.index(chr(0))].count(chr(10)) + 1}")
    yield from csv_records(body, path)


def _header(path: Path, cells: list[str]) -> list[str]:
    names = [c.strip() for c in cells]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise InputError(f"column{'s' if len(dup) > 1 else ''} {', '.join(map(repr, dup))} "
                         "named twice in the header", path=path, where="line 1")
    if "" in names:
        raise InputError(f"column {names.index('') + 1} of the header has no name", path=path,
                         where="line 1")
    return names


def _check_width(path: Path, line: int, cells: list[str], names: list[str]) -> None:
    if not cells:
        raise InputError("empty line; remove it", path=path, where=f"line {line}")
    if len(cells) != len(names):
        raise InputError(f"{len(cells)} fields, expected {len(names)} ({', '.join(names)})",
                         path=path, where=f"line {line}")


def read_annotations(path: str | Path) -> Annotations:
    """Parse an annotations CSV (see the module docstring); raises InputError."""
    path = Path(path)
    rows: dict[str, list[tuple[float, float, str, int]]] = {}
    names: list[str] = []
    for line, cells in _rows(path, "annotations"):
        if line == 1:
            names = _header(path, cells)
            missing = [c for c in ANNOTATION_COLUMNS if c not in names]
            extra = [c for c in names if c not in ANNOTATION_COLUMNS]
            if missing or extra:
                problem = (f"missing column{'s' if len(missing) > 1 else ''} "
                           f"{', '.join(map(repr, missing))}" if missing else
                           f"unexpected column{'s' if len(extra) > 1 else ''} "
                           f"{', '.join(map(repr, extra))}")
                raise InputError(f"{problem}; an annotations file has exactly the columns "
                                 "trial, start_s, end_s, label", path=path, where="line 1")
            continue
        _check_width(path, line, cells, names)
        row = dict(zip(names, (c.strip() for c in cells), strict=True))
        trial = _trial(path, line, row["trial"])
        times = []
        for key in ("start_s", "end_s"):
            try:
                value = float(row[key])
            except ValueError:
                value = math.nan
            if not math.isfinite(value):
                raise InputError(f"{key} {row[key]!r} is not a finite number of seconds",
                                 path=path, where=f"line {line}")
            times.append(value)
        if times[0] > times[1]:
            raise InputError(f"start_s {row['start_s']} is after end_s {row['end_s']}",
                             path=path, where=f"line {line}")
        if not row["label"]:
            raise InputError("empty label", path=path, where=f"line {line}")
        rows.setdefault(trial, []).append((times[0], times[1], row["label"], line))
    _no_rows(path, "annotations", bool(rows))
    return Annotations(path, rows)


def _no_rows(path: Path, what: str, any_rows: bool) -> None:
    if not any_rows:  # given on purpose and empty: almost surely the wrong or a cut file
        raise InputError(f"no rows after the header; a {what} file holds one row per "
                         f"{'interval' if what == 'annotations' else 'trial'} (leave the file "
                         "out if there is nothing to add)", path=path)


def read_trial_labels(path: str | Path) -> TrialLabels:
    """Parse a trial-labels CSV (see the module docstring); raises InputError."""
    path = Path(path)
    rows: dict[str, tuple[dict[str, str | int | float], int]] = {}
    splits: dict[str, str] = {}
    cells_of: dict[str, list[tuple[int, str | int | float]]] = {}  # column -> (line, value)
    names: list[str] = []
    for line, cells in _rows(path, "trial labels"):
        if line == 1:
            names = _header(path, cells)
            if "trial" not in names:
                raise InputError(f"no 'trial' column; the header names {names}", path=path,
                                 where="line 1")
            if len(names) == 1:
                raise InputError("only a 'trial' column; add one column per label (or a "
                                 "'split' column)", path=path, where="line 1")
            keys = [safe_name(n) for n in names if n != "trial"]
            clash = sorted({k for k in keys if keys.count(k) > 1})
            if clash:
                raise InputError(f"columns map to the same label name {clash[0]!r} (label "
                                 "names keep letters, digits, _ . - only); rename them",
                                 path=path, where="line 1")
            continue
        _check_width(path, line, cells, names)
        row = dict(zip(names, cells, strict=True))
        trial = _trial(path, line, row.pop("trial").strip())
        if trial in rows:
            raise InputError(f"trial {trial!r} has a second row (the first is line "
                             f"{rows[trial][1]})", path=path, where=f"line {line}")
        split = _split(path, line, row.pop(SPLIT_COLUMN, ""))
        if split:
            splits[trial] = split
        labels = {}
        for key, cell in row.items():
            if cell.strip() == "":
                continue
            value = number_or_text(cell)
            if _non_finite(value):
                raise InputError(f"{cell.strip()!r} is not a finite number; write the label "
                                 "as a finite number or leave the cell empty", path=path,
                                 where=f"line {line}, column {key!r}")
            labels[safe_name(key)] = value
            cells_of.setdefault(key, []).append((line, value))
        rows[trial] = (labels, line)
    _no_rows(path, "trial labels", bool(rows))
    _text_among_numbers(path, cells_of)
    return TrialLabels(path, rows, splits)


def _split(path: Path, line: int, cell: str) -> str:
    """The split named by a ``split`` cell (``""`` when empty); InputError for any other
    value than :data:`SPLITS`."""
    value = cell.strip()
    if value and value not in SPLITS:
        raise InputError(f"split {value!r} is not one of {', '.join(SPLITS)}; write one of them "
                         "or leave the cell empty (no split)", path=path,
                         where=f"line {line}, column {SPLIT_COLUMN!r}")
    return value


def _non_finite(value: str | int | float) -> bool:
    """A float that is not finite, or text that Python reads as one (``nan``, ``-inf``)."""
    if isinstance(value, str):
        try:
            value = float(value)
        except ValueError:
            return False
    return isinstance(value, float) and not math.isfinite(value)


def _text_among_numbers(path: Path, cells_of: dict[str, list[tuple[int, str | int | float]]]
                        ) -> None:
    """Refuse one text cell in a column whose other cells are all numbers (a typo, or a
    damaged cell: ``12`` -> ``1x``); columns of free text, or of mixed text, are kept."""
    for key, cells in cells_of.items():
        text = [(line, v) for line, v in cells if isinstance(v, str)]
        if len(text) == 1 and len(cells) > 1:
            line, value = text[0]
            raise InputError(f"{value!r} is not a number, but every other cell of column "
                             f"{key!r} is; fix the cell (labels of one column are all numbers "
                             "or all text)", path=path, where=f"line {line}, column {key!r}")


def number_or_text(cell: str) -> str | int | float:
    """``"12"`` -> 12, ``"0.5"``/``"1e-3"`` -> float, anything else (``"nan"``, ``"yes"``,
    ``"small medium"``) -> the text, stripped of surrounding spaces."""
    text = cell.strip()
    if _INT.fullmatch(text):
        value = int(text)
        if -(2**63) <= value < 2**63:
            return value
    if _FLOAT.fullmatch(text):
        return float(text)
    return text


def _trial(path: Path, line: int, name: str) -> str:
    if not name:
        raise InputError("empty trial name", path=path, where=f"line {line}")
    return safe_name(name)


def apply_sidecars(writer: StoreWriter, *, annotations: Annotations | None = None,
                   labels: TrialLabels | None = None) -> list[str]:
    """Write parsed sidecars into the trials of a file being written (through
    :meth:`StoreWriter.trial_writer <tactile_cli.store.writer.StoreWriter.trial_writer>`).
    Returns a note naming the trials a labels table has no row for (they keep only the
    labels of the input and ``labels``).

    Raises InputError naming the file and line of a row whose trial is not in the file, of
    a trial that already has annotations, or of a label that contradicts one already set.
    """
    have = set(writer.trial_names)

    def unknown(path: Path, trial: str, line: int) -> InputError:
        shown = ", ".join(sorted(have)[:8]) + (" ..." if len(have) > 8 else "")
        return InputError(f"trial {trial!r} is not among the ingested trials ({shown}); "
                          "a trial is named by its input file's stem or folder's name "
                          "(`tactile info INPUT` lists the names an ingest gives)", path=path,
                          where=f"line {line}")

    if annotations is not None:
        for trial, rows in annotations.rows.items():
            if trial not in have:
                raise unknown(annotations.path, trial, rows[0][3])
            trial_writer = writer.trial_writer(trial)
            if trial_writer.has_annotations:
                raise InputError(f"trial {trial!r} already has annotations from its input; "
                                 "leave out `annotations`", path=annotations.path,
                                 where=f"line {rows[0][3]}")
            trial_writer.set_annotations([(r[0], r[1], r[2]) for r in rows])
    if labels is not None:
        for trial, (values, line) in labels.rows.items():
            if trial not in have:
                raise unknown(labels.path, trial, line)
            trial_writer = writer.trial_writer(trial)
            old_labels = trial_writer.labels
            for key, value in values.items():
                old = old_labels.get(key, value)
                if old != value:
                    raise InputError(f"label {key!r} = {value!r} contradicts {old!r} set "
                                     "by the input or `labels`", path=labels.path,
                                     where=f"line {line}")
            trial_writer.set_labels(**values)
            split = labels.splits.get(trial)
            if split is not None:
                if trial_writer.split not in ("", split):
                    raise InputError(f"split {split!r} contradicts {trial_writer.split!r} set by "
                                     "the input", path=labels.path, where=f"line {line}")
                trial_writer.set_split(split)
        missing = sorted(have - set(labels.rows))
        if missing:
            shown = ", ".join(missing[:5]) + (f" and {len(missing) - 5} more"
                                              if len(missing) > 5 else "")
            return [f"{labels.path}: no row for {len(missing)} of {len(have)} trial(s) "
                    f"({shown}); they have none of its labels"]
    return []


__all__ = ["Annotations", "TrialLabels", "read_annotations", "read_trial_labels",
           "apply_sidecars", "number_or_text"]
