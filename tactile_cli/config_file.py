"""Read a YAML config file into (text, parsed value), and any text file, with one-line errors.

Every config of the toolkit (train, scene, synth, grade, ROI, ingest mapping) is read the
same way: the text first (so a later validation error can name the key's line), then
``yaml.safe_load``. A missing or unreadable file, or text that is not YAML, is one
:class:`~tactile_cli.errors.InputError` naming the file and, for YAML, the line and column
of the problem and where the enclosing construct starts.

Text inputs that may not be text (CSV tables, timestamps, sidecars) are read as bytes and
decoded with :func:`decode_utf8`, so a stray byte is reported at its line and column
instead of as a ``UnicodeDecodeError``; :func:`missing_file_error` tells a missing file
from a broken symlink or a symlink loop.
"""

from __future__ import annotations

import errno
import os
import re
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import yaml

from .errors import InputError
from .input_guard import note_input


def missing_file_error(path: str | Path, what: str = "file") -> InputError:
    """The error for a ``path`` that cannot be opened because it is not there: "not found",
    or, when ``path`` is a symlink, "a symlink loop" or "a broken symlink" (``what``:
    "file", "config file")."""
    path = Path(path)
    try:
        path.resolve(strict=True)
    except RuntimeError:  # Python < 3.13 reports a loop this way
        return InputError(f"{what} is a symlink loop; point the link at a real file", path=path)
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            return InputError(f"{what} is a symlink loop; point the link at a real file",
                              path=path)
        if path.is_symlink():
            return InputError(f"{what} is a broken symlink (it points to "
                              f"{os.readlink(path)!r}, which does not exist)", path=path)
    return InputError(f"{what} not found", path=path)


def os_error(exc: OSError, path: str | Path, what: str = "file") -> InputError:
    """One-line :class:`InputError` for an ``OSError`` raised while opening or reading
    ``path``."""
    path = Path(path)
    if isinstance(exc, FileNotFoundError) or exc.errno == errno.ELOOP:
        return missing_file_error(path, what)
    if isinstance(exc, IsADirectoryError):
        return InputError(f"{what} is a folder; expected a file", path=path)
    if isinstance(exc, PermissionError):
        return InputError(f"cannot read the {what}: permission denied", path=path)
    reason = " ".join(str(exc.strerror or exc).split())
    return InputError(f"cannot read the {what} ({exc.__class__.__name__}: {reason})", path=path)


def decode_utf8(data: bytes, path: str | Path, *, first_line: int = 1,
                advice: str = "save the file as UTF-8") -> str:
    """``data`` (the bytes of ``path``, from its line ``first_line`` on) as text; a UTF-8 byte
    order mark at the start is dropped. A byte that is not UTF-8 is an :class:`InputError`
    naming its line and byte column: ``FILE, line 7: not UTF-8 text (byte 0xff at column 3);
    save the file as UTF-8`` (``advice`` is what to do)."""
    bom = 3 if first_line == 1 and data.startswith(b"\xef\xbb\xbf") else 0
    try:
        return data[bom:].decode("utf-8")
    except UnicodeDecodeError as exc:
        start = bom + exc.start
        line_start = data.rfind(b"\n", 0, start) + 1
        line = first_line + data.count(b"\n", 0, start)
        raise InputError(f"not UTF-8 text (byte 0x{data[start]:02x} at column "
                         f"{start - line_start + 1}); {advice}", path=Path(path),
                         where=f"line {line}") from None


def read_bytes(path: str | Path, what: str = "file") -> bytes:
    """The bytes of ``path``; a file that cannot be read is one :class:`InputError`."""
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise os_error(exc, path, what) from None
    note_input(path, tree=False)
    return data


def read_text(path: str | Path, what: str = "file", *,
              advice: str = "save the file as UTF-8") -> str:
    """The UTF-8 text of ``path`` (see :func:`read_bytes`, :func:`decode_utf8`)."""
    return decode_utf8(read_bytes(path, what), path, advice=advice)


def read_config_text(path: str | Path, what: str = "config file") -> str:
    """The UTF-8 text of ``path``; ``what`` names the file in the error ("config file",
    "mapping file")."""
    return read_text(path, what)


class _SafeLoader(yaml.SafeLoader):
    """PyYAML's safe loader that also reads ``9e-6`` and ``1e3`` as numbers.

    PyYAML follows YAML 1.1, whose floats need a dot (``9.0e-6``), so the ``9e-6`` people
    write for a pixel pitch came back as the string ``"9e-06"``; YAML 1.2 and every other
    parser read it as a float. Integers are still integers (their resolver comes first)."""


_SafeLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"))


#: Deepest nesting of lists and mappings a config, sidecar or JSON record may have. The
#: toolkit's own formats need fewer than 10 levels; a file nested thousands deep would
#: exhaust the parser's recursion (a traceback) or the checks that walk it.
MAX_NESTING = 64


def nesting_depth(value: Any) -> int:
    """Levels of lists, tuples and mappings in ``value`` (a scalar is 0), walked without
    recursion, stopping once past :data:`MAX_NESTING`."""
    deepest = 0
    # YAML anchors share one object between many places (a "billion laughs" file shares
    # each level ten times): a container is walked again only when reached deeper
    seen: dict[int, int] = {}
    stack = [(value, 1)]
    while stack:
        item, depth = stack.pop()
        if isinstance(item, Mapping):
            children = list(item.values())
        elif isinstance(item, list | tuple):
            children = list(item)
        else:
            continue
        if seen.get(id(item), 0) >= depth:
            continue
        seen[id(item)] = depth
        deepest = max(deepest, depth)
        if deepest > MAX_NESTING:
            break
        stack.extend((c, depth + 1) for c in children)
    return deepest


def check_nesting(value: Any, path: str | Path) -> Any:
    """``value`` if it is nested at most :data:`MAX_NESTING` deep; else an InputError."""
    if nesting_depth(value) > MAX_NESTING:
        raise InputError(f"is nested more than {MAX_NESTING} levels deep; no file of the "
                         "toolkit needs that many: check the file", path=Path(path))
    return value


def _too_deep(path: str | Path) -> InputError:
    return InputError(f"is nested more than {MAX_NESTING} levels deep (the parser ran out of "
                      "recursion); check the file", path=Path(path))


def parse_json(text: str, path: str | Path) -> Any:
    """``json.loads(text)`` bounded in nesting (:data:`MAX_NESTING`); text that is not JSON
    is an InputError at its line and column."""
    import json

    try:
        value = json.loads(text)
    except RecursionError:
        raise _too_deep(path) from None
    except json.JSONDecodeError as exc:
        raise InputError(f"not valid JSON ({exc.msg})", path=Path(path),
                         where=f"line {exc.lineno}, column {exc.colno}") from None
    return check_nesting(value, path)


def parse_yaml(text: str, path: str | Path) -> Any:
    """``yaml.safe_load(text)`` (with YAML 1.2's exponent floats, see :class:`_SafeLoader`),
    bounded in nesting (:data:`MAX_NESTING`); a syntax error is an InputError at its line
    and column."""
    try:
        return check_nesting(yaml.load(text, Loader=_SafeLoader), path)  # noqa: S506
    except RecursionError:
        raise _too_deep(path) from None
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


def machine_memory_bytes() -> int | None:
    """Physical memory of this machine in bytes (``/proc/meminfo`` MemTotal, else
    ``os.sysconf``); None when neither tells."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemTotal:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_PAGE_SIZE")) * int(os.sysconf("SC_PHYS_PAGES"))
    except (AttributeError, OSError, ValueError):
        return None


def format_bytes(n: float) -> str:
    """``8.0 TB``, ``24 GB``, ``512 MB``: decimal units, two significant digits."""
    for unit, size in (("EB", 1e18), ("PB", 1e15), ("TB", 1e12), ("GB", 1e9), ("MB", 1e6),
                       ("kB", 1e3)):
        if n >= size:
            return f"{n / size:.2g} {unit}" if n / size < 10 else f"{n / size:.0f} {unit}"
    return f"{n:.0f} B"


def check_fits_in_memory(needed_bytes: float, key: str, purpose: str, *,
                         path: str | Path | None, text: str | None, keys: Sequence[Any]) -> None:
    """Refuse a config whose sizes cannot fit: ``needed_bytes`` (an estimate, from the
    config alone) above this machine's physical memory is an :class:`InputError` at the line
    of ``keys``: ``train.yaml, line 12: `model.hidden` (=1000000000000) needs about 64 TB for
    its weights; this machine has 24 GB: make it smaller`` (``key``: "`model.hidden`
    (=1000000000000)", ``purpose``: "for its weights")."""
    memory = machine_memory_bytes()
    if memory is None or needed_bytes <= memory:
        return
    line = key_line(text, keys) if text else None
    raise InputError(f"{key} needs about {format_bytes(needed_bytes)} {purpose}; this machine "
                     f"has {format_bytes(memory)}: make it smaller", path=path,
                     where=None if line is None else f"line {line}")


def read_yaml(path: str | Path, what: str = "config file") -> tuple[str, Any]:
    """``(text, parsed)`` of a YAML file (see :func:`read_config_text`, :func:`parse_yaml`)."""
    text = read_config_text(path, what)
    return text, parse_yaml(text, path)


def describe_validation(err: Mapping[str, Any]) -> str:
    """Default wording of one pydantic error: ``unknown key `a.b` `` or ``` `a.b`: msg```."""
    key = ".".join(str(p) for p in err["loc"])
    msg = str(err["msg"]).removeprefix("Value error, ")
    if err["type"] == "extra_forbidden":
        return f"unknown key `{key}`"
    return f"`{key}`: {msg}" if key else msg


def describe_key_first(err: Mapping[str, Any]) -> str:
    """Wording of one pydantic error with the key first: `` `a.b`: unknown key `` or
    `` `a.b`: msg `` (loc parts that are not names or indices are left out)."""
    keys = tuple(k for k in err["loc"] if isinstance(k, str | int))
    shown = ".".join(str(k) for k in keys) or "(top level)"
    if err["type"] == "extra_forbidden":
        return f"`{shown}`: unknown key"
    return f"`{shown}`: {str(err['msg']).removeprefix('Value error, ')}"


def validation_error(exc: Any, text: str, path: str | Path, *,
                     describe: Callable[[dict[str, Any]], str] = describe_validation
                     ) -> InputError:
    """The one-line :class:`InputError` of a pydantic ``ValidationError`` of a YAML config:
    the error to show (an unknown key first, since a misspelt key also leaves the intended
    one at its default; else the deepest), worded by ``describe``, with the line of its key
    in ``text``."""
    err = max(exc.errors(), key=lambda e: (e["type"] == "extra_forbidden", len(e["loc"])))
    keys = tuple(part for part in err["loc"] if isinstance(part, str | int))
    line = key_line(text, keys) if keys else None
    return InputError(describe(err), path=path, where=None if line is None else f"line {line}")


__all__ = ["check_fits_in_memory", "decode_utf8", "describe_key_first", "describe_validation",
           "format_bytes",
           "key_line",
           "machine_memory_bytes", "missing_file_error", "os_error", "parse_yaml", "read_bytes",
           "read_config_text", "read_text", "read_yaml", "validation_error"]


def load_yaml_model(path: str | Path, model: Any, *, not_a_mapping: str,
                    empty: str | None = None, what: str = "config file",
                    describe: Callable[[dict[str, Any]], str] = describe_validation) -> Any:
    """Read the YAML mapping in ``path`` and validate it as ``model`` (a pydantic model
    class). Every problem is one :class:`InputError` naming the file: ``not_a_mapping`` for
    a document that is not a mapping, a pydantic error with its key and line (worded by
    ``describe``). An empty file gives the model's defaults, or the error ``empty``."""
    from pydantic import ValidationError

    path = Path(path)
    text, raw = read_yaml(path, what)
    if raw is None:
        if empty is not None:
            raise InputError(empty, path=path)
        raw = {}
    if not isinstance(raw, dict):
        raise InputError(not_a_mapping, path=path)
    try:
        return model.model_validate(raw)
    except ValidationError as exc:
        raise validation_error(exc, text, path, describe=describe) from None



def with_overrides(config: Any, overrides: Mapping[str, tuple[str, Any]]) -> Any:
    """A copy of the pydantic config ``config`` with ``overrides`` applied and validated
    like the file: argument name -> (dotted key, value), None values left out. A value
    the config refuses is one :class:`InputError` naming the argument and the value
    (``"`trials` (=0): Input should be greater than or equal to 1"``), so the CLI can spell
    it as its flag."""
    from pydantic import ValidationError

    data = config.model_dump()
    given = {arg: (key, value) for arg, (key, value) in overrides.items() if value is not None}
    for key, value in given.values():
        *parents, last = key.split(".")
        node = data
        for part in parents:
            node = node[part]
        node[last] = value
    try:
        return type(config).model_validate(data)
    except ValidationError as exc:
        err = exc.errors()[0]
        loc = ".".join(str(p) for p in err["loc"])
        msg = str(err["msg"]).removeprefix("Value error, ")
        for arg, (key, value) in given.items():
            if loc == key or loc.startswith(key + "."):
                shown = ",".join(map(str, value)) if isinstance(value, list | tuple) else value
                raise InputError(f"`{arg}` (={shown}): {msg}") from None
        raise InputError(describe_validation(err)) from None
