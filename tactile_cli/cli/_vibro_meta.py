"""Provenance of the active-vibration chain's figures: PNG text chunks naming the command,
the tool version, the inputs (with SHA-256) and the config."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .._version import __version__
from ..store.provenance import current_command, sha256_of


def png_meta(inputs: Sequence[Path], config: dict[str, Any]) -> dict[str, str]:
    """PNG metadata: Software, Command, Source (path and SHA-256 of each input), Config."""
    sources = [f"{p} sha256:{sha256_of(p)}" for p in inputs if Path(p).is_file()]
    return {"Software": f"tactile-cli {__version__}", "Command": current_command(),
            "Source": "; ".join(sources), "Comment": json.dumps(config, sort_keys=True)}
