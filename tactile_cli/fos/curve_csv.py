"""Response curves from CSV files, for ``tactile fit-fos FILE.csv`` (or a folder of them).

Format: a header line (e.g. ``t,x``), then one ``t, x`` row per sample: ``t`` in seconds
from the input's start (>= 0, strictly increasing), ``x`` the response (any unit; a fitted
alpha is in the same unit). A column name may carry its unit in parentheses or brackets,
``t (s),force (N)`` or ``t [s],force [N]``: the response's unit then labels the fits and
figures (the time column's must be seconds). Blank lines are skipped; any other bad row is
an :class:`~tactile_cli.errors.InputError` naming the file and the line.

Several curves sampled at the same times are one file with more response columns,
``t, x1, x2, ...`` (:func:`read_curves`): each column is a curve named ``stem/column``. A
column's cell may be empty where that curve has no sample (curves of different lengths);
each curve needs 5 samples. :func:`csv_inputs` expands a folder into its ``*.csv`` files.
"""

from __future__ import annotations

import csv
import io
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..config_file import read_text
from ..errors import InputError


def _number(text: str) -> float | None:
    try:
        value = float(text)
    except ValueError:
        return None
    return value if math.isfinite(value) else None


#: ``name (unit)`` or ``name [unit]``.
_NAME_UNIT = re.compile(r"^(?P<name>.*?)\s*[(\[]\s*(?P<unit>[^()\[\]]*?)\s*[)\]]$")


@dataclass(frozen=True)
class Curve:
    """One response curve: ``t_s`` (n,) float64 seconds, ``x`` (n,) float64 responses;
    ``name`` the file's stem, ``quantity`` the response column's name (without its unit),
    ``units`` the unit its header gives, or None."""

    name: str
    t_s: np.ndarray
    x: np.ndarray
    quantity: str
    units: str | None


def split_unit(column: str) -> tuple[str, str | None]:
    """``"force (N)"`` -> ``("force", "N")``; a name without a unit -> ``(name, None)``."""
    match = _NAME_UNIT.match(column)
    if match is None or not match["unit"]:
        return column, None
    return match["name"] or column, match["unit"]


def read_curve(path: str | Path) -> Curve:
    """The :class:`Curve` of a two-column CSV file (see the module doc)."""
    path = Path(path)
    curves = read_curves(path)
    if len(curves) != 1:
        raise InputError(f"expected two columns (t, x), got {len(curves) + 1}", path=path,
                         where="line 1")
    return curves[0]


def read_curves(path: str | Path) -> list[Curve]:
    """The curves of a CSV file with a time column and one or more response columns (see
    the module doc): one :class:`Curve` per response column, named after the file (one
    column) or ``stem/column`` (several)."""
    path = Path(path)
    t_s, x, header, line = _read(path)
    _, t_unit = split_unit(header[0])
    if t_unit is not None and t_unit != "s":
        raise InputError(f"the time column {header[0]!r} is in {t_unit!r}; give t in seconds "
                         "('t (s)' or plain 't')", path=path, where=f"line {line}")
    out = []
    for c, column in enumerate(header[1:]):
        quantity, units = split_unit(column)
        have = np.isfinite(x[:, c])
        if have.sum() < 5:
            raise InputError(f"{int(have.sum())} values; a fit needs at least 5", path=path,
                             where=f"column {column!r}")
        name = path.stem if len(header) == 2 else f"{path.stem}/{quantity}"
        out.append(Curve(name=name, t_s=t_s[have], x=x[have, c], quantity=quantity,
                         units=units))
    return out


def csv_inputs(paths: list[Path]) -> list[Path]:
    """``paths`` with each folder replaced by its ``*.csv`` files (not recursive), in
    natural order; a folder without one raises :class:`InputError`."""
    from ..natural import natural_key

    out: list[Path] = []
    for p in paths:
        if p.is_dir():
            found = sorted((f for f in p.iterdir() if f.suffix.lower() == ".csv"
                            and f.is_file()), key=lambda f: natural_key(f.name))
            if not found:
                raise InputError("the folder holds no .csv files", path=p)
            out.extend(found)
        else:
            out.append(p)
    return out


def read_curve_csv(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """``(t_s, x)``: (n,) float64 times in seconds and (n,) float64 responses."""
    curve = read_curve(path)
    return curve.t_s, curve.x


def _read(path: Path) -> tuple[np.ndarray, np.ndarray, list[str], int]:
    """Times (n,), responses (n, n_columns) with NaN for empty cells, the header's names and
    its line number."""
    path = Path(path)
    t_s: list[float] = []
    x: list[list[float]] = []
    reader = csv.reader(io.StringIO(read_text(path, "CSV file"), newline=""), strict=True)
    try:
        rows = [(reader.line_num, row) for row in reader]
    except csv.Error as exc:
        raise InputError(f"not valid CSV ({exc})", path=path,
                         where=f"line {reader.line_num}") from None
    rows = [(n, [c.strip() for c in r]) for n, r in rows if any(c.strip() for c in r)]
    if not rows:
        raise InputError("the file is empty; expected a header (t,x) and rows of t, x",
                         path=path)
    header_line, header = rows[0]
    line = header_line
    if len(header) < 2 or all(_number(c) is not None for c in header) or not all(header):
        raise InputError(f"expected a header of column names such as 't,x' or 't,x1,x2', "
                         f"got {','.join(header)!r}", path=path, where=f"line {line}")
    if len(set(header)) != len(header):
        dup = next(h for h in header if header.count(h) > 1)
        raise InputError(f"column {dup!r} appears twice in the header", path=path,
                         where=f"line {line}")
    width = len(header)
    for line, row in rows[1:]:
        if len(row) != width:
            raise InputError(f"expected {width} values ({', '.join(header)}), got {len(row)}",
                             path=path, where=f"line {line}")
        t = _number(row[0])
        if t is None:
            raise InputError(f"{row[0]!r} is not a finite number", path=path,
                             where=f"line {line}")
        values = []
        for cell in row[1:]:
            v = _number(cell) if cell else math.nan
            if v is None or (not cell and width == 2):
                raise InputError(f"{cell!r} is not a finite number", path=path,
                                 where=f"line {line}")
            values.append(v)
        if t < 0:
            raise InputError(f"t = {t} s is negative; t counts seconds from the input's "
                             "start", path=path, where=f"line {line}")
        if t_s and t <= t_s[-1]:
            raise InputError(f"t = {t} s is not after the previous {t_s[-1]} s (times "
                             "must increase)", path=path, where=f"line {line}")
        t_s.append(t)
        x.append(values)
    if len(t_s) < 5:
        raise InputError(f"{len(t_s)} data rows; a fit needs at least 5", path=path)
    return np.array(t_s), np.array(x, dtype=np.float64).reshape(len(t_s), width - 1), \
        header, header_line


__all__ = ["Curve", "csv_inputs", "read_curve", "read_curve_csv", "read_curves", "split_unit"]
