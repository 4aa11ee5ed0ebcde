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

FLAGS: dict[str, Flag] = {"band_hz": "--band", "band_width_hz": "--band-width",
                          "plot": "--plot", "out": "--samples-out", "trial": "--trial",
                          "trials": "--trial", "rate_hz": "--rate", "scenario": "--scenario",
                          "follow_s": "--wait"}


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
    band_width: Annotated[float | None, typer.Option("--band-width", help="Width (Hz) of the "
                                                     "proposed band (default: the band's).")
                          ] = None,
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
    as_json: Annotated[bool, typer.Option("--json", help="Print the result as JSON.")] = False,
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
        _print_follow(result.as_dict(), as_json)
    elif samples_out is not None:
        one = trial[0] if trial and len(trial) == 1 else None
        done = run_guarded(lambda: vibro.write_trial_samples(file, samples_out, trial=one,
                                                              overwrite=overwrite), flags=FLAGS)
        typer.echo(f"{done.trial}: {done.n_samples} samples at {done.sample_rate_hz:g} Hz -> "
                   f"{done.out}")
    else:
        found = run_guarded(lambda: vibro.detect_contact_file(
            file, config=config, band_hz=_band(band), trials=trial or None, plot=plot,
            propose_band=find_band_, band_width_hz=band_width, overwrite=overwrite),
            flags=FLAGS)
        if as_json:
            typer.echo(json.dumps(found.as_dict(), indent=2))
        else:
            _print(found.as_dict())


def _print_follow(out: dict, as_json: bool) -> None:
    if as_json:
        typer.echo(json.dumps(out))
        return
    lat = out["latency_ms"]
    typer.echo(f"{out['n_samples']} samples, {out['n_updates']} updates, "
               f"{len(out['events'])} {out['scenario']} events; per-update latency mean "
               f"{lat['mean']:.3f} ms, p99 {lat['p99']:.3f} ms, max {lat['max']:.3f} ms "
               f"(refresh every {out['refresh_ms']:g} ms; {out['over_budget']} over)")


def _num(v: float | None, spec: str = ".3f") -> str:
    return "-" if v is None else format(v, spec)


def _print(out: dict) -> None:
    from rich.console import Console
    from rich.table import Table

    tot = out["totals"]
    console = Console(width=120)
    rows = [r for r in out["trials"] if r["scenario"] == "contact"]
    if rows:
        table = Table(title=f"contact detection, band {out['config']['band_hz']} Hz")
        for col in ("trial", "contact s", "vibration s", "force s", "lead s", "false alarms",
                    "SNR vib", "SNR force"):
            table.add_column(col, justify="right")
        for r in rows:
            table.add_row(r["trial"], _num(r.get("contact_s")), _num(r.get("vibration_s")),
                          _num(r.get("force_s")), _num(r.get("lead_s")),
                          str(r.get("vibration_false_alarms", "-")),
                          _num(r.get("vibration_snr"), ".1f"), _num(r.get("force_snr"), ".1f"))
        console.print(table)
    if tot["n_contacts"]:
        console.print(f"vibration detected {tot['vibration_detected']}/{tot['n_contacts']}, "
                      f"force {tot['force_detected']}/{tot['n_contacts']}; false alarms "
                      f"{tot['false_alarms']} (force {tot['force_false_alarms']}); SNR "
                      f"{_num(tot['vibration_snr'], '.1f')} vs {_num(tot['force_snr'], '.1f')}"
                      f"; vibration leads force by {_num(tot['mean_lead_s'], '.2f')} s on "
                      "average")
    if tot["n_touches"]:
        console.print(f"touches: vibration {tot['vibration_touch_hits']}/{tot['n_touches']} "
                      f"({tot['vibration_touch_false_alarms']} false), force "
                      f"{tot['force_touch_hits']}/{tot['n_touches']} "
                      f"({tot['force_touch_false_alarms']} false)")
    if out.get("band"):
        b = out["band"]
        console.print(f"most contact-sensitive band: {b['band_hz'][0]:g}-{b['band_hz'][1]:g} Hz "
                      f"(score {b['score']}, {b['n_recordings']} recordings)")
    if out.get("plot"):
        console.print(f"figure -> {out['plot']}")
