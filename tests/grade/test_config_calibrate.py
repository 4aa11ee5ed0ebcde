"""Grader configs (validation, round trip, the shipped default) and calibration."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from tactile_cli.errors import InputError
from tactile_cli.grade import (
    AreaCalibrator,
    FuzzyGrader,
    config_from_dict,
    default_config_path,
    load_config,
    save_config,
)

from ..factories.press_regions import expected_press, grades_of, level_alpha, press_areas

REPO = Path(__file__).resolve().parents[2]


def _raw() -> dict:
    return yaml.safe_load(default_config_path().read_text())


def test_shipped_default_is_the_repository_config():
    assert default_config_path().read_bytes() == (REPO / "configs/grade_marker.yaml").read_bytes()
    cfg = load_config(default_config_path())
    assert cfg.grades == ("light", "small", "small_medium", "medium", "small_big", "big")
    assert [(r.if_, r.then) for r in cfg.rules][0] == ("very_small", "light")
    assert cfg.provenance["n_trials"] > 0
    assert cfg.system().method == "closed_form"


def test_unknown_key_is_named_with_its_line(tmp_path):
    text = default_config_path().read_text().replace("    small:\n      mf: trapmf",
                                                     "    small:\n      mff: 1\n      mf: trapmf")
    path = tmp_path / "c.yaml"
    path.write_text(text)
    with pytest.raises(InputError) as exc:
        load_config(path)
    msg = str(exc.value)
    assert "unknown key `input.terms.small.mff` (allowed here: mf, params)" in msg
    line = text.splitlines().index("      mff: 1") + 1
    assert msg.startswith(f"{path}, line {line}: ")


@pytest.mark.parametrize("edit,message", [
    (lambda d: d["rules"].append({"if": "huge", "then": "big"}),
     "rules[6].if: 'huge' is not an input term"),
    (lambda d: d["input"]["terms"]["small"].update(params=[1, 2, 3]),
     "`input.terms.small`: trapmf takes 4 parameters, got 3"),
    (lambda d: d["output"].update(range=[1, 0]), "`output.range`: range must be [low, high]"),
    (lambda d: d.pop("rules"), "missing key `rules`"),
    (lambda d: d["input"]["terms"]["small"].update(params=[30000, 30500, 31000, 31500]),
     "no rule fires for an input area of"),
    (lambda d: d.update(rules=d["rules"][:5]), "output term(s) big appear in no rule"),
])
def test_config_errors(edit, message):
    raw = _raw()
    edit(raw)
    with pytest.raises(InputError, match=None) as exc:
        config_from_dict(raw)
    assert message in str(exc.value)


def test_save_round_trip_is_atomic(tmp_path):
    cfg = load_config(default_config_path())
    out = save_config(cfg, tmp_path / "x.yaml", header="line one\nline two")
    text = out.read_text()
    assert text.startswith("# line one\n# line two\n")
    assert load_config(out) == cfg
    assert not list(tmp_path.glob(".*tmp*"))


# -- calibration -------------------------------------------------------------------------------
def _ideal_boundaries(**timing) -> np.ndarray:
    """Expected area halfway between the two levels facing each grade boundary."""
    areas = np.array([expected_press(a, **timing).sum() for a in level_alpha(np.arange(1, 13))])
    return 0.5 * (areas[1:-1:2] + areas[2::2])


def test_calibration_recovers_grade_boundaries_and_grades_new_trials():
    rng = np.random.default_rng(7)
    levels = np.tile(np.arange(1, 13), 20)
    areas = press_areas(levels, rng)
    cal = AreaCalibrator().fit(areas, grades_of(levels), 6)
    ideal = _ideal_boundaries()
    spacing = np.diff(ideal).mean() / 2  # one force level
    assert np.all(np.abs(cal.boundaries_ - ideal) < 0.1 * spacing)
    traps = cal.trapezoids()
    for k, b in enumerate(cal.boundaries_):  # neighbours cross at 0.5 exactly there
        (_, _, c, d), (a, bb, _, _) = traps[k], traps[k + 1]
        assert (c, d) == (a, bb) and 0.5 * (c + d) == pytest.approx(b, abs=1e-9)
    cfg = cal.to_config(load_config(default_config_path()))
    test_levels = np.tile(np.arange(1, 13), 25)
    res = FuzzyGrader(cfg).grade(press_areas(test_levels, rng))
    err = res.grade - grades_of(test_levels)
    assert np.mean(err == 0) >= 0.99 and np.abs(err).max() <= 1


def test_calibration_with_a_saturated_top_level():
    rng = np.random.default_rng(8)
    levels = np.tile(np.arange(1, 13), 20)
    cal = AreaCalibrator().fit(press_areas(levels, rng, top_r=0.6), grades_of(levels), 6)
    # the facing quartiles keep the small_big/big boundary between levels 10 and 11
    ideal = _ideal_boundaries()
    assert abs(cal.boundaries_[-1] - ideal[-1]) < 0.5 * np.diff(ideal).mean() / 2


def test_calibration_refuses_areas_that_do_not_order_the_grades():
    areas = np.array([1.0, 2.0, 5.0, 6.0, 3.0, 4.0])
    with pytest.raises(ValueError, match="median area of grade 2 .* is not above that of "
                                         "grade 1"):
        AreaCalibrator().fit(areas, np.array([0, 0, 1, 1, 2, 2]), 3)
    with pytest.raises(ValueError, match=r"no labelled trial of grade\(s\) \[2\]"):
        AreaCalibrator().fit(areas[:4], np.array([0, 0, 1, 1]), 3)
