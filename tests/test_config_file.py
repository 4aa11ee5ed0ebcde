"""YAML configs are read the same way everywhere (tactile_cli.config_file)."""

from __future__ import annotations

import pytest

from tactile_cli.config_file import parse_yaml
from tactile_cli.errors import InputError
from tactile_cli.spatial import load_config


def test_exponent_floats_without_a_dot_are_numbers():
    # PyYAML (YAML 1.1) reads 9e-6 as a string; people write it for a pixel pitch
    got = parse_yaml("a: 9e-6\nb: 9.0e-6\nc: 1e3\nd: -2E+2\ne: 12\nf: 1_000\ng: .5\n"
                     "h: '9e-6'\ni: 1e\nj: e5\n", "x.yaml")
    assert got == {"a": 9e-6, "b": 9e-6, "c": 1000.0, "d": -200.0, "e": 12, "f": 1000,
                   "g": 0.5, "h": "9e-6", "i": "1e", "j": "e5"}
    assert isinstance(got["c"], float) and isinstance(got["e"], int)


def test_optics_written_with_exponents_are_read(tmp_path):
    cfg = tmp_path / "optics.yaml"
    cfg.write_text("version: 1\nsensor: {width_px: 640, height_px: 480}\n"
                   "optics: {pixel_pitch_m: 9e-6, focal_length_m: 3.6e-3, "
                   "strip_distance_m: 3e-2}\n")
    optics = load_config(cfg).optics
    assert (optics.pixel_pitch_m, optics.focal_length_m, optics.strip_distance_m) == \
        (9e-6, 3.6e-3, 0.03)


def test_python_tags_are_still_refused(tmp_path):
    with pytest.raises(InputError, match="not valid YAML"):
        parse_yaml("a: !!python/object/apply:os.system ['true']\n", tmp_path / "x.yaml")


# -- nesting bounded (issue 33) ------------------------------------------------------------
@pytest.mark.slow
def test_yaml_and_json_nested_thousands_deep_are_one_error(tmp_path):
    from tactile_cli.config_file import MAX_NESTING, parse_json, parse_yaml

    deep = "[" * 20000 + "]" * 20000
    for parse in (parse_yaml, parse_json):
        with pytest.raises(InputError, match=f"nested more than {MAX_NESTING} levels deep"):
            parse(deep, tmp_path / "deep.txt")


def test_nesting_up_to_the_bound_is_read(tmp_path):
    from tactile_cli.config_file import MAX_NESTING, nesting_depth, parse_json, parse_yaml

    ok = "[" * MAX_NESTING + "1" + "]" * MAX_NESTING
    assert nesting_depth(parse_json(ok, "ok.json")) == MAX_NESTING
    assert nesting_depth(parse_yaml(ok, "ok.yaml")) == MAX_NESTING
    over = "[" * (MAX_NESTING + 1) + "]" * (MAX_NESTING + 1)
    with pytest.raises(InputError):
        parse_json(over, "over.json")
    with pytest.raises(InputError, match=r"bad.json, line 1, column 2: not valid JSON"):
        parse_json("{x", "bad.json")


def test_an_anchor_bomb_is_walked_once_per_shared_level(tmp_path):
    from tactile_cli.config_file import nesting_depth, parse_yaml

    levels = ["a0: &a0 [x, x, x, x, x, x, x, x, x, x]"]
    levels += [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 10)}]" for i in range(1, 9)]
    value = parse_yaml("\n".join(levels) + "\n", tmp_path / "bomb.yaml")  # 10^9 leaves
    assert nesting_depth(value) == 10
