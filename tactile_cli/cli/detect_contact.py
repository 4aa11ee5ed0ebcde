"""`tactile detect-contact FILE`: contact and touch detection from active vibration and
force (paper 003, sec. 2.4), offline on a tactile file or live on a stream of samples."""

from __future__ import annotations

import enum
import json
import sys
from pathlib import Path
from typing import Annotated

import typer

from ._errors import Flag, run_guarded
from ._options import JsonOption
from ._output import print_result

FLAGS: dict[str, Flag] = {
    "band_hz": "--band", "band_width_hz": "--band-width", "width_hz": "--band-width",
    "out": "--samples-out", "trials": "--trial", "rate_hz": "--rate", "follow_s": "--wait",
}


class Scenario(enum.StrEnum):
    contact = "contact"
    touch = "touch"


def _band(text: str | None) -> tuple[float, float] | None:
    """``"570,580"`` -> ``(570.0, 580.0)``."""
    if text is None:
        return None
    try:
        lo, hi = (float(v) for v in text.split(","))
    except ValueError:
        from ..errors import InputError

        raise InputError(f"--band {text!r} must be two frequencies in Hz like 570,580"
                         ) from None
    return lo, hi


def detect_contact_command(
    file: Annotated[Path, typer.Argument(help="Tactile HDF5 file (tactile simulate "
                                         "vibrotouch); with --follow a text stream, one "
                                         "acceleration value (g) per line, or - for standard "
                                         "input.", show_default=False, metavar="FILE")],
    config: Annotated[Path | None, typer.Option("--config", "-c", help="Detector YAML (see "
                                                "configs/detect_contact.yaml); default: the "
                                                "paper's settings.", metavar="CONFIG")] = None,
    band: Annotated[str | None, typer.Option("--band", metavar="LOW,HIGH", help="Override "
                                             "band_hz: the contact band, e.g. 570,580 (Hz).")
                    ] = None,
    trial: Annotated[list[str] | None, typer.Option("--trial", help="Only this trial "
                                                    "(repeatable).")] = None,
    plot: Annotated[Path | None, typer.Option("--plot", help="Write a figure like Figs. 5-6 "
                                              "(PNG).", metavar="FILE")] = None,
    find_band_: Annotated[bool, typer.Option("--find-band", help="Also propose the most "
                                             "contact-sensitive band from the labelled "
                                             "contact trials.")] = False,
    band_width: Annotated[float | None, typer.Option(
        "--band-width", help="Width (Hz) of the proposed band (default: the band's).")] = None,
    follow_: Annotated[bool, typer.Option("--follow", help="Read FILE as a live text stream "
                                          "and print events as they happen.")] = False,
    rate: Annotated[float, typer.Option("--rate", min=1.0, help="Sample rate of the stream "
                                        "(Hz; --follow).")] = 2500.0,
    scenario: Annotated[Scenario, typer.Option(help="Trigger of the stream (--follow): "
                                               "contact (band amplitude) or touch (peak "
                                               "frequency shift).")] = Scenario.contact,
    wait: Annotated[float, typer.Option("--wait", min=0.0, help="With --follow on a file: "
                                        "seconds to wait for more samples at its end.")
                    ] = 0.0,
    samples_out: Annotated[Path | None, typer.Option("--samples-out", help="Write the "
                                                     "accelerometer samples of --trial as the "
                                                     "text --follow reads, and stop.",
                                                     metavar="FILE")] = None,
    overwrite: Annotated[bool, typer.Option(help="Replace existing --plot/--samples-out "
                                            "files.")] = False,
    as_json: JsonOption = False,
) -> None:
    """Detect gripper-object contacts (peak amplitude in a band, 2 x its noise level; the
    force at 1.6 x its noise) and touches on a grasped object (peak-frequency shift over
    3 %; force over 0.3 N) in every trial, each scored against its ground truth: delay
    after the true contact, false alarms while the gripper moves, SNR of each sensor.

    JSON keys: totals (n_contacts, vibration_detected, force_detected, false_alarms,
    vibration_snr, force_snr, mean_lead_s, ...), trials, config, band (with --find-band).
    With --follow: events, n_updates, latency_ms (mean, p99, max) and refresh_ms.
    """
    from .. import vibro

    if follow_:
        def say(t: float) -> None:
            typer.echo(json.dumps({"event": scenario.value, "start_s": round(t, 4)})
                       if as_json else f"{scenario.value} at {t:.3f} s")
            sys.stdout.flush()

        result = run_guarded(lambda: vibro.follow_input(
            file, config=config, band_hz=_band(band), rate_hz=rate, scenario=scenario.value,
            follow_s=wait, on_event=say), flags=FLAGS)
        print_result(result, as_json=as_json, indent=None)
    elif samples_out is not None:
        one = trial[0] if trial and len(trial) == 1 else None
        print_result(run_guarded(lambda: vibro.write_trial_samples(
            file, samples_out, trial=one, overwrite=overwrite), flags=FLAGS), as_json=as_json)
    else:
        print_result(run_guarded(lambda: vibro.detect_contact_file(
            file, config=config, band_hz=_band(band), trials=trial or None, plot=plot,
            propose_band=find_band_, band_width_hz=band_width, overwrite=overwrite),
            flags=FLAGS), as_json=as_json)
