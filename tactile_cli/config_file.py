"""Read a YAML config file into (text, parsed value), with one-line errors.

Every config of the toolkit (train, scene, synth, grade, ROI, ingest mapping) is read the
same way: the text first (so a later validation error can name the key's line), then
``yaml.safe_load``. A missing or unreadable file, or text that is not YAML, is one
:class:`~tactile_cli.errors.InputError` naming the file and, for YAML, the line and column
of the problem and where the enclosing construct starts.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import yaml

from .errors import InputError


def read_config_text(path: str | Path, what: str = "config file") -> str:
    """The UTF-8 text of ``path``; ``what`` names the file in the error ("config file",
    "mapping file")."""
    path = Path(path)
    try:
        return path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputError(f"{what} not found", path=path) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read the {what} ({exc.__class__.__name__}: {exc})",
                         path=path) from None


def parse_yaml(text: str, path: str | Path) -> Any:
    """``yaml.safe_load(text)``; a syntax error is an InputError at its line and column."""
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = None if mark is None else f"line {mark.line + 1}, column {mark.column + 1}"
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        context, start = getattr(exc, "context", None), getattr(exc, "context_mark", None)
        if context and start is not None and mark is not None and start.line != mark.line:
            problem += f", {context} that starts at line {start.line + 1}"
        raise InputError(f"not valid YAML ({problem}); check the indentation and quoting there",
                         path=Path(path), where=where) from None


def key_line(text: str, keys: Sequence[Any], *, start: int | None = None,
             skip_missing: bool = False) -> int | None:
    """1-based line of the YAML node at ``keys`` (mapping keys, list indexes) in ``text``:
    the key's line for a mapping entry, the item's line for a list entry; for keys that are
    not all there, the line of the deepest one found (``start`` when none is).

    Keys match by their text, so a pydantic location's ``12`` finds the YAML key ``12``.
    ``skip_missing``: a key that is not in its mapping is passed over and the next one is
    looked up in the same mapping (for the tags pydantic inserts into union locations)
    instead of ending the walk. None when ``text`` is not YAML.
    """
    try:
        node = yaml.compose(text, Loader=yaml.SafeLoader)
    except yaml.YAMLError:
        return None
    line = start
    for part in keys:
        if isinstance(node, yaml.MappingNode):
            for key_node, value_node in node.value:
                if str(getattr(key_node, "value", None)) == str(part):
                    line, node = key_node.start_mark.line + 1, value_node
                    break
            else:
                if not skip_missing:
                    return line
        elif isinstance(node, yaml.SequenceNode) and isinstance(part, int):
            if part >= len(node.value):
                return line
            node = node.value[part]
            line = node.start_mark.line + 1
        elif not skip_missing:
            return line
    return line


def read_yaml(path: str | Path, what: str = "config file") -> tuple[str, Any]:
    """``(text, parsed)`` of a YAML file (see :func:`read_config_text`, :func:`parse_yaml`)."""
    text = read_config_text(path, what)
    return text, parse_yaml(text, path)


__all__ = ["key_line", "parse_yaml", "read_config_text", "read_yaml"]
