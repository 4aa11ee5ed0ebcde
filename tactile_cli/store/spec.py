"""The tactile HDF5 schema spec: loading it from the installed package and matching paths.

The spec lives in ``data_schemas/tactile-h5-v1.json`` and ships inside the package
(``tactile_cli/data_schemas``), loaded with :mod:`importlib.resources` so an installed
wheel finds it without the source tree.
"""

from __future__ import annotations

import functools
import json
import re
from dataclasses import dataclass, field
from importlib import resources
from typing import Any

SCHEMA_NAME = "tactile-h5"
SPEC_RESOURCE = "tactile-h5-v1.json"


@dataclass(frozen=True)
class NodeSpec:
    """One node of the layout: a group or dataset path pattern with its rules."""

    path: str
    type: str
    regex: re.Pattern[str]
    placeholders: tuple[str, ...]
    rules: dict[str, Any] = field(hash=False, compare=False)

    @property
    def parent_path(self) -> str:
        return self.path.rsplit("/", 1)[0] or "/"


@dataclass(frozen=True)
class Spec:
    """The parsed schema spec."""

    name: str
    version: str
    raw_json: str
    enums: dict[str, list[Any]]
    nodes: tuple[NodeSpec, ...]
    checks: tuple[dict[str, Any], ...]

    @property
    def major(self) -> int:
        return int(self.version.split(".")[0])

    @property
    def minor(self) -> int:
        return int(self.version.split(".")[1])

    def node(self, path: str) -> NodeSpec:
        """The node spec whose pattern is exactly ``path`` (e.g. ``/trials/{trial}``)."""
        for node in self.nodes:
            if node.path == path:
                return node
        raise KeyError(path)

    def match(self, h5_path: str) -> tuple[NodeSpec, dict[str, str]] | None:
        """The node spec matching a concrete HDF5 path, with its placeholder values."""
        for node in self.nodes:
            m = node.regex.fullmatch(h5_path)
            if m:
                return node, m.groupdict()
        return None


_PLACEHOLDER = re.compile(r"\{(\w+)\}")


def pattern_to_regex(pattern: str) -> tuple[re.Pattern[str], tuple[str, ...]]:
    """Turn ``/trials/{trial}/events`` into a regex with one named group per placeholder."""
    names = tuple(_PLACEHOLDER.findall(pattern))
    parts = _PLACEHOLDER.split(pattern)
    out = []
    for i, part in enumerate(parts):
        out.append(f"(?P<{part}>[^/]+)" if i % 2 else re.escape(part))
    return re.compile("".join(out)), names


def parse_spec(text: str) -> Spec:
    """Parse spec JSON text into a :class:`Spec`."""
    raw = json.loads(text)
    nodes = []
    for entry in raw["nodes"]:
        regex, names = pattern_to_regex(entry["path"])
        nodes.append(NodeSpec(entry["path"], entry["type"], regex, names, entry))
    return Spec(
        name=raw["schema_name"],
        version=raw["schema_version"],
        raw_json=text,
        enums=raw.get("enums", {}),
        nodes=tuple(nodes),
        checks=tuple(raw.get("checks", [])),
    )


@functools.cache
def load_spec() -> Spec:
    """The spec this version of the toolkit writes and validates against."""
    text = resources.files("tactile_cli").joinpath("data_schemas", SPEC_RESOURCE).read_text("utf-8")
    return parse_spec(text)
