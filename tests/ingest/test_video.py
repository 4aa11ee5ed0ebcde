"""Videos (written with PyAV) through `tactile info` and `tactile ingest`: frames exact for a
lossless codec, presentation timestamps kept (variable frame rate), reference, damaged files."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.ingest import ingest
from tactile_cli.store import validate_file
from tests.factories.videos import write_video

runner = CliRunner()
PTS_MS = [0, 33, 70, 100, 140, 175]  # variable frame rate


def _frames(seed: int, n: int = 6) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, 256, (n, 12, 16, 3), dtype=np.uint8)


def test_lossless_video_round_trips_pixels_and_presentation_times(tmp_path):
    frames = _frames(0)
    video = write_video(tmp_path / "touch.mkv", frames, PTS_MS)
    result = runner.invoke(app, ["ingest", str(video), "--out", str(tmp_path / "o.h5"),
                                 "--reference", "2"])
    assert result.exit_code == 0, result.output
    out = tmp_path / "o.h5"
    assert validate_file(out).ok
    with h5py.File(out) as h5:
        f = h5["trials/touch/frames"]
        np.testing.assert_array_equal(f["images"][:], frames)
        np.testing.assert_array_equal(f["t_s"][:], np.array(PTS_MS) / 1000)
        np.testing.assert_array_equal(f["reference"][:], frames[2])
        sensor = h5["sensors/visuotactile"].attrs
        assert (sensor["kind"], sensor["width_px"], sensor["height_px"]) == ("visuotactile", 16, 12)
        assert sensor["sample_rate_hz"] == pytest.approx(1000 / 35, abs=1e-5)  # median 35 ms


def test_a_folder_of_videos_is_one_trial_each_and_info_reads_the_container(tmp_path):
    folder = tmp_path / "touches"
    folder.mkdir()
    write_video(folder / "touch_10.mkv", _frames(1, 4))
    write_video(folder / "touch_2.mp4", _frames(2, 5), codec="libx264")
    data = json.loads(runner.invoke(app, ["info", str(folder), "--json"]).output)
    assert data["format"] == "video"
    assert [(s["name"], s["codec"], s["count"], s["width_px"], s["height_px"])
            for s in data["streams"]] == [("touch_2", "h264", 5, 16, 12),
                                          ("touch_10", "ffv1", 4, 16, 12)]
    assert data["streams"][0]["rate_hz"] == pytest.approx(30.0, rel=1e-3)  # pts in whole ms
    out = ingest([folder], tmp_path / "o.h5")
    with h5py.File(out) as h5:
        assert list(h5["trials"]) == ["touch_2", "touch_10"]
        assert h5["trials/touch_2/frames/images"].shape == (5, 12, 16, 3)
        np.testing.assert_array_equal(h5["trials/touch_10/frames/images"][:], _frames(1, 4))


def test_videos_of_one_name_in_experiment_folders_are_named_by_their_path(tmp_path):
    # one folder per experiment, one file per camera: camera_0.avi in both folders
    for k, exp in enumerate(("exp_1", "exp_2")):
        (tmp_path / "mug" / exp).mkdir(parents=True)
        for cam in ("camera_0", "camera_2"):
            write_video(tmp_path / "mug" / exp / f"{cam}.mkv", _frames(10 * k + len(cam), 3))
    labels = tmp_path / "labels.csv"
    labels.write_text("trial,experiment\nexp_1__camera_0,e1\nexp_1__camera_2,e1\n"
                      "exp_2__camera_0,e2\nexp_2__camera_2,e2\n")
    inputs = [tmp_path / "mug" / "exp_1", tmp_path / "mug" / "exp_2"]
    out = ingest(inputs, tmp_path / "o.h5", trial_labels=labels)
    with h5py.File(out) as h5:
        assert list(h5["trials"]) == ["exp_1__camera_0", "exp_1__camera_2", "exp_2__camera_0",
                                      "exp_2__camera_2"]
        assert h5["trials/exp_2__camera_2/labels"].attrs["experiment"] == "e2"
        np.testing.assert_array_equal(h5["trials/exp_2__camera_2/frames/images"][:],
                                      _frames(10 + len("camera_2"), 3))
    # one folder alone: the stems are unique, so trials keep them
    with h5py.File(ingest([inputs[0]], tmp_path / "one.h5")) as h5:
        assert list(h5["trials"]) == ["camera_0", "camera_2"]


def test_damaged_and_empty_videos_are_one_line(tmp_path):
    video = write_video(tmp_path / "v.mkv", _frames(3))
    cut = tmp_path / "cut.mkv"
    cut.write_bytes(video.read_bytes()[:200])
    empty = tmp_path / "empty.mp4"
    empty.write_bytes(b"")
    for bad in (cut, empty):
        out = tmp_path / "o.h5"
        result = runner.invoke(app, ["ingest", str(bad), "--out", str(out)])
        assert result.exit_code == 2 and not out.exists()
        assert len(result.output.strip().splitlines()) == 1
        assert result.output.startswith(f"tactile: error: {bad}: ")
    with pytest.raises(InputError, match="has 6 frame\\(s\\), so there is no frame 9"):
        ingest([video], tmp_path / "o.h5", options={"reference": "9"})
