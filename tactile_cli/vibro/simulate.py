"""``tactile simulate vibrotouch``: paper 003's test bench as a tactile HDF5 file with its
ground truth (secs. 2.3-2.4).

The accelerometer (2.5 kHz) and the force/torque sensor (1 kHz) run at rates no common
sample grid holds, so the scene writes the store directly through
:class:`~tactile_cli.store.writer.StoreWriter` (validated, atomic) instead of a raw format
for ``tactile ingest``. Two kinds of trial, each labelled ``origin=simulated``,
``dataset=vibrotouch seed <seed>`` and ``scenario``:

- ``contact_<k>`` (sec. 2.4.1): still for ``calibration_s`` (the detectors' calibration
  buffer), then the gripper closes at 0.01 mm/s, shaking the fingers with its drive's
  vibration, until one fingertip touches the object (a light link of stiffness
  ``k_light``), the other one a moment later; from then on both press in and the links
  stiffen with depth. Annotation ``contact`` from the first touch to the end; labels
  ``contact_s``, ``second_contact_s``, ``first_finger`` (``actuating`` or ``sensing``,
  Fig. 5E-F), ``light_stiffness_n_m``.
- ``touch_<k>`` (sec. 2.4.2): the object held at the 1 N grip; a human presses it
  ``touches_per_trial`` times, each press a link from the object to the ground whose
  stiffness follows the press force. Annotations ``touch`` (start, end of each press).

Accelerometer: the ERM's displacement (fundamental near 130 Hz wandering slowly, its
harmonics and a broadband buzz) filtered by the lumped model of
:mod:`tactile_cli.vibro.model` in the contact state of the moment (updated every
``state_step_s`` and crossfaded), plus the gripper's drive vibration while it moves, sensor
noise and 3.9 mg quantisation; stream ``accel`` (channel ``a_x``, g). Force: ``f_z`` the
squeeze on the sensing fingertip (contact trials) or the grip (touch trials), ``f_y`` the
share of a press that reaches the sensor, both with sensor noise; stream ``force`` (N).

Left out: the gripper's own position loop, nonlinear skin damping, the object's rocking,
the ADXL345's packetised timing and any drift of the force sensor's offset.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import check_seed
from ..interrupt import raise_if_requested
from ..progress import NullProgress, Progress
from ..store.provenance import current_command
from ..store.writer import StoreWriter
from .config import LinkConfig, VibroTouchSceneConfig
from .model import assemble, frequency_response

G_M_S2 = 9.80665
ACCEL_STREAM, FORCE_STREAM = "accel", "force"
ACCEL_CHANNEL = "a_x"
FORCE_CHANNELS = ("f_y", "f_z")
#: Frequency grid (Hz) on which the model is solved before interpolation to the FFT grid.
_MODEL_STEP_HZ = 0.25


@dataclass(frozen=True)
class SceneTrial:
    """One simulated trial: ``accel_g`` (n_a,), ``force_n`` (n_f, 2) [f_y, f_z], their
    rates, the annotations and the labels (ground truth)."""

    name: str
    accel_g: np.ndarray
    force_n: np.ndarray
    accel_rate_hz: float
    force_rate_hz: float
    annotations: list[tuple[float, float, str]]
    labels: dict[str, Any] = field(default_factory=dict)


def _erm_displacement_m(cfg: VibroTouchSceneConfig, n: int, rng: np.random.Generator) -> np.ndarray:
    """(n,) motor displacement: wandering fundamental, harmonics and broadband buzz (m)."""
    from scipy.signal import butter, sosfiltfilt

    fs = cfg.accel_rate_hz
    wander = rng.standard_normal(n)
    sos = butter(2, min(2.0, 0.4 * fs / 2), fs=fs, output="sos")  # slower than 2 Hz
    wander = sosfiltfilt(sos, wander)
    wander *= cfg.erm_jitter / max(float(wander.std()), 1e-12)
    phase = 2 * np.pi * np.cumsum(cfg.erm_hz * (1 + wander)) / fs
    u = np.zeros(n)
    for h, amp in enumerate(cfg.erm_harmonics, start=1):
        if h * cfg.erm_hz < 0.45 * fs:
            u += amp * np.sin(h * phase + rng.uniform(0, 2 * np.pi))
    u *= cfg.erm_um * 1e-6
    return u + cfg.buzz_um * 1e-6 * rng.standard_normal(n)


def _motion_vibration_g(cfg: VibroTouchSceneConfig, moving: np.ndarray,
                        rng: np.random.Generator) -> np.ndarray:
    """(n,) the gripper drive's band-limited vibration where ``moving`` (n,) is 1 (g)."""
    from scipy.signal import butter, sosfilt

    if cfg.motion_noise_g == 0:
        return np.zeros(len(moving))
    fs = cfg.accel_rate_hz
    sos = butter(4, cfg.motion_band_hz, btype="bandpass", fs=fs, output="sos")
    x = sosfilt(sos, rng.standard_normal(len(moving) + int(fs)))[int(fs):]
    x *= cfg.motion_noise_g / max(float(x.std()), 1e-12)
    return x * moving


def _respond_g(cfg: VibroTouchSceneConfig, u_m: np.ndarray, states: np.ndarray) -> np.ndarray:
    """(n,) accelerometer response (g) to the motor displacement ``u_m`` (n,) with the
    contact stiffnesses ``states`` (n_steps, 3) [actuating, sensing, human] N/m, one row
    per ``state_step_s``, crossfaded linearly between rows."""
    fs = cfg.accel_rate_hz
    n = len(u_m)
    spectrum = np.fft.rfft(u_m)
    f_fft = np.fft.rfftfreq(n, 1 / fs)
    f_grid = np.arange(0.0, fs / 2 + _MODEL_STEP_HZ, _MODEL_STEP_HZ)
    model_cfg = cfg.model.model_copy(update={"contact": [
        *cfg.model.contact,
        LinkConfig(between=("object", "ground"), stiffness_n_m=1.0, damping_n_s_m=0.0)]})
    # quantise the states (2 % in stiffness) so a slow squeeze needs few model solves
    q = np.where(states > 0, np.round(np.log(np.maximum(states, 1e-9)) / 0.02), -1e9)
    keys, inverse = np.unique(q, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    outputs = np.empty((len(keys), n))
    w2 = (2 * np.pi * f_fft) ** 2
    for i, key in enumerate(keys):
        raise_if_requested()
        stiff = np.where(key > -1e8, np.exp(key * 0.02), 0.0)
        h = frequency_response(assemble(model_cfg, contact=list(stiff)), f_grid)
        h_fft = np.interp(f_fft, f_grid, h.real) + 1j * np.interp(f_fft, f_grid, h.imag)
        outputs[i] = np.fft.irfft(-w2 * h_fft * spectrum, n=n) / G_M_S2
    step = int(round(cfg.state_step_s * fs))
    k = np.arange(n) // step
    w = (np.arange(n) % step) / step
    k0 = np.minimum(k, len(inverse) - 1)
    k1 = np.minimum(k + 1, len(inverse) - 1)
    cols = np.arange(n)
    return (1 - w) * outputs[inverse[k0], cols] + w * outputs[inverse[k1], cols]


def _sensor_g(cfg: VibroTouchSceneConfig, a_g: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    x = a_g + cfg.accel_noise_g * rng.standard_normal(len(a_g))
    if cfg.accel_lsb_g > 0:
        x = np.round(x / cfg.accel_lsb_g) * cfg.accel_lsb_g
    return x


def simulate_contact_trial(cfg: VibroTouchSceneConfig, k: int, seed: int) -> SceneTrial:
    """One gripper-object trial (sec. 2.4.1); see the module docstring."""
    rng = np.random.default_rng([seed, 1, k])
    fs, ff = cfg.accel_rate_hz, cfg.force_rate_hz
    gap_mm = float(rng.uniform(*cfg.gap_mm))
    t_c1 = cfg.calibration_s + gap_mm / cfg.closing_mm_s
    t_c2 = t_c1 + float(rng.uniform(*cfg.second_contact_s))
    first = "sensing" if rng.random() < 0.5 else "actuating"
    k_light = cfg.light_stiffness_n_m * float(np.exp(cfg.light_spread * rng.standard_normal()))
    duration = t_c1 + cfg.after_contact_s
    n = int(round(duration * fs))
    speed_m_s = cfg.closing_mm_s * 1e-3

    def links(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        depth = np.where(t >= t_c2, 0.5 * speed_m_s * (t - t_c2), 0.0)  # each fingertip
        both = k_light + cfg.stiffening_n_m2 * depth
        one = np.where(t >= t_c1, k_light, 0.0)
        k_first = np.where(t >= t_c2, both, one)
        k_second = np.where(t >= t_c2, both, 0.0)
        k_act, k_sens = (k_second, k_first) if first == "sensing" else (k_first, k_second)
        force = k_light * depth + 0.5 * cfg.stiffening_n_m2 * depth ** 2
        return k_act, k_sens, force

    t_steps = np.arange(int(np.ceil(duration / cfg.state_step_s)) + 1) * cfg.state_step_s
    k_act, k_sens, _ = links(t_steps)
    states = np.column_stack([k_act, k_sens, np.zeros_like(k_act)])
    u = _erm_displacement_m(cfg, n, rng)
    t_a = np.arange(n) / fs
    moving = np.clip((t_a - cfg.calibration_s) / 0.1, 0, 1)
    accel = _respond_g(cfg, u, states) + _motion_vibration_g(cfg, moving, rng)
    accel = _sensor_g(cfg, accel, rng)
    t_f = np.arange(int(round(duration * ff))) / ff
    _, _, f_z = links(t_f)
    noise = cfg.force_noise_n * rng.standard_normal((len(t_f), 2))
    force = np.column_stack([np.zeros_like(f_z), f_z]) + noise
    labels = {"scenario": "contact", "contact_s": round(t_c1, 6),
              "second_contact_s": round(t_c2, 6), "first_finger": first,
              "light_stiffness_n_m": round(k_light, 3), "gap_mm": round(gap_mm, 6)}
    return SceneTrial(f"contact_{k:02d}", accel, force, fs, ff,
                      [(0.0, cfg.calibration_s, "calibration"),
                       (t_c1, duration, "contact")], labels)


def simulate_touch_trial(cfg: VibroTouchSceneConfig, k: int, seed: int) -> SceneTrial:
    """One grasped object-human trial (sec. 2.4.2); see the module docstring."""
    rng = np.random.default_rng([seed, 2, k])
    fs, ff = cfg.accel_rate_hz, cfg.force_rate_hz
    presses = []
    t = cfg.calibration_s + float(rng.uniform(*cfg.touch_gap_s))
    for _ in range(cfg.touches_per_trial):
        length = float(rng.uniform(*cfg.touch_s))
        presses.append((t, t + length, float(rng.uniform(*cfg.touch_n))))
        t += length + float(rng.uniform(*cfg.touch_gap_s))
    duration = t
    n = int(round(duration * fs))

    def press_force(times: np.ndarray) -> np.ndarray:
        out = np.zeros_like(times)
        for start, end, peak in presses:
            inside = (times >= start) & (times < end)
            out[inside] += peak * np.sin(np.pi * (times[inside] - start) / (end - start)) ** 2
        return out

    # the grip's contact stiffness: k_light + s depth at the depth that holds grip_n
    s, kl = cfg.stiffening_n_m2, cfg.light_stiffness_n_m
    depth = ((-kl + np.sqrt(kl ** 2 + 2 * s * cfg.grip_n)) / s) if s > 0 else cfg.grip_n / kl
    k_grip = kl + s * depth
    t_steps = np.arange(int(np.ceil(duration / cfg.state_step_s)) + 1) * cfg.state_step_s
    k_h = cfg.touch_stiffness_n_m_per_n * press_force(t_steps)
    states = np.column_stack([np.full_like(k_h, k_grip), np.full_like(k_h, k_grip), k_h])
    u = _erm_displacement_m(cfg, n, rng)
    accel = _sensor_g(cfg, _respond_g(cfg, u, states), rng)
    t_f = np.arange(int(round(duration * ff))) / ff
    noise = cfg.force_noise_n * rng.standard_normal((len(t_f), 2))
    force = np.column_stack([cfg.touch_force_fraction * press_force(t_f),
                             np.full_like(t_f, cfg.grip_n)]) + noise
    labels = {"scenario": "touch", "grip_n": cfg.grip_n, "n_touches": len(presses),
              "grip_stiffness_n_m": round(float(k_grip), 3)}
    ann = [(0.0, cfg.calibration_s, "calibration")] + [(a, b, "touch") for a, b, _ in presses]
    return SceneTrial(f"touch_{k:02d}", accel, force, fs, ff, ann, labels)


@dataclass(frozen=True)
class VibroTouchResult:
    """What :func:`simulate_vibrotouch` wrote: the file, the seed, each trial's truth."""

    out: Path
    seed: int
    trials: tuple[dict[str, Any], ...]
    duration_s: float
    elapsed_s: float

    def as_dict(self) -> dict[str, Any]:
        return {"out": str(self.out), "seed": self.seed, "n_trials": len(self.trials),
                "duration_s": round(self.duration_s, 3), "elapsed_s": round(self.elapsed_s, 3),
                "trials": list(self.trials)}

    def summary_lines(self) -> list[str]:
        scen = [t["scenario"] for t in self.trials]
        return [f"vibrotouch -> {self.out} (seed {self.seed}): {scen.count('contact')} contact "
                f"and {scen.count('touch')} touch trials, {self.duration_s:.1f} s in all, "
                f"simulated in {self.elapsed_s:.1f} s"]


def simulate_vibrotouch(cfg: VibroTouchSceneConfig, out: str | Path, *, seed: int,
                        progress: Progress | None = None, overwrite: bool = False,
                        command: str | None = None,
                        sources: Sequence[str | Path] = ()) -> VibroTouchResult:
    """Simulate every trial of ``cfg`` and write the tactile HDF5 file ``out``; ``sources``
    (the config file, say) are recorded with their SHA-256 as the file's inputs.

    ``seed`` (>= 0) fixes every sample. Raises :class:`InputError` when ``out`` exists and
    ``overwrite`` is false, or is a folder; nothing is left behind when the run fails.
    """
    started = time.perf_counter()
    progress = progress or NullProgress()
    seed = check_seed(seed)
    jobs = [(simulate_contact_trial, k) for k in range(cfg.contact_trials)] + \
           [(simulate_touch_trial, k) for k in range(cfg.touch_trials)]
    truths: list[dict[str, Any]] = []
    total = 0.0
    provenance = {"scene": cfg.model_dump(mode="json"), "seed": seed}
    try:
        with StoreWriter(out, command=command or current_command(), config=provenance,
                         overwrite=overwrite) as w:
            source_index = [w.add_source(p) for p in sources]
            w.add_sensor(ACCEL_STREAM, kind="vibro_active", sample_rate_hz=cfg.accel_rate_hz,
                         channel_names=[ACCEL_CHANNEL], channel_units="g",
                         description="simulated ADXL345 in the sensing fingertip; ERM in "
                         f"the other one near {cfg.erm_hz:g} Hz (paper 003)")
            w.add_sensor(FORCE_STREAM, kind="force_torque", sample_rate_hz=cfg.force_rate_hz,
                         channel_names=list(FORCE_CHANNELS), channel_units="N",
                         description="simulated HEX21 under the sensing fingertip: f_z grip "
                         "axis, f_y press axis")
            progress.start(len(jobs), "vibrotouch trials")
            for fn, k in jobs:
                raise_if_requested()
                trial = fn(cfg, k, seed)
                labels = {"origin": "simulated", "dataset": f"vibrotouch seed {seed}",
                          **trial.labels}
                tw = w.trial(trial.name, labels=labels, annotations=trial.annotations,
                             sources=source_index)
                tw.write_signal(ACCEL_STREAM, sensor=ACCEL_STREAM, data=trial.accel_g[:, None],
                                t_s=np.arange(len(trial.accel_g)) / trial.accel_rate_hz)
                tw.write_signal(FORCE_STREAM, sensor=FORCE_STREAM, data=trial.force_n,
                                t_s=np.arange(len(trial.force_n)) / trial.force_rate_hz)
                duration = len(trial.accel_g) / trial.accel_rate_hz
                total += duration
                truths.append({"trial": trial.name, "duration_s": round(duration, 3),
                               **trial.labels,
                               "touches": [[round(a, 4), round(b, 4)]
                                           for a, b, lab in trial.annotations
                                           if lab == "touch"]})
                progress.advance(1)
            path = w.commit()
    finally:
        progress.finish()
    return VibroTouchResult(path, seed, tuple(truths), total, time.perf_counter() - started)
