"""File-level verbs of the spatial chain, outputs checked before any work: the event frames
of ``tactile frames`` (:func:`write_frames`) and the slip rates of ``tactile slip-rate``
with their figures (:func:`slip_rate_report`). The ROI centroid stream of ``tactile
centroids`` is :func:`~tactile_cli.spatial.stream.write_centroid_file`.

Each verb takes paths (a tactile file; the ROI config as a YAML file or a scene's
``scene.json``, or an already loaded :class:`~tactile_cli.spatial.config.SpatialConfig`),
refuses an output that is, holds or lies inside an input, builds its output folder aside
(``store.outdir.output_folder``) and returns a dataclass whose ``as_dict`` is the JSON it
also records beside the pictures, with the provenance of every input.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import InputError
from ..input_guard import check_outputs
from .config import SpatialConfig, load_config
from .slip_rate import SlipRateEstimate

#: Frames one trial may have (window count over [start, end)); each is a PNG of the sensor
#: (640 x 480 px: measured 4-8 kB and ~35 ms of one core to read, draw and write, 20 ms
#: windows of the fuzz corpus's event file), so 10,000 take about 6 minutes.
MAX_FRAMES = 10_000
#: Frame PNGs per second and bytes per sensor pixel of one, for the estimate in the refusal.
_FRAMES_PER_S = 30
_PNG_BYTES_PER_PX = 0.03


def config_source(rois: SpatialConfig | str | Path | None) -> tuple[SpatialConfig | None,
                                                                     list[Path]]:
    """``(config, [its file])`` from a path (loaded) or a config (its ``source`` file, if
    any, so that its hash is recorded); ``(None, [])`` for None."""
    if rois is None:
        return None, []
    if isinstance(rois, SpatialConfig):
        source = Path(rois.source) if rois.source and Path(rois.source).is_file() else None
        return rois, [] if source is None else [source]
    return load_config(rois), [Path(rois)]


def _inputs(path: Path, rois: SpatialConfig | str | Path | None) -> list[Path]:
    files = [path]
    if rois is not None and not isinstance(rois, SpatialConfig):
        files.append(Path(rois))
    return files


@dataclass(frozen=True)
class FramesResult:
    """What :func:`write_frames` wrote: ``record`` (the provenance, options and one
    summary per trial, as in ``frames.json``) and the output folder."""

    out: Path
    record: dict[str, Any]

    @property
    def trials(self) -> list[dict[str, Any]]:
        return self.record["outputs"]

    def as_dict(self) -> dict[str, Any]:
        return self.record


def _check_frame_options(window_s: float, median: int, kind: str, start_s: float,
                         end_s: float | None) -> None:
    from .render import KINDS

    if not window_s > 0:  # NaN fails too
        raise InputError(f"`window_s` (={window_s:g}) must be > 0")
    if window_s * 1e6 < 1:
        raise InputError(f"`window_s` (={window_s:g}) must be at least 1 us")
    if median < 1 or median % 2 == 0:
        raise InputError(f"`median` (={median}) must be an odd whole number of px >= 1 "
                         "(1 = no filter)")
    if kind not in KINDS:
        raise InputError(f"`kind` (={kind!r}) must be one of {', '.join(KINDS)}")
    if start_s < 0:
        raise InputError(f"`start_s` (={start_s:g}) must be >= 0 (trial seconds)")
    if end_s is not None and end_s <= start_s:
        raise InputError(f"`end_s` (={end_s:g}) must be later than `start_s` (={start_s:g})")


def _check_frame_count(trial: Any, te: Any, *, window_s: float, median: int, start_s: float,
                       end_s: float | None, frame_pngs: bool, path: Path) -> None:
    """Refuse a trial that would give more than :data:`MAX_FRAMES` frames (with the disk
    and time they would take) or a median filter larger than the sensor."""
    width, height = te.sensor.width_px, te.sensor.height_px
    if median > min(width, height):
        raise InputError(f"`median` (={median}) is larger than the {width}x{height} px "
                         "sensor; give a filter of a few px", path=path, where=trial.where)
    stop_s = te.end_s if end_s is None else end_s
    n = max(0, -(-round((stop_s - start_s) * 1e6) // round(window_s * 1e6)))
    if n == 0:
        raise InputError(f"no frames: the window [{start_s:g}, {stop_s:g}) s is empty (the "
                         f"trial ends at {te.end_s:g} s)", path=path, where=trial.where)
    if n > MAX_FRAMES:
        from ..config_file import format_bytes

        size = f", about {format_bytes(n * width * height * _PNG_BYTES_PER_PX)} of PNGs" \
            if frame_pngs else ""
        raise InputError(f"`window_s` (={window_s:g}) over [{start_s:g}, {stop_s:g}) s gives "
                         f"{n:,} frames, more than {MAX_FRAMES:,} per trial{size} and "
                         f"{n / _FRAMES_PER_S / 60:.0f} min of drawing; give a longer "
                         "`window_s` or a shorter [`start_s`, `end_s`)", path=path,
                         where=trial.where)


def write_frames(
    path: str | Path,
    out: str | Path,
    *,
    trials: Sequence[str] | None = None,
    window_s: float = 0.05,
    median: int = 1,
    kind: str = "polarity",
    rois: SpatialConfig | str | Path | None = None,
    start_s: float = 0.0,
    end_s: float | None = None,
    sheet_max: int = 24,
    frame_pngs: bool = True,
    overwrite: bool = False,
) -> FramesResult:
    """The event frames of every event trial of ``path`` (or of ``trials``) as
    ``out/<trial>/frame_NNNN.png`` (unless ``frame_pngs`` is False) and
    ``out/<trial>/contact_sheet.png`` (ROIs of ``rois`` drawn), and ``out/frames.json``
    (see :func:`~tactile_cli.spatial.render.write_trial_frames` for the options).

    Trial folders are added to an existing ``out``; one holding PNGs of an earlier run is
    replaced only with ``overwrite``, and only when every trial is drawn. Raises
    :class:`InputError` before any frame is drawn for a bad option, an output that is or
    holds an input, a trial that would give more than :data:`MAX_FRAMES` frames, or ROIs
    off the sensor."""
    from ..store.atomic import write_json
    from ..store.outdir import check_output_folder, output_folder
    from ..store.provenance import png_meta, provenance_record
    from ..store.trials import TactileFile
    from .render import write_trial_frames
    from .trial_events import event_trial_names, spatial_events

    path, out = Path(path), Path(out)
    _check_frame_options(window_s, median, kind, start_s, end_s)
    if not path.is_file():
        raise InputError("file not found", path=path)
    check_outputs({"out": out}, _inputs(path, rois))
    config, config_files = config_source(rois)
    check_output_folder(out, merge=True)  # trial subfolders are added; a file there is not
    with TactileFile(path) as tf:
        names = list(trials) if trials else event_trial_names(tf)
        if not names:
            raise InputError("no trial with events", path=path)
        chosen = []
        for name in names:  # every input checked before the first PNG is written
            chosen.append(tf.trial(name))
            te = spatial_events(chosen[-1])
            if config is not None:
                config.check_sensor(te.sensor.width_px, te.sensor.height_px)
            _check_frame_count(chosen[-1], te, window_s=window_s, median=median,
                               start_s=start_s, end_s=end_s, frame_pngs=frame_pngs, path=path)
            target = out / name
            if target.exists() and not target.is_dir():
                raise InputError("is a file; give another `out` folder or move the file",
                                 path=target)
            if target.exists() and any(target.glob("*.png")) and not overwrite:
                raise InputError("holds PNGs of an earlier run; pass `overwrite=True` to "
                                 "replace them", path=target)
        options = {"window_ms": window_s * 1e3, "median": median, "kind": kind,
                   "start_s": start_s, "end_s": end_s, "sheet_max": sheet_max,
                   "sheet_only": not frame_pngs, "trials": names,
                   "rois": None if config is None else config.as_dict()}
        record = provenance_record([path, *config_files], options)
        meta = png_meta(record)
        written = []
        # built in a hidden folder beside `out`; each trial folder (replacing an earlier
        # one) and frames.json are renamed into `out` only when every trial is drawn
        with output_folder(out, merge=True) as tmp:
            for name, tr in zip(names, chosen, strict=True):
                summary = write_trial_frames(
                    tr, tmp / name, window_s=window_s, median=median, kind=kind,
                    rois=() if config is None else config.rois, start_s=start_s,
                    end_s=end_s, sheet_max=sheet_max, frame_pngs=frame_pngs, meta=meta)
                summary["folder"] = str(out / name)
                written.append(summary)
            record["outputs"] = written
            write_json(tmp / "frames.json", record)
    return FramesResult(out, record)


@dataclass(frozen=True)
class SlipRateReport:
    """The slip rates of one file: ``estimates`` (per trial, with the curves behind each),
    ``record`` (provenance, config, one result per trial and the summary: what
    ``slip_rate.json`` holds and ``--json`` prints) and the figures written."""

    estimates: list[SlipRateEstimate]
    record: dict[str, Any]
    plot: Path | None = None
    figures: list[Path] = field(default_factory=list)

    @property
    def results(self) -> list[dict[str, Any]]:
        return self.record["trials"]

    @property
    def summary(self) -> dict[str, Any]:
        return self.record["summary"]

    def as_dict(self) -> dict[str, Any]:
        return self.record


def _summary(results: list[dict[str, Any]]) -> dict[str, Any]:
    errors = [abs(r["speed_rel_error"]) for r in results if r["speed_rel_error"] is not None]
    return {
        "n_trials": len(results),
        "n_ok": sum(r["status"] == "ok" for r in results),
        "n_with_truth": len(errors),
        "mean_abs_rel_error": float(sum(errors) / len(errors)) if errors else None,
        "max_abs_rel_error": float(max(errors)) if errors else None,
    }


def slip_rate_report(
    path: str | Path,
    rois: SpatialConfig | str | Path | None = None,
    *,
    trials: Sequence[str] | None = None,
    plot: str | Path | None = None,
) -> SlipRateReport:
    """:func:`~tactile_cli.spatial.slip_rate.estimate_slip_rates` of ``path`` with the ROIs
    and optics of ``rois`` (a config file, a scene.json or a config; None: ROIs proposed
    per trial, optics from the sensor), summarised against the trials' true speeds, and
    (with ``plot``) one Fig. 23-style PNG per measured trial and ``slip_rate.json`` added
    to folder ``plot``."""
    from ..store.outdir import check_output_folder
    from ..store.provenance import provenance_record
    from .slip_rate import estimate_slip_rates

    path = Path(path)
    plot = None if plot is None else Path(plot)
    if not path.is_file():
        raise InputError("file not found", path=path)
    check_outputs({"plot": plot}, _inputs(path, rois))
    if plot is not None:  # figures are added to an existing folder; a file there is not
        check_output_folder(plot, merge=True)
    config, config_files = config_source(rois)
    estimates = estimate_slip_rates(path, config, trials=trials)
    results = [e.result.as_dict() for e in estimates]
    record = provenance_record([path, *config_files], {
        "config": None if config is None else config.as_dict(),
        "rois_proposed": config is None or not config.rois,
        "trials": list(trials) if trials else "all",
    })
    record["trials"] = results
    record["summary"] = _summary(results)
    report = SlipRateReport(estimates, record, plot)
    if plot is not None:
        report.figures.extend(_plot_slips(report, plot))
    return report


def _plot_slips(report: SlipRateReport, plot: Path) -> list[Path]:
    from ..store.atomic import write_json
    from ..store.outdir import output_folder
    from ..store.provenance import png_meta
    from .render import plot_slip

    meta = png_meta(report.record)
    figures = []
    with output_folder(plot, merge=True) as tmp:  # in place when every figure is
        for e in report.estimates:
            if e.trace is not None:
                name = f"slip_{e.result.trial}.png"
                plot_slip(e, tmp / name, meta=meta)
                figures.append(plot / name)
        write_json(tmp / "slip_rate.json", report.record)
    return figures


__all__ = ["MAX_FRAMES", "FramesResult", "SlipRateReport", "config_source", "slip_rate_report",
           "write_frames"]
