"""Small robot recordings written by the real writers: ROS 1 bags and ROS 2 bags (sqlite3,
mcap storage) with rosbags' writers, standalone MCAP files with mcap-ros2-support's writer.

:func:`rig_messages` builds the messages of a small tactile rig once (a DIGIT-like camera,
a taxel array, a force/torque sensor, a custom type, a trial marker), with known values and
stamps, so the tests can compare every value and time that comes out of the store with what
went in. Stamps are in ns on a Unix-epoch clock; header stamps lag the log times by
``HEADER_LAG_NS`` so the tests can tell the two time sources apart.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

T0_NS = 1_700_000_000_000_000_000
HEADER_LAG_NS = 2_000_000  # header stamp = log time - 2 ms
CUSTOM_MSG = """std_msgs/Header header
geometry_msgs/Vector3[] taxels
float32 temperature
"""
CUSTOM_TYPE = "tactile_rig/msg/TaxelPad"
EVENT_MSG = """std_msgs/Header header
uint32 height
uint32 width
dvs_msgs/Event[] events
================================================================================
MSG: dvs_msgs/Event
uint16 x
uint16 y
time ts
bool polarity
"""


@dataclass
class Rig:
    """Messages per topic: topic -> (msgtype, [(log_ns, message object)]); the values the
    tests expect: ``taxels`` (n, 6), ``wrench`` (n, 6), ``frames`` (n, H, W, 3)."""

    topics: dict[str, tuple[str, list[tuple[int, Any]]]] = field(default_factory=dict)
    taxels: np.ndarray | None = None
    wrench: np.ndarray | None = None
    frames: np.ndarray | None = None
    custom: np.ndarray | None = None


def typestore(ros1: bool) -> Any:
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    store.register(get_types_from_msg(CUSTOM_MSG, CUSTOM_TYPE))
    if ros1:
        store.register(get_types_from_msg(EVENT_MSG, "dvs_msgs/msg/EventArray"))
    return store


def _stamp(store: Any, ns: int) -> Any:
    return store.types["builtin_interfaces/msg/Time"](sec=ns // 1_000_000_000,
                                                      nanosec=ns % 1_000_000_000)


def _header(store: Any, ns: int, frame: str, ros1: bool) -> Any:
    H = store.types["std_msgs/msg/Header"]
    if ros1:
        return H(seq=0, stamp=_stamp(store, ns), frame_id=frame)
    return H(stamp=_stamp(store, ns), frame_id=frame)


def rig_messages(store: Any, *, ros1: bool, n_taxel: int = 50, n_frames: int = 6,
                 size_hw: tuple[int, int] = (6, 8), marker: bool = True,
                 events: bool = False, seed: int = 0) -> Rig:
    """The rig's messages over 0.5 s: taxels at 100 Hz (2x3 Float32MultiArray), wrench at
    100 Hz (offset 5 ms), rgb8 frames at ~12 Hz, the custom pad at 20 Hz, a String marker
    opening two trials (0.05-0.2 s, 0.25-0.45 s), optionally DVS events."""
    rng = np.random.default_rng(seed)
    rig = Rig()
    T = store.types
    ML, MD = T["std_msgs/msg/MultiArrayLayout"], T["std_msgs/msg/MultiArrayDimension"]
    taxels = rng.normal(size=(n_taxel, 6)).astype(np.float32)
    msgs = []
    for i in range(n_taxel):
        layout = ML(dim=[MD(label="row", size=2, stride=6), MD(label="col", size=3, stride=3)],
                    data_offset=0)
        msgs.append((T0_NS + i * 10_000_000,
                     T["std_msgs/msg/Float32MultiArray"](layout=layout, data=taxels[i])))
    rig.topics["/taxels"] = ("std_msgs/msg/Float32MultiArray", msgs)
    rig.taxels = taxels
    wrench = rng.normal(size=(n_taxel, 6))
    msgs = []
    V = T["geometry_msgs/msg/Vector3"]
    for i in range(n_taxel):
        log = T0_NS + 5_000_000 + i * 10_000_000
        w = T["geometry_msgs/msg/Wrench"](force=V(*wrench[i, :3]), torque=V(*wrench[i, 3:]))
        msgs.append((log, T["geometry_msgs/msg/WrenchStamped"](
            header=_header(store, log - HEADER_LAG_NS, "ft_link", ros1), wrench=w)))
    rig.topics["/ft"] = ("geometry_msgs/msg/WrenchStamped", msgs)
    rig.wrench = wrench
    h, w_ = size_hw
    frames = rng.integers(0, 256, size=(n_frames, h, w_, 3), dtype=np.uint8)
    msgs = []
    for i in range(n_frames):
        log = T0_NS + 1_000_000 + i * 80_000_000
        msgs.append((log, T["sensor_msgs/msg/Image"](
            header=_header(store, log - HEADER_LAG_NS, "digit_DG123", ros1), height=h, width=w_,
            encoding="rgb8", is_bigendian=0, step=w_ * 3, data=frames[i].ravel())))
    rig.topics["/digit/image_raw"] = ("sensor_msgs/msg/Image", msgs)
    rig.frames = frames
    custom = rng.normal(size=(10, 4, 3))
    msgs = []
    for i in range(10):
        log = T0_NS + 2_000_000 + i * 50_000_000
        msgs.append((log, T[CUSTOM_TYPE](
            header=_header(store, log - HEADER_LAG_NS, "pad", ros1),
            taxels=[V(*custom[i, j]) for j in range(4)], temperature=np.float32(30 + i))))
    rig.topics["/pad"] = (CUSTOM_TYPE, msgs)
    rig.custom = custom
    if marker:
        S = T["std_msgs/msg/String"]
        rig.topics["/trial"] = ("std_msgs/msg/String", [
            (T0_NS + 50_000_000, S(data="start:press_a")), (T0_NS + 200_000_000, S(data="stop")),
            (T0_NS + 250_000_000, S(data="start")), (T0_NS + 450_000_000, S(data="stop"))])
    if events:
        E, EA = T["dvs_msgs/msg/Event"], T["dvs_msgs/msg/EventArray"]
        msgs = []
        for i in range(5):
            log = T0_NS + i * 100_000_000
            evs = [E(x=int(rng.integers(0, 32)), y=int(rng.integers(0, 24)),
                     ts=_stamp(store, log + 1000 * j), polarity=bool(j % 2)) for j in range(20)]
            msgs.append((log, EA(header=_header(store, log, "dvs", ros1), height=24, width=32,
                                 events=evs)))
        rig.topics["/dvs/events"] = ("dvs_msgs/msg/EventArray", msgs)
    return rig


def _sorted(rig: Rig) -> list[tuple[int, str, str, Any]]:
    out = [(t, topic, msgtype, m) for topic, (msgtype, msgs) in rig.topics.items()
           for t, m in msgs]
    return sorted(out, key=lambda r: r[0])


def write_ros1_bag(path: Path, rig: Rig, store: Any) -> Path:
    """A ROS 1 bag (rosbags' rosbag1 writer, definitions stored)."""
    from rosbags.rosbag1 import Writer

    with Writer(path) as w:
        conns = {topic: w.add_connection(topic, msgtype, typestore=store)
                 for topic, (msgtype, _) in rig.topics.items()}
        for t, topic, msgtype, m in _sorted(rig):
            w.write(conns[topic], t, store.serialize_ros1(m, msgtype))
    return path


def write_ros2_bag(path: Path, rig: Rig, store: Any, *, storage: str = "sqlite3") -> Path:
    """A ROS 2 bag folder (rosbags' rosbag2 writer, version 9, definitions stored)."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    with Writer(path, version=9, storage_plugin=plugin) as w:
        conns = {topic: w.add_connection(topic, msgtype, typestore=store)
                 for topic, (msgtype, _) in rig.topics.items()}
        for t, topic, msgtype, m in _sorted(rig):
            w.write(conns[topic], t, store.serialize_cdr(m, msgtype))
    return path


def _to_dict(msg: Any) -> Any:
    """A rosbags message as the plain dicts mcap-ros2-support's writer encodes."""
    if hasattr(msg, "__dataclass_fields__"):
        return {k: _to_dict(getattr(msg, k)) for k in msg.__dataclass_fields__
                if k != "__msgtype__"}
    if isinstance(msg, np.ndarray):
        return bytes(msg) if msg.dtype == np.uint8 else msg.tolist()
    if isinstance(msg, list):
        return [_to_dict(m) for m in msg]
    if isinstance(msg, np.generic):
        return msg.item()
    return msg


def write_mcap(path: Path, rig: Rig, store: Any) -> Path:
    """A standalone MCAP file of ROS 2 messages (mcap-ros2-support's writer)."""
    from mcap_ros2.writer import Writer

    with open(path, "wb") as f:
        w = Writer(f)
        schemas = {}
        for topic, (msgtype, _) in rig.topics.items():
            schemas[topic] = w.register_msgdef(msgtype, store.generate_msgdef(
                msgtype, ros_version=2)[0])
        for t, topic, _, m in _sorted(rig):
            w.write_message(topic, schemas[topic], _to_dict(m), log_time=t, publish_time=t)
        w.finish()
    return path


__all__ = ["CUSTOM_TYPE", "HEADER_LAG_NS", "T0_NS", "Rig", "rig_messages", "typestore",
           "write_mcap", "write_ros1_bag", "write_ros2_bag"]


def write_mcap_without_definition(path: Path) -> Path:
    """A standalone MCAP file whose one topic ``/pad`` has the custom type
    :data:`CUSTOM_TYPE` with an empty definition (what a recorder that stores no message
    definitions writes): one message."""
    from mcap.writer import Writer

    with open(path, "wb") as f:
        w = Writer(f)
        w.start(profile="ros2")
        schema = w.register_schema(CUSTOM_TYPE, "ros2msg", b"")
        channel = w.register_channel("/pad", "cdr", schema)
        w.add_message(channel, log_time=1, publish_time=1, data=b"\x00\x01\x00\x00")
        w.finish()
    return path
