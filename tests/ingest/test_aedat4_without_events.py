"""AEDAT4 files without an event stream (issue 12, item 1): a DAVIS recording saved with
APS frames only and an IMU log ingest the streams they have, time 0 at the earliest
timestamp of any stream (trial attribute ``t_origin_us``); a file with no stream tactile
reads, or event-sensor options for a file without events, is one line naming the file.
``tactile info`` on a raw AEDAT4 file lists its streams read-only (text and --json).
"""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.ingest import ingest
from tactile_cli.ingest.aedat4_describe import describe_aedat4
from tactile_cli.store import TactileFile, validate_file

from ..factories.aedat4_files import T0_US, H, W, write_multistream

pytest.importorskip("dv_processing")

runner = CliRunner()


def _nothing_written(folder, out) -> None:
    assert not out.exists()
    assert [p.name for p in folder.iterdir() if ".tmp-" in p.name] == []


def _one_line(result) -> str:
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1, result.output
    assert "Traceback" not in result.output
    return lines[0]


def test_frames_only_file_ingests_its_frames_and_triggers(tmp_path):
    src = tmp_path / "aps.aedat4"
    truth = write_multistream(src, streams=("frames", "triggers"), n_frames=4, n_triggers=3,
                              camera="DAVIS346_aps")
    out = ingest([src], tmp_path / "aps.h5")
    assert validate_file(out).ok
    origin = T0_US + 1_000  # the first frame: triggers start later (T0 + 2000)
    assert origin == min(truth.frame_t_us.min(), truth.trigger_t_us.min())
    with h5py.File(out) as f:
        trial = f["trials/aps"]
        assert "events" not in trial and "signals" not in trial
        assert int(trial.attrs["t_origin_us"]) == origin
        frames = trial["frames"]
        assert frames.attrs["sensor"] == "DAVIS346_aps"
        sensor = f["sensors/DAVIS346_aps"]
        assert (sensor.attrs["kind"], int(sensor.attrs["width_px"]),
                int(sensor.attrs["height_px"])) == ("event_camera", W, H)
        assert frames["images"].shape == (4, H, W, 3)
        for c in range(3):
            np.testing.assert_array_equal(frames["images"][:, :, :, c], truth.frames)
        np.testing.assert_allclose(frames["t_s"][()], (truth.frame_t_us - origin) * 1e-6,
                                   rtol=0, atol=1e-12)
        assert frames["t_s"][0] == 0.0
        np.testing.assert_allclose(frames["exposure_end_s"][()] - frames["exposure_start_s"][()],
                                   truth.frame_exposure_us * 1e-6, atol=1e-12)
        ann = trial["annotations"]
        assert list(ann["label"].asstr()[()]) == ["trigger_external_rising_edge",
                                                  "trigger_external_falling_edge",
                                                  "trigger_external_rising_edge"]
        np.testing.assert_allclose(ann["start_s"][()], (truth.trigger_t_us - origin) * 1e-6,
                                   atol=1e-12)
        assert float(trial.attrs["duration_s"]) == pytest.approx(0.045)  # 3 x 15 ms
    with TactileFile(out) as tf:  # the one reader takes the trial without events
        t = tf.trial("aps")
        assert t.frames().n_frames == 4


def test_imu_only_file_ingests_its_samples(tmp_path):
    src = tmp_path / "imu.aedat4"
    truth = write_multistream(src, streams=("imu",), n_imu=25, camera="DVXplorer_imu_log")
    out = ingest([src], tmp_path / "imu.h5")
    assert validate_file(out).ok
    origin = int(truth.imu_t_us[0])
    with h5py.File(out) as f:
        trial = f["trials/imu"]
        assert sorted(trial.keys()) == ["labels", "signals"]
        assert int(trial.attrs["t_origin_us"]) == origin
        imu = trial["signals/imu"]
        assert imu.attrs["sensor"] == "DVXplorer_imu_log_imu"
        assert imu["data"].shape == (25, 7)
        np.testing.assert_array_equal(imu["data"][()], truth.imu[:, [1, 2, 3, 4, 5, 6, 0]])
        np.testing.assert_allclose(imu["t_s"][()], np.arange(25) * 1e-3, rtol=0, atol=1e-12)
        assert float(trial.attrs["duration_s"]) == pytest.approx(0.024)
        assert list(f["sensors"]) == ["DVXplorer_imu_log_imu"]  # no camera sensor without frames
        assert f["sensors/DVXplorer_imu_log_imu"].attrs["kind"] == "imu"


def test_sensor_option_names_the_camera(tmp_path):
    src = tmp_path / "aps.aedat4"
    write_multistream(src, streams=("frames", "imu"))
    out = ingest([src], tmp_path / "o.h5", options={"sensor_name": "davis"})
    assert validate_file(out).ok
    with h5py.File(out) as f:
        assert sorted(f["sensors"]) == ["davis", "davis_imu"]
        trial = f["trials/aps"]
        assert int(trial.attrs["t_origin_us"]) == T0_US - 500  # the first IMU sample
        assert trial["frames/t_s"][0] == pytest.approx(1.5e-3)


def test_event_sensor_options_for_a_file_without_events_are_one_line(tmp_path):
    src = tmp_path / "aps.aedat4"
    write_multistream(src, streams=("frames",))
    out = tmp_path / "o.h5"
    result = runner.invoke(app, ["ingest", str(src), "--out", str(out), "--no-progress",
                                 "--width", str(W)])
    assert _one_line(result) == (
        f"tactile: error: {src}: --width sets the size of an event sensor, but the file has "
        "no event stream (found: frame); omit it")
    _nothing_written(tmp_path, out)
    with pytest.raises(InputError, match=r"`width_px` and `height_px` set the size"):
        ingest([src], out, options={"width_px": W, "height_px": H})
    _nothing_written(tmp_path, out)


def test_unsupported_stream_only_is_one_line(tmp_path):
    src = tmp_path / "pose.aedat4"
    write_multistream(src, streams=(), pose=True)
    out = tmp_path / "pose.h5"
    for extra in ([], ["--skip-unknown"]):
        result = runner.invoke(app, ["ingest", str(src), "--out", str(out), "--no-progress",
                                     *extra])
        assert _one_line(result) == (
            f"tactile: error: {src}: no stream tactile reads in the file (found: stream 0 "
            "'POSE'); tactile reads events, frames, IMU samples, triggers")
        _nothing_written(tmp_path, out)


def test_triggers_alone_are_one_line(tmp_path):
    src = tmp_path / "trig.aedat4"
    write_multistream(src, streams=("triggers",))
    out = tmp_path / "o.h5"
    with pytest.raises(InputError, match=r"trig\.aedat4: no event, frame or IMU stream in the "
                                         r"file \(found: triggers\)"):
        ingest([src], out)
    _nothing_written(tmp_path, out)


def test_empty_frame_stream_is_one_line(tmp_path):
    src = tmp_path / "empty.aedat4"
    write_multistream(src, streams=("frames",), n_frames=0)
    out = tmp_path / "o.h5"
    with pytest.raises(InputError, match=r"empty\.aedat4: the file's streams \(frame\) hold no "
                                         r"frames and no IMU samples"):
        ingest([src], out)
    _nothing_written(tmp_path, out)


# ---- tactile info on a raw AEDAT4 file ----

def test_info_lists_the_streams_of_a_raw_file(tmp_path):
    src = tmp_path / "rec.aedat4"
    truth = write_multistream(src, pose=True)
    before = sorted(p.name for p in tmp_path.iterdir())
    result = runner.invoke(app, ["info", str(src), "--json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.output)
    assert data["format"] == "aedat4" and data["file"] == str(src)
    rows = {s["stream_id"]: s for s in data["streams"]}
    assert {k: (s["type"], s["name"], s["count"]) for k, s in rows.items()} == {
        0: ("events", "events", 2500), 1: ("frame", "frames", 3), 2: ("imus", "imu", 40),
        3: ("POSE", "poses", None), 4: ("triggers", "triggers", 2)}
    assert (rows[0]["width_px"], rows[0]["height_px"]) == (W, H)
    assert (rows[0]["t_first_us"], rows[0]["t_last_us"]) == (int(truth.events["t"][0]),
                                                             int(truth.events["t"][-1]))
    assert rows[2]["t_first_us"] == T0_US - 500
    assert rows[2]["span_s"] == pytest.approx(0.039)
    assert rows[3]["readable"] is False
    assert f"`tactile ingest {src} --out FILE.h5`" in data["hint"]

    text = runner.invoke(app, ["info", str(src)])
    assert text.exit_code == 0, text.output
    for piece in ("2,500 events", "3 frames", "40 IMU samples", "2 triggers", "not readable",
                  "32x24 px", "AEDAT4 recording", f"tactile ingest {src} --out FILE.h5"):
        assert piece in text.output, piece
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # read-only


def test_describe_a_file_without_events(tmp_path):
    src = tmp_path / "imu.aedat4"
    write_multistream(src, streams=("imu",), n_imu=7)
    (stream,) = describe_aedat4(src).streams
    assert (stream.type, stream.count, stream.unit, stream.t_first_us, stream.resolution) == \
        ("imus", 7, "IMU samples", T0_US - 500, "")


@pytest.mark.parametrize("cut", [0.5, 0.999])
def test_info_on_a_damaged_raw_file_is_one_line(tmp_path, cut):
    src = tmp_path / "rec.aedat4"
    write_multistream(src)
    data = src.read_bytes()
    src.write_bytes(data[: int(len(data) * cut)])
    line = _one_line(runner.invoke(app, ["info", str(src)]))
    assert line.startswith(f"tactile: error: {src}: ")
    assert "cut short" in line and line.endswith("re-export or re-copy the recording")


def test_info_on_garbage_named_aedat4_is_one_line(tmp_path):
    src = tmp_path / "rec.aedat4"
    src.write_bytes(b"#!AER-DAT4.0\r\n" + bytes(200))
    line = _one_line(runner.invoke(app, ["info", str(src), "--json"]))
    assert line.startswith(f"tactile: error: {src}: ")
    assert "AEDAT4" in line
