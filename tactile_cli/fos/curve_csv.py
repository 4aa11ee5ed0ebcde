"""A plain two-column response curve from a CSV file, for ``tactile fit-fos FILE.csv``.

Format: a header line (e.g. ``t,x``), then one ``t, x`` row per sample: ``t`` in seconds
from the input's start (>= 0, strictly increasing), ``x`` the response (any unit; a fitted
alpha is in the same unit). A column name may carry its unit in parentheses or brackets,
``t (s),force (N)`` or ``t [s],force [N]``: the response's unit then labels the fits and
figures (the time column's must be seconds). Blank lines are skipped; any other bad row is
an :class:`~tactile_cli.errors.InputError` naming the file and the line.
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
    t_s, x, header, line = _read(path)
    _, t_unit = split_unit(header[0])
    if t_unit is not None and t_unit != "s":
        raise InputError(f"the time column {header[0]!r} is in {t_unit!r}; give t in seconds "
                         "('t (s)' or plain 't')", path=path, where=f"line {line}")
    quantity, units = split_unit(header[1])
    return Curve(name=path.stem, t_s=t_s, x=x, quantity=quantity, units=units)


def read_curve_csv(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """``(t_s, x)``: (n,) float64 times in seconds and (n,) float64 responses."""
    curve = read_curve(path)
    return curve.t_s, curve.x


def _read(path: Path) -> tuple[np.ndarray, np.ndarray, list[str], int]:
    """Times, responses, the header's two names and its line number."""
    path = Path(path)
    t_s: list[float] = []
    x: list[float] = []
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
    if len(header) != 2 or all(_number(c) is not None for c in header):
        raise InputError(f"expected a header of two column names such as 't,x', got "
                         f"{','.join(header)!r}", path=path, where=f"line {line}")
    for line, row in rows[1:]:
        if len(row) != 2:
            raise InputError(f"expected 2 values (t, x), got {len(row)}", path=path,
                             where=f"line {line}")
        t, v = _number(row[0]), _number(row[1])
        if t is None or v is None:
            bad = row[0] if t is None else row[1]
            raise InputError(f"{bad!r} is not a finite number", path=path,
                             where=f"line {line}")
        if t < 0:
            raise InputError(f"t = {t} s is negative; t counts seconds from the input's "
                             "start", path=path, where=f"line {line}")
        if t_s and t <= t_s[-1]:
            raise InputError(f"t = {t} s is not after the previous {t_s[-1]} s (times "
                             "must increase)", path=path, where=f"line {line}")
        t_s.append(t)
        x.append(v)
    if len(t_s) < 5:
        raise InputError(f"{len(t_s)} data rows; a fit needs at least 5", path=path)
    return np.array(t_s), np.array(x), header, header_line


__all__ = ["Curve", "read_curve", "read_curve_csv", "split_unit"]
