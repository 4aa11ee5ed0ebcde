"""`tactile frames FILE --out DIR`"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from ._errors import Flag, run_guarded, seconds_as_ms
from ._options import JsonOption

#: How this command spells the library arguments its errors name (see ``_errors.to_flags``).
FLAGS: dict[str, Flag] = {"window_s": ("--window-ms", seconds_as_ms)}


def frames_command(
    file: Annotated[Path, typer.Argument(help="A tactile HDF5 file with events.",
                                         metavar="FILE", show_default=False)],
    out: Annotated[Path, typer.Option("--out", "-o", help="Output folder (one subfolder per "
                                      "trial).", metavar="FOLDER",
                                      show_default=False)],
    trial: Annotated[list[str] | None, typer.Option(
        "--trial", "-t", help="Trial to draw; repeatable (default: every trial with events).",
        metavar="TRIAL", show_default=False)] = None,
    window_ms: Annotated[float, typer.Option(help="Accumulation window per frame, ms.")] = 50.0,
    median: Annotated[int, typer.Option(help="Median filter size in px against salt-and-"
                                        "pepper noise (odd; 1 = none).")] = 1,
    kind: Annotated[str, typer.Option(help="What a frame shows: polarity (ON green, OFF red), "
                                      "net, positive or negative.")] = "polarity",
    rois: Annotated[Path | None, typer.Option(help="ROI config (YAML or a scene.json) whose "
                                              "rectangles are drawn on the contact sheet.",
                                              metavar="FILE")] = None,
    start_s: Annotated[float, typer.Option(help="First window starts here, trial seconds.")
                       ] = 0.0,
    end_s: Annotated[float | None, typer.Option(help="Last window ends here (default: the "
                                                "trial's end).", show_default=False)] = None,
    sheet_max: Annotated[int, typer.Option(min=1, help="Frames on the contact sheet, evenly "
                                           "spread.")] = 24,
    sheet_only: Annotated[bool, typer.Option("--sheet-only", help="Write only the contact "
                                             "sheet, no per-frame PNGs.")] = False,
    overwrite: Annotated[bool, typer.Option(help="Replace the PNGs of an earlier run.")] = False,
    as_json: JsonOption = False,
) -> None:
    """Event frames (paper 000, Fig. 13): events accumulated per window onto the sensor grid,
    optionally median-filtered, written as PNGs plus one contact sheet per trial with the
    ROIs drawn. DIR/frames.json records the command, options and input."""

    def body() -> None:
        from ..spatial.pipeline import write_frames

        result = write_frames(file, out, trials=trial, window_s=window_ms * 1e-3, median=median,
                              kind=kind, rois=rois, start_s=start_s, end_s=end_s,
                              sheet_max=sheet_max, frame_pngs=not sheet_only,
                              overwrite=overwrite)
        if as_json:
            typer.echo(json.dumps(result.as_dict(), indent=2))
            return
        for s in result.trials:
            typer.echo(f"{s['trial']}: {s['n_frames']} frames of {window_ms:g} ms "
                       f"-> {s['folder']}/ (contact_sheet.png"
                       f"{'' if sheet_only else ', frame_*.png'})")
        typer.echo(f"wrote {out / 'frames.json'}")

    run_guarded(body, flags=FLAGS)
