"""Inputs are sacred: no output may be an input, contain one or lie inside one.

Two layers, both used by every writer of :mod:`tactile_cli.store`:

- :func:`check_outputs` is called by a library verb before any work, with the outputs it
  will write and the inputs it will read: one :class:`InputError` naming the output option
  and the input it would destroy.
- A scope (:func:`input_scope`, opened by the CLI around every command) collects each input
  as it is opened (:func:`note_input`: the trial reader, config and text readers, run
  folders and raw-format readers call it). Every atomic writer calls
  :func:`refuse_overlap` on its target when it starts and again just before it renames its
  result into place, so an output that names an input is refused even where a verb forgot
  to declare it, and never after the input was touched.

Paths are compared after resolving symlinks, ``.`` and ``..`` (and, for paths that exist,
by device and inode, which also catches hard links and case-insensitive file systems).
An input is a *file* (only the file itself is protected: a run folder's ``model.pt``, so
``RUN/eval/x`` may be written) or a *tree* (a recording folder: nothing may be written
anywhere inside it).
"""

from __future__ import annotations

import contextvars
import os
from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from .errors import InputError


@dataclass(frozen=True)
class _Input:
    path: Path  # resolved
    given: str  # as the user gave it
    tree: bool


_SCOPE: contextvars.ContextVar[list[_Input] | None] = contextvars.ContextVar(
    "tactile_input_scope", default=None)


def _resolved(path: str | Path) -> Path:
    return Path(os.path.realpath(os.path.expanduser(str(path))))


@contextmanager
def input_scope() -> Iterator[None]:
    """Collect the inputs noted inside the block (nested scopes share the outer one)."""
    if _SCOPE.get() is not None:
        yield
        return
    token = _SCOPE.set([])
    try:
        yield
    finally:
        _SCOPE.reset(token)


def note_input(path: str | Path, *, tree: bool | None = None) -> None:
    """Record ``path`` as an input of the current command (no-op outside a scope).
    ``tree``: protect everything inside it (default: whether ``path`` is a folder)."""
    inputs = _SCOPE.get()
    if inputs is None:
        return
    resolved = _resolved(path)
    is_tree = resolved.is_dir() if tree is None else tree
    entry = _Input(resolved, str(path), is_tree)
    if entry not in inputs:
        inputs.append(entry)


def noted_inputs() -> list[Path]:
    """The resolved inputs noted in the current scope (empty outside one)."""
    return [i.path for i in (_SCOPE.get() or [])]


def _same(a: Path, b: Path) -> bool:
    if a == b:
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def _inside(inner: Path, outer: Path) -> bool:
    """Whether ``inner`` lies strictly inside folder ``outer`` (resolved paths)."""
    if inner == outer:
        return False
    if outer in inner.parents:
        return True
    # case-insensitive file systems, hard-linked folders: walk up by inode
    for parent in inner.parents:
        if parent.exists() and _same(parent, outer):
            return True
    return False


def overlap(output: str | Path, inp: str | Path, *, tree: bool | None = None) -> str | None:
    """How writing ``output`` would touch input ``inp``: ``"is"``, ``"contains"``,
    ``"inside"`` (``inp`` is a tree), or None."""
    out, src = _resolved(output), _resolved(inp)
    is_tree = src.is_dir() if tree is None else tree
    if _same(out, src):
        return "is"
    if _inside(src, out):
        return "contains"
    if is_tree and _inside(out, src):
        return "inside"
    return None


_WORDS = {"is": "is the input", "contains": "contains the input",
          "inside": "lies inside the input folder"}


def _refusal(output: str | Path, given: str, how: str, option: str | None) -> InputError:
    what = f"{option} " if option else "output "
    return InputError(f"{what}{_WORDS[how]} {given}; the toolkit never overwrites or deletes "
                      "its inputs: give an output elsewhere", path=output)


def check_outputs(outputs: Mapping[str, str | Path | None] | Iterable[str | Path | None],
                  inputs: Iterable[str | Path | None], *, trees: Iterable[str | Path | None] = ()
                  ) -> None:
    """Refuse, with one :class:`InputError`, any output that is an input, contains one or
    (for ``trees``, and inputs that are folders) lies inside one. ``outputs``: the paths,
    or a mapping from the argument that names each (``"out"``, shown as ``out=...`` in the
    message) to its path. ``None`` entries are skipped (options not given). The inputs are
    noted in the current scope as well (see :func:`note_input`)."""
    named = (list(outputs.items()) if isinstance(outputs, Mapping)
             else [(None, o) for o in outputs])
    sources = [(p, None) for p in inputs if p is not None]
    sources += [(p, True) for p in trees if p is not None]
    for src, tree in sources:
        note_input(src, tree=tree)
    for name, out in named:
        if out is None:
            continue
        for src, tree in sources:
            how = overlap(out, src, tree=tree)
            if how is not None:
                raise _refusal(out, str(src), how, None if name is None else f"`{name}`")


def refuse_overlap(output: str | Path) -> None:
    """Refuse ``output`` if it overlaps an input noted in the current scope (every atomic
    writer calls this on its target)."""
    for entry in _SCOPE.get() or []:
        how = overlap(output, entry.path, tree=entry.tree)
        if how is not None:
            raise _refusal(output, entry.given, how, None)


__all__ = ["check_outputs", "input_scope", "note_input", "noted_inputs", "overlap",
           "refuse_overlap"]
