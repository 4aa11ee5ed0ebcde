"""The ROI/optics config of the spatial chain: a YAML file, or a scene's ``scene.json``.

A ``scene.json`` of ``tactile simulate marker-events`` (``format:
tactile-marker-events``) gives its sensor grid, optics and strip ROIs; any other JSON file
and every YAML file use these keys (``configs/rois_marker_scene.yaml`` is an example)::

    version: 1
    sensor: {width_px: 640, height_px: 480}        # optional: checked against the file
    optics:                                        # eqs. 3 and 15 (see optics.py)
      pixel_pitch_m: 9.0e-6
      focal_length_m: 3.6e-3
      strip_distance_m: 0.02
    rois:                                          # px, half-open: x0 <= x < x1;
                                                   # none: proposed per trial
      - {name: strip_1, x0_px: 100, y0_px: 150, x1_px: 160, y1_px: 330}
    centroid: {polarity: positive, median: 1, bin_s: 0.02,   # optional (these defaults)
               background: auto}           # approach | none | auto (approach if median 1)
    slip: {edge_trim_s: 0.1}                                 # optional (this default)

An ROI's corners are ``x0_px``, ``y0_px``, ``x1_px``, ``y1_px`` (the fields of
:class:`~tactile_cli.spatial.roi.Roi`, what ``Roi.as_dict`` and a scene's ``scene.json``
write); configs written before the unit was in the names say ``x0``, ``y0``, ``x1``, ``y1``,
read the same way (one spelling per ROI).

Every key is checked before any event is read; an unknown key, a wrong type or a missing
required key is one :class:`InputError` naming the file and the key.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from ..config_file import parse_json, parse_yaml, read_config_text
from ..errors import InputError
from ..vocabulary import BIN_S
from .frames import _check_median
from .optics import StripOptics
from .roi import POLARITIES, Roi

CONFIG_VERSION = 1
#: Largest pixel coordinate or sensor size accepted (event coordinates are 16-bit).
MAX_PX = 65_535
#: Largest optical length accepted, m (a strip 10 m from a fingertip camera is a typo).
MAX_OPTICS_M = 10.0


@dataclass(frozen=True)
class CentroidOptions:
    """How eq. 19 is computed: events of ``polarity`` per pixel, median-filtered over
    ``median`` px (1 = none), in bins of ``bin_s`` seconds. ``background``: ``approach``
    subtracts the uniform background rate measured over the sensor during the trial's
    approach region (unfiltered counts only); ``none`` keeps the raw counts; ``auto`` is
    ``approach`` without a median filter and ``none`` with one (the filter removes
    isolated background events itself)."""

    polarity: str = "positive"
    median: int = 1
    bin_s: float = BIN_S
    background: str = "auto"

    @property
    def subtract_background(self) -> bool:
        return self.background == "approach" or (self.background == "auto" and self.median == 1)


@dataclass(frozen=True)
class SlipOptions:
    """The slip region used for the speed fit: the annotated region shortened by
    ``edge_trim_s`` at both ends (the centroid lags the region's boundaries)."""

    edge_trim_s: float = 0.1


@dataclass(frozen=True)
class SpatialConfig:
    """ROIs, optics and options of the spatial chain, validated. No ROIs: the slip rate
    proposes them per trial from its slip-region events."""

    rois: tuple[Roi, ...]
    optics: StripOptics | None
    width_px: int | None = None
    height_px: int | None = None
    centroid: CentroidOptions = field(default_factory=CentroidOptions)
    slip: SlipOptions = field(default_factory=SlipOptions)
    source: str = ""

    def check_sensor(self, width_px: int, height_px: int) -> None:
        """InputError when the config names another sensor size or an ROI leaves the
        ``width_px`` x ``height_px`` grid of the recording."""
        from .roi import check_rois_on_sensor

        src = self.source or None
        if self.width_px is not None and (self.width_px, self.height_px) != (width_px,
                                                                             height_px):
            raise InputError(f"the config is for a {self.width_px}x{self.height_px} px sensor; "
                             f"the recording's is {width_px}x{height_px} px: use the config "
                             "of that sensor", path=src)
        if self.rois:
            check_rois_on_sensor(self.rois, width_px, height_px, source=src)

    def as_dict(self) -> dict[str, Any]:
        return {
            "version": CONFIG_VERSION,
            "sensor": None if self.width_px is None else
            {"width_px": self.width_px, "height_px": self.height_px},
            "optics": None if self.optics is None else self.optics.as_dict(),
            "rois": [r.as_dict() for r in self.rois],
            "centroid": asdict(self.centroid),
            "slip": asdict(self.slip),
            "source": self.source,
        }


_TOP_KEYS = ("version", "sensor", "optics", "rois", "centroid", "slip")
_SENSOR_KEYS = ("width_px", "height_px")
_OPTICS_KEYS = ("pixel_pitch_m", "focal_length_m", "strip_distance_m")
_ROI_KEYS = ("name", "x0_px", "y0_px", "x1_px", "y1_px")
#: the corners' spelling in configs written before the unit was in the names
_ROI_KEYS_UNITLESS = ("name", "x0", "y0", "x1", "y1")
_CENTROID_KEYS = ("polarity", "median", "bin_s", "background")
BACKGROUNDS = ("auto", "approach", "none")
_SLIP_KEYS = ("edge_trim_s",)


class _Checker:
    def __init__(self, path: str | Path):
        self.path = path

    def fail(self, message: str) -> InputError:
        return InputError(message, path=self.path)

    def mapping(self, value: Any, key: str, allowed: tuple[str, ...],
                required: tuple[str, ...] = ()) -> dict[str, Any]:
        if not isinstance(value, dict):
            raise self.fail(f"`{key}` must be a mapping with keys {', '.join(allowed)}")
        for k in value:
            if k not in allowed:
                raise self.fail(f"unknown key `{key + '.' if key else ''}{k}` "
                                f"(allowed here: {', '.join(allowed)})")
        for k in required:
            if k not in value:
                raise self.fail(f"missing key `{key + '.' if key else ''}{k}`")
        return value

    def number(self, value: Any, key: str, *, positive: bool = True,
               allow_zero: bool = False, maximum: float = 3600.0) -> float:
        """A finite number, > 0 (or >= 0) and at most ``maximum`` (far above any real
        value: a typo with six extra zeros is an error, not an allocation)."""
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.fail(f"`{key}` must be a number (got {value!r})")
        if not math.isfinite(value):
            raise self.fail(f"`{key}` must be finite (got {value!r})")
        if positive and not (value > 0 or (allow_zero and value == 0)):
            raise self.fail(f"`{key}` must be {'>= 0' if allow_zero else '> 0'} (got {value!r})")
        if value > maximum:
            raise self.fail(f"`{key}` (={value!r}) is absurdly large: at most {maximum:g}")
        return float(value)

    def integer(self, value: Any, key: str, *, maximum: int = MAX_PX) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.fail(f"`{key}` must be a whole number of px (got {value!r})")
        if value > maximum:
            raise self.fail(f"`{key}` (={value!r}) is absurdly large: at most {maximum:,} px")
        return int(value)


def config_from_mapping(raw: Any, *, path: str | Path = "<config>") -> SpatialConfig:
    """Validate a parsed YAML/JSON mapping (see the module docstring for the keys)."""
    c = _Checker(path)
    raw = c.mapping(raw, "", _TOP_KEYS)
    if raw.get("version", CONFIG_VERSION) != CONFIG_VERSION:
        raise c.fail(f"`version` is {raw['version']!r}; this tool reads version "
                     f"{CONFIG_VERSION}")
    width = height = None
    if raw.get("sensor") is not None:
        s = c.mapping(raw["sensor"], "sensor", _SENSOR_KEYS, required=_SENSOR_KEYS)
        width = c.integer(s["width_px"], "sensor.width_px")
        height = c.integer(s["height_px"], "sensor.height_px")
    optics = None
    if raw.get("optics") is not None:
        o = c.mapping(raw["optics"], "optics", _OPTICS_KEYS, required=_OPTICS_KEYS)
        optics = StripOptics(*(c.number(o[k], f"optics.{k}", maximum=MAX_OPTICS_M)
                               for k in _OPTICS_KEYS))
    if "rois" in raw and (not isinstance(raw["rois"], list) or not raw["rois"]):
        raise c.fail("`rois` must be a non-empty list of {name, x0_px, y0_px, x1_px, y1_px}")
    rois = []
    for i, item in enumerate(raw.get("rois") or []):
        key = f"rois[{i}]"
        unitless = isinstance(item, dict) and "x0" in item and "x0_px" not in item
        keys = _ROI_KEYS_UNITLESS if unitless else _ROI_KEYS
        r = c.mapping(item, key, keys, required=keys)
        coords = [c.integer(r[k], f"{key}.{k}") for k in keys[1:]]
        try:
            rois.append(Roi(str(r["name"]), *coords))
        except ValueError as exc:
            raise c.fail(f"`{key}`: {exc}") from None
    names = [r.name for r in rois]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise c.fail(f"ROI names must be unique; repeated: {', '.join(dup)}")
    if width is not None and rois:
        from .roi import check_rois_on_sensor

        check_rois_on_sensor(rois, width, height, source=path)
    centroid = CentroidOptions()
    if raw.get("centroid") is not None:
        m = c.mapping(raw["centroid"], "centroid", _CENTROID_KEYS)
        polarity = m.get("polarity", centroid.polarity)
        if polarity not in POLARITIES:
            raise c.fail(f"`centroid.polarity` is {polarity!r}; use one of "
                         f"{', '.join(POLARITIES)}")
        median = c.integer(m.get("median", centroid.median), "centroid.median", maximum=101)
        try:
            _check_median(median)
        except ValueError as exc:
            raise c.fail(f"`centroid.median`: {exc}") from None
        background = m.get("background", "auto")
        if background not in BACKGROUNDS:
            raise c.fail(f"`centroid.background` is {background!r}; use one of "
                         f"{', '.join(BACKGROUNDS)}")
        if background == "approach" and median != 1:
            raise c.fail("`centroid.background: approach` needs `centroid.median: 1` (the "
                         "median filter already removes isolated background events); set "
                         "`background: none`")
        bin_s = c.number(m.get("bin_s", centroid.bin_s), "centroid.bin_s")
        if bin_s < 1e-6:
            raise c.fail(f"`centroid.bin_s` (={bin_s!r}) must be at least 1e-6 s: event times "
                         "are whole microseconds")
        centroid = CentroidOptions(polarity, median, bin_s, background)
    slip = SlipOptions()
    if raw.get("slip") is not None:
        m = c.mapping(raw["slip"], "slip", _SLIP_KEYS)
        slip = SlipOptions(c.number(m.get("edge_trim_s", slip.edge_trim_s), "slip.edge_trim_s",
                                    allow_zero=True))
    return SpatialConfig(tuple(rois), optics, width, height, centroid, slip, str(path))


#: ``format`` of the scene.json that ``tactile simulate marker-events`` writes.
SCENE_FORMAT = "tactile-marker-events"


def scene_mapping(raw: dict[str, Any], path: str | Path) -> dict[str, Any]:
    """The spatial-config keys of a marker-event scene's ``scene.json``: the sensor's grid
    (``sensor.width_px``, ``height_px``), its optics (``sensor.pixel_pitch_m``,
    ``focal_length_m``, ``strip_distance_m``) and the strip ROIs (``rois[].name``,
    ``x0_px``, ``y0_px``, ``x1_px``, ``y1_px``, half-open like ours)."""
    sensor = raw.get("sensor")
    rois = raw.get("rois")
    if not isinstance(sensor, dict) or not isinstance(rois, list):
        raise InputError("scene.json lacks the `sensor` mapping or the `rois` list; re-create "
                         "it with `tactile simulate marker-events`", path=path)
    missing = [k for k in ("width_px", "height_px", "pixel_pitch_m", "focal_length_m",
                           "strip_distance_m") if k not in sensor]
    if missing:
        raise InputError(f"scene.json: `sensor` lacks {', '.join(missing)}", path=path)
    out_rois = []
    for i, r in enumerate(rois):
        if not isinstance(r, dict) or any(k not in r for k in
                                          ("name", "x0_px", "y0_px", "x1_px", "y1_px")):
            raise InputError(f"scene.json: `rois[{i}]` needs name, x0_px, y0_px, x1_px, y1_px",
                             path=path)
        out_rois.append({k: r[k] for k in _ROI_KEYS})
    return {
        "sensor": {"width_px": sensor["width_px"], "height_px": sensor["height_px"]},
        "optics": {k: sensor[k] for k in ("pixel_pitch_m", "focal_length_m",
                                          "strip_distance_m")},
        "rois": out_rois,
    }


def load_config(path: str | Path) -> SpatialConfig:
    """Read a YAML config or a scene's ``scene.json`` (``.json``); InputError when the file
    is missing, does not parse or breaks a key rule."""
    path = Path(path)
    if not path.is_file():
        raise InputError("config file not found", path=path)
    text = read_config_text(path)
    if path.suffix.lower() == ".json":
        raw = parse_json(text, path)  # nesting bounded: never a RecursionError
        if not isinstance(raw, dict):
            raise InputError("a JSON config is a JSON object", path=path)
        if raw.get("format") == SCENE_FORMAT:
            raw = scene_mapping(raw, path)
        return config_from_mapping(raw, path=path)
    return config_from_mapping(parse_yaml(text, path), path=path)
