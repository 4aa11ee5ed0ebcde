"""What sensor CSVs hold, read without writing anything (``tactile info PATH [--mapping M]``).

With a mapping, :func:`describe_mapped_csv` plans the trials as an ingest does (headers
checked), parses every file and lists per stream its channels, sample count, rate (1 / the
median interval) and jitter, time span and the repeated and out-of-order stamps found
(with what the mapping's ``time.stamps`` policy would do about them); per trial its
samples and duration; and the columns of each file that no stream, label or time base
reads (what an ingest would leave out). Without a mapping it lists the CSV files found and
the columns of each, which is what a mapping is written from.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError
from ..natural import natural_key
from ..progress import NullProgress
from .contract import IngestFormat, RecordingSummary, StreamSummary, TrialSummary
from .mapped_csv import (
    TABLE,
    CsvTable,
    MappedCsvOptions,
    TrialPlan,
    load_plans,
    output_channels,
    read_csv_header,
    read_tables,
    row_trials,
)
from .mapping import CsvDialect, CsvMapping, Stream
from .stamps import interval_jitter_s, stamp_stats

#: CSV files listed by name when no mapping is given (the rest are counted).
MAX_FILES_LISTED = 200


def describe_mapped_csv(path: Path, options: MappedCsvOptions,
                        fmt: IngestFormat) -> RecordingSummary:
    """The summary of the recording at ``path`` (a file or folder; module docstring)."""
    if options.mapping is None:
        return _describe_columns(path, fmt)
    mapping_path, mapping, plans = load_plans([path], options)
    tally = {s.name: _StreamTally() for s in mapping.streams}
    trials: list[TrialSummary] = []
    files: set[Path] = set()
    for plan in plans:
        tables = read_tables(plan, mapping, NullProgress())
        files |= set(plan.files.values())
        counts: dict[str, int] = {}
        spans: list[float] = []
        for s in mapping.streams:
            n, span = tally[s.name].add(s, plan, tables)
            counts[s.name] = n
            if span is not None:
                spans.append(span)
        if mapping.trials.row_trials:
            trials += [TrialSummary(name=name, source=str(plan.path), labels=labels,
                                    counts=dict.fromkeys(counts, 1), duration_s=0.0)
                       for _, name, labels in row_trials(plan, mapping, tables)]
        else:
            trials.append(TrialSummary(name=plan.name, source=str(plan.path), counts=counts,
                                       duration_s=max(spans) if spans else None,
                                       labels=dict(plan.labels)))
    streams = [tally[s.name].summary(s, output_channels(s, plans[0].channels[s.name]))
               for s in mapping.streams]
    notes = [note for s in mapping.streams for note in tally[s.name].notes(s, len(plans))]
    return RecordingSummary(file=str(path), format=fmt.name, title=fmt.title,
                            size_bytes=sum(p.stat().st_size for p in files), streams=streams,
                            trials=trials, dropped=unread_columns(plans[0], mapping),
                            notes=notes, ingest_options={"mapping": str(mapping_path)})


class _StreamTally:
    """One stream's samples, stamp intervals and late stamps over every trial."""

    def __init__(self) -> None:
        self.count = 0
        self.intervals: list[np.ndarray] = []
        self.span_s = 0.0
        self.t_first: float | None = None
        self.t_last: float | None = None
        self.n_trials = 0
        self.repeated = self.out_of_order = 0
        self.late_trials: list[tuple[str, int, int]] = []
        self.size = 0
        self.rows = 0

    def add(self, s: Stream, plan: TrialPlan, tables: dict[str, CsvTable]
            ) -> tuple[int, float | None]:
        """Count one trial; returns its samples and its span in seconds (None when the
        stream has no time base: one sample per table row)."""
        table = tables[s.file]
        m = 1 if s.unroll is None else len(plan.channels[s.name])
        n = table.n_rows * m
        self.count += n
        self.rows += table.n_rows
        self.n_trials += 1
        self.size += table.path.stat().st_size
        if s.time is None:
            return n, None
        if s.time.column is None:
            rate = s.time.sample_rate_hz
            if s.time.rate_from is not None:
                rate = float(tables[s.time.rate_from.file].columns[s.time.rate_from.column][0])
            span = (table.n_rows - 1) / rate if rate else 0.0
            if rate and table.n_rows > 1:
                self.intervals.append(np.full(table.n_rows - 1, 1.0 / rate))
            self.span_s += span
            return n, span
        t = tables[s.time.file or s.file].columns[s.time.column] * s.time.seconds_per_unit
        stats = stamp_stats(t)
        if stats.n_late:
            self.repeated += stats.n_repeated
            self.out_of_order += stats.n_out_of_order
            self.late_trials.append((plan.name, stats.n_repeated, stats.n_out_of_order))
        if len(t) > 1:
            self.intervals.append(np.diff(t))
        span = float(np.max(t) - t[0]) if len(t) else 0.0
        self.span_s += span
        if len(t):
            self.t_first = float(t[0]) if self.t_first is None else self.t_first
            self.t_last = float(t[-1])
        return n, span

    def summary(self, s: Stream, channels: list[str]) -> StreamSummary:
        steps = np.concatenate(self.intervals) if self.intervals else np.empty(0)
        positive = steps[steps > 0]
        m = self.count // self.rows if s.unroll is not None and self.rows else 1
        rate = float(m / np.median(positive)) if len(positive) else None  # samples per row
        timed = s.time is not None and s.time.column is not None
        one_trial = self.n_trials == 1
        return StreamSummary(
            name=s.name, type=s.kind, count=self.count, unit="samples", channels=channels,
            rate_hz=rate, jitter_s=interval_jitter_s(steps),
            t_first_s=self.t_first if one_trial else None,
            t_last_s=self.t_last if one_trial else None,
            span_s=self.span_s if s.time is not None else None, size_bytes=self.size,
            repeated_stamps=self.repeated if timed else None,
            out_of_order_stamps=self.out_of_order if timed else None,
            extra={"sensor": s.sensor_name, "file": s.file,
                   "stamps": s.time.stamps if timed and s.time is not None else None})

    def notes(self, s: Stream, n_trials: int) -> list[str]:
        if not self.late_trials or s.time is None:
            return []
        shown = ", ".join(f"{name} ({rep} repeated, {back} out of order)"
                          for name, rep, back in self.late_trials[:5])
        more = f" and {len(self.late_trials) - 5} more" if len(self.late_trials) > 5 else ""
        what = (f"an ingest refuses them; give `streams.{s.name}.time.stamps` (drop_repeats, "
                "keep_last or spread) in the mapping to keep them" if s.time.stamps == "refuse"
                else f"an ingest applies `stamps: {s.time.stamps}` and reports them")
        return [f"stream {s.name!r}: {len(self.late_trials)} of {n_trials} trial(s) have "
                f"repeated or out-of-order time stamps: {shown}{more}; {what}"]


def unread_columns(plan: TrialPlan, mapping: CsvMapping) -> list[str]:
    """One line per file of the first trial whose columns no stream, time base or label
    reads (checked on the first trial: all trials share their streams' columns)."""
    used: dict[str, set[str]] = {t: set() for t in plan.files}
    for s in mapping.streams:
        used[s.file] |= set(plan.channels[s.name])
        if s.time is not None and s.time.column is not None:
            used[s.time.file or s.file].add(s.time.column)
        if s.time is not None and s.time.rate_from is not None:
            used[s.time.rate_from.file].add(s.time.rate_from.column)
        for lab in s.sample_labels:
            used[lab.file or s.file].add(lab.column)
    if TABLE in plan.files:
        used[TABLE] |= set(mapping.trials.label_column_names)
    by_path: dict[Path, tuple[str, set[str]]] = {}
    for template, path in plan.files.items():
        first, columns = by_path.get(path, (template, set()))
        by_path[path] = (first, columns | used[template])
    out = []
    for path, (template, columns) in by_path.items():
        names = read_csv_header(path, mapping.dialect(template))
        unread = [n for n in names if n not in columns]
        if unread:
            more = " ..." if len(unread) > 12 else ""
            out.append(f"{path.name}: {len(unread)} column(s) no stream reads: "
                       f"{', '.join(unread[:12])}{more}")
    return out


def _describe_columns(path: Path, fmt: IngestFormat) -> RecordingSummary:
    """Without a mapping: the CSV files under ``path`` and the columns of each."""
    if path.is_dir():
        files = sorted((p for p in path.rglob("*.csv")
                        if p.is_file() and not any(part.startswith(".")
                                                   for part in p.relative_to(path).parts)),
                       key=lambda p: natural_key(p.as_posix()))
    elif path.is_file():
        files = [path]
    else:
        raise InputError("not a file or folder", path=path)
    if not files:
        raise InputError("no CSV files in this folder or its subfolders", path=path)
    headers: dict[tuple[str, ...], list[Path]] = {}
    trials = []
    for f in files:
        names = tuple(read_csv_header(f, CsvDialect()))
        headers.setdefault(names, []).append(f)
        if len(trials) < MAX_FILES_LISTED:
            trials.append(TrialSummary(name=f.stem, source=str(f),
                                       counts={"rows": _data_rows(f)}))
    streams = [StreamSummary(name=f"columns {k + 1}", type="csv header", count=len(members),
                             unit="files", channels=list(names),
                             size_bytes=sum(p.stat().st_size for p in members),
                             extra={"first_file": str(members[0])})
               for k, (names, members) in enumerate(headers.items())]
    notes = ["no mapping given: these are the CSV files and their header columns (the first "
             "line of each); write a mapping (see configs/mapping_example.yaml) that names the "
             "time, channel and label columns, then describe or ingest with `mapping=FILE.yaml`"]
    if len(files) > MAX_FILES_LISTED:
        notes.append(f"{len(files)} CSV files; the first {MAX_FILES_LISTED} are listed")
    return RecordingSummary(file=str(path), format=fmt.name, title=fmt.title,
                            size_bytes=sum(p.stat().st_size for p in files), streams=streams,
                            trials=trials, notes=notes, ingest_options={"mapping": "FILE.yaml"})


def _data_rows(path: Path) -> int:
    """Lines after the header that are not blank (a cheap count; quoted line breaks count
    as lines)."""
    with open(path, "rb") as f:
        lines = [line for line in f.read().splitlines()[1:] if line.strip()]
    return len(lines)


__all__ = ["describe_mapped_csv"]
