"""The YAML mapping file of ``tactile ingest --mapping``: how sensor CSVs become trials and streams.

A mapping says, for any sampled-signal CSV recording, which files make up a trial, which
columns are time, channels and labels, the rate, the units and the sensor kind, so a new
sensor needs a YAML file rather than code. ``configs/mapping_example.yaml`` documents every
key with an example; ``configs/xela_slip.yaml`` and ``configs/biotac_slide20.yaml`` are
worked examples for two real datasets. In brief::

    version: 1
    trials:                 # which paths are trials, and their labels
      layout: file          # file: one trial per CSV; folder: one trial per folder
      glob: "**/*.csv"
      pattern: '(?P<object>[a-z]+)_(?P<rep>\\d+)\\.csv$'   # named groups -> trial labels
      labels: {setup: bench}                               # constant trial labels
    csv: {delimiter: ",", header: true}                    # default dialect of every file
    files: {"{object}_{rep}.csv": {trailing_delimiter: true}}   # per-file dialect overrides
    streams:
      - name: taxels
        file: "{object}_{rep}.csv"   # template: regex groups and {stem}
        kind: taxel_array
        channels: ["p_*"]            # names or glob patterns, in file order
        units: kPa                   # one unit, or {glob: unit}
        time: {column: t, unit: s}   # or {sample_rate_hz: 100} or {rate_from: {file, column}}
                                     # stamps: refuse | drop_repeats | keep_last | spread
        sample_labels:
          - {name: slip, column: state, classes: [stick, slip]}

The model is validated as a whole before any CSV is read: unknown keys are errors (every
model forbids extra keys), and :func:`load_mapping` turns any problem into one
:class:`~tactile_cli.errors.InputError` naming the mapping file, the line and the key.
Checks that need the CSV headers (a named column that does not exist) run in the ingest's
planning pass, before any data are written.
"""

from __future__ import annotations

import re
import string
from pathlib import Path
from typing import Any, Literal, get_origin

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from ..config_file import key_line, read_yaml
from ..errors import InputError
from ..store.spec import load_spec
from .stamps import StampPolicy

#: Time-column units and their length in seconds.
TIME_UNITS_S: dict[str, float] = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
#: Template field available in every file and name template besides the regex groups:
#: the matched trial file's stem, or the trial folder's name.
STEM_FIELD = "stem"
#: Template field of the trial name with ``layout: rows``, ``rows_are: trials``: the data
#: row's number in its table (1-based).
ROW_FIELD = "row"


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", use_attribute_docstrings=True, frozen=True)


class CsvDialect(_Model):
    """How a CSV file is split into rows and columns.

    Standard CSV quoting is honoured: a field in double quotes may hold the delimiter,
    doubled quotes (``""``) and line breaks (``notes: "slipped, regrasped"``). Every row is
    checked to hold exactly as many fields as the header before parsing.
    """

    delimiter: str = Field(default=",", min_length=1, max_length=1)
    """The one-character field separator."""
    header: bool = True
    """Whether the first line holds the column names."""
    column_names: list[str] | None = None
    """The column names when the file has no header line (required then), in file order."""
    trailing_delimiter: bool = False
    """Every data row ends with one extra delimiter (an empty last field), as BioTac rows
    do; without this a reader shifts every column by one. The header may or may not end
    with the delimiter."""

    @model_validator(mode="after")
    def _names_when_headerless(self) -> CsvDialect:
        if not self.header and not self.column_names:
            raise ValueError("a file without a header needs `column_names` "
                             "(the names in file order)")
        if self.header and self.column_names is not None:
            raise ValueError("give `column_names` only with `header: false`; with a header "
                             "the names come from the file")
        if self.column_names is not None and len(set(self.column_names)) != len(self.column_names):
            raise ValueError("`column_names` has duplicates")
        return self


class CsvDialectOverride(_Model):
    """Per-file changes to the default ``csv`` dialect; keys left out keep the default."""

    delimiter: str | None = Field(default=None, min_length=1, max_length=1)
    """The one-character field separator."""
    header: bool | None = None
    """Whether the first line holds the column names."""
    column_names: list[str] | None = None
    """The column names when the file has no header line, in file order."""
    trailing_delimiter: bool | None = None
    """Every data row ends with one extra delimiter (an empty last field)."""


class TrialLayout(_Model):
    """Which paths under each input are trials, and the labels every trial gets."""

    layout: Literal["file", "folder", "rows"]
    """``file``: each file matching ``glob`` is one trial (its sibling files named by the
    stream templates belong to it). ``folder``: each folder matching ``glob`` is one trial,
    the stream files are inside it, and files that share a time base are joined row by row
    (they must have equal row counts). ``rows``: each file matching ``glob`` is a table
    whose rows are trials (``rows_are: trials``: one trial per row, each stream one sample
    at t = 0) or the samples of one trial (``rows_are: samples``), with trial labels read
    from ``label_columns`` and ``group``."""
    glob: str
    """Glob of trial files or folders under each input folder (``**`` recurses), e.g.
    ``"**/*_bio.csv"`` or ``"data_sample_*"``. An input file is itself a trial (file
    layout); an input folder with no match that holds the stream files is itself a trial
    (folder layout)."""
    pattern: str | None = None
    """Regular expression searched in the trial's path (as given plus as found, with ``/``
    separators). Its named groups become trial labels (text) and template fields; a trial
    path it does not match is an error."""
    name: str | None = None
    """Template of the trial name from the regex groups and ``{stem}``; default the file
    stem (file layout) or the folder name (folder layout)."""
    labels: dict[str, str | int | float] = Field(default_factory=dict)
    """Constant labels of every trial, e.g. ``{dataset: biotac_slide20}``."""
    rows_are: Literal["trials", "samples"] = "trials"
    """``layout: rows`` only. ``trials``: every row of the table is one trial (grasp
    outcome tables: one row per grasp); ``samples``: the whole table is one trial whose rows
    are its samples (then ``label_columns`` and ``group`` must hold one value per table)."""
    label_columns: list[str] = Field(default_factory=list)
    """``layout: rows`` only. Columns of the table stored as trial labels under their own
    names (numbers as numbers, text as text; an empty cell is an error), e.g. ``[slipped]``."""
    group: str | None = None
    """``layout: rows`` only. The column naming the group a row belongs to (the object
    grasped, the subject), stored as a trial label of that name, so that
    ``data.split: {mode: group, by: <column>}`` keeps a group's trials together."""

    @model_validator(mode="after")
    def _rows_keys(self) -> TrialLayout:
        if self.layout != "rows":
            given = sorted({"rows_are", "label_columns", "group"} & self.model_fields_set)
            if given:
                raise ValueError(f"{', '.join(f'`{k}`' for k in given)} belong to "
                                 "`layout: rows`; leave them out with `layout: "
                                 f"{self.layout}`")
            return self
        columns = [*self.label_columns, *([self.group] if self.group else [])]
        dup = sorted({c for c in columns if columns.count(c) > 1})
        if dup:
            raise ValueError(f"column {dup[0]!r} is named twice in `label_columns`/`group`")
        return self

    @property
    def row_trials(self) -> bool:
        """Whether every table row is one trial (``layout: rows``, ``rows_are: trials``)."""
        return self.layout == "rows" and self.rows_are == "trials"

    @property
    def label_column_names(self) -> list[str]:
        """The table columns read as trial labels: ``label_columns`` and ``group``."""
        return [*self.label_columns, *([self.group] if self.group else [])]

    @field_validator("pattern")
    @classmethod
    def _compiles(cls, value: str | None) -> str | None:
        if value is not None:
            try:
                re.compile(value)
            except re.error as exc:
                raise ValueError(f"not a valid regular expression ({exc})") from None
        return value

    def fields(self, *, per_row: bool = False) -> set[str]:
        """Template fields a file template may use; ``per_row``: those of the trial ``name``,
        which with ``rows_are: trials`` may also use ``{row}`` (1-based data row) and the
        label columns."""
        groups = set(re.compile(self.pattern).groupindex) if self.pattern else set()
        if per_row and self.row_trials:
            groups |= {ROW_FIELD, *(c for c in self.label_column_names if c.isidentifier())}
        return groups | {STEM_FIELD}


class ValueFrom(_Model):
    """One number read from a column of a one-row file (e.g. Xela ``meta_data.csv``)."""

    file: str
    """Template of the file name, relative to the trial folder."""
    column: str
    """The column holding the value; the file must have exactly one data row."""


class TimeBase(_Model):
    """A stream's time base: a time column, a fixed rate, or a rate read from a file.

    With ``column`` the times come from that column (seconds = value x ``scale_s``) and
    ``sample_rate_hz``/``rate_from`` only give the nominal rate; without it the samples
    are evenly spaced from 0 at that rate. Times are stored in seconds from the trial's
    first sample: the earliest first time of all the trial's column-timed streams (they
    share one clock); evenly spaced streams start at 0. A time column's repeated and
    out-of-order stamps are refused unless ``stamps`` names a policy for them.
    """

    column: str | None = None
    """The time column."""
    file: str | None = None
    """Template of the file holding ``column`` when it is not the stream's own file; the
    two files are joined row by row (equal row counts), e.g. Xela ``robot_state.csv``."""
    unit: Literal["s", "ms", "us", "ns"] = "s"
    """Unit of the time column."""
    scale_s: float | None = Field(default=None, gt=0)
    """Seconds per time-column unit, for clocks no ``unit`` names (e.g. 3.0517578125e-05
    for 32768 Hz ticks); replaces ``unit``."""
    epoch: bool = False
    """The time column holds Unix time; the trial then records its origin in the
    attribute ``time_origin_unix_s`` (seconds)."""
    sample_rate_hz: float | None = Field(default=None, gt=0)
    """A fixed sampling rate in Hz (before any unroll)."""
    rate_from: ValueFrom | None = None
    """Read the rate in Hz per trial from a file (before any unroll)."""
    stamps: StampPolicy = "refuse"
    """What to do with rows whose stamp repeats the latest one or is earlier than it
    (loggers that stamp in whole ms, or hold a sample): ``refuse`` (stop with the file and
    line), ``drop_repeats`` (keep the first row of each stamp), ``keep_last`` (keep the last
    row written before the clock moves on, at that stamp) or ``spread`` (keep every row and
    spread the rows of one stamp evenly towards the next stamp). The ingest says per trial
    how many it met (a note, and the stream attributes ``stamps_repeated`` and
    ``stamps_out_of_order``)."""

    @model_validator(mode="after")
    def _one_source(self) -> TimeBase:
        if self.sample_rate_hz is not None and self.rate_from is not None:
            raise ValueError("give either `sample_rate_hz` or `rate_from`, not both")
        if self.column is None and self.sample_rate_hz is None and self.rate_from is None:
            raise ValueError("give a time `column`, a `sample_rate_hz` or a `rate_from`")
        about_column = (self.file is not None or self.epoch or self.scale_s is not None
                        or self.stamps != "refuse")
        if self.column is None and about_column:
            raise ValueError("`file`, `epoch`, `scale_s` and `stamps` describe a time "
                             "`column`; give `column` too")
        return self

    @property
    def seconds_per_unit(self) -> float:
        """Seconds per time-column unit."""
        return self.scale_s if self.scale_s is not None else TIME_UNITS_S[self.unit]


class Unroll(_Model):
    """Rows that hold several consecutive samples of one channel (BioTac ``pac1..pac22``).

    The stream's m channels of row i become samples ``m*i .. m*i+m-1`` of one channel,
    at m times the row rate. Their times are spread evenly from the row's time to the next
    row's time (the last row repeats the previous interval), i.e. the row time is taken
    to be the time of its first sample.
    """

    channel: str
    """Name of the one output channel."""


class SampleLabel(_Model):
    """A per-sample label read from a column (of the stream's file or a row-joined file)."""

    name: str
    """Label name in the output (``sample_labels/<name>``)."""
    column: str
    """The column holding the label."""
    file: str | None = None
    """Template of the file holding ``column`` when it is not the stream's own file; the
    files are joined row by row (equal row counts), e.g. Xela ``slip_label.csv``."""
    classes: list[str] | None = None
    """Class names of a categorical label; the column holds either their index codes
    (0, 1, ... also written as 0.0, 1.0) or the class names as text. Stored as integer
    codes with a ``classes`` attribute. Without ``classes`` the label is numeric (float)."""

    @field_validator("classes")
    @classmethod
    def _unique(cls, value: list[str] | None) -> list[str] | None:
        if value is not None and (not value or len(set(value)) != len(value)):
            raise ValueError("`classes` must be a non-empty list of distinct names")
        return value


class Stream(_Model):
    """One sampled stream of a trial: some columns of one file, with a time base."""

    name: str
    """Stream name (``/trials/<trial>/signals/<name>``)."""
    file: str
    """Template of the file name, relative to the trial folder (file layout: the matched
    file's folder), e.g. ``"{material}_{sample}_cw.csv"`` or ``"xela_sensor1.csv"``."""
    sensor: str | None = None
    """Sensor group name (``/sensors/<sensor>``); default the stream name. Each stream has
    its own sensor, since a sensor group carries one rate and one channel list."""
    kind: str
    """Sensor kind, one of the schema's ``sensor_kind`` values (taxel_array, pressure, ...)."""
    description: str = ""
    """Free text stored with the sensor."""
    channels: list[str] = Field(min_length=1)
    """Channel columns in output order: exact names or glob patterns (``"txl*_*"``); a
    pattern adds its matches in file order. Columns not listed are not read (use this to
    leave out columns that are all ``-nan``)."""
    channel_names: list[str] | None = None
    """Output channel names, one per selected column; default the column names."""
    units: str | dict[str, str]
    """One unit for every channel, or ``{glob: unit}`` matched against the output channel
    names (first match wins; every channel must match)."""
    time: TimeBase | None = None
    """The time base; required except with ``layout: rows``, ``rows_are: trials``, where
    each trial's one sample is at t = 0 and ``time`` is left out."""
    unroll: Unroll | None = None
    """Treat the channels of a row as consecutive samples of one channel."""
    sample_labels: list[SampleLabel] = Field(default_factory=list)
    """Per-sample labels."""

    @field_validator("kind")
    @classmethod
    def _known_kind(cls, value: str) -> str:
        kinds = load_spec().enums["sensor_kind"]
        if value not in kinds:
            raise ValueError(f"unknown sensor kind {value!r}; use one of: {', '.join(kinds)}")
        if value == "event_camera" or value == "visuotactile":
            raise ValueError(f"kind {value!r} is not a sampled-signal sensor; mapped CSVs hold "
                             "sampled signals (events and images have their own formats)")
        return value

    @model_validator(mode="after")
    def _consistent(self) -> Stream:
        if self.unroll is not None and self.channel_names is not None:
            raise ValueError("`unroll.channel` names the one output channel; "
                             "leave out `channel_names`")
        names = [lab.name for lab in self.sample_labels]
        if len(set(names)) != len(names):
            raise ValueError("sample label names must be distinct")
        renamed = self.channel_names
        if renamed is not None and len(set(renamed)) != len(renamed):
            raise ValueError("`channel_names` has duplicates")
        return self

    @property
    def sensor_name(self) -> str:
        """The sensor group name."""
        return self.sensor or self.name

    def templates(self) -> list[tuple[str, str]]:
        """Every file template the stream reads, with the mapping key that names it."""
        out = [(self.file, "file")]
        if self.time is not None and self.time.file is not None:
            out.append((self.time.file, "time.file"))
        if self.time is not None and self.time.rate_from is not None:
            out.append((self.time.rate_from.file, "time.rate_from.file"))
        out += [(lab.file, f"sample_labels.{lab.name}.file") for lab in self.sample_labels
                if lab.file is not None]
        return out


class CsvMapping(_Model):
    """A whole mapping file: trial layout, CSV dialect and streams."""

    version: Literal[1] = 1
    """Version of the mapping format."""
    trials: TrialLayout
    """Which paths are trials and their labels."""
    csv: CsvDialect = Field(default_factory=CsvDialect)
    """The default dialect of every file."""
    files: dict[str, CsvDialectOverride] = Field(default_factory=dict)
    """Dialect overrides keyed by a file template exactly as the streams write it."""
    streams: list[Stream] = Field(min_length=1)
    """The streams of each trial."""

    @model_validator(mode="after")
    def _cross_checks(self) -> CsvMapping:
        for what, values in (("stream names", [s.name for s in self.streams]),
                             ("sensor names", [s.sensor_name for s in self.streams])):
            dup = sorted({v for v in values if values.count(v) > 1})
            if dup:
                raise ValueError(f"{what} must be distinct (repeated: {', '.join(dup)})")
        self._check_time_bases()
        templates = [(self.trials.name, "trials.name")] if self.trials.name else []
        for s in self.streams:
            templates += [(t, f"streams.{s.name}.{key}") for t, key in s.templates()]
        for template, key in templates:
            used = _template_fields(template, key)
            fields = self.trials.fields(per_row=key == "trials.name")
            unknown = sorted(used - fields)
            if unknown:
                raise ValueError(f"`{key}` ({template!r}) uses {', '.join(unknown)}, which the "
                                 f"trial `pattern` does not define (available: "
                                 f"{', '.join(sorted(fields))})")
        used_templates = {t for t, _ in templates}
        extra = sorted(set(self.files) - used_templates)
        if extra:
            raise ValueError(f"`files` has {', '.join(map(repr, extra))}, which no stream reads; "
                             "keys must equal a stream's file template")
        epochs = {s.time.epoch for s in self.streams
                  if s.time is not None and s.time.column is not None}
        if len(epochs) > 1:
            raise ValueError("time columns of one trial share one clock: set `epoch: true` on "
                             "all of them or on none")
        for s in self.streams:
            self.dialect(s.file)  # a header-less override without names fails here
        return self

    def _check_time_bases(self) -> None:
        """``time`` is left out exactly when every row is a trial (one sample at t = 0)."""
        for s in self.streams:
            if self.trials.row_trials:
                if s.time is not None or s.unroll is not None:
                    key = "time" if s.time is not None else "unroll"
                    raise ValueError(f"`streams.{s.name}.{key}`: with `layout: rows` and "
                                     "`rows_are: trials` each row is one sample at t = 0; "
                                     f"leave `{key}` out")
            elif s.time is None:
                raise ValueError(f"`streams.{s.name}` needs a `time` (a column, a "
                                 "`sample_rate_hz` or a `rate_from`)")

    def dialect(self, template: str) -> CsvDialect:
        """The dialect of one file template: ``csv`` with the ``files`` override applied."""
        override = self.files.get(template)
        if override is None:
            return self.csv
        merged = {**self.csv.model_dump(), **override.model_dump(exclude_none=True)}
        if override.header is True and override.column_names is None:
            merged["column_names"] = None
        try:
            return CsvDialect(**merged)
        except ValidationError as exc:
            raise ValueError(f"files.{template}: {_first_message(exc)}") from None


def _template_fields(template: str, key: str) -> set[str]:
    try:
        parsed = list(string.Formatter().parse(template))
    except ValueError as exc:
        raise ValueError(f"`{key}` ({template!r}) is not a valid template ({exc})") from None
    out = set()
    for _, field, spec, conv in parsed:
        if field is None:
            continue
        if not field.isidentifier() or spec or conv:
            raise ValueError(f"`{key}` ({template!r}): use plain fields like {{name}}")
        out.add(field)
    return out


def render(template: str, fields: dict[str, str]) -> str:
    """Fill a file or name template with a trial's fields (names checked at load time)."""
    return template.format_map(fields)


# -- loading ----------------------------------------------------------------------------------
def load_mapping(path: str | Path) -> CsvMapping:
    """Read and validate a mapping file; any problem is one :class:`InputError` line."""
    path = Path(path)
    text, raw = read_yaml(path, "mapping file")
    if not isinstance(raw, dict):
        raise InputError("a mapping file is a YAML mapping with keys trials, streams (and "
                         "optionally version, csv, files); see configs/mapping_example.yaml",
                         path=path)
    try:
        return CsvMapping.model_validate(raw)
    except ValidationError as exc:
        err = _deepest(exc)
        keys = _keys_in_file(tuple(err["loc"]), raw, last_may_be_missing=err["type"] == "missing")
        line = key_line(text, keys, start=1, skip_missing=True) if keys else None
        raise InputError(_describe(err, raw), path=path,
                         where=None if line is None else f"line {line}") from None


def _deepest(exc: ValidationError) -> dict[str, Any]:
    """The error to report: an unknown key, else the deepest (a union reports one error per
    member; the deepest is about the value the user wrote)."""
    errors = exc.errors()
    # an unknown key first: a misspelt key also makes the intended one "missing"
    return max(errors, key=lambda e: (e["type"] == "extra_forbidden", len(e["loc"])))


def _first_message(exc: ValidationError) -> str:
    return str(_deepest(exc)["msg"]).removeprefix("Value error, ")


def _keys_in_file(loc: tuple[Any, ...], raw: Any, *, last_may_be_missing: bool) -> tuple[Any, ...]:
    """The parts of a pydantic ``loc`` that are keys or indexes of the YAML document
    (union member names such as ``str`` are dropped)."""
    out: list[Any] = []
    node = raw
    for i, part in enumerate(loc):
        last = i == len(loc) - 1
        if isinstance(part, int):
            if isinstance(node, list) and part < len(node):
                out.append(part)
                node = node[part]
            continue
        if isinstance(node, dict) and part in node:
            out.append(part)
            node = node[part]
        elif last and last_may_be_missing and isinstance(node, dict):
            out.append(part)
    return tuple(out)


def _key_path(keys: tuple[Any, ...], raw: Any) -> str:
    """``("streams", 0, "time", "colum")`` -> ``streams[0](taxels).time.colum``."""
    out = ""
    node = raw
    for part in keys:
        if isinstance(part, int):
            out += f"[{part}]"
            node = node[part] if isinstance(node, list) and part < len(node) else None
            if isinstance(node, dict) and isinstance(node.get("name"), str):
                out += f"({node['name']})"
        else:
            out += f".{part}" if out else str(part)
            node = node.get(part) if isinstance(node, dict) else None
    return out


def _describe(err: dict[str, Any], raw: Any) -> str:
    missing = err["type"] == "missing"
    keys = _keys_in_file(tuple(err["loc"]), raw, last_may_be_missing=missing)
    key = _key_path(keys, raw)
    msg = str(err["msg"]).removeprefix("Value error, ")
    if not keys:
        return msg
    if err["type"] == "extra_forbidden":
        allowed = _allowed_keys(keys[:-1])
        hint = f" (allowed here: {', '.join(allowed)})" if allowed else ""
        return f"unknown key `{key}`{hint}"
    if missing:
        return f"missing key `{key}`"
    value = err.get("input")
    shown = ""
    if not (isinstance(value, dict | list) or value is None or repr(value) in msg):
        shown = f" (got {value!r})"
    if isinstance(value, bool) and err["type"] == "string_type":
        shown += "; quote it: YAML reads yes/no/on/off/true/false unquoted as booleans"
    return f"`{key}`: {msg}{shown}"


def _allowed_keys(keys: tuple[Any, ...]) -> list[str]:
    """The field names of the model at ``keys`` (best effort, for error hints)."""
    model: Any = CsvMapping
    free_key = False  # the next part is a key of a dict such as `files`
    for part in keys:
        if isinstance(part, int):
            continue
        if free_key:
            free_key = False
            continue
        if not (isinstance(model, type) and issubclass(model, BaseModel)):
            return []
        if part not in model.model_fields:
            return []
        annotation = model.model_fields[part].annotation
        free_key = get_origin(annotation) is dict
        model = _inner_model(annotation)
    if isinstance(model, type) and issubclass(model, BaseModel):
        return list(model.model_fields)
    return []


def _inner_model(annotation: Any) -> Any:
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    for arg in getattr(annotation, "__args__", ()):
        found = _inner_model(arg)
        if found is not None:
            return found
    return None


__all__ = ["ROW_FIELD", "CsvDialect", "CsvMapping", "SampleLabel", "Stream", "TimeBase",
           "TrialLayout", "Unroll", "ValueFrom", "load_mapping", "render"]
