"""`tactile samples DIR`: one small recording of every input format, and the commands that
ingest them."""

from __future__ import annotations

import csv
import shlex

import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app

runner = CliRunner()
N_EVENTS = 300
FORMATS = ("events_csv", "events_npy", "accel", "taxel", "visuotactile", "ros1_bag", "ros2_bag",
           "mcap", "video")


def _samples(out, *args):
    result = runner.invoke(app, ["samples", str(out), "--n-events", str(N_EVENTS), *args])
    assert result.exit_code == 0, result.output
    return result


def _tree(root):
    """Every file under ``root``: relative path -> bytes."""
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in root.rglob("*") if p.is_file()}


@pytest.mark.slow
def test_samples_writes_every_format(tmp_path):
    out = tmp_path / "s"
    _samples(out)
    with open(out / "events.csv", newline="") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["t", "x", "y", "p"] and len(rows) == 1 + N_EVENTS
    assert {r[3] for r in rows[1:]} == {"0", "1"}
    npy = np.load(out / "events.npy")
    assert npy.dtype.names == ("t", "x", "y", "p") and len(npy) == N_EVENTS
    assert set(np.unique(npy["p"])) == {-1, 1}
    assert np.all(np.diff(npy["t"]) >= 0)
    assert npy["x"].max() < 640 and npy["y"].max() < 480
    # paper 001 layout: object/orientation/speed/data.csv
    assert sorted(p.relative_to(out / "accel_tree").parts[0] for p in
                  (out / "accel_tree").glob("*/*/*/data.csv")) == ["aluminum"] * 2 + ["wood"] * 2
    assert (out / "taxel" / "taxels.yaml").is_file()
    assert len(list((out / "taxel").glob("*.csv"))) == 4
    for press in ("press_01", "press_02"):
        folder = out / "visuotactile" / press
        assert len(list(folder.glob("frame_*.png"))) == 12
        assert (folder / "reference.png").is_file() and (folder / "timestamps.csv").is_file()


@pytest.mark.slow
def test_samples_printed_commands_ingest_every_format(tmp_path):
    out = tmp_path / "s"
    result = _samples(out)
    lines = result.output.strip().splitlines()
    assert [line.split(":", 1)[0] for line in lines] == list(FORMATS)
    for line in lines:
        name, command = line.split(": ", 1)
        args = shlex.split(command)
        assert args[0] == "tactile" and args[-2:] == ["--out", f"{name}.h5"]
        h5 = tmp_path / f"{name}.h5"
        ingest = runner.invoke(app, [*args[1:-1], str(h5), "--no-progress"])
        assert ingest.exit_code == 0, (name, ingest.output)
        assert h5.is_file()


@pytest.mark.slow
def test_samples_same_seed_same_bytes(tmp_path):
    _samples(tmp_path / "a", "--seed", "7")
    _samples(tmp_path / "b", "--seed", "7")
    _samples(tmp_path / "c", "--seed", "8")
    a, b, c = (_tree(tmp_path / k) for k in "abc")
    # 2 event files, 4 accel CSVs, 4 taxel CSVs + mapping, 2 x 14 image files, and robot/:
    # press.bag, press.mcap, press.mp4, topics.yaml, press_ros2/{metadata.yaml,press_ros2.mcap}
    assert len(a) == 45
    assert a == b
    assert a.keys() == c.keys()
    differ = {k for k in a if a[k] != c[k]}
    assert {"events.csv", "events.npy", "visuotactile/press_01/frame_5.png", "robot/press.bag",
            "robot/press.mcap"} <= differ
