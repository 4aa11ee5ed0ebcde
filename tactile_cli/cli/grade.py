"""`tactile grade FILE... [--config C] [--json] [--plot DIR] [--calibrate --out NEW.yaml]`"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.table import Table

from ..errors import InputError
from ..grade import (
    AreaCalibrator,
    GradeReport,
    default_config_path,
    grade_trials,
    load_areas,
    load_config,
    save_config,
    true_grade_index,
)
from ._errors import Flag, run_guarded

#: How this command spells the library arguments its errors name (see ``_errors.to_flags``).
FLAGS: dict[str, Flag] = {
    "label_key": "--label-key",
}


def _fmt(v: float | None, spec: str = ".4f") -> str:
    return "" if v is None or v != v else format(v, spec)


def grade_command(
    files: Annotated[list[Path], typer.Argument(
        help="Tactile HDF5 files (events or an event-count stream with a `net` channel) or "
             "CSV tables trial,area[,level].", metavar="FILE", show_default=False)],
    config: Annotated[Path | None, typer.Option(
        "--config", "-c", help="Grader YAML config (default: the marker-sensor config "
        "shipped with tactile, configs/grade_marker.yaml).", metavar="FILE",
        show_default=False)] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the result as JSON.")] = False,
    plot: Annotated[Path | None, typer.Option(
        "--plot", help="Write membership, inference and area-vs-level PNGs to this folder.",
        metavar="FOLDER", show_default=False)] = None,
    calibrate: Annotated[bool, typer.Option(
        "--calibrate", help="Fit the input membership functions to the labelled trials and "
        "write a new config to --out.")] = False,
    out: Annotated[Path | None, typer.Option(
        "--out", "-o", help="Output config of --calibrate.", metavar="FILE",
        show_default=False)] = None,
    overwrite: Annotated[bool, typer.Option(help="Replace an existing --out file.")] = False,
    label_key: Annotated[str | None, typer.Option(
        "--label-key", help="Trial label holding the truth: force_grade or force_level "
        "(default: force_grade when present, else force_level).", show_default=False)] = None,
    overlap: Annotated[float, typer.Option(
        min=0.01, max=1.0, help="--calibrate: transition width of neighbouring terms as a "
        "fraction of the room around each boundary.")] = 0.5,
) -> None:
    """Grade the pressing force of every trial with a Mamdani fuzzy classifier (paper 000,
    sec. 5.3, Table III) over the area of net pressing events in the press region.

    Prints per trial the crisp output, the grade, the firing strength of every rule and the
    true grade when the trial is labelled, then the fraction graded right, off by one grade
    and worse, and the Pearson r of the area with the force level (Fig. 15).
    """

    def body() -> None:
        if label_key not in (None, "force_grade", "force_level"):
            raise InputError(f"--label-key {label_key!r} must be force_grade or force_level")
        if calibrate and out is None:
            raise InputError("--calibrate needs --out NEW_CONFIG.yaml")
        if out is not None and not calibrate:
            raise InputError("--out is the config written by --calibrate; add --calibrate")
        if out is not None and out.is_dir():
            raise InputError("is a folder; give a file name for --out", path=out)
        if out is not None and out.exists() and not overwrite:
            raise InputError("exists; pass --overwrite to replace it", path=out)
        if plot is not None:  # figures are added to an existing folder; a file there is not
            from ..store.outdir import check_output_folder

            check_output_folder(plot, merge=True)
        config_path = config or default_config_path()
        cfg = load_config(config_path)
        areas = load_areas(files, bin_s=cfg.feature.bin_s, region=cfg.feature.region,
                           kind=cfg.feature.kind)
        if not areas:
            raise InputError("no trials in the given files")
        calib = None
        if calibrate:
            cfg, calib = _calibrate(cfg, config_path, areas, label_key, overlap, out)
        report = grade_trials(areas, cfg, label_key=label_key)
        plots = _plots(cfg, report, plot) if plot is not None else []
        if as_json:
            data = report.as_dict()
            data["config"] = str(out if calibrate else config_path)
            data["plots"] = [str(p) for p in plots]
            if calib is not None:
                data["calibration"] = calib
            typer.echo(json.dumps(data, indent=2))
            return
        _print(report, cfg, config_path if not calibrate else out, calib, plots,
               multi_file=len({str(f) for f in files}) > 1)

    run_guarded(body, flags=FLAGS)


def _calibrate(cfg, config_path, areas, label_key, overlap, out):
    from .._version import __version__
    from ..store.provenance import current_command, sha256_of, utc_now

    pairs = [(a.area, true_grade_index(a, cfg, label_key)[0]) for a in areas]
    pairs = [(x, g) for x, g in pairs if g is not None and x == x]
    if not pairs:
        raise InputError("--calibrate needs labelled trials (force_grade or force_level) "
                         "with a press region; none found")
    x, g = zip(*pairs, strict=True)
    try:
        cal = AreaCalibrator(overlap=overlap).fit(list(x), list(g), len(cfg.grades))
    except ValueError as exc:
        raise InputError(f"cannot calibrate: {exc}") from None
    summary = cal.summary(cfg.grades)
    provenance = {
        "command": current_command(),
        "tool_version": __version__,
        "created_utc": utc_now(),
        "method": "tactile_cli.grade.calibrate.AreaCalibrator: per-grade quartiles, boundary "
                  "= midpoint of facing quartiles, trapezoid fuzzy partition",
        "overlap": overlap,
        "base_config": str(config_path),
        "label_key": label_key or "force_grade, else force_level",
        "n_trials": len(pairs),
        "inputs": [{"path": str(p), "sha256": sha256_of(p)}
                   for p in dict.fromkeys(Path(a.file) for a in areas)],
        "per_grade": summary,
    }
    new = cal.to_config(cfg, provenance=provenance)
    header = (f"tactile grade config calibrated by `{provenance['command']}`\n"
              f"tactile {__version__}, {provenance['created_utc']}, from {len(pairs)} labelled "
              "trials; see the provenance key.")
    save_config(new, out, header=header)
    return new, {"out": str(out), "per_grade": summary, "range": list(cal.range_)}


def _plots(cfg, report: GradeReport, folder: Path) -> list[Path]:
    from ..grade.plots import plot_area_vs_level, plot_inference, plot_membership
    from ..store.outdir import output_folder

    with output_folder(folder, merge=True) as tmp:  # in place when every figure is
        paths = [plot_membership(cfg, tmp / "membership.png")]
        graded = [t for t in report.trials if t.area == t.area]
        if graded:
            # like Fig. 22: the trial where two rules fire most evenly
            def second(t) -> float:
                return sorted(t.firing.values())[-2] if len(t.firing) > 1 else 0.0

            example = max(graded, key=second)
            paths.append(plot_inference(cfg, example.area, tmp / "inference.png",
                                        title=f"trial {example.trial}: area "
                                        f"{example.area:.6g}"))
        if report.summary.pearson_r is not None:
            paths.append(plot_area_vs_level(report, tmp / "area_vs_level.png"))
    return [folder / p.name for p in paths]


def _print(report: GradeReport, cfg, config_path, calib, plots, *, multi_file: bool) -> None:
    console = Console(width=None if sys.stdout.isatty() else 160)
    if calib is not None:
        t = Table(title=f"Calibration (written to {calib['out']})")
        for col in ("grade", "n", "Q25", "median", "Q75", "upper boundary"):
            t.add_column(col)
        for row in calib["per_grade"]:
            t.add_row(row["grade"], str(row["n"]), f"{row['q25']:.6g}", f"{row['median']:.6g}",
                      f"{row['q75']:.6g}", _fmt(row["upper_boundary"], ".6g"))
        console.print(t)
    table = Table(title=f"Force grades ({config_path}, {report.method} centroid)")
    cols = (["file"] if multi_file else []) + [
        "trial", cfg.input.name, "crisp", "grade", "true", "rules fired (strength)"]
    for col in cols:
        table.add_column(col)
    for t in report.trials:
        fired = ", ".join(f"{k}={v:.2f}" for k, v in t.firing.items() if v > 0)
        if t.status != "ok":
            fired = t.status
        true = t.true_grade or ""
        if t.true_level is not None:
            true += f" (level {t.true_level})"
        grade = t.grade or "-"
        if t.error not in (None, 0):
            grade = f"[red]{grade}[/]"
        row = ([Path(t.file).name] if multi_file else []) + [
            t.trial, _fmt(t.area, ".6g"), _fmt(t.crisp), grade, true, fired]
        table.add_row(*row)
    console.print(table)
    s = report.summary
    if s.n_labelled:
        console.print(
            f"{s.n_labelled} labelled trials: {100 * s.accuracy:.1f} % graded right, "
            f"{100 * s.off_by_one:.1f} % off by one grade, {100 * s.worse:.1f} % worse")
    if s.pearson_r is not None:
        console.print(f"Pearson r of {cfg.input.name} with {s.correlation_with.replace('_', ' ')}: "
                      f"{s.pearson_r:.4f} ({s.n_correlation} trials)")
    if s.n_graded < s.n_trials:
        console.print(f"{s.n_trials - s.n_graded} trial(s) not graded (see the rules column)")
    for p in plots:
        console.print(f"wrote {p}")
