"""`tactile slip-rate FILE`"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Annotated

import typer

from ..errors import InputError
from ._errors import Flag, run_guarded, to_flags

#: How this command spells the library arguments its errors name (see ``_errors.to_flags``):
#: the library takes the ROIs and optics as ``config``, this command as the --rois file.
FLAGS: dict[str, Flag] = {"config": "--rois"}


def _fmt(value: float | None, scale: float = 1.0, digits: int = 4) -> str:
    if value is None or value != value:  # None or NaN
        return "-"
    return f"{value * scale:.{digits}f}"


def slip_rate_command(
    file: Annotated[Path, typer.Argument(help="A tactile HDF5 file with events and slip "
                                         "annotations.", metavar="FILE", show_default=False)],
    rois: Annotated[Path | None, typer.Option(
        help="ROI + optics config: YAML (configs/rois_marker_scene.yaml) or a scene's "
             "scene.json. Without it the ROIs are proposed from each trial's slip-region "
             "events and the optics come from the sensor's attributes.",
        metavar="FILE", show_default=False)] = None,
    trial: Annotated[list[str] | None, typer.Option(
        "--trial", "-t", help="Trial to measure; repeatable (default: every trial with "
        "events).", metavar="TRIAL", show_default=False)] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the results as JSON.")] = False,
    plot: Annotated[Path | None, typer.Option(
        help="Folder for one Fig. 23-style PNG per trial (centroid, velocity, displacement) "
             "and slip_rate.json.", metavar="FOLDER", show_default=False)] = None,
) -> None:
    """Slip speed (m/s) and displacement (m) per trial from the event-weighted centroids of
    the marker-strip ROIs (paper 000, eqs. 19-21, Fig. 23): the slope of a line fitted to the
    centroid's y over the slip region, converted to metres by the optics (eqs. 3, 15), with
    standard errors; the truth is shown when the trial labels carry slip_speed_m_s."""

    def body() -> None:
        from ..spatial.config import load_config
        from ..spatial.slip_rate import estimate_slip_rates
        from ..store.atomic import write_json
        from ..store.outdir import check_output_folder, output_folder
        from ..store.provenance import png_meta
        from ..store.provenance import provenance_record as provenance

        if not file.exists():
            raise InputError("file not found", path=file)
        if plot is not None:  # figures are added to an existing folder; a file there is not
            check_output_folder(plot, merge=True)
        config = load_config(rois) if rois is not None else None
        estimates = estimate_slip_rates(file, config, trials=trial)
        results = [e.result.as_dict() for e in estimates]
        errors = [abs(r["speed_rel_error"]) for r in results
                  if r["speed_rel_error"] is not None]
        record = provenance([file] + ([rois] if rois is not None else []), {
            "config": None if config is None else config.as_dict(),
            "rois_proposed": config is None or not config.rois,
            "trials": trial or "all",
        })
        record["trials"] = results
        record["summary"] = {
            "n_trials": len(results),
            "n_ok": sum(r["status"] == "ok" for r in results),
            "n_with_truth": len(errors),
            "mean_abs_rel_error": float(sum(errors) / len(errors)) if errors else None,
            "max_abs_rel_error": float(max(errors)) if errors else None,
        }
        if plot is not None:
            from ..spatial.render import plot_slip

            meta = png_meta(record)
            with output_folder(plot, merge=True) as tmp:  # in place when every figure is
                for e in estimates:
                    if e.trace is not None:
                        plot_slip(e, tmp / f"slip_{e.result.trial}.png", meta=meta)
                write_json(tmp / "slip_rate.json", record)
        if as_json:
            typer.echo(json.dumps(record, indent=2, allow_nan=False))
            return
        from rich.console import Console
        from rich.table import Table

        console = Console(width=None if sys.stdout.isatty() else 160)
        table = Table(title=f"Slip rate of {file} (speed = |slope of centroid y| over the "
                      "slip region)")
        for col in ("trial", "status", "speed (m/s)", "+- se", "displacement (m)", "+- se",
                    "truth (m/s)", "error", "r2", "ROIs"):
            table.add_column(col)
        for r in results:
            err = r["speed_rel_error"]
            table.add_row(
                r["trial"], r["status"] if r["status"] == "ok" else
                f"{r['status']}: {to_flags(r['message'], FLAGS)}",
                _fmt(r["speed_m_s"], digits=6), _fmt(r["speed_se_m_s"], digits=6),
                _fmt(r["displacement_m"], digits=6), _fmt(r["displacement_se_m"], digits=6),
                _fmt(r["truth_speed_m_s"], digits=6),
                "-" if err is None else f"{err * 100:+.1f} %", _fmt(r["r2"], digits=3),
                str(r["n_rois_used"]),
            )
        console.print(table)
        s = record["summary"]
        if s["n_with_truth"]:
            console.print(f"speed error vs truth over {s['n_with_truth']} trial(s): mean "
                          f"|error| {s['mean_abs_rel_error'] * 100:.1f} %, max "
                          f"{s['max_abs_rel_error'] * 100:.1f} %")
        if plot is not None:
            console.print(f"wrote {plot}/slip_*.png and {plot / 'slip_rate.json'}")

    run_guarded(body, flags=FLAGS)
