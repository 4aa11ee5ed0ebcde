"""Results as text for people: the tables and lines `tactile evaluate`, `compare` and
`perturb` print.

Each function turns a result dataclass into lines and :class:`TextTable` objects whose
cells are already formatted (percentages, units, ``n/a``), so any front end shows the same
thing: the CLI renders them with rich (``cli/_output.print_blocks``), a notebook with
pandas (``pd.DataFrame(t.rows, columns=t.columns)``). Nothing here computes a metric.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..text_table import TextTable, num, pct

if TYPE_CHECKING:
    from .compare import Comparison
    from .metrics import ClassificationMetrics, EvalResult
    from .perturb import PerturbResult


# -- tactile evaluate ---------------------------------------------------------------------------
def _class_table(m: ClassificationMetrics) -> TextTable:
    table = TextTable(["class", "precision", "recall", "F1", "support"])
    for c in m.per_class:
        if c.absent:
            table.rows.append([c.name, f"{c.precision:.5f}", "-", "-", "0 (absent)"])
        else:
            table.rows.append([c.name, f"{c.precision:.5f}", f"{c.recall:.5f}", f"{c.f1:.5f}",
                               f"{c.support:,}"])
    captions = []
    if m.accuracy_excluding_boundaries is not None:
        captions.append(f"without the {m.n_near_boundary:,} windows within "
                        f"{m.boundary_margin} sample(s) of a label change: "
                        f"{pct(m.accuracy_excluding_boundaries)}")
    if any(c.absent for c in m.per_class):
        captions.append("absent classes are left out of the macro F1")
    table.caption = "; ".join(captions) or None
    return table


def _classification_blocks(m: ClassificationMetrics) -> list[str | TextTable]:
    from .trial_metrics import fmt_interval

    blocks: list[str | TextTable] = [
        f"{m.head}: accuracy {pct(m.accuracy)} per window (95 % CI "
        f"{fmt_interval(m.accuracy_ci95)}, bootstrap over {m.n_trials} trials), macro F1 "
        f"{num(m.macro_f1)} (95 % CI {fmt_interval(m.macro_f1_ci95, 1.0, 3)})",
        _class_table(m)]
    for other, groups in (m.accuracy_by or {}).items():
        parts = [f"{name} {pct(g['accuracy'])} ({g['n']:,})" for name, g in groups.items()
                 if g["n"]]
        blocks.append(f"{m.head} accuracy by true {other}: " + ", ".join(parts))
    if m.per_trial:
        v = m.per_trial
        blocks.append(f"{m.head} per trial ({v['n_trials']} trials): majority vote "
                      f"{pct(v['majority_accuracy'])} (95 % CI "
                      f"{fmt_interval(v['majority_accuracy_ci95'])}), mean probability "
                      f"{pct(v['mean_probability_accuracy'])} (95 % CI "
                      f"{fmt_interval(v['mean_probability_accuracy_ci95'])})")
    if m.per_group:
        g = m.per_group
        blocks.append(f"{m.head} per {g['by']} ({g['n_trials']} groups of trials, decided "
                      f"together): majority vote {pct(g['majority_accuracy'])} (95 % CI "
                      f"{fmt_interval(g['majority_accuracy_ci95'])}), mean probability "
                      f"{pct(g['mean_probability_accuracy'])} (95 % CI "
                      f"{fmt_interval(g['mean_probability_accuracy_ci95'])})")
    return blocks


def _cv_line(cv: dict) -> str:
    from .splits import fold_text

    line = (fold_text(cv.get("k"), cv["n_folds"], cv["mode"], cv.get("by"))
            + ": accuracy per fold "
            f"{pct(cv.get('accuracy_mean'))} +- {pct(cv.get('accuracy_std'))}, macro F1 "
            f"{num(cv.get('macro_f1_mean'))} +- {num(cv.get('macro_f1_std'))}")
    if cv.get("per_trial_accuracy_mean") is not None:
        line += (f", per-trial accuracy {pct(cv['per_trial_accuracy_mean'])} +- "
                 f"{pct(cv.get('per_trial_accuracy_std'))}")
    return line + " (mean +- sample std over folds)"


def evaluation_blocks(result: EvalResult) -> list[str | TextTable]:
    """What ``tactile evaluate`` prints: the per-head tables (support always shown, absent
    classes flagged), intervals, per-trial votes, for a cross-validated run the per-fold
    spread, the cost table and the results folder."""
    from .metrics import ClassificationMetrics

    what = "held-out trials of every fold" if result.cv else "trials"
    blocks: list[str | TextTable] = [
        f"{result.run} ({result.family}) on {result.n_trials} {what}, "
        f"{result.n_windows:,} windows, split {result.split}"]
    if result.origin:
        from ..store.origin import describe_origin

        blocks.append(f"data: {describe_origin(result.origin)}")
    for m in result.heads:
        if isinstance(m, ClassificationMetrics):
            blocks += _classification_blocks(m)
        else:
            blocks.append(f"{m.head}: MAE {m.mae:.4g}, RMSE {m.rmse:.4g} ({m.n:,} windows)")
    if result.cv:
        blocks.append(_cv_line(result.cv))
    return [*blocks, cost_table(result), *drift_lines(result), f"wrote {result.out_dir}"]


def drift_lines(result: EvalResult) -> list[str]:
    """The input-shift and interleaving lines of an evaluation (:mod:`.drift`)."""
    from .drift import ChannelShift, ShiftReport

    out = []
    shift = result.extra.get("shift")
    if shift:
        report = ShiftReport(shift["threshold_sd"], shift["n_samples"],
                             [ChannelShift(**c) for c in shift["channels"]])
        what = "worst fold per channel" if shift.get("folds") else "evaluated data"
        out.append(f"input shift ({what}): largest |shift| {shift['max_abs_shift_sd']:.2f} "
                   f"training SD; {report.summary()}")
    inter = result.extra.get("interleaving")
    if inter:
        if inter.get("interleaved") is None:
            out.append(f"recording order: unknown ({inter.get('reason')})")
        else:
            inside = (inter["n_inside_class_span"] if inter.get("n_inside_class_span")
                      is not None else inter["n_inside_span"])
            where = f" of their {inter['class_label']}" if inter.get("class_label") else ""
            out.append(f"recording order (by {inter['order_by']}): {inside} of "
                       f"{inter['n_evaluated']} evaluated trial(s) inside the span of the "
                       f"training trials{where}"
                       + (" (interleaved)" if inter["interleaved"] else " (not interleaved)"))
    return out


def drift_warnings(result: EvalResult) -> list[str]:
    """The one-line warnings of an evaluation: interleaved trials, shifted channels."""
    return drift_messages(result.extra)


def drift_messages(record: Mapping[str, Any]) -> list[str]:
    """:func:`drift_warnings` of a metrics.json record (its ``interleaving`` and ``shift``)."""
    from .drift import ChannelShift, Interleaving, ShiftReport

    out = []
    inter = record.get("interleaving")
    if inter:
        message = Interleaving(**{k: v for k, v in inter.items() if k != "folds"}).message()
        if message:
            out.append(message)
    shift = record.get("shift")
    if shift and shift.get("flagged"):
        report = ShiftReport(shift["threshold_sd"], shift["n_samples"],
                             [ChannelShift(**c) for c in shift["channels"]])
        out.append(report.summary() + "; the model sees levels it was not trained on "
                   "(remove per-trial baselines or use level-free features: data.baseline, "
                   "data.window_norm)")
    return out


def cost_table(result: EvalResult) -> TextTable:
    """Parameters, size, batch-1 latency and throughput; with an exported model a row of
    its own (runtime, latency, largest output difference from the run's)."""
    exp = result.extra.get("exported")
    cols = ["parameters", "size (MB)", "batch-1 median (ms)", "batch-1 p95 (ms)", "windows/s",
            "threads"]
    lat = result.latency
    row = [f"{result.n_params:,}", f"{result.size_mb:.3f}",
           "" if lat is None else f"{lat.batch1_ms_median:.3f}",
           "" if lat is None else f"{lat.batch1_ms_p95:.3f}",
           "" if lat is None else f"{lat.windows_per_s:,.0f}",
           "" if lat is None else str(lat.threads)]
    if not exp:
        return TextTable(cols, [row], title="Cost on this machine", left=0)
    elat = exp.get("latency") or {}
    ratio = ""
    if lat is not None and elat.get("batch1_ms_median"):
        ratio = f"; batch-1 latency {elat['batch1_ms_median'] / lat.batch1_ms_median:.2f}x torch's"
    file = Path(exp["file"])
    size = file.stat().st_size / 1e6 if file.exists() else None
    exported_row = [f"{exp['runtime']}: {file.name}", "", "" if size is None else f"{size:.3f}",
                    f"{elat['batch1_ms_median']:.3f}" if elat else "",
                    f"{elat['batch1_ms_p95']:.3f}" if elat else "", "", str(exp["threads"])]
    return TextTable(["runtime", *cols], [["torch", *row], exported_row],
                     title="Cost on this machine",
                     caption=f"exported model: largest output difference from the run's "
                             f"{exp['max_abs_diff']:.2g} over {exp['n_windows']:,} "
                             f"windows{ratio}")


# -- tactile compare ----------------------------------------------------------------------------
def comparison_table(cmp: Comparison) -> TextTable:
    """The comparison table; each run named by the part of its folder that tells it apart
    from the others (:func:`~tactile_cli.learn.compare.distinct_run_paths`)."""
    from .compare import distinct_run_paths, table_rows

    rows = table_rows(cmp)
    exported = any(row["exported_latency_ms"] is not None for row in rows)
    seeded = any(row["n_seeds"] is not None for row in rows)
    table = TextTable(["run", "family", f"{cmp.metric_label} (%)",
                       *(("seeds", "seed SD (pp)") if seeded else ()), "vs best (pp)",
                       "batch-1 ms",
                       "p95 ms", *(("exported ms",) if exported else ()), "windows/s",
                       "parameters", "MB", "Pareto", "in margin", ""],
                      title=f"{cmp.metric_label} against cost on {cmp.data_name}", left=2,
                      fold=(0,))

    def ms(value: float | None) -> str:
        return "" if value is None else f"{value:.3f}"

    for row, name in zip(rows, distinct_run_paths([row["run"] for row in rows]), strict=True):
        verdict = "needed" if row["needed"] else ("fastest" if row["fastest"] else "")
        if row["meets_targets"] is not None:
            verdict += " (meets targets)" if row["meets_targets"] else " (misses a target)"
        table.rows.append([
            name, row["family"], f"{row['score_pct']:.2f}",
            *(("" if row["n_seeds"] is None else str(row["n_seeds"]),
               "" if row["seed_sd_pp"] is None else f"{row['seed_sd_pp']:.2f}")
              if seeded else ()),
            f"{row['delta_pp']:+.2f}",
            ms(row["latency_ms_median"]), ms(row["latency_ms_p95"]),
            *((ms(row["exported_latency_ms"]),) if exported else ()),
            "" if row["windows_per_s"] is None else f"{row['windows_per_s']:,.0f}",
            f"{row['n_params']:,}", f"{row['size_mb']:.4f}", "*" if row["pareto"] else "",
            "*" if row["within_margin"] else "", verdict])
    return table


# -- tactile perturb ----------------------------------------------------------------------------
def perturbation_table(result: PerturbResult) -> TextTable:
    """Accuracy by level and the breaking points of every kind of one run."""
    from .perturb import level_text

    r = result
    table = TextTable(["kind", "accuracy (%) by level", "direction", "breaking point",
                       "last level above"],
                      title=f"{r.label} on {r.name}: clean accuracy "
                            f"{100 * r.clean_accuracy:.2f} %, threshold "
                            f"{100 * r.threshold:.2f} % ({r.threshold_rule})", left=5)
    for k in r.kinds:
        accs = ", ".join(f"{level_text(k, lv.level)}: {100 * lv.accuracy:.1f}"
                         for lv in k.levels)
        for i, b in enumerate(k.breaking):
            table.rows.append([k.kind if i == 0 else "", accs if i == 0 else "", b.direction,
                               level_text(k, b.level) or "none", level_text(k, b.last_ok)])
    return table


def perturbation_blocks(results: Sequence[PerturbResult]) -> list[str | TextTable]:
    """Every run's table and the folder its results went to."""
    blocks: list[str | TextTable] = []
    for r in results:
        blocks += [perturbation_table(r), f"wrote {r.out_dir}"]
    return blocks


__all__ = ["TextTable", "comparison_table", "cost_table", "drift_lines", "drift_messages",
           "drift_warnings", "evaluation_blocks", "num", "pct", "perturbation_blocks",
           "perturbation_table"]
