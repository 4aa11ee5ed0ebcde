"""AEDAT4 stream types, and a copy of a file without the streams the decoder cannot read.

The maintained ``aedat`` decoder knows four stream types (``EVTS`` events, ``FRME`` frames,
``IMUS`` IMU samples, ``TRIG`` triggers) and refuses a whole file that declares any other
(``POSE`` poses, ``BBOX`` bounding boxes, ... written by DV or dv-processing). To ingest
the rest of such a file (``skip_unknown=True``), :func:`copy_without_streams` writes a copy
without those streams: their ``outInfo`` nodes leave the header's XML description and
their packets are left out, byte for byte otherwise. The copy has no file data table (the
decoder reads packets until the file ends). It costs one pass over the file's bytes, on a
temporary disk, and only files with unknown streams pay it.

Layout (AEDAT 4.0, iniVation): ``#!AER-DAT4.0\\r\\n``, a uint32 header length, the IOHeader
flatbuffer (compression, data table position, XML description), then packets of an int32
stream id, a uint32 byte count and that many (compressed) bytes.
"""

from __future__ import annotations

import re
import struct
import xml.etree.ElementTree as ET
from pathlib import Path

from ..errors import InputError

MAGIC = b"#!AER-DAT4.0\r\n"

#: Stream type identifier -> what tactile makes of it.
KNOWN_TYPES: dict[str, str] = {"EVTS": "events", "FRME": "frames", "IMUS": "IMU samples",
                               "TRIG": "triggers"}

_COPY_BLOCK = 1 << 22  # bytes copied at a time


def stream_types(path: Path) -> dict[int, str]:
    """Stream id -> type identifier (``EVTS``, ``FRME``, ``POSE``, ...) from the header's
    XML description; an empty dict when the header has no readable description (the
    decoder then reports the file)."""
    root = _description(path)
    if root is None:
        return {}
    out: dict[int, str] = {}
    for sid, node in _stream_nodes(root):
        kind = node.find("attr[@key='typeIdentifier']")
        out[sid] = (kind.text or "").strip() if kind is not None else ""
    return out


def unknown_streams(path: Path) -> dict[int, str]:
    """The streams of ``path`` whose type the decoder does not read: id -> identifier."""
    return {sid: kind for sid, kind in stream_types(path).items() if kind not in KNOWN_TYPES}


def copy_without_streams(path: Path, drop: set[int], dest: Path) -> Path:
    """Write ``dest``: ``path`` without the streams ``drop`` (header nodes and packets);
    returns ``dest``. The file's layout must have passed ``check_layout`` first."""
    with open(path, "rb") as f:
        f.read(len(MAGIC))
        (header_len,) = struct.unpack("<I", f.read(4))
        compression, table_pos, info = _read_io_header(f.read(header_len), path)
        xml = _drop_nodes(info.decode("utf-8"), drop)
        header = _io_header_bytes(compression, xml.encode("utf-8"))
        end = table_pos if table_pos >= 0 else f.seek(0, 2)
        f.seek(len(MAGIC) + 4 + header_len)
        with open(dest, "wb") as out:
            out.write(MAGIC + struct.pack("<I", len(header)) + header)
            pos = f.tell()
            while pos + 8 <= end:
                head = f.read(8)
                stream_id, n_bytes = struct.unpack("<iI", head)
                if stream_id in drop:
                    f.seek(n_bytes, 1)
                else:
                    out.write(head)
                    _copy(f, out, n_bytes)
                pos += 8 + n_bytes
    return dest


def _copy(src, dst, n_bytes: int) -> None:
    while n_bytes > 0:
        block = src.read(min(n_bytes, _COPY_BLOCK))
        if not block:
            return
        dst.write(block)
        n_bytes -= len(block)


def _description(path: Path) -> ET.Element | None:
    try:
        with open(path, "rb") as f:
            if f.read(len(MAGIC)) != MAGIC:
                return None
            (header_len,) = struct.unpack("<I", f.read(4))
            header = f.read(min(header_len, 1 << 24))
        match = re.search(rb"<dv.*?</dv>", header, re.DOTALL)
        if match is None:
            return None
        return ET.fromstring(match.group(0).decode("utf-8", errors="replace"))
    except (OSError, struct.error, ET.ParseError):
        return None


def _stream_nodes(root: ET.Element) -> list[tuple[int, ET.Element]]:
    """(stream id, node) of each stream under ``outInfo``."""
    out_info = root.find("node[@name='outInfo']")
    if out_info is None:
        return []
    return [(int(n.get("name", "")), n) for n in out_info.findall("node")
            if (n.get("name") or "").isdigit()]


def _drop_nodes(xml: str, drop: set[int]) -> str:
    root = ET.fromstring(xml)
    out_info = root.find("node[@name='outInfo']")
    if out_info is not None:
        for sid, node in _stream_nodes(root):
            if sid in drop:
                out_info.remove(node)
    return ET.tostring(root, encoding="unicode")


def parse_io_header(buf: bytes) -> tuple[int, int, bytes]:
    """(compression, data table position or -1, XML description) from the header's IOHeader
    flatbuffer; struct.error or ValueError when an offset points outside it."""
    def get(fmt: str, at: int) -> int:
        if at < 0:
            raise ValueError(f"offset {at}")
        return struct.unpack_from(fmt, buf, at)[0]

    table = get("<I", 0)
    vtable = table - get("<i", table)
    vt_len = get("<H", vtable)

    def field(i: int) -> int:  # offset of field i in the table, 0 when absent
        at = 4 + 2 * i
        return get("<H", vtable + at) if at + 2 <= vt_len else 0

    compression = get("<i", table + field(0)) if field(0) else 0
    table_pos = get("<q", table + field(1)) if field(1) else -1
    if not field(2):
        raise ValueError("no XML description")
    text = table + field(2) + get("<I", table + field(2))
    length = get("<I", text)
    if text + 4 + length > len(buf):
        raise ValueError("XML description runs past the header")
    return compression, table_pos, buf[text + 4:text + 4 + length]


def _read_io_header(buf: bytes, path: Path) -> tuple[int, int, bytes]:

    try:
        return parse_io_header(buf)
    except (struct.error, ValueError):
        raise InputError("AEDAT4 file header is damaged (its IOHeader cannot be parsed)",
                         path=path) from None


def _io_header_bytes(compression: int, description: bytes) -> bytes:
    """An IOHeader flatbuffer: compression (int32), no data table (int64 -1) and the XML
    description (string).

    Layout: root offset (4 bytes), vtable at 4 (5 uint16: its size, the table's size and
    the three field offsets), 2 bytes padding, the table at 16 (int32 offset back to the
    vtable, compression, int64 position at 24, string offset at 32), the string at 36.
    """
    vtable = struct.pack("<5H", 10, 20, 4, 8, 16) + b"\0\0"
    table = struct.pack("<iiqI", 16 - 4, compression, -1, 4)
    text = struct.pack("<I", len(description)) + description + b"\0"
    text += b"\0" * (-len(text) % 4)
    return struct.pack("<I", 16) + vtable + table + text


__all__ = ["KNOWN_TYPES", "copy_without_streams", "stream_types", "unknown_streams"]
