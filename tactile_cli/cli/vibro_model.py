"""`tactile vibro-model CONFIG`: resonances of the lumped model without and with contact."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ._errors import Flag, run_guarded
from ._options import JsonOption
from ._output import print_result

FLAGS: dict[str, Flag] = {}


def vibro_model_command(
    config: Annotated[Path, typer.Argument(help="Lumped-model YAML (see "
                                           "configs/vibro_model.yaml).", show_default=False,
                                           metavar="CONFIG")],
    plot: Annotated[Path | None, typer.Option("--plot", help="Write both spectra as a PNG "
                                              "(like paper 003, Fig. 3A).", metavar="FILE")
                    ] = None,
    overwrite: Annotated[bool, typer.Option(help="Replace an existing --plot file.")] = False,
    as_json: JsonOption = False,
) -> None:
    """Solve the lumped model of paper 003 (sec. 2.2) from 1 to 1000 Hz: the
    accelerometer's displacement per unit motor displacement without contact and with the
    config's contact links, the resonance peaks of both, and the undamped natural
    frequencies (eigen-analysis of M and K with the motor held).

    JSON keys: resonances_free, resonances_contact (f_hz, amplitude), natural_free_hz,
    natural_contact_hz, f_range_hz, config, plot.
    """
    from ..vibro.pipeline import model_file

    print_result(run_guarded(lambda: model_file(config, plot=plot, overwrite=overwrite),
                             flags=FLAGS), as_json=as_json)
