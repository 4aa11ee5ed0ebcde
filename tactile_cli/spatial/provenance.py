"""Provenance of the spatial chain's outputs (PNG folders, JSON): what made them from what."""

from __future__ import annotations

import json
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from .._version import __version__
from ..store.writer import current_command, sha256_of, utc_now


def provenance(inputs: Sequence[str | Path], config: Mapping[str, Any]) -> dict[str, Any]:
    """``command``, ``tool_version``, ``created_utc``, ``config`` and each input's path,
    size and SHA-256."""
    return {
        "command": current_command(),
        "tool_name": "tactile-cli",
        "tool_version": __version__,
        "created_utc": utc_now(),
        "config": dict(config),
        "inputs": [{"path": str(p), "size_bytes": Path(p).stat().st_size,
                    "sha256": sha256_of(p)} for p in inputs],
    }


def png_meta(record: Mapping[str, Any]) -> dict[str, str]:
    """The PNG text chunks of a provenance record."""
    return {"Software": f"tactile-cli {record['tool_version']}",
            "Source": ", ".join(i["path"] for i in record["inputs"]),
            "Comment": record["command"]}


def write_json(path: str | Path, obj: Any) -> Path:
    """Write ``obj`` as indented JSON atomically (temporary file + rename)."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    try:
        tmp.write_text(json.dumps(obj, indent=2, allow_nan=False) + "\n", encoding="utf-8")
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path
