"""`ingest --format accel-tree`: the object/orientation/speed CSV tree of paper 001."""

from __future__ import annotations

import hashlib
from pathlib import Path

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.ingest import ingest
from tactile_cli.ingest.accel_tree import MOTION_CLASSES, motion_class
from tactile_cli.samples.signals import write_accel_tree
from tactile_cli.store import validate_file

runner = CliRunner()


def _ingest(inputs, out, **kw) -> Path:
    return ingest([Path(p) for p in inputs], out, format="accel-tree",
                  command="test", **kw)


class CountingProgress:
    def __init__(self) -> None:
        self.total = None
        self.advanced = 0

    def start(self, total: float, description: str) -> None:
        self.total = total

    def advance(self, amount: float = 1) -> None:
        self.advanced += amount

    def finish(self) -> None:
        pass


def test_motion_rule_threshold_and_tie():
    v_slip = np.array([0.0, 0.049, -0.049, 0.05, -0.2, 0.0, 0.3, -0.06, 0.01])
    v_slide = np.array([0.0, 0.049, 0.0, 0.0, 0.0, -0.05, 0.3, 0.2, 0.1])
    want = ["no_motion", "no_motion", "no_motion", "slip", "slip", "slide", "slip", "slip", "slide"]
    assert [MOTION_CLASSES[c] for c in motion_class(v_slip, v_slide)] == want


def test_round_trip_exact(tmp_path):
    truth = write_accel_tree(tmp_path / "tree", objects=("wood", "plastic"),
                             orientations=("0", "45"), speeds=("0.16", "0.48"), seconds=0.01,
                             seed=7)
    assert {t["header"] for t in truth["trials"].values()} == {True, False}
    progress = CountingProgress()
    out = _ingest([tmp_path / "tree"], tmp_path / "a.h5", progress=progress)
    assert progress.total == 8 and progress.advanced == 8
    assert validate_file(out).ok
    with h5py.File(out) as h5:
        acc = h5["sensors/accel"]
        assert acc.attrs["kind"] == "accelerometer" and acc.attrs["sample_rate_hz"] == 8000.0
        assert acc.attrs["full_scale_g"] == 5.0
        assert list(acc["channel_names"].asstr()[()]) == ["L_x", "L_y", "L_z", "R_x", "R_y", "R_z"]
        assert set(acc["channel_units"].asstr()[()]) == {"fs5g"}
        vel = h5["sensors/velocity"]
        assert vel.attrs["kind"] == "robot_state"
        assert list(vel["channel_units"].asstr()[()]) == ["m/s", "m/s"]
        paths = list(h5["provenance/sources/path"].asstr()[()])
        shas = list(h5["provenance/sources/sha256"].asstr()[()])
        assert sorted(h5["trials"]) == sorted(truth["trials"])
        seen_classes = set()
        for name, want in truth["trials"].items():
            g = h5["trials"][name]
            assert dict(g["labels"].attrs) == want["labels"]
            np.testing.assert_array_equal(g["signals/accel/data"][()], want["accel"])
            np.testing.assert_array_equal(g["signals/velocity/data"][()], want["velocity"])
            n = len(want["accel"])
            np.testing.assert_array_equal(g["signals/accel/t_s"][()], np.arange(n) / 8000.0)
            np.testing.assert_array_equal(g["signals/velocity/t_s"][()], np.arange(n) / 8000.0)
            motion = g["signals/accel/sample_labels/motion"]
            np.testing.assert_array_equal(motion[()], want["motion"])
            assert list(motion.attrs["classes"]) == list(MOTION_CLASSES)
            assert "slip if |v_slip| >= 0.05 m/s" in motion.attrs["rule"]
            seen_classes |= set(motion[()].tolist())
            (index,) = g.attrs["source_index"]
            assert paths[index] == str(want["path"])
            assert shas[index] == hashlib.sha256(want["path"].read_bytes()).hexdigest()
        assert seen_classes == {0, 1, 2}


def test_several_csvs_in_one_folder_get_their_stem(tmp_path):
    truth = write_accel_tree(tmp_path / "tree", objects=("wood",), orientations=("15",),
                             seconds=0.002)
    (path,) = [t["path"] for t in truth["trials"].values()]
    (path.parent / "second.csv").write_bytes(path.read_bytes())
    out = _ingest([tmp_path / "tree"], tmp_path / "a.h5")
    with h5py.File(out) as h5:
        assert sorted(h5["trials"]) == ["wood_15_0.16_data", "wood_15_0.16_second"]


def _tree_with_one_file(tmp_path: Path) -> Path:
    truth = write_accel_tree(tmp_path / "tree", objects=("wood",), orientations=("0",),
                             seconds=0.002, seed=2)
    (trial,) = truth["trials"].values()
    assert trial["header"]  # the first file of a tree has a header row; drop it
    path = trial["path"]
    path.write_text("".join(path.read_text().splitlines(keepends=True)[1:]))
    return path


def _replace_line(path: Path, line: int, text: str) -> None:
    lines = path.read_text().splitlines()
    lines[line - 1] = text
    path.write_text("\n".join(lines) + "\n")


@pytest.mark.parametrize(
    ("line", "text", "message"),
    [
        (5, "0.1,0.2,0.3,0.4,0.5,0.6,0.01", r"line 5: row has 7 fields, expected 8"),
        (1, "0.1,0.2,0.3,0.4,0.5,0.6,0.01", r"line 1: first line has 7 fields, expected 8"),
        (3, "0.1,0.2,0.3,0.4,0.5,0.6,0.01,0.02,0.0", r"line 3: row has 9 fields, expected 8"),
        (4, "0.1,0.2,x,0.4,0.5,0.6,0.01,0.02", r"line 4, column 'L_z': column 'L_z' holds 'x', "
                                               r"which is not a number"),
        (6, "0.1,0.2,0.3,0.4,0.5,0.6,nan,0.02",
         r"line 6, column 'v_slip': column 'v_slip' holds nan"),
    ],
)
def test_bad_rows_name_file_and_line(tmp_path, line, text, message):
    path = _tree_with_one_file(tmp_path)
    _replace_line(path, line, text)
    outdir = tmp_path / "out"
    outdir.mkdir()
    with pytest.raises(InputError, match=message) as info:
        _ingest([tmp_path / "tree"], outdir / "a.h5")
    assert str(info.value).startswith(f"{path}, line {line}")
    assert list(outdir.iterdir()) == []


def test_bad_layouts(tmp_path):
    path = _tree_with_one_file(tmp_path)
    stray = tmp_path / "tree" / "wood" / "notes.csv"
    stray.write_text("1,2\n")
    with pytest.raises(InputError, match=r"notes\.csv: CSV at the wrong depth: expected "
                                         r".*/<object>/<orientation>/<speed>/<file>\.csv"):
        _ingest([tmp_path / "tree"], tmp_path / "a.h5")
    with pytest.raises(InputError, match=r"data\.csv: accel-tree inputs are root folders"):
        _ingest([path], tmp_path / "a.h5")
    (tmp_path / "empty").mkdir()
    with pytest.raises(InputError, match=r"empty: no <object>/<orientation>/<speed>/<file>\.csv"):
        _ingest([tmp_path / "empty"], tmp_path / "a.h5")
    assert not (tmp_path / "a.h5").exists()


@pytest.mark.parametrize(
    ("line", "text", "message"),
    [(5, "0.1,0.2,0.3", "line 5: row has 3 fields, expected 8"),
     (2, "0.1,0.2,0.3,0.4,0.5,0.6,0.01,--",
      "line 2, column 'v_slide': column 'v_slide' holds '--'")],
)
def test_cli_bad_input_is_one_line_exit_2(tmp_path, line, text, message):
    path = _tree_with_one_file(tmp_path)
    _replace_line(path, line, text)
    outdir = tmp_path / "out"
    outdir.mkdir()
    result = runner.invoke(app, ["ingest", str(tmp_path / "tree"), "--format", "accel-tree",
                                 "--out", str(outdir / "a.h5")])
    assert result.exit_code == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1
    assert lines[0].startswith(f"tactile: error: {path}, {message}")
    assert list(outdir.iterdir()) == []


def test_cli_success(tmp_path):
    truth = write_accel_tree(tmp_path / "tree", seconds=0.002)
    out = tmp_path / "a.h5"
    result = runner.invoke(app, ["ingest", str(tmp_path / "tree"), "--format", "accel-tree",
                                 "--out", str(out)])
    assert result.exit_code == 0, result.stderr
    with h5py.File(out) as h5:
        assert sorted(h5["trials"]) == sorted(truth["trials"])
