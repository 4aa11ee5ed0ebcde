"""``tactile simulate vibro-slip``: the slip-slide rig of paper 001 as the CSV tree its
dataset uses, with the ground truth beside it.

One recording per texture x gripper angle x motor speed (3 x 4 x 3 = 36 by default), each
``duration_s`` long at 8 kHz, written as::

    OUT/<texture>/<angle>/<motor rps>/data.csv   header L_x,L_y,L_z,R_x,R_y,R_z,v_slip,v_slide
    OUT/scene.json                               config, seed, command, per-recording truth

The six accelerations are acceleration / 5 g in [-1, 1], the velocities m/s (sec. 4), so
``tactile ingest OUT --format accel-tree`` reads the folder unchanged (scene.json is not a
CSV and is ignored by the tree reader).

What is modelled (details in :mod:`.kinematics` and :mod:`.vibration`): the crank-driven
slider with the object's stops (sliding, then slippage when the slider pushes the object,
then a motor pause: no motion; the paper's Fig. 2 cycle), short drags of slippery objects
during sliding, encoder quantisation of both velocities, surface-following vibration that
grows with roughness and speed and rises in pitch with speed, the ring-down of the bar when
the slider hits a stop, motor hum through the bar, the grasped bar's mode excited by the
gripper holding it (``grip_hum_g``, always on, its frequency shifted per set-up by
``grip_mode_spread``: the cue that lets paper 001 name the object at rest), the fingertip
pad's resonance, the
orientation's split of vibration over x/y/z, gravity offset, sensor noise, the 1.5 kHz
first-order low-pass, 16-bit quantisation and clipping at +-5 g.

Left out: the gripper force itself (only its effect on the bar's mode is modelled),
stick-slip limit cycles of the pads, wear and temperature, the
``dv/dt h'`` term of surface following, aliasing (profiles stop at 100 um wavelengths, so
nothing exceeds 4 kHz), cross-axis sensitivity of the accelerometers, the ADC's timing
jitter and the acquisition's USB framing. Every recording of one texture in one scene
shares its surfaces (the same bar); another seed draws other bars, so a model tested on
another seed meets surfaces it never felt.

The output folder is built beside its destination and renamed into place when complete.
"""

from __future__ import annotations

import json
import shlex
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .._version import __version__
from ..errors import check_seed
from ..interrupt import raise_if_requested
from ..progress import NullProgress, Progress
from ..store.outdir import check_output_folder, output_folder
from ..store.provenance import current_command
from .config import TextureConfig, VibroSceneConfig
from .kinematics import simulate_motion
from .vibration import follow, hum, resonance, ring_downs, sensor, surface_curvature

#: CSV header (the accel-tree ingest reads columns by position and checks these names).
CSV_COLUMNS = ("L_x", "L_y", "L_z", "R_x", "R_y", "R_z", "v_slip", "v_slide")
SCENE_FORMAT = "tactile-vibro-slip"
SCENE_FORMAT_VERSION = 1
#: Motor speed at which ``motor_hum_g`` is reached.
_HUM_REFERENCE_RPS = 0.48
#: Object surface covered by the profiles (m), both directions from the rest position.
_SURFACE_HALF_SPAN_M = 0.25


@dataclass(frozen=True)
class Surfaces:
    """The random surfaces of one bar: (x_m, h''(x)) for the left face, right face and the
    slider's track, normal and tangential realisations of each."""

    left: tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]
    right: tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]
    track: tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]


def draw_surfaces(texture: TextureConfig, rng: np.random.Generator) -> Surfaces:
    """Six independent profile realisations of one texture."""
    def pair() -> tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]:
        return tuple(surface_curvature(texture, -_SURFACE_HALF_SPAN_M, _SURFACE_HALF_SPAN_M,
                                       rng) for _ in range(2))  # type: ignore[return-value]
    return Surfaces(pair(), pair(), pair())


@dataclass(frozen=True)
class Recording:
    """One simulated recording: accel (n, 6) float32 CSV values (fraction of full scale),
    velocity (n, 2) float32 m/s (v_slip, v_slide), and its ground truth."""

    texture: str
    orientation_deg: float
    motor_rps: float
    accel: np.ndarray
    velocity: np.ndarray
    truth: dict[str, Any] = field(default_factory=dict)

    @property
    def folder(self) -> tuple[str, str, str]:
        """``(texture, angle, rps)`` folder names, e.g. ``("wood", "15", "0.32")``."""
        return self.texture, f"{self.orientation_deg:g}", f"{self.motor_rps:g}"


def simulate_recording(cfg: VibroSceneConfig, texture_name: str, orientation_deg: float,
                       motor_rps: float, surfaces: Surfaces, rng: np.random.Generator,
                       grip_rng: np.random.Generator | None = None) -> Recording:
    """Simulate one recording (see the module docstring). ``grip_rng`` draws the set-up's
    grip vibration (default: ``rng``); a separate stream keeps the rest of a recording
    unchanged when ``cfg.grip_hum_g`` changes."""
    texture = cfg.textures[texture_name]
    motion = simulate_motion(cfg, texture, motor_rps, rng)
    rate = cfg.rate_hz
    n = int(round(cfg.duration_s * rate))
    t = np.arange(n) / rate

    def up(values: np.ndarray) -> np.ndarray:
        return np.interp(t, motion.t_s, values)

    x_obj, v_obj = up(motion.object_m), up(motion.v_object_m_s)
    on_track = up(motion.slider_m - motion.object_m)
    v_rel = up(motion.v_slider_m_s - motion.v_object_m_s)
    # tangential (t) and normal (n) vibration at each fingertip, g
    fingers = []
    for face in (surfaces.left, surfaces.right):
        normal = cfg.slip_gain * follow(*face[0], x_obj, v_obj)
        tangential = cfg.slip_gain * follow(*face[1], x_obj, v_obj)
        fingers.append([tangential, normal])
    slide_n = cfg.slide_gain * follow(*surfaces.track[0], on_track, v_rel)
    slide_t = cfg.slide_gain * follow(*surfaces.track[1], on_track, v_rel)
    ring = ring_downs(n, rate, motion.impacts, texture.mode_hz, texture.mode_q,
                      cfg.impact_g_per_m_s)
    moving = up((np.abs(motion.v_slider_m_s) > 1e-6).astype(float)) > 0.5
    level = cfg.motor_hum_g * motor_rps / _HUM_REFERENCE_RPS * np.where(moving, 1.0, 0.3)
    bar = hum(n, rate, texture.mode_hz, texture.mode_q, level, rng) + ring
    grip_mode_hz = None
    if cfg.grip_hum_g > 0:
        grip_rng = rng if grip_rng is None else grip_rng
        grip_mode_hz = texture.mode_hz * float(
            np.exp(cfg.grip_mode_spread * grip_rng.standard_normal()))
        bar = bar + hum(n, rate, grip_mode_hz, texture.mode_q,
                        np.full(n, cfg.grip_hum_g), grip_rng)
    alpha = np.deg2rad(orientation_deg)
    accel = np.empty((n, 6))
    for side, (tangential, normal) in enumerate(fingers):
        tan = tangential + slide_t + bar
        nor = normal + slide_n + 0.5 * bar
        mirror = 1.0 if side == 0 else -1.0
        accel[:, 3 * side + 0] = tan * np.cos(alpha)
        accel[:, 3 * side + 1] = mirror * tan * np.sin(alpha)
        accel[:, 3 * side + 2] = mirror * nor
    accel = resonance(accel, rate, cfg.pad_resonance_hz, cfg.pad_q) * cfg.pad_gain
    gravity = np.array([np.cos(alpha), np.sin(alpha), 0.0, np.cos(alpha), -np.sin(alpha), 0.0])
    values = sensor(accel + gravity, cfg, rng)  # gravity: DC, unchanged by the pad
    velocity = np.column_stack([up(motion.enc_v_object_m_s),
                                up(motion.enc_v_slider_m_s)]).astype(np.float32)
    truth = {
        "texture": texture_name, "orientation_deg": orientation_deg, "motor_rps": motor_rps,
        "roughness_nm": texture.roughness_nm, "wavelength_mm": texture.wavelength_mm,
        "n_samples": n, "n_impacts": int(len(motion.impacts)),
        "grip_mode_hz": None if grip_mode_hz is None else round(grip_mode_hz, 3),
        "peak_speed_m_s": round(float(np.abs(motion.v_slider_m_s).max()), 6),
        "clipped_fraction": round(float((np.abs(values) >= 1).mean()), 6),
        "vibration_rms_g": [round(float(v), 6) for v in (accel.std(axis=0))],
    }
    return Recording(texture_name, orientation_deg, motor_rps, values, velocity, truth)


@dataclass(frozen=True)
class VibroSceneResult:
    """What ``simulate_vibro_slip`` wrote: the folder, seed, recordings' ground truth."""

    out_dir: Path
    seed: int
    recordings: tuple[dict[str, Any], ...]
    duration_s: float
    elapsed_s: float

    def as_dict(self) -> dict[str, Any]:
        return {"out_dir": str(self.out_dir), "seed": self.seed,
                "n_recordings": len(self.recordings), "duration_s": self.duration_s,
                "elapsed_s": round(self.elapsed_s, 3), "recordings": list(self.recordings)}

    def summary_lines(self) -> list[str]:
        return [f"vibro-slip -> {self.out_dir} (seed {self.seed}): {len(self.recordings)} "
                f"recordings, {self.duration_s:.1f} s in all, simulated in "
                f"{self.elapsed_s:.1f} s"]


def write_csv(path: Path, accel: np.ndarray, velocity: np.ndarray) -> None:
    """The 8-column CSV with a header: accelerations to 6 decimals, velocities to 5."""
    table = np.column_stack([accel, velocity])
    fmt = ",".join(["%.6f"] * 6 + ["%.5f"] * 2)
    with open(path, "w", encoding="ascii", newline="") as f:
        f.write(",".join(CSV_COLUMNS) + "\n")
        np.savetxt(f, table, fmt=fmt, delimiter=",", newline="\n")


def ingest_shell_command(out: Path) -> str:
    """The shell command that ingests a scene folder (recorded in its scene.json)."""
    return shlex.join(["tactile", "ingest", str(out), "--format", "accel-tree", "--out",
                       "scene.h5"])


def simulate_vibro_slip(cfg: VibroSceneConfig, out_dir: str | Path, *, seed: int,
                        progress: Progress | None = None, overwrite: bool = False,
                        command: str | None = None) -> VibroSceneResult:
    """Simulate every recording of ``cfg`` and write the CSV tree ``out_dir``.

    ``seed`` (>= 0) fixes every byte of the output. Raises :class:`InputError` when
    ``out_dir`` is a file, or a non-empty folder and ``overwrite`` is false; nothing is
    written then, and nothing is left behind when the run fails or is interrupted.
    """
    started = time.perf_counter()
    progress = progress or NullProgress()
    seed = check_seed(seed)
    out = check_output_folder(out_dir, overwrite=overwrite)
    cells = [(ti, tex, oi, ori, si, rps)
             for ti, tex in enumerate(cfg.textures)
             for oi, ori in enumerate(cfg.orientations_deg)
             for si, rps in enumerate(cfg.motor_rps)]
    truths: list[dict[str, Any]] = []
    try:
        with output_folder(out, overwrite=overwrite) as tmp:
            progress.start(len(cells), "vibro-slip recordings")
            surfaces = {tex: draw_surfaces(cfg.textures[tex],
                                           np.random.default_rng([seed, 0, ti]))
                        for ti, tex in enumerate(cfg.textures)}
            for ti, tex, oi, ori, si, rps in cells:
                raise_if_requested()
                rng = np.random.default_rng([seed, 1, ti, oi, si])
                rec = simulate_recording(cfg, tex, ori, rps, surfaces[tex], rng,
                                         np.random.default_rng([seed, 2, ti, oi, si]))
                folder = tmp.joinpath(*rec.folder)
                folder.mkdir(parents=True, exist_ok=True)
                write_csv(folder / "data.csv", rec.accel, rec.velocity)
                truths.append({"path": "/".join([*rec.folder, "data.csv"]), **rec.truth})
                progress.advance(1)
            scene = {
                "format": SCENE_FORMAT, "format_version": SCENE_FORMAT_VERSION,
                "tool_version": __version__, "seed": seed,
                "command": command if command is not None else current_command(),
                "config": cfg.model_dump(mode="json"), "columns": list(CSV_COLUMNS),
                "recordings": truths,
                "ingest": ingest_shell_command(out),
            }
            (tmp / "scene.json").write_text(json.dumps(scene, indent=2) + "\n",
                                            encoding="utf-8")
    finally:
        progress.finish()
    return VibroSceneResult(out, seed, tuple(truths), cfg.duration_s * len(cells),
                            time.perf_counter() - started)
