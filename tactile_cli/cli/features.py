"""`tactile features spectral FILE --out FILE [--stream NAME]`: spectral features as a
stream."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated, Any

import typer

from ._batch import BATCH_FLAGS, SchedulerOption, WorkersOption, run_file_batch
from ._errors import Flag, run_guarded
from ._options import JsonOption, OverwriteOption
from ._output import print_result
from .progress import ProgressOption, RichProgress

FLAGS: dict[str, Flag] = {"groups": "--group", "bands_hz": "--band", **BATCH_FLAGS}

app = typer.Typer(
    name="features",
    help="Features of tactile streams written as new streams for train/evaluate.",
    no_args_is_help=True,
    add_completion=False,
    context_settings={"help_option_names": ["-h", "--help"]},
)


@app.command("spectral")
def spectral_command(
    files: Annotated[list[Path], typer.Argument(
        help="Tactile HDF5 file of taxel-array trials (tactile simulate taxel-slip), or with "
        "--stream any tactile file; several with --out-dir.", metavar="FILE", show_default=False)],
    out: Annotated[Path | None, typer.Option("--out", "-o", help="Output tactile HDF5 file "
                                             "(one input).", metavar="FILE",
                                             show_default=False)] = None,
    out_dir: Annotated[Path | None, typer.Option(
        "--out-dir", help="With --stream: one output per input, <input stem>.h5, one task "
        "per file on Dask (--workers, --scheduler); outputs newer than their input are "
        "skipped.", metavar="FOLDER", show_default=False)] = None,
    scheduler: SchedulerOption = None,
    workers: WorkersOption = None,
    config: Annotated[Path | None, typer.Option(
        "--config", "-c", help="Feature config YAML (see configs/taxel_features.yaml): "
        "window, hop and bands; default: the built-in defaults.", metavar="CONFIG")] = None,
    stream: Annotated[str | None, typer.Option(
        help="Any multichannel stream instead of the taxel-slip layout: Gamma and G2 of its "
        "channels (or of each --group) per window and band, its per-sample labels carried "
        "over.", show_default=False)] = None,
    group: Annotated[list[str] | None, typer.Option(
        "--group", help="With --stream: channel globs of one array, comma-separated (e.g. "
        "'L_*'); repeat for several arrays (G2 across them too). Default: one array of "
        "every channel.", show_default=False)] = None,
    band: Annotated[list[str] | None, typer.Option(
        "--band", help="With --stream: a named band NAME=LOW-HIGH in Hz (e.g. "
        "mid=100-400); repeatable; 'full' is always added.", show_default=False)] = None,
    window_s: Annotated[float, typer.Option(
        "--window-s", min=1e-6, help="With --stream: window length (s).")] = 1.0,
    hop_s: Annotated[float, typer.Option(
        "--hop-s", min=1e-6, help="With --stream: step between windows (s).")] = 0.25,
    nperseg: Annotated[int, typer.Option(
        "--nperseg", min=8, help="With --stream: Welch segment (samples; at most the "
        "window), overlap half.")] = 64,
    overwrite: OverwriteOption = False,
    as_json: JsonOption = False,
    progress: ProgressOption = None,
) -> None:
    """Power ratio Gamma and single- and multi-finger group square coherence G2 (paper 004)
    per sliding window and band, as stream spectral_features (channels
    <feature>_<band>, one sample per window) with per-window labels slip (rest, hand,
    world), for tactile train CONFIG --data OUT. With --stream NAME: the same features of
    any multichannel stream (accelerometers, vibration fingers, taxels of any layout), one
    array or several (--group), the stream's per-sample labels taken at each window's end."""
    from ..spectral.stream_features import (
        check_feature_modes,
        parse_bands,
        stream_features_each,
        write_stream_features,
    )
    from ..taxel import write_taxel_features

    def settings() -> dict[str, Any]:
        groups = [[g.strip() for g in text.split(",") if g.strip()] for text in group or []]
        return {"stream": stream, "window_s": window_s, "hop_s": hop_s, "nperseg": nperseg,
                "bands_hz": parse_bands(band), "groups": groups or None}

    def body() -> Any:
        check_feature_modes(files, out=out, out_dir=out_dir, stream=stream,
                            scheduler=scheduler, workers=workers, groups=group, bands_hz=band,
                            config=config)
        if out_dir is not None:
            return run_file_batch("features", lambda **printing: stream_features_each(
                files, out_dir, settings=settings(), overwrite=overwrite, scheduler=scheduler,
                workers=workers, **printing), progress=progress, as_json=as_json, flags=FLAGS,
                describe=lambda item: f"-> {item.output} ({item.value['n_windows']} windows)")
        with RichProgress(enabled=progress) as bar:
            if stream is None:
                return write_taxel_features(files[0], out, config=config, overwrite=overwrite,
                                            progress=bar)
            return write_stream_features(files[0], out, config=settings(),
                                         overwrite=overwrite, progress=bar, **settings())

    result = run_guarded(body, flags=FLAGS)
    if out_dir is None:
        print_result(result, as_json=as_json)
    if out_dir is None and stream is not None and result.too_short:
        print(f"tactile: note: left out, shorter than one window: "
              f"{', '.join(result.too_short)}", file=sys.stderr)
