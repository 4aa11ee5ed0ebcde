"""``tactile simulate taxel-slip``: paper 004's slip experiments (sec. 4) as one tactile
HDF5 file with its ground truth.

Each trial holds an object in ``fingers`` fingertips of one sensor preset: at rest without
contact for ``rest_s`` (the noise reference of contact estimation), then in contact and
slipping for ``slip_s``. Its label ``slip`` says where:

- ``hand`` (object/hand slip): every contact of the skin's texture elements sticks and
  slips on its own, so each taxel mostly senses an independent stick-slip source; fingers
  are independent too;
- ``world`` (object/world slip): the object rubs against something else; one vibration
  source (stick-slip at that interface, coloured by the object's own ringing) reaches
  every taxel of every finger through the taxel's own linear path (gain, delay, low pass).

A stick-slip source is a train of impulses, one per texture period of travel
(``period_mm``) with random size (``roughness``), at the speed of the moment (nominal speed
drawn per trial, wandering slowly by ``speed_jitter``: manual motion), ringing at the
skin's texture mode (hand) or the object's mode (world). Each trial also carries the other
slip type's vibration, at an amplitude drawn up to ``mix`` (relative). Per finger: a
contact patch of ``contact_fraction`` of the taxels (taxels outside it sense a tenth),
crosstalk along a 1-D chain of taxels (``crosstalk ** distance``), the taxel's bandwidth (4th-order
low pass), a static response to the grip (``static_per_n``), the conversion slots of
sequential sampling (taxel i read ``delays_s[i]`` after the period starts; the sensor's
``channel_delays_s``) and white sensor noise. The BioTac preset adds one AC
fluid-pressure channel per finger at 4.4 kHz (the contact taxels' inputs summed, 10 Hz
high pass), simultaneous across fingers.

Amplitudes scale with roughness, the square root of grip / mid-range grip and of speed /
3.5 cm/s. Not modelled: the skin's contact mechanics (friction laws, Hertzian contact,
the fluid of a BioTac), object rotation in a flat-on-flat grasp (the cause of the inverted
Gamma of the paper's capacitive sensor, sec. 5.2.2), aliasing beyond the 4th-order low
pass, wear, drift and temperature.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import check_seed
from ..interrupt import raise_if_requested
from ..progress import NullProgress, Progress
from ..store.provenance import current_command
from ..store.writer import StoreWriter
from .config import SLIP_TYPES, PresetConfig, TaxelSceneConfig

#: Trial label values; the annotations of every trial.
REST, SLIP = "rest", "slip"


def taxel_stream(preset: str, finger: int) -> str:
    """Stream (and sensor) name of a preset's taxel array on finger ``finger``."""
    return f"{preset}_f{finger}"


def pressure_stream(preset: str) -> str:
    """Stream (and sensor) name of a preset's fluid-pressure channels (one per finger)."""
    return f"{preset}_pressure"


def channel_names(n_taxels: int) -> list[str]:
    return [f"taxel_{i:02d}" for i in range(n_taxels)]


@dataclass(frozen=True)
class SceneTrial:
    """One simulated trial: ``taxels`` per finger (n_samples, n_taxels) at the preset's
    rate, ``pressure`` (n_p, fingers) or None, the labels (ground truth)."""

    name: str
    preset: str
    taxels: list[np.ndarray]
    pressure: np.ndarray | None
    labels: dict[str, Any] = field(default_factory=dict)


def _slow_noise(n: int, fs: float, corner_hz: float, rng: np.random.Generator,
                k: int = 1) -> np.ndarray:
    """(n, k) unit-variance noise slower than ``corner_hz``."""
    from scipy.signal import butter, sosfiltfilt

    x = rng.standard_normal((n, k))
    sos = butter(2, min(corner_hz, 0.4 * fs), fs=fs, output="sos")
    x = sosfiltfilt(sos, x, axis=0)
    return x / np.maximum(x.std(axis=0, keepdims=True), 1e-12)


def _stick_slip(speed_m_s: np.ndarray, fs: float, period_m: float, roughness: float,
                mode_hz: float, k: int, rng: np.random.Generator) -> np.ndarray:
    """(n, k) independent stick-slip sources at the speed profile ``speed_m_s`` (n,):
    one impulse per texture period of travel (each source with its own timing jitter and
    phase), random sizes, ringing at ``mode_hz``; unit-free, roughly unit RMS."""
    from scipy.signal import butter, sosfilt

    n = len(speed_m_s)
    wobble = 1.0 + 0.2 * _slow_noise(n, fs, 5.0, rng, k)
    travel = np.cumsum(speed_m_s[:, None] * wobble, axis=0) / fs / period_m  # periods
    travel += rng.uniform(0, 1, k)
    events = np.diff(np.floor(travel), axis=0, prepend=np.floor(travel[:1]))
    imp = events * roughness * (0.5 + np.abs(rng.standard_normal((n, k))))
    nyq = fs / 2
    lo, hi = mode_hz / 1.3, min(mode_hz * 1.3, 0.95 * nyq)
    ring = sosfilt(butter(2, (lo, hi) if lo < hi else 0.9 * nyq,
                          btype="bandpass" if lo < hi else "lowpass", fs=fs, output="sos"),
                   imp, axis=0)
    broad = sosfilt(butter(2, min(3 * mode_hz, 0.9 * nyq), fs=fs, output="sos"), imp, axis=0)
    rub = sosfilt(butter(2, min(2 * mode_hz, 0.9 * nyq), fs=fs, output="sos"),
                  rng.standard_normal((n, k)), axis=0) * 0.3 * roughness
    x = ring + 0.5 * broad + rub
    return x / max(float(x.std()), 1e-12)


def _paths(common: np.ndarray, fs: float, n_taxels: int, bandwidth_hz: float,
           rng: np.random.Generator) -> np.ndarray:
    """(n, n_taxels) one source (n,) through each taxel's linear path: gain 0.6-1.4, delay
    up to 0.3 ms, a first-order low pass at 0.5-2 x the taxel bandwidth."""
    n = len(common)
    f = np.fft.rfftfreq(n, 1 / fs)
    gain = rng.uniform(0.6, 1.4, n_taxels)
    delay = rng.uniform(0.0, 3e-4, n_taxels)
    corner = bandwidth_hz * rng.uniform(0.5, 2.0, n_taxels)
    h = gain * np.exp(-2j * np.pi * f[:, None] * delay) / (1 + 1j * f[:, None] / corner)
    return np.fft.irfft(np.fft.rfft(common)[:, None] * h, n=n, axis=0)


def _crosstalk(n_taxels: int, level: float) -> np.ndarray:
    """(N, N) mixing of a 1-D chain: a taxel senses ``level ** d`` of the input ``d``
    taxels away, rows normalised to 1."""
    i = np.arange(n_taxels)
    k = float(level) ** np.abs(i[:, None] - i[None, :])
    return k / k.sum(axis=1, keepdims=True)


def simulate_trial(cfg: TaxelSceneConfig, preset_name: str, slip: str, k: int,
                   seed: int) -> SceneTrial:
    """One trial of ``preset_name`` with slip type ``slip`` (hand or world); see the module
    docstring. ``seed`` and ``k`` fix every sample."""
    from scipy.signal import butter, sosfilt

    p: PresetConfig = cfg.preset[preset_name]
    rng = np.random.default_rng([seed, 4, list(cfg.preset).index(preset_name),
                                 SLIP_TYPES.index(slip), k])
    fs = p.slot_hz
    n = int(round((cfg.rest_s + cfg.slip_s) * p.rate_hz)) * p.slots_per_sample
    t = np.arange(n) / fs
    envelope = np.clip((t - cfg.rest_s) / 0.05, 0.0, 1.0)
    texture = list(cfg.textures)[int(rng.integers(len(cfg.textures)))]
    tex = cfg.textures[texture]
    grip = float(rng.uniform(*p.grip_n))
    speed_cm_s = float(rng.uniform(*p.speed_cm_s))
    speed = speed_cm_s * 1e-2 * np.clip(
        1 + cfg.speed_jitter * _slow_noise(n, fs, 3.0, rng)[:, 0], 0.2, None)
    amp = p.vibration * tex.roughness * np.sqrt(grip / np.mean(p.grip_n)) \
        * np.sqrt(speed_cm_s / 3.5)
    object_mode = float(np.exp(rng.uniform(np.log(10.0), np.log(0.8 * p.bandwidth_hz))))
    common = _stick_slip(speed, fs, tex.period_mm * 1e-3, tex.roughness, object_mode, 1,
                         rng)[:, 0]
    other = float(rng.uniform(0.0, cfg.mix))
    local_amp, common_amp = (1.0, other) if slip == "hand" else (other, 1.0)
    n_contact = max(1, int(round(p.contact_fraction * p.n_taxels)))
    mix = _crosstalk(p.n_taxels, p.crosstalk if cfg.crosstalk is None else cfg.crosstalk)
    lowpass = butter(4, min(p.bandwidth_hz, 0.45 * fs), fs=fs, output="sos")
    delays_slots = np.round(p.delays_s() * fs).astype(int)
    periods = np.arange(n // p.slots_per_sample) * p.slots_per_sample
    noise = p.noise * cfg.noise_scale
    taxels, pressure_in = [], []
    for _ in range(cfg.fingers):
        local = _stick_slip(speed, fs, tex.period_mm * 1e-3, tex.roughness, p.texture_mode_hz,
                            p.n_taxels, rng)
        paths = _paths(common, fs, p.n_taxels, p.bandwidth_hz, rng)
        start = int(rng.integers(0, p.n_taxels - n_contact + 1))
        in_contact = np.full(p.n_taxels, 0.1)
        in_contact[start:start + n_contact] = 1.0
        u = amp * envelope[:, None] * in_contact * (local_amp * local + common_amp * paths)
        pressure_in.append(u[:, in_contact == 1.0].sum(axis=1))
        sensed = sosfilt(lowpass, u @ mix.T, axis=0)
        static = p.static_per_n * grip * envelope[:, None] * (in_contact == 1.0)
        sensed = sensed + static + rng.normal(0, 1.0, p.n_taxels)  # per-taxel baseline
        rows = periods[:, None] + delays_slots[None, :]
        sampled = np.take_along_axis(sensed, rows, axis=0)
        taxels.append(sampled + noise * rng.standard_normal(sampled.shape))
    pressure = None
    if p.pressure_rate_hz is not None:
        step = int(round(fs / p.pressure_rate_hz))
        hp = butter(2, 10.0, btype="highpass", fs=fs, output="sos")
        pac = sosfilt(hp, np.column_stack(pressure_in), axis=0)[::max(step, 1)]
        pressure = pac / np.sqrt(n_contact) + noise * rng.standard_normal(pac.shape)
    labels = {"preset": preset_name, "slip": slip, "texture": texture,
              "grip_n": round(grip, 4), "speed_cm_s": round(speed_cm_s, 4),
              "object_mode_hz": round(object_mode, 3), "contact_taxels": n_contact}
    return SceneTrial(f"{preset_name}_{slip}_{k:03d}", preset_name, taxels, pressure, labels)


@dataclass(frozen=True)
class TaxelSlipResult:
    """What :func:`simulate_taxel_slip` wrote: the file, the seed, trial counts."""

    out: Path
    seed: int
    counts: dict[str, dict[str, int]]
    duration_s: float
    elapsed_s: float

    def as_dict(self) -> dict[str, Any]:
        return {"out": str(self.out), "seed": self.seed, "trials": self.counts,
                "n_trials": sum(sum(c.values()) for c in self.counts.values()),
                "duration_s": round(self.duration_s, 3), "elapsed_s": round(self.elapsed_s, 3)}

    def summary_lines(self) -> list[str]:
        counts = ", ".join(f"{p} {c['hand']}+{c['world']}" for p, c in self.counts.items())
        return [f"taxel-slip -> {self.out} (seed {self.seed}): "
                f"{sum(sum(c.values()) for c in self.counts.values())} trials ({counts} "
                f"hand+world), simulated in {self.elapsed_s:.1f} s"]


def simulate_taxel_slip(cfg: TaxelSceneConfig, out: str | Path, *, seed: int,
                        progress: Progress | None = None, overwrite: bool = False,
                        command: str | None = None) -> TaxelSlipResult:
    """Simulate ``trials_per_class`` object/hand and object/world trials of every preset in
    ``cfg.presets`` and write the tactile HDF5 file ``out`` (atomic, validated).

    Streams per preset: ``<preset>_f<k>`` (the taxels of finger k, the sensor's
    ``channel_delays_s`` giving each taxel's sampling delay) and, for the BioTac,
    ``biotac_pressure``. Trial labels ``origin=simulated``, ``dataset=taxel-slip seed
    <seed>``, ``preset``, ``slip`` (hand/world), texture, grip, speed; annotations ``rest``
    and ``slip``. Raises :class:`InputError` for a bad ``seed`` or an existing ``out``
    without ``overwrite``.
    """
    started = time.perf_counter()
    progress = progress or NullProgress()
    seed = check_seed(seed)
    jobs = [(p, s, k) for p in cfg.presets for s in SLIP_TYPES
            for k in range(cfg.trials_per_class)]
    counts: dict[str, dict[str, int]] = {p: dict.fromkeys(SLIP_TYPES, 0) for p in cfg.presets}
    provenance = {"scene": cfg.model_dump(mode="json"), "seed": seed}
    duration = cfg.rest_s + cfg.slip_s
    try:
        with StoreWriter(out, command=command or current_command(), config=provenance,
                         overwrite=overwrite) as w:
            for name in cfg.presets:
                p = cfg.preset[name]
                delays = p.delays_s()
                for finger in range(cfg.fingers):
                    w.add_sensor(taxel_stream(name, finger), kind="taxel_array",
                                 sample_rate_hz=p.rate_hz, channel_names=channel_names(
                                     p.n_taxels), channel_units=p.units,
                                 channel_delays_s=delays, preset=name, finger=finger,
                                 sampling="sequential" if p.sequential else "simultaneous",
                                 channel_delay_first_s=float(delays[0]),
                                 channel_delay_step_s=float(delays[1] - delays[0]),
                                 description=f"simulated {name} taxel array, finger "
                                 f"{finger} (paper 004)")
                if p.pressure_rate_hz is not None:
                    w.add_sensor(pressure_stream(name), kind="pressure",
                                 sample_rate_hz=p.pressure_rate_hz,
                                 channel_names=[f"f{k}" for k in range(cfg.fingers)],
                                 channel_units=p.units, preset=name, sampling="simultaneous",
                                 description=f"simulated {name} AC fluid pressure, one per "
                                 "finger")
            progress.start(len(jobs), "taxel-slip trials")
            for name, slip, k in jobs:
                raise_if_requested()
                trial = simulate_trial(cfg, name, slip, k, seed)
                p = cfg.preset[name]
                labels = {"origin": "simulated", "dataset": f"taxel-slip seed {seed}",
                          **trial.labels}
                tw = w.trial(trial.name, labels=labels,
                             annotations=[(0.0, cfg.rest_s, REST),
                                          (cfg.rest_s, duration, SLIP)])
                for finger, data in enumerate(trial.taxels):
                    tw.write_signal(taxel_stream(name, finger),
                                    sensor=taxel_stream(name, finger), data=data,
                                    t_s=np.arange(len(data)) / p.rate_hz)
                if trial.pressure is not None:
                    tw.write_signal(pressure_stream(name), sensor=pressure_stream(name),
                                    data=trial.pressure,
                                    t_s=np.arange(len(trial.pressure)) / p.pressure_rate_hz)
                counts[name][slip] += 1
                progress.advance(1)
            path = w.commit()
    finally:
        progress.finish()
    return TaxelSlipResult(path, seed, counts, duration * len(jobs),
                           time.perf_counter() - started)
