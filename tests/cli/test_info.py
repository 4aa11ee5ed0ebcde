"""`tactile info`: what a train config needs (streams, rates, channel names, units, labels,
splits), labels with many values summarised, and one-line errors for paths that are not
tactile files."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.ingest import ingest
from tactile_cli.store import StoreWriter, summarize
from tactile_cli.store.labels import MAX_VALUES_LISTED

from ..conftest import REPO, shared_path

runner = CliRunner()
N_TRIALS = 60
TAXELS = [f"txl{i}_{a}" for i in range(1, 17) for a in "xyz"]


def _file(path: Path) -> Path:
    """60 trials: a grasp id per trial, 12 materials, a continuous force, splits, and a
    48-channel taxel stream with a per-sample slip label (10 of 20 samples in odd trials)."""
    with StoreWriter(path, command="test") as w:
        s = w.add_sensor("skin", kind="taxel_array", sample_rate_hz=59.8,
                         channel_names=TAXELS, channel_units="counts")
        for i in range(N_TRIALS):
            labels = {"grasp": f"g{1000 + i}", "material": f"mat{i % 12 + 1}",
                      "force_n": 0.5 + i * 0.25}
            split = ("train", "val", "test")[i % 3] if i < 30 else ""
            slip = np.zeros(20, dtype=np.int8)
            if i % 2:
                slip[10:] = 1
            w.trial(f"t{i}", labels=labels, split=split).write_signal(
                "taxels", sensor=s, data=np.zeros((20, 48)), t_s=np.arange(20) / 59.8,
                sample_labels={"slip": (slip, ["no_slip", "slip"]),
                               "depth_mm": (np.full(20, i % 3, dtype=np.float64), None)})
        w.commit()
    return path


@pytest.fixture(scope="module")
def info_file(tmp_path_factory) -> Path:
    return _file(tmp_path_factory.mktemp("info") / "many.h5")


def test_table_summarises_many_values_and_counts_few(info_file):
    result = runner.invoke(app, ["info", str(info_file)])
    assert result.exit_code == 0, result.output
    out = result.output.split("Trial labels (trials per value)")[1]  # after the trials table
    assert N_TRIALS > MAX_VALUES_LISTED
    assert "60 distinct values over 60 trials (one each); e.g. g1000, g1001, g1002, g1003, ..." \
        in out
    assert "g1059" not in out  # not listed in full
    assert "60 distinct values over 60 trials (one each), 0.5 to 15.25; e.g. 0.5, 0.75" in out
    materials = ", ".join(f"mat{k}: 5" for k in range(1, 13))  # natural order: mat2 < mat10
    assert materials in out
    assert "no_slip: 900, slip: 300 (1,200 samples)" in out
    assert "0: 400, 1: 400, 2: 400 (1,200 samples)" in out
    assert "splits: train 10, val 10, test 10, none 30" in out


def test_table_names_streams_channels_rate_and_units(info_file):
    out = runner.invoke(app, ["info", str(info_file)]).output
    row = next(line for line in out.splitlines() if line.startswith("│ skin "))
    cells = [c.strip() for c in row.strip("│").split("│")]
    assert cells == ["skin", "taxel_array", "taxels", "59.8",
                     "txl1_x, txl1_y, txl1_z .. txl16_z (48)", "counts", ""]


def test_json_lists_everything(info_file):
    result = runner.invoke(app, ["info", str(info_file), "--json"])
    assert result.exit_code == 0
    data = json.loads(result.output)
    (sensor,) = data["sensors"]
    assert sensor["channel_names"] == TAXELS and sensor["channel_units"] == ["counts"] * 48
    assert sensor["streams"] == ["taxels"] and sensor["sample_rate_hz"] == 59.8
    assert len(data["label_counts"]["grasp"]) == N_TRIALS
    assert list(data["label_counts"]["material"])[:3] == ["mat1", "mat2", "mat3"]
    slip = next(lc for lc in data["sample_labels"] if lc["name"] == "slip")
    assert slip["counts"] == {"no_slip": 900, "slip": 300} and slip["stream"] == "taxels"
    assert data["splits"] == {"train": 10, "val": 10, "test": 10, "": 30}


def test_numbers_sort_by_value(tmp_path):
    with StoreWriter(tmp_path / "n.h5", command="test") as w:
        s = w.add_sensor("acc", kind="accelerometer", sample_rate_hz=10, channel_names=["a"],
                         channel_units="g")
        for i, level in enumerate([10, 2, 1, 2]):
            w.trial(f"t{i}", labels={"level": level}).write_signal(
                "acc", sensor=s, data=np.zeros((3, 1)), t_s=np.arange(3) / 10)
        w.commit()
    (lc,) = summarize(tmp_path / "n.h5").trial_labels
    assert lc.brief() == "1: 1, 2: 2, 10: 1"


def test_real_xela_slip_counts(tmp_path):
    root = shared_path("xela_slip")
    out = ingest([root], tmp_path / "x.h5", options={
        "mapping": REPO / "configs" / "xela_slip.yaml"}, command="test")
    result = runner.invoke(app, ["info", str(out)])
    assert result.exit_code == 0, result.output
    assert "no_slip: 1,999, slip: 196 (2,195 samples)" in result.output
    assert "txl1_x, txl1_y, txl1_z .. txl16_z (48)" in result.output


# -- paths that are not tactile files ---------------------------------------------------------
def _one_line_error(path: Path) -> str:
    result = runner.invoke(app, ["info", str(path)])
    assert result.exit_code == 2, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.output
    assert "->" not in lines[0] and "addr" not in lines[0]  # no HDF5 C internals
    return lines[0]


def test_folder_is_one_line_naming_what_to_do(tmp_path, info_file):
    (tmp_path / "raw").mkdir()
    assert _one_line_error(tmp_path / "raw") == (
        f"tactile: error: {tmp_path / 'raw'}: is a folder, not a tactile HDF5 file; make one "
        f"from the recordings in it with `tactile ingest {tmp_path / 'raw'} --out FILE.h5`")
    assert _one_line_error(info_file.parent) == (
        f"tactile: error: {info_file.parent}: is a folder, not a tactile HDF5 file; give one of "
        "the files in it (many.h5)")


def test_files_that_are_not_hdf5_say_what_to_do(tmp_path, info_file):
    raw = tmp_path / "rec.aedat4"
    raw.write_bytes(b"#!AER-DAT4.0\r\n" + bytes(200))
    # info reads a raw AEDAT4 file itself (tests/ingest/test_aedat4_without_events.py): a
    # damaged one is the AEDAT4 reader's one line
    assert _one_line_error(raw) == (f"tactile: error: {raw}: AEDAT4 file header is damaged "
                                    "(its IOHeader cannot be parsed); re-export or re-copy "
                                    "the recording")
    raw_npy = tmp_path / "rec.npy"
    raw_npy.write_bytes(b"\x93NUMPY" + bytes(200))
    # so does every raw format (tests/ingest/test_describe.py): a damaged NPY array is the
    # NPY reader's one line
    assert _one_line_error(raw_npy).startswith(
        f"tactile: error: {raw_npy}: not a readable .npy array (damaged header or data: ")
    text = tmp_path / "notes.txt"
    text.write_text("hello\n")
    assert _one_line_error(text).endswith("not a readable HDF5 file (no HDF5 signature: another "
                                          "format, or a damaged file); give a file that "
                                          "`tactile ingest` wrote")
    empty = tmp_path / "empty.h5"
    empty.write_bytes(b"")
    assert "(the file is empty)" in _one_line_error(empty)
    cut = tmp_path / "cut.h5"
    data = info_file.read_bytes()
    cut.write_bytes(data[: len(data) // 2])
    assert _one_line_error(cut).endswith(
        f"not a readable HDF5 file (cut short: {len(data) // 2:,} of {len(data):,} bytes); "
        "copy it again, or write it again with the command that made it")
