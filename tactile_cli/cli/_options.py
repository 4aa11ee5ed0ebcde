"""Pieces every command shares on the way in: the parsing of option values and the one-line
report of a command line click refuses.

- :func:`finite_float_options`: every float option and argument of every command refuses
  ``nan``, ``inf`` and numbers that overflow a float (``1e400``) when the command line is
  parsed, naming the option (a NaN would pass every ``> 0`` check and poison the work).
- :func:`usage_error`: an unknown option, a bad value or a missing argument is one
  ``tactile: error:`` line on stderr with the help command to run, exit 2, like every other
  error of the toolkit.
- :func:`data_files`, :func:`runs_and_files`: the file lists of commands that take
  ``--data FILE...`` (a shell glob after ``--data``) and run folders mixed with files.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Annotated, Any

import typer

from ..errors import InputError

try:  # typer 0.2x carries its own copy of click's core
    from typer import _click as _click  # type: ignore[attr-defined]
except ImportError:  # pragma: no cover - older typer on plain click
    import click as _click  # type: ignore[no-redef]

#: The exceptions a command line raises while it is parsed.
ClickException = _click.exceptions.ClickException
BadParameter = _click.exceptions.BadParameter
NoArgsIsHelpError = getattr(_click.exceptions, "NoArgsIsHelpError", ())
Abort = typer.Abort

#: Exit code of a command line click refuses (click's own, and the toolkit's bad input).
EXIT_USAGE = 2


def _floats(value: Any) -> Iterator[float]:
    if isinstance(value, float):
        yield value
    elif isinstance(value, list | tuple):
        for v in value:
            yield from _floats(v)


def _checked(param: Any) -> Any:
    """``param.process_value`` that refuses a non-finite float (``nan``, ``inf``,
    ``1e400``) after the value is converted, naming the parameter."""
    convert = param.process_value

    def process_value(ctx: Any, value: Any) -> Any:
        out = convert(ctx, value)
        for v in _floats(out):
            if not math.isfinite(v):
                raise BadParameter(f"{v} is not a finite number", ctx=ctx, param=param)
        return out

    process_value.tactile_finite = True  # type: ignore[attr-defined]
    return process_value


def finite_float_options(command: Any) -> None:
    """Make every float option and argument of ``command`` and its subcommands refuse
    non-finite values when the command line is parsed (idempotent)."""
    for param in getattr(command, "params", []):
        if not getattr(param.process_value, "tactile_finite", False):
            param.process_value = _checked(param)
    for sub in getattr(command, "commands", {}).values():
        finite_float_options(sub)


def usage_error(exc: Any) -> int:
    """Print a refused command line as one line on stderr; returns the exit code."""
    message = " ".join(exc.format_message().split()).rstrip(".")
    ctx = getattr(exc, "ctx", None)
    where = ""
    hint = ""
    if ctx is not None and ctx.command_path:
        where = ctx.command_path.removeprefix("tactile").strip()
        hint = f"; see `{ctx.command_path} --help`"
    prefix = f"{where}: " if where else ""
    print(f"tactile: error: {prefix}{message}{hint}", file=sys.stderr)
    return exc.exit_code if exc.exit_code else EXIT_USAGE


def current_context() -> Any:
    """The click context of the command being run, or None outside one."""
    try:
        from typer._click.globals import get_current_context  # type: ignore[import-not-found]
    except ImportError:  # pragma: no cover - older typer on plain click
        from click import get_current_context
    return get_current_context(silent=True)


def data_files(data: list[Path] | None, ctx: typer.Context) -> list[Path]:
    """``--data`` values plus the files a shell glob put after it (``--data runs/*.h5``); a
    left-over argument that looks like an option is refused (for commands that allow extra
    arguments)."""
    for a in ctx.args:
        if a.startswith("-"):
            raise InputError(f"unknown option {a!r}; see --help")
    return [*(data or []), *(Path(a) for a in ctx.args)]


def runs_and_files(paths: list[Path], data: list[Path] | None) -> tuple[list[Path], list[Path]]:
    """Split positional paths into run folders and data files: a run is a folder, so a
    positional path that is a file is a data file (``--data a.h5 b.h5`` leaves ``b.h5``
    among the positional arguments)."""
    runs, files = [], list(data or [])
    for p in paths:
        (files if p.is_file() else runs).append(p)
    return runs, files


#: Options several commands share, spelt once (the simulators, the chain commands).
SceneConfigOption = Annotated[Path | None, typer.Option(
    "--config", "-c", help="Scene config YAML (see configs/scene_<scene>.yaml); default: the "
    "built-in defaults, which that file repeats.", metavar="CONFIG")]
SeedOption = Annotated[int, typer.Option(min=0, help="Random seed; fixes every output byte.")]
OverwriteOption = Annotated[bool, typer.Option(help="Replace an existing output (only once "
                                               "the new one is complete).")]
JsonOption = Annotated[bool, typer.Option("--json", help="Print the result as JSON.")]
#: ``--device auto|cpu|cuda`` of train, evaluate and sweep (``tactile_cli.learn.device``).
DeviceOption = Annotated[str, typer.Option(
    "--device", metavar="auto|cpu|cuda",
    help="Where networks train and predict: auto (a CUDA GPU when torch sees one, else the "
    "CPU), cpu or cuda. Recorded in the run; classic families always use the CPU.")]


__all__ = ["EXIT_USAGE", "Abort", "BadParameter", "ClickException", "DeviceOption", "JsonOption",
           "NoArgsIsHelpError", "OverwriteOption", "SceneConfigOption", "SeedOption",
           "current_context", "data_files", "finite_float_options", "runs_and_files", "usage_error"]
