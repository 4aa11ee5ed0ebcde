"""Results as text for people, in a form any front end renders: :class:`TextTable` (cells
already formatted) and the number formats the tables share.

The library turns each result into lines and tables here (``learn/tables.py`` for
evaluate, compare and perturb; ``fos/tables.py`` for fit-fos; ``store/summary_text.py`` and
``ingest/summary_text.py`` for ``tactile info``); the CLI renders them with rich
(``cli/_output.print_blocks``), a notebook with pandas
(``pd.DataFrame(t.rows, columns=t.columns)``). Nothing here computes a metric.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field


@dataclass
class TextTable:
    """A table of formatted cells: ``columns`` (headers), ``rows`` (one list of strings
    per row), an optional ``title`` and ``caption``; the first ``left`` columns are text
    (left-justified), and so are the columns listed in ``text`` (indices); the others are
    numbers; cells of the columns in ``fold`` may wrap."""

    columns: list[str]
    rows: list[list[str]] = field(default_factory=list)
    title: str | None = None
    caption: str | None = None
    left: int = 1
    fold: tuple[int, ...] = ()
    text: tuple[int, ...] = ()

    def is_text(self, column: int) -> bool:
        """Whether column ``column`` (0-based) is left-justified text."""
        return column < self.left or column in self.text


def pct(value: float | None) -> str:
    """A fraction as ``12.34 %``; ``n/a`` for None or NaN."""
    return "n/a" if value is None or math.isnan(value) else f"{100 * value:.2f} %"


def num(value: float | None) -> str:
    """A number to four decimals; ``n/a`` for None or NaN."""
    return "n/a" if value is None or math.isnan(value) else f"{value:.4f}"


def fixed(value: float | None, spec: str) -> str:
    """``value`` formatted with ``spec`` (``".3f"``); empty for None."""
    return "" if value is None else format(value, spec)


def head_and_tail(items: list, limit: int) -> list:
    """``items`` when at most ``limit`` long, else its first and last ``limit // 2``."""
    half = limit // 2
    return items if len(items) <= limit else items[:half] + items[-half:]
