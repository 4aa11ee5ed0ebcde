"""Typed configs of the taxel-array chain (paper 004): the sensor presets, the
``tactile simulate taxel-slip`` scene and the slip-interface features.

Unknown keys are errors; every problem is one :class:`~tactile_cli.errors.InputError` that
names the file, the line and the key.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from ..config_file import load_yaml_model

PRESET_NAMES = ("biotac", "capacitive", "pvdf")
SLIP_TYPES = ("hand", "world")


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", use_attribute_docstrings=True, frozen=True,
                              allow_inf_nan=False)


class PresetConfig(_Model):
    """One sensor of sec. 4: taxels per finger, their sampling and their skin."""

    n_taxels: int = Field(ge=2, le=256)
    """Taxels (electrodes, capacitive pads, PVDF strips) per finger."""
    rate_hz: float = Field(gt=0, le=1e5)
    """Samples per second of each taxel."""
    slot_hz: float = Field(gt=0, le=1e6)
    """The converter's conversion rate; the scene is simulated on this grid and taxel i is
    read at slot ``first_slot + i * slot_stride`` of each sampling period (sequential
    sampling), or every taxel at slot 0 when ``sequential`` is false."""
    sequential: bool
    first_slot: int = Field(default=0, ge=0)
    slot_stride: int = Field(default=1, ge=1)
    bandwidth_hz: float = Field(gt=0)
    """Physical bandwidth of a taxel (4th-order low pass before sampling)."""
    crosstalk: float = Field(ge=0, lt=1)
    """Crosstalk between taxels of a 1-D chain: a taxel senses ``crosstalk ** d`` of the
    input of the taxel ``d`` places away (rows normalised)."""
    noise: float = Field(ge=0)
    """Sensor noise, standard deviation in channel units."""
    vibration: float = Field(gt=0)
    """Vibration amplitude (channel units) of a rough texture at the reference grip."""
    contact_fraction: float = Field(gt=0, le=1)
    """Share of the taxels under the contact patch."""
    static_per_n: float = Field(ge=0)
    """Static response of a taxel in contact per newton of grip (0: a dynamic-only sensor
    such as PVDF)."""
    grip_n: tuple[float, float]
    """Range of grip forces (N), drawn per trial."""
    speed_cm_s: tuple[float, float]
    """Range of nominal slip speeds (cm/s), drawn per trial."""
    texture_mode_hz: float = Field(gt=0)
    """Fundamental of the skin's texture elements, excited by stick-slip at the skin."""
    pressure_rate_hz: float | None = Field(default=None, gt=0)
    """A fluid-pressure channel per finger at this rate (BioTac PAC), or none."""
    units: str = "a.u."

    @model_validator(mode="after")
    def _check(self) -> PresetConfig:
        ratio = self.slot_hz / self.rate_hz
        if abs(ratio - round(ratio)) > 1e-9:
            raise ValueError(f"slot_hz (={self.slot_hz}) must be a whole multiple of rate_hz "
                             f"(={self.rate_hz})")
        last = self.first_slot + (self.n_taxels - 1) * self.slot_stride if self.sequential \
            else 0
        if last >= round(ratio):
            raise ValueError(f"the {self.n_taxels} taxels need {last + 1} slots but a "
                             f"sampling period has {round(ratio)}")
        if not 0 < self.grip_n[0] <= self.grip_n[1] or \
                not 0 < self.speed_cm_s[0] <= self.speed_cm_s[1]:
            raise ValueError("grip_n and speed_cm_s must be ranges (lo <= hi) of positive "
                             "values")
        return self

    @property
    def slots_per_sample(self) -> int:
        return int(round(self.slot_hz / self.rate_hz))

    def delays_s(self) -> np.ndarray:
        """(n_taxels,) each taxel's sampling delay (s) within a sampling period."""
        if not self.sequential:
            return np.zeros(self.n_taxels)
        return (self.first_slot + np.arange(self.n_taxels) * self.slot_stride) / self.slot_hz


def default_presets() -> dict[str, PresetConfig]:
    """The three sensors of sec. 4 with plausible skins (amplitudes are arbitrary units)."""
    p = PresetConfig
    return {
        # 19 impedance electrodes at 100 Hz read between the 4.4 kHz pressure samples:
        # electrode i at slot 2 i + 1 of the 44 slots of a period; fluid couples them
        "biotac": p(n_taxels=19, rate_hz=100.0, slot_hz=4400.0, sequential=True,
                    first_slot=1, slot_stride=2, bandwidth_hz=45.0, crosstalk=0.25,
                    noise=0.02, vibration=0.5, contact_fraction=0.6, static_per_n=0.4,
                    grip_n=(1.5, 3.5), speed_cm_s=(2.0, 5.0), texture_mode_hz=30.0,
                    pressure_rate_hz=4400.0, units="a.u."),
        # 12 pads per AD7147, read one after the other at 12 x 300 Hz
        "capacitive": p(n_taxels=12, rate_hz=300.0, slot_hz=3600.0, sequential=True,
                        bandwidth_hz=140.0, crosstalk=0.1, noise=0.02, vibration=0.4,
                        contact_fraction=0.75, static_per_n=0.05, grip_n=(10.0, 20.0),
                        speed_cm_s=(2.0, 5.0), texture_mode_hz=120.0, units="pF"),
        # 8 PVDF strips per fingertip on an AD7608: simultaneous, 1.5 kHz anti-alias filter
        "pvdf": p(n_taxels=8, rate_hz=3125.0, slot_hz=6250.0, sequential=False,
                  bandwidth_hz=1500.0, crosstalk=0.15, noise=0.02, vibration=0.5,
                  contact_fraction=1.0, static_per_n=0.0, grip_n=(5.5, 10.0),
                  speed_cm_s=(2.0, 5.0), texture_mode_hz=1360.0, units="V"),
    }


class TextureConfig(_Model):
    """A held object's surface (Table 1): stick-slip events every ``period_mm`` of travel
    with relative strength ``roughness``."""

    period_mm: float = Field(gt=0)
    roughness: float = Field(gt=0, le=10)


def default_textures() -> dict[str, TextureConfig]:
    t = TextureConfig
    return {"A_smooth": t(period_mm=1.0, roughness=0.3), "B_holes_1.6": t(period_mm=6.35,
            roughness=0.6), "C_holes_3.2": t(period_mm=6.35, roughness=0.8),
            "D_skin": t(period_mm=2.0, roughness=0.6), "E_slats": t(period_mm=6.35,
            roughness=1.0), "F_grit60": t(period_mm=0.25, roughness=1.0),
            "G_grit150": t(period_mm=0.1, roughness=0.7), "H_grit400": t(period_mm=0.04,
            roughness=0.45)}


class TaxelSceneConfig(_Model):
    """``tactile simulate taxel-slip`` (``configs/scene_taxel_slip.yaml``)."""

    presets: tuple[Literal["biotac", "capacitive", "pvdf"], ...] = PRESET_NAMES
    """Which sensors to simulate (each trial uses one)."""
    trials_per_class: int = Field(default=30, ge=1, le=2000)
    """Trials per sensor and slip type (object/hand, object/world)."""
    rest_s: float = Field(default=0.5, gt=0, le=60)
    """At rest without contact at the start (the noise reference of contact estimation)."""
    slip_s: float = Field(default=2.0, gt=0, le=60)
    """Slipping after contact."""
    speed_jitter: float = Field(default=0.3, ge=0, le=1)
    """Manual motion: relative standard deviation of the speed around its nominal value,
    wandering slower than 3 Hz."""
    mix: float = Field(default=0.6, ge=0, le=1)
    """Largest amplitude of the other slip type's vibration in a trial, relative, drawn
    uniformly per trial (object/hand slip shakes the object; object/world slip makes the
    skin micro-slip)."""
    crosstalk: float | None = Field(default=None, ge=0, lt=1)
    """Replaces every preset's crosstalk (stability studies); None: the presets' own."""
    noise_scale: float = Field(default=1.0, ge=0, le=1000)
    """Multiplies every preset's sensor noise (stability studies)."""
    fingers: int = Field(default=2, ge=2, le=3)
    preset: dict[str, PresetConfig] = Field(default_factory=default_presets)
    textures: dict[str, TextureConfig] = Field(default_factory=default_textures)

    @model_validator(mode="after")
    def _check(self) -> TaxelSceneConfig:
        missing = [p for p in self.presets if p not in self.preset]
        if missing:
            raise ValueError(f"presets {missing} have no entry under preset")
        if not self.textures:
            raise ValueError("textures must name at least one texture")
        return self

    def with_overrides(self, *, presets: list[str] | None = None,
                       trials_per_class: int | None = None) -> TaxelSceneConfig:
        """A copy with the CLI's overrides (``presets`` once each, in order), validated like
        the file."""
        from ..config_file import with_overrides

        return with_overrides(self, {
            "presets": ("presets", None if not presets else list(dict.fromkeys(presets))),
            "trials_per_class": ("trials_per_class", trials_per_class)})


class WelchConfig(_Model):
    """Welch settings of one preset's features (Hann segments)."""

    nperseg: int = Field(ge=8, le=1 << 16)
    """Segment length (samples) of the taxel streams."""
    pressure_nperseg: int = Field(default=256, ge=8, le=1 << 16)
    """Segment length (samples) of a pressure stream (multi-finger G2 of the BioTac)."""
    max_band_bins: int = Field(default=8, ge=1, le=1024)
    """Widest band (in Welch bins) of the best-band search."""
    overlap: float = Field(default=0.5, ge=0, lt=1)
    """Share of a segment that the next one overlaps (taxels and pressure)."""

    def noverlap(self, nperseg: int) -> int:
        """Samples shared by consecutive segments of ``nperseg`` samples."""
        return min(int(round(self.overlap * nperseg)), nperseg - 1)


def default_welch() -> dict[str, WelchConfig]:
    w = WelchConfig
    return {"biotac": w(nperseg=64, max_band_bins=6), "capacitive": w(nperseg=128),
            "pvdf": w(nperseg=256)}


class FeatureConfig(_Model):
    """``tactile features spectral`` and ``tactile slip-interface``
    (``configs/taxel_features.yaml``)."""

    contact_threshold: float = Field(default=4.0, gt=0)
    """A taxel is in contact when its mean shifts, or its vibration RMS rises, by more than
    this many at-rest standard deviations (sec. 5.2.1)."""
    gate_ratio: float = Field(default=2.0, ge=1)
    """Noise-floor gate: no decision when no taxel's slip RMS exceeds the at-rest noise by
    this factor."""
    window_s: float = Field(default=1.0, gt=0)
    """``features spectral``: window length (s)."""
    hop_s: float = Field(default=0.25, gt=0)
    """``features spectral``: window step (s)."""
    bands_hz: dict[str, dict[str, tuple[float, float]]] = Field(default_factory=lambda: {
        "biotac": {"low": (1.0, 15.0), "mid": (15.0, 35.0), "high": (35.0, 50.0)},
        "capacitive": {"low": (2.0, 40.0), "mid": (40.0, 100.0), "high": (100.0, 150.0)},
        "pvdf": {"low": (10.0, 300.0), "mid": (300.0, 1000.0), "high": (1000.0, 1560.0)}})
    """``features spectral``: named bands [lo, hi] Hz per preset (plus the full spectrum)."""
    welch: dict[str, WelchConfig] = Field(default_factory=default_welch)
    """Welch settings per preset (a stream of another preset takes ``biotac``'s)."""
    folds: int = Field(default=10, ge=2, le=100)
    inner_folds: int = Field(default=5, ge=2, le=100)
    """Folds of the band search inside each training set (nested)."""
    seed: int = Field(default=0, ge=0)
    """Seed of the fold assignment."""
    sequential_correction: bool = True
    contact_estimation: bool = True

    @model_validator(mode="after")
    def _bands(self) -> FeatureConfig:
        for preset, bands in self.bands_hz.items():
            for name, (lo, hi) in bands.items():
                if not (np.isfinite(lo) and np.isfinite(hi) and 0 <= lo < hi):
                    raise ValueError(f"band bands_hz.{preset}.{name} (={[lo, hi]}) must be "
                                     "[low, high] Hz with 0 <= low < high")
        return self


def load_taxel_scene_config(path: str | Path) -> TaxelSceneConfig:
    """Read and validate a taxel-slip scene config (one :class:`InputError` line)."""
    return load_yaml_model(path, TaxelSceneConfig, not_a_mapping="a taxel-slip scene config is a "
                           "YAML mapping; see configs/scene_taxel_slip.yaml")


def load_feature_config(path: str | Path) -> FeatureConfig:
    """Read and validate a taxel feature config (one :class:`InputError` line)."""
    return load_yaml_model(path, FeatureConfig, not_a_mapping="a taxel feature config is a "
                           "YAML mapping; see configs/taxel_features.yaml")
