"""Counts of label values over a file, for `tactile info` and other summaries.

A trial label (``/trials/<trial>/labels``) is counted in trials per value; a per-sample
label (``signals/<stream>/sample_labels/<name>``) in samples per class (or per value, for
numeric labels), over all trials. Values are listed in natural order (``mat2`` before
``mat10``, numbers by value). A label with few values is shown value by value with its
counts; one that differs on (nearly) every trial, such as a grasp id, is summarised: how
many distinct values, their range when they are numbers, and a few examples.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..natural import natural_key
from .trials import SampleLabel

#: A label with at most this many distinct values is listed value by value.
MAX_VALUES_LISTED = 24
#: Example values shown for a label with more distinct values than that.
EXAMPLES_SHOWN = 4
#: Distinct values of a numeric per-sample label counted one by one; a label with more
#: (a continuous quantity) keeps its range and a lower bound of its distinct values only.
MAX_VALUES_COUNTED = 10_000
#: The name of samples whose class code is -1.
UNLABELLED = "(unlabelled)"


@dataclass
class LabelCounts:
    """One label over a file.

    name: the label; stream: the stream of a per-sample label, ``""`` for a trial label;
    unit: what is counted (``"trials"`` or ``"samples"``); n: trials (or samples) that
    carry the label; counts: value (as text) -> trials (or samples) with it, in natural
    order, every value (classes with no sample included), or None when a numeric per-sample
    label took more than :data:`MAX_VALUES_COUNTED` values; n_distinct: distinct values (a
    lower bound when counts is None); classes: class names of a categorical per-sample
    label, in code order (None otherwise); low, high: the smallest and largest value when
    every value is a number (else None).
    """

    name: str
    stream: str
    unit: str
    n: int = 0
    counts: dict[str, int] | None = field(default_factory=dict)
    n_distinct: int = 0
    classes: list[str] | None = None
    low: float | None = None
    high: float | None = None

    @property
    def listed(self) -> bool:
        """Whether the label is shown value by value (few distinct values)."""
        return self.counts is not None and self.n_distinct <= MAX_VALUES_LISTED

    def brief(self) -> str:
        """One line: ``no_slip: 1,999, slip: 196 (2,195 samples)`` for a label with few
        values, else ``1,276 distinct values over 1,276 trials (one each), e.g. g1, g2, ...``."""
        if self.listed and self.counts is not None:
            text = ", ".join(f"{v}: {c:,}" for v, c in self.counts.items())
            return text + (f" ({self.n:,} samples)" if self.unit == "samples" else "")
        distinct = (f"{self.n_distinct:,}" if self.counts is not None
                    else f"more than {MAX_VALUES_COUNTED:,}")
        text = f"{distinct} distinct values over {self.n:,} {self.unit}"
        if self.counts is not None and self.n_distinct == self.n:
            text += " (one each)"
        if self.low is not None and self.high is not None:
            text += f", {self.low:g} to {self.high:g}"
        if self.counts:
            examples = list(self.counts)[:EXAMPLES_SHOWN]
            text += f"; e.g. {', '.join(examples)}, ..."
        return text


def count_trial_labels(labels_per_trial: list[dict[str, Any]]) -> list[LabelCounts]:
    """The trial labels of a file (one dict per trial), counted in trials per value; labels
    in natural order of their names."""
    counters: dict[str, Counter[str]] = {}
    numbers: dict[str, list[float]] = {}
    for labels in labels_per_trial:
        for key, value in labels.items():
            counters.setdefault(key, Counter())[str(value)] += 1
            if _is_number(value):
                numbers.setdefault(key, []).append(float(value))
    out = []
    for key in sorted(counters, key=natural_key):
        counter = counters[key]
        counts = {v: counter[v] for v in sorted(counter, key=natural_key)}
        n = sum(counts.values())
        found = numbers.get(key, [])
        low, high = (min(found), max(found)) if len(found) == n else (None, None)
        out.append(LabelCounts(key, "", "trials", n=n, counts=counts, n_distinct=len(counts),
                               low=low, high=high))
    return out


class SampleLabelTally:
    """Adds up the per-sample labels of every trial's streams (:meth:`add` one stream's
    labels at a time), then :meth:`result` gives one :class:`LabelCounts` per (stream,
    label) in the order first seen."""

    def __init__(self) -> None:
        self._labels: dict[tuple[str, str], LabelCounts] = {}
        self._values: dict[tuple[str, str], dict[float, int] | None] = {}

    def add(self, stream: str, labels: dict[str, SampleLabel]) -> None:
        """Count the labels of one stream of one trial."""
        for name, label in labels.items():
            key = (stream, name)
            lc = self._labels.setdefault(key, LabelCounts(name, stream, "samples"))
            values = np.asarray(label.values)
            lc.n += int(values.shape[0])
            if label.classes is not None:
                self._add_codes(lc, values, list(label.classes))
            else:
                self._add_numbers(key, lc, values)

    def _add_codes(self, lc: LabelCounts, codes: np.ndarray, classes: list[str]) -> None:
        lc.classes = lc.classes or classes
        per_code = np.bincount(codes.astype(np.int64) + 1, minlength=len(classes) + 1)
        counts = lc.counts if lc.counts is not None else {}
        for name, c in zip([UNLABELLED, *classes], per_code.tolist(), strict=False):
            if c or name != UNLABELLED:
                counts[name] = counts.get(name, 0) + int(c)
        lc.counts = counts

    def _add_numbers(self, key: tuple[str, str], lc: LabelCounts, values: np.ndarray) -> None:
        if values.size:
            low, high = float(values.min()), float(values.max())
            lc.low = low if lc.low is None else min(lc.low, low)
            lc.high = high if lc.high is None else max(lc.high, high)
        tally = self._values.setdefault(key, {})
        if tally is None:  # gave up counting
            return
        uniq, counts = np.unique(values, return_counts=True)
        for v, c in zip(uniq.tolist(), counts.tolist(), strict=True):
            tally[v] = tally.get(v, 0) + c
        if len(tally) > MAX_VALUES_COUNTED:
            self._values[key] = None
            lc.n_distinct = len(tally)

    def result(self) -> list[LabelCounts]:
        """Every (stream, label) counted, values in natural order."""
        out = []
        for key, lc in self._labels.items():
            if lc.classes is None:
                tally = self._values.get(key)
                if tally is None:
                    lc.counts = None
                else:
                    lc.counts = {_number_text(v): c for v, c in sorted(tally.items())}
            elif lc.counts is not None:
                lc.counts = {v: lc.counts[v] for v in sorted(lc.counts, key=natural_key)}
            if lc.counts is not None:
                lc.n_distinct = len(lc.counts)
            out.append(lc)
        return out


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(
        value, (bool, np.bool_))


def _number_text(value: float) -> str:
    """``1.0`` -> ``"1"``, ``0.25`` -> ``"0.25"`` (every digit kept: no two values merge)."""
    return str(int(value)) if float(value).is_integer() else repr(float(value))


__all__ = ["EXAMPLES_SHOWN", "MAX_VALUES_LISTED", "LabelCounts", "SampleLabelTally",
           "count_trial_labels"]
