"""Typed configs of the active-vibration chain (paper 003, VibroTouch).

- :class:`ModelConfig`: the lumped model of sec. 2.2 (``configs/vibro_model.yaml``): Kelvin-
  Voigt blocks (mass, spring and damper in parallel), each hung from a parent node (another
  block or ``ground``), the block whose displacement the motor prescribes, the block whose
  motion the accelerometer registers, and the contact links that a touch adds;
- :class:`VibroTouchSceneConfig`: ``tactile simulate vibrotouch``
  (``configs/scene_vibrotouch.yaml``);
- :class:`DetectorConfig`: the spectral and force triggers of sec. 2.4
  (``configs/detect_contact.yaml``).

Unknown keys are errors; every problem is one :class:`~tactile_cli.errors.InputError` that
names the file, the line and the key.
"""

from __future__ import annotations

import math
from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field, model_validator

from ..config_file import describe_key_first, load_yaml_model
from ..errors import InputError

#: The fixed node every chain ends at (the office table of Fig. 2).
GROUND = "ground"


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", use_attribute_docstrings=True, frozen=True,
                              allow_inf_nan=False)


class BlockConfig(_Model):
    """One lumped block: a mass hung from its parent by a spring and a damper in parallel."""

    mass_kg: float = Field(gt=0, le=1e4)
    stiffness_n_m: float = Field(gt=0, le=1e12)
    """Spring between this block and its parent."""
    damping_n_s_m: float = Field(default=0.0, ge=0, le=1e9)
    """Damper between this block and its parent."""
    parent: str = GROUND
    """The node the spring and damper attach to: another block's name or ``ground``."""


class LinkConfig(_Model):
    """A spring and damper between two nodes, added by a contact (no mass of its own)."""

    between: tuple[str, str]
    stiffness_n_m: float = Field(ge=0, le=1e12)
    damping_n_s_m: float = Field(default=0.0, ge=0, le=1e9)


def _default_blocks() -> dict[str, BlockConfig]:
    # Both fingers hang from the gripper; the object hangs from the table by a soft string.
    # Masses and stiffnesses are order-of-magnitude values for a PLA bone, Elastic 50A
    # tissue and skin, a 10 mm coin ERM and an ADXL345 board (paper 003, sec. 2.3).
    b = BlockConfig
    return {
        "gripper": b(mass_kg=0.8, stiffness_n_m=4.0e6, damping_n_s_m=80.0),
        "bone_a": b(mass_kg=0.02, stiffness_n_m=6.0e5, damping_n_s_m=4.0, parent="gripper"),
        "tissue_a": b(mass_kg=0.006, stiffness_n_m=9.0e4, damping_n_s_m=1.5, parent="bone_a"),
        "motor": b(mass_kg=0.002, stiffness_n_m=4.0e4, damping_n_s_m=0.6, parent="tissue_a"),
        "skin_a": b(mass_kg=0.002, stiffness_n_m=2.0e4, damping_n_s_m=0.4, parent="motor"),
        "bone_s": b(mass_kg=0.02, stiffness_n_m=6.0e5, damping_n_s_m=4.0, parent="gripper"),
        "tissue_s": b(mass_kg=0.006, stiffness_n_m=9.0e4, damping_n_s_m=1.5, parent="bone_s"),
        "accelerometer": b(mass_kg=0.002, stiffness_n_m=4.0e4, damping_n_s_m=0.25,
                           parent="tissue_s"),
        # the sensing skin's own mode sits at 575 Hz: hung from the accelerometer it is a
        # vibration absorber, a notch in the accelerometer's response that a touch detunes
        "skin_s": b(mass_kg=0.0005, stiffness_n_m=6526.0, damping_n_s_m=0.009,
                    parent="accelerometer"),
        # a 17.65 mm printed cube (paper 003, sec. 2.4.1) on a soft string
        "object": b(mass_kg=0.01, stiffness_n_m=20.0, damping_n_s_m=0.02),
    }


def _default_contact() -> list[LinkConfig]:
    # each fingertip's contact at the 1 N grip of sec. 2.4.2
    return [LinkConfig(between=("skin_a", "object"), stiffness_n_m=3.0e4, damping_n_s_m=0.6),
            LinkConfig(between=("object", "skin_s"), stiffness_n_m=3.0e4, damping_n_s_m=0.6)]


def _check_no_cycle(blocks: dict[str, BlockConfig]) -> None:
    """The blocks hang from the ground as a tree: following parents from any block reaches
    the ground (a ValueError naming a block of the loop otherwise)."""
    for name in blocks:
        seen = {name}
        node = blocks[name].parent
        while node != GROUND and node in blocks:
            if node in seen:
                raise ValueError(f"block {name!r}: its parents form a loop through {node!r}; "
                                 f"every chain of parents must end at {GROUND!r}")
            seen.add(node)
            node = blocks[node].parent


class ModelConfig(_Model):
    """The lumped-element model of the gripper, fingers and object (paper 003, Fig. 2)."""

    blocks: dict[str, BlockConfig] = Field(default_factory=_default_blocks, min_length=2,
                                           max_length=200)
    source: str = "motor"
    """The block whose displacement the ERM prescribes (u = u_src exp(i phi))."""
    sensor: str = "accelerometer"
    """The block whose motion the accelerometer registers."""
    contact: list[LinkConfig] = Field(default_factory=_default_contact, max_length=200)
    """The links a contact adds (Fig. 3A's dashed spectrum: the object enters the chain)."""
    f_min_hz: float = Field(default=1.0, gt=0, le=1e5)
    f_max_hz: float = Field(default=1000.0, gt=0, le=1e5)
    f_step_hz: float = Field(default=0.25, gt=0, le=100)
    """Frequency grid of the spectra (sec. 2.2: 1 to 1000 Hz)."""

    @model_validator(mode="after")
    def _check(self) -> ModelConfig:
        names = set(self.blocks)
        if GROUND in names:
            raise ValueError(f"a block may not be called {GROUND!r} (the fixed node)")
        for name, block in self.blocks.items():
            if block.parent != GROUND and block.parent not in names:
                raise ValueError(f"block {name!r}: parent {block.parent!r} is neither a block "
                                 f"nor {GROUND!r}")
            if block.parent == name:
                raise ValueError(f"block {name!r} hangs from itself")
        _check_no_cycle(self.blocks)
        for key in ("source", "sensor"):
            if getattr(self, key) not in names:
                raise ValueError(f"`{key}` (={getattr(self, key)!r}) is not one of the blocks")
        if self.source == self.sensor:
            raise ValueError("`source` and `sensor` must be different blocks")
        for link in self.contact:
            for node in link.between:
                if node != GROUND and node not in names:
                    raise ValueError(f"contact link {list(link.between)}: {node!r} is neither "
                                     f"a block nor {GROUND!r}")
        if not self.f_min_hz < self.f_max_hz:
            raise ValueError("`f_min_hz` must be below `f_max_hz`")
        if (self.f_max_hz - self.f_min_hz) / self.f_step_hz > 1e6:
            raise ValueError("`f_step_hz` gives more than 1e6 frequencies")
        return self


def load_model_config(path: str | Path) -> ModelConfig:
    """Read and validate a lumped-model config (one :class:`InputError` line on a problem)."""
    return load_yaml_model(path, ModelConfig, describe=describe_key_first,
                           not_a_mapping="a lumped-model config is a YAML mapping; see "
                           "configs/vibro_model.yaml")


class VibroTouchSceneConfig(_Model):
    """Every parameter of ``tactile simulate vibrotouch`` (paper 003, secs. 2.3-2.4).

    Values the paper gives are marked with their section; the others are the scene's own
    modelling choices (see :mod:`tactile_cli.vibro.simulate`)."""

    model: ModelConfig = Field(default_factory=ModelConfig)
    """The lumped model whose response the accelerometer records."""
    contact_trials: int = Field(default=10, ge=0, le=1000)
    """Gripper-object trials (sec. 2.4.1: 10 repetitions)."""
    touch_trials: int = Field(default=2, ge=0, le=1000)
    """Grasped object-human trials (sec. 2.4.2), each with ``touches_per_trial`` presses."""
    touches_per_trial: int = Field(default=5, ge=1, le=100)
    """Presses per touch trial (sec. 2.4.2: 5)."""
    accel_rate_hz: float = Field(default=2500.0, gt=0, le=1e5)
    """ADXL345 sample rate (sec. 2.3)."""
    force_rate_hz: float = Field(default=1000.0, gt=0, le=1e5)
    """HEX21 force/torque sample rate (sec. 2.3)."""
    erm_hz: float = Field(default=130.0, gt=0, le=1000)
    """ERM rotation frequency (sec. 2.3: about 130 Hz)."""
    erm_jitter: float = Field(default=0.01, ge=0, le=0.2)
    """Relative standard deviation of the ERM's slow speed wander."""
    erm_harmonics: list[float] = Field(default=[1.0, 0.5, 0.3, 0.2, 0.12, 0.08, 0.05, 0.03],
                                       min_length=1, max_length=20)
    """Displacement amplitude of each harmonic of the ERM, relative to ``erm_um``."""
    erm_um: float = Field(default=20.0, gt=0, le=1e4)
    """Displacement amplitude of the ERM's fundamental (um)."""
    buzz_um: float = Field(default=1.0, ge=0, le=1e4)
    """Broadband (white) displacement of the ERM's brushes and bearing, RMS over the
    accelerometer's band (um): what makes the chain's resonances visible between harmonics."""
    calibration_s: float = Field(default=1.0, gt=0, le=100)
    """Still time at the start of each trial, the detectors' calibration buffer."""
    gap_mm: tuple[float, float] = (0.02, 0.06)
    """Range of the gap left when the gripper starts closing (sec. 2.4.1 closes 2.35 mm;
    the scene starts near the object to keep trials short)."""
    closing_mm_s: float = Field(default=0.01, gt=0, le=100)
    """Closing speed of the gripper (sec. 2.4.1: 0.01 mm/s)."""
    second_contact_s: tuple[float, float] = (0.0, 0.6)
    """Range of the delay between the first fingertip's contact and the second's
    (Fig. 5E-F: either finger may reach the object first)."""
    after_contact_s: float = Field(default=5.0, gt=0, le=1000)
    """Recording after the first contact while the gripper keeps closing."""
    light_stiffness_n_m: float = Field(default=800.0, gt=0, le=1e9)
    """Median stiffness of a fingertip's first, light contact (the weak link of sec. 2.2)."""
    light_spread: float = Field(default=0.5, ge=0, le=3)
    """Log-normal spread (sigma of ln) of the light contact's stiffness between trials."""
    stiffening_n_m2: float = Field(default=4.5e8, ge=0, le=1e15)
    """Growth of contact stiffness with penetration, k = k_light + s * depth (N/m per m);
    force = k_light depth + s depth^2 / 2. 4.5e8 gives 3e4 N/m at the 1 N grip."""
    motion_noise_g: float = Field(default=0.05, ge=0, le=100)
    """RMS of the gripper's drive vibration while it moves (g), band ``motion_band_hz``."""
    motion_band_hz: tuple[float, float] = (40.0, 350.0)
    """Band of the drive vibration (4th-order Butterworth; Fig. 4B)."""
    accel_noise_g: float = Field(default=0.004, ge=0, le=10)
    """Accelerometer noise RMS (ADXL345 at 2.5 kHz: about 4 mg)."""
    accel_lsb_g: float = Field(default=0.0039, ge=0, le=1)
    """Accelerometer resolution (ADXL345 full resolution: 3.9 mg/LSB); 0: no quantisation."""
    force_noise_n: float = Field(default=0.019, ge=0, le=100)
    """RMS of the force sensor's noise; mean |noise| = 0.8 RMS = 0.015 N (sec. 2.4)."""
    grip_n: float = Field(default=1.0, gt=0, le=100)
    """Grip force of the touch trials (sec. 2.4.2: 1 N)."""
    touch_n: tuple[float, float] = (0.6, 2.0)
    """Range of the peak force of a human press on the grasped object."""
    touch_s: tuple[float, float] = (0.4, 0.9)
    """Range of the duration of a press."""
    touch_gap_s: tuple[float, float] = (1.0, 2.0)
    """Range of the pause between presses."""
    touch_stiffness_n_m_per_n: float = Field(default=3000.0, ge=0, le=1e9)
    """Stiffness a press adds between the object and the ground, per newton of press."""
    touch_force_fraction: float = Field(default=0.5, ge=0, le=1)
    """Share of a press's force that reaches the force sensor's y axis."""
    state_step_s: float = Field(default=0.02, gt=0, le=1)
    """The contact state is updated (and crossfaded) every this many seconds."""

    @model_validator(mode="after")
    def _check(self) -> VibroTouchSceneConfig:
        for key in ("gap_mm", "second_contact_s", "touch_n", "touch_s", "touch_gap_s",
                    "motion_band_hz"):
            lo, hi = getattr(self, key)
            if not 0 <= lo <= hi:
                raise ValueError(f"`{key}` (={[lo, hi]}) must be [low, high] with 0 <= low "
                                 "<= high")
        if len(self.model.contact) != 2:
            raise ValueError("the scene needs `model.contact` to hold two links: actuating "
                             "fingertip-object and object-sensing fingertip")
        nyquist = self.accel_rate_hz / 2
        if self.motion_band_hz[1] >= nyquist or self.motion_band_hz[0] <= 0:
            raise ValueError(f"`motion_band_hz` must lie inside (0, {nyquist:g}) Hz")
        if self.contact_trials + self.touch_trials == 0:
            raise ValueError("`contact_trials` and `touch_trials` are both 0: nothing to "
                             "simulate")
        return self

    def with_overrides(self, *, contact_trials: int | None = None,
                       touch_trials: int | None = None) -> VibroTouchSceneConfig:
        """A copy with the CLI's overrides, validated like the file."""
        from ..config_file import with_overrides

        return with_overrides(self, {"contact_trials": ("contact_trials", contact_trials),
                                     "touch_trials": ("touch_trials", touch_trials)})


def load_vibrotouch_config(path: str | Path) -> VibroTouchSceneConfig:
    """Read and validate a vibrotouch scene config (one :class:`InputError` line on a
    problem)."""
    return load_yaml_model(path, VibroTouchSceneConfig, describe=describe_key_first,
                           not_a_mapping="a vibrotouch scene config is a YAML mapping; see "
                           "configs/scene_vibrotouch.yaml")


class DetectorConfig(_Model):
    """The triggers of paper 003, sec. 2.4 (``configs/detect_contact.yaml``)."""

    window_s: float = Field(default=0.2, gt=0, le=10)
    """Length of each spectrogram frame."""
    refresh_hz: float = Field(default=100.0, gt=0, le=10000)
    """Spectrogram refresh rate (sec. 2.4: 100 Hz, one frame every 10 ms)."""
    n_fft: int = Field(default=2048, ge=8, le=1 << 20)
    """FFT length (zero padding) of each frame; at least the frame's samples."""
    calibration_s: float = Field(default=1.0, gt=0, le=1000)
    """The calibration buffer at the start of a recording: noise levels and the reference
    frequency come from it."""
    band_hz: tuple[float, float] = (570.0, 580.0)
    """Band whose peak amplitude signals contact with an object (sec. 2.4: 570-580 Hz)."""
    average_frames: int = Field(default=50, ge=1, le=100000)
    """Moving average of the peak amplitude, in frames (sec. 3.1: 50)."""
    vibration_factor: float = Field(default=2.0, gt=0, le=1000)
    """Trigger when the averaged amplitude exceeds this many times the noise level (the
    calibration buffer's mean amplitude; sec. 2.4: 2)."""
    force_channel: str = "f_z"
    """Force channel of the gripper-object trigger (the grip axis)."""
    force_average_samples: int = Field(default=50, ge=1, le=1000000)
    """Moving average of the force, in samples."""
    force_factor: float = Field(default=1.6, gt=0, le=1000)
    """Trigger when the averaged force (less its calibration mean) exceeds this many times
    the noise level (mean |force - mean| over the calibration buffer; sec. 2.4: 1.6)."""
    touch_band_hz: tuple[float, float] = (180.0, 250.0)
    """Band whose peak frequency signals a touch on a grasped object (sec. 2.4.2)."""
    touch_shift: float = Field(default=0.03, gt=0, le=1)
    """Trigger when the averaged peak frequency moves by more than this fraction from its
    calibration value (sec. 2.4.2: 3 %)."""
    touch_average_frames: int = Field(default=20, ge=1, le=100000)
    """Moving average of the peak frequency, in frames."""
    touch_force_channel: str = "f_y"
    """Force channel of the touch trigger (the press axis)."""
    touch_force_n: float = Field(default=0.3, gt=0, le=1e6)
    """Touch trigger of the force sensor: averaged |force - calibration mean| above this
    (sec. 2.4.2: 0.3 N)."""
    snr_window_s: float = Field(default=4.0, gt=0, le=1000)
    """SNR: the highest averaged level within this long after the true contact, over the
    noise level."""
    merge_s: float = Field(default=0.3, gt=0, le=100)
    """Triggers closer than this to the previous one's end count as the same event."""
    match_s: float = Field(default=0.5, ge=0, le=100)
    """A touch detection counts as a hit when it starts within a press or this long after."""

    @model_validator(mode="after")
    def _check(self) -> DetectorConfig:
        for key in ("band_hz", "touch_band_hz"):
            lo, hi = getattr(self, key)
            if not 0 <= lo < hi:
                raise ValueError(f"`{key}` (={[lo, hi]}) must be [low, high] with 0 <= low "
                                 "< high")
        return self

    @property
    def hop_s(self) -> float:
        """Seconds between spectrogram frames (1 / ``refresh_hz``)."""
        return 1.0 / self.refresh_hz


def load_detector_config(path: str | Path) -> DetectorConfig:
    """Read and validate a detector config (one :class:`InputError` line on a problem)."""
    return load_yaml_model(path, DetectorConfig, describe=describe_key_first,
                           not_a_mapping="a contact-detector config is a YAML mapping; see "
                           "configs/detect_contact.yaml")


def detector_config(path: str | Path | None = None, *,
                    band_hz: tuple[float, float] | None = None) -> DetectorConfig:
    """The detector config of file ``path`` (default: the paper's settings), its contact
    band replaced by ``band_hz`` when given; one :class:`InputError` for a bad band."""
    cfg = load_detector_config(path) if path is not None else DetectorConfig()
    if band_hz is None:
        return cfg
    lo, hi = (float(v) for v in band_hz)
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 <= lo < hi):
        raise InputError(f"`band_hz` (={lo:g},{hi:g}) must be a band in Hz: low,high with "
                         "0 <= low < high")
    return cfg.model_copy(update={"band_hz": (lo, hi)})

