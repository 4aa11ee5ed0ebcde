"""The typed config of ``tactile simulate marker-events`` (``configs/scene_marker_events.yaml``).

Every parameter of the marker-event scene lives here, with the paper's value as its default
(paper 000: eqs. 16-17 and sec. 4.2 for the FOS parameters, sec. 3.3 and eq. 15 for the
optics, sec. 4.1 for 4 groups x 12 force levels). The YAML file in ``configs/`` repeats
these defaults with a comment per key; a test keeps the two equal.

:func:`load_marker_scene_config` validates a whole file before any event is drawn: unknown keys
are errors (every model forbids extra keys) and any problem becomes one
:class:`~tactile_cli.errors.InputError` naming the file, the line and the key.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    field_validator,
    model_validator,
)

from ..config_file import load_yaml_model
from ..errors import InputError
from ..vocabulary import BIN_S, FORCE_GRADES


class _Model(BaseModel):
    # NaN and infinities are errors: a rate of 1e999 is a typo, not a scene
    model_config = ConfigDict(extra="forbid", use_attribute_docstrings=True, frozen=True,
                              allow_inf_nan=False)


Range = tuple[float, float]
"""``[low, high]``: a per-trial value is drawn uniformly from it (``low == high`` fixes it)."""


def _check_range(name: str, value: Range, *, minimum: float = 0.0) -> Range:
    low, high = value
    if not (low > minimum and high >= low):
        raise ValueError(f"`{name}` (={list(value)}) must be [low, high] with "
                         f"{minimum} < low <= high")
    return value


class TrialsConfig(_Model):
    """Which trials the scene holds: ``groups`` x the selected force levels."""

    groups: int = Field(default=4, ge=1, le=1000)
    """Trial groups; each holds one trial per selected force level (the paper: 4)."""
    n_levels: int = Field(default=12, ge=1, le=1000)
    """Force levels; level k has the k-th of ``n_levels`` press gains spread evenly over
    ``fos.alpha_press_range`` (the paper: 12)."""
    levels: list[int] | None = None
    """The force levels to simulate (1-based); ``null`` for all."""
    force_grades: list[str] = Field(
        default_factory=lambda: list(FORCE_GRADES), min_length=1)
    """Names of the force grades (sec. 4.4, Table III), lowest first; the levels are split
    evenly among them (12 levels, 6 grades: 2 levels per grade)."""

    @model_validator(mode="after")
    def _levels_in_range(self) -> TrialsConfig:
        if self.levels is not None:
            bad = [k for k in self.levels if not 1 <= k <= self.n_levels]
            if bad or not self.levels:
                raise ValueError(f"`levels` (={self.levels}) must be a non-empty list of "
                                 f"levels between 1 and n_levels={self.n_levels}")
            if len(set(self.levels)) != len(self.levels):
                raise ValueError(f"`levels` (={self.levels}) has duplicates")
        if len(self.force_grades) > self.n_levels:
            raise ValueError(f"{len(self.force_grades)} force_grades for {self.n_levels} levels; "
                             "give at most one grade per level")
        return self

    @property
    def selected_levels(self) -> list[int]:
        """The simulated levels, ascending."""
        return sorted(self.levels) if self.levels is not None else list(
            range(1, self.n_levels + 1))

    def grade_of(self, level: int) -> str:
        """The force grade name of a level (levels split evenly among the grades)."""
        return self.force_grades[(level - 1) * len(self.force_grades) // self.n_levels]


class TimingConfig(_Model):
    """Durations of the four action regions, seconds, each drawn per trial from its range
    (uniform, whole milliseconds)."""

    approach_s: Range = (0.3, 0.6)
    """Approach region (no contact: background events only); the press starts after it."""
    press_region_s: Range = (1.15, 1.25)
    """Press region, from the press start to the slip start."""
    press_duration_s: Range = (0.395, 0.405)
    """T of eq. 16: how long the press input lasts (at most the shortest press region)."""
    slip_s: Range = (1.8, 2.2)
    """Slip region, from the slip start to the release start."""
    release_s: Range = (0.6, 1.0)
    """Release region, from the release start to the trial end (rounded up to whole bins)."""
    release_duration_s: Range = (0.15, 0.25)
    """Duration of the release pulse (the markers springing back), at most the release."""

    @model_validator(mode="after")
    def _ranges(self) -> TimingConfig:
        for name in type(self).model_fields:
            _check_range(name, getattr(self, name))
            if getattr(self, name)[1] > 3600:  # an hour of 20 ms bins is already 180 000
                raise ValueError(f"`{name}` high (={getattr(self, name)[1]}) must be at most "
                                 "3600 s")
        if self.press_duration_s[1] > self.press_region_s[0]:
            raise ValueError(f"`press_duration_s` high (={self.press_duration_s[1]}) must be at "
                             f"most `press_region_s` low (={self.press_region_s[0]}): T of eq. "
                             "16 lies inside the press region")
        if self.release_duration_s[1] > self.release_s[0]:
            raise ValueError(f"`release_duration_s` high (={self.release_duration_s[1]}) must be "
                             f"at most `release_s` low (={self.release_s[0]})")
        return self


class FosConfig(_Model):
    """First-order-system parameters (eqs. 16-17); gains in net events per 20 ms bin.

    Every ``*_jitter_rel`` is the relative standard deviation of a per-trial Gaussian
    jitter, clipped at 3 standard deviations: ``value * (1 + jitter_rel * clip(z, -3, 3))``.
    """

    alpha_press_range: Range = (1365.0, 2280.0)
    """alpha_1 of eq. 16: the press gains of level 1 and of the top level (sec. 4.2:
    alpha_1 in [1365, 2280]); the levels in between are spaced evenly."""
    alpha_press_jitter_rel: float = Field(default=0.01, ge=0, le=0.3)
    """Per-trial jitter of alpha_1 around its level's value."""
    tau_press_s: float = Field(default=0.300, gt=0)
    """tau_1 of eq. 16, seconds (sec. 4.2: about 300 ms)."""
    tau_press_jitter_rel: float = Field(default=0.03, ge=0, le=0.3)
    """Per-trial jitter of tau_1."""
    alpha_slip: float = Field(default=1615.0, gt=0, le=1e7)
    """alpha_2 of eq. 17 (sec. 4.2: about 1615)."""
    alpha_slip_jitter_rel: float = Field(default=0.03, ge=0, le=0.3)
    """Per-trial jitter of alpha_2."""
    tau_slip_s: float = Field(default=0.325, gt=0)
    """tau_2 of eq. 17, seconds (sec. 4.2: about 325 ms)."""
    tau_slip_jitter_rel: float = Field(default=0.03, ge=0, le=0.3)
    """Per-trial jitter of tau_2."""
    release_gain: float = Field(default=0.8, ge=0)
    """Release pulse gain as a fraction of alpha_1 (this toolkit's assumption; see
    tactile_cli.fos.actions: the paper fits only press and slip)."""
    release_gain_jitter_rel: float = Field(default=0.05, ge=0, le=0.3)
    """Per-trial jitter of the release gain."""

    @field_validator("alpha_press_range")
    @classmethod
    def _alpha_range(cls, value: Range) -> Range:
        return _check_range("alpha_press_range", value)


class SaturationConfig(_Model):
    """The big-force nonlinearity (sec. 4.2, Fig. 11 right; conclusions): the expected net
    count of a saturated level is ``limit * tanh(net / limit)`` with
    ``limit = alpha_1 / ratio``; levels not listed stay linear."""

    alpha_over_limit: dict[int, float] = Field(default_factory=lambda: {12: 0.6})
    """Force level -> ratio r = alpha_1 / limit (r > 0; bigger r flattens more)."""

    @field_validator("alpha_over_limit")
    @classmethod
    def _positive(cls, value: dict[int, float]) -> dict[int, float]:
        for level, ratio in value.items():
            if not ratio > 0:
                raise ValueError(f"`alpha_over_limit` of level {level} (={ratio}) must be > 0")
        return value


class PolarityConfig(_Model):
    """How the net count splits into positive and negative events (sec. 4.4, Fig. 14)."""

    opposite_fraction: float = Field(default=0.35, ge=0, le=10)
    """beta: pressing darkens the markers (negative events) while the strip apertures open
    (positive events); per bin, positive = (1 + beta) max(net, 0) + beta max(-net, 0) and
    negative = beta max(net, 0) + (1 + beta) max(-net, 0), so positive - negative = net."""


class NoiseConfig(_Model):
    """Noise beside the Poisson counting noise of every bin."""

    background_rate_hz: float = Field(default=2000.0, ge=0, le=1e7)
    """Background events per second over the whole sensor, half of each polarity,
    uniform in space and time; at most 10^7 (ten million events a second of noise alone
    would fill the memory before the scene does)."""


class SensorConfig(_Model):
    """The event camera and its optics (sec. 3.3, eqs. 3 and 15)."""

    width_px: int = Field(default=640, ge=16, le=65535)
    """Sensor width (DVXplorer Mini: 640 px)."""
    height_px: int = Field(default=480, ge=16, le=65535)
    """Sensor height (480 px)."""
    pixel_pitch_m: float = Field(default=9e-6, gt=0)
    """Pixel size (9 um: 640 px = 5.76 mm)."""
    focal_length_m: float = Field(default=3.6e-3, gt=0)
    """Lens focal length f (3.6 mm)."""
    strip_distance_m: float = Field(default=0.03, gt=0)
    """delta of eqs. 3 and 15, the strip-to-camera distance. ASSUMPTION: the paper gives no
    value; 30 mm fits inside its 40 x 50 x 40 mm housing."""


class SlipConfig(_Model):
    """Slip speeds and how the strips move in the image (sec. 5.3, Fig. 23)."""

    speeds_m_s: list[float] = Field(default=[0.002, 0.003, 0.004, 0.005], min_length=1)
    """Slip speeds, m/s (the paper's robot: 0.004 m/s). Trial (group g, level k) gets
    ``speeds_m_s[(g - 1 + k - 1) % len(speeds_m_s)]``, so every group sees every speed
    and, with 4 speeds and 4 groups, every level too."""
    direction_y: int = -1
    """Sign of the strip motion along image y during slip: -1, as the paper's negative
    slope (the object falls while the markers move up), or +1."""

    @field_validator("speeds_m_s")
    @classmethod
    def _positive(cls, value: list[float]) -> list[float]:
        if any(not v > 0 for v in value):
            raise ValueError(f"`speeds_m_s` (={value}) must all be > 0")
        return value

    @field_validator("direction_y")
    @classmethod
    def _sign(cls, value: int) -> int:
        if value not in (-1, 1):
            raise ValueError(f"`direction_y` (={value}) must be -1 or 1")
        return value


class MarkersConfig(_Model):
    """The grid of marker blobs where the negative (darkening) events land."""

    x_px: list[float] = Field(default=[80.0, 200.0, 320.0, 440.0, 560.0], min_length=1)
    """Marker column centres, px."""
    y_px: list[float] = Field(default=[60.0, 140.0, 220.0, 300.0, 380.0, 440.0], min_length=1)
    """Marker row centres, px; the grid is every column x every row."""
    radius_px: float = Field(default=10.0, gt=0)
    """Blob radius, px: events are uniform over the disc."""


class StripsConfig(_Model):
    """The marker strips whose apertures open (positive events) and move during slip."""

    x_px: list[float] = Field(default=[140.0, 260.0, 380.0, 500.0], min_length=1)
    """Strip centres along x, px (one ROI each)."""
    rest_y_px: float = 400.0
    """Centre of every strip's bright band along y at rest (before the slip), px."""
    width_px: int = Field(default=30, ge=1)
    """Strip width along x, px."""
    band_height_px: int = Field(default=40, ge=1)
    """Height of the bright aperture band, px; events are uniform over it."""
    roi_margin_px: int = Field(default=5, ge=0)
    """The ROI of a strip spans its band over the longest possible slip travel plus this
    margin on each side along y."""


class MarkerSceneConfig(_Model):
    """The whole marker-event scene."""

    bin_s: float = Field(default=BIN_S, gt=0, le=1)
    """Bin width of the expected counts, seconds (the paper's 20 ms); whole microseconds."""
    trials: TrialsConfig = Field(default_factory=TrialsConfig)
    """Groups and force levels."""
    timing: TimingConfig = Field(default_factory=TimingConfig)
    """Region durations."""
    fos: FosConfig = Field(default_factory=FosConfig)
    """FOS parameters of eqs. 16-17."""
    saturation: SaturationConfig = Field(default_factory=SaturationConfig)
    """Big-force saturation."""
    polarity: PolarityConfig = Field(default_factory=PolarityConfig)
    """Positive/negative split."""
    noise: NoiseConfig = Field(default_factory=NoiseConfig)
    """Background events."""
    sensor: SensorConfig = Field(default_factory=SensorConfig)
    """Event camera and optics."""
    slip: SlipConfig = Field(default_factory=SlipConfig)
    """Slip speeds."""
    markers: MarkersConfig = Field(default_factory=MarkersConfig)
    """Marker blobs."""
    strips: StripsConfig = Field(default_factory=StripsConfig)
    """Marker strips and their ROIs."""

    @field_validator("bin_s")
    @classmethod
    def _whole_us(cls, value: float) -> float:
        if abs(value * 1e6 - round(value * 1e6)) > 1e-6:
            raise ValueError(f"`bin_s` (={value}) must be a whole number of microseconds")
        return value

    @model_validator(mode="after")
    def _cross_checks(self) -> MarkerSceneConfig:
        bad = sorted(k for k in self.saturation.alpha_over_limit if
                     not 1 <= k <= self.trials.n_levels)
        if bad:
            raise ValueError(f"saturation.alpha_over_limit names levels {bad} outside 1.."
                             f"{self.trials.n_levels} (trials.n_levels)")
        from .layout import scene_layout  # the geometry checks live with the geometry

        scene_layout(self)
        return self

    @property
    def bin_us(self) -> int:
        return round(self.bin_s * 1e6)

    def with_overrides(self, *, groups: int | None = None,
                       levels: list[int] | None = None) -> MarkerSceneConfig:
        """A validated copy with ``trials.groups`` and/or ``trials.levels`` replaced."""
        trials = self.trials.model_dump()
        if groups is not None:
            trials["groups"] = groups
        if levels is not None:
            trials["levels"] = levels
        data = self.model_dump()
        data["trials"] = trials
        try:
            return MarkerSceneConfig.model_validate(data)
        except ValidationError as exc:
            raise InputError(_describe(exc.errors()[0])) from None


def load_marker_scene_config(path: str | Path) -> MarkerSceneConfig:
    """Read and validate a scene config file; any problem is one :class:`InputError` line
    naming the file, the line and the key."""
    return load_yaml_model(path, MarkerSceneConfig, describe=_describe,
                           not_a_mapping="a scene config is a YAML mapping of sections "
                           "(trials, timing, fos, ...); see configs/scene_marker_events.yaml")


def _describe(err: dict[str, Any]) -> str:
    key = ".".join(str(p) for p in err["loc"])
    msg = str(err["msg"]).removeprefix("Value error, ")
    if err["type"] == "extra_forbidden":
        allowed = _allowed_keys(err["loc"][:-1])
        hint = f" (allowed here: {', '.join(allowed)})" if allowed else ""
        return f"unknown key `{key}`{hint}"
    if not key:
        return msg
    value = err.get("input")
    shown = "" if isinstance(value, dict | list) or repr(value) in msg else f" (got {value!r})"
    return f"`{key}`: {msg}{shown}"


def _allowed_keys(loc: tuple[Any, ...]) -> list[str]:
    model: Any = MarkerSceneConfig
    for part in loc:
        field = model.model_fields.get(part) if isinstance(part, str) else None
        annotation = None if field is None else field.annotation
        if not (isinstance(annotation, type) and issubclass(annotation, BaseModel)):
            return []
        model = annotation
    return list(model.model_fields)


__all__ = ["FosConfig", "MarkerSceneConfig", "MarkersConfig", "NoiseConfig", "PolarityConfig",
           "SaturationConfig", "SensorConfig", "SlipConfig", "StripsConfig", "TimingConfig",
           "TrialsConfig", "load_marker_scene_config"]
