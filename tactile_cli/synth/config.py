"""The typed config of ``tactile synth`` (``configs/synth_fos.yaml``).

Every value has a default here (the YAML file repeats them with a comment per key; a test
keeps the two equal). :func:`load_synth_config` validates a whole file before anything is
drawn: unknown keys are errors, and a problem is one
:class:`~tactile_cli.errors.InputError` naming the file, the line and the key.

A range ``[low, high]`` is drawn uniformly per trial (``low == high`` fixes it).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from ..config_file import load_yaml_model
from ..errors import InputError
from ..vocabulary import BIN_S, FORCE_GRADES

Range = tuple[float, float]


class _Model(BaseModel):
    # NaN and infinities are errors: a gain of 1e999 is a typo, not a distribution
    model_config = ConfigDict(extra="forbid", use_attribute_docstrings=True, frozen=True,
                              allow_inf_nan=False)


def _range(name: str, value: Range, *, minimum: float | None = 0.0) -> Range:
    low, high = value
    if not high >= low or (minimum is not None and not low > minimum):
        lower = "" if minimum is None else f"{minimum} < "
        raise ValueError(f"`{name}` (={list(value)}) must be [low, high] with {lower}low <= high")
    return value


class LevelsConfig(_Model):
    """The force levels a synthetic trial is drawn from, and their grade names."""

    n_levels: int = Field(default=12, ge=1, le=1000)
    """Force levels 1..n_levels (the paper: 12)."""
    levels: list[int] | None = None
    """Levels to draw from (uniformly), e.g. [1, 6, 12]; null = all."""
    force_grades: list[str] = Field(
        default_factory=lambda: list(FORCE_GRADES), min_length=1)
    """Grade names, lowest first, the levels split evenly among them (as the scene does);
    used unless the fits file's trials carry force_grade labels."""

    @model_validator(mode="after")
    def _check(self) -> LevelsConfig:
        if self.levels is not None:
            bad = [k for k in self.levels if not 1 <= k <= self.n_levels]
            if bad or not self.levels or len(set(self.levels)) != len(self.levels):
                raise ValueError(f"`levels` (={self.levels}) must be distinct levels between 1 "
                                 f"and n_levels={self.n_levels}")
        if len(self.force_grades) > self.n_levels:
            raise ValueError(f"{len(self.force_grades)} force_grades for {self.n_levels} "
                             "levels; give at most one grade per level")
        return self

    @property
    def selected(self) -> list[int]:
        return sorted(self.levels) if self.levels is not None else list(
            range(1, self.n_levels + 1))

    def grade_of(self, level: int) -> str:
        return self.force_grades[(level - 1) * len(self.force_grades) // self.n_levels]


class TimingConfig(_Model):
    """Region durations in s, drawn per trial (action times are continuous, so the 20 ms
    bin grid has a random phase against them)."""

    approach_s: Range = (0.2, 0.8)
    """Trial start -> press start: no contact, background only."""
    press_after_s: Range = (0.3, 1.3)
    """End of the press input (T) -> slip start; the press region lasts T + this."""
    slip_s: Range = (0.6, 2.5)
    """Slip start -> release start."""
    release_s: Range = (0.5, 1.2)
    """Release start -> trial end."""
    release_duration_s: Range = (0.15, 0.25)
    """Length of the release pulse (at most release_s low)."""

    @field_validator("*")
    @classmethod
    def _positive(cls, value: Range, info: Any) -> Range:
        return _range(info.field_name, value)

    @model_validator(mode="after")
    def _release_fits(self) -> TimingConfig:
        if self.release_duration_s[1] > self.release_s[0]:
            raise ValueError(f"`release_duration_s` high (={self.release_duration_s[1]}) must "
                             f"not exceed `release_s` low (={self.release_s[0]})")
        return self


class FosConfig(_Model):
    """FOS parameters per force level when no ``--fits`` file is given: the paper's values
    (sec. 4.2). Each is log-normal per trial around its level's value with the relative
    spread ``*_jitter_rel`` (the sd of its logarithm). Gains in events per bin."""

    alpha_press_range: Range = (1365.0, 2280.0)
    """alpha_1 of eq. 16 at level 1 and at the last level, evenly spaced between (paper)."""
    alpha_press_jitter_rel: float = Field(default=0.02, ge=0)
    tau_press_s: float = Field(default=0.300, gt=0)
    """tau_1 of eq. 16 (paper: about 300 ms)."""
    tau_press_jitter_rel: float = Field(default=0.03, ge=0)
    press_duration_s: Range = (0.3, 0.5)
    """T of eq. 16, uniform (not in the paper; the scene's range). Also used with --fits when
    the fits had T known rather than fitted."""
    alpha_slip: float = Field(default=1615.0, gt=0, le=1e7)
    """alpha_2 of eq. 17 (paper: about 1615)."""
    alpha_slip_jitter_rel: float = Field(default=0.03, ge=0)
    tau_slip_s: float = Field(default=0.325, gt=0)
    """tau_2 of eq. 17 (paper: about 325 ms)."""
    tau_slip_jitter_rel: float = Field(default=0.03, ge=0)
    release_gain: Range = (0.7, 0.9)
    """Release pulse gain as a fraction of alpha_1 (toolkit assumption; never fitted)."""

    @field_validator("alpha_press_range", "press_duration_s", "release_gain")
    @classmethod
    def _ranges(cls, value: Range, info: Any) -> Range:
        return _range(info.field_name, value)


class FitsConfig(_Model):
    """How a ``--fits`` file's converged fits become per-level distributions."""

    exclude_second_order: bool = True
    """Leave out fits whose order verdict is second_order (or relaxation): the FOS does
    not describe those trials (the scene's saturated big force), so their FOS parameters
    are not ones to draw."""
    min_fits_per_level: int = Field(default=1, ge=1)
    """Levels with fewer converged fits get their means interpolated between the others."""


class NoiseConfig(_Model):
    """Counting noise of the two polarities around the expected net count mu per bin:
    positive = k Poisson(((1 + beta) max(mu, 0) + beta max(-mu, 0) + background) / k),
    negative likewise with the signs swapped; the net is their difference (mean mu)."""

    opposite_fraction: float = Field(default=0.5, ge=0)
    """beta: events of the opposite polarity per net event (markers darken while strips
    open, paper Fig. 14); the scene's value."""
    background_per_bin: Range = (15.0, 25.0)
    """Background events per bin and polarity (Poisson mean), drawn per trial."""
    counting_scale: float = Field(default=1.0, gt=0)
    """k: the counting noise variance is k times Poisson's (1 = Poisson)."""

    @field_validator("background_per_bin")
    @classmethod
    def _bg(cls, value: Range) -> Range:
        if not 0 <= value[0] <= value[1]:
            raise ValueError(f"`background_per_bin` (={list(value)}) must be [low, high] with "
                             "0 <= low <= high")
        return value


class InitialConfig(_Model):
    """Random initial conditions of a trial."""

    baseline_per_bin: Range = (-2.0, 2.0)
    """A constant offset of the expected net count, events per bin."""
    state_per_bin: Range = (-20.0, 20.0)
    """The system's output at t = 0 (a previous action's leftover), decaying with the
    trial's tau_press."""

    @field_validator("*")
    @classmethod
    def _ordered(cls, value: Range, info: Any) -> Range:
        return _range(info.field_name, value, minimum=None)


class SaturationConfig(_Model):
    """Optional big-force flattening, as the scene models it: level -> r, the expected net
    count becomes limit * tanh(net / limit) with limit = alpha_press / r."""

    alpha_over_limit: dict[int, float] = Field(default_factory=dict)

    @field_validator("alpha_over_limit")
    @classmethod
    def _positive(cls, value: dict[int, float]) -> dict[int, float]:
        bad = {k: v for k, v in value.items() if not v > 0}
        if bad:
            raise ValueError(f"`alpha_over_limit` values must be > 0, got {bad}")
        return value


class CentroidsConfig(_Model):
    """The model of the ROI centroid trajectories that ``tactile synth --centroids ROIS``
    adds (tactile_cli/synth/centroids.py; the ROIs and optics come from the ROIS file).
    Ranges are drawn per trial."""

    speeds_m_s: Range = (0.001, 0.006)
    """Slip speed, m/s, uniform; px/s through the optics of eqs. 3 and 15."""
    direction_y: Literal[-1, 1] = -1
    """The strips move towards smaller (-1) or larger (+1) y during the slip (paper Fig. 23:
    negative slope)."""
    band_height_px: Range = (30.0, 50.0)
    """Height of the bright band of strip events, px; events are uniform over it."""
    rest_inset_px: Range = (15.0, 35.0)
    """Band centre at rest: this far inside the ROI edge the slip moves away from, px."""
    roi_fraction: Range = (0.8, 1.0)
    """Share of the positive signal events that land in the ROIs (split evenly)."""

    @field_validator("speeds_m_s", "band_height_px", "rest_inset_px", "roi_fraction")
    @classmethod
    def _ranges(cls, value: Range, info: Any) -> Range:
        _range(info.field_name, value)
        if info.field_name == "roi_fraction" and value[1] > 1:
            raise ValueError(f"`roi_fraction` (={list(value)}) must lie in (0, 1]")
        return value


class SynthConfig(_Model):
    """Everything ``tactile synth`` draws from (see configs/synth_fos.yaml)."""

    bin_s: float = Field(default=BIN_S, gt=0, le=1)
    """Bin width of the event counts, s (the paper's 20 ms)."""
    width_px: int = Field(default=640, ge=1, le=65535)
    """Sensor geometry recorded on the event_counts sensor (the paper's 640 x 480)."""
    height_px: int = Field(default=480, ge=1, le=65535)
    levels: LevelsConfig = LevelsConfig()
    timing: TimingConfig = TimingConfig()
    fos: FosConfig = FosConfig()
    fits: FitsConfig = FitsConfig()
    noise: NoiseConfig = NoiseConfig()
    initial: InitialConfig = InitialConfig()
    saturation: SaturationConfig = SaturationConfig()
    centroids: CentroidsConfig = CentroidsConfig()
    """Used with ``--centroids ROIS`` only."""

    def with_bin_s(self, bin_s: float | None) -> SynthConfig:
        """A copy with ``bin_s`` replaced (None keeps it)."""
        if bin_s is None:
            return self
        try:
            return SynthConfig.model_validate({**self.model_dump(), "bin_s": bin_s})
        except ValidationError as exc:
            raise InputError(_describe(exc.errors()[0])) from None


def load_synth_config(path: str | Path | None) -> SynthConfig:
    """Read and validate a synth config (None: the defaults); any problem is one
    :class:`InputError` naming the file, the line and the key."""
    if path is None:
        return SynthConfig()
    # an empty (or all-comment) file: a truncated config, not the defaults
    return load_yaml_model(
        path, SynthConfig, describe=_describe,
        empty="empty config; a synth config is a YAML mapping of sections (levels, timing, "
        "fos, ...), see configs/synth_fos.yaml (leave the config out for the defaults)",
        not_a_mapping="a synth config is a YAML mapping of sections (levels, timing, fos, "
        "...); see configs/synth_fos.yaml")


def _describe(err: dict[str, Any]) -> str:
    key = ".".join(str(p) for p in err["loc"])
    msg = str(err["msg"]).removeprefix("Value error, ")
    if err["type"] == "extra_forbidden":
        return f"unknown key `{key}`; see configs/synth_fos.yaml for the keys"
    return f"`{key}`: {msg}" if key else msg


__all__ = ["CentroidsConfig", "FitsConfig", "FosConfig", "InitialConfig", "LevelsConfig",
           "NoiseConfig", "SaturationConfig", "SynthConfig", "TimingConfig", "load_synth_config"]
