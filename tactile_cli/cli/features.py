"""`tactile features spectral FILE --out FILE`: spectral features as a stream."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from ..errors import InputError
from ._errors import Flag, run_guarded
from .progress import RichProgress

FLAGS: dict[str, Flag] = {}

app = typer.Typer(
    name="features",
    help="Features of tactile streams written as new streams for train/evaluate.",
    no_args_is_help=True,
    add_completion=False,
    context_settings={"help_option_names": ["-h", "--help"]},
)


@app.command("spectral")
def spectral_command(
    file: Annotated[Path, typer.Argument(help="Tactile HDF5 file of taxel-array trials "
                                         "(tactile simulate taxel-slip).", metavar="FILE",
                                         show_default=False)],
    out: Annotated[Path, typer.Option("--out", "-o", help="Output tactile HDF5 file.",
                                      metavar="FILE", show_default=False)],
    config: Annotated[Path | None, typer.Option(
        "--config", "-c", help="Feature config YAML (see configs/taxel_features.yaml): "
        "window, hop and bands; default: the built-in defaults.", metavar="CONFIG")] = None,
    overwrite: Annotated[bool, typer.Option(help="Replace an existing output file.")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print what was written as JSON.")
                       ] = False,
    progress: Annotated[bool | None, typer.Option(
        "--progress/--no-progress", help="Show a progress bar (default: when stderr is a "
        "terminal).", show_default=False)] = None,
) -> None:
    """Power ratio Gamma and single- and multi-finger group square coherence G2 (paper 004)
    per sliding window and band, as stream spectral_features (channels
    <feature>_<band>, one sample per window) with per-window labels slip (rest, hand,
    world), for tactile train CONFIG --data OUT."""

    def body() -> None:
        from ..store.writer import current_command
        from ..taxel import FeatureConfig, load_feature_config, write_feature_stream
        from ..taxel.pipeline import provenance_record

        if not file.exists():
            raise InputError("file not found", path=file)
        if out.exists() and not overwrite:
            raise InputError("output exists; pass --overwrite to replace it", path=out)
        cfg = load_feature_config(config) if config is not None else FeatureConfig()
        record = provenance_record([file] + ([config] if config else []),
                                   cfg.model_dump(mode="json"))
        with RichProgress(enabled=progress) as bar:
            result = write_feature_stream(file, out, cfg, command=current_command(),
                                          provenance=record, overwrite=overwrite,
                                          progress=bar)
        if as_json:
            typer.echo(json.dumps(result.as_dict(), indent=2))
            return
        flagged = [p for p, bad in result.rank_deficient.items() if bad]
        typer.echo(f"wrote {result.out}: {result.n_trials} trial(s), {result.n_windows} "
                   f"windows of {result.window_s:g} s every {result.hop_s:g} s, "
                   f"{len(result.channels)} channels"
                   + (f"; rank-deficient bands (G2 biased up) in {', '.join(flagged)}"
                      if flagged else ""))

    run_guarded(body, flags=FLAGS)
