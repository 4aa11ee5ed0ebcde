"""Provenance of every output: the command line, the time, the tool version and each
input's path, size and SHA-256.

One builder, :func:`provenance_record`, for every output that is not a tactile HDF5 file
(JSON results, run folders, figures, configs); :class:`~tactile_cli.store.StoreWriter`
writes the same facts as attributes of the files it makes. Modules that need only the
command, a hash or the time import them from here, not from the writer.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import shlex
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from .._version import __version__
from ..interrupt import raise_if_requested

TOOL_NAME = "tactile-cli"


def utc_now() -> str:
    """The current UTC time, ISO 8601 to the second (``2026-11-27T19:17:02+00:00``)."""
    return _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")


def current_command() -> str:
    """The command line of this process, shell-quoted (recorded as provenance)."""
    argv = list(sys.argv)
    if argv and argv[0].endswith(("tactile", "__main__.py")):
        argv[0] = "tactile"
    return " ".join(shlex.quote(a) for a in argv)


def sha256_of(path: str | Path, *, block: int = 1 << 22) -> str:
    """The SHA-256 of a file's bytes, read in blocks (an interrupt is honoured between
    blocks)."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while chunk := f.read(block):
            raise_if_requested()
            h.update(chunk)
    return h.hexdigest()


def source_record(path: str | Path) -> dict[str, Any]:
    """``{"path", "size_bytes", "sha256"}`` of one input file (the path as given)."""
    p = Path(path)
    return {"path": str(path), "size_bytes": p.stat().st_size, "sha256": sha256_of(p)}


def provenance_record(inputs: Sequence[str | Path], config: Mapping[str, Any] | None = None,
                      *, command: str | None = None) -> dict[str, Any]:
    """What made an output from what: ``command`` (this process's, unless given),
    ``tool_name``, ``tool_version``, ``created_utc``, ``config`` and each input's
    :func:`source_record` (inputs that are folders are listed by path only)."""
    records = []
    for p in inputs:
        records.append({"path": str(p)} if Path(p).is_dir() else source_record(p))
    return {
        "command": current_command() if command is None else command,
        "tool_name": TOOL_NAME,
        "tool_version": __version__,
        "created_utc": utc_now(),
        "config": dict(config or {}),
        "inputs": records,
    }


def png_meta(record: Mapping[str, Any]) -> dict[str, str]:
    """The PNG text chunks (``Software``, ``Source``, ``Comment``) of a provenance record."""
    return {"Software": f"{TOOL_NAME} {record['tool_version']}",
            "Source": ", ".join(i["path"] for i in record["inputs"]),
            "Comment": record["command"]}


__all__ = ["TOOL_NAME", "current_command", "png_meta", "provenance_record", "sha256_of",
           "source_record", "utc_now"]
