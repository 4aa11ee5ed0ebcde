"""Error types shared by the library and the CLI.

The library raises these; the CLI turns them into a one-line message on stderr and
exit code 2 (see :mod:`tactile_cli.cli._errors`). A message names the file and, where
it applies, the row or HDF5 path, the expected and the actual value, and what to do.

A message names the arguments of the library call in backticks, as a notebook user
writes them, and never a command-line flag of the current call::

    output exists; pass `overwrite=True` to replace it
    bin width 0.0015 ms is not a whole number of microseconds; pass e.g. `bin_s=0.02`
    `seed` (=-1) must be a non-negative integer

Each command gives :func:`tactile_cli.cli._errors.run_guarded` a table that spells those
arguments as its flags (``--overwrite``, ``--bin-ms 20``, ``--seed (=-1)``). Another
command to run is named whole, in backticks (``tactile ingest --annotations FILE``).
tests/test_errors.py keeps the library free of flags.
"""

from __future__ import annotations

import numbers
from pathlib import Path


class TactileError(Exception):
    """Base class of every error the toolkit raises on purpose."""


class InputError(TactileError):
    """Bad user input: a file, a row, an option or a config key.

    Parameters
    ----------
    message:
        What is wrong and what to do, without the location.
    path:
        The file (or folder) concerned, as the user gave it.
    where:
        Optional location inside it: ``"row 17"``, ``"/trials/t0/events/p"``.
    """

    def __init__(self, message: str, *, path: str | Path | None = None, where: str | None = None):
        self.message = message
        self.path = None if path is None else str(path)
        self.where = where
        super().__init__(self.__str__())

    def __str__(self) -> str:
        loc = ""
        if self.path is not None:
            loc = self.path if self.where is None else f"{self.path}, {self.where}"
            loc += ": "
        elif self.where is not None:
            loc = f"{self.where}: "
        return f"{loc}{self.message}"


class SchemaError(TactileError):
    """A file does not follow the tactile HDF5 schema (see ``tactile validate``)."""


def check_seed(seed: object) -> int:
    """``seed`` as an ``int``; an :class:`InputError` unless it is a non-negative integer
    (Python or numpy; a bool is refused). Every simulator takes its seed through this."""
    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or seed < 0:
        raise InputError(f"`seed` (={seed!r}) must be a non-negative integer")
    return int(seed)
