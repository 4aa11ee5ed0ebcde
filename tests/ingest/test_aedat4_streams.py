"""Every stream of an AEDAT4 file (issue 12, items 1 and 5): events, APS frames, IMU samples
and triggers, on files dv-processing writes (tests/factories/aedat4_files.py) with exact
counts and values per stream, and on the real DVXplorer recording (events + 475 IMU
samples + an empty trigger stream). Unknown stream types are refused in one line, or left
out with a note under --skip-unknown; bad streams leave no output behind.
"""

from __future__ import annotations

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.ingest import ingest
from tactile_cli.ingest.aedat4_streams import ImuCollector
from tactile_cli.store import StoreWriter, validate_file

from ..conftest import shared_path
from ..factories.aedat4_files import H, W, write_multistream

runner = CliRunner()


def _nothing_written(folder, out) -> None:
    assert not out.exists()
    assert [p.name for p in folder.iterdir() if ".tmp-" in p.name] == []


@pytest.fixture
def multi(tmp_path):
    src = tmp_path / "rec.aedat4"
    return src, write_multistream(src)


def test_every_stream_round_trips_exactly(tmp_path, multi):
    src, truth = multi
    out = ingest([src], tmp_path / "rec.h5")
    assert validate_file(out).ok
    origin = int(truth.events["t"][0])
    with h5py.File(out) as f:
        trial = f["trials/rec"]
        ev = trial["events"]
        assert int(ev.attrs["t_origin_us"]) == origin
        for name in ("t", "x", "y", "p"):
            np.testing.assert_array_equal(ev[name][()], truth.events[name])
        frames = trial["frames"]
        assert frames.attrs["sensor"] == "DAVIS346_test"  # the camera's sensor (same size)
        assert frames["images"].shape == (3, H, W, 3)
        for c in range(3):  # grey frames repeated over R, G, B
            np.testing.assert_array_equal(frames["images"][:, :, :, c], truth.frames)
        np.testing.assert_array_equal(frames["reference"][()], frames["images"][0])
        np.testing.assert_allclose(frames["t_s"][()], (truth.frame_t_us - origin) * 1e-6,
                                   rtol=0, atol=1e-12)
        np.testing.assert_allclose(frames["exposure_start_s"][()], frames["t_s"][()], atol=1e-12)
        np.testing.assert_allclose(frames["exposure_end_s"][()] - frames["exposure_start_s"][()],
                                   truth.frame_exposure_us * 1e-6, atol=1e-12)
        imu = trial["signals/imu"]
        assert imu["data"].shape == (40, 7)
        np.testing.assert_allclose(imu["t_s"][()], (truth.imu_t_us - origin) * 1e-6, atol=1e-12)
        assert imu["t_s"][0] < 0  # a sample before the first event keeps its time
        # output order: accel xyz, gyro xyz, temperature (decoder/dv order: temperature first)
        np.testing.assert_array_equal(imu["data"][()], truth.imu[:, [1, 2, 3, 4, 5, 6, 0]])
        sensor = f["sensors/DAVIS346_test_imu"]
        assert sensor.attrs["kind"] == "imu"
        assert list(sensor["channel_units"].asstr()[()]) == ["g"] * 3 + ["deg/s"] * 3 + ["degC"]
        assert abs(float(sensor.attrs["sample_rate_hz"]) - 1000.0) < 1e-6
        ann = trial["annotations"]
        assert list(ann["label"].asstr()[()]) == ["trigger_external_rising_edge",
                                                  "trigger_external_falling_edge"]
        np.testing.assert_allclose(ann["start_s"][()], (truth.trigger_t_us - origin) * 1e-6,
                                   atol=1e-12)
        np.testing.assert_array_equal(ann["start_s"][()], ann["end_s"][()])


def test_info_lists_every_stream(tmp_path, multi):
    src, _ = multi
    out = ingest([src], tmp_path / "rec.h5")
    result = runner.invoke(app, ["info", str(out), "--json"])
    assert result.exit_code == 0, result.output
    import json

    trial = json.loads(result.output)["trials"][0]
    assert (trial["n_events"], trial["streams"], trial["n_frames"], trial["n_annotations"]) == \
        (2500, {"imu": [40, 7]}, 3, 2)
    table = runner.invoke(app, ["info", str(out)]).output
    assert "imu 40x7" in table and "annotations" in table


def test_unknown_stream_is_refused_in_one_line(tmp_path):
    src = tmp_path / "pose.aedat4"
    write_multistream(src, pose=True)
    out = tmp_path / "pose.h5"
    result = runner.invoke(app, ["ingest", str(src), "--out", str(out), "--no-progress"])
    assert result.exit_code == 2
    lines = result.output.strip().splitlines()
    assert lines == [f"tactile: error: {src}: stream 3 has type 'POSE', which the AEDAT4 decoder "
                     "does not read (it reads EVTS, FRME, IMUS, TRIG); pass --skip-unknown to "
                     "ingest the other streams"]
    _nothing_written(tmp_path, out)


def test_skip_unknown_keeps_the_other_streams(tmp_path):
    src = tmp_path / "pose.aedat4"
    truth = write_multistream(src, pose=True)
    out = tmp_path / "pose.h5"
    result = runner.invoke(app, ["ingest", str(src), "--out", str(out), "--no-progress",
                                 "--skip-unknown"])
    assert result.exit_code == 0, result.output
    assert f"tactile: note: {src}: skipped stream 3 of type 'POSE' (not readable)" in result.output
    assert validate_file(out).ok
    with h5py.File(out) as f:
        trial = f["trials/pose"]
        np.testing.assert_array_equal(trial["events/t"][()], truth.events["t"])
        assert (trial["frames/images"].shape[0], trial["signals/imu/data"].shape[0],
                trial["annotations/start_s"].shape[0]) == (3, 40, 2)
        assert f["provenance/sources/path"].asstr()[0] == str(src)  # the file, not a copy


def test_real_dvxplorer_imu_and_empty_triggers(tmp_path):
    src = shared_path("aedat4", "dvxplorer_sample.aedat4")
    out = ingest([src], tmp_path / "dvx.h5")
    assert validate_file(out).ok
    with h5py.File(out) as f:
        trial = f["trials/dvxplorer_sample"]
        assert trial["events/t"].shape == (111_954,)
        imu = trial["signals/imu"]
        assert imu["data"].shape == (475, 7)  # no magnetometer: its zeros are left out
        assert (np.diff(imu["t_s"][()]) > 0).all()
        accel = imu["data"][:, :3]
        assert 0.9 < float(np.median(np.linalg.norm(accel, axis=1))) < 1.1  # gravity, in g
        assert "annotations" not in trial and "frames" not in trial  # no triggers, no APS
        assert f["sensors/DVXplorer_DXB00010_imu"].attrs["kind"] == "imu"


def test_imu_times_that_do_not_increase_are_one_error(tmp_path):
    rows = np.zeros(3, dtype=[("t", "<u8"), ("temperature", "<f4"), ("accelerometer_x", "<f4"),
                              ("accelerometer_y", "<f4"), ("accelerometer_z", "<f4"),
                              ("gyroscope_x", "<f4"), ("gyroscope_y", "<f4"),
                              ("gyroscope_z", "<f4"), ("magnetometer_x", "<f4"),
                              ("magnetometer_y", "<f4"), ("magnetometer_z", "<f4")])
    rows["t"] = [10, 20, 20]
    imu = ImuCollector(tmp_path / "cam.aedat4", 2)
    imu.add(rows)
    out = tmp_path / "o.h5"
    with pytest.raises(InputError, match=r"cam\.aedat4: IMU stream 2: sample 2 at 20 us does "
                                         r"not come after sample 1 \(20 us\)"):
        with StoreWriter(out) as w:
            imu.write(w, w.trial("t"), stream="imu", sensor="cam_imu", camera="cam",
                      origin_us=0)
    _nothing_written(tmp_path, out)


def test_width_that_disagrees_names_the_file(tmp_path, multi):
    src, _ = multi
    out = tmp_path / "o.h5"
    with pytest.raises(InputError, match=r"rec\.aedat4: `width_px` 64 disagrees"):
        ingest([src], out, options={"width_px": 64})
    _nothing_written(tmp_path, out)
