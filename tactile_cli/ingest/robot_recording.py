"""Open a robot recording (ROS 1 bag, ROS 2 bag folder, standalone MCAP file) as one thing:
its topics, its raw messages in log-time order, and a decoder per message type.

Which library reads what, and why:

- **ROS 1 bags and ROS 2 bag folders** (sqlite3 or mcap storage) are read by ``rosbags``
  (``AnyReader``): pure Python with no ROS installation, maintained, one API for both ROS
  generations and both ROS 2 storage plugins, the definitions carried by the bag turned into
  generated (de)serialisers whose primitive arrays come out as numpy arrays (so a 1,200-value
  taxel array is one ``frombuffer``, not 1,200 Python floats).
- **Standalone ``.mcap`` files** are read by ``mcap`` (the format's reference reader: chunk
  index, summary statistics, zstd/lz4 chunks, log-time order across chunks). Their ROS 2
  messages (schema encoding ``ros2msg``, message encoding ``cdr``) are decoded with the
  same ``rosbags`` typesys from the definitions the file carries, rather than with
  ``mcap-ros2-support``'s pure-Python decoder, so an MCAP message and the same message in a
  bag come out as the same object (numpy arrays, the same field names), several times
  faster; ``mcap-ros2-support`` writes the MCAP files of the tests and samples.

Message types are spelt as recorded (``sensor_msgs/msg/Image``); :func:`short_type` gives
the ROS 1 spelling (``sensor_msgs/Image``) the mapping and the converters match on. Types the
recording carries no definition for are taken from the standard ROS type store of its
generation (ROS 1 Noetic, ROS 2 Humble); a type in neither is one error naming it, raised
only when a mapping asks for its topic. Every reader error (a file cut inside a chunk, a
corrupt chunk, a bad index) becomes one :class:`~tactile_cli.errors.InputError` naming the
file. The libraries are imported inside the functions: the package import stays light.
"""

from __future__ import annotations

import functools
import struct
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import InputError

#: Suffix of ROS 1 bags.
BAG_SUFFIX = ".bag"
#: Suffix of MCAP files (standalone, or the storage files of a ROS 2 bag folder).
MCAP_SUFFIX = ".mcap"
#: The file that makes a folder a ROS 2 bag.
ROS2_METADATA = "metadata.yaml"


@dataclass(frozen=True)
class TopicInfo:
    """One topic of a recording: its message type as recorded, its message count (from the
    recording's index) and whether a definition of its type is known."""

    name: str
    msgtype: str
    count: int
    defined: bool


def short_type(msgtype: str) -> str:
    """``sensor_msgs/msg/Image`` -> ``sensor_msgs/Image`` (ROS 1 and ROS 2 spell types apart)."""
    return msgtype.replace("/msg/", "/")


def is_ros2_folder(path: Path) -> bool:
    """Whether ``path`` is a ROS 2 bag folder (holds ``metadata.yaml``)."""
    try:
        return path.is_dir() and (path / ROS2_METADATA).is_file()
    except OSError:
        return False


def recording_kind(path: Path) -> str | None:
    """``"ros1"``, ``"ros2"`` or ``"mcap"`` from the path's suffix or layout, else None."""
    if is_ros2_folder(path):
        return "ros2"
    suffix = path.suffix.lower()
    if suffix == BAG_SUFFIX:
        return "ros1"
    if suffix == MCAP_SUFFIX:
        return "mcap"
    return None


def damaged(path: Path, exc: BaseException) -> InputError:
    """The one-line error of a recording its reader cannot read."""
    detail = " ".join(str(exc).split()) or type(exc).__name__
    return InputError(f"cannot read the recording ({detail}); the file is damaged or was cut "
                      "short (a recorder killed before it closed the file): re-index it "
                      "(`rosbag reindex`, `ros2 bag reindex`, `mcap recover`) or record it again",
                      path=path)


def require_robot_extra(what: str, modules: tuple[str, ...] = ("rosbags", "mcap")) -> None:
    """InputError saying how to install the ``robot`` extra when one of ``modules`` is
    missing (they are optional dependencies: ``pip install 'tactile-cli[robot]'``)."""
    import importlib.util

    missing = [m for m in modules if importlib.util.find_spec(m) is None]
    if missing:
        raise InputError(f"reading {what} needs {', '.join(missing)}, which is not installed; "
                         "install the robot extra: pip install 'tactile-cli[robot]'")


def _reader_errors() -> tuple[type[BaseException], ...]:
    """The exceptions the readers raise for damaged files."""
    from mcap.exceptions import McapError
    from rosbags.highlevel.anyreader import AnyReaderError
    from rosbags.rosbag1 import ReaderError as Reader1Error
    from rosbags.rosbag2 import ReaderError as Reader2Error
    from rosbags.serde import SerdeError
    from rosbags.typesys import TypesysError

    errors: list[type[BaseException]] = [McapError, AnyReaderError, Reader1Error, Reader2Error,
                                         SerdeError, TypesysError, struct.error, EOFError,
                                         ValueError, KeyError, IndexError, AssertionError]
    try:
        from zstandard import ZstdError
        errors.append(ZstdError)
    except ImportError:  # pragma: no cover - mcap installs zstandard
        pass
    import sqlite3
    errors.append(sqlite3.DatabaseError)
    return tuple(errors)


@functools.cache
def standard_types(generation: str) -> Any:
    """rosbags' store of the standard message types of ROS 1 Noetic (``"ros1"``) or ROS 2
    Humble (``"ros2"``): the definitions of types a recording does not carry. Read-only here."""
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS1_NOETIC if generation == "ros1" else Stores.ROS2_HUMBLE)


class RobotRecording:
    """A recording opened read-only; use as a context manager::

        with RobotRecording(path) as rec:
            for topic, log_ns, raw in rec.raw_messages({"/ft"}):
                msg = rec.decoder(topic)(raw)

    kind: ``"ros1"``, ``"ros2"`` or ``"mcap"``; topics: name -> :class:`TopicInfo`, in
    name order; size_bytes: bytes of the files read; storage: how the messages are stored
    (``ROS 1 bag``, ``ROS 2 bag (sqlite3)``, ``ROS 2 bag (mcap)``, ``MCAP``).
    """

    def __init__(self, path: Path):
        self.path = Path(path)
        kind = recording_kind(self.path)
        if kind is None:
            raise InputError("is not a robot recording (a .bag file, a ROS 2 bag folder with "
                             "metadata.yaml, or a .mcap file)", path=path)
        self.kind = kind
        require_robot_extra("ROS bags and MCAP files")
        self._errors = _reader_errors()
        self._reader: Any = None
        self._file: Any = None
        self._typestore: Any = None
        self._types: dict[str, str] = {}  # topic -> msgtype
        self._decoders: dict[str, Callable[[bytes], Any]] = {}
        self.topics: dict[str, TopicInfo] = {}
        self.size_bytes = 0
        self.storage = ""

    # -- opening ------------------------------------------------------------------
    def __enter__(self) -> RobotRecording:
        try:
            if self.kind == "mcap":
                self._open_mcap()
            else:
                self._open_bag()
        except InputError:
            self.close()
            raise
        except self._errors as exc:
            self.close()
            raise damaged(self.path, exc) from None
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        if self._reader is not None and self.kind != "mcap":
            try:
                self._reader.close()
            except Exception:  # noqa: BLE001 - closing a reader that failed half-way
                pass
        self._reader = None
        if self._file is not None:
            self._file.close()
            self._file = None

    def _open_bag(self) -> None:
        from rosbags.highlevel import AnyReader

        default = standard_types("ros1" if self.kind == "ros1" else "ros2")
        if self.kind == "ros2":
            files = [p for p in self.path.iterdir() if p.is_file()]
            storage = "mcap" if any(p.suffix == MCAP_SUFFIX for p in files) else "sqlite3"
            self.storage = f"ROS 2 bag ({storage})"
        else:
            files = [self.path]
            self.storage = "ROS 1 bag"
        self.size_bytes = sum(p.stat().st_size for p in files)
        reader = AnyReader([self.path], default_typestore=default)
        reader.open()
        self._reader = reader
        self._typestore, self._default = reader.typestore, default
        self._ros2 = self.kind == "ros2"
        for name, info in reader.topics.items():
            msgtype = info.msgtype or "(mixed types)"
            self._types[name] = msgtype
            self.topics[name] = TopicInfo(name=name, msgtype=msgtype, count=int(info.msgcount),
                                          defined=self._known(msgtype))

    def _open_mcap(self) -> None:
        from mcap.reader import make_reader
        from rosbags.typesys import Stores, get_types_from_msg, get_typestore

        self.storage = "MCAP"
        self.size_bytes = self.path.stat().st_size
        self._file = open(self.path, "rb")  # noqa: SIM115 - closed by close()
        # chunk CRCs checked: a corrupt chunk is then an error, never values decoded from
        # damaged bytes (zlib's crc32 costs little next to decompression)
        reader = make_reader(self._file, validate_crcs=True)
        summary = reader.get_summary()
        if summary is None:
            raise InputError("the MCAP file has no summary section (it was not closed "
                             "properly); run `mcap recover` on it first", path=self.path)
        self._reader = reader
        store = get_typestore(Stores.EMPTY)
        types: dict[str, Any] = {}
        for schema in summary.schemas.values():
            if schema.encoding != "ros2msg" or not schema.data:
                continue
            types.update(get_types_from_msg(schema.data.decode(), schema.name))
        store.register(types)
        self._typestore, self._default = store, standard_types("ros2")
        self._ros2 = True
        counts = summary.statistics.channel_message_counts if summary.statistics else {}
        self._mcap_encodings: dict[str, str] = {}
        for cid, channel in sorted(summary.channels.items(), key=lambda kv: kv[1].topic):
            schema = summary.schemas.get(channel.schema_id)
            msgtype = schema.name if schema is not None else "(no schema)"
            self._types[channel.topic] = msgtype
            self._mcap_encodings[channel.topic] = channel.message_encoding
            self.topics[channel.topic] = TopicInfo(
                name=channel.topic, msgtype=msgtype, count=int(counts.get(cid, 0)),
                defined=self._known(msgtype) and channel.message_encoding == "cdr")

    def _known(self, msgtype: str) -> bool:
        """Whether ``msgtype`` is defined by the recording or the standard store, with every
        type it nests; the standard ones are registered (with what they nest) on first use,
        since generating every standard type up front costs half a second."""
        store, default = self._typestore, self._default
        missing: dict[str, Any] = {}
        todo = [msgtype]
        while todo:
            name = todo.pop()
            if name in store.fielddefs or name in missing:
                continue
            if name not in default.fielddefs:
                return False
            missing[name] = default.fielddefs[name]
            for _, node in default.fielddefs[name][1]:
                while node[0] in (3, 4):  # arrays and sequences of ...
                    node = node[1][0]
                if node[0] == 2:  # ... a nested message
                    todo.append(node[1])
        if missing:
            store.register(missing)
        return True

    # -- messages -----------------------------------------------------------------
    def raw_messages(self, topics: Iterable[str] | None = None
                     ) -> Iterator[tuple[str, int, bytes]]:
        """``(topic, log_time_ns, raw bytes)`` of every message of ``topics`` (all when
        None), in log-time order; a damaged file is one InputError naming it."""
        wanted = None if topics is None else set(topics)
        try:
            if self.kind == "mcap":
                for _, channel, message in self._reader.iter_messages(
                        topics=None if wanted is None else sorted(wanted)):
                    yield channel.topic, int(message.log_time), message.data
            else:
                conns = [c for c in self._reader.connections
                         if wanted is None or c.topic in wanted]
                if wanted is not None and not conns:
                    return
                for conn, t_ns, raw in self._reader.messages(connections=conns):
                    yield conn.topic, int(t_ns), raw
        except InputError:
            raise
        except self._errors as exc:
            raise damaged(self.path, exc) from None

    def decoder(self, topic: str) -> Callable[[bytes], Any]:
        """The function that turns a raw message of ``topic`` into a message object (a
        dataclass with the type's fields, primitive arrays as numpy arrays); InputError
        naming the type when the recording has no definition for it."""
        if topic in self._decoders:
            return self._decoders[topic]
        info = self.topics[topic]
        if not info.defined:
            encoding = getattr(self, "_mcap_encodings", {}).get(topic, "cdr")
            if encoding != "cdr":
                raise InputError(f"topic {topic} holds {encoding} messages; tactile reads ROS "
                                 "messages (cdr encoding, ros2msg schemas) from MCAP files",
                                 path=self.path)
            raise InputError(f"message type {info.msgtype} (topic {topic}) has no definition in "
                             "the recording and is not a standard ROS type; record with the "
                             "definitions stored (ros2 bag record does; rosbags needs "
                             "`msgdef=`) or leave the topic out of the mapping", path=self.path)
        store, msgtype = self._typestore, info.msgtype
        errors, path = self._errors, self.path
        deserialize = store.deserialize_cdr if self._ros2 else store.deserialize_ros1

        def decode(raw: bytes) -> Any:
            try:
                return deserialize(raw, msgtype)
            except errors as exc:
                raise damaged(path, exc) from None

        self._decoders[topic] = decode
        return decode

    @property
    def serialisation(self) -> str:
        """How the messages are serialised: ``"ros1"`` (ROS 1 bags) or ``"cdr"`` (ROS 2 bags
        and MCAP files)."""
        return "ros1" if self.kind == "ros1" else "cdr"

    def is_standard(self, msgtype: str) -> bool:
        """Whether the recording defines ``msgtype``, and every type it nests, field for field
        as the standard store of its ROS generation does (a bag may carry its own definition
        under a standard name)."""
        store, default = self._typestore, self._default
        todo, seen = [msgtype], set()
        while todo:
            name = todo.pop()
            if name in seen:
                continue
            seen.add(name)
            if name not in store.fielddefs or name not in default.fielddefs:
                return False
            fields = store.fielddefs[name][1]
            if fields != default.fielddefs[name][1]:
                return False
            for _, node in fields:
                while node[0] in (3, 4):  # arrays and sequences of ...
                    node = node[1][0]
                if node[0] == 2:  # ... a nested message
                    todo.append(node[1])
        return True

    def fields_of(self, msgtype: str) -> list[tuple[str, tuple[Any, ...]]]:
        """The fields of a message type as ``(name, type node)``: rosbags' field
        definitions (see :mod:`tactile_cli.ingest.robot_messages`)."""
        return list(self._typestore.fielddefs[msgtype][1])

    def has_type(self, msgtype: str) -> bool:
        return self._known(msgtype)


__all__ = ["BAG_SUFFIX", "MCAP_SUFFIX", "ROS2_METADATA", "RobotRecording", "TopicInfo",
           "damaged", "is_ros2_folder", "recording_kind", "require_robot_extra", "short_type"]
