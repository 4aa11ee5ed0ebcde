"""The one place CLI errors are printed: one line on stderr, exit code 2, no traceback."""

from __future__ import annotations

import signal
import sys
from collections.abc import Callable
from typing import NoReturn, TypeVar

from ..errors import TactileError

T = TypeVar("T")

EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130


def fail(message: str, code: int = EXIT_BAD_INPUT) -> NoReturn:
    print(f"tactile: error: {message}", file=sys.stderr)
    raise SystemExit(code)


class Terminated(BaseException):
    """Raised in the main thread on SIGTERM, so cleanup code runs as for Ctrl-C."""


def _on_sigterm(signum, frame) -> None:  # noqa: ARG001
    raise Terminated()


def run_guarded(func: Callable[[], T]) -> T:
    """Run a command body: library errors become one-line messages with exit code 2;
    Ctrl-C and SIGTERM unwind (temporary files are removed) and exit 130."""
    previous = signal.signal(signal.SIGTERM, _on_sigterm)
    try:
        return func()
    except TactileError as exc:
        fail(str(exc))
    except (KeyboardInterrupt, Terminated):
        fail("interrupted; no output was written and earlier outputs are intact", EXIT_INTERRUPTED)
    finally:
        signal.signal(signal.SIGTERM, previous)
