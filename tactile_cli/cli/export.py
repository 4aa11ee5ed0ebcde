"""`tactile export RUN --format onnx|torchscript --out FILE [--overwrite] [--json]`"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ._errors import Flag, run_guarded
from ._output import echo_json

#: How this command spells the library arguments its errors name (see ``_errors.to_flags``).
FLAGS: dict[str, Flag] = {"format": "--format"}


def export_command(
    run: Annotated[Path, typer.Argument(help="Run folder written by `tactile train` (a fold's "
                                        "folder for a cross-validated run).",
                                        show_default=False, metavar="RUN")],
    out: Annotated[
        Path, typer.Option("--out", "-o", help="Model file to write (e.g. model.onnx); its "
                           "sidecar FILE.json is written beside it.", metavar="FILE",
                           show_default=False)],
    fmt: Annotated[str, typer.Option(
        "--format", help="onnx (onnxruntime or any ONNX runtime) or torchscript (torch.jit.load; "
        "deprecated by torch, prefer onnx).")] = "onnx",
    overwrite: Annotated[
        bool, typer.Option(help="Replace an existing FILE and FILE.json.")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print the sidecar to stdout.")
                       ] = False,
) -> None:
    """Export a trained run as one self-contained model file: input the raw window
    (batch x samples x channels, float32, the run's channel order and units), outputs the
    class probabilities and regression values of every head; the transform, normalisation
    and in-model features are inside the graph. FILE.json states the input shape,
    channels and units, sample period, window and stride, label names, tool version and
    the run's provenance."""

    def body() -> None:
        from ..learn.export import export_run

        result = export_run(run, out, format=fmt, overwrite=overwrite)  # type: ignore[arg-type]
        if as_json:
            echo_json(result.sidecar_record)
            return
        heads = ", ".join(result.outputs)
        typer.echo(f"wrote {result.path} ({result.format}, {result.family}, "
                   f"{result.size_bytes / 1e3:,.1f} kB; outputs {heads}) and {result.sidecar}")

    run_guarded(body, flags=FLAGS)
