"""Robot recordings of a simulated press, as a ROS rig records them: a DIGIT-like camera
(``sensor_msgs/Image`` rgb8), a 4x4 taxel array (``std_msgs/Float32MultiArray``), a
force/torque sensor (``geometry_msgs/WrenchStamped``) and a trial marker (``std_msgs/String``
``start:NAME`` / ``stop``), written by the real writers: a ROS 1 bag and a ROS 2 bag with
mcap storage (``rosbags``), a standalone MCAP file (``mcap-ros2-support``) and an MP4 of the
camera (PyAV, MPEG-4). :data:`RIG_MAPPING` is the topic mapping that ingests them (the same
as ``configs/rosbag_tactile_rig.yaml``).

The press: an indenter comes down at t = 0.2 s of each trial, holds, and lifts at 0.7 s;
force follows a smooth step (about 5 N), taxel pressure is a Gaussian patch scaled by the
force, the camera shows a dome growing with it. Messages are made one at a time in log-time
order (:func:`rig_stream`), so the benchmark can write recordings of any size in bounded
memory. Everything is deterministic for a given seed.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

#: The log time of the first message, ns since the Unix epoch (2024-01-01T00:00:00Z).
T0_NS = 1_704_067_200_000_000_000
#: Header stamps lag the log times by this much (acquisition before the recorder got it).
HEADER_LAG_NS = 1_000_000

RIG_MAPPING = """\
# A tactile ROS rig: a camera-based sensor (DIGIT), a taxel array and a wrist F/T sensor.
version: 1
time: header                 # header stamps (log time for messages without a header)
trials:
  marker: {topic: /trial_marker}   # std_msgs/String: "start:NAME" opens, "stop" closes
  labels: {origin: synthetic, dataset: tactile-samples}
streams:
  - topic: /digit/image_raw
    name: digit
    kind: visuotactile
    reference: first         # the frame before contact is each trial's reference
    description: DIGIT-like camera, simulated press
  - topic: /taxels
    name: taxels
    kind: taxel_array
    units: kPa
    description: 4x4 taxel array (layout dims row, col become the channel names)
  - topic: /ft_sensor/wrench
    name: wrench
    kind: force_torque
    serial: FT-SIM-0001
    description: wrist force/torque sensor (N, N m)
"""


def _types(ros1: bool) -> Any:
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)


def press_force_n(t_s: np.ndarray) -> np.ndarray:
    """The press's normal force in N at trial times ``t_s`` (s): smooth up at 0.2 s, down at
    0.7 s, 5 N held."""
    rise = 0.5 * (1 + np.tanh((t_s - 0.2) / 0.04))  # logistic steps, no overflow far out
    fall = 0.5 * (1 - np.tanh((t_s - 0.7) / 0.04))
    return 5.0 * rise * fall


def rig_stream(*, ros1: bool, seconds: float = 1.0, n_trials: int = 2, image_hz: float = 30.0,
               size_hw: tuple[int, int] = (30, 40), array_hz: float = 200.0,
               taxel_grid: tuple[int, int] = (4, 4),
               seed: int = 0) -> Iterator[tuple[int, str, str, Any]]:
    """``(log_ns, topic, msgtype, message)`` of ``n_trials`` presses of ``seconds`` each, in
    log-time order (rosbags message objects of the ROS generation asked for).
    ``taxel_grid``: (rows, cols) of the taxel array (4x4; 20x60 is a Tac3D-sized array of
    1,200 values)."""
    store = _types(ros1)
    T = store.types
    rng = np.random.default_rng(seed)
    h, w = size_hw
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    background = np.stack([90 + 70 * x / max(1, w - 1), 80 + 70 * y / max(1, h - 1),
                           np.full_like(x, 140.0)], axis=-1)
    d2 = (x - w / 2) ** 2 + (y - h / 2) ** 2
    rows, cols = taxel_grid
    gy, gx = np.mgrid[0:rows, 0:cols]
    patch = np.exp(-((gx - (cols - 1) / 2) ** 2 + (gy - (rows - 1) / 2) ** 2)
                   / (2.0 * max(1.0, rows * cols / 16))).ravel()
    V = T["geometry_msgs/msg/Vector3"]
    Time = T["builtin_interfaces/msg/Time"]
    Header = T["std_msgs/msg/Header"]
    MD = T["std_msgs/msg/MultiArrayDimension"]
    layout = T["std_msgs/msg/MultiArrayLayout"](
        dim=[MD(label="row", size=rows, stride=rows * cols),
             MD(label="col", size=cols, stride=cols)],
        data_offset=0)

    def header(ns: int, frame: str) -> Any:
        stamp = Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)
        return Header(seq=0, stamp=stamp, frame_id=frame) if ros1 else Header(
            stamp=stamp, frame_id=frame)

    gap_ns = 200_000_000  # between trials
    trial_ns = round(seconds * 1e9)
    events: list[tuple[int, int, str]] = []  # (log_ns, order, what)
    for k in range(n_trials):
        start = T0_NS + k * (trial_ns + gap_ns)
        events.append((start, 0, f"start:{k}"))
        events.append((start + trial_ns, 0, "stop"))
        for i in range(int(seconds * image_hz)):
            events.append((start + round(i * 1e9 / image_hz) + 1_500_000, 1, f"image:{k}"))
        for i in range(int(seconds * array_hz)):
            events.append((start + round(i * 1e9 / array_hz) + 100_000, 2, f"taxel:{k}"))
            events.append((start + round(i * 1e9 / array_hz) + 1_200_000, 3, f"wrench:{k}"))
    events.sort()
    for log_ns, _, what in events:
        kind, _, trial = what.partition(":")
        if kind in ("start", "stop"):
            text = f"start:press_{int(trial) + 1}" if kind == "start" else "stop"
            yield log_ns, "/trial_marker", "std_msgs/msg/String", T["std_msgs/msg/String"](
                data=text)
            continue
        start = T0_NS + int(trial) * (trial_ns + gap_ns)
        t_s = np.array([(log_ns - start) / 1e9])
        force = float(press_force_n(t_s)[0])
        stamp_ns = log_ns - HEADER_LAG_NS
        if kind == "image":
            radius = 0.35 * min(h, w) * force / 5.0
            dome = np.clip(1 - d2 / max(radius, 0.5) ** 2, 0, 1)
            rgb = background + dome[..., None] * np.array([60.0, -30.0, -50.0])
            rgb += rng.normal(0, 2.0, rgb.shape)
            data = np.clip(np.rint(rgb), 0, 255).astype(np.uint8).ravel()
            yield log_ns, "/digit/image_raw", "sensor_msgs/msg/Image", T["sensor_msgs/msg/Image"](
                header=header(stamp_ns, "digit_D20001"), height=h, width=w, encoding="rgb8",
                is_bigendian=0, step=w * 3, data=data)
        elif kind == "taxel":
            values = (force * 4.0 * patch + rng.normal(0, 0.05, rows * cols)).astype(np.float32)
            yield log_ns, "/taxels", "std_msgs/msg/Float32MultiArray", T[
                "std_msgs/msg/Float32MultiArray"](layout=layout, data=values)
        else:
            f = rng.normal(0, 0.02, 6)
            wrench = T["geometry_msgs/msg/Wrench"](
                force=V(x=f[0], y=f[1], z=-force + f[2]),
                torque=V(x=f[3], y=f[4], z=f[5]))
            yield log_ns, "/ft_sensor/wrench", "geometry_msgs/msg/WrenchStamped", T[
                "geometry_msgs/msg/WrenchStamped"](header=header(stamp_ns, "ft_sensor"),
                                                   wrench=wrench)


def write_ros1_bag(path: str | Path, **kw: Any) -> Path:
    """The rig as a ROS 1 bag (rosbags' writer; ``kw`` as for :func:`rig_stream`)."""
    from rosbags.rosbag1 import Writer

    store = _types(True)
    path = Path(path)
    with Writer(path) as w:
        conns: dict[str, Any] = {}
        for t, topic, msgtype, msg in rig_stream(ros1=True, **kw):
            if topic not in conns:
                conns[topic] = w.add_connection(topic, msgtype, typestore=store)
            w.write(conns[topic], t, store.serialize_ros1(msg, msgtype))
    return path


def write_ros2_bag(path: str | Path, *, storage: str = "mcap", **kw: Any) -> Path:
    """The rig as a ROS 2 bag folder (rosbags' writer, mcap or sqlite3 storage)."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    store = _types(False)
    path = Path(path)
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    with Writer(path, version=9, storage_plugin=plugin) as w:
        conns: dict[str, Any] = {}
        for t, topic, msgtype, msg in rig_stream(ros1=False, **kw):
            if topic not in conns:
                conns[topic] = w.add_connection(topic, msgtype, typestore=store)
            w.write(conns[topic], t, store.serialize_cdr(msg, msgtype))
    return path


def _plain(msg: Any) -> Any:
    """A rosbags message as the plain dicts mcap-ros2-support's writer encodes."""
    if hasattr(msg, "__dataclass_fields__"):
        return {k: _plain(getattr(msg, k)) for k in msg.__dataclass_fields__
                if k != "__msgtype__"}
    if isinstance(msg, np.ndarray):
        return bytes(msg) if msg.dtype == np.uint8 else msg.tolist()
    if isinstance(msg, list):
        return [_plain(m) for m in msg]
    if isinstance(msg, np.generic):
        return msg.item()
    return msg


def write_mcap(path: str | Path, **kw: Any) -> Path:
    """The rig as a standalone MCAP file (mcap-ros2-support's ROS 2 writer)."""
    from mcap_ros2.writer import Writer

    store = _types(False)
    path = Path(path)
    with open(path, "wb") as f:
        w = Writer(f)
        schemas: dict[str, Any] = {}
        for t, topic, msgtype, msg in rig_stream(ros1=False, **kw):
            if topic not in schemas:
                schemas[topic] = w.register_msgdef(
                    msgtype, store.generate_msgdef(msgtype, ros_version=2)[0])
            w.write_message(topic, schemas[topic], _plain(msg), log_time=t, publish_time=t)
        w.finish()
    return path


def write_press_video(path: str | Path, **kw: Any) -> Path:
    """The rig's camera as an MP4 (PyAV, MPEG-4 part 2, 30 fps), one press."""
    from fractions import Fraction

    import av

    path = Path(path)
    frames = [np.asarray(m.data, dtype=np.uint8).reshape(m.height, m.width, 3)
              for _, topic, _, m in rig_stream(ros1=False, n_trials=1, **kw)
              if topic == "/digit/image_raw"]
    h, w = frames[0].shape[:2]
    with av.open(str(path), "w") as container:
        # FFmpeg's own MPEG-4 part 2 encoder: the same bytes every run (libx264's do vary)
        stream = container.add_stream("mpeg4", rate=30)
        stream.width, stream.height, stream.pix_fmt = w + w % 2, h + h % 2, "yuv420p"
        stream.codec_context.time_base = Fraction(1, 30)
        stream.codec_context.thread_count = 1
        stream.bit_rate = 2_000_000
        for k, rgb in enumerate(frames):
            rgb = np.pad(rgb, ((0, h % 2), (0, w % 2), (0, 0)), mode="edge")
            frame = av.VideoFrame.from_ndarray(rgb, format="rgb24")
            frame.pts, frame.time_base = k, Fraction(1, 30)
            for packet in stream.encode(frame):
                container.mux(packet)
        for packet in stream.encode():
            container.mux(packet)
    return path


def write_robot_samples(folder: str | Path, *, seed: int = 0) -> dict[str, Path]:
    """A ROS 1 bag, a ROS 2 bag (mcap storage), a standalone MCAP file, an MP4 and the
    mapping ``topics.yaml`` under ``folder``; returns their paths by name."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    mapping = folder / "topics.yaml"
    mapping.write_text(RIG_MAPPING)
    return {"mapping": mapping,
            "ros1_bag": write_ros1_bag(folder / "press.bag", seed=seed),
            "ros2_bag": write_ros2_bag(folder / "press_ros2", seed=seed),
            "mcap": write_mcap(folder / "press.mcap", seed=seed),
            "video": write_press_video(folder / "press.mp4", seed=seed)}


__all__ = ["HEADER_LAG_NS", "RIG_MAPPING", "T0_NS", "press_force_n", "rig_stream",
           "write_mcap", "write_press_video", "write_robot_samples", "write_ros1_bag",
           "write_ros2_bag"]
