"""`tactile ingest --annotations FILE --trial-labels FILE` and the events' `t_origin_us`.

Sidecars round-trip exactly (floats as written, numbers as numbers, text as text); every
bad row is one error line naming the file and the line, with exit code 2 and no output.
"""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.ingest import ingest
from tactile_cli.ingest.sidecars import number_or_text, read_annotations, read_trial_labels
from tactile_cli.samples.events import write_events_csv, write_events_npy
from tactile_cli.store import validate_file

from ..conftest import shared_path

runner = CliRunner()
W, H = 64, 48


@pytest.fixture
def recordings(tmp_path) -> list[Path]:
    """Two NPY recordings with times relative to the trial start: trials rec_a, rec_b."""
    paths = [tmp_path / "rec_a.npy", tmp_path / "rec b.npy"]  # "rec b" -> trial rec_b
    for i, path in enumerate(paths):
        write_events_npy(path, 500, width=W, height=H, seed=i, t0_us=1000 * (i + 1),
                         mean_dt_us=100)
    return paths


def _write(path: Path, text: str) -> Path:
    path.write_text(text, encoding="utf-8")
    return path


def _attrs(group: h5py.Group) -> dict:
    return {k: (v.item() if isinstance(v, np.generic) else v) for k, v in group.attrs.items()}


def _ingest_cli(inputs: list[Path], out: Path, *extra: str):
    return runner.invoke(app, ["ingest", *map(str, inputs), "--width", str(W), "--height",
                               str(H), "--out", str(out), *extra])


def test_annotations_and_labels_round_trip_exactly(tmp_path, recordings):
    ann = _write(tmp_path / "ann.csv",
                 "trial,start_s,end_s,label\n"
                 "rec_a,0.0,0.1,approach\n"
                 "rec_a,0.1,0.30000000000000004,press\n"
                 "rec b,0.05,1e-1,slip\n")
    labels = _write(tmp_path / "labels.csv",
                    "trial,force_level,alpha,grade,note,big,neg\n"
                    "rec_a,12,2280.125,small big,,123456789012,-3\n"
                    "rec b,1,1.5e3,light,none,7,-0.25\n")
    out = tmp_path / "out.h5"
    result = _ingest_cli(recordings, out, "--annotations", str(ann), "--trial-labels",
                         str(labels), "--label", "rig=bench")
    assert result.exit_code == 0, result.output
    assert validate_file(out).ok
    with h5py.File(out) as f:
        a = f["trials/rec_a"]
        assert a["annotations/start_s"][()].tolist() == [0.0, 0.1]
        assert a["annotations/end_s"][()].tolist() == [0.1, 0.30000000000000004]
        assert a["annotations/label"].asstr()[()].tolist() == ["approach", "press"]
        b = f["trials/rec_b"]
        assert b["annotations/start_s"][()].tolist() == [0.05]
        assert b["annotations/end_s"][()].tolist() == [0.1]
        assert _attrs(a["labels"]) == {"force_level": 12, "alpha": 2280.125,
                                       "grade": "small big", "big": 123456789012, "neg": -3,
                                       "rig": "bench"}  # the empty note is skipped
        assert _attrs(b["labels"]) == {"force_level": 1, "alpha": 1500.0, "grade": "light",
                                       "note": "none", "big": 7, "neg": -0.25, "rig": "bench"}
        assert isinstance(_attrs(a["labels"])["force_level"], int)
        sources = f["provenance/sources/path"].asstr()[()].tolist()
        assert sources[-2:] == [str(ann), str(labels)]


def test_a_trial_without_rows_gets_no_annotations(tmp_path, recordings):
    ann = _write(tmp_path / "ann.csv", "label,end_s,trial,start_s\npress,2.5,rec_a,1\n\n\n")
    out = ingest(recordings, tmp_path / "out.h5",
                 options={"width_px": W, "height_px": H}, annotations=ann)
    with h5py.File(out) as f:
        assert "annotations" not in f["trials/rec_b"]
        assert f["trials/rec_a/annotations/start_s"][()].tolist() == [1.0]


def test_a_trial_without_a_labels_row_is_named(tmp_path, recordings):
    """A --trial-labels table that misses a trial: written, and the trial is named (it has
    none of the table's labels, which a train config reading them would refuse later)."""
    table = _write(tmp_path / "labels.csv", "trial,force\nrec_a,1\n")
    notes: list[str] = []
    out = ingest(recordings, tmp_path / "out.h5", options={"width_px": W, "height_px": H},
                 trial_labels=table, on_note=notes.append)
    assert notes == [f"{table}: no row for 1 of 2 trial(s) (rec_b); they have none of its "
                     "labels"]
    with h5py.File(out) as f:
        assert "force" not in f["trials/rec_b/labels"].attrs
        assert f["trials/rec_a/labels"].attrs["force"] == 1


@pytest.mark.parametrize(
    ("kind", "text", "message"),
    [
        ("annotations", "trial,start_s,end_s,label\nrec_a,0,1,press\nrec_a,abc,2,slip\n",
         "line 3: start_s 'abc' is not a finite number of seconds"),
        ("annotations", "trial,start_s,end_s,label\nrec_a,0,1,press\nrec_a,inf,2,slip\n",
         "line 3: start_s 'inf' is not a finite number of seconds"),
        ("annotations", "trial,start_s,end_s,label\nrec_a,2,1,press\n",
         "line 2: start_s 2 is after end_s 1"),
        ("annotations", "trial,start_s,end_s,label\nrec_a,0,1\n",
         "line 2: 3 fields, expected 4 (trial, start_s, end_s, label)"),
        ("annotations", "trial,start_s,end_s,label\nrec_a,0,1,press\n\nrec_a,1,2,slip\n",
         "line 3: empty line; remove it"),
        ("annotations", "trial,start_s,end_s,label\nrec_a,0,1,\n", "line 2: empty label"),
        ("annotations", "trial,start,end_s,label\n",
         "line 1: missing column 'start_s'; an annotations file has exactly the columns "
         "trial, start_s, end_s, label"),
        ("annotations", "trial,start_s,end_s,label,who\n",
         "line 1: unexpected column 'who'; an annotations file has exactly the columns "
         "trial, start_s, end_s, label"),
        ("annotations", "trial,start_s,end_s,label\nrec_a,0,1,press\nrec_c,0,1,press\n",
         "line 3: trial 'rec_c' is not among the ingested trials (rec_a, rec_b); a trial "
         "is named by its input file's stem or folder's name (`tactile info INPUT` lists the "
         "names an ingest gives)"),
        ("trial-labels", "trial,force\nrec_a,1\nrec_a,2\n",
         "line 3: trial 'rec_a' has a second row (the first is line 2)"),
        ("trial-labels", "trial,force\nrec_a,1\nzzz,2\n",
         "line 3: trial 'zzz' is not among the ingested trials (rec_a, rec_b); a trial is "
         "named by its input file's stem or folder's name (`tactile info INPUT` lists the "
         "names an ingest gives)"),
        ("trial-labels", "name,force\n", "line 1: no 'trial' column; the header names "
         "['name', 'force']"),
        ("trial-labels", "trial,force,force\n", "line 1: column 'force' named twice in the "
         "header"),
        ("trial-labels", "trial,force\nrec_a,1,2\n", "line 2: 3 fields, expected 2 (trial, "
         "force)"),
        ("trial-labels", "trial,rig\nrec_a,lab\n", "line 2: label 'rig' = 'lab' contradicts "
         "'bench' set by the input or --label"),
    ],
)
def test_bad_sidecar_row_is_one_line_naming_file_and_line(tmp_path, recordings, kind, text,
                                                         message):
    sidecar = _write(tmp_path / "side.csv", text)
    out = tmp_path / "out.h5"
    result = _ingest_cli(recordings, out, f"--{kind}", str(sidecar), "--label", "rig=bench")
    assert result.exit_code == 2, result.output
    assert result.stderr.strip() == f"tactile: error: {sidecar}, {message}"
    assert not out.exists()
    assert [p.name for p in tmp_path.iterdir() if ".tmp-" in p.name] == []


def test_sidecars_are_checked_before_the_recordings(tmp_path):
    sidecar = _write(tmp_path / "side.csv", "trial,start_s,end_s,label\nx,0,1\n")
    huge = tmp_path / "missing_dims.npy"  # would fail on --width/--height if read first
    write_events_npy(huge, 10, width=W, height=H, seed=0)
    result = runner.invoke(app, ["ingest", str(huge), "--annotations", str(sidecar),
                                 "--out", str(tmp_path / "o.h5")])
    assert result.exit_code == 2
    assert result.stderr.strip() == (f"tactile: error: {sidecar}, line 2: 3 fields, expected "
                                     "4 (trial, start_s, end_s, label)")


def test_missing_sidecar_file(tmp_path, recordings):
    result = _ingest_cli(recordings, tmp_path / "o.h5", "--trial-labels",
                         str(tmp_path / "nope.csv"))
    assert result.exit_code == 2
    assert result.stderr.strip() == f"tactile: error: {tmp_path / 'nope.csv'}: trial labels " \
        "file not found"


def test_split_column_sets_the_split_attribute(tmp_path, recordings):
    labels = _write(tmp_path / "labels.csv", "trial,split,force\nrec_a,train,3\nrec b, test ,\n")
    out = tmp_path / "out.h5"
    result = _ingest_cli(recordings, out, "--trial-labels", str(labels))
    assert result.exit_code == 0, result.output
    assert validate_file(out).ok
    with h5py.File(out) as f:
        assert f["trials/rec_a"].attrs["split"] == "train"
        assert f["trials/rec_b"].attrs["split"] == "test"
        assert _attrs(f["trials/rec_a/labels"]) == {"force": 3}  # split is not a label
        assert _attrs(f["trials/rec_b/labels"]) == {}
    parsed = read_trial_labels(_write(tmp_path / "l.csv", "trial,split\nt1,val\nt2,\n"))
    assert parsed.splits == {"t1": "val"}  # an empty cell assigns no split
    assert parsed.rows == {"t1": ({}, 2), "t2": ({}, 3)}


@pytest.mark.parametrize("value", ["training", "Train", "2"])
def test_split_column_refuses_other_values(tmp_path, recordings, value):
    labels = _write(tmp_path / "labels.csv", f"trial,split\nrec_a,train\nrec b,{value}\n")
    out = tmp_path / "out.h5"
    result = _ingest_cli(recordings, out, "--trial-labels", str(labels))
    assert result.exit_code == 2
    assert result.stderr.strip() == (
        f"tactile: error: {labels}, line 3, column 'split': split {value!r} is not one of "
        "train, val, test; write one of them or leave the cell empty (no split)")
    assert not out.exists()


def test_number_or_text():
    assert number_or_text(" 12 ") == 12 and isinstance(number_or_text("12"), int)
    assert number_or_text("-0.5") == -0.5 and number_or_text("1e-3") == 0.001
    assert number_or_text(".5") == 0.5 and number_or_text("5.") == 5.0
    for text in ("nan", "inf", "yes", "1,5", "0x10", "1_000", "small big"):
        assert number_or_text(text) == text
    assert number_or_text(str(2**70)) == float(2**70)  # beyond int64: stored as a float


def test_parsers_keep_file_order_and_lines(tmp_path):
    ann = read_annotations(_write(tmp_path / "a.csv", "\ufefftrial,start_s,end_s,label\n"
                                  "t 1,0.5,0.75,b\nt 1,0,0.5,a\n"))
    assert ann.rows == {"t_1": [(0.5, 0.75, "b", 2), (0.0, 0.5, "a", 3)]}
    labels = read_trial_labels(_write(tmp_path / "l.csv", 'trial,"my label"\nt1,"a, b"\n'))
    assert labels.rows == {"t1": ({"my_label": "a, b"}, 2)}
    with pytest.raises(InputError, match="only a 'trial' column"):
        read_trial_labels(_write(tmp_path / "m.csv", "trial\nt1\n"))


# -- time origin of events --------------------------------------------------------------------
@pytest.mark.parametrize(("writer", "suffix"), [(write_events_npy, ".npy"),
                                                 (write_events_csv, ".csv")])
@pytest.mark.parametrize(("t0_us", "origin"), [(0, 0), (5_000, 0), ((1 << 40) - 1, 0),
                                                (1 << 40, 1 << 40),
                                                (1_600_000_000_000_000, 1_600_000_000_000_000)])
def test_table_events_time_origin(tmp_path, writer, suffix, t0_us, origin):
    src = tmp_path / f"rec{suffix}"
    truth = writer(src, 200, width=W, height=H, seed=1, t0_us=t0_us, mean_dt_us=50)
    out = ingest([src], tmp_path / "o.h5", options={"width_px": W, "height_px": H})
    with h5py.File(out) as f:
        events = f["trials/rec/events"]
        assert int(events.attrs["t_origin_us"]) == origin
        assert int(events.attrs["ms_index_origin_us"]) == t0_us
        # the duration runs from the trial's time 0 (or the first event if that is later)
        want = (int(truth["t"][-1]) - min(origin, int(truth["t"][0]))) * 1e-6
        assert float(f["trials/rec"].attrs["duration_s"]) == pytest.approx(want, abs=1e-12)


def test_aedat4_time_origin_is_the_first_event(tmp_path):
    src = shared_path("aedat4", "dvxplorer_sample.aedat4")
    out = ingest([src], tmp_path / "dvx.h5")
    with h5py.File(out) as f:
        events = f["trials/dvxplorer_sample/events"]
        assert int(events.attrs["t_origin_us"]) == int(events["t"][0]) == 1605537493718345
