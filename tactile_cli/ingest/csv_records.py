"""Records of a CSV text with standard quoting (RFC 4180), each with the line it starts on.

Every CSV that ingest reads honours quoting the same way: a field in double quotes may hold
the delimiter, a doubled quote (``""`` for ``"``) and line breaks, so one record can span
several lines. A malformed quote (``"ab"c``, a quote never closed) is an
:class:`~tactile_cli.errors.InputError` naming the file and the line where the record
starts. Numeric tables without any quote character take a faster path in
:func:`~tactile_cli.ingest.mapped_csv.read_csv_table` and never come here.
"""

from __future__ import annotations

import csv
import io
from collections.abc import Iterator
from pathlib import Path
from typing import BinaryIO

from ..config_file import decode_utf8
from ..errors import InputError

#: The quote character of every CSV ingest reads.
QUOTE = '"'
QUOTE_BYTE = ord(QUOTE)


def csv_records(text: str, path: Path, *, delimiter: str = ",") -> Iterator[tuple[int, list[str]]]:
    """``(line, cells)`` of every record of ``text``: the 1-based line the record starts on
    and its fields, unquoted. A blank line is a record with no cells."""
    reader = csv.reader(io.StringIO(text, newline=""), delimiter=delimiter, quotechar=QUOTE,
                        doublequote=True, strict=True)
    start = 1
    try:
        for cells in reader:
            yield start, cells
            start = reader.line_num + 1
    except csv.Error as exc:
        raise InputError(f"not valid CSV ({exc}); a field that holds the delimiter, a quote or "
                         "a line break must be quoted, with quotes inside it doubled (\"\")",
                         path=path, where=f"line {start}") from None


def first_record(f: BinaryIO) -> bytes:
    """The bytes of the first record of an open binary file: its first line, and the lines
    after it while a quoted field is still open (an odd number of quotes so far)."""
    data = f.readline()
    while data.count(QUOTE_BYTE) % 2:
        more = f.readline()
        if not more:
            break
        data += more
    return data


def record_cells(data: bytes, path: Path, *, delimiter: str = ",") -> list[str]:
    """The fields of one record given as bytes (a header line, say), unquoted."""
    text = decode_utf8(data, path).rstrip("\r\n")
    if QUOTE not in text:  # the common case: plain names
        return text.split(delimiter)
    for _, cells in csv_records(text, path, delimiter=delimiter):
        return cells
    return []


__all__ = ["QUOTE", "csv_records", "first_record", "record_cells"]
