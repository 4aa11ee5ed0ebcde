"""Trial-level splits and cross-validation folds: every window of a trial on one side.

Used by ``tactile train`` (train/val/test) and ``tactile train --cv`` (folds). Every rule
works on whole trials, is seeded, and does not depend on the order the files or trials are
given in: trials are ranked by a SHA-256 hash of ``(seed, file name, trial name)`` and groups
or classes by a hash of ``(seed, value)``.

Modes (``data.split.mode``, see :class:`~tactile_cli.learn.config.SplitConfig`):

- ``attribute``: each trial's ``split`` attribute (set at ingest or by ``--split-from``).
- ``random``: the first ``round(test_fraction n)`` trials of the hash order go to test, the
  next ``round(val_fraction n)`` to val (at least one each when the fraction is > 0).
- ``stratified``: the same rule inside every class of the label ``by``, so each class is in
  every split where it has enough trials. A class too small for a split (it would leave no
  training trial) stays out of that split, and the assignment carries a warning saying so.
- ``group``: the groups (values of ``by``) in hash order go whole to test, then to val, until
  the fraction of trials is reached; a group is never split.
- ``blocked``: the values of ``by`` in recording order (natural order: numbers by value;
  ``time_origin_unix_s`` is the trial's start time), the latest values whole to test (as
  many as come nearest ``round(test_fraction n)`` trials, at least one), the values just
  before them to val, the rest to train; with ``within``, inside every value of that label
  (every class keeps its own earliest recordings for training). A value is never split, and
  no held-out trial lies between two training trials of its stratum.

Folds (:func:`cv_folds`): ``k``-fold by the same modes (random: dealt round the folds in hash
order; stratified: each class dealt round the folds, continuing where the previous class
stopped, so fold sizes stay within one trial; group: largest groups first, each to the fold
with the fewest trials; blocked: the values in recording order cut into ``k`` contiguous
blocks whose trial counts are as even as possible, block ``i`` is fold ``i``, inside every
value of ``within`` when it is set), or ``loto`` (leave one trial out). Inside a fold, the
validation trials are taken from the fold's training trials by the configured mode and
``val_fraction`` (a fraction of those trials; blocked: the latest training blocks).
Blocked folds do not depend on the seed at all: recording order decides them.
"""

from __future__ import annotations

import csv
import hashlib
import io
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from ..config_file import read_text
from ..errors import InputError
from ..natural import natural_key
from .config import SplitConfig

SPLITS: tuple[str, ...] = ("train", "val", "test")


class SplitTrial(Protocol):
    """What a split rule reads of a trial (:class:`tactile_cli.learn.data.TrialSeries` has
    it): where it is, its ``split`` attribute and its labels."""

    file: str
    trial: str
    split_attr: str
    trial_labels: dict[str, Any]
    sample_labels: dict[str, Any]
    classes: dict[str, tuple[str, ...] | None]

    @property
    def key(self) -> str: ...


@dataclass(frozen=True)
class SplitAssignment:
    """Which split each trial belongs to, how that was decided, and what to warn about."""

    splits: tuple[str, ...]  # one of SPLITS per trial, in the order of the trials
    mode: str  # attribute, random, stratified, group, blocked, given (a mapping), cv
    by: str | None = None
    warnings: tuple[str, ...] = ()

    def indices(self, split: str) -> list[int]:
        return [i for i, s in enumerate(self.splits) if s == split]

    def counts(self) -> dict[str, int]:
        return {s: self.splits.count(s) for s in SPLITS}


@dataclass(frozen=True)
class Fold:
    """One cross-validation fold: ``assignment`` puts the fold's held-out trials in test."""

    index: int
    assignment: SplitAssignment
    test_keys: tuple[str, ...]


@dataclass
class FoldPlan:
    """All folds of a cross-validation: ``k`` (or ``"loto"``), the mode and its label."""

    k: int | str
    mode: str
    by: str | None
    folds: list[Fold]
    warnings: list[str] = field(default_factory=list)
    within: str | None = None
    """``blocked`` folds cut inside every value of this label (None: across all trials)."""

    def as_dict(self) -> dict[str, Any]:
        return {"k": self.k, "n_folds": len(self.folds), "mode": self.mode, "by": self.by,
                **({"within": self.within} if self.within is not None else {}),
                "folds": [{"fold": f.index, "test": list(f.test_keys),
                           "counts": f.assignment.counts()} for f in self.folds],
                "warnings": list(self.warnings)}


def fold_text(k: int | str, n_folds: int, mode: str, by: str | None = None) -> str:
    """``"5 folds (stratified by material)"``, or ``"7 folds (leave one trial out)"``."""
    how = "leave one trial out" if k == "loto" else mode + (f" by {by}" if by else "")
    return f"{n_folds} folds ({how})"


# -- recording order (blocked) -----------------------------------------------------------------
#: The trial attribute a ``blocked`` split may order by when no trial label has that name.
TIME_ORIGIN = "time_origin_unix_s"


def order_value(trial: SplitTrial, by: str) -> str:
    """The value of ``by`` that places a trial in recording order, as text for
    :func:`~tactile_cli.natural.natural_key` (numbers sort by value): a trial label, or for
    ``time_origin_unix_s`` without such a label the trial's start time."""
    if by in trial.trial_labels:
        return str(trial.trial_labels[by])
    if by == TIME_ORIGIN:
        value = getattr(trial, "time_origin_unix_s", None)
        if value is not None:
            return repr(float(value))
        raise InputError("trial has no start time (attribute time_origin_unix_s, written by "
                         "the mapped-CSV ingest of epoch time columns); order the blocks by "
                         "a trial label such as a sample number (data.split.by)",
                         path=trial.file, where=f"/trials/{trial.trial}")
    raise InputError(f"no trial label {by!r} to order the blocks by (trial labels: "
                     f"{', '.join(trial.trial_labels) or 'none'}); fix data.split.by (a trial "
                     "label or time_origin_unix_s)", path=trial.file,
                     where=f"/trials/{trial.trial}/labels")


def _ordered_values(trials: Sequence[SplitTrial], idx: Sequence[int], by: str
                    ) -> list[tuple[str, list[int]]]:
    """(value, indices of its trials) of the trials ``idx``, values in recording order."""
    out: dict[str, list[int]] = {}
    for i in idx:
        out.setdefault(order_value(trials[i], by), []).append(i)
    return [(v, out[v]) for v in sorted(out, key=natural_key)]


def contiguous_blocks(counts: Sequence[int], k: int) -> list[int]:
    """Block index (0..k-1, non-decreasing) of each of ``len(counts)`` ordered values whose
    trial counts are ``counts``: ``k`` contiguous, non-empty blocks whose trial counts are
    as even as possible (least squares from ``n / k``, exact in integers; ties: the earlier
    cut). ``k`` must be between 1 and ``len(counts)``."""
    m = len(counts)
    if not 1 <= k <= m:
        raise ValueError(f"`k` (={k}) must be between 1 and the number of values (={m})")
    prefix = np.concatenate([[0], np.cumsum(np.asarray(counts, dtype=np.int64))])
    n = int(prefix[-1])
    big = np.iinfo(np.int64).max // 4
    cost = np.full((k + 1, m + 1), big, dtype=np.int64)  # cost[j, i]: i values in j blocks
    cut = np.zeros((k + 1, m + 1), dtype=np.int64)
    cost[0, 0] = 0
    for j in range(1, k + 1):
        for i in range(j, m - (k - j) + 1):
            p = np.arange(j - 1, i)
            c = cost[j - 1, p] + (k * (prefix[i] - prefix[p]) - n) ** 2
            best = int(np.argmin(c))  # the first minimum: the earlier cut
            cost[j, i], cut[j, i] = c[best], p[best]
    out = [0] * m
    i = m
    for j in range(k, 0, -1):
        p = int(cut[j, i])
        for v in range(p, i):
            out[v] = j - 1
        i = p
    return out


def _blocked_strata(trials: Sequence[SplitTrial], within: str | None) -> dict[str, list[int]]:
    return _strata(trials, within) if within is not None else {"": list(range(len(trials)))}


def _trailing(values: Sequence[tuple[str, list[int]]], want: int) -> int:
    """How many of the last ``values`` hold nearest ``want`` trials (at least one when
    ``want`` > 0; ties: fewer values)."""
    if want <= 0:
        return 0
    best, best_gap, total = 1, None, 0
    for t in range(1, len(values) + 1):
        total += len(values[-t][1])
        gap = abs(total - want)
        if best_gap is None or gap < best_gap:
            best, best_gap = t, gap
        if total >= want:
            break
    return best


def _blocked_split(trials: Sequence[SplitTrial], split: SplitConfig, by: str
                   ) -> SplitAssignment:
    out = ["train"] * len(trials)
    warnings: list[str] = []
    for stratum, idx in _blocked_strata(trials, split.within).items():
        values = _ordered_values(trials, idx, by)
        n = len(idx)
        n_test = _trailing(values, _count(split.test_fraction, n))
        n_val = _trailing(values[:len(values) - n_test], _count(split.val_fraction, n))
        where = f" within {split.within}={stratum}" if split.within is not None else ""
        while len(values) - n_test - n_val < 1 and (n_val or n_test):
            if n_val:
                n_val -= 1
                warnings.append(f"{by} has {len(values)} value(s){where}: none left for val")
            else:
                n_test -= 1
                warnings.append(f"{by} has {len(values)} value(s){where}: none left for test")
        if split.within is None and n_test == 0 and split.test_fraction > 0:
            raise InputError(f"label {by!r} has {len(values)} value(s): a blocked split needs "
                             "at least 2 (one for training and one held out)")
        held = {"test": 0, "val": 0}
        for pos, (_, members) in enumerate(reversed(values)):
            name = "test" if pos < n_test else "val" if pos < n_test + n_val else "train"
            for i in members:
                out[i] = name
            if name in held:
                held[name] += len(members)
        for name, fraction in (("val", split.val_fraction), ("test", split.test_fraction)):
            if fraction > 0 and held[name] > max(1.5 * fraction * n, _count(fraction, n) + 1):
                instead = ("val_fraction 0 (no early stopping)" if name == "val"
                           else "test_fraction 0")
                warnings.append(
                    f"{name}: {held[name]} of {n} trial(s){where} ({100 * held[name] / n:.0f} %) "
                    f"for {name}_fraction {fraction:g}: whole blocks of {by} are held out "
                    f"and {len(values)} value(s) make blocks that large; give more values of "
                    f"{by}, or {instead} if that is too much to hold out")
    return SplitAssignment(tuple(out), "blocked", by, tuple(warnings))


def _blocked_folds(trials: Sequence[SplitTrial], split: SplitConfig, by: str, k: int
                   ) -> tuple[list[int], list[str]]:
    """Fold index of each trial by the blocked k-fold rule, and the plan's warnings."""
    fold_of = [0] * len(trials)
    warnings: list[str] = []
    for stratum, idx in _blocked_strata(trials, split.within).items():
        values = _ordered_values(trials, idx, by)
        if len(values) < k:
            if split.within is None:
                raise InputError(f"label {by!r} has {len(values)} value(s), fewer than the {k} "
                                 "folds; lower `k` or order the blocks by another label")
            warnings.append(f"{split.within}={stratum} has {len(values)} value(s) of {by}, "
                            f"fewer than the {k} folds: {k - len(values)} fold(s) hold none "
                            "of it")
        blocks = contiguous_blocks([len(m) for _, m in values], min(k, len(values)))
        for b, (_, members) in zip(blocks, values, strict=True):
            for i in members:
                fold_of[i] = b
    return fold_of, warnings


# -- what a trial is, for a rule ---------------------------------------------------------------
def _rank(seed: int, text: str) -> str:
    return hashlib.sha256(f"{seed}|{text}".encode()).hexdigest()


def trial_class(trial: SplitTrial, by: str) -> str:
    """The value of label ``by`` for a trial: its trial label, or for a per-sample label the
    classes its samples hold, joined with ``+`` (``no_slip+slip``; ``unlabelled`` when none)."""
    if by in trial.trial_labels:
        return str(trial.trial_labels[by])
    if by in trial.sample_labels:
        values = trial.sample_labels[by]
        classes = trial.classes.get(by)
        present = sorted({int(v) for v in set(values.tolist()) if v >= 0}) \
            if values.dtype.kind in "iu" else []
        if values.dtype.kind not in "iu":
            raise InputError(f"label {by!r} is numeric (not classes); stratify or group by a "
                             "categorical label", path=trial.file, where=f"/trials/{trial.trial}")
        names = [classes[i] if classes is not None and i < len(classes) else str(i)
                 for i in present]
        return "+".join(names) or "unlabelled"
    raise InputError(f"no trial or per-sample label {by!r} to split by (trial labels: "
                     f"{', '.join(trial.trial_labels) or 'none'}; sample labels: "
                     f"{', '.join(trial.sample_labels) or 'none'}); fix data.split.by",
                     path=trial.file, where=f"/trials/{trial.trial}/labels")


def _strata(trials: Sequence[SplitTrial], by: str) -> dict[str, list[int]]:
    """class value -> indices of its trials, classes in natural order."""
    out: dict[str, list[int]] = {}
    for i, t in enumerate(trials):
        out.setdefault(trial_class(t, by), []).append(i)
    return {k: out[k] for k in sorted(out, key=natural_key)}


def _count(fraction: float, n: int) -> int:
    return 0 if fraction <= 0 or n == 0 else max(1, round(fraction * n))


def default_by(split: SplitConfig, targets: Sequence[Any] = ()) -> str | None:
    """``split.by``, or for ``stratified`` the first classification target's name."""
    if split.by is not None or split.mode != "stratified":
        return split.by
    for t in targets:
        if getattr(t, "kind", "classification") == "classification":
            return str(t.name)
    raise InputError("data.split.mode stratified needs data.split.by (no classification "
                     "target to stratify by)")


# -- train/val/test ----------------------------------------------------------------------------
def assign_splits(trials: Sequence[SplitTrial], split: SplitConfig, seed: int, *,
                  by: str | None = None) -> SplitAssignment:
    """Assign whole trials to train/val/test by ``split.mode`` (see the module docstring);
    ``by``: the label of ``stratified``/``group`` when ``split.by`` is not set."""
    attrs = [t.split_attr for t in trials]
    mode = split.mode
    by = split.by or by
    if mode == "auto":
        if all(a in SPLITS for a in attrs):
            mode = "attribute"
        elif all(a == "" for a in attrs):
            mode = "random"
        else:
            t = next(t for t in trials if t.split_attr not in SPLITS)
            raise InputError("some trials have a split attribute and this one has none; set "
                             "data.split.mode to attribute or random", path=t.file,
                             where=f"/trials/{t.trial}")
    if mode == "attribute":
        for t in trials:
            if t.split_attr not in SPLITS:
                raise InputError(f"split attribute is {t.split_attr!r}, not one of "
                                 f"{', '.join(SPLITS)}; set data.split.mode: random",
                                 path=t.file, where=f"/trials/{t.trial}")
        return SplitAssignment(tuple(attrs), "attribute")
    split_seed = seed if split.seed is None else split.seed
    if mode in ("stratified", "group", "blocked") and by is None:
        raise InputError(f"data.split.mode {mode} needs data.split.by")
    if mode == "group":
        return _group_split(trials, split, split_seed, str(by))
    if mode == "blocked":
        return _blocked_split(trials, split, str(by))
    strata = _strata(trials, str(by)) if mode == "stratified" else {"": list(range(len(trials)))}
    out = ["train"] * len(trials)
    warnings: list[str] = []
    for value, idx in strata.items():
        order = sorted(idx, key=lambda i: (_rank(split_seed, trials[i].key), trials[i].file))
        n = len(order)
        n_test, n_val = _count(split.test_fraction, n), _count(split.val_fraction, n)
        if mode != "stratified" and n - n_test - n_val < 1:
            raise InputError(f"{n} trial(s) cannot be split into {n_val} val and {n_test} test "
                             "trial(s) with at least one left for training; give more trials "
                             "or lower data.split.val_fraction / test_fraction")
        while n - n_test - n_val < 1 and (n_val or n_test):
            if n_val:
                n_val -= 1
                warnings.append(f"class {by}={value} has {n} trial(s): none in val")
            else:
                n_test -= 1
                warnings.append(f"class {by}={value} has {n} trial(s): none in test")
        for pos, i in enumerate(order):
            if pos < n_test:
                out[i] = "test"
            elif pos < n_test + n_val:
                out[i] = "val"
    return SplitAssignment(tuple(out), mode, by if mode == "stratified" else None,
                           tuple(warnings))


def _group_split(trials: Sequence[SplitTrial], split: SplitConfig, seed: int, by: str
                 ) -> SplitAssignment:
    groups = _strata(trials, by)
    n = len(trials)
    if len(groups) < 2:
        raise InputError(f"label {by!r} has {len(groups)} value(s): grouping needs at least 2 "
                         "groups (one for training and one held out)")
    order = sorted(groups, key=lambda g: _rank(seed, g))
    want_test, want_val = _count(split.test_fraction, n), _count(split.val_fraction, n)
    out = ["train"] * n
    taken = {"test": 0, "val": 0}
    warnings: list[str] = []
    remaining = list(order)
    for name, want in (("test", want_test), ("val", want_val)):
        while want and taken[name] < want and len(remaining) > 1:
            g = remaining.pop(0)
            for i in groups[g]:
                out[i] = name
            taken[name] += len(groups[g])
        if want and taken[name] == 0:
            warnings.append(f"no group of {by!r} is left for {name}: every other group is "
                            "needed for training")
    return SplitAssignment(tuple(out), "group", by, tuple(warnings))


# -- given splits ------------------------------------------------------------------------------
def split_from_mapping(trials: Sequence[SplitTrial], mapping: Mapping[str, str], *,
                       source: str | Path, mode: str = "given") -> SplitAssignment:
    """Splits given per trial (``file name/trial`` or a trial name unique in the data ->
    split): every trial must be covered, with one of train, val, test."""
    by_name: dict[str, list[str]] = {}
    for t in trials:
        by_name.setdefault(t.trial, []).append(t.key)
    out = []
    for t in trials:
        value = mapping.get(t.key)
        if value is None and len(by_name[t.trial]) == 1:
            value = mapping.get(t.trial)
        if value is None:
            raise InputError(f"trial {t.key} has no split in it; give every trial of the data "
                             "a row (columns trial, split and, where trial names repeat "
                             "across files, file)", path=source)
        out.append(value)
    return SplitAssignment(tuple(out), mode)


def read_split_csv(path: str | Path) -> dict[str, str]:
    """``--split-from CSV``: columns ``trial`` and ``split`` (train, val or test) and
    optionally ``file`` (the data file's name); returns ``file/trial`` or ``trial`` ->
    split. Standard CSV quoting; a bad row is one error naming the file and row."""
    path = Path(path)
    text = read_text(path)
    rows = list(csv.reader(io.StringIO(text)))
    if not rows:
        raise InputError("empty split file; give columns trial,split", path=path)
    header = [h.strip() for h in rows[0]]
    for col in ("trial", "split"):
        if col not in header:
            raise InputError(f"no column {col!r} in the header ({', '.join(header)}); give "
                             "columns trial,split (and file where trial names repeat)",
                             path=path, where="row 1")
    ti, si = header.index("trial"), header.index("split")
    fi = header.index("file") if "file" in header else None
    out: dict[str, str] = {}
    for n, row in enumerate(rows[1:], start=2):
        if not any(c.strip() for c in row):
            continue
        if len(row) != len(header):
            raise InputError(f"row has {len(row)} fields, expected {len(header)} like the "
                             "header", path=path, where=f"row {n}")
        split = row[si].strip()
        if split not in SPLITS:
            raise InputError(f"split {split!r} is not one of {', '.join(SPLITS)}", path=path,
                             where=f"row {n}")
        trial = row[ti].strip()
        key = f"{Path(row[fi].strip()).name}/{trial}" if fi is not None else trial
        if key in out:
            raise InputError(f"trial {key} appears twice", path=path, where=f"row {n}")
        out[key] = split
    if not out:
        raise InputError("the split file has no rows", path=path)
    return out


def read_run_splits(path: str | Path) -> dict[str, str]:
    """A run's ``split.csv`` (columns file, trial, split) as ``file name/trial`` -> split;
    an empty dict when the file is missing or unreadable as such (older runs)."""
    path = Path(path)
    if not path.is_file():
        return {}
    try:
        rows = list(csv.reader(io.StringIO(read_text(path))))
    except InputError:
        return {}
    if not rows or rows[0][:3] != ["file", "trial", "split"]:
        return {}
    return {f"{Path(r[0]).name}/{r[1]}": r[2] for r in rows[1:] if len(r) >= 3}


def held_out_trials(trials: Sequence[SplitTrial], *, split_csv: str | Path, split: SplitConfig,
                seed: int, targets: Sequence[Any] = ()) -> list[SplitTrial]:
    """The trials a trained run held out for test: those its ``split.csv`` marks test, and
    for trials the run never saw, those its split rule (same config and seed) puts in test."""
    recorded = read_run_splits(split_csv)
    unseen = [t for t in trials if t.key not in recorded]
    by_rule: set[str] = set()
    if unseen:
        if split.mode == "attribute" or (split.mode == "auto" and
                                         all(t.split_attr for t in unseen)):
            by_rule = {t.key for t in unseen if t.split_attr == "test"}
        else:
            assignment = assign_splits(unseen, split, seed, by=default_by(split, targets))
            by_rule = {unseen[i].key for i in assignment.indices("test")}
    return [t for t in trials if recorded.get(t.key) == "test" or t.key in by_rule]


# -- cross-validation --------------------------------------------------------------------------
def _deal_folds(keys: Sequence[str], strata: Mapping[str, Sequence[int]], k: int, seed: int,
                files: Sequence[str] | None = None) -> list[int]:
    """Fold index of each trial: each stratum (in the given order) dealt round the ``k``
    folds in the order of :func:`_rank` of its keys (ties: ``files``), continuing where
    the previous stratum stopped."""
    fold_of = [0] * len(keys)
    pos = 0
    for idx in strata.values():
        for i in sorted(idx, key=lambda i: (_rank(seed, keys[i]), files[i] if files else "")):
            fold_of[i] = pos % k
            pos += 1
    return fold_of


def stratified_fold_of(keys: Sequence[str], classes: Sequence[Any], k: int,
                       seed: int) -> list[int]:
    """Fold index of each trial by the ``stratified`` k-fold rule of :func:`cv_folds`, from
    trial keys (``<file name>/<trial>``) and class values alone (no trial objects): the
    classes (as text) in natural order, each dealt round the ``k`` folds in hash order."""
    strata: dict[str, list[int]] = {}
    for i, c in enumerate(classes):
        strata.setdefault(str(c), []).append(i)
    return _deal_folds(keys, {v: strata[v] for v in sorted(strata, key=natural_key)}, k, seed)


def cv_folds(trials: Sequence[SplitTrial], split: SplitConfig, seed: int, k: int | str, *,
             by: str | None = None) -> FoldPlan:
    """The folds of ``k``-fold (an int >= 2) or ``"loto"`` cross-validation; see the module
    docstring. Raises InputError when the data cannot give ``k`` folds."""
    n = len(trials)
    mode = split.mode
    by = split.by or by
    if mode == "attribute" or (mode == "auto" and all(t.split_attr for t in trials)
                               and k != "loto"):
        raise InputError("cross-validation makes its own folds; set data.split.mode to "
                         "random, stratified or group (the split attributes are ignored)")
    if mode == "auto":
        mode = "random"
    split_seed = seed if split.seed is None else split.seed
    fold_of = [0] * n
    warnings: list[str] = []
    if k == "loto":
        order = sorted(range(n), key=lambda i: (trials[i].key, trials[i].file))
        for pos, i in enumerate(order):
            fold_of[i] = pos
        n_folds = n
        if n < 2:
            raise InputError(f"leave-one-trial-out needs at least 2 trials, got {n}")
    else:
        if not isinstance(k, int) or k < 2:
            raise InputError(f"`k` must be an integer >= 2 or loto, got {k!r}")
        n_folds = k
        if mode == "blocked":
            if by is None:
                raise InputError("data.split.mode blocked needs data.split.by")
            fold_of, warnings = _blocked_folds(trials, split, str(by), k)
        elif mode == "group":
            groups = _strata(trials, str(by))
            if len(groups) < k:
                raise InputError(f"label {by!r} has {len(groups)} group(s), fewer than the {k} "
                                 "folds; lower `k` or group by another label")
            sizes = [0] * k
            for g in sorted(groups, key=lambda g: (-len(groups[g]), _rank(split_seed, g))):
                f = min(range(k), key=lambda j: (sizes[j], j))
                for i in groups[g]:
                    fold_of[i] = f
                sizes[f] += len(groups[g])
        else:
            if n < k:
                raise InputError(f"{n} trial(s) cannot make {k} folds; lower `k`")
            if mode == "stratified" and by is None:
                raise InputError("data.split.mode stratified needs data.split.by")
            strata = _strata(trials, str(by)) if mode == "stratified" \
                else {"": list(range(n))}
            for value, idx in strata.items():
                if mode == "stratified" and len(idx) < k:
                    warnings.append(f"class {by}={value} has {len(idx)} trial(s), fewer than "
                                    f"the {k} folds: {k - len(idx)} fold(s) hold none of it")
            fold_of = _deal_folds([t.key for t in trials], strata, k, split_seed,
                                  [t.file for t in trials])
    folds = []
    inner = SplitConfig(mode=mode if mode != "auto" else "random", by=by,
                        val_fraction=split.val_fraction, test_fraction=0.0, seed=split.seed,
                        within=split.within if mode == "blocked" else None)
    for f in range(n_folds):
        held = [i for i in range(n) if fold_of[i] == f]
        rest = [i for i in range(n) if fold_of[i] != f]
        inner_assign = assign_splits([trials[i] for i in rest], inner, seed + f, by=by) \
            if inner.val_fraction > 0 else SplitAssignment(("train",) * len(rest), mode)
        out = ["test"] * n
        for j, i in enumerate(rest):
            out[i] = inner_assign.splits[j]
        fold_warn = tuple(inner_assign.warnings)
        folds.append(Fold(f, SplitAssignment(tuple(out), "cv", by, fold_warn),
                          tuple(trials[i].key for i in held)))
    return FoldPlan(k, mode, by if mode in ("stratified", "group", "blocked") else None, folds,
                    warnings, split.within if mode == "blocked" else None)


__all__ = ["SPLITS", "TIME_ORIGIN", "Fold", "FoldPlan", "SplitAssignment", "assign_splits",
           "contiguous_blocks", "cv_folds", "order_value",
           "fold_text", "default_by", "read_run_splits", "read_split_csv", "split_from_mapping",
           "held_out_trials", "stratified_fold_of", "trial_class"]
