"""`tactile slip-rate` results as text for people: one row per trial (speed and
displacement with standard errors, the truth and the error against it) and the error
summary, as :class:`~tactile_cli.text_table.TextTable` and lines."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from ..text_table import TextTable

if TYPE_CHECKING:
    from .pipeline import SlipRateReport


def _fmt(value: float | None, digits: int = 4) -> str:
    if value is None or value != value:  # None or NaN
        return "-"
    return f"{value:.{digits}f}"


def slip_rate_blocks(report: SlipRateReport, *, title: str,
                     spell: Callable[[str], str] = str) -> list[str | TextTable]:
    """The trials table, the error line and the files written (``spell``: turns the
    Python argument names of a trial's message into a front end's spelling)."""
    table = TextTable(["trial", "status", "speed (m/s)", "+- se", "displacement (m)", "+- se",
                       "truth (m/s)", "error", "r2", "ROIs"], title=title, left=10)
    for r in report.results:
        err = r["speed_rel_error"]
        table.rows.append([
            r["trial"], r["status"] if r["status"] == "ok" else
            f"{r['status']}: {spell(r['message'])}",
            _fmt(r["speed_m_s"], 6), _fmt(r["speed_se_m_s"], 6), _fmt(r["displacement_m"], 6),
            _fmt(r["displacement_se_m"], 6), _fmt(r["truth_speed_m_s"], 6),
            "-" if err is None else f"{err * 100:+.1f} %", _fmt(r["r2"], 3),
            str(r["n_rois_used"])])
    blocks: list[str | TextTable] = [table]
    s = report.summary
    if s["n_with_truth"]:
        blocks.append(f"speed error vs truth over {s['n_with_truth']} trial(s): mean "
                      f"|error| {s['mean_abs_rel_error'] * 100:.1f} %, max "
                      f"{s['max_abs_rel_error'] * 100:.1f} %")
    if report.plot is not None:
        blocks.append(f"wrote {report.plot}/slip_*.png and {report.plot / 'slip_rate.json'}")
    return blocks


__all__ = ["slip_rate_blocks"]
