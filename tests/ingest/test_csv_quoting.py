"""Standard CSV quoting in every CSV that ingest reads: a quoted field may hold the delimiter,
doubled quotes and line breaks (mapped CSVs and their rate files, trial labels, annotations,
image-sequence timestamps, the accelerometer tree); errors still name the file and line."""

from __future__ import annotations

import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from tactile_cli.errors import InputError
from tactile_cli.ingest import ingest, mapped_csv
from tactile_cli.ingest.image_sequence import read_timestamps
from tactile_cli.ingest.mapped_csv import read_csv_table
from tactile_cli.ingest.mapping import CsvDialect
from tactile_cli.ingest.sidecars import read_annotations, read_trial_labels
from tactile_cli.samples.events import write_events_npy
from tactile_cli.samples.signals import write_accel_tree

from ..conftest import REPO, shared_path

#: A notes cell with a comma, a doubled quote and a line break: one field of valid CSV.
NOTES = '"slipped, regrasped; ""box"" moved\nby 2 cm"'
NOTES_VALUE = 'slipped, regrasped; "box" moved\nby 2 cm'

FOLDER_MAPPING = """\
trials: {layout: folder, glob: "run_*"}
streams:
  - name: skin
    file: skin.csv
    kind: taxel_array
    channels: [a, b]
    units: counts
    time: {column: t, rate_from: {file: meta.csv, column: hz}}
    sample_labels: [{name: phase, column: phase, classes: [press, "slip, fast"]}]
"""


def _run(folder: Path, skin: str, meta: str) -> None:
    folder.mkdir(parents=True)
    (folder / "skin.csv").write_text(skin)
    (folder / "meta.csv").write_text(meta)


def _ingest(inputs: list[Path], out: Path, *, format: str = "auto",
            trial_labels: Path | None = None, **options) -> Path:
    return ingest(inputs, out, format=format, options=options, trial_labels=trial_labels,
                  command="test")


# -- mapped CSVs --------------------------------------------------------------------------------
def test_rate_file_with_a_quoted_notes_field(tmp_path):
    """A meta file whose notes field holds commas, quotes and a line break (11 raw commas
    against 9 header fields would be refused by a reader without quoting)."""
    _run(tmp_path / "raw" / "run_1",
         "t,a,b,phase\n0.0,1,2,press\n0.02,3,4,\"slip, fast\"\n0.04,5,6,press\n",
         f"dropped,notes,hz,sensor\n0,{NOTES},50.0,\"xela, glove\"\n")
    (tmp_path / "m.yaml").write_text(FOLDER_MAPPING)
    out = _ingest([tmp_path / "raw"], tmp_path / "q.h5", mapping=tmp_path / "m.yaml")
    with h5py.File(out) as h5:
        skin = h5["trials/run_1/signals/skin"]
        assert skin.attrs["sample_rate_hz"] == 50.0
        np.testing.assert_array_equal(skin["data"][()], [[1, 2], [3, 4], [5, 6]])
        np.testing.assert_array_equal(skin["sample_labels/phase"][()], [0, 1, 0])


def test_quoted_table_values_and_lines(tmp_path):
    path = tmp_path / "t.csv"
    path.write_text('"t","note","x"\n0.5,"a, b",1.5\n1.0,' + NOTES + ',"2.5"\n1.5,"",3.5\n\n')
    table = read_csv_table(path, CsvDialect(), numeric=["t", "x"], text=["note"])
    assert table.names == ("t", "note", "x")
    np.testing.assert_array_equal(table.columns["x"], [1.5, 2.5, 3.5])
    assert list(table.columns["note"]) == ["a, b", NOTES_VALUE, ""]
    assert [table.line(i) for i in range(3)] == [2, 3, 5]  # row 1 spans lines 3-4


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('t,note,x\n0.5,"a, b",1.5\n1.0,' + NOTES + ',oops\n', r"t\.csv, line 3, column 'x': "
         r"column 'x' holds 'oops', which is not a number"),
        ('t,note,x\n0.5,"a, b",1.5\n1.0,' + NOTES + ',2\n2.0,"c",3,4\n', r"t\.csv, line 5: row "
         r"has 4 fields, expected 3"),
        ('t,note,x\n0.5,"a, b",1.5\n1.0,"x"y,2\n', r"t\.csv, line 3: not valid CSV"),
        ('t,note,x\n0.5,"a, b",1.5\n1.0,"never closed,2\n', r"t\.csv, line 3: not valid CSV"),
        ('t,note,x\n0.5,"a",inf\n', r"t\.csv, line 2, column 'x': column 'x' holds inf"),
        ('t,note,x\n0.5,"a",1\n\n1.0,"b",2\n', r"t\.csv, line 3: blank line inside the data"),
    ],
)
def test_quoted_table_errors_name_file_and_line(tmp_path, text, message):
    path = tmp_path / "t.csv"
    path.write_text(text)
    with pytest.raises(InputError, match=message) as info:
        read_csv_table(path, CsvDialect(), numeric=["t", "x"], text=["note"])
    assert "\n" not in str(info.value)


def test_files_without_quotes_keep_the_fast_path(tmp_path, monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("the csv module was used for a file without quotes")

    monkeypatch.setattr(mapped_csv, "csv_records", refuse)
    path = tmp_path / "t.csv"
    path.write_text("t,x\n0.5,1.5\n1.0,2.5\n")
    table = read_csv_table(path, CsvDialect(), numeric=["t", "x"])
    np.testing.assert_array_equal(table.columns["x"], [1.5, 2.5])
    assert table.row_lines is None and table.line(1) == 3


def test_trailing_delimiter_with_quotes(tmp_path):
    path = tmp_path / "t.csv"
    path.write_text('t,"x"\n0.5,1.5,\n1.0,"2,5",\n')
    with pytest.raises(InputError, match=r"line 3, column 'x': column 'x' holds '2,5'"):
        read_csv_table(path, CsvDialect(trailing_delimiter=True), numeric=["t", "x"])
    path.write_text('t,"x"\n0.5,1.5,\n1.0,"2",\n')
    table = read_csv_table(path, CsvDialect(trailing_delimiter=True), numeric=["t", "x"])
    np.testing.assert_array_equal(table.columns["x"], [1.5, 2.0])


def test_real_xela_trial_with_a_quoted_notes_field(tmp_path):
    src = sorted(p for p in shared_path("xela_slip").iterdir() if p.is_dir())[0]
    copy = tmp_path / "xela" / src.name
    shutil.copytree(src, copy)
    header, row = (copy / "meta_data.csv").read_text().splitlines()[:2]
    cells = row.split(",")
    cells[1] = NOTES  # the notes column
    (copy / "meta_data.csv").write_text(header + "\n" + ",".join(cells) + "\n")
    out = _ingest([tmp_path / "xela"], tmp_path / "x.h5",
                  mapping=REPO / "configs" / "xela_slip.yaml")
    with h5py.File(out) as h5:
        rate = h5["trials"][src.name]["signals/sensor1"].attrs["sample_rate_hz"]
    assert rate == float(cells[3])


# -- sidecars, timestamps, accelerometer tree ---------------------------------------------------
def test_trial_labels_and_annotations_with_quotes(tmp_path):
    labels = tmp_path / "labels.csv"
    labels.write_text(f'trial,note,"grip, mm"\nrec_a,{NOTES},12\n"rec_b","plain",3\n')
    parsed = read_trial_labels(labels)
    assert parsed.rows["rec_a"] == ({"note": NOTES_VALUE, "grip_mm": 12}, 2)
    assert parsed.rows["rec_b"] == ({"note": "plain", "grip_mm": 3}, 4)  # after a 2-line row
    ann = tmp_path / "ann.csv"
    ann.write_text(f'trial,start_s,end_s,label\nrec_a,0,0.1,"press, firm"\nrec_a,0.1,0.2,{NOTES}\n')
    rows = read_annotations(ann).rows["rec_a"]
    assert [(r[2], r[3]) for r in rows] == [("press, firm", 2), (NOTES_VALUE, 3)]
    bad = tmp_path / "bad.csv"
    bad.write_text('trial,note\nrec_a,"ok"\nrec_b,"open\n')
    with pytest.raises(InputError, match=r"bad\.csv, line 3: not valid CSV"):
        read_trial_labels(bad)


def test_trial_labels_applied_through_ingest(tmp_path):
    write_events_npy(tmp_path / "rec_a.npy", 100, width=16, height=16, seed=0)
    labels = tmp_path / "labels.csv"
    labels.write_text(f"trial,note\nrec_a,{NOTES}\n")
    out = _ingest([tmp_path / "rec_a.npy"], tmp_path / "e.h5", width_px=16, height_px=16,
                  trial_labels=labels)
    with h5py.File(out) as h5:
        assert h5["trials/rec_a/labels"].attrs["note"] == NOTES_VALUE


def test_timestamps_with_quoted_file_names(tmp_path):
    frames = [tmp_path / "frame, 1.png", tmp_path / 'frame "2".png']
    ts = tmp_path / "timestamps.csv"
    ts.write_text('file,t_s\n"frame, 1.png",0.0\n"frame ""2"".png","0.04"\n')
    np.testing.assert_array_equal(read_timestamps(ts, frames).t_s, [0.0, 0.04])


def test_accel_tree_with_a_quoted_header(tmp_path):
    truth = write_accel_tree(tmp_path / "tree", objects=("wood",), orientations=("0",),
                             seconds=0.002, seed=2)
    (trial,) = truth["trials"].values()
    path = trial["path"]
    lines = path.read_text().splitlines(keepends=True)
    names = lines[0].strip().split(",")
    path.write_text(",".join(f'"{n}"' for n in names) + "\n" + "".join(lines[1:]))
    out = _ingest([tmp_path / "tree"], tmp_path / "a.h5", format="accel-tree")
    with h5py.File(out) as h5:
        (g,) = h5["trials"].values()
        assert g["signals/accel/data"].shape == (len(lines) - 1, 6)
