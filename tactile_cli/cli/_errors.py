"""The one place CLI errors are printed: one line on stderr, exit code 2, no traceback.

Library messages name Python arguments, never flags (a notebook user reads
``pass `overwrite=True` to replace it``); :func:`to_flags` turns those references into the
command line's spelling (``pass --overwrite to replace it``) with a table each command
gives :func:`run_guarded`. See :func:`to_flags` for the forms it rewrites.
"""

from __future__ import annotations

import errno
import re
import signal
import sys
import warnings
from collections.abc import Callable, Mapping
from typing import NoReturn, TypeAlias, TypeVar

from .. import interrupt
from ..errors import TactileError
from ..input_guard import input_scope
from ..interrupt import Interrupted
from ..store.atomic import remove_live_temporaries

T = TypeVar("T")

EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130

#: errno values of the machine's resources (disk, memory, processes, files, permissions)
#: that a command reports on one line instead of a traceback
RESOURCE_ERRNOS = {errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EPERM,
                   errno.ENOMEM, errno.EAGAIN, errno.EMFILE, errno.ENFILE, errno.EFBIG,
                   errno.EIO}


#: How a command line spells a library argument: the flag (``"--overwrite"``), or the flag
#: and a function that turns the Python value's text into the flag's (seconds to ms).
Flag: TypeAlias = str | tuple[str, Callable[[str], str]]

#: Arguments every command spells the same way; a command's own table is added to these.
COMMON_FLAGS: dict[str, Flag] = {"overwrite": "--overwrite"}

_REFERENCE = re.compile(
    r"`(?P<name>[A-Za-z_]\w*)(?:=(?P<value>[^`]+))?`(?P<shown> \(=(?P<shown_value>[^()]*)\))?"
)


def seconds_as_ms(value: str) -> str:
    """``"0.02"`` -> ``"20"``: a value in seconds as a ``--...-ms`` flag takes it."""
    return f"{float(value) * 1e3:g}"


def _unquoted(value: str) -> str:
    if len(value) >= 2 and value[0] == value[-1] and value[0] in "'\"":
        return value[1:-1]
    return value


def to_flags(message: str, flags: Mapping[str, Flag]) -> str:
    """``message`` with its references to the arguments in ``flags`` spelt as flags.

    A library message names an argument in backticks, in one of these forms, each
    rewritten when ``flags`` knows the name (other backticked words are left alone)::

        `overwrite=True`        ->  --overwrite           a switch
        `bin_s=0.02`            ->  --bin-ms 20           the value converted by the table
        `regions='detect'`      ->  --regions detect      Python string quotes dropped
        `seed`, `seed` (=-1)    ->  --seed, --seed (=-1)  a shown value converted too
    """

    def spell(m: re.Match[str]) -> str:
        flag = flags.get(m["name"])
        if flag is None:
            return m[0]
        name, convert = (flag, None) if isinstance(flag, str) else flag

        def value(text: str) -> str:
            text = _unquoted(text)
            if convert is None:
                return text
            try:
                return convert(text)
            except ValueError:  # not a number after all: show it as the library wrote it
                return text

        out = name if m["value"] in (None, "True") else f"{name} {value(m['value'])}"
        if m["shown"] is not None:
            shown = m["shown_value"] if convert is None else value(m["shown_value"])
            out += f" (={shown})"
        return out

    return _REFERENCE.sub(spell, message)


def command_flags() -> dict[str, str]:
    """The running command's options by their Python names, each with its long flag
    (``{"max_steps": "--max-steps"}``): a library argument named like the option it comes
    from is spelt without a table entry; empty outside a command."""
    from ._options import current_context

    ctx = current_context()
    if ctx is None:
        return {}
    return {p.name: longs[0] for p in ctx.command.params
            if p.param_type_name == "option" and p.name
            and (longs := [o for o in p.opts if o.startswith("--")])}


def spell(message: str, flags: Mapping[str, Flag] | None = None) -> str:
    """``message`` through :func:`to_flags` with the running command's table: its options
    (:func:`command_flags`), :data:`COMMON_FLAGS` and ``flags`` (the command's ``FLAGS``:
    library names that differ from the option's)."""
    return to_flags(message, {**command_flags(), **COMMON_FLAGS, **(flags or {})})


def fail(message: str, code: int = EXIT_BAD_INPUT) -> NoReturn:
    print(f"tactile: error: {message}", file=sys.stderr)
    raise SystemExit(code)


#: At most this many library warnings are printed after a command (the rest are counted).
MAX_WARNINGS_SHOWN = 5


def _warning_lines(caught: list[warnings.WarningMessage]) -> list[str]:
    """Each distinct warning on one line (``RuntimeWarning: invalid value ...``)."""
    lines: list[str] = []
    for w in caught:
        text = " ".join(str(w.message).split())
        line = f"{w.category.__name__}: {text}" if text else w.category.__name__
        if line not in lines:
            lines.append(line)
    return lines


def print_warnings(caught: list[warnings.WarningMessage]) -> None:
    """Library warnings of a successful command as ``tactile: warning: ...`` lines."""
    lines = _warning_lines(caught)
    for line in lines[:MAX_WARNINGS_SHOWN]:
        print(f"tactile: warning: {line}", file=sys.stderr)
    if len(lines) > MAX_WARNINGS_SHOWN:
        print(f"tactile: warning: ... and {len(lines) - MAX_WARNINGS_SHOWN} more",
              file=sys.stderr)


def _with_warnings(message: str, caught: list[warnings.WarningMessage]) -> str:
    """An error line with the first library warning raised before it, as its context."""
    lines = _warning_lines(caught)
    if not lines:
        return message
    more = f" and {len(lines) - 1} more" if len(lines) > 1 else ""
    return f"{message} (after the warning {lines[0]!r}{more})"


def _on_signal(signum, frame) -> None:  # noqa: ARG001
    # The first signal only marks the request: the writer stops at its next chunk, frame or
    # stream (raising here could land in a garbage-collection callback, which swallows it
    # and prints a traceback). A second signal stops at once.
    if interrupt.requested():
        raise Interrupted()
    interrupt.request()


def run_guarded(func: Callable[[], T], *, flags: Mapping[str, Flag] | None = None) -> T:
    """Run a command body: library errors become one-line messages with exit code 2;
    Ctrl-C and SIGTERM unwind (temporary files are removed) and exit 130.

    ``flags`` maps the library arguments this command's errors can name to its flags
    (``{"bin_s": ("--bin-ms", seconds_as_ms)}``) where the name is not the option's own
    (those are spelt from the command, :func:`command_flags`), on top of
    :data:`COMMON_FLAGS`; the message is printed through :func:`spell`, so the library says
    ``overwrite=True`` and the command line ``--overwrite``. Each command module keeps its
    table in ``FLAGS`` (tests/cli/test_errors.py checks that every flag there is an option of
    the command).
    An argument missing from the table is printed as the library wrote it (a Python name
    in backticks): less familiar on the command line, never wrong.

    Library warnings (numpy, pandas, h5py, torch) raised during the body are collected, never
    printed above an error: after success each distinct one is one ``tactile: warning:``
    line; on an error the first is added to the error line. The warning filters are left as
    they are (pytest's ``error`` filter still turns them into failures).
    """
    table = {**command_flags(), **COMMON_FLAGS, **(flags or {})}
    # SIGINT too: a KeyboardInterrupt that surfaced during interpreter shutdown would make
    # CPython exit by SIGINT instead of with code 130
    previous = {sig: signal.signal(sig, _on_signal) for sig in (signal.SIGINT, signal.SIGTERM)}
    interrupt.clear()
    with warnings.catch_warnings(record=True) as caught, input_scope():
        try:
            result = func()
        except TactileError as exc:
            remove_live_temporaries()
            fail(_with_warnings(to_flags(str(exc), table), caught))
        except (KeyboardInterrupt, Interrupted):
            remove_live_temporaries()
            fail("interrupted; no output was written and earlier outputs are intact",
                 EXIT_INTERRUPTED)
        except MemoryError:
            remove_live_temporaries()
            fail("out of memory; nothing was written (give smaller inputs or options that "
                 "ask for less: a shorter window, fewer channels, a coarser grid)")
        except RecursionError:
            remove_live_temporaries()
            fail("an input is nested too deeply to read; nothing was written")
        except OSError as exc:
            if exc.errno not in RESOURCE_ERRNOS:
                raise
            remove_live_temporaries()
            where = f"{exc.filename}: " if exc.filename else ""
            fail(f"{where}{exc.strerror or exc}; nothing was written")
        finally:
            for sig, handler in previous.items():
                signal.signal(sig, handler)
    print_warnings(caught)
    return result
