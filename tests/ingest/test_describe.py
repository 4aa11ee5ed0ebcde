"""`tactile info RAW` on every raw format: what an ingest would make (streams, counts, rates,
time spans, trials, what it leaves out), read-only, as a table and with --json; the same
figures an ingest of the recording then writes."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.ingest import FORMATS, describe_recording, ingest
from tactile_cli.samples import write_all
from tactile_cli.store import TactileFile

from ..conftest import REPO
from ..factories.aedat4_files import H, W, write_multistream

runner = CliRunner()


@pytest.fixture(scope="module")
def samples(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("describe") / "raw"
    write_all(root, seed=1, n_events=800)
    return root


def _tree(root: Path) -> list[tuple[str, int]]:
    return sorted((str(p.relative_to(root)), p.stat().st_mtime_ns) for p in root.rglob("*"))


def _info(path: Path, *args: str) -> dict:
    """``tactile info PATH --json`` (exit 0, nothing written beside the input)."""
    folder = path if path.is_dir() else path.parent
    before = _tree(folder)
    result = runner.invoke(app, ["info", str(path), *args, "--json"])
    assert result.exit_code == 0, result.output
    assert _tree(folder) == before  # read-only
    text = runner.invoke(app, ["info", str(path), *args])
    assert text.exit_code == 0, text.output
    assert "recording, " in text.output and "tactile ingest" in text.output
    return json.loads(result.output)


@pytest.mark.slow
def test_event_csv_and_npy(samples, tmp_path):
    for name, fmt in (("events.csv", "events-csv"), ("events.npy", "events-npy")):
        data = _info(samples / name)
        assert (data["format"], data["file"]) == (fmt, str(samples / name))
        (s,) = data["streams"]
        assert (s["type"], s["count"], s["out_of_order_stamps"]) == ("events", 800, 0)
        assert s["x_range"][1] < 640 and s["y_range"][1] < 480
        assert data["trials"] == [{"name": "events", "source": str(samples / name),
                                   "counts": {"events": 800}, "duration_s": s["span_s"],
                                   "labels": {}}]
        assert "--width WIDTH --height HEIGHT" in data["hint"]
        assert any("`width_px=" in n for n in data["notes"])
    # what ingest writes agrees with what info said
    described = describe_recording(samples / "events.npy", options={"width_px": 640,
                                                                    "height_px": 480})
    out = ingest([samples / "events.npy"], tmp_path / "e.h5",
                 options={"width_px": 640, "height_px": 480})
    with TactileFile(out) as f:
        trial = f.trial("events")
        assert trial.events.n_events == described.streams[0].count
        extra = described.streams[0].extra
        assert (trial.events.origin_us, trial.events.t_last_us) == (extra["t_first_us"],
                                                                    extra["t_last_us"])


def test_aedat4(tmp_path):
    src = tmp_path / "rec.aedat4"
    write_multistream(src)
    data = _info(src)
    assert data["format"] == "aedat4" and data["title"] == "AEDAT4"
    by_type = {s["type"]: s for s in data["streams"]}
    assert by_type["events"]["count"] == 2500
    assert (by_type["events"]["width_px"], by_type["events"]["height_px"]) == (W, H)
    assert data["trials"][0]["counts"]["events"] == 2500


def test_accel_tree(samples):
    data = _info(samples / "accel_tree")
    assert data["format"] == "accel-tree"
    accel, velocity = data["streams"]
    assert accel["channels"] == ["L_x", "L_y", "L_z", "R_x", "R_y", "R_z"]
    assert velocity["channels"] == ["v_slip", "v_slide"]
    assert accel["rate_hz"] == 8000.0 and accel["count"] == velocity["count"] > 0
    assert len(data["trials"]) == 4
    t0 = data["trials"][0]
    assert set(t0["labels"]) == {"object", "orientation", "speed"}
    assert t0["duration_s"] == pytest.approx((t0["counts"]["accel"] - 1) / 8000)
    assert "--format accel-tree" in data["hint"]


def test_mapped_csv_with_and_without_a_mapping(samples, tmp_path):
    bare = _info(samples / "taxel")
    assert bare["format"] == "mapped-csv"
    assert bare["streams"][0]["channels"][:2] == ["timestamp", "p_r0c0"]
    assert bare["streams"][0]["count"] == 4  # files with this header
    assert "no mapping given" in bare["notes"][0]
    mapping = samples / "taxel" / "taxels.yaml"
    data = _info(samples / "taxel", "--mapping", str(mapping))
    (s,) = data["streams"]
    assert (s["name"], s["type"], len(s["channels"])) == ("taxels", "taxel_array", 16)
    assert s["rate_hz"] == pytest.approx(100.0, rel=1e-4)
    assert (s["repeated_stamps"], s["out_of_order_stamps"]) == (0, 0)
    assert [t["name"] for t in data["trials"]] == ["foam_1", "foam_2", "wood_1", "wood_2"]
    assert data["hint"].endswith(f"--out FILE.h5` with --mapping {mapping})")
    out = ingest([samples / "taxel"], tmp_path / "t.h5", options={"mapping": mapping})
    with TactileFile(out) as f:
        assert sum(len(f.trial(t).signal("taxels").t_s) for t in f.trial_names) == s["count"]


def test_columns_no_stream_reads_are_listed(tmp_path):
    (tmp_path / "raw").mkdir()
    (tmp_path / "raw" / "a.csv").write_text("t,v,unused,also\n0,1,2,3\n1,2,3,4\n")
    mapping = tmp_path / "m.yaml"
    mapping.write_text("version: 1\ntrials: {layout: file, glob: '*.csv'}\nstreams:\n"
                       "  - {name: s, file: '{stem}.csv', kind: pressure, channels: [v], "
                       "units: kPa, time: {column: t}}\n")
    data = _info(tmp_path / "raw", "--mapping", str(mapping))
    assert data["dropped"] == ["a.csv: 2 column(s) no stream reads: unused, also"]


def test_row_table(tmp_path):
    table = tmp_path / "grasps.csv"
    table.write_text("object,slipped,e1,e2\nmug,0,1.5,2\nbox,1,3,4\ncan,0,5,6\n")
    data = _info(table, "--mapping", str(REPO / "configs" / "grasp_rows.yaml"))
    assert data["format"] == "mapped-csv"
    assert [(t["name"], t["labels"]["object"], t["labels"]["slipped"]) for t in
            data["trials"]] == [("grasps_1", "mug", 0), ("grasps_2", "box", 1),
                                ("grasps_3", "can", 0)]
    (s,) = data["streams"]
    assert (s["count"], s["channels"], s["rate_hz"]) == (3, ["e1", "e2"], None)


def test_image_folders(samples):
    data = _info(samples / "visuotactile")
    assert data["format"] == "images"
    (s,) = data["streams"]
    assert s["type"] == "frames" and s["width_px"] > 0 and s["height_px"] > 0
    assert [t["name"] for t in data["trials"]] == ["press_01", "press_02"]
    assert s["count"] == sum(t["counts"]["frames"] for t in data["trials"])
    assert s["rate_hz"] == pytest.approx(30.0)
    one = _info(samples / "visuotactile" / "press_01", "--option", "px_per_mm=16")
    assert len(one["trials"]) == 1 and not any("px_per_mm" in n for n in one["notes"])


def test_every_format_is_described(samples):
    """The registry's formats all have a describe that the tests above reach."""
    reached = {"aedat4", "events-csv", "events-npy", "accel-tree", "mapped-csv", "images",
               "rosbag", "mcap", "video"}  # tests/ingest/test_robot_bag.py, test_video.py
    assert set(FORMATS) == reached


def test_format_and_options_pick_the_reader(samples, tmp_path):
    # a CSV that is not an event table: described as a sensor table when asked
    table = tmp_path / "sensor.csv"
    table.write_text("t,force\n0,1\n0.1,2\n")
    data = _info(table, "--format", "mapped-csv")
    assert data["streams"][0]["channels"] == ["t", "force"]
    bad = runner.invoke(app, ["info", str(table)])
    assert bad.exit_code == 2
    assert bad.stderr.strip() == (
        f"tactile: error: {table}, line 1: missing columns 'x', 'y', 'p'; the header names "
        "['t', 'force']; a CSV of another sensor is read with a mapping (--mapping FILE.yaml, "
        "see configs/mapping_example.yaml)")
    wrong = runner.invoke(app, ["info", str(samples / "events.csv"), "-O", "fps=3"])
    assert wrong.exit_code == 2
    assert "`fps` is not an option of any format" in wrong.stderr


def test_an_hdf5_file_is_still_summarised(samples, tmp_path):
    out = ingest([samples / "events.csv"], tmp_path / "x.h5",
                 options={"width_px": 640, "height_px": 480})
    data = json.loads(runner.invoke(app, ["info", str(out), "--json"]).output)
    assert "sensors" in data and data["trials"][0]["n_events"] == 800
    assert np.isfinite(data["trials"][0]["duration_s"])
