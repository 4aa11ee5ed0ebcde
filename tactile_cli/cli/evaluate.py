"""`tactile evaluate RUN --data FILE... [--split test|all] [--json]`"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from ..errors import InputError
from ._batch import BATCH_FLAGS, SchedulerOption, WorkersOption
from ._errors import COMMON_FLAGS, Flag, run_guarded, to_flags

if TYPE_CHECKING:
    from rich.console import Console
    from rich.table import Table

    from ..learn.evaluate import EvalResult
from .train import data_files

#: How this command spells the library arguments its errors name (see ``_errors.to_flags``).
FLAGS: dict[str, Flag] = {
    "data_paths": "--data FILE",
    "split": "--split",
    "threshold": "--threshold",
    "overwrite": "--overwrite",
    "name": "--name",
    "exported": "--exported FILE",
    "shift_threshold_sd": "--shift-threshold",
    **BATCH_FLAGS,
}


def evaluate_command(
    ctx: typer.Context,
    run: Annotated[Path, typer.Argument(help="Run folder written by `tactile train`.",
                                        show_default=False, metavar="RUN")],
    data: Annotated[
        list[Path] | None,
        typer.Option("--data", "-d", help="Tactile HDF5 file(s) to evaluate on; repeat the "
                     "option or list several files after it. A cross-validated run (train "
                     "--cv) needs none: each fold is scored on its held-out trials.",
                     show_default=False, metavar="FILE"),
    ] = None,
    split: Annotated[
        str, typer.Option(help="all: every trial; test: the trials the run's split rule puts "
                          "in test (on the training files, the training's test split).")
    ] = "all",
    name: Annotated[
        str | None,
        typer.Option(help="Name of the results folder RUN/eval/<name> (default from the data "
                     "file names).", show_default=False),
    ] = None,
    threads: Annotated[
        int, typer.Option(min=1, help="torch CPU threads for the latency measurement.")
    ] = 1,
    latency: Annotated[
        bool, typer.Option("--latency/--no-latency", help="Measure latency and throughput.")
    ] = True,
    overwrite: Annotated[
        bool, typer.Option(help="Replace an existing RUN/eval/<name> folder.")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print metrics.json to stdout.")] = False,
    each: Annotated[
        bool, typer.Option("--each", help="Evaluate on each --data file apart, into "
                           "RUN/eval/<file stem>, one task per file on Dask (--workers, "
                           "--scheduler); evaluations newer than their file and the model "
                           "are skipped; no latency (tasks side by side would time each "
                           "other).")
    ] = False,
    scheduler: SchedulerOption = None,
    workers: WorkersOption = None,
    perturb: Annotated[
        bool, typer.Option("--perturb", help="Also re-evaluate on perturbed copies of the data "
                           "(see `tactile perturb`); results in RUN/perturb/<name>/.")
    ] = False,
    perturb_kinds: Annotated[
        str, typer.Option("--perturb-kinds", help="Kinds for --perturb: noise, lowpass, drop, "
                          "drop_events, drop_samples, scale (comma-separated).")
    ] = "noise,lowpass,drop,scale",
    threshold: Annotated[
        str, typer.Option(help="--perturb breaking point: accuracy below a factor of the clean "
                          "accuracy (0.9x) or an accuracy (0.95 or 95%).")
    ] = "0.9x",
    exported: Annotated[
        Path | None,
        typer.Option("--exported", help="A file `tactile export` wrote from this run: its "
                     "outputs are checked against the run's on the same windows and its "
                     "batch-1 latency (onnxruntime or TorchScript) is measured beside torch's.",
                     metavar="FILE", show_default=False),
    ] = None,
    shift_threshold: Annotated[
        float, typer.Option("--shift-threshold", help="Flag a channel whose mean in the "
                            "evaluated data lies more than this many training standard "
                            "deviations from the training data's.", metavar="SD")
    ] = 1.0,
) -> None:
    """Evaluate a trained run: overall accuracy, per-class precision/recall/F1 and confusion
    matrix (PNG + JSON) per classification head, MAE/RMSE per regression head, latency per
    window at batch 1 and windows/s at batch 1024 on this machine, parameters and size.
    Files go to RUN/eval/<name>/."""

    def body() -> None:
        from rich.console import Console

        from ..learn.evaluate import evaluate
        from ..learn.runs import dumps, read_run_info

        files = data_files(data, ctx)
        cross_validated = read_run_info(run).get("cv") is not None
        if not files and not cross_validated:
            raise InputError("no data files; give --data FILE...")
        if perturb and cross_validated:
            raise InputError("--perturb needs one model: give a fold's folder "
                             "(RUN/folds/fold_00) instead of the cross-validated run")
        if split not in ("all", "test"):
            raise InputError(f"--split must be all or test, got {split!r}")
        if each:
            _evaluate_each(run, files)
            return
        if scheduler is not None or workers is not None:
            raise InputError("--scheduler and --workers go with --each (one task per file)")
        if perturb:
            from .perturb import parse_threshold

            parse_threshold(threshold)  # a bad value fails before any work
        result = evaluate(run, files, split=split, name=name,  # type: ignore[arg-type]
                          latency=latency, threads=threads, overwrite=overwrite,
                          exported=exported, shift_threshold_sd=shift_threshold)
        if as_json:
            payload = result.as_dict()
            if perturb:
                from .perturb import perturb_and_print

                perturbed = perturb_and_print([run], files, kinds=perturb_kinds,
                                              threshold=threshold, split=split, name=name,
                                              echo=False, notes=False)
                payload = {"evaluation": payload, "perturbation": perturbed[0].as_dict()}
            typer.echo(dumps(payload))
        else:
            console = Console(width=None if sys.stdout.isatty() else 120)
            print_metrics(console, result)
            console.print(cost_table(result))
            for line in drift_lines(result):
                console.print(line, highlight=False, soft_wrap=True)
            console.print(f"wrote {result.out_dir}")
            if perturb:
                from .perturb import perturb_and_print

                perturb_and_print([run], files, kinds=perturb_kinds, threshold=threshold,
                                  split=split, name=name, notes=False)
        for note in [*result.notes, *result.warnings, *drift_warnings(result)]:
            print(f"tactile: warning: {note}", file=sys.stderr)
        if result.overlaps_training and split == "all":
            print(f"tactile: warning: {', '.join(result.overlaps_training)} was used to train "
                  "this run; these metrics include training trials (use --split test)",
                  file=sys.stderr)

    def _evaluate_each(run: Path, files: list[Path]) -> None:
        from ..learn.evaluate_each import NO_LATENCY, evaluate_each
        from ._batch import FileBatchPrinter, finish_batch

        if not files:
            raise InputError("--each needs --data FILE...: the files to evaluate on apart")
        for flag, value in (("--name", name), ("--perturb", perturb or None),
                            ("--exported", exported)):
            if value is not None:
                raise InputError(f"{flag} goes with one evaluation; --each names each "
                                 "results folder after its data file")

        def describe(item: Any) -> str:
            parts = []
            for head, m in item.value["summary"]["heads"].items():
                parts.append(f"{head} MAE {m['mae']:.4g}" if "mae" in m
                             else f"{head} {_pct(m['accuracy'])}")
            return f"-> {item.output} ({', '.join(parts)})"

        printer = FileBatchPrinter("evaluate", describe=describe, todo="to evaluate",
                                   flags=lambda t: to_flags(t, {**COMMON_FLAGS, **FLAGS}))
        with printer.running():
            result = evaluate_each(run, files, split=split,  # type: ignore[arg-type]
                                   overwrite=overwrite, scheduler=scheduler, workers=workers,
                                   on_plan=printer.on_plan, on_progress=printer.on_progress,
                                   on_item=printer.on_item)
        if not as_json:
            print(f"tactile: note: {NO_LATENCY}", file=sys.stderr)
        finish_batch(result, as_json=as_json, payload={"note": NO_LATENCY})

    run_guarded(body, flags=FLAGS)


def cost_table(result: EvalResult) -> Table:
    """Parameters, size, batch-1 latency and throughput; with an exported model a row of
    its own (runtime, latency, largest output difference from the run's)."""
    from rich.table import Table

    exp = result.extra.get("exported")
    cost = Table(title="Cost on this machine")
    cols = ("parameters", "size (MB)", "batch-1 median (ms)", "batch-1 p95 (ms)", "windows/s",
            "threads")
    for col in (("runtime",) if exp else ()) + cols:
        cost.add_column(col, justify="left" if col == "runtime" else "right")
    lat = result.latency
    row = [f"{result.n_params:,}", f"{result.size_mb:.3f}",
           "" if lat is None else f"{lat.batch1_ms_median:.3f}",
           "" if lat is None else f"{lat.batch1_ms_p95:.3f}",
           "" if lat is None else f"{lat.windows_per_s:,.0f}",
           "" if lat is None else str(lat.threads)]
    if not exp:
        cost.add_row(*row)
        return cost
    cost.add_row("torch", *row)
    elat = exp.get("latency") or {}
    ratio = ""
    if lat is not None and elat.get("batch1_ms_median"):
        ratio = f"; batch-1 latency {elat['batch1_ms_median'] / lat.batch1_ms_median:.2f}x torch's"
    size = Path(exp["file"]).stat().st_size / 1e6 if Path(exp["file"]).exists() else None
    cost.add_row(f"{exp['runtime']}: {Path(exp['file']).name}", "",
                 "" if size is None else f"{size:.3f}",
                 f"{elat['batch1_ms_median']:.3f}" if elat else "",
                 f"{elat['batch1_ms_p95']:.3f}" if elat else "", "", str(exp["threads"]))
    cost.caption = (f"exported model: largest output difference from the run's "
                    f"{exp['max_abs_diff']:.2g} over {exp['n_windows']:,} windows{ratio}")
    return cost


def drift_lines(result: EvalResult) -> list[str]:
    """The input-shift and interleaving lines of an evaluation (:mod:`..learn.drift`)."""
    from ..learn.drift import ChannelShift, ShiftReport

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
            inside = inter["n_inside_class_span"] if inter.get("n_inside_class_span") \
                is not None else inter["n_inside_span"]
            where = f" of their {inter['class_label']}" if inter.get("class_label") else ""
            out.append(f"recording order (by {inter['order_by']}): {inside} of "
                       f"{inter['n_evaluated']} evaluated trial(s) inside the span of the "
                       f"training trials{where}"
                       + (" (interleaved)" if inter["interleaved"] else " (not interleaved)"))
    return out


def drift_warnings(result: EvalResult) -> list[str]:
    """The one-line warnings: interleaved trials, shifted channels."""
    from ..learn.drift import ChannelShift, Interleaving, ShiftReport

    out = []
    inter = result.extra.get("interleaving")
    if inter:
        message = Interleaving(**{k: v for k, v in inter.items() if k != "folds"}).message()
        if message:
            out.append(message)
    shift = result.extra.get("shift")
    if shift and shift.get("flagged"):
        report = ShiftReport(shift["threshold_sd"], shift["n_samples"],
                             [ChannelShift(**c) for c in shift["channels"]])
        out.append(report.summary() + "; the model sees levels it was not trained on "
                   "(remove per-trial baselines or use level-free features: data.baseline, "
                   "data.window_norm)")
    return out


def _pct(value: float | None) -> str:
    return "n/a" if value is None or math.isnan(value) else f"{100 * value:.2f} %"


def print_metrics(console: Console, result: EvalResult) -> None:
    """The per-head tables (support always shown, absent classes flagged), intervals,
    per-trial votes and, for a cross-validated run, the per-fold spread."""
    from rich.table import Table

    from ..learn.evaluate import ClassificationMetrics
    from ..learn.trial_metrics import fmt_interval

    what = "held-out trials of every fold" if result.cv else "trials"
    console.print(f"[bold]{result.run}[/] ({result.family}) on {result.n_trials} {what}, "
                  f"{result.n_windows:,} windows, split {result.split}")
    if result.origin:
        from ..store.origin import describe_origin

        console.print(f"data: {describe_origin(result.origin)}")
    for m in result.heads:
        if not isinstance(m, ClassificationMetrics):
            console.print(f"{m.head}: MAE {m.mae:.4g}, RMSE {m.rmse:.4g} ({m.n:,} windows)")
            continue
        console.print(f"[bold]{m.head}[/]: accuracy {_pct(m.accuracy)} per window (95 % CI "
                      f"{fmt_interval(m.accuracy_ci95)}, bootstrap over {m.n_trials} trials), "
                      f"macro F1 {_num(m.macro_f1)} (95 % CI "
                      f"{fmt_interval(m.macro_f1_ci95, 1.0, 3)})")
        table = Table()
        for col in ("class", "precision", "recall", "F1", "support"):
            table.add_column(col, justify="left" if col == "class" else "right")
        for c in m.per_class:
            if c.absent:
                table.add_row(c.name, f"{c.precision:.5f}", "-", "-", "0 (absent)")
            else:
                table.add_row(c.name, f"{c.precision:.5f}", f"{c.recall:.5f}", f"{c.f1:.5f}",
                              f"{c.support:,}")
        captions = []
        if m.accuracy_excluding_boundaries is not None:
            captions.append(f"without the {m.n_near_boundary:,} windows within "
                            f"{m.boundary_margin} sample(s) of a label change: "
                            f"{_pct(m.accuracy_excluding_boundaries)}")
        if any(c.absent for c in m.per_class):
            captions.append("absent classes are left out of the macro F1")
        table.caption = "; ".join(captions) or None
        console.print(table)
        for other, groups in (m.accuracy_by or {}).items():
            parts = [f"{name} {_pct(g['accuracy'])} ({g['n']:,})" for name, g in groups.items()
                     if g["n"]]
            console.print(f"{m.head} accuracy by true {other}: " + ", ".join(parts))
        if m.per_trial:
            v = m.per_trial
            console.print(f"{m.head} per trial ({v['n_trials']} trials): majority vote "
                          f"{_pct(v['majority_accuracy'])} (95 % CI "
                          f"{fmt_interval(v['majority_accuracy_ci95'])}), mean probability "
                          f"{_pct(v['mean_probability_accuracy'])} (95 % CI "
                          f"{fmt_interval(v['mean_probability_accuracy_ci95'])})")
    if result.cv:
        cv = result.cv
        from ..learn.splits import fold_text

        line = (fold_text(cv.get("k"), cv["n_folds"], cv["mode"], cv.get("by"))
                + ": accuracy per fold "
                f"{_pct(cv.get('accuracy_mean'))} +- {_pct(cv.get('accuracy_std'))}, macro F1 "
                f"{_num(cv.get('macro_f1_mean'))} +- {_num(cv.get('macro_f1_std'))}")
        if cv.get("per_trial_accuracy_mean") is not None:
            line += (f", per-trial accuracy {_pct(cv['per_trial_accuracy_mean'])} +- "
                     f"{_pct(cv.get('per_trial_accuracy_std'))}")
        console.print(line + " (mean +- sample std over folds)")


def _num(value: float | None) -> str:
    return "n/a" if value is None or math.isnan(value) else f"{value:.4f}"
