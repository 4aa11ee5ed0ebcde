"""`tactile grade` results as text for people: the calibration, one row per trial (crisp
output, grade, truth, rules fired) and the accuracy and correlation lines, as
:class:`~tactile_cli.text_table.TextTable` and lines."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from ..text_table import TextTable

if TYPE_CHECKING:
    from .pipeline import GradeRun


def _fmt(v: float | None, spec: str = ".4f") -> str:
    return "" if v is None or v != v else format(v, spec)


def grade_blocks(run: GradeRun, *, multi_file: bool = False) -> list[str | TextTable]:
    """The calibration table (with ``calibrate``), the grades table (a file column when
    ``multi_file``), the summary lines and the figures written; a wrong grade is marked
    with ``*``."""
    report, cfg, calib = run.report, run.config, run.calibration
    blocks: list[str | TextTable] = []
    if calib is not None:
        blocks.append(TextTable(
            ["grade", "n", "Q25", "median", "Q75", "upper boundary"],
            title=f"Calibration (written to {calib.out})",
            rows=[[row["grade"], str(row["n"]), f"{row['q25']:.6g}", f"{row['median']:.6g}",
                   f"{row['q75']:.6g}", _fmt(row["upper_boundary"], ".6g")]
                  for row in calib.per_grade]))
    columns = (["file"] if multi_file else []) + [
        "trial", cfg.input.name, "crisp", "grade", "true", "rules fired (strength)"]
    table = TextTable(columns, title=f"Force grades ({run.config_path}, {report.method} "
                      "centroid)", left=len(columns))
    for t in report.trials:
        fired = ", ".join(f"{k}={v:.2f}" for k, v in t.firing.items() if v > 0)
        true = (t.true_grade or "") + (f" (level {t.true_level})"
                                       if t.true_level is not None else "")
        grade = (t.grade or "-") + (" *" if t.error not in (None, 0) else "")
        table.rows.append(([Path(t.file).name] if multi_file else []) + [
            t.trial, _fmt(t.area, ".6g"), _fmt(t.crisp), grade, true,
            fired if t.status == "ok" else t.status])
    blocks.append(table)
    s = report.summary
    if s.n_labelled:
        blocks.append(f"{s.n_labelled} labelled trials: {100 * s.accuracy:.1f} % graded right, "
                      f"{100 * s.off_by_one:.1f} % off by one grade, {100 * s.worse:.1f} % "
                      "worse (* in the grade column)")
    if s.pearson_r is not None:
        blocks.append(f"Pearson r of {cfg.input.name} with "
                      f"{s.correlation_with.replace('_', ' ')}: {s.pearson_r:.4f} "
                      f"({s.n_correlation} trials)")
    if s.n_graded < s.n_trials:
        blocks.append(f"{s.n_trials - s.n_graded} trial(s) not graded (see the rules column)")
    blocks += [f"wrote {p}" for p in run.plots]
    return blocks


__all__ = ["grade_blocks"]
