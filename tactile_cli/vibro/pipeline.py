"""File-level verbs of the active-vibration chain: detect contacts and touches in every
trial of a tactile file (``tactile detect-contact``) and propose the most contact-sensitive
band from labelled recordings (the band-finder).

A trial's scenario comes from its label ``scenario`` (``contact``: gripper-object, sec.
2.4.1; ``touch``: grasped object-human, sec. 2.4.2; ``contact`` when absent). Its ground
truth, when it has one, is the label ``contact_s`` (contact) or the ``touch`` annotations;
without it, the detections are listed and nothing is scored.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..spectral import FrameSettings, FrameSpectra, band_peak, frame_spectra
from ..store.trials import TactileFile, Trial
from .config import DetectorConfig
from .features import Trigger, band_scores, threshold_trigger

VIBRATION_KINDS = ("vibro_active", "accelerometer")
FORCE_KINDS = ("force_torque",)


def _stream(trial: Trial, kinds: tuple[str, ...]) -> str | None:
    for name in trial.signal_names:
        if trial.signal_sensor(name).kind in kinds:
            return name
    return None


def trial_spectra(trial: Trial, cfg: DetectorConfig) -> tuple[FrameSpectra, FrameSettings]:
    """The accelerometer's frames of ``trial`` (first channel of its first stream from a
    sensor of kind vibro_active or accelerometer), times from the trial's origin."""
    name = _stream(trial, VIBRATION_KINDS)
    if name is None:
        kinds = " or ".join(VIBRATION_KINDS)
        raise InputError(f"trial has no stream from a sensor of kind {kinds}",
                         path=trial.path, where=trial.where)
    sig = trial.signal(name)
    try:
        settings = FrameSettings.from_seconds(sig.sample_rate_hz, window_s=cfg.window_s,
                                              hop_s=cfg.hop_s, n_fft=cfg.n_fft)
    except ValueError as exc:
        raise InputError(str(exc), path=trial.path, where=f"{trial.where}/signals/{name}") \
            from None
    spectra = frame_spectra(sig.data[:, 0], settings)
    t0 = float(sig.t_s[0]) if len(sig.t_s) else 0.0
    return FrameSpectra(spectra.t_s + t0, spectra.f_hz, spectra.magnitude), settings


def _force(trial: Trial, channel: str) -> tuple[np.ndarray, np.ndarray] | None:
    name = _stream(trial, FORCE_KINDS)
    if name is None:
        return None
    sig = trial.signal(name)
    if channel not in sig.channel_names:
        raise InputError(f"force stream has no channel {channel!r} (it has "
                         f"{', '.join(sig.channel_names)}); set `force_channel` or "
                         "`touch_force_channel` in the detector config",
                         path=trial.path, where=f"{trial.where}/signals/{name}")
    return sig.t_s, sig.data[:, sig.channel_names.index(channel)].astype(np.float64)


@dataclass(frozen=True)
class TrialDetection:
    """The triggers of one trial and their scoring against its ground truth."""

    trial: str
    scenario: str
    vibration: Trigger
    force: Trigger | None
    contact_s: float | None = None
    touches: list[tuple[float, float]] = field(default_factory=list)
    summary: dict[str, Any] = field(default_factory=dict)


def _round(x: float | None, nd: int = 4) -> float | None:
    return None if x is None else round(float(x), nd)


def _score_contact(vib: Trigger, force: Trigger | None, contact_s: float | None,
                   cfg: DetectorConfig) -> dict[str, Any]:
    out: dict[str, Any] = {
        "vibration_events_s": [_round(a) for a, _ in vib.events],
        "force_events_s": [_round(a) for a, _ in force.events] if force else None,
        "contact_s": _round(contact_s)}
    if contact_s is None:
        return out
    v = vib.first_after(contact_s)
    f = force.first_after(contact_s) if force else None
    out.update({
        "vibration_s": _round(v), "force_s": _round(f),
        "vibration_delay_s": _round(None if v is None else v - contact_s),
        "force_delay_s": _round(None if f is None else f - contact_s),
        "vibration_false_alarms": vib.count_between(-np.inf, contact_s),
        "force_false_alarms": force.count_between(-np.inf, contact_s) if force else None,
        "vibration_snr": _round(vib.snr(contact_s, cfg.snr_window_s), 3),
        "force_snr": _round(force.snr(contact_s, cfg.snr_window_s), 3) if force else None,
        "lead_s": _round(None if v is None or f is None else f - v)})
    return out


def _score_touch(trigger: Trigger | None, touches: list[tuple[float, float]],
                 cfg: DetectorConfig) -> tuple[int, int]:
    """(hits, false alarms) of ``trigger`` against the presses ``touches``."""
    if trigger is None:
        return 0, 0
    starts = [a for a, _ in trigger.events]
    hits = sum(1 for a, b in touches if any(a <= s <= b + cfg.match_s for s in starts))
    false = sum(1 for s in starts if not any(a <= s <= b + cfg.match_s for a, b in touches))
    return hits, false


def detect_trial(trial: Trial, cfg: DetectorConfig) -> TrialDetection:
    """Run the triggers of ``trial``'s scenario and score them against its ground truth."""
    spectra, _ = trial_spectra(trial, cfg)
    labels = trial.labels
    scenario = str(labels.get("scenario", "contact"))
    if scenario not in ("contact", "touch"):
        raise InputError(f"trial label scenario is {scenario!r}; expected contact or touch",
                         path=trial.path, where=f"{trial.where}/labels")
    where = f"{trial.where}/signals"
    try:
        if scenario == "touch":
            _, peak_hz = band_peak(spectra.magnitude, spectra.f_hz, cfg.touch_band_hz,
                                   local=True)
            vib = threshold_trigger(spectra.t_s, peak_hz, calibration_s=cfg.calibration_s,
                                    average=cfg.touch_average_frames, threshold=cfg.touch_shift,
                                    relative=True, merge_s=cfg.merge_s)
            f = _force(trial, cfg.touch_force_channel)
            force = None if f is None else threshold_trigger(
                *f, calibration_s=cfg.calibration_s, average=cfg.force_average_samples,
                threshold=cfg.touch_force_n, merge_s=cfg.merge_s)
            touches = [(a.start_s, a.end_s) for a in trial.annotations if a.label == "touch"]
            v_hits, v_false = _score_touch(vib, touches, cfg)
            f_hits, f_false = _score_touch(force, touches, cfg)
            summary = {"n_touches": len(touches), "vibration_hits": v_hits,
                       "vibration_false_alarms": v_false,
                       "force_hits": f_hits if force else None,
                       "force_false_alarms": f_false if force else None,
                       "vibration_events_s": [_round(a) for a, _ in vib.events],
                       "force_events_s": [_round(a) for a, _ in force.events] if force else None,
                       "reference_hz": _round(vib.reference, 3)}
            return TrialDetection(trial.name, scenario, vib, force, None, touches, summary)
        amplitude, _ = band_peak(spectra.magnitude, spectra.f_hz, cfg.band_hz)
        vib = threshold_trigger(spectra.t_s, amplitude, calibration_s=cfg.calibration_s,
                                average=cfg.average_frames, factor=cfg.vibration_factor,
                                centre=False, merge_s=cfg.merge_s)
        f = _force(trial, cfg.force_channel)
        force = None if f is None else threshold_trigger(
            *f, calibration_s=cfg.calibration_s, average=cfg.force_average_samples,
            factor=cfg.force_factor, merge_s=cfg.merge_s)
    except ValueError as exc:
        raise InputError(str(exc), path=trial.path, where=where) from None
    contact = labels.get("contact_s")
    contact_s = float(contact) if isinstance(contact, int | float) else None
    return TrialDetection(trial.name, scenario, vib, force, contact_s, [],
                          _score_contact(vib, force, contact_s, cfg))


@dataclass(frozen=True)
class DetectionReport:
    """Every trial's detections and the totals over the file."""

    path: str
    config: dict[str, Any]
    trials: list[TrialDetection]

    def totals(self) -> dict[str, Any]:
        """Totals over the scored trials (the benchmark's keys and a few more)."""
        contact = [t.summary for t in self.trials
                   if t.scenario == "contact" and t.contact_s is not None]
        touch = [t.summary for t in self.trials if t.scenario == "touch"]

        def mean(key: str, rows: list[dict[str, Any]]) -> float | None:
            vals = [r[key] for r in rows if r.get(key) is not None]
            return round(float(np.mean(vals)), 4) if vals else None

        return {
            "n_contacts": len(contact),
            "vibration_detected": sum(r["vibration_s"] is not None for r in contact),
            "force_detected": sum(r["force_s"] is not None for r in contact),
            "false_alarms": sum(r["vibration_false_alarms"] for r in contact),
            "force_false_alarms": sum(r["force_false_alarms"] or 0 for r in contact),
            "vibration_snr": mean("vibration_snr", contact),
            "force_snr": mean("force_snr", contact),
            "mean_lead_s": mean("lead_s", contact),
            "mean_vibration_delay_s": mean("vibration_delay_s", contact),
            "mean_force_delay_s": mean("force_delay_s", contact),
            "n_touches": sum(r["n_touches"] for r in touch),
            "vibration_touch_hits": sum(r["vibration_hits"] for r in touch),
            "force_touch_hits": sum(r["force_hits"] or 0 for r in touch),
            "vibration_touch_false_alarms": sum(r["vibration_false_alarms"] for r in touch),
            "force_touch_false_alarms": sum(r["force_false_alarms"] or 0 for r in touch),
        }

    def as_dict(self) -> dict[str, Any]:
        return {"path": self.path, "config": self.config, "totals": self.totals(),
                "trials": [{"trial": t.trial, "scenario": t.scenario, **t.summary}
                           for t in self.trials]}


def detect_contacts(f: TactileFile, cfg: DetectorConfig, *,
                    trials: list[str] | None = None) -> DetectionReport:
    """Detect contacts and touches in the named trials of ``f`` (all by default)."""
    chosen = f.trials(trials)
    if not chosen:
        raise InputError("the file has no trials", path=f.path)
    return DetectionReport(str(f.path), cfg.model_dump(mode="json"),
                           [detect_trial(t, cfg) for t in chosen])


@dataclass(frozen=True)
class BandProposal:
    """The band-finder's answer: the best band, its score, and every band's score."""

    band_hz: tuple[float, float]
    score: float
    starts_hz: np.ndarray
    scores: np.ndarray
    n_recordings: int

    def as_dict(self) -> dict[str, Any]:
        top = np.argsort(self.scores)[::-1][:5]
        width = self.band_hz[1] - self.band_hz[0]
        return {"band_hz": [round(self.band_hz[0], 2), round(self.band_hz[1], 2)],
                "score": round(self.score, 3), "n_recordings": self.n_recordings,
                "runners_up": [{"band_hz": [round(float(self.starts_hz[i]), 2),
                                            round(float(self.starts_hz[i]) + width, 2)],
                                "score": round(float(self.scores[i]), 3)} for i in top[1:]]}


def find_band(f: TactileFile, cfg: DetectorConfig, *, width_hz: float | None = None,
              range_hz: tuple[float, float] = (50.0, 1200.0)) -> BandProposal:
    """Propose the most contact-sensitive band of ``width_hz`` (default: the width of
    ``cfg.band_hz``) inside ``range_hz`` from the file's contact trials that carry the label
    ``contact_s`` (see :func:`~tactile_cli.vibro.features.band_scores`)."""
    width = float(cfg.band_hz[1] - cfg.band_hz[0]) if width_hz is None else float(width_hz)
    if not width > 0:
        raise InputError(f"`width_hz` (={width_hz}) must be positive", path=f.path)
    amps, times, contacts = [], [], []
    f_hz = None
    for trial in f.trials():
        labels = trial.labels
        if str(labels.get("scenario", "contact")) != "contact" or \
                not isinstance(labels.get("contact_s"), int | float):
            continue
        spectra, _ = trial_spectra(trial, cfg)
        keep = (spectra.f_hz >= range_hz[0]) & (spectra.f_hz <= range_hz[1])
        amps.append(spectra.magnitude[:, keep])
        times.append(spectra.t_s)
        contacts.append(float(labels["contact_s"]))
        f_hz = spectra.f_hz[keep]
    if f_hz is None:
        raise InputError("no contact trial carries the label contact_s: the band-finder "
                         "needs labelled recordings (tactile simulate vibrotouch writes them)",
                         path=f.path)
    try:
        starts, scores = band_scores(amps, times, contacts, f_hz, width_hz=width,
                                     calibration_s=cfg.calibration_s,
                                     average=cfg.average_frames, window_s=cfg.snr_window_s)
    except ValueError as exc:
        raise InputError(str(exc), path=f.path) from None
    best = int(np.argmax(scores))
    lo = float(starts[best])
    return BandProposal((lo, lo + width), float(scores[best]), starts, scores, len(amps))


# -- the file-level verbs of the commands -----------------------------------------------------
def _figure_meta(inputs: list[Path], config: dict[str, Any]) -> dict[str, str]:
    from ..store.provenance import png_meta, provenance_record

    return png_meta(provenance_record(inputs, config))


def _check_plot(plot: str | Path | None, inputs: list[Path], *,
                overwrite: bool) -> Path | None:
    """The figure path of ``plot`` (``.png`` added when it has no suffix), checked before
    any work: not an input, writable, not there unless ``overwrite``."""
    from ..input_guard import check_outputs
    from ..store.atomic import check_output_file
    from .plots import figure_path

    if plot is None:
        check_outputs({}, inputs)
        return None
    target = figure_path(plot)
    check_outputs({"plot": target}, inputs)
    return check_output_file(target, overwrite=overwrite)


@dataclass(frozen=True)
class ModelFileResult:
    """What ``tactile vibro-model`` computed: the model config, its spectra (see
    :class:`~tactile_cli.vibro.model.ModelSpectra`) and the figure written, if any."""

    config_path: Path
    config: Any
    spectra: Any
    plot: Path | None = None

    def as_dict(self) -> dict[str, Any]:
        return {**self.spectra.as_dict(), "config": str(self.config_path),
                "plot": None if self.plot is None else str(self.plot)}

    def summary_lines(self) -> list[str]:
        cfg, out = self.config, self.as_dict()
        lines = [f"lumped model {self.config_path}: {len(cfg.blocks)} blocks, "
                 f"{len(cfg.contact)} contact links; |x_{cfg.sensor} / u_{cfg.source}| over "
                 f"{cfg.f_min_hz:g}-{cfg.f_max_hz:g} Hz"]
        for key, title in (("resonances_free", "no contact"), ("resonances_contact", "contact")):
            peaks = ", ".join(f"{r['f_hz']:.1f} Hz ({r['amplitude']:.3g})" for r in out[key])
            lines.append(f"  {title:>10}: {peaks or 'no resonance'}")
        for key, title in (("natural_free_hz", "no contact"), ("natural_contact_hz", "contact")):
            lines.append(f"  natural frequencies (Hz), {title:>10}: "
                         + ", ".join(f"{v:.1f}" for v in out[key]))
        return lines + ([f"  spectra -> {self.plot}"] if self.plot is not None else [])


def model_file(config: str | Path, *, plot: str | Path | None = None,
               overwrite: bool = False) -> ModelFileResult:
    """Solve the lumped model of the YAML file ``config`` (both spectra, resonances and
    natural frequencies) and, with ``plot``, draw Fig. 3A to that PNG (provenance in its
    text chunks)."""
    from .config import load_model_config
    from .model import model_spectra
    from .plots import plot_model_spectra

    config = Path(config)
    target = _check_plot(plot, [config], overwrite=overwrite)
    cfg = load_model_config(config)
    spectra = model_spectra(cfg)
    if target is not None:
        plot_model_spectra(spectra, target, overwrite=overwrite,
                           meta=_figure_meta([config], cfg.model_dump(mode="json")))
    return ModelFileResult(config, cfg, spectra, target)


@dataclass(frozen=True)
class ContactFileResult:
    """What ``tactile detect-contact FILE`` found: every trial's detections, the proposed
    band (``propose_band``) and the figure written, if any."""

    report: DetectionReport
    band: BandProposal | None = None
    plot: Path | None = None

    def as_dict(self) -> dict[str, Any]:
        return {**self.report.as_dict(),
                "band": None if self.band is None else self.band.as_dict(),
                "plot": None if self.plot is None else str(self.plot)}

    def table(self) -> tuple[str, list[str], list[list[str]]] | None:
        """Title, columns and rows of the contact trials (None without one)."""
        rows = [r for r in self.as_dict()["trials"] if r["scenario"] == "contact"]
        if not rows:
            return None
        cols = ["trial", "contact s", "vibration s", "force s", "lead s", "false alarms",
                "SNR vib", "SNR force"]
        return (f"contact detection, band {self.report.config['band_hz']} Hz", cols,
                [[r["trial"], _text(r.get("contact_s")), _text(r.get("vibration_s")),
                  _text(r.get("force_s")), _text(r.get("lead_s")),
                  str(r.get("vibration_false_alarms", "-")), _text(r.get("vibration_snr"), ".1f"),
                  _text(r.get("force_snr"), ".1f")] for r in rows])

    def summary_lines(self) -> list[str]:
        tot, lines = self.report.totals(), []
        if tot["n_contacts"]:
            lines.append(f"vibration detected {tot['vibration_detected']}/{tot['n_contacts']}, "
                         f"force {tot['force_detected']}/{tot['n_contacts']}; false alarms "
                         f"{tot['false_alarms']} (force {tot['force_false_alarms']}); SNR "
                         f"{_text(tot['vibration_snr'], '.1f')} vs "
                         f"{_text(tot['force_snr'], '.1f')}; vibration leads force by "
                         f"{_text(tot['mean_lead_s'], '.2f')} s on average")
        if tot["n_touches"]:
            lines.append(f"touches: vibration {tot['vibration_touch_hits']}/{tot['n_touches']} "
                         f"({tot['vibration_touch_false_alarms']} false), force "
                         f"{tot['force_touch_hits']}/{tot['n_touches']} "
                         f"({tot['force_touch_false_alarms']} false)")
        if self.band is not None:
            b = self.band.as_dict()
            lines.append(f"most contact-sensitive band: {b['band_hz'][0]:g}-"
                         f"{b['band_hz'][1]:g} Hz (score {b['score']}, {b['n_recordings']} "
                         "recordings)")
        return lines + ([f"figure -> {self.plot}"] if self.plot is not None else [])


def _text(v: float | None, spec: str = ".3f") -> str:
    return "-" if v is None else format(v, spec)


def detect_contact_file(path: str | Path, *, config: str | Path | None = None,
                        band_hz: tuple[float, float] | None = None,
                        trials: list[str] | None = None, plot: str | Path | None = None,
                        propose_band: bool = False, band_width_hz: float | None = None,
                        overwrite: bool = False) -> ContactFileResult:
    """:func:`detect_contacts` on the tactile file ``path`` with the detector of ``config``
    (default: the paper's) and ``band_hz``; with ``propose_band`` the band-finder's answer
    (bands of ``band_width_hz``); with ``plot`` the Figs. 5-6 page as a PNG."""
    from .config import detector_config
    from .plots import plot_detections

    path = Path(path)
    inputs = [path] + ([Path(config)] if config is not None else [])
    target = _check_plot(plot, inputs, overwrite=overwrite)
    cfg = detector_config(config, band_hz=band_hz)
    if band_width_hz is not None and not (np.isfinite(band_width_hz) and band_width_hz > 0):
        raise InputError(f"`band_width_hz` (={band_width_hz}) must be a positive width in Hz")
    with TactileFile(path) as f:
        report = detect_contacts(f, cfg, trials=trials)
        proposal = find_band(f, cfg, width_hz=band_width_hz) if propose_band else None
    if target is not None:
        plot_detections(report, target, overwrite=overwrite,
                        meta=_figure_meta(inputs, report.config))
    return ContactFileResult(report, proposal, target)


@dataclass(frozen=True)
class SamplesResult:
    """The accelerometer samples of one trial written as the text ``--follow`` reads."""

    trial: str
    n_samples: int
    sample_rate_hz: float
    out: Path

    def as_dict(self) -> dict[str, Any]:
        return {"trial": self.trial, "n_samples": self.n_samples,
                "sample_rate_hz": self.sample_rate_hz, "out": str(self.out)}

    def summary_lines(self) -> list[str]:
        return [f"{self.trial}: {self.n_samples} samples at {self.sample_rate_hz:g} Hz -> "
                f"{self.out}"]


def write_trial_samples(path: str | Path, out: str | Path, *, trial: str | None,
                        overwrite: bool = False) -> SamplesResult:
    """The first accelerometer channel of ``trial`` in the tactile file ``path`` written to
    ``out`` as text, one value (g) per line: a recording to replay through
    :func:`~tactile_cli.vibro.stream.follow_input`."""
    from ..input_guard import check_outputs
    from ..store.atomic import check_output_file
    from .stream import write_samples

    path, out = Path(path), Path(out)
    check_outputs({"out": out}, [path])
    check_output_file(out, overwrite=overwrite)
    if not trial:
        raise InputError("name one trial with `trial` to write its samples", path=path)
    with TactileFile(path) as f:
        t = f.trial(trial)
        name = _stream(t, VIBRATION_KINDS)
        if name is None:
            raise InputError("trial has no accelerometer stream", path=path, where=t.where)
        sig = t.signal(name)
        write_samples(sig.data[:, 0], out, overwrite=overwrite)
    return SamplesResult(t.name, int(sig.data.shape[0]), float(sig.sample_rate_hz), out)
