"""A minimal progress protocol, so library code can report progress without a UI dependency.

The CLI passes a rich-based implementation; notebooks and tests use :class:`NullProgress`.
"""

from __future__ import annotations

from typing import Protocol


class Progress(Protocol):
    def start(self, total: float, description: str) -> None:
        """Begin a task of ``total`` units (bytes, files or trials)."""

    def advance(self, amount: float = 1) -> None:
        """Report ``amount`` more units done."""

    def finish(self) -> None:
        """End the current task."""


class NullProgress:
    """A progress sink that shows nothing."""

    def start(self, total: float, description: str) -> None:
        pass

    def advance(self, amount: float = 1) -> None:
        pass

    def finish(self) -> None:
        pass
