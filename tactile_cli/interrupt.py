"""Cooperative interruption: a signal marks a request; the writer stops at its next step.

A Python signal handler that raises does so in whatever code runs at that moment; when
that is a callback whose exceptions are ignored (a weakref or ``__del__`` during garbage
collection), the exception vanishes with a traceback on stderr. So the CLI's handler only
calls :func:`request`, and :class:`~tactile_cli.store.StoreWriter` calls
:func:`raise_if_requested` at every chunk, frame, stream, source block and before its
rename: an interrupted command stops within one step and never puts an output in place.
"""

from __future__ import annotations


class Interrupted(BaseException):
    """The user interrupted the command (Ctrl-C, SIGTERM)."""


_requested = False


def request() -> None:
    """Mark that the user asked to stop (called from a signal handler)."""
    global _requested
    _requested = True


def requested() -> bool:
    return _requested


def clear() -> None:
    global _requested
    _requested = False


def raise_if_requested() -> None:
    """Raise :class:`Interrupted` when a stop was requested."""
    if _requested:
        raise Interrupted()
