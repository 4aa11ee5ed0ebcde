"""Typed config of the ``tactile simulate digit-press`` scene (paper 002): ball-bearing
calibration presses and held-then-slipping objects on a DIGIT-like sensor.

Unknown keys are errors; every problem is one :class:`~tactile_cli.errors.InputError` that
names the file, the line and the key (``configs/scene_digit_press.yaml`` repeats the
defaults with comments).
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from ..config_file import load_yaml_model
from .shapes import OBJECT_NAMES

#: Slip directions of the trials: in-plane translations, pressing toward the sensor
#: (``z``), rotation about the object's own centre (``rot``), or no slip (``none``).
DIRECTIONS = ("+x", "-x", "+y", "-y", "z", "rot", "none")

ObjectName = Literal["cable", "box", "fabric", "hex_key_small", "hex_key_medium",
                     "hex_key_large"]
Direction = Literal["+x", "-x", "+y", "-y", "z", "rot", "none"]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", use_attribute_docstrings=True, frozen=True,
                              allow_inf_nan=False)


class OpticsConfig(_Model):
    """The sensor (see :class:`~tactile_cli.visuotactile.render.GelOptics`)."""

    width_px: int = Field(default=320, ge=16, le=4096)
    height_px: int = Field(default=240, ge=16, le=4096)
    px_per_mm: float = Field(default=16.0, gt=0, le=1000)
    """Pixels per millimetre on the gel (DIGIT: 320 px over about 20 mm)."""
    noise_std: float = Field(default=2.0, ge=0, le=50)
    """Camera noise, standard deviation in 0-255 units."""
    lighting_jitter: float = Field(default=0.05, ge=0, le=0.5)
    """Per-scene (per-seed) variation of the LEDs: each colour channel scaled by
    1 + jitter * N(0, 1), each LED moved by 10 * jitter mm * N(0, 1); another seed is
    another unit of the sensor."""
    flicker: float = Field(default=0.01, ge=0, le=0.5)
    """Variation of the LED brightness (relative standard deviation): independent between a
    calibration press and its reference; within a trial a slow drift (correlation about
    10 frames), not frame-to-frame jitter."""


class CalibrationConfig(_Model):
    """Ball-bearing presses (sec. II-B: 30 images pressed with a ball bearing)."""

    presses: int = Field(default=30, ge=0, le=10_000)
    ball_radius_mm: list[float] = Field(default=[2.0, 3.0], min_length=1, max_length=100)
    """Radii of the ball bearings used; each press picks one at random."""
    depth_mm: tuple[float, float] = (0.25, 0.8)
    """Range of the press depth (mm); the contact circle's radius is sqrt(2 R d - d^2)."""
    margin_px: int = Field(default=50, ge=0, le=1000)
    """The ball centre stays this far from the frame's edges."""

    @model_validator(mode="after")
    def _ranges(self) -> CalibrationConfig:
        lo, hi = self.depth_mm
        if not 0 < lo <= hi:
            raise ValueError(f"depth_mm (={list(self.depth_mm)}) must be 0 < low <= high")
        if any(r <= hi for r in self.ball_radius_mm):
            raise ValueError(f"every ball_radius_mm (={self.ball_radius_mm}) must exceed the "
                             f"largest depth_mm (={hi})")
        return self


class TrialsConfig(_Model):
    """Objects held, then slipping (sec. III-IV)."""

    objects: list[ObjectName] = Field(default=list(OBJECT_NAMES), min_length=1, max_length=100)
    per_object: int = Field(default=3, ge=0, le=1000)
    """Trials per object: the first holds still (no_slip), the others slip in
    ``directions`` taken in turn (shifted by the object's index, so objects differ); 0: a
    calibration-only scene."""
    directions: list[Direction] = Field(default=["+x", "-y", "z", "rot", "-x", "+y"],
                                        min_length=1, max_length=100)
    frame_rate_hz: float = Field(default=30.0, gt=0, le=1000)
    duration_s: float = Field(default=3.3, gt=0, le=600)
    """Seconds per trial (99 frames at 30 Hz)."""
    static_s: tuple[float, float] = (1.4, 1.8)
    """Range of the static grip before a slip starts (>= 1.2 s: the adaptive threshold
    averages the first 30 slip signals at 30 Hz)."""
    slip_s: tuple[float, float] = (0.3, 1.0)
    """Range of the slip's duration (fast or slow motion)."""
    slip_mm: tuple[float, float] = (1.0, 2.5)
    """Range of the in-plane slip distance (mm); ``rot`` turns by 4 deg per mm and ``z``
    presses 15 % deeper per mm."""
    depth_mm: tuple[float, float] = (0.3, 0.6)
    """Range of the grip's press depth (mm)."""
    tremor_mm: float = Field(default=0.002, ge=0, le=1)
    """Standard deviation (mm) of the press depth's slow drift while held (a real grip is
    never perfectly still; correlation about 10 frames)."""

    @model_validator(mode="after")
    def _ranges(self) -> TrialsConfig:
        for name in ("static_s", "slip_s", "slip_mm", "depth_mm"):
            lo, hi = getattr(self, name)
            if not 0 < lo <= hi:
                raise ValueError(f"{name} (={[lo, hi]}) must be 0 < low <= high")
        if self.static_s[0] < 1.2:
            raise ValueError(f"static_s (={list(self.static_s)}) must start at >= 1.2 s: the "
                             "adaptive threshold needs 30 static slip signals at 30 Hz")
        if self.static_s[1] + self.slip_s[1] >= self.duration_s:
            raise ValueError(f"duration_s (={self.duration_s}) must exceed the longest static "
                             f"grip plus slip ({self.static_s[1] + self.slip_s[1]} s)")
        if self.per_object > 1 and all(d == "none" for d in self.directions):
            raise ValueError("directions must name at least one slip direction (not only none)")
        return self


class DigitSceneConfig(_Model):
    """A whole ``tactile simulate digit-press`` scene."""

    version: Literal[1] = 1
    optics: OpticsConfig = OpticsConfig()
    calibration: CalibrationConfig = CalibrationConfig()
    trials: TrialsConfig = TrialsConfig()

    def with_overrides(self, *, presses: int | None = None, per_object: int | None = None,
                       objects: list[str] | None = None) -> DigitSceneConfig:
        """A copy with the CLI's overrides, validated like the file."""
        from ..config_file import with_overrides

        return with_overrides(self, {"presses": ("calibration.presses", presses),
                                     "per_object": ("trials.per_object", per_object),
                                     "objects": ("trials.objects", objects)})


def load_digit_scene_config(path: str | Path) -> DigitSceneConfig:
    """Read and validate a digit-press scene config (one :class:`InputError` line)."""
    return load_yaml_model(path, DigitSceneConfig, not_a_mapping="a digit-press scene config "
                           "is a YAML mapping; see configs/scene_digit_press.yaml")


__all__ = ["DIRECTIONS", "CalibrationConfig", "DigitSceneConfig", "OpticsConfig",
           "TrialsConfig", "load_digit_scene_config"]
