"""The one place CLI errors are printed: one line on stderr, exit code 2, no traceback."""

from __future__ import annotations

import signal
import sys
from collections.abc import Callable
from typing import NoReturn, TypeVar

from .. import interrupt
from ..errors import TactileError
from ..interrupt import Interrupted
from ..store.writer import remove_live_temporaries

T = TypeVar("T")

EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130


def fail(message: str, code: int = EXIT_BAD_INPUT) -> NoReturn:
    print(f"tactile: error: {message}", file=sys.stderr)
    raise SystemExit(code)


def _on_signal(signum, frame) -> None:  # noqa: ARG001
    # The first signal only marks the request: the writer stops at its next chunk, frame or
    # stream (raising here could land in a garbage-collection callback, which swallows it
    # and prints a traceback). A second signal stops at once.
    if interrupt.requested():
        raise Interrupted()
    interrupt.request()


def run_guarded(func: Callable[[], T]) -> T:
    """Run a command body: library errors become one-line messages with exit code 2;
    Ctrl-C and SIGTERM unwind (temporary files are removed) and exit 130."""
    # SIGINT too: a KeyboardInterrupt that surfaced during interpreter shutdown would make
    # CPython exit by SIGINT instead of with code 130
    previous = {sig: signal.signal(sig, _on_signal) for sig in (signal.SIGINT, signal.SIGTERM)}
    interrupt.clear()
    try:
        return func()
    except TactileError as exc:
        remove_live_temporaries()
        fail(str(exc))
    except (KeyboardInterrupt, Interrupted):
        remove_live_temporaries()
        fail("interrupted; no output was written and earlier outputs are intact", EXIT_INTERRUPTED)
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
