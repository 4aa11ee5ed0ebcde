"""Grade trials and score the grades against their labels (paper 000, Fig. 15, Table III).

:class:`FuzzyGrader` wraps a config's Mamdani system; :func:`grade_trials` grades the
areas of many trials at once and, where trials carry a ``force_grade`` or ``force_level``
label, reports the fraction graded right, off by one grade and worse, and the Pearson
correlation of the area with the force level (Fig. 15).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from ..errors import InputError
from .config import GraderConfig, normalise_grade
from .features import TrialArea
from .fuzzy import Inference, infer


class FuzzyGrader:
    """The Mamdani grader of one config: ``grade(areas)`` for (n,) areas in events."""

    def __init__(self, config: GraderConfig):
        self.config = config
        self.system = config.system()

    @property
    def grades(self) -> tuple[str, ...]:
        return self.config.grades

    @property
    def rule_names(self) -> tuple[str, ...]:
        """``"very_small->light"``, one per rule, in rule order."""
        return tuple(f"{r.if_}->{r.then}" for r in self.config.rules)

    def grade(self, areas: np.ndarray) -> Inference:
        return infer(self.system, np.asarray(areas, dtype=np.float64))


@dataclass
class GradedTrial:
    """One trial's grade: ``crisp`` output, ``grade`` name (``""`` when ungraded),
    ``firing`` strength of every rule, and the truth when labelled (``true_grade``,
    ``true_level``; ``error`` = grade index minus true grade index)."""

    file: str
    trial: str
    area: float
    crisp: float
    grade: str
    grade_index: int
    firing: dict[str, float]
    true_grade: str | None = None
    true_level: int | None = None
    error: int | None = None
    region_start_s: float = float("nan")
    region_end_s: float = float("nan")
    source: str = ""
    status: str = "ok"


@dataclass
class GradeSummary:
    """Accuracy over the labelled, graded trials, and the area-force correlation."""

    n_trials: int
    n_graded: int
    n_labelled: int
    accuracy: float | None
    off_by_one: float | None
    worse: float | None
    correlation_with: str | None  # "force_level" or "grade"
    pearson_r: float | None
    n_correlation: int


@dataclass
class GradeReport:
    trials: list[GradedTrial]
    summary: GradeSummary
    grades: tuple[str, ...]
    rules: tuple[str, ...]
    method: str
    config: dict[str, Any] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        def clean(v: Any) -> Any:
            if isinstance(v, float) and not np.isfinite(v):
                return None
            if isinstance(v, dict):
                return {k: clean(x) for k, x in v.items()}
            if isinstance(v, list | tuple):
                return [clean(x) for x in v]
            return v

        return clean({"grades": list(self.grades), "rules": list(self.rules),
                      "method": self.method, "summary": asdict(self.summary),
                      "trials": [asdict(t) for t in self.trials]})


def true_grade_index(trial: TrialArea, config: GraderConfig, label_key: str | None) \
        -> tuple[int | None, int | None]:
    """(grade index, force level) of a trial's label, ``(None, None)`` when unlabelled.

    ``label_key`` ``force_grade`` or ``force_level`` picks the label; None takes
    ``force_grade`` when the trial has it, else ``force_level``. An unknown grade name or a
    level outside ``1 .. levels_per_grade * n_grades`` is an :class:`InputError`.
    """
    labels = trial.labels
    level = labels.get("force_level")
    level_int = None
    if level is not None:
        try:
            level_int = int(level)
        except (TypeError, ValueError):
            raise InputError(f"trial {trial.trial!r}: force_level {level!r} is not a whole "
                             "number", path=trial.file) from None
    key = label_key or ("force_grade" if "force_grade" in labels else "force_level")
    if key not in labels:
        return None, level_int
    n_grades = len(config.grades)
    if key == "force_grade":
        names = [normalise_grade(g) for g in config.grades]
        value = normalise_grade(str(labels["force_grade"]))
        if value not in names:
            raise InputError(f"trial {trial.trial!r}: force_grade {labels['force_grade']!r} is "
                             f"not a grade of the config ({', '.join(config.grades)})",
                             path=trial.file)
        return names.index(value), level_int
    n_levels = config.levels_per_grade * n_grades
    if level_int is None or not 1 <= level_int <= n_levels:
        raise InputError(f"trial {trial.trial!r}: force_level {level!r} is outside 1..{n_levels} "
                         f"({config.levels_per_grade} levels per grade, {n_grades} grades; "
                         "set levels_per_grade in the config)", path=trial.file)
    return config.grade_of_level(level_int), level_int


def grade_trials(areas: list[TrialArea], config: GraderConfig, *,
                 label_key: str | None = None) -> GradeReport:
    """Grade every trial in one vectorised call and score the labelled ones."""
    if label_key not in (None, "force_grade", "force_level"):
        raise InputError(f"`label_key` (={label_key!r}) must be force_grade or force_level")
    grader = FuzzyGrader(config)
    x = np.array([t.area for t in areas], dtype=np.float64)
    inf = grader.grade(x)
    truth = [true_grade_index(t, config, label_key) for t in areas]
    rows = []
    for n, t in enumerate(areas):
        g = int(inf.grade[n])
        tg, level = truth[n]
        rows.append(GradedTrial(
            file=t.file, trial=t.trial, area=float(t.area), crisp=float(inf.crisp[n]),
            grade=grader.grades[g] if g >= 0 else "", grade_index=g,
            firing={name: float(v) for name, v in zip(grader.rule_names, inf.firing[n],
                                                      strict=True)},
            true_grade=None if tg is None else grader.grades[tg], true_level=level,
            error=None if (tg is None or g < 0) else g - tg,
            region_start_s=t.region_start_s, region_end_s=t.region_end_s, source=t.source,
            status=t.status))
    errors = np.array([r.error for r in rows if r.error is not None], dtype=np.int64)
    n_lab = errors.size
    # Fig. 15: area against the force level (the grade when only grades are labelled)
    levels = np.array([r.true_level if r.true_level is not None else np.nan for r in rows],
                      dtype=np.float64)
    with_level = np.isfinite(levels) & np.isfinite(x)
    corr_with = "force_level"
    if with_level.sum() < 3:
        levels = np.array([truth[n][0] if truth[n][0] is not None else np.nan
                           for n in range(len(rows))], dtype=np.float64)
        with_level = np.isfinite(levels) & np.isfinite(x)
        corr_with = "grade"
    r = None
    if with_level.sum() >= 3 and np.ptp(levels[with_level]) > 0 and np.ptp(x[with_level]) > 0:
        r = float(np.corrcoef(x[with_level], levels[with_level])[0, 1])
    summary = GradeSummary(
        n_trials=len(rows), n_graded=int(np.sum(inf.grade >= 0)), n_labelled=int(n_lab),
        accuracy=float(np.mean(errors == 0)) if n_lab else None,
        off_by_one=float(np.mean(np.abs(errors) == 1)) if n_lab else None,
        worse=float(np.mean(np.abs(errors) > 1)) if n_lab else None,
        correlation_with=corr_with if r is not None else None, pearson_r=r,
        n_correlation=int(with_level.sum()) if r is not None else 0)
    return GradeReport(rows, summary, grader.grades, grader.rule_names, grader.system.method,
                       config.as_yaml_dict())


__all__ = ["FuzzyGrader", "GradeReport", "GradeSummary", "GradedTrial", "grade_trials",
           "true_grade_index"]
