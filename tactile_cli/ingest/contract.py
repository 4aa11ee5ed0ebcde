"""The contract every input format of ``tactile ingest`` keeps, and what ``tactile info`` prints
for a raw recording.

A format is one module holding one :class:`IngestFormat` subclass and its options model (a
:class:`FormatOptions` subclass), registered by one line in
:mod:`tactile_cli.ingest.registry`. The registry is what ingest's auto-detection and
``format``, ``tactile info`` on raw inputs and the CLI's option help read, so a new format
touches neither the dispatcher, nor ``info``, nor the command line.

- ``name`` (``"events-csv"``), ``title`` (``"event CSV"``, how messages and ``info`` call it),
  ``summary`` (one line for help texts) and ``suffixes`` (the file suffixes it reads, for
  messages; empty for folder formats);
- ``Options``: a pydantic model of the format's own options, unknown keys refused. Options
  every format shares (run-wide labels, annotations, trial labels) are :class:`CommonOptions`
  and are applied by :func:`tactile_cli.ingest.ingest` after the reader, not by the reader;
- ``sniff(path) -> bool``: whether a path looks like this format, cheaply (its suffix, a few
  header bytes, a folder's layout), and True for a path that does not exist yet when its
  suffix says so. It never raises: a damaged file that looks like the format is the
  format's to refuse in ``describe`` or ``read``;
- ``describe(path, options) -> RecordingSummary``: what the recording holds, read-only
  (streams with counts, rates and time spans, trials, what an ingest would leave out),
  raising the same one-line :class:`~tactile_cli.errors.InputError` an ingest would for a
  damaged input;
- ``read(inputs, options, writer, progress) -> notes``: add the inputs' sensors and trials to
  an open :class:`~tactile_cli.store.StoreWriter`, returning one-line notes about
  assumptions the file records (a frame rate assumed, samples with repeated stamps dropped).

Heavy third-party imports (pandas, Pillow, the AEDAT4 decoder) happen inside ``describe``
and ``read``, so importing the registry (which ``import tactile_cli`` and ``tactile --help``
do) stays light.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar, Generic, TypeVar, get_args

from pydantic import BaseModel, ConfigDict, Field

if TYPE_CHECKING:
    from ..progress import Progress
    from ..store.writer import StoreWriter


class FormatOptions(BaseModel):
    """The options of one input format: typed, frozen, unknown keys refused.

    Each format subclasses this with its own fields (documented by attribute docstrings,
    which the CLI's help shows); every field has a default, so ``Options()`` is what
    ``tactile info`` describes a recording with when no option is given.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, use_attribute_docstrings=True)

    @classmethod
    def path_fields(cls) -> list[str]:
        """The options that name a file (typed ``Path``)."""
        return [k for k, f in cls.model_fields.items()
                if f.annotation is Path or Path in get_args(f.annotation)]

    def files(self) -> list[Path]:
        """The files these options name (a mapping file): a batch ingest re-runs an input
        when one of them is newer than its output."""
        return [v for v in (getattr(self, k) for k in self.path_fields()) if v is not None]


class CommonOptions(BaseModel):
    """Options every format takes, applied to the file after the format's reader ran."""

    model_config = ConfigDict(extra="forbid", frozen=True, use_attribute_docstrings=True)

    labels: dict[str, str | int | float] = Field(default_factory=dict)
    """Labels added to every trial (``{"object": "box"}``)."""
    annotations: Path | None = None
    """CSV of time intervals per trial (columns trial,start_s,end_s,label)."""
    trial_labels: Path | None = None
    """CSV with a ``trial`` column; every other column is a label of that trial."""

    def files(self) -> list[Path]:
        """The sidecar files given (annotations, trial labels)."""
        return [p for p in (self.annotations, self.trial_labels) if p is not None]


# -- what `tactile info` prints for a raw recording ---------------------------------------------
@dataclass
class StreamSummary:
    """One stream of a raw recording (an event stream, a column group, a topic, frames).

    type: what it holds (``events``, ``frames``, ``samples``, ``imus``, a message type);
    count: items in all (events, frames, samples, messages), None when not readable;
    unit: what ``count`` counts; rate_hz: 1 / the median interval between consecutive stamps
    and jitter_s the standard deviation of those intervals in seconds (both over every
    trial, None without two stamps); t_first_s, t_last_s: first and last stamp in seconds on
    the recording's own clock (None when the stream spans several trials with clocks of
    their own); span_s: seconds from first to last stamp, summed over trials;
    repeated_stamps, out_of_order_stamps: samples whose stamp equals, or is earlier than,
    the latest stamp before them (None when the format has no stamps to check);
    extra: format-specific fields, listed beside the others in JSON (AEDAT4: ``stream_id``).
    """

    name: str
    type: str
    count: int | None
    unit: str
    readable: bool = True
    channels: list[str] = field(default_factory=list)
    rate_hz: float | None = None
    jitter_s: float | None = None
    t_first_s: float | None = None
    t_last_s: float | None = None
    span_s: float | None = None
    size_bytes: int | None = None
    width_px: int | None = None
    height_px: int | None = None
    repeated_stamps: int | None = None
    out_of_order_stamps: int | None = None
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def resolution(self) -> str:
        return f"{self.width_px}x{self.height_px} px" if self.width_px and self.height_px else ""

    def as_dict(self) -> dict[str, Any]:
        out = asdict(self)
        extra = out.pop("extra")
        return {**out, **extra}


@dataclass
class TrialSummary:
    """One trial an ingest would write: its name, where it comes from, items per stream,
    its duration in seconds (None when unknown before decoding) and its labels."""

    name: str
    source: str
    counts: dict[str, int] = field(default_factory=dict)
    duration_s: float | None = None
    labels: dict[str, str | int | float] = field(default_factory=dict)


@dataclass
class RecordingSummary:
    """What a raw recording holds, read without writing anything (``tactile info RAW``).

    file: the path described (a file or a folder); size_bytes: bytes of every file read;
    dropped: one line per thing an ingest would leave out (columns no stream reads, stream
    types the reader skips); notes: one line per thing to know before ingesting (timing
    problems, assumed rates); ingest_options: the format options an ingest of it needs, by
    their Python names, for the hint (``{"mapping": "m.yaml"}``; the CLI spells them as
    flags).
    """

    file: str
    format: str
    title: str
    size_bytes: int
    streams: list[StreamSummary] = field(default_factory=list)
    trials: list[TrialSummary] = field(default_factory=list)
    dropped: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    ingest_options: dict[str, str] = field(default_factory=dict)

    @property
    def hint(self) -> str:
        given = " ".join(f"`{k}={v!r}`" for k, v in self.ingest_options.items())
        return (f"a raw {self.title} recording, not a tactile HDF5 file: other commands need "
                f"it ingested (`tactile ingest {self.file} --out FILE.h5`"
                + (f" with {given})" if given else ")"))

    def as_dict(self) -> dict[str, Any]:
        return {"file": self.file, "format": self.format, "title": self.title,
                "size_bytes": self.size_bytes, "streams": [s.as_dict() for s in self.streams],
                "trials": [asdict(t) for t in self.trials], "dropped": list(self.dropped),
                "notes": list(self.notes), "hint": self.hint}


OptionsT = TypeVar("OptionsT", bound=FormatOptions)


class IngestFormat(ABC, Generic[OptionsT]):
    """One input format (see the module docstring). Subclasses set the class attributes and
    implement the three methods; the registry holds one instance of each."""

    #: the name ``format=`` and ``--format`` take (``"events-csv"``)
    name: ClassVar[str]
    #: how messages and ``tactile info`` call the format (``"event CSV"``)
    title: ClassVar[str]
    #: one line for help texts: what the inputs are
    summary: ClassVar[str]
    #: file suffixes (lower case, with the dot) the format reads; empty for folders
    suffixes: ClassVar[tuple[str, ...]] = ()
    #: the options model
    Options: ClassVar[type[FormatOptions]]
    #: an option that, when given, makes this format read an input that no format sniffs
    #: (``"mapping"``: a mapping says what a CSV table is, whatever its suffix)
    claim_option: ClassVar[str | None] = None

    @abstractmethod
    def sniff(self, path: Path) -> bool:
        """Whether ``path`` looks like this format (cheap; never raises)."""

    @abstractmethod
    def describe(self, path: Path, options: OptionsT) -> RecordingSummary:
        """What the recording at ``path`` holds, read-only (InputError when damaged)."""

    @abstractmethod
    def read(self, inputs: Sequence[Path], options: OptionsT, writer: StoreWriter,
             progress: Progress) -> list[str]:
        """Add the sensors and trials of ``inputs`` to ``writer``; returns notes."""

    def options(self, values: dict[str, Any] | FormatOptions | None = None) -> OptionsT:
        """The options model from a mapping of values (or a model instance of this format):
        see :func:`tactile_cli.ingest.registry.format_options` for the errors."""
        from .registry import format_options

        return format_options(self, values)  # type: ignore[return-value]

    def __repr__(self) -> str:
        return f"<ingest format {self.name!r}>"


__all__ = ["CommonOptions", "FormatOptions", "IngestFormat", "RecordingSummary",
           "StreamSummary", "TrialSummary"]
