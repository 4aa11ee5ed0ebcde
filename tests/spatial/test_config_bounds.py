"""The ROI/optics config refuses absurd numbers with their key (issue 20, item 5)."""

from __future__ import annotations

import pytest

from tactile_cli.errors import InputError
from tactile_cli.spatial.config import config_from_mapping

BASE = {"version": 1, "sensor": {"width_px": 640, "height_px": 480},
        "optics": {"pixel_pitch_m": 9e-6, "focal_length_m": 3.6e-3, "strip_distance_m": 0.02},
        "rois": [{"name": "s1", "x0": 100, "y0": 150, "x1": 160, "y1": 330}],
        "centroid": {"median": 1, "bin_s": 0.02}, "slip": {"edge_trim_s": 0.1}}


def _with(section: str, key: str, value):
    raw = {k: (dict(v) if isinstance(v, dict) else v) for k, v in BASE.items()}
    raw[section][key] = value
    return raw


def test_the_base_config_is_valid():
    cfg = config_from_mapping(BASE, path="rois.yaml")
    assert cfg.width_px == 640 and cfg.centroid.bin_s == 0.02


@pytest.mark.parametrize("section, key, value, message", [
    ("sensor", "width_px", 10**12, "`sensor.width_px` (=1000000000000) is absurdly large"),
    ("optics", "strip_distance_m", 1e300, "`optics.strip_distance_m` (=1e+300) is absurdly"),
    ("optics", "focal_length_m", float("inf"), "`optics.focal_length_m` must be finite"),
    ("optics", "pixel_pitch_m", float("nan"), "`optics.pixel_pitch_m` must be finite"),
    ("centroid", "median", 10**6 + 1, "`centroid.median` (=1000001) is absurdly large"),
    ("centroid", "bin_s", 1e-9, "`centroid.bin_s` (=1e-09) must be at least 1e-6 s"),
    ("centroid", "bin_s", 1e12, "`centroid.bin_s` (=1000000000000.0) is absurdly large"),
    ("slip", "edge_trim_s", 1e9, "`slip.edge_trim_s` (=1000000000.0) is absurdly large"),
])
def test_absurd_numbers_are_refused_with_their_key(section, key, value, message):
    with pytest.raises(InputError, match=message.replace("(", r"\(").replace(")", r"\)")
                       .replace("+", r"\+")) as err:
        config_from_mapping(_with(section, key, value), path="rois.yaml")
    assert str(err.value).startswith("rois.yaml")
