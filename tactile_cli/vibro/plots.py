"""Figures of the active-vibration chain: the model's spectra (like paper 003, Fig. 3A) and
the detections (like Figs. 5-6). PNGs are written atomically with the provenance (command,
tool version, inputs) in their metadata."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..store.atomic import save_figure
from .model import ModelSpectra

if TYPE_CHECKING:  # the pipeline imports these figures
    from .pipeline import DetectionReport, TrialDetection


def figure_path(path: str | Path) -> Path:
    """Where a figure named ``path`` is written: ``path``, ``.png`` added when it has no
    suffix."""
    path = Path(path)
    return path.with_suffix(path.suffix or ".png")


def _save(fig, path: str | Path, meta: Mapping[str, str] | None, overwrite: bool) -> Path:
    return save_figure(fig, figure_path(path), meta=meta, dpi=110, overwrite=overwrite)


def plot_model_spectra(spectra: ModelSpectra, path: str | Path, *,
                       meta: Mapping[str, str] | None = None, overwrite: bool = False) -> Path:
    """Both spectra of the lumped model on a log scale, resonances marked (Fig. 3A)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 4.2))
    ax.semilogy(spectra.f_hz, spectra.free, color="tab:blue", label="no contact")
    ax.semilogy(spectra.f_hz, spectra.contact, "--", color="tab:red", label="contact")
    for res, colour in ((spectra.resonances_free, "red"), (spectra.resonances_contact, "green")):
        ax.plot([r.f_hz for r in res], [r.amplitude for r in res], "o", color=colour, ms=5)
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("|x_accelerometer / u_motor|")
    ax.set_title("lumped model: accelerometer response to the motor's displacement")
    ax.legend()
    ax.grid(alpha=0.3, which="both")
    fig.tight_layout()
    return _save(fig, path, meta, overwrite)


def _trigger_axes(ax, det: TrialDetection, which: str, unit: str) -> None:
    trig = det.vibration if which == "vibration" else det.force
    if trig is None:
        ax.text(0.5, 0.5, "no force stream", transform=ax.transAxes, ha="center")
        return
    if det.scenario == "touch" and which == "vibration":
        raw = (trig.raw - trig.reference) / trig.reference * 100
        level = trig.level * 100
        thr = trig.threshold * 100
        ax.plot(trig.t_s, raw, color="tab:blue", lw=0.6, label="peak frequency shift (raw)")
        ax.plot(trig.t_s, level, color="black", lw=1.2, label="|averaged shift|")
        ax.axhline(thr, color="green", ls="--", label=f"threshold {thr:.3g} %")
        ax.set_ylabel("shift (%)")
    else:
        raw = np.abs(trig.raw - trig.reference)
        ax.plot(trig.t_s, raw, color="tab:blue", lw=0.5, label="raw")
        ax.plot(trig.t_s, trig.level, color="black" if which == "vibration" else "tab:orange",
                lw=1.2, label="moving average")
        ax.axhline(trig.noise, color="orange" if which == "vibration" else "red", ls="--",
                   label=f"noise level {trig.noise:.3g}")
        ax.axhline(trig.threshold, color="green" if which == "vibration" else "black", ls="--",
                   label=f"threshold {trig.threshold:.3g}")
        ax.set_ylabel(unit)
    for start, end in trig.events:
        ax.axvspan(start, end, color="green", alpha=0.12)
    if det.contact_s is not None:
        ax.axvline(det.contact_s, color="purple", lw=1, label="true contact")
    for a, b in det.touches:
        ax.axvspan(a, b, color="purple", alpha=0.08)
    ax.legend(fontsize=7, loc="upper left")
    ax.grid(alpha=0.3)


def plot_detections(report: DetectionReport, path: str | Path, *,
                    meta: Mapping[str, str] | None = None, trial: str | None = None,
                    overwrite: bool = False) -> Path:
    """Fig. 5/6-like page: the vibration and force triggers of one trial (``trial``, else
    the first contact trial, else the first) and, over every scored contact trial, the
    detection times after the true contact of both sensors (Fig. 5C)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    dets = report.trials
    shown = next((d for d in dets if d.trial == trial), None) if trial else None
    shown = shown or next((d for d in dets if d.scenario == "contact"), dets[0])
    scored = [d for d in dets if d.scenario == "contact" and d.contact_s is not None]
    fig, axes = plt.subplots(3, 1, figsize=(9, 9))
    vib_unit = "band peak amplitude (g)"
    _trigger_axes(axes[0], shown, "vibration", vib_unit)
    axes[0].set_title(f"{shown.trial} ({shown.scenario}): vibration trigger")
    _trigger_axes(axes[1], shown, "force", "|force - calibration mean| (N)")
    axes[1].set_title(f"{shown.trial}: force trigger")
    axes[1].set_xlabel("time (s)")
    ax = axes[2]
    if scored:
        k = np.arange(1, len(scored) + 1)
        vib = [d.summary.get("vibration_delay_s") for d in scored]
        frc = [d.summary.get("force_delay_s") for d in scored]
        ax.plot([i for i, v in zip(k, vib, strict=True) if v is not None],
                [v for v in vib if v is not None], "o", color="red", label="vibration")
        ax.plot([i for i, v in zip(k, frc, strict=True) if v is not None],
                [v for v in frc if v is not None], "x", color="blue", label="force")
        ax.set_xticks(k)
        ax.set_xlabel("contact trial")
        ax.set_ylabel("detected after contact (s)")
        totals = report.totals()
        ax.set_title(f"detected: vibration {totals['vibration_detected']}/{len(scored)}, force "
                     f"{totals['force_detected']}/{len(scored)}; false alarms "
                     f"{totals['false_alarms']}")
        ax.legend()
        ax.grid(alpha=0.3)
    else:
        ax.text(0.5, 0.5, "no contact trial with a true contact time", ha="center",
                transform=ax.transAxes)
        ax.set_axis_off()
    fig.tight_layout()
    return _save(fig, path, meta, overwrite)
