"""The accelerometer CSV tree of paper 001 (fingertip accelerometers, slip/slide) into the store.

Layout (paper 001, sec. 4 and Fig. 4), one trial per CSV file::

    <root>/<object>/<orientation>/<speed>/<file>.csv

The three folder names become the trial labels ``object``, ``orientation`` and ``speed``,
stored as the folder text (``"wood"``, ``"15"``, ``"0.32"``). Every ``.csv`` under a root
must sit at exactly that depth (anything else is an error, not a skipped file); hidden
files (``.*``) are not read.

Columns, taken by position (the public dataset's header names are not known): ::

    L_x, L_y, L_z, R_x, R_y, R_z, v_slip, v_slide

A header name that names one of these columns (``slip_v``, ``acc_l_x``, ``Right_Z``: "slip" or
"slide", or a side ``l``/``left``/``r``/``right`` and an axis) must sit at that column's
position; a header with ``slide_v`` where ``v_slip`` belongs is refused, naming both, rather
than read with the velocities swapped. Names that name none of them are taken by position.

- six accelerations of the left (L) and right (R) fingertip accelerometers, which the
  paper scaled from [-5 g, 5 g] to [-1, 1] (sec. 4). They are stored as written, in the
  unit :data:`ACCEL_UNIT` = ``"fs5g"``: a fraction of the +-5 g full scale, so
  acceleration in g = 5 x value (the sensor also records ``full_scale_g`` = 5);
- the slip velocity (grasped object) and slide velocity (slider), in m/s.

A header row is optional: a first line whose 8 fields are all numbers is data. Rows
sampled at 8 kHz (sec. 3.1) unless another rate is given. The files are written by the
acquisition program, so a last line without a line break is taken for a row cut short and
refused.

Two streams per trial: ``accel`` (sensor kind ``accelerometer``, 6 channels) with the
per-sample label ``motion``, and ``velocity`` (kind ``robot_state``, 2 channels, m/s),
on one time base ``t_s = i / rate``.

Motion class (sec. 4, "5 cm/s speed threshold to define no-motion"), per sample, from the
speeds ``|v_slip|`` and ``|v_slide|``:

- ``no_motion`` when both are below 0.05 m/s;
- ``slip`` when ``|v_slip| >= 0.05`` m/s, **also when** ``|v_slide|`` is above the threshold
  too (the tie rule: slippage is the grasped object moving against the gripper, sec. 3.1,
  and on slippery objects both motions occur in quick succession, sec. 4; the object's
  motion is what a grasp controller must react to);
- ``slide`` otherwise (only ``|v_slide| >= 0.05`` m/s).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..config_file import os_error, read_bytes
from ..errors import InputError
from ..progress import Progress
from ..store.writer import StoreWriter
from .contract import (
    FormatOptions,
    IngestFormat,
    RecordingSummary,
    StreamSummary,
    TrialSummary,
)
from .csv_records import first_record, record_cells
from .mapped_csv import path_order, read_csv_header, read_csv_table
from .mapping import CsvDialect

#: Column order of every CSV (by position).
ACCEL_CHANNELS = ("L_x", "L_y", "L_z", "R_x", "R_y", "R_z")
VELOCITY_CHANNELS = ("v_slip", "v_slide")
COLUMNS = ACCEL_CHANNELS + VELOCITY_CHANNELS
#: Acceleration unit: a fraction of the +-5 g full scale (g = FULL_SCALE_G x value).
ACCEL_UNIT = "fs5g"
FULL_SCALE_G = 5.0
#: Sampling rate of the paper's acquisition board (sec. 3.1).
SAMPLE_RATE_HZ = 8000.0
#: Speed below which a motion does not count (sec. 4).
MOTION_THRESHOLD_M_S = 0.05
#: Classes of the ``motion`` sample label, in code order.
MOTION_CLASSES = ("no_motion", "slide", "slip")
MOTION_RULE = ("no_motion if |v_slip| < 0.05 m/s and |v_slide| < 0.05 m/s; slip if "
               "|v_slip| >= 0.05 m/s (also when |v_slide| >= 0.05 m/s); else slide")
ACCEL_SENSOR = "accel"
VELOCITY_SENSOR = "velocity"


def motion_class(v_slip_m_s: np.ndarray, v_slide_m_s: np.ndarray, *,
                 threshold_m_s: float = MOTION_THRESHOLD_M_S) -> np.ndarray:
    """(n,) int8 motion codes (indices into :data:`MOTION_CLASSES`) from (n,) velocities in m/s.

    Slip wins when both speeds reach the threshold (see the module docstring).
    """
    slipping = np.abs(v_slip_m_s) >= threshold_m_s
    sliding = np.abs(v_slide_m_s) >= threshold_m_s
    codes = np.zeros(len(slipping), dtype=np.int8)
    codes[sliding] = MOTION_CLASSES.index("slide")
    codes[slipping] = MOTION_CLASSES.index("slip")
    return codes


def find_accel_csvs(root: Path) -> list[tuple[Path, str, str, str]]:
    """Every trial CSV of one tree as (path, object, orientation, speed), in natural order."""
    if not root.is_dir():
        raise InputError("accel-tree inputs are root folders holding <object>/<orientation>/"
                         "<speed>/<file>.csv", path=root)
    found = []
    for path in root.rglob("*"):
        rel = path.relative_to(root)
        if path.suffix.lower() != ".csv" or any(p.startswith(".") for p in rel.parts):
            continue
        if len(rel.parts) != 4 or not path.is_file():
            raise InputError(f"CSV at the wrong depth: expected {root}/<object>/<orientation>/"
                             "<speed>/<file>.csv", path=path)
        found.append((path, *rel.parts[:3]))
    if not found:
        raise InputError("no <object>/<orientation>/<speed>/<file>.csv found under this folder",
                         path=root)
    return sorted(found, key=lambda f: path_order(f[0]))


def _column_role(name: str) -> str | None:
    """The column of :data:`COLUMNS` a header name names (``"slip_v"`` -> ``"v_slip"``,
    ``"acc_l_x"`` -> ``"L_x"``), or None when it names none of them."""
    tokens = re.findall(r"[a-z]+|[0-9]+", name.lower())
    joined = "".join(tokens)
    if ("slip" in joined) != ("slide" in joined):
        return "v_slip" if "slip" in joined else "v_slide"
    if not tokens:
        return None
    last = re.fullmatch(r"(l|left|r|right)?([xyz])", tokens[-1])
    if last is None:
        return None
    side = last[1] or next((t for t in reversed(tokens[:-1]) if t in ("l", "left", "r", "right")),
                           None)
    return None if side is None else f"{side[0].upper()}_{last[2]}"


def _check_header(names: list[str], path: Path) -> None:
    """Refuse a header whose names put a known column at another column's position."""
    for i, (name, expected) in enumerate(zip(names, COLUMNS, strict=False)):
        role = _column_role(name)
        if role is not None and role != expected:
            raise InputError(
                f"header column {i + 1} is {name!r} ({role}), but column {i + 1} must be "
                f"{expected}: columns are read by position ({', '.join(COLUMNS)}); put the "
                "columns in this order", path=path, where="line 1")


def _dialect(path: Path) -> CsvDialect:
    """Header or not, from the first line: 8 numbers are data."""
    try:
        with open(path, "rb") as f:
            first = first_record(f)
    except OSError as exc:
        raise os_error(exc, path, "CSV file") from None
    fields = [c.strip() for c in record_cells(first.strip(), path)]
    if len(fields) != len(COLUMNS):
        raise InputError(f"first line has {len(fields)} fields, expected {len(COLUMNS)} "
                         f"({', '.join(COLUMNS)})", path=path, where="line 1")
    try:
        [float(v) for v in fields]
    except ValueError:
        return CsvDialect(header=True)
    return CsvDialect(header=False, column_names=list(COLUMNS))


class AccelTreeOptions(FormatOptions):
    """Options of the accelerometer-tree format."""

    sample_rate_hz: float = SAMPLE_RATE_HZ
    """Rate of the rows in Hz (the files hold no time column; paper 001's board: 8 kHz)."""


def ingest_accel_tree(inputs: Sequence[Path], options: AccelTreeOptions, writer: StoreWriter,
                      progress: Progress) -> list[str]:
    """Ingest accelerometer CSV trees (``inputs`` are root folders); one trial per CSV.

    Writes the streams ``accel`` (n, 6) in ``fs5g`` with the sample label ``motion`` and
    ``velocity`` (n, 2) in m/s, both at ``options.sample_rate_hz`` (default 8 kHz).
    """
    sample_rate_hz = options.sample_rate_hz
    if not sample_rate_hz > 0:
        raise InputError(f"`sample_rate_hz` (={sample_rate_hz}) must be positive")
    files = [f for root in inputs for f in find_accel_csvs(root)]
    per_folder: dict[Path, int] = {}
    for path, *_ in files:
        per_folder[path.parent] = per_folder.get(path.parent, 0) + 1
    accel = writer.add_sensor(
        ACCEL_SENSOR, kind="accelerometer", sample_rate_hz=sample_rate_hz,
        channel_names=ACCEL_CHANNELS, channel_units=ACCEL_UNIT, full_scale_g=FULL_SCALE_G,
        description="left (L) and right (R) fingertip 3-axis accelerometers (ADXL335), as a "
                    "fraction of the +-5 g full scale: g = 5 x value (paper 001, sec. 3-4)")
    velocity = writer.add_sensor(
        VELOCITY_SENSOR, kind="robot_state", sample_rate_hz=sample_rate_hz,
        channel_names=VELOCITY_CHANNELS, channel_units="m/s",
        description="slip velocity (grasped object) and slide velocity (slider) from the "
                    "linear encoders, m/s (paper 001, sec. 3.1)")
    progress.start(len(files), "accelerometer CSV files")
    for path, obj, orientation, speed in files:
        dialect = _dialect(path)
        names = read_csv_header(path, dialect)  # COLUMNS when there is no header
        _check_header(names, path)
        table = read_csv_table(path, dialect, numeric=names, final_newline=True)
        values = np.column_stack([table.columns[n] for n in names])  # (n, 8) by position
        t_s = np.arange(table.n_rows, dtype=np.float64) / sample_rate_hz
        motion = motion_class(values[:, 6], values[:, 7])
        name = _trial_name(path, obj, orientation, speed, per_folder)
        trial = writer.trial(name, labels={"object": obj, "orientation": orientation,
                                           "speed": speed},
                             sources=[writer.add_source(path)])
        trial.write_signal("accel", sensor=accel, data=values[:, :6], t_s=t_s,
                           sample_labels={"motion": (motion, MOTION_CLASSES)})
        trial.group["signals/accel/sample_labels/motion"].attrs["rule"] = MOTION_RULE
        trial.write_signal("velocity", sensor=velocity, data=values[:, 6:], t_s=t_s)
        progress.advance(1)
    progress.finish()
    return []


def _trial_name(path: Path, obj: str, orientation: str, speed: str,
                per_folder: dict[Path, int]) -> str:
    name = f"{obj}_{orientation}_{speed}"
    return name + f"_{path.stem}" if per_folder[path.parent] > 1 else name


def describe_accel_tree(root: Path, options: AccelTreeOptions, fmt: IngestFormat
                        ) -> RecordingSummary:
    """The trials of one tree, read-only: every CSV's place and header checked as an
    ingest does, its rows counted (not parsed: a damaged value is an ingest's to find)."""
    files = find_accel_csvs(root)
    per_folder: dict[Path, int] = {}
    for path, *_ in files:
        per_folder[path.parent] = per_folder.get(path.parent, 0) + 1
    rate = options.sample_rate_hz
    trials, total, size = [], 0, 0
    for path, obj, orientation, speed in files:
        dialect = _dialect(path)
        _check_header(read_csv_header(path, dialect), path)
        raw = read_bytes(path, "CSV file")
        rows = sum(1 for line in raw.splitlines() if line.strip()) - int(dialect.header)
        total += rows
        size += len(raw)
        trials.append(TrialSummary(
            name=_trial_name(path, obj, orientation, speed, per_folder), source=str(path),
            counts={ACCEL_SENSOR: rows, VELOCITY_SENSOR: rows},
            duration_s=(rows - 1) / rate if rows > 1 and rate > 0 else 0.0,
            labels={"object": obj, "orientation": orientation, "speed": speed}))
    span = sum(t.duration_s or 0.0 for t in trials)
    streams = [StreamSummary(name=ACCEL_SENSOR, type="accelerometer", count=total,
                             unit="samples", channels=list(ACCEL_CHANNELS), rate_hz=rate,
                             span_s=span, size_bytes=size, extra={"unit": ACCEL_UNIT}),
               StreamSummary(name=VELOCITY_SENSOR, type="robot_state", count=total,
                             unit="samples", channels=list(VELOCITY_CHANNELS), rate_hz=rate,
                             span_s=span, extra={"unit": "m/s"})]
    notes = [f"the rows hold no time: they are taken at {rate:g} Hz (`sample_rate_hz`)",
             f"per-sample label motion: {MOTION_RULE}"]
    return RecordingSummary(file=str(root), format=fmt.name, title=fmt.title, size_bytes=size,
                            streams=streams, trials=trials, notes=notes,
                            ingest_options={"format": fmt.name})


class AccelTreeFormat(IngestFormat[AccelTreeOptions]):
    """The accelerometer CSV tree of paper 001 (see the module docstring)."""

    name = "accel-tree"
    title = "accelerometer CSV tree"
    summary = ("paper 001's accelerometer CSV tree (object, orientation and speed folders; 6 "
               "accelerations and 2 velocities per row), one trial per CSV")
    Options = AccelTreeOptions

    def sniff(self, path: Path) -> bool:
        """A folder whose first sub-sub-subfolder (natural order) holds a CSV with the
        8 columns of the tree, and whose root holds no CSV."""
        try:
            if not path.is_dir() or any(p.suffix.lower() == ".csv" for p in path.iterdir()):
                return False
            folder = path
            for _ in range(3):
                subs = sorted((p for p in folder.iterdir()
                               if p.is_dir() and not p.name.startswith(".")),
                              key=lambda p: path_order(p))
                if not subs:
                    return False
                folder = subs[0]
            csv = next((p for p in sorted(folder.iterdir(), key=path_order)
                        if p.suffix.lower() == ".csv" and p.is_file()
                        and not p.name.startswith(".")), None)
            if csv is None:
                return False
            with open(csv, "rb") as f:
                return len(record_cells(first_record(f).strip(), csv)) == len(COLUMNS)
        except (OSError, InputError):
            return False

    def describe(self, path: Path, options: AccelTreeOptions) -> RecordingSummary:
        return describe_accel_tree(path, options, self)

    def read(self, inputs: Sequence[Path], options: AccelTreeOptions, writer: StoreWriter,
             progress: Progress) -> list[str]:
        return ingest_accel_tree(inputs, options, writer, progress)


ACCEL_TREE = AccelTreeFormat()

__all__ = ["ACCEL_TREE", "ACCEL_UNIT", "MOTION_CLASSES", "AccelTreeFormat", "AccelTreeOptions",
           "describe_accel_tree", "find_accel_csvs", "ingest_accel_tree", "motion_class"]
