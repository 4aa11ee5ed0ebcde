"""Frames streams of robot recordings: a reference frame taken from another image topic, and
frame stamps that go back (counted, or sorted with `sort_stamps`). Each test writes a small
ROS 2 bag (sqlite3) with rosbags' writer."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.ingest import ingest
from tests.factories.robot_recordings import T0_NS, typestore

STORE = typestore(False)
T = STORE.types
IMAGE = "sensor_msgs/msg/Image"
MS = 1_000_000


def _image(ns: int, pixels: np.ndarray):
    h, w = pixels.shape[:2]
    header = T["std_msgs/msg/Header"](
        stamp=T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9),
        frame_id="cam")
    return T[IMAGE](header=header, height=h, width=w, encoding="rgb8", is_bigendian=0,
                    step=w * 3, data=pixels.reshape(-1).copy())


def _bag(path: Path, topics: dict[str, list[tuple[int, np.ndarray]]],
         stamps: dict[str, list[int]] | None = None) -> Path:
    """A bag of rgb8 image topics: topic -> [(log ns, pixels)]; header stamps = log times
    unless ``stamps`` gives them."""
    from rosbags.rosbag2 import Writer

    stamps = stamps or {}
    msgs = sorted((t, topic, i, px) for topic, items in topics.items()
                  for i, (t, px) in enumerate(items))
    with Writer(path, version=9) as w:
        conns = {topic: w.add_connection(topic, IMAGE, typestore=STORE) for topic in topics}
        for t, topic, i, px in msgs:
            ns = stamps[topic][i] if topic in stamps else t
            w.write(conns[topic], t, STORE.serialize_cdr(_image(ns, px), IMAGE))
    return path


def _pixels(n: int, seed: int, hw: tuple[int, int] = (4, 5)) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    return [rng.integers(0, 256, (*hw, 3), dtype=np.uint8) for _ in range(n)]


def _mapping(tmp_path: Path, reference: str | int = "first") -> Path:
    path = tmp_path / "m.yaml"
    path.write_text("streams:\n  - {topic: /cam, name: cam, kind: visuotactile, "
                    f"reference: '{reference}'}}\n")
    return path


def _refuse(args: list[str], out: Path) -> str:
    result = CliRunner().invoke(app, [*args, "--out", str(out), "--no-progress"])
    assert result.exit_code == 2, result.output
    assert not out.exists()
    lines = result.output.strip().splitlines()
    assert len(lines) == 1, result.output
    return lines[0]


# -- reference: TOPIC ------------------------------------------------------------------------
def test_each_trial_takes_the_latest_reference_logged_before_its_first_frame(tmp_path):
    frames, refs = _pixels(6, 1), _pixels(2, 2)
    # reference A at 0 ms, frames at 10..60 ms, reference B at 35 ms
    bag = _bag(tmp_path / "rig", {
        "/cam": [(T0_NS + (i + 1) * 10 * MS, p) for i, p in enumerate(frames)],
        "/cam/reference": [(T0_NS, refs[0]), (T0_NS + 35 * MS, refs[1])]})
    ranges = tmp_path / "trials.csv"
    ranges.write_text("start_s,end_s,trial\n0.0,0.035,one\n0.035,0.1,two\n")
    out = ingest([bag], tmp_path / "o.h5", options={
        "mapping": _mapping(tmp_path, "/cam/reference"), "trials_from": ranges})
    with h5py.File(out) as h5:
        one, two = h5["trials/one/frames"], h5["trials/two/frames"]
        np.testing.assert_array_equal(one["images"][:], np.stack(frames[:3]))
        np.testing.assert_array_equal(two["images"][:], np.stack(frames[3:]))
        np.testing.assert_array_equal(one["reference"][:], refs[0])
        np.testing.assert_array_equal(two["reference"][:], refs[1])
        np.testing.assert_array_equal(two["t_s"][:], [0.005, 0.015, 0.025])
        # the reference topic is used, so not listed as left out
        assert h5["trials/one"].attrs["topics_left_out"] == "none"


def test_a_reference_published_after_the_first_frame_is_taken_when_none_precedes(tmp_path):
    frames, refs = _pixels(4, 3), _pixels(2, 4)
    bag = _bag(tmp_path / "rig", {
        "/cam": [(T0_NS + i * 10 * MS, p) for i, p in enumerate(frames)],
        "/cam/reference": [(T0_NS + 15 * MS, refs[0]), (T0_NS + 25 * MS, refs[1])]})
    out = ingest([bag], tmp_path / "o.h5", options={
        "mapping": _mapping(tmp_path, "/cam/reference")})
    with h5py.File(out) as h5:
        np.testing.assert_array_equal(h5["trials/rig/frames/reference"][:], refs[0])
        np.testing.assert_array_equal(h5["trials/rig/frames/images"][:], np.stack(frames))


def test_a_reference_topic_that_is_missing_empty_of_another_size_or_not_images(tmp_path):
    frames = _pixels(3, 5)
    cam = [(T0_NS + i * 10 * MS, p) for i, p in enumerate(frames)]
    bag = _bag(tmp_path / "rig", {"/cam": cam, "/big": [(T0_NS, _pixels(1, 6, (5, 5))[0])]})
    out = tmp_path / "o.h5"
    line = _refuse(["ingest", str(bag), "--mapping", str(_mapping(tmp_path, "/nope"))], out)
    assert line == (f"tactile: error: {tmp_path / 'm.yaml'}: stream cam: the reference topic "
                    f"/nope is not in the recording {bag}; its topics: /big, /cam")
    line = _refuse(["ingest", str(bag), "--mapping", str(_mapping(tmp_path, "/big"))], out)
    assert line == (f"tactile: error: {bag}: stream cam: the reference frame (topic /big, "
                    "message 0) is 5x5 px but the frames of /cam are 5x4 px; a reference has "
                    "the frames' size")
    from rosbags.rosbag2 import Writer

    empty = tmp_path / "empty"
    with Writer(empty, version=9) as w:
        conn = w.add_connection("/cam", IMAGE, typestore=STORE)
        w.add_connection("/ref", IMAGE, typestore=STORE)
        w.add_connection("/ft", "geometry_msgs/msg/WrenchStamped", typestore=STORE)
        w.write(conn, T0_NS, STORE.serialize_cdr(_image(T0_NS, frames[0]), IMAGE))
    line = _refuse(["ingest", str(empty), "--mapping", str(_mapping(tmp_path, "/ref"))], out)
    assert line == (f"tactile: error: {tmp_path / 'm.yaml'}: stream cam: the reference topic "
                    "/ref has no messages; give `reference: first` or a frame index")
    line = _refuse(["ingest", str(empty), "--mapping", str(_mapping(tmp_path, "/ft"))], out)
    assert line == (f"tactile: error: {tmp_path / 'm.yaml'}: stream cam: the reference topic "
                    "/ft holds geometry_msgs/WrenchStamped, not images (sensor_msgs/Image or "
                    "CompressedImage)")


def test_a_reference_that_is_neither_first_an_index_nor_a_topic(tmp_path):
    bag = _bag(tmp_path / "rig", {"/cam": [(T0_NS, _pixels(1, 7)[0])]})
    with pytest.raises(InputError, match=r"'frist' is neither `first`, a frame index nor a "
                       r"topic \(a topic starts with /\)"):
        ingest([bag], tmp_path / "o.h5", options={"mapping": _mapping(tmp_path, "frist")})


# -- frame stamps that go back -----------------------------------------------------------------
def _back_and_forth(tmp_path: Path, stamps_ms: list[int]) -> tuple[Path, list[np.ndarray]]:
    frames = _pixels(len(stamps_ms), 8)
    bag = _bag(tmp_path / "cam", {"/cam": [(T0_NS + i * 10 * MS, p)
                                           for i, p in enumerate(frames)]},
               stamps={"/cam": [T0_NS + s * MS for s in stamps_ms]})
    return bag, frames


def test_frame_stamps_that_go_back_are_counted_and_sorted_only_when_asked(tmp_path):
    bag, frames = _back_and_forth(tmp_path, [0, 10, 5, 20, 15, 30])  # two go back
    mapping = _mapping(tmp_path, 1)
    with pytest.raises(InputError, match=r"stream cam \(topic /cam\): 2 frame stamp\(s\) go back "
                       r"in trial cam; pass `sort_stamps=True` to sort the frames by stamp"):
        ingest([bag], tmp_path / "o.h5", options={"mapping": mapping})
    line = _refuse(["ingest", str(bag), "--mapping", str(mapping)], tmp_path / "o.h5")
    assert line == (f"tactile: error: {bag}: stream cam (topic /cam): 2 frame stamp(s) go back "
                    "in trial cam; pass --sort-stamps to sort the frames by stamp, or map the "
                    "topic with `time: log`")
    notes: list[str] = []
    out = ingest([bag], tmp_path / "o.h5", options={"mapping": mapping, "sort_stamps": True},
                 on_note=notes.append)
    order = [0, 2, 1, 4, 3, 5]
    with h5py.File(out) as h5:
        g = h5["trials/cam/frames"]
        np.testing.assert_array_equal(g["t_s"][:], np.array([0, 5, 10, 15, 20, 30]) / 1e3)
        np.testing.assert_array_equal(g["images"][:], np.stack([frames[i] for i in order]))
        np.testing.assert_array_equal(g["reference"][:], frames[2])  # index 1 in stamp order
    assert any("cam (/cam): 6 frames" in n and "2 stamp(s) that went back were sorted" in n
               for n in notes)


def test_frames_are_sorted_across_batches_within_the_window(tmp_path, monkeypatch):
    from tactile_cli.ingest import robot_bag

    monkeypatch.setattr(robot_bag, "FRAME_BATCH_BYTES", 4 * 4 * 5 * 3)  # 4 frames a batch
    stamps = [0, 10, 5, 20, 15, 30, 25, 40, 35, 50, 45, 60]
    bag, frames = _back_and_forth(tmp_path, stamps)
    out = ingest([bag], tmp_path / "o.h5", options={"mapping": _mapping(tmp_path),
                                                    "sort_stamps": True})
    order = np.argsort(stamps, kind="stable")
    with h5py.File(out) as h5:
        np.testing.assert_array_equal(h5["trials/cam/frames/t_s"][:], np.sort(stamps) / 1e3)
        np.testing.assert_array_equal(h5["trials/cam/frames/images"][:],
                                      np.stack([frames[i] for i in order]))
    # a frame going back past what is already written (beyond the window) is one error
    (tmp_path / "far").mkdir()
    bag, _ = _back_and_forth(tmp_path / "far", [10, 20, 30, 40, 50, 60, 70, 80, 0])
    with pytest.raises(InputError, match=r"topic /cam, trial cam: a frame's stamp goes back "
                       r"0.0[0-9]+ s, behind frames already written; `sort_stamps=True` sorts "
                       r"frames within 2 frames"):
        ingest([bag], tmp_path / "o2.h5", options={"mapping": _mapping(tmp_path),
                                                   "sort_stamps": True})
