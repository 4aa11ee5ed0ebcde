"""`tactile fit-fos` results as text for people: one table per region, its failures
explained and its summary line (:class:`~tactile_cli.text_table.TextTable` cells already
formatted; see :mod:`tactile_cli.text_table`). Nothing here computes a statistic."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from ..text_table import TextTable

if TYPE_CHECKING:
    from .fit_files import FitFosResult, RegionResult

#: Rows of a region's table printed in full; beyond it converged rows are elided (failed
#: rows never are).
MAX_ROWS = 60


def _pm(value: Any, se: Any, fmt: str) -> str:
    if value is None:
        return "-"
    return f"{value:{fmt}}" + (f" ± {se:{fmt}}" if se is not None else "")


def _verdict_cell(r: dict[str, Any]) -> str:
    """The order verdict; a relaxation with its share and time constant."""
    if r["order_verdict"] == "relaxation" and r.get("relax_fraction") is not None:
        return (f"relaxation ({100 * r['relax_fraction']:.0f} % over "
                f"{r['relax_tau_s']:.3g} s)")
    return r["order_verdict"]


def _layout(records: list[dict[str, Any]]) -> tuple[list[str], str | None, bool, bool]:
    """The table's columns, the one unit of every row (None when they differ), whether
    rows are per channel and whether any has a force label."""
    units = {r["units"] for r in records}
    unit = units.pop() if len(units) == 1 else None
    short = {"events/bin": "ev/bin"}.get(unit or "", unit)
    columns = ["trial", "force", f"alpha ({short})" if unit else "alpha", "tau (s)", "T (s)",
               "R", f"s ({short})" if unit else "s",
               f"RSS ({short})^2" if unit else "RSS", "status", "steps", "order"]
    if unit is None:
        columns.insert(2, "units")
    per_channel = any("channel" in r for r in records)
    if per_channel:
        columns[1:1] = ["channel", "region"]
    has_force = any(r.get("force_level", r.get("force_grade")) is not None for r in records)
    if not has_force:
        columns.pop(3 if per_channel else 1)
    return columns, unit, per_channel, has_force


def _row(r: dict[str, Any], model: str, unit: str | None, per_channel: bool,
         has_force: bool) -> list[str]:
    force = r.get("force_level", r.get("force_grade", ""))
    cells = [
        str(r["trial"]), "" if force is None else str(force),
        _pm(r["alpha"], r["alpha_se"], ".1f" if r["units"] == "events/bin" else ".4g"),
        _pm(r["tau_s"], r["tau_se"], ".4f"),
        _pm(r["duration_s"], r["duration_se"], ".3f") if model == "pulse" else "",
        "-" if r["pearson_r"] is None else f"{r['pearson_r']:.5f}",
        _pm(r["residual_std"], None, ".4g"), _pm(r["rss"], None, ".4g"),
        r["status"], str(r["n_steps"]), _verdict_cell(r),
    ]
    if unit is None:
        cells.insert(2, r["units"])
    if per_channel:
        cells[1:1] = [str(r["channel"]), str(r["region"])]
    if not has_force:
        cells.pop(3 if per_channel else 1)
    return cells


def region_blocks(name: str, region: RegionResult) -> list[str | TextTable]:
    """One region's table (long ones cut to the first and last 20 rows and every failure),
    its failures explained, its summary line and the curves it did not fit."""
    from .fit_files import EQUATIONS

    records, summary = region.records, region.summary
    columns, unit, per_channel, has_force = _layout(records)
    text = tuple(i for i, c in enumerate(columns) if c in ("units", "status", "order"))
    table = TextTable(columns, title=f"{name}: {region.model} ({EQUATIONS[region.model]})",
                      left=3 if per_channel else 1, text=text)
    shown = records
    if len(records) > MAX_ROWS:
        failed = [r for r in records if r["status"] != "converged"]
        keep = {id(r) for r in records[:20] + records[-20:] + failed}
        shown = [r for r in records if id(r) in keep]
    table.rows = [_row(r, region.model, unit, per_channel, has_force) for r in shown]
    if len(shown) < len(records):
        table.caption = (f"{len(records) - len(shown)} converged trials not shown; "
                         "the JSON and CSV outputs list all")
    blocks: list[str | TextTable] = [table]
    for status, n in summary["status_counts"].items():
        if status != "converged":
            message = next(r["status_message"] for r in records if r["status"] == status)
            blocks.append(f"  {status} ({n} trial(s)): {message}")
    median = summary["median_pearson_r"]
    verdicts = ", ".join(f"{k} {v}" for k, v in sorted(summary["verdict_counts"].items()))
    blocks.append(f"{name}: {summary['n_converged']} converged, {summary['n_failed']} failed; "
                  f"median R {'-' if median is None else f'{median:.5f}'}; order: {verdicts}"
                  + (f"; written to {region.group}" if region.group else ""))
    missed = region.no_step or []
    if missed:
        names = ", ".join(missed[:10]) + (f", ... ({len(missed)} in all)"
                                          if len(missed) > 10 else "")
        blocks.append(f"  no step found (not fitted) in {len(missed)} curve(s): {names}")
    why = region.not_fitted or {}
    blocks += [f"    {curve}: {reason}" for curve, reason in list(why.items())[:MAX_ROWS]]
    if len(why) > MAX_ROWS:
        blocks.append(f"    ... {len(why) - MAX_ROWS} more; the JSON output lists all")
    return blocks


def fit_blocks(result: FitFosResult, plot: object = None) -> list[str | TextTable]:
    """Every region's blocks, then the CSV and figures written (``plot``: the folder
    named in the last line)."""
    blocks: list[str | TextTable] = []
    for name, region in result.regions.items():
        blocks += region_blocks(name, region)
    if result.csv is not None:
        blocks.append(f"wrote {result.csv}")
    if result.figures:
        blocks.append(f"wrote {len(result.figures)} figure(s) to {plot}")
    return blocks


def batch_line(value: dict[str, Any]) -> str:
    """A batch file's line after ``ok`` (``value``: the file's ``as_dict()``): each
    region's converged count and median R."""
    parts = []
    for region, s in value["summary"].items():
        median = s["median_pearson_r"]
        parts.append(f"{region} {s['n_converged']}/{s['n_trials']} converged"
                     + ("" if median is None else f" (median R {median:.4f})"))
    return "; ".join(parts)


__all__ = ["MAX_ROWS", "batch_line", "fit_blocks", "region_blocks"]
