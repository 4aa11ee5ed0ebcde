"""Rows read straight from the bytes (robot_layouts) against rosbags' deserialiser: every
type with a raw reader, in ROS 1 and both byte orders of CDR, with frame ids and labels of
every length mod 8 (so every alignment of the values after them), value for value, one
message at a time and in blocks; a damaged message (cut short, bytes after its end, a bad CDR
header) is one error naming the topic and the message."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tactile_cli.errors import InputError
from tactile_cli.ingest.robot_layouts import MULTIARRAY_DTYPES, RAW_TYPES, raw_rows
from tactile_cli.ingest.robot_messages import header_stamp_ns, row_reader
from tests.factories.robot_recordings import T0_NS, typestore

STORES = {True: typestore(True), False: typestore(False)}
#: (serialisation, ROS 1 store, little-endian CDR)
SERIALISATIONS = [("ros1", True, True), ("cdr", False, True), ("cdr", False, False)]


def _full(kind: str) -> str:
    package, name = kind.split("/")
    return f"{package}/msg/{name}"


def _message(store, kind: str, rng: np.random.Generator, k: int, ros1: bool):
    T = store.types
    text = "x" * (k % 8)  # frame ids and labels of 0-7 characters
    if kind.endswith("MultiArray"):
        dtype = np.dtype(MULTIARRAY_DTYPES[kind[len("std_msgs/"):-len("MultiArray")]])
        n_dims = k % 3
        dims = [T["std_msgs/msg/MultiArrayDimension"](label=text[:d + 1] * (d + 1), size=2,
                                                      stride=2) for d in range(n_dims)]
        layout = T["std_msgs/msg/MultiArrayLayout"](dim=dims, data_offset=1)
        if dtype.kind == "f":
            data = rng.normal(0, 1e3, 3 + k % 5).astype(dtype)
        else:
            info = np.iinfo(dtype)
            data = rng.integers(info.min, info.max, 3 + k % 5, dtype=dtype, endpoint=True)
        return T[_full(kind)](layout=layout, data=data)
    ns = T0_NS + int(rng.integers(0, 10**12))
    stamp = T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
    header = (T["std_msgs/msg/Header"](seq=k, stamp=stamp, frame_id=text) if ros1
              else T["std_msgs/msg/Header"](stamp=stamp, frame_id=text))
    vec = T["geometry_msgs/msg/Vector3"]
    if kind == "sensor_msgs/Imu":
        v = rng.normal(size=13)
        return T["sensor_msgs/msg/Imu"](
            header=header,
            orientation=T["geometry_msgs/msg/Quaternion"](x=v[0], y=v[1], z=v[2], w=v[3]),
            orientation_covariance=rng.normal(size=9),
            angular_velocity=vec(x=v[4], y=v[5], z=v[6]),
            angular_velocity_covariance=rng.normal(size=9),
            linear_acceleration=vec(x=v[7], y=v[8], z=v[9]),
            linear_acceleration_covariance=rng.normal(size=9))
    v = rng.normal(size=6)
    wrench = T["geometry_msgs/msg/Wrench"](force=vec(x=v[0], y=v[1], z=v[2]),
                                           torque=vec(x=v[3], y=v[4], z=v[5]))
    if kind == "geometry_msgs/Wrench":
        return wrench
    return T["geometry_msgs/msg/WrenchStamped"](header=header, wrench=wrench)


def _serialise(store, msg, kind: str, serialisation: str, little: bool) -> bytes:
    if serialisation == "ros1":
        return bytes(store.serialize_ros1(msg, _full(kind)))
    return bytes(store.serialize_cdr(msg, _full(kind), little_endian=little))


def _deserialise(store, raw: bytes, kind: str, serialisation: str):
    if serialisation == "ros1":
        return store.deserialize_ros1(raw, _full(kind))
    return store.deserialize_cdr(raw, _full(kind))


@pytest.mark.parametrize(("serialisation", "ros1", "little"), SERIALISATIONS)
@pytest.mark.parametrize("kind", sorted(RAW_TYPES))
def test_raw_rows_equal_the_deserialised_ones(kind, serialisation, ros1, little):
    store = STORES[ros1]
    rng = np.random.default_rng(len(kind) + 10 * little)
    raws, wants = [], []
    reader = fast = None
    for k in range(16):
        msg = _message(store, kind, rng, k, ros1)
        raw = _serialise(store, msg, kind, serialisation, little)
        decoded = _deserialise(store, raw, kind, serialisation)
        if reader is None:  # planned on the first message, as robot_bag does
            reader = row_reader(None, "/t", _full(kind), decoded, None)
            layout = getattr(decoded, "layout", None)
            fast = raw_rows(serialisation, _full(kind),
                            int(layout.data_offset) if layout is not None else 0, "/t",
                            Path("r"))
        assert fast is not None
        want = reader.read(decoded)
        row = fast.row(raw, k)
        assert fast.stamp(raw, k) == header_stamp_ns(decoded)
        assert row.dtype == want.dtype
        np.testing.assert_array_equal(row, want)
        raws.append(raw)
        wants.append(want)
    # blocks: of one layout (a view of the joined bytes) and of mixed layouts (one by one)
    for block in ([raws[0]], [raws[8]] * 5, [raws[3]] * 4 + [raws[11]] * 3, raws):
        expect = [wants[raws.index(r)] for r in block]
        if len({len(e) for e in expect}) > 1:
            continue  # multi-arrays of several lengths: a channel count error, tested below
        got = fast.rows(block, list(range(len(block))), len(expect[0]))
        assert got.dtype == expect[0].dtype
        np.testing.assert_array_equal(got, np.vstack(expect))


def test_types_without_a_raw_reader_are_left_to_the_deserialiser():
    for msgtype in ("sensor_msgs/msg/Image", "sensor_msgs/msg/JointState",
                    "std_msgs/msg/ByteMultiArray", "tactile_msgs/msg/Taxels"):
        for serialisation in ("ros1", "cdr"):
            assert raw_rows(serialisation, msgtype, 0, "/t", Path("r")) is None


@pytest.mark.parametrize(("serialisation", "ros1", "little"), SERIALISATIONS)
@pytest.mark.parametrize("kind", ["std_msgs/Float32MultiArray", "geometry_msgs/WrenchStamped",
                                  "sensor_msgs/Imu"])
def test_a_damaged_message_is_one_error_naming_topic_and_message(kind, serialisation, ros1,
                                                                   little):
    store = STORES[ros1]
    msg = _message(store, kind, np.random.default_rng(3), 5, ros1)
    raw = _serialise(store, msg, kind, serialisation, little)
    fast = raw_rows(serialisation, _full(kind), 0, "/t", Path("rig.bag"))
    n = len(fast.row(raw, 0))
    damaged = [raw[:cut] for cut in (len(raw) - 1, len(raw) // 2, 3, 0)]
    damaged.append(raw + bytes(8))  # bytes after the message's end
    if serialisation == "cdr":
        damaged.append(b"\x07" + raw[1:])  # not a CDR encapsulation header
    for bad in damaged:
        calls = [lambda r: fast.row(r, 7), lambda r: fast.rows([raw, r], [6, 7], n)]
        if kind != "std_msgs/Float32MultiArray" and len(bad) < 16:
            calls.append(lambda r: fast.stamp(r, 7))
        for call in calls:
            with pytest.raises(InputError) as err:
                call(bad)
            text = str(err.value)
            assert "rig.bag" in text and "topic /t, message 7" in text and "\n" not in text


def test_a_block_with_another_channel_count_names_the_message():
    store = STORES[True]
    T = store.types
    layout = T["std_msgs/msg/MultiArrayLayout"](dim=[], data_offset=0)
    raws = [bytes(store.serialize_ros1(
        T["std_msgs/msg/Float32MultiArray"](layout=layout, data=np.zeros(n, np.float32)),
        "std_msgs/msg/Float32MultiArray")) for n in (4, 4, 5)]
    fast = raw_rows("ros1", "std_msgs/msg/Float32MultiArray", 0, "/taxels", Path("rig.bag"))
    np.testing.assert_array_equal(fast.rows(raws[:2], [0, 1], 4), np.zeros((2, 4)))
    with pytest.raises(InputError, match="topic /taxels, message 12: 5 values, but the first "
                                         "message gave 4"):
        fast.rows(raws, [10, 11, 12], 4)


def _custom_wrench_bag(path: Path) -> Path:
    """A ROS 2 bag whose own WrenchStamped has a float64 between header and wrench."""
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    standard = get_typestore(Stores.ROS2_HUMBLE)
    store = get_typestore(Stores.EMPTY)
    store.register({n: standard.fielddefs[n] for n in (
        "std_msgs/msg/Header", "builtin_interfaces/msg/Time", "geometry_msgs/msg/Wrench",
        "geometry_msgs/msg/Vector3")})
    store.register(get_types_from_msg(
        "std_msgs/Header header\nfloat64 temperature\ngeometry_msgs/Wrench wrench\n",
        "geometry_msgs/msg/WrenchStamped"))
    T = store.types
    vec = T["geometry_msgs/msg/Vector3"]
    with Writer(path, version=9) as w:
        conn = w.add_connection("/ft", "geometry_msgs/msg/WrenchStamped", typestore=store)
        for i in range(5):
            ns = T0_NS + i * 10**6
            stamp = T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
            msg = T["geometry_msgs/msg/WrenchStamped"](
                header=T["std_msgs/msg/Header"](stamp=stamp, frame_id="ft"),
                temperature=30.0 + i,
                wrench=T["geometry_msgs/msg/Wrench"](force=vec(x=float(i), y=2.0, z=3.0),
                                                     torque=vec(x=4.0, y=5.0, z=6.0)))
            w.write(conn, ns, store.serialize_cdr(msg, "geometry_msgs/msg/WrenchStamped"))
    return path


def test_a_recordings_own_definition_under_a_standard_name_is_deserialised(tmp_path):
    import h5py

    from tactile_cli.ingest import ingest
    from tactile_cli.ingest.robot_recording import RobotRecording

    bag = _custom_wrench_bag(tmp_path / "b")
    with RobotRecording(bag) as rec:
        assert not rec.is_standard("geometry_msgs/msg/WrenchStamped")
        assert rec.is_standard("geometry_msgs/msg/Wrench")
    mapping = tmp_path / "m.yaml"
    mapping.write_text("streams:\n  - {topic: /ft, name: ft, kind: force_torque}\n")
    out = ingest([bag], tmp_path / "o.h5", options={"mapping": mapping})
    with h5py.File(out) as h5:
        values = h5["trials/b/signals/ft/data"][:]
    expect = np.array([[i, 2, 3, 4, 5, 6] for i in range(5)], dtype=values.dtype)
    np.testing.assert_array_equal(values, expect)  # not the temperature read as force x


def test_a_block_of_equal_lengths_but_other_layouts_is_read_message_by_message():
    """Same byte length, values at other places: an array with a longer label and fewer
    values, a wrench in the other byte order; the block view must not be used."""
    store = STORES[True]
    T = store.types

    def array(label: str, n: int) -> bytes:
        dim = T["std_msgs/msg/MultiArrayDimension"](label=label, size=n, stride=n)
        layout = T["std_msgs/msg/MultiArrayLayout"](dim=[dim], data_offset=0)
        msg = T["std_msgs/msg/Float32MultiArray"](layout=layout,
                                                  data=np.arange(n, dtype=np.float32))
        return bytes(store.serialize_ros1(msg, "std_msgs/msg/Float32MultiArray"))

    a, b = array("ab", 3), array("abcdef", 2)
    assert len(a) == len(b)
    fast = raw_rows("ros1", "std_msgs/msg/Float32MultiArray", 0, "/taxels", Path("rig.bag"))
    with pytest.raises(InputError, match="message 1: 2 values, but the first message gave 3"):
        fast.rows([a, b], [0, 1], 3)

    store2 = STORES[False]
    msgs = [_message(store2, "geometry_msgs/WrenchStamped", np.random.default_rng(k), 2, False)
            for k in range(2)]
    raws = [_serialise(store2, m, "geometry_msgs/WrenchStamped", "cdr", little)
            for m, little in zip(msgs, (True, False), strict=True)]
    assert len(raws[0]) == len(raws[1])
    fast = raw_rows("cdr", "geometry_msgs/msg/WrenchStamped", 0, "/ft", Path("rig.bag"))
    want = [[m.wrench.force.x, m.wrench.force.y, m.wrench.force.z, m.wrench.torque.x,
             m.wrench.torque.y, m.wrench.torque.z] for m in msgs]
    np.testing.assert_array_equal(fast.rows(raws, [0, 1], 6), want)
