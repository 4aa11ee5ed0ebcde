"""The one table of input formats, and what is read from it: detection, options, help.

:data:`FORMATS` holds one :class:`~tactile_cli.ingest.contract.IngestFormat` per line, in
the order auto-detection tries them (the first format whose ``sniff`` says yes and that
takes every option given reads an input). ``tactile ingest`` (``format``, auto-detection),
``tactile info`` on raw recordings and the CLI's option help all read this table; a new
format is one module and one line here (see ARCHITECTURE.md, "A new input format").
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from ..errors import InputError
from .accel_tree import ACCEL_TREE
from .contract import CommonOptions, FormatOptions, IngestFormat
from .events_aedat4 import AEDAT4
from .events_table import EVENTS_CSV, EVENTS_NPY
from .image_sequence import IMAGES
from .mapped_csv import MAPPED_CSV
from .robot_bag import MCAP, ROSBAG
from .video import VIDEO

#: format name -> format, in the order auto-detection tries them
FORMATS: dict[str, IngestFormat[Any]] = {f.name: f for f in (
    AEDAT4,      # .aedat4 files (or the AEDAT4 magic bytes)
    EVENTS_NPY,  # .npy files (or the NumPy magic bytes)
    EVENTS_CSV,  # .csv files (a header t,x,y,p)
    ROSBAG,      # .bag files and ROS 2 bag folders (metadata.yaml)
    MCAP,        # .mcap files
    VIDEO,       # .mp4/.avi/.mov/.mkv files, or folders of them
    IMAGES,      # folders with PNG/JPG frames, or with subfolders of them
    ACCEL_TREE,  # folders <object>/<orientation>/<speed>/<file>.csv of 8 columns
    MAPPED_CSV,  # .csv/.tsv files and folders of CSVs; any input when `mapping` is given
)}

#: What ``format`` takes besides the names: detect the format from the inputs.
AUTO = "auto"


def get_format(name: str) -> IngestFormat[Any]:
    """The format called ``name``; InputError listing the names for an unknown one."""
    if name not in FORMATS:
        raise InputError(f"unknown format {name!r}; use one of: {', '.join(FORMATS)}")
    return FORMATS[name]


def formats_taking(option: str) -> list[str]:
    """The names of the formats whose options include ``option``, in table order."""
    return [f.name for f in FORMATS.values() if option in f.Options.model_fields]


def option_names() -> dict[str, list[str]]:
    """Every format option name -> the formats that take it (for help texts)."""
    out: dict[str, list[str]] = {}
    for f in FORMATS.values():
        for key in f.Options.model_fields:
            out.setdefault(key, []).append(f.name)
    return out


def _given(options: Mapping[str, Any] | FormatOptions | None) -> set[str]:
    """The option names a caller set (a mapping's keys, a model's fields set)."""
    if options is None:
        return set()
    if isinstance(options, FormatOptions):
        return set(options.model_fields_set)
    return set(options)


def _takes(fmt: IngestFormat[Any], options: Mapping[str, Any] | FormatOptions | None) -> bool:
    if isinstance(options, FormatOptions):
        return isinstance(options, fmt.Options)
    return _given(options) <= set(fmt.Options.model_fields)


def detect_format(inputs: Sequence[str | Path], *, format: str = AUTO,
                  options: Mapping[str, Any] | FormatOptions | None = None
                  ) -> IngestFormat[Any]:
    """The format of ``inputs``: ``format`` when it names one, else told from the inputs.

    Each input is sniffed by every format in table order; of those that say yes, the
    first that takes every option given (``options``: a mapping of option names, or an
    options model, which only its own formats take) reads it, else the first (whose
    options then name the option it does not take). An input no format sniffs is read by
    the format whose ``claim_option`` was given (a mapping says what a CSV table is).
    All inputs must come out as one format.
    """
    if format != AUTO:
        return get_format(format)
    given = _given(options)
    found: dict[str, list[Path]] = {}
    for raw in inputs:
        path = Path(raw)
        fmt = _detect_one(path, options, given)
        found.setdefault(fmt.name, []).append(path)
    if len(found) != 1:
        raise InputError(f"inputs mix formats ({', '.join(sorted(found))}); ingest each "
                         "format separately")
    return FORMATS[next(iter(found))]


def _detect_one(path: Path, options: Mapping[str, Any] | FormatOptions | None,
                given: set[str]) -> IngestFormat[Any]:
    sniffed = [f for f in FORMATS.values() if f.sniff(path)]
    taking = [f for f in sniffed if _takes(f, options)]
    if taking:
        return taking[0]
    if sniffed:
        return sniffed[0]
    claimed = [f for f in FORMATS.values() if f.claim_option in given and _takes(f, options)]
    if claimed:
        return claimed[0]
    if path.is_dir():
        raise InputError("cannot tell the format of a folder (no PNG/JPG frames in it or in its "
                         "subfolders); pass `format='accel-tree'`, `format='images'`, or "
                         f"`mapping='FILE.yaml'` (formats: {', '.join(FORMATS)})", path=path)
    suffixes = sorted({s for f in FORMATS.values() for s in f.suffixes})
    raise InputError(f"unknown format (suffix {path.suffix or 'none'!r}); tactile reads "
                     f"{', '.join(suffixes)} files and folders of frames or CSVs (with "
                     "`format` or `mapping`)", path=path)


def format_options(fmt: IngestFormat[Any],
                   values: Mapping[str, Any] | FormatOptions | None) -> FormatOptions:
    """The options model of ``fmt`` from ``values`` (a mapping of option names to values,
    or a model instance). An option the format does not take is one InputError naming it
    and the formats that take it; a value of the wrong type names the option and value."""
    if values is None:
        return fmt.Options()
    if isinstance(values, FormatOptions):
        if isinstance(values, fmt.Options):
            return values
        owners = [f.name for f in FORMATS.values() if isinstance(values, f.Options)]
        raise InputError(f"options {type(values).__name__} belong to the format(s) "
                         f"{', '.join(owners) or 'of no registered format'}, not to {fmt.name}; "
                         f"give `{fmt.Options.__name__}` options or a mapping of option names")
    for key in values:
        if key not in fmt.Options.model_fields:
            raise InputError(wrong_option(fmt, key))
    try:
        return fmt.Options(**values)
    except ValidationError as exc:
        err = exc.errors()[0]
        key = ".".join(str(p) for p in err["loc"]) or "options"
        msg = str(err["msg"]).removeprefix("Value error, ")
        raise InputError(f"`{key}` (={values.get(key, err.get('input'))}): {msg} (an option "
                         f"of {fmt.name})") from None


def wrong_option(fmt: IngestFormat[Any], key: str) -> str:
    """The message for an option ``fmt`` does not take: which formats take it, or, when
    none does, the options ``fmt`` has."""
    if key in CommonOptions.model_fields:
        return (f"`{key}` is an option every format shares, not an option of {fmt.name}: give "
                f"it to `ingest` itself (`{key}=...`), not in `options`")
    takers = formats_taking(key)
    if takers:
        return (f"`{key}` is not an option of the {fmt.title} format ({fmt.name}); formats "
                f"that take it: {', '.join(takers)}")
    own = ", ".join(f"`{k}`" for k in fmt.Options.model_fields) or "none"
    return f"`{key}` is not an option of any format; the options of {fmt.name}: {own}"


__all__ = ["AUTO", "FORMATS", "detect_format", "format_options", "formats_taking",
           "get_format", "option_names", "wrong_option"]
