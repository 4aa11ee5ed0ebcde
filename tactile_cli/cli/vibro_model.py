"""`tactile vibro-model CONFIG`: resonances of the lumped model without and with contact."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from ._errors import Flag, run_guarded

FLAGS: dict[str, Flag] = {"plot": "--plot"}


def vibro_model_command(
    config: Annotated[Path, typer.Argument(help="Lumped-model YAML (see "
                                           "configs/vibro_model.yaml).", show_default=False,
                                           metavar="CONFIG")],
    plot: Annotated[Path | None, typer.Option("--plot", help="Write both spectra as a PNG "
                                              "(like paper 003, Fig. 3A).", metavar="FILE")
                    ] = None,
    overwrite: Annotated[bool, typer.Option(help="Replace an existing --plot file.")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print the result as JSON.")] = False,
) -> None:
    """Solve the lumped model of paper 003 (sec. 2.2) from 1 to 1000 Hz: the
    accelerometer's displacement per unit motor displacement without contact and with the
    config's contact links, the resonance peaks of both, and the undamped natural
    frequencies (eigen-analysis of M and K with the motor held).

    JSON keys: resonances_free, resonances_contact (f_hz, amplitude), natural_free_hz,
    natural_contact_hz, f_range_hz, config, plot.
    """
    from ..vibro.pipeline import model_file

    result = run_guarded(lambda: model_file(config, plot=plot, overwrite=overwrite),
                         flags=FLAGS)
    out, cfg = result.as_dict(), result.config
    if as_json:
        typer.echo(json.dumps(out, indent=2))
        return
    typer.echo(f"lumped model {config}: {len(cfg.blocks)} blocks, {len(cfg.contact)} contact "
               f"links; |x_{cfg.sensor} / u_{cfg.source}| over {cfg.f_min_hz:g}-"
               f"{cfg.f_max_hz:g} Hz")
    for key, title in (("resonances_free", "no contact"), ("resonances_contact", "contact")):
        peaks = ", ".join(f"{r['f_hz']:.1f} Hz ({r['amplitude']:.3g})" for r in out[key])
        typer.echo(f"  {title:>10}: {peaks or 'no resonance'}")
    for key, title in (("natural_free_hz", "no contact"), ("natural_contact_hz", "   contact")):
        typer.echo(f"  natural frequencies (Hz), {title}: "
                   + ", ".join(f"{v:.1f}" for v in out[key]))
    if result.plot is not None:
        typer.echo(f"  spectra -> {result.plot}")
