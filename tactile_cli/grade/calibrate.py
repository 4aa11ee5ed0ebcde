"""Fit the input membership functions of the grader from labelled areas.

Another sensor (or another lens, threshold or press duration) gives other areas, so the
input terms are fitted to labelled recordings while the output terms and the rule table
stay as configured. The method, per grade ``k = 0 .. G-1`` (lowest force first):

1. Robust statistics of the areas labelled ``k``: median ``m_k`` and quartiles
   ``Q25_k``, ``Q75_k``. The medians must increase with the grade; if they do not, the area
   does not order the forces and calibration stops with an error naming the grades.
2. Boundary between grades ``k`` and ``k+1``: the midpoint of the facing quartiles,
   ``b_k = (Q75_k + Q25_{k+1}) / 2``. With two force levels per grade the upper quartile of
   a grade sits near its upper level and the lower quartile of the next grade near that
   grade's lower level, so ``b_k`` falls between the two levels that actually face each
   other, even when one grade is compressed (the saturated biggest force). It is clamped
   into ``[m_k, m_{k+1}]``.
3. Membership functions: a fuzzy partition of trapezoids. Term ``k`` falls from 1 to 0
   over ``[b_k - w_k/2, b_k + w_k/2]`` while term ``k+1`` rises over the same interval, so
   the two cross at 0.5 exactly at ``b_k`` and sum to 1 everywhere. The transition width
   is ``w_k = overlap * 2 * min(b_k - m_k, m_{k+1} - b_k)`` (``overlap`` in (0, 1],
   default 0.5), which keeps every grade's median on its term's plateau. The first term is
   a left shoulder from the range's low end, the last a right shoulder to its high end.
   The input range spans the data plus half its span on each side (inputs beyond it are
   clipped to it, so very large areas grade as the biggest force).

With the default output terms (symmetric triangles one step apart, end terms included),
equal firing of two neighbours puts the centroid halfway between their peaks, so the
crisp grade changes exactly at ``b_k``: the fuzzy grader then decides like thresholds at
the boundaries, with a crisp output that moves smoothly inside each transition.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .config import GraderConfig, TermConfig, config_from_dict


@dataclass
class AreaCalibrator:
    """Fits the input terms; ``fit`` returns ``self``, learned attributes end in ``_``.

    overlap: transition width as a fraction of the room around each boundary, (0, 1].
    range_margin: the input range extends the data by this fraction of its span each side.
    """

    overlap: float = 0.5
    range_margin: float = 0.5

    def fit(self, areas: np.ndarray, grades: np.ndarray, n_grades: int) -> AreaCalibrator:
        """Fit from ``areas`` (n,) events and ``grades`` (n,) ints in ``[0, n_grades)``;
        NaN areas are ignored."""
        if not 0 < self.overlap <= 1:
            raise ValueError(f"`overlap` (={self.overlap}) must be in (0, 1]")
        if not self.range_margin >= 0:
            raise ValueError(f"`range_margin` (={self.range_margin}) must be >= 0")
        areas = np.asarray(areas, dtype=np.float64).reshape(-1)
        grades = np.asarray(grades).reshape(-1)
        if areas.shape != grades.shape:
            raise ValueError(f"`areas` {areas.shape} and `grades` {grades.shape} differ in "
                             "shape")
        keep = np.isfinite(areas)
        areas, grades = areas[keep], grades[keep].astype(np.int64)
        bad = (grades < 0) | (grades >= n_grades)
        if bad.any():
            raise ValueError(f"grade {int(grades[bad][0])} is outside 0..{n_grades - 1}")
        counts = np.bincount(grades, minlength=n_grades)
        if (counts == 0).any():
            missing = [int(k) for k in np.flatnonzero(counts == 0)]
            raise ValueError(f"no labelled trial of grade(s) {missing}; calibration needs at "
                             "least one trial of every grade")
        q25, med, q75 = (np.array([np.percentile(areas[grades == k], q)
                                   for k in range(n_grades)]) for q in (25, 50, 75))
        for k in range(n_grades - 1):
            if not med[k + 1] > med[k]:
                raise ValueError(
                    f"the median area of grade {k + 1} (={med[k + 1]:.6g}) is not above that "
                    f"of grade {k} (={med[k]:.6g}): the area does not order these forces")
        bounds = np.clip(0.5 * (q75[:-1] + q25[1:]), med[:-1], med[1:])
        room = np.minimum(bounds - med[:-1], med[1:] - bounds)
        widths = self.overlap * 2.0 * room
        span = float(areas.max() - areas.min()) or max(1.0, abs(float(areas.max())))
        lo = float(areas.min()) - self.range_margin * span
        hi = float(areas.max()) + self.range_margin * span
        self.counts_ = counts
        self.medians_, self.q25_, self.q75_ = med, q25, q75
        self.boundaries_ = bounds
        self.widths_ = widths
        self.range_ = (lo, hi)
        return self

    def trapezoids(self) -> list[tuple[float, float, float, float]]:
        """``(a, b, c, d)`` of every grade's input term, lowest grade first."""
        lo, hi = self.range_
        edges_lo = [(lo, lo)] + [(b - w / 2, b + w / 2) for b, w in
                                 zip(self.boundaries_, self.widths_, strict=True)]
        edges_hi = edges_lo[1:] + [(hi, hi)]
        return [(a, b, c, d) for (a, b), (c, d) in zip(edges_lo, edges_hi, strict=True)]

    def to_config(self, base: GraderConfig, *, provenance: dict | None = None) \
            -> GraderConfig:
        """``base`` with its input terms and range replaced by the fitted ones.

        The base's rules must map one input term to each grade; that term gets the grade's
        trapezoid.
        """
        grades = base.grades
        term_of_grade: dict[str, str] = {}
        for rule in base.rules:
            if rule.then in term_of_grade and term_of_grade[rule.then] != rule.if_:
                raise ValueError(f"grade {rule.then!r} has rules from two input terms; "
                                 "calibration needs one input term per grade (Table III)")
            term_of_grade[rule.then] = rule.if_
        if len(set(term_of_grade.values())) != len(grades):
            raise ValueError("calibration needs one input term per grade (Table III)")
        traps = self.trapezoids()
        terms = {term_of_grade[g]: TermConfig(mf="trapmf", params=[float(v) for v in t])
                 for g, t in zip(grades, traps, strict=True)}
        data = base.as_yaml_dict()
        data["input"]["range"] = [float(v) for v in self.range_]
        data["input"]["terms"] = {name: {"mf": t.mf, "params": t.params}
                                  for name, t in terms.items()}
        data["provenance"] = provenance
        if provenance is None:
            data.pop("provenance")
        return config_from_dict(data)

    def summary(self, grades: tuple[str, ...]) -> list[dict]:
        """Per grade: n, quartiles and median, and the boundary above it."""
        out = []
        for k, name in enumerate(grades):
            out.append({
                "grade": name, "n": int(self.counts_[k]), "q25": float(self.q25_[k]),
                "median": float(self.medians_[k]), "q75": float(self.q75_[k]),
                "upper_boundary": (float(self.boundaries_[k])
                                   if k < len(self.boundaries_) else None),
            })
        return out


__all__ = ["AreaCalibrator"]
