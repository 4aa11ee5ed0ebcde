"""`tactile frames FILE --out DIR`"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from ..errors import InputError
from ._errors import run_guarded


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
    as_json: Annotated[bool, typer.Option("--json", help="Print what was written as JSON.")
                       ] = False,
) -> None:
    """Event frames (paper 000, Fig. 13): events accumulated per window onto the sensor grid,
    optionally median-filtered, written as PNGs plus one contact sheet per trial with the
    ROIs drawn. DIR/frames.json records the command, options and input."""

    def body() -> None:
        from ..spatial.config import load_config
        from ..spatial.render import KINDS, write_trial_frames
        from ..spatial.trial_events import event_trial_names, spatial_events
        from ..store.atomic import write_json
        from ..store.outdir import check_output_folder, output_folder
        from ..store.provenance import png_meta
        from ..store.provenance import provenance_record as provenance
        from ..store.trials import TactileFile

        if not file.exists():
            raise InputError("file not found", path=file)
        if not window_ms > 0:
            raise InputError(f"--window-ms (={window_ms:g}) must be > 0")
        if median < 1 or median % 2 == 0:
            raise InputError(f"--median (={median}) must be an odd whole number of px >= 1 "
                             "(1 = no filter)")
        if kind not in KINDS:
            raise InputError(f"--kind (={kind!r}) must be one of {', '.join(KINDS)}")
        if end_s is not None and end_s <= start_s:
            raise InputError(f"--end-s (={end_s:g}) must be later than --start-s "
                             f"(={start_s:g})")
        config = load_config(rois) if rois is not None else None
        # trial subfolders are added to an existing --out; a file there is refused
        check_output_folder(out, merge=True)
        with TactileFile(file) as tf:
            names = list(trial) if trial else event_trial_names(tf)
            if not names:
                raise InputError("no trial with events", path=file)
            chosen = []
            for name in names:  # every input checked before the first PNG is written
                chosen.append(tf.trial(name))
                te = spatial_events(chosen[-1])
                if config is not None:
                    config.check_sensor(te.sensor.width_px, te.sensor.height_px)
                target = out / name
                if target.exists() and not target.is_dir():
                    raise InputError("is a file; give another --out folder or move the "
                                     "file", path=target)
                if target.exists() and any(target.glob("*.png")) and not overwrite:
                    raise InputError("holds PNGs of an earlier run; pass --overwrite to "
                                     "replace them", path=target)
            options = {"window_ms": window_ms, "median": median, "kind": kind,
                       "start_s": start_s, "end_s": end_s, "sheet_max": sheet_max,
                       "sheet_only": sheet_only, "trials": names,
                       "rois": None if config is None else config.as_dict()}
            record = provenance([file], options)
            meta = png_meta(record)
            written = []
            # built in a hidden folder beside --out; each trial folder (replacing an earlier
            # one) and frames.json are renamed into --out only when every trial is drawn
            with output_folder(out, merge=True) as tmp:
                for name, tr in zip(names, chosen, strict=True):
                    summary = write_trial_frames(
                        tr, tmp / name, window_s=window_ms * 1e-3, median=median,
                        kind=kind, rois=() if config is None else config.rois,
                        start_s=start_s, end_s=end_s, sheet_max=sheet_max,
                        frame_pngs=not sheet_only, meta=meta,
                    )
                    summary["folder"] = str(out / name)
                    written.append(summary)
                record["outputs"] = written
                write_json(tmp / "frames.json", record)
        if as_json:
            typer.echo(json.dumps(record, indent=2))
            return
        for s in written:
            typer.echo(f"{s['trial']}: {s['n_frames']} frames of {window_ms:g} ms "
                       f"-> {s['folder']}/ (contact_sheet.png"
                       f"{'' if sheet_only else ', frame_*.png'})")
        typer.echo(f"wrote {out / 'frames.json'}")

    run_guarded(body)
