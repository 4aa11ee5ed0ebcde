"""A plain two-column response curve from a CSV file, for ``tactile fit-fos FILE.csv``.

Format: a header line (e.g. ``t,x``), then one ``t, x`` row per sample: ``t`` in seconds
from the input's start (>= 0, strictly increasing), ``x`` the response (any unit; a fitted
alpha is in the same unit). Blank lines are skipped; any other bad row is an
:class:`~tactile_cli.errors.InputError` naming the file and the line.
"""

from __future__ import annotations

import csv
import io
import math
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


def read_curve_csv(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """``(t_s, x)``: (n,) float64 times in seconds and (n,) float64 responses."""
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
    line, header = rows[0]
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
    return np.array(t_s), np.array(x)


__all__ = ["read_curve_csv"]
