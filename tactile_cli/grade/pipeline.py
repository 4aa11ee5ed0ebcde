"""``tactile grade FILE...`` as one library verb: :func:`grade_files`.

Reads the grader inputs of every trial of the files (:func:`~.features.load_areas`),
optionally fits the input membership functions to the labelled trials and writes the new
config (:func:`calibrate_config`, provenance from :mod:`tactile_cli.store.provenance`),
grades every trial with the config (:func:`~.grading.grade_trials`) and draws the figures.
Every output (the calibrated config, the figure folder) is checked before any input is
read, and written through the store's atomic writers.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import InputError
from ..input_guard import check_outputs
from .calibrate import AreaCalibrator
from .config import GraderConfig, load_config, save_config
from .features import TrialArea, load_areas
from .grading import GradeReport, grade_trials, true_grade_index

LABEL_KEYS: tuple[str, ...] = ("force_grade", "force_level")
CALIBRATION_METHOD = ("tactile_cli.grade.calibrate.AreaCalibrator: per-grade quartiles, "
                      "boundary = midpoint of facing quartiles, trapezoid fuzzy partition")


@dataclass(frozen=True)
class Calibration:
    """What :func:`calibrate_config` wrote: the config file, each grade's quartiles and
    upper boundary (:meth:`AreaCalibrator.summary`) and the input range."""

    out: Path
    per_grade: list[dict[str, Any]]
    range: list[float]

    def as_dict(self) -> dict[str, Any]:
        return {"out": str(self.out), "per_grade": self.per_grade, "range": self.range}


@dataclass(frozen=True)
class GradeRun:
    """What :func:`grade_files` did: the ``report`` of every trial, the config used (the
    calibrated one with ``calibrate``) and where it lies, the calibration, the figures."""

    report: GradeReport
    config: GraderConfig
    config_path: Path
    calibration: Calibration | None = None
    plots: list[Path] = field(default_factory=list)

    def as_dict(self) -> dict[str, Any]:
        data = self.report.as_dict()
        data["config"] = str(self.config_path)
        data["plots"] = [str(p) for p in self.plots]
        if self.calibration is not None:
            data["calibration"] = self.calibration.as_dict()
        return data


def calibrate_config(config: GraderConfig, areas: Sequence[TrialArea], out: str | Path, *,
                     base_config: str | Path, label_key: str | None = None,
                     overlap: float = 0.5, overwrite: bool = False
                     ) -> tuple[GraderConfig, Calibration]:
    """Fit ``config``'s input terms to the labelled ``areas`` (:class:`AreaCalibrator`) and
    write the calibrated config to ``out`` with its provenance (the command, the inputs with
    their SHA-256, the settings and each grade's quartiles) and a header comment."""
    from .._version import __version__
    from ..store.provenance import provenance_record

    pairs = [(a.area, true_grade_index(a, config, label_key)[0]) for a in areas]
    pairs = [(x, g) for x, g in pairs if g is not None and x == x]
    if not pairs:
        raise InputError("`calibrate` needs labelled trials (force_grade or force_level) "
                         "with a press region; none found")
    x, g = zip(*pairs, strict=True)
    try:
        cal = AreaCalibrator(overlap=overlap).fit(list(x), list(g), len(config.grades))
    except ValueError as exc:
        raise InputError(f"cannot calibrate: {exc}") from None
    summary = cal.summary(config.grades)
    inputs = list(dict.fromkeys(Path(a.file) for a in areas))
    settings = {"method": CALIBRATION_METHOD, "overlap": overlap,
                "base_config": str(base_config),
                "label_key": label_key or "force_grade, else force_level"}
    provenance = {**provenance_record(inputs, settings), **settings, "n_trials": len(pairs),
                  "per_grade": summary}
    new = cal.to_config(config, provenance=provenance)
    header = (f"tactile grade config calibrated by `{provenance['command']}`\n"
              f"tactile {__version__}, {provenance['created_utc']}, from {len(pairs)} labelled "
              "trials; see the provenance key.")
    save_config(new, out, header=header, overwrite=overwrite)
    return new, Calibration(Path(out), summary, list(cal.range_))


def plot_grades(config: GraderConfig, report: GradeReport, folder: str | Path) -> list[Path]:
    """The membership functions, one inference (like Fig. 22: the trial where two rules
    fire most evenly) and area against level (Fig. 15, when correlated), added to
    ``folder`` when all are drawn."""
    from ..store.outdir import output_folder
    from .plots import plot_area_vs_level, plot_inference, plot_membership

    folder = Path(folder)
    with output_folder(folder, merge=True) as tmp:  # in place when every figure is
        paths = [plot_membership(config, tmp / "membership.png")]
        graded = [t for t in report.trials if t.area == t.area]
        if graded:
            def second(t: Any) -> float:
                return sorted(t.firing.values())[-2] if len(t.firing) > 1 else 0.0

            example = max(graded, key=second)
            paths.append(plot_inference(config, example.area, tmp / "inference.png",
                                        title=f"trial {example.trial}: area "
                                        f"{example.area:.6g}"))
        if report.summary.pearson_r is not None:
            paths.append(plot_area_vs_level(report, tmp / "area_vs_level.png"))
    return [folder / p.name for p in paths]


def grade_files(
    files: Sequence[str | Path],
    *,
    config: str | Path | None = None,
    label_key: str | None = None,
    plot: str | Path | None = None,
    calibrate: bool = False,
    out: str | Path | None = None,
    overlap: float = 0.5,
    overwrite: bool = False,
) -> GradeRun:
    """Grade the pressing force of every trial of ``files`` (tactile HDF5 files or CSV
    tables ``trial,area[,level]``) with the grader ``config`` (a YAML file; default the
    packaged marker-sensor config). ``label_key``: the truth label (``force_grade`` or
    ``force_level``; default the first a trial has). ``calibrate``: first fit the config's
    input terms to the labelled trials (``overlap``: the terms' transition width) and write
    the calibrated config to ``out`` (an existing file only with ``overwrite``), then grade
    with it. ``plot``: a folder for the figures (:func:`plot_grades`).

    Raises :class:`InputError` before any input is read for a bad argument or an output
    that is an input or cannot be written."""
    from ..store.atomic import check_output_file
    from ..store.outdir import check_output_folder
    from . import default_config_path

    if label_key not in (None, *LABEL_KEYS):
        raise InputError(f"`label_key` {label_key!r} must be force_grade or force_level")
    if calibrate and out is None:
        raise InputError("`calibrate` needs `out` (the new config's file)")
    if out is not None and not calibrate:
        raise InputError("`out` is the config written by `calibrate`; add `calibrate`")
    if not 0 < overlap <= 1:
        raise InputError(f"`overlap` (={overlap:g}) must be in (0, 1]")
    config_path = Path(config) if config is not None else default_config_path()
    check_outputs({"out": out, "plot": plot}, [*files, config_path])
    if out is not None:
        check_output_file(out, overwrite=overwrite)
    if plot is not None:  # figures are added to an existing folder; a file there is not
        check_output_folder(plot, merge=True)
    cfg = load_config(config_path)
    areas = load_areas([Path(f) for f in files], bin_s=cfg.feature.bin_s,
                       region=cfg.feature.region, kind=cfg.feature.kind)
    if not areas:
        raise InputError("no trials in the given files")
    calibration = None
    if calibrate:
        cfg, calibration = calibrate_config(cfg, areas, out, base_config=config_path,
                                            label_key=label_key, overlap=overlap,
                                            overwrite=overwrite)
        config_path = Path(out)
    report = grade_trials(areas, cfg, label_key=label_key)
    plots = [] if plot is None else plot_grades(cfg, report, plot)
    return GradeRun(report, cfg, config_path, calibration, plots)


__all__ = ["CALIBRATION_METHOD", "Calibration", "GradeRun", "calibrate_config", "grade_files",
           "plot_grades"]
