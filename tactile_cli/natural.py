"""Natural order of names and label values: ``mat2`` before ``mat10``, ``2`` before ``10``.

One sort key for every place that lists classes, trials or label values to a user, so
that the order is the same in ``info``, splits, metrics tables and reports.
"""

from __future__ import annotations

import math
import re
from typing import Any

_DIGITS = re.compile(r"(\d+)")


def natural_key(text: object) -> tuple[Any, ...]:
    """Sort key of ``str(text)``. A value that is a number as a whole (``-1.5``, ``10``)
    sorts by its value, before every name; in a name, digit runs compare as numbers and
    the rest case-insensitively; the exact text breaks ties (``f01`` vs ``f1``)."""
    s = str(text)
    try:
        value = float(s)
    except ValueError:
        value = math.nan
    if not math.isnan(value):
        return (0, value, s)
    parts = _DIGITS.split(s.casefold())
    # re.split with one group alternates text (even) and digits (odd), so types line up
    return (1, tuple(int(p) if i % 2 else p for i, p in enumerate(parts)), s)


def natural_sorted(values: Any) -> list[Any]:
    """``values`` in natural order (see :func:`natural_key`)."""
    return sorted(values, key=natural_key)


__all__ = ["natural_key", "natural_sorted"]
