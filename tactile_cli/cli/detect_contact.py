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

FLAGS: dict[str, Flag] = {"band_hz": "--band", "width_hz": "--band-width", "plot": "--plot",
                          "samples_out": "--samples-out", "trial": "--trial",
                          "rate_hz": "--rate", "scenario": "--scenario"}


class Scenario(enum.StrEnum):
    contact = "contact"
    touch = "touch"


def _parse_band(text: str) -> tuple[float, float]:
    from ..errors import InputError

    try:
        lo, hi = (float(v) for v in text.split(","))
    except ValueError:
        raise InputError(f"--band {text!r} must be two frequencies in Hz like 570,580") from None
    return lo, hi


def detect_contact_command(
    file: Annotated[Path, typer.Argument(help="Tactile HDF5 file (tactile simulate "
                                         "vibrotouch); with --follow a text stream, one "
                                         "acceleration value (g) per line, or - for standard "
                                         "input.", show_default=False, metavar="FILE")],
    config: Annotated[Path | None, typer.Option("--config", "-c", help="Detector YAML (see "
                                                "configs/detect_contact.yaml); default: the "
                                                "paper's settings.", metavar="CONFIG")] = None,
    band: Annotated[str | None, typer.Option("--band", help="Override band_hz: the contact "
                                             "band, e.g. 570,580 (Hz).")] = None,
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

    def body() -> None:
        from ..errors import InputError
        from ..vibro import DetectorConfig, load_detector_config

        cfg = load_detector_config(config) if config is not None else DetectorConfig()
        if band is not None:
            try:
                cfg = DetectorConfig.model_validate({**cfg.model_dump(),
                                                     "band_hz": _parse_band(band)})
            except ValueError as exc:  # pydantic's ValidationError
                raise InputError(f"--band {band!r}: the band must be [low, high] with "
                                 f"0 <= low < high ({type(exc).__name__})") from None
        for out in (plot, samples_out):
            if out is not None and out.exists() and not overwrite:
                raise InputError("output exists; pass `overwrite=True` to replace it", path=out)
            if out is not None and not out.parent.is_dir():
                raise InputError("output folder does not exist", path=out.parent)
        if follow_:
            _follow(cfg)
            return
        _offline(cfg)

    def _follow(cfg) -> None:
        from ..errors import InputError
        from ..vibro import follow

        def say(t: float) -> None:
            if as_json:
                typer.echo(json.dumps({"event": scenario.value, "start_s": round(t, 4)}))
            else:
                typer.echo(f"{scenario.value} at {t:.3f} s")
            sys.stdout.flush()

        if str(file) == "-":
            result = follow(sys.stdin, cfg, rate_hz=rate, name="<stdin>",
                            scenario=scenario.value, on_event=say)
        else:
            if not file.is_file():
                raise InputError("no such file", path=file)
            with open(file, encoding="utf-8", errors="replace") as src:
                result = follow(src, cfg, rate_hz=rate, name=str(file),
                                scenario=scenario.value, follow_s=wait, on_event=say)
        out = result.as_dict()
        if as_json:
            typer.echo(json.dumps(out))
            return
        lat = out["latency_ms"]
        typer.echo(f"{out['n_samples']} samples, {out['n_updates']} updates, "
                   f"{len(out['events'])} {scenario.value} events; per-update latency mean "
                   f"{lat['mean']:.3f} ms, p99 {lat['p99']:.3f} ms, max {lat['max']:.3f} ms "
                   f"(refresh every {out['refresh_ms']:g} ms; {out['over_budget']} over)")

    def _offline(cfg) -> None:
        from ..errors import InputError
        from ..store.trials import TactileFile
        from ..vibro import detect_contacts, find_band

        with TactileFile(file) as f:
            if samples_out is not None:
                from ..vibro.pipeline import VIBRATION_KINDS, _stream
                from ..vibro.stream import write_samples

                if not trial or len(trial) != 1:
                    raise InputError("name one trial with `trial` to write its samples",
                                     path=file)
                t = f.trial(trial[0])
                name = _stream(t, VIBRATION_KINDS)
                if name is None:
                    raise InputError("trial has no accelerometer stream", path=file,
                                     where=t.where)
                write_samples(t.signal(name).data[:, 0], samples_out)
                typer.echo(f"{t.name}: {t.signal(name).data.shape[0]} samples at "
                           f"{t.signal(name).sample_rate_hz:g} Hz -> {samples_out}")
                return
            report = detect_contacts(f, cfg, trials=trial or None)
            proposal = find_band(f, cfg, width_hz=band_width) if find_band_ else None
        out = report.as_dict()
        out["band"] = None if proposal is None else proposal.as_dict()
        if plot is not None:
            from ..vibro.plots import plot_detections
            from ._vibro_meta import png_meta

            plot_detections(report, plot, meta=png_meta([file], out["config"]))
        out["plot"] = None if plot is None else str(plot)
        if as_json:
            typer.echo(json.dumps(out, indent=2))
            return
        _print(out)

    run_guarded(body, flags=FLAGS)


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

        def fmt(v, spec=".3f"):
            return "-" if v is None else format(v, spec)

        for r in rows:
            table.add_row(r["trial"], fmt(r.get("contact_s")), fmt(r.get("vibration_s")),
                          fmt(r.get("force_s")), fmt(r.get("lead_s")),
                          str(r.get("vibration_false_alarms", "-")),
                          fmt(r.get("vibration_snr"), ".1f"), fmt(r.get("force_snr"), ".1f"))
        console.print(table)
    if tot["n_contacts"]:
        def num(v, spec):
            return "-" if v is None else format(v, spec)

        console.print(f"vibration detected {tot['vibration_detected']}/{tot['n_contacts']}, "
                      f"force {tot['force_detected']}/{tot['n_contacts']}; false alarms "
                      f"{tot['false_alarms']} (force {tot['force_false_alarms']}); SNR "
                      f"{num(tot['vibration_snr'], '.1f')} vs {num(tot['force_snr'], '.1f')}; "
                      f"vibration leads force by {num(tot['mean_lead_s'], '.2f')} s on average")
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
