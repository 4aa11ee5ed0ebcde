"""The typed config of ``tactile simulate vibro-slip`` (``configs/scene_vibro_slip.yaml``).

Defaults are paper 001's set-up where the paper gives a value (3 objects, 4 gripper
angles, 3 motor speeds, speeds up to 0.35 m/s, 8 kHz, +-5 g, 1.5 kHz first-order
low-pass, surface roughness 6381 / 372 / 121 nm for wood / plastic / aluminium; secs. 3-4)
and the scene's own modelling choice where it does not (marked "scene" below; see
:mod:`tactile_cli.accel.simulate` for the physics). Unknown keys are errors; any problem
is one :class:`~tactile_cli.errors.InputError` naming the file, the line and the key.
"""

from __future__ import annotations

from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field, model_validator

from ..config_file import describe_key_first, load_yaml_model
from ..errors import InputError


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", use_attribute_docstrings=True, frozen=True,
                              allow_inf_nan=False)


class TextureConfig(_Model):
    """One grasped object: its surface and how it carries vibration."""

    roughness_nm: float = Field(gt=0, le=1e6)
    """Standard deviation of the surface height (paper 001, sec. 4, profilometer)."""
    wavelength_mm: float = Field(gt=0, le=100)
    """Scene: dominant spatial wavelength of the surface profile."""
    relative_bandwidth: float = Field(gt=0, le=2)
    """Scene: spread of the profile's spatial frequencies around 1/wavelength (Gaussian
    sigma over the centre): small = periodic machining marks, large = random grain."""
    drag_rate_hz: float = Field(default=0.0, ge=0, le=100)
    """Scene: how often per second of sliding the slider drags a slippery object along for a
    moment (paper 001, sec. 4: on aluminium and plastic both motions follow each other
    quickly)."""
    mode_hz: float = Field(gt=0, le=3900)
    """Scene: bending mode of the grasped bar, rung by the impact at slip onset and by the
    running motor."""
    mode_q: float = Field(default=8.0, gt=0.5, le=200)
    """Scene: quality factor of that mode (wood damps, aluminium rings)."""


def _default_textures() -> dict[str, TextureConfig]:
    return {
        "wood": TextureConfig(roughness_nm=6381, wavelength_mm=0.8, relative_bandwidth=0.8,
                              drag_rate_hz=0.0, mode_hz=650, mode_q=4),
        "plastic": TextureConfig(roughness_nm=372, wavelength_mm=0.35, relative_bandwidth=0.5,
                                 drag_rate_hz=1.0, mode_hz=420, mode_q=8),
        "aluminum": TextureConfig(roughness_nm=121, wavelength_mm=0.18,
                                  relative_bandwidth=0.25, drag_rate_hz=2.0, mode_hz=1150,
                                  mode_q=25),
    }


class VibroSceneConfig(_Model):
    """Every parameter of the vibro-slip scene."""

    textures: dict[str, TextureConfig] = Field(default_factory=_default_textures,
                                               min_length=1, max_length=100)
    orientations_deg: list[float] = Field(default=[0, 15, 30, 45], min_length=1,
                                          max_length=100)
    """Angle between gripper and object (paper 001, Fig. 3)."""
    motor_rps: list[float] = Field(default=[0.16, 0.32, 0.48], min_length=1, max_length=100)
    """Motor rotations per second (paper 001, sec. 3.2)."""
    duration_s: float = Field(default=20.0, gt=0, le=3600)
    """Seconds per recording (one per texture x orientation x motor speed)."""
    rate_hz: float = Field(default=8000.0, gt=0, le=1e6)
    """Accelerometer sample rate (paper 001, sec. 3.1)."""
    kinematics_rate_hz: float = Field(default=1000.0, gt=0, le=1e5)
    """Scene: rate of the slider/object motion loop, interpolated to ``rate_hz``."""
    crank_radius_m: float = Field(default=0.116, gt=0, le=10)
    """Scene: slider crank radius; 0.116 m at 0.48 rps gives the paper's 0.35 m/s peak."""
    play_m: float = Field(default=0.05, gt=0, le=10)
    """Scene: half the free travel of the slider between the object's two stops."""
    dwell_s: tuple[float, float] = (0.15, 0.6)
    """Scene: the motor pauses at each dead point for a time drawn from this range."""
    drag_s: tuple[float, float] = (0.03, 0.1)
    """Scene: duration range of one drag of a slippery object during sliding."""
    drag_fraction: float = Field(default=0.7, gt=0, le=1)
    """Scene: object speed during a drag, as a fraction of the slider's."""
    encoder_resolution_m: float = Field(default=0.12e-3, gt=0, le=1)
    """Linear encoder resolution (paper 001, sec. 3.1, AEDR-8300)."""
    velocity_window_s: float = Field(default=0.01, gt=0, le=1)
    """Scene: span of the central difference that turns encoder counts into velocity."""
    slip_gain: float = Field(default=1.0, ge=0, le=100)
    """Scene: vibration reaching the fingertips from the object rubbing them (slip)."""
    slide_gain: float = Field(default=0.35, ge=0, le=100)
    """Scene: vibration reaching them from the slider rubbing the object (slide)."""
    impact_g_per_m_s: float = Field(default=2.0, ge=0, le=1000)
    """Scene: peak of the ring-down when the slider hits a stop, g per m/s of closing speed."""
    motor_hum_g: float = Field(default=0.02, ge=0, le=5)
    """Scene: RMS of the bar's mode excited by the running motor at 0.48 rps (scales with
    speed; 30 % of it while the motor holds at a dead point)."""
    grip_hum_g: float = Field(default=0.015, ge=0, le=5)
    """Scene: RMS of the grasped bar's mode excited all the time by the gripper holding it
    (its servo and frame), whether or not anything moves. Paper 001 (sec. 6.2) found the
    object at rest (91 %) and explains it by the set-up: installing an object and its grip
    force change the gripper's vibration. 0 leaves the cue out. 0.015 g: a linear probe on
    Welch spectra of still windows, trained on scene seed 0, names the object in 91 % of
    the still windows of seed 2 (paper: 91 %); 0.01 g gives 81 %, 0 g 59 % (chance 33 %)."""
    grip_mode_spread: float = Field(default=0.03, ge=0, le=0.5)
    """Scene: relative standard deviation of the bar's clamped mode frequency between
    set-ups (recordings): the grip force and clamping point shift it."""
    pad_resonance_hz: float = Field(default=350.0, gt=0, le=3900)
    """Scene: resonance of the fingertip pad (TPU padding, silicone insert)."""
    pad_q: float = Field(default=1.5, gt=0.1, le=100)
    pad_gain: float = Field(default=0.3, gt=0, le=100)
    """Scene: pad transmission below its resonance."""
    noise_g: float = Field(default=0.007, ge=0, le=5)
    """Accelerometer noise RMS over its band (ADXL335: about 150-300 ug/sqrt(Hz))."""
    lowpass_hz: float = Field(default=1500.0, gt=0, le=1e5)
    """First-order analogue low-pass cut-off (paper 001, sec. 3.1)."""
    full_scale_g: float = Field(default=5.0, gt=0, le=1000)
    """The CSV holds acceleration / full_scale_g, clipped to [-1, 1] (paper 001, sec. 4)."""
    adc_bits: int = Field(default=16, ge=2, le=32)
    """ADC resolution (paper 001, sec. 3.1: 16-bit AD7685)."""

    @model_validator(mode="after")
    def _check(self) -> VibroSceneConfig:
        for name in self.textures:
            if not name or "/" in name or name.startswith("."):
                raise ValueError(f"texture name {name!r} must be a plain folder name")
        for key in ("dwell_s", "drag_s"):
            lo, hi = getattr(self, key)
            if not 0 <= lo <= hi:
                raise ValueError(f"`{key}` (={[lo, hi]}) must be [low, high] with 0 <= low <= high")
        if any(r <= 0 for r in self.motor_rps):
            raise ValueError(f"`motor_rps` (={self.motor_rps}) must all be positive")
        if self.kinematics_rate_hz > self.rate_hz:
            raise ValueError("`kinematics_rate_hz` must not exceed `rate_hz`")
        return self

    def with_duration(self, duration_s: float | None) -> VibroSceneConfig:
        """A copy with ``duration_s`` replaced (validated); unchanged for None."""
        from pydantic import ValidationError

        if duration_s is None:
            return self
        try:
            return VibroSceneConfig.model_validate({**self.model_dump(),
                                                    "duration_s": duration_s})
        except ValidationError as exc:  # the one key replaced: its error is the one shown
            raise InputError(describe_key_first(exc.errors()[0])) from None


def load_vibro_config(path: str | Path) -> VibroSceneConfig:
    """Read and validate a scene config file (one :class:`InputError` line on a problem)."""
    return load_yaml_model(path, VibroSceneConfig, describe=describe_key_first,
                           not_a_mapping="a vibro-slip scene config is a YAML mapping; see "
                           "configs/scene_vibro_slip.yaml")
