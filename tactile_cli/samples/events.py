"""Synthetic event-camera recordings (CSV and NPY) with known content, for tests and demos.

:func:`make_events` draws a deterministic event stream; :func:`write_events_csv` and
:func:`write_events_npy` write it in the two table formats `tactile ingest` reads and
return the ground truth *as the store keeps it* (``p`` in -1/+1 whatever the file used),
so a caller compares the ingested file with the returned arrays directly.

The CSV writer formats integers with numpy (digits of a whole block at once) instead of
``DataFrame.to_csv``, so the ingest benchmark can write tens of millions of rows in seconds.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Literal

import numpy as np

Polarity = Literal["pm1", "01"]

#: Field order and dtypes of the NPY files written here (any order is accepted on ingest).
NPY_DTYPE = np.dtype([("t", "<i8"), ("x", "<u2"), ("y", "<u2"), ("p", "i1")])

_ROWS_PER_BLOCK = 1 << 20  # rows formatted at once by the CSV writer (about 30 MB of text)


def make_events(n: int, *, width: int, height: int, seed: int,
                t0_us: int = 1_600_000_000_000_000, mean_dt_us: int = 1) -> dict[str, np.ndarray]:
    """A random event stream sorted by time.

    Returns ``x`` (n,) uint16 in [0, width), ``y`` (n,) uint16 in [0, height), ``t`` (n,)
    int64 microseconds from ``t0_us`` with gaps uniform in [0, 2 * mean_dt_us] (so equal
    timestamps occur, as in real sensors) and ``p`` (n,) int8 in {-1, +1}.
    """
    if n < 0 or width < 1 or height < 1 or mean_dt_us < 0:
        raise ValueError(f"`n` (={n}), `width` (={width}), `height` (={height}) and "
                         f"`mean_dt_us` (={mean_dt_us}) must be >= 0, >= 1, >= 1 and >= 0")
    rng = np.random.default_rng(seed)
    gaps = rng.integers(0, 2 * mean_dt_us + 1, size=n, dtype=np.int64)
    if n:
        gaps[0] = 0
    return {
        "x": rng.integers(0, width, size=n, dtype=np.uint16),
        "y": rng.integers(0, height, size=n, dtype=np.uint16),
        "t": t0_us + np.cumsum(gaps),
        "p": np.where(rng.random(n) < 0.5, np.int8(-1), np.int8(1)).astype(np.int8),
    }


def polarity_as(p: np.ndarray, polarity: Polarity) -> np.ndarray:
    """-1/+1 polarity (n,) in the file convention ``"pm1"`` (-1/+1) or ``"01"`` (0/1)."""
    if polarity == "pm1":
        return p.astype(np.int8)
    if polarity == "01":
        return (p > 0).astype(np.int8)
    raise ValueError(f"`polarity` (={polarity!r}) must be 'pm1' or '01'")


def write_events_csv(path: str | Path, n: int, *, width: int, height: int, seed: int,
                     polarity: Polarity = "pm1", columns: Sequence[str] = ("t", "x", "y", "p"),
                     t0_us: int = 1_600_000_000_000_000,
                     mean_dt_us: int = 1) -> dict[str, np.ndarray]:
    """Write ``n`` random events as CSV (header row, then one event per line).

    ``columns`` is the column order of the file (a permutation of t, x, y, p); ``t`` is
    written in integer microseconds, ``p`` in the ``polarity`` convention. Returns the
    ground truth as stored after ingest (see :func:`make_events`; ``p`` in -1/+1).
    """
    if sorted(columns) != ["p", "t", "x", "y"]:
        raise ValueError(f"`columns` (={list(columns)}) must be a permutation of t, x, y, p")
    events = make_events(n, width=width, height=height, seed=seed, t0_us=t0_us,
                         mean_dt_us=mean_dt_us)
    in_file = {**events, "p": polarity_as(events["p"], polarity)}
    with open(path, "wb") as f:
        f.write((",".join(columns) + "\n").encode())
        for start in range(0, n, _ROWS_PER_BLOCK):
            stop = min(n, start + _ROWS_PER_BLOCK)
            f.write(format_int_rows([in_file[c][start:stop] for c in columns]))
    return events


def write_events_npy(path: str | Path, n: int, *, width: int, height: int, seed: int,
                     polarity: Polarity = "pm1", t0_us: int = 1_600_000_000_000_000,
                     mean_dt_us: int = 1) -> dict[str, np.ndarray]:
    """Write ``n`` random events as a .npy structured array (fields t, x, y, p; see
    :data:`NPY_DTYPE`), ``p`` in the ``polarity`` convention. Returns the ground truth as
    stored after ingest (``p`` in -1/+1)."""
    events = make_events(n, width=width, height=height, seed=seed, t0_us=t0_us,
                         mean_dt_us=mean_dt_us)
    table = np.empty(n, dtype=NPY_DTYPE)
    for name in ("t", "x", "y"):
        table[name] = events[name]
    table["p"] = polarity_as(events["p"], polarity)
    np.save(path, table)
    return events


def format_int_rows(columns: Sequence[np.ndarray]) -> bytes:
    """CSV lines (``b"v0,v1,...\\n"`` per row) of integer columns, each (n,).

    Vectorised: every column becomes an (n, digits) array of ASCII digits, the rows are
    laid side by side with separators, and a mask drops each number's leading zeros.
    """
    n = len(columns[0])
    parts: list[np.ndarray] = []
    keep: list[np.ndarray] = []
    for j, column in enumerate(columns):
        digits, used = _ascii_digits(np.asarray(column, dtype=np.int64))
        parts.append(digits)
        keep.append(used)
        sep = np.full((n, 1), ord("\n") if j == len(columns) - 1 else ord(","), dtype=np.uint8)
        parts.append(sep)
        keep.append(np.ones((n, 1), dtype=bool))
    return np.hstack(parts)[np.hstack(keep)].tobytes()


def _ascii_digits(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(n, w) uint8 sign and digits right-aligned in w columns, and (n, w) bool of the
    characters that belong to each number (sign if negative, no leading zeros)."""
    n = len(values)
    magnitude = np.abs(values)
    n_digits = len(str(int(magnitude.max()))) if n else 1
    width = n_digits + 1  # a column for the sign
    chars = np.empty((n, width), dtype=np.uint8)
    rest = magnitude.copy()
    for col in range(width - 1, 0, -1):
        chars[:, col] = ord("0") + rest % 10
        rest //= 10
    n_used = np.ones(n, dtype=np.int64)  # digits of each number ("0" has one)
    for k in range(1, n_digits):
        n_used += magnitude >= 10 ** k
    negative = np.flatnonzero(values < 0)
    chars[:, 0] = ord("0")
    chars[negative, width - 1 - n_used[negative]] = ord("-")
    n_used[negative] += 1
    used = np.arange(width)[None, :] >= (width - n_used)[:, None]
    return chars, used
