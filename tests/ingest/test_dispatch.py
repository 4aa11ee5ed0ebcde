"""Format detection, run-wide labels and the input errors shared by every format."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.ingest import detect_format, ingest, parse_labels

runner = CliRunner()


def test_detect_by_suffix(tmp_path):
    assert detect_format([tmp_path / "a.aedat4"]).name == "aedat4"
    assert detect_format([tmp_path / "a.NPY"]).name == "events-npy"
    assert detect_format([tmp_path / "a.csv"]).name == "events-csv"
    assert detect_format([tmp_path], options={"mapping": tmp_path / "m.yaml"}).name == \
        "mapped-csv"
    assert detect_format([tmp_path], format="accel-tree").name == "accel-tree"


def test_unknown_and_mixed_formats(tmp_path):
    with pytest.raises(InputError, match=r"a\.txt: unknown format \(suffix '\.txt'\)"):
        detect_format([tmp_path / "a.txt"])
    with pytest.raises(InputError, match="inputs mix formats"):
        detect_format([tmp_path / "a.csv", tmp_path / "b.npy"])
    with pytest.raises(InputError, match="unknown format 'hdf4'; use one of"):
        detect_format([tmp_path / "a.csv"], format="hdf4")
    (tmp_path / "d").mkdir()
    with pytest.raises(InputError,
                       match=r"cannot tell the format of a folder \(no PNG/JPG frames in it or "
                             r"in its subfolders\); pass `format='accel-tree'`"):
        detect_format([tmp_path / "d"])


def test_parse_labels():
    assert parse_labels(["object=box", "speed=0.02", "force_level=3", "note=a=b"]) == {
        "object": "box",
        "speed": 0.02,
        "force_level": 3,
        "note": "a=b",
    }
    with pytest.raises(InputError, match="`labels` 'object' must look like key=value"):
        parse_labels(["object"])


def test_missing_input_names_the_file(tmp_path):
    with pytest.raises(InputError, match=r"nope\.aedat4: file not found"):
        ingest([tmp_path / "nope.aedat4"], tmp_path / "out.h5")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["{tmp}/nope.aedat4"], "{tmp}/nope.aedat4: file not found"),
        (["{tmp}/notes.txt"], "{tmp}/notes.txt: unknown format (suffix '.txt')"),
        (["{tmp}/notes.txt", "--label", "bad"], "--label 'bad' must look like key=value"),
    ],
)
def test_cli_input_errors_are_one_line_exit_2(tmp_path, args, message):
    (tmp_path / "notes.txt").write_text("hello")
    out = tmp_path / "out.h5"
    result = runner.invoke(
        app, ["ingest", *[a.format(tmp=tmp_path) for a in args], "--out", str(out)]
    )
    assert result.exit_code == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("tactile: error: ")
    assert message.format(tmp=tmp_path) in lines[0]
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]


def test_cli_existing_output_needs_overwrite(tmp_path):
    out = tmp_path / "out.h5"
    out.write_bytes(b"earlier")
    (tmp_path / "notes.txt").write_text("x")
    result = runner.invoke(
        app, ["ingest", str(tmp_path / "notes.txt"), "--format", "events-csv", "--out", str(out)]
    )
    assert result.exit_code == 2
    assert f"{out}: output exists; pass --overwrite to replace it" in result.stderr
    assert out.read_bytes() == b"earlier"
