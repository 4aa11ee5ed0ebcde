"""Robot recordings that are wrong in what they hold, not in their bytes (issue 31, item 6):
each is a well-formed file written by the real writer, with a mapping that reads it, so the
corpus runs ``tactile ingest`` (and ``tactile info``) on exactly one fault:

- ``backward.mcap``: a wrench topic whose header stamps go back twice (refused unless
  ``--sort-stamps``; counted in the line);
- ``bad_jpeg.mcap``: a CompressedImage topic whose second JPEG is cut to 20 bytes (the line
  names the message index);
- ``nodef.mcap``: a custom message type with an empty definition (the line names the type);
- ``no_frames.mp4``: an MP4 whose video track has no sample in it;
- ``zeroed_frame.mp4``: an MP4 of one frame whose coded bytes are zeros (a stream that holds
  no frame that decodes).

The byte-level damage of the sample bags (cut, zeroed, flipped, empty) and the mapping
mutations (a topic the recording lacks, a field path that does not exist) are made in
corpus.py from the samples. :func:`write_robot_cases` writes the files under ``folder``
(about a second) and returns {name: (recording, mapping)}.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from tests.factories.robot_recordings import T0_NS, write_mcap_without_definition

#: case name -> (recording file name, the mapping's one stream line)
CASES = {
    "backward-stamps": ("backward.mcap", "{topic: /ft, name: ft, kind: force_torque}"),
    "bad-jpeg": ("bad_jpeg.mcap", "{topic: /cam/compressed, name: cam, kind: visuotactile}"),
    "type-without-definition": ("nodef.mcap", "{topic: /pad, name: p, kind: pressure}"),
    "no-frames": ("no_frames.mp4", None),
    "undecodable-frame": ("zeroed_frame.mp4", None),
}


def _store():
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_HUMBLE)


def _write_bag(path: Path, topic: str, msgtype: str, msgs: list[tuple[int, object]]) -> None:
    """A ROS 2 bag with mcap storage holding one topic; ``path`` is the .mcap file inside."""
    import shutil

    from rosbags.rosbag2 import StoragePlugin, Writer

    folder = path.with_suffix("")
    store = _store()
    with Writer(folder, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        conn = w.add_connection(topic, msgtype, typestore=store)
        for t, m in msgs:
            w.write(conn, t, store.serialize_cdr(m, msgtype))
    (inner,) = folder.glob("*.mcap")
    shutil.move(str(inner), path)
    shutil.rmtree(folder)


def _header(ns: int, frame: str):
    T = _store().types
    return T["std_msgs/msg/Header"](
        stamp=T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9),
        frame_id=frame)


def _backward(path: Path) -> None:
    T = _store().types
    V, W = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Wrench"]
    stamps_ms = [0, 10, 5, 20, 15, 30]
    _write_bag(path, "/ft", "geometry_msgs/msg/WrenchStamped", [
        (T0_NS + i * 10**7, T["geometry_msgs/msg/WrenchStamped"](
            header=_header(T0_NS + s * 10**6, "ft"),
            wrench=W(force=V(float(i), 0.0, 0.0), torque=V(0.0, 0.0, 0.0))))
        for i, s in enumerate(stamps_ms)])


def _jpeg(pixels: np.ndarray) -> np.ndarray:
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(pixels).save(buf, format="JPEG")
    return np.frombuffer(buf.getvalue(), dtype=np.uint8)


def _bad_jpeg(path: Path) -> None:
    T = _store().types
    rng = np.random.default_rng(3)
    msgs = []
    for i in range(3):
        data = _jpeg(rng.integers(0, 256, (16, 16, 3), dtype=np.uint8))
        data = data[:20] if i == 1 else data
        ns = T0_NS + i * 10**7
        msgs.append((ns, T["sensor_msgs/msg/CompressedImage"](
            header=_header(ns, "cam"), format="jpeg", data=data)))
    _write_bag(path, "/cam/compressed", "sensor_msgs/msg/CompressedImage", msgs)


def _mp4(path: Path, n_frames: int) -> None:
    import av

    with av.open(str(path), "w") as container:
        stream = container.add_stream("mpeg4", rate=30)
        stream.width, stream.height, stream.pix_fmt = 32, 24, "yuv420p"
        container.start_encoding()
        for _ in range(n_frames):
            frame = av.VideoFrame.from_ndarray(np.zeros((24, 32, 3), np.uint8), format="rgb24")
            for packet in stream.encode(frame):
                container.mux(packet)
        for packet in stream.encode():
            container.mux(packet)


def _no_frames(path: Path) -> None:
    _mp4(path, 0)


def _zeroed_frame(path: Path) -> None:
    _mp4(path, 1)
    data = bytearray(path.read_bytes())
    at = data.find(b"mdat")
    size = int.from_bytes(data[at - 4:at], "big")
    data[at + 4:at - 4 + size] = bytes(size - 8)
    path.write_bytes(bytes(data))


def write_robot_cases(folder: Path) -> dict[str, tuple[Path, Path | None]]:
    """Write every case of :data:`CASES` under ``folder``; name -> (recording, mapping)."""
    folder.mkdir(parents=True, exist_ok=True)
    writers = {"backward-stamps": _backward, "bad-jpeg": _bad_jpeg,
               "type-without-definition": write_mcap_without_definition, "no-frames": _no_frames,
               "undecodable-frame": _zeroed_frame}
    out: dict[str, tuple[Path, Path | None]] = {}
    for name, (file, stream) in CASES.items():
        writers[name](folder / file)
        mapping = None
        if stream is not None:
            mapping = folder / f"{Path(file).stem}.yaml"
            mapping.write_text(f"streams:\n  - {stream}\n")
        out[name] = (folder / file, mapping)
    return out
