"""Message types into streams: image encodings, compressed frames, Imu, JointState, stamps
that go back. Each test writes a small ROS 2 bag (sqlite3) with rosbags' writer."""

from __future__ import annotations

import io
from pathlib import Path

import h5py
import numpy as np
import pytest
from PIL import Image

from tactile_cli.errors import InputError
from tactile_cli.ingest import ingest
from tests.factories.robot_recordings import T0_NS, typestore

STORE = typestore(False)
T = STORE.types


def _stamp(ns: int):
    return T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)


def _header(ns: int, frame: str = "cam"):
    return T["std_msgs/msg/Header"](stamp=_stamp(ns), frame_id=frame)


def _bag(path: Path, topic: str, msgtype: str, msgs: list[tuple[int, object]]) -> Path:
    from rosbags.rosbag2 import Writer

    with Writer(path, version=9) as w:
        conn = w.add_connection(topic, msgtype, typestore=STORE)
        for t, m in msgs:
            w.write(conn, t, STORE.serialize_cdr(m, msgtype))
    return path


def _mapping(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "m.yaml"
    path.write_text("streams:\n  - " + text + "\n")
    return path


def _image(ns: int, pixels: np.ndarray, encoding: str, *, big: bool = False):
    h, w = pixels.shape[:2]
    raw = pixels.astype(pixels.dtype.newbyteorder(">" if big else "<")).tobytes()
    return T["sensor_msgs/msg/Image"](header=_header(ns), height=h, width=w, encoding=encoding,
                                      is_bigendian=int(big), step=len(raw) // h,
                                      data=np.frombuffer(raw, dtype=np.uint8))


@pytest.mark.parametrize("encoding", ["rgb8", "bgr8", "mono8"])
def test_8bit_images_become_rgb_frames(tmp_path, encoding):
    rng = np.random.default_rng(1)
    shape = (4, 5) if encoding == "mono8" else (4, 5, 3)
    pixels = [rng.integers(0, 256, shape, dtype=np.uint8) for _ in range(3)]
    bag = _bag(tmp_path / "b", "/cam", "sensor_msgs/msg/Image",
               [(T0_NS + i * 10**7, _image(T0_NS + i * 10**7, p, encoding))
                for i, p in enumerate(pixels)])
    out = ingest([bag], tmp_path / "o.h5", options={
        "mapping": _mapping(tmp_path, "{topic: /cam, name: cam, kind: visuotactile}")})
    expect = {"rgb8": lambda p: p, "bgr8": lambda p: p[..., ::-1],
              "mono8": lambda p: np.repeat(p[..., None], 3, axis=2)}[encoding]
    with h5py.File(out) as h5:
        frames = h5["trials/b/frames"]
        np.testing.assert_array_equal(frames["images"][:], np.stack([expect(p) for p in pixels]))
        np.testing.assert_array_equal(frames["t_s"][:], [0.0, 0.01, 0.02])
        np.testing.assert_array_equal(frames["reference"][:], expect(pixels[0]))


@pytest.mark.parametrize(("encoding", "dtype", "big"), [("mono16", np.uint16, False),
                                                         ("16UC1", np.uint16, True),
                                                         ("32FC1", np.float32, False)])
def test_depth_images_become_exact_samples(tmp_path, encoding, dtype, big):
    rng = np.random.default_rng(2)
    pixels = [(rng.random((3, 4)) * 60000).astype(dtype) for _ in range(2)]
    bag = _bag(tmp_path / "b", "/depth", "sensor_msgs/msg/Image",
               [(T0_NS + i * 10**7, _image(T0_NS + i * 10**7, p, encoding, big=big))
                for i, p in enumerate(pixels)])
    out = ingest([bag], tmp_path / "o.h5", options={
        "mapping": _mapping(tmp_path, "{topic: /depth, name: depth, kind: pressure, units: mm}")})
    with h5py.File(out) as h5:
        np.testing.assert_array_equal(h5["trials/b/signals/depth/data"][:],
                                      np.stack([p.ravel() for p in pixels]).astype(np.float32))
        names = list(h5["sensors/depth/channel_names"].asstr()[:])
        assert names[:5] == ["y0_x0", "y0_x1", "y0_x2", "y0_x3", "y1_x0"] and len(names) == 12
    frames = _mapping(tmp_path, "{topic: /depth, name: depth, kind: visuotactile}")
    with pytest.raises(InputError, match=f"topic /depth, message 0: {encoding} images do not fit "
                       "8-bit frames; map the topic with a sampled kind"):
        ingest([bag], tmp_path / "f.h5", options={"mapping": frames})


def _compressed(ns: int, pixels: np.ndarray, fmt: str):
    buf = io.BytesIO()
    Image.fromarray(pixels).save(buf, format=fmt.upper())
    return T["sensor_msgs/msg/CompressedImage"](header=_header(ns), format=fmt,
                                                data=np.frombuffer(buf.getvalue(), np.uint8))


def test_compressed_frames_png_exact_and_a_bad_jpeg_named(tmp_path):
    rng = np.random.default_rng(3)
    pixels = [rng.integers(0, 256, (6, 7, 3), dtype=np.uint8) for _ in range(3)]
    bag = _bag(tmp_path / "png", "/cam/compressed", "sensor_msgs/msg/CompressedImage",
               [(T0_NS + i * 10**7, _compressed(T0_NS + i * 10**7, p, "png"))
                for i, p in enumerate(pixels)])
    mapping = _mapping(tmp_path, "{topic: /cam/compressed, name: cam, kind: visuotactile, "
                       "reference: 2}")
    out = ingest([bag], tmp_path / "o.h5", options={"mapping": mapping})
    with h5py.File(out) as h5:
        np.testing.assert_array_equal(h5["trials/png/frames/images"][:], np.stack(pixels))
        np.testing.assert_array_equal(h5["trials/png/frames/reference"][:], pixels[2])
    msgs = [(T0_NS + i * 10**7, _compressed(T0_NS + i * 10**7, p, "jpeg"))
            for i, p in enumerate(pixels)]
    broken = msgs[1][1]
    msgs[1] = (msgs[1][0], T["sensor_msgs/msg/CompressedImage"](
        header=broken.header, format="jpeg", data=broken.data[:20]))
    bag = _bag(tmp_path / "jpg", "/cam/compressed", "sensor_msgs/msg/CompressedImage", msgs)
    with pytest.raises(InputError, match=r"topic /cam/compressed, message 1: the jpeg frame "
                       r"cannot be decoded"):
        ingest([bag], tmp_path / "j.h5", options={"mapping": mapping})
    assert not (tmp_path / "j.h5").exists()


def test_imu_and_joint_state_with_units(tmp_path):
    rng = np.random.default_rng(4)
    V, Q = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Quaternion"]
    values = rng.normal(size=(4, 10))
    imu = [(T0_NS + i * 10**6, T["sensor_msgs/msg/Imu"](
        header=_header(T0_NS + i * 10**6, "imu_link"), orientation=Q(*values[i, :4]),
        orientation_covariance=np.zeros(9), angular_velocity=V(*values[i, 4:7]),
        angular_velocity_covariance=np.zeros(9), linear_acceleration=V(*values[i, 7:]),
        linear_acceleration_covariance=np.zeros(9))) for i in range(4)]
    bag = _bag(tmp_path / "imu", "/imu", "sensor_msgs/msg/Imu", imu)
    out = ingest([bag], tmp_path / "i.h5", options={
        "mapping": _mapping(tmp_path, "{topic: /imu, name: imu, kind: imu}")})
    with h5py.File(out) as h5:
        np.testing.assert_array_equal(h5["trials/imu/signals/imu/data"][:],
                                      values.astype(np.float32))
        assert list(h5["sensors/imu/channel_units"].asstr()[:]) == (
            ["1"] * 4 + ["rad/s"] * 3 + ["m/s^2"] * 3)
        assert h5["sensors/imu"].attrs["sample_rate_hz"] == 1000.0
    joints = [(T0_NS + i * 10**6, T["sensor_msgs/msg/JointState"](
        header=_header(T0_NS + i * 10**6), name=["j1", "j2"], position=values[i, :2],
        velocity=values[i, 2:4], effort=np.zeros(0))) for i in range(4)]
    bag = _bag(tmp_path / "js", "/joint_states", "sensor_msgs/msg/JointState", joints)
    out = ingest([bag], tmp_path / "j.h5", options={
        "mapping": _mapping(tmp_path, "{topic: /joint_states, name: arm, kind: robot_state}")})
    with h5py.File(out) as h5:
        np.testing.assert_array_equal(h5["trials/js/signals/arm/data"][:],
                                      values[:, :4].astype(np.float32))
        assert list(h5["sensors/arm/channel_names"].asstr()[:]) == [
            "j1_position", "j2_position", "j1_velocity", "j2_velocity"]
        assert list(h5["sensors/arm/channel_units"].asstr()[:]) == ["rad"] * 2 + ["rad/s"] * 2


@pytest.mark.parametrize("block_bytes", [None, 48], ids=["one-piece", "2-row-blocks"])
def test_header_stamps_that_go_back_are_counted_and_sorted_only_when_asked(
        tmp_path, block_bytes, monkeypatch):
    """With 2-row blocks both stamps that go back cross a block boundary."""
    if block_bytes is not None:
        from tactile_cli.ingest import robot_bag

        monkeypatch.setattr(robot_bag, "SIGNAL_CHUNK_BYTES", block_bytes)
    stamps = [0, 10, 5, 20, 15, 30]  # ms: two go back
    V = T["geometry_msgs/msg/Vector3"]
    msgs = [(T0_NS + i * 10**7, T["geometry_msgs/msg/WrenchStamped"](
        header=_header(T0_NS + s * 10**6, "ft"),
        wrench=T["geometry_msgs/msg/Wrench"](force=V(float(i), 0.0, 0.0), torque=V(0.0, 0.0, 0.0))))
        for i, s in enumerate(stamps)]
    bag = _bag(tmp_path / "ft", "/ft", "geometry_msgs/msg/WrenchStamped", msgs)
    mapping = _mapping(tmp_path, "{topic: /ft, name: ft, kind: force_torque}")
    with pytest.raises(InputError, match=r"stream ft \(topic /ft\): 2 stamp\(s\) go back in trial "
                       r"ft; pass `sort_stamps=True`"):
        ingest([bag], tmp_path / "o.h5", options={"mapping": mapping})
    assert not (tmp_path / "o.h5").exists()
    from typer.testing import CliRunner

    from tactile_cli.cli import app

    cli = CliRunner().invoke(app, ["ingest", str(bag), "--mapping", str(mapping), "--out",
                                   str(tmp_path / "o.h5")])
    assert cli.exit_code == 2 and cli.output.strip().endswith(
        "2 stamp(s) go back in trial ft; pass --sort-stamps to sort the samples by stamp, or "
        "map the topic with `time: log`")
    notes: list[str] = []
    out = ingest([bag], tmp_path / "o.h5", options={"mapping": mapping, "sort_stamps": True},
                 on_note=notes.append)
    with h5py.File(out) as h5:
        np.testing.assert_array_equal(h5["trials/ft/signals/ft/t_s"][:],
                                      np.array([0, 5, 10, 15, 20, 30]) / 1e3)
        # the force x of message i is i: the values moved with their stamps
        np.testing.assert_array_equal(h5["trials/ft/signals/ft/data"][:, 0],
                                      [0, 2, 1, 4, 3, 5])
        assert h5["trials/ft"].attrs["duration_s"] == 0.03
    assert any("2 stamp(s) that went back were sorted" in n for n in notes)
