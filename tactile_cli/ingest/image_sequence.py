"""Image-sequence folders of visuotactile sensors (DIGIT, GelSight) into the tactile store.

Layout read (one folder = one trial, trial name = folder name; when folder names repeat
across the inputs, every trial is named by its path below their common folder, parts joined
by ``__``: ``object001__066_60_mm``, :func:`folder_trial_names`)::

    press_01/
        reference.png          the no-contact frame (names below)
        frame_1.png ... frame_240.png
        timestamps.csv         optional frame times

An input folder without frames whose subfolders are such folders (``digit/press_01/``,
``digit/press_02/``, ...) is ingested as one trial per subfolder, in natural name order.

- **Frames**: every ``.png``/``.jpg``/``.jpeg`` file directly in the folder except the
  reference, in natural name order (``frame_2`` before ``frame_10``). Hidden files
  (``.*``, e.g. macOS ``._frame1.png``) and subfolders are not read. BMP/TIFF/GIF/WebP
  files are an error rather than silently skipped frames.
- **Reference (no-contact) frame**: exactly one PNG/JPG whose name without suffix is, in
  any letter case, one of :data:`REFERENCE_STEMS` (``reference``, ``ref``, ``background``,
  ``no_contact``); none or several is an error. ``reference`` (``tactile ingest
  --reference``) changes that for every folder: ``first`` takes each folder's first frame
  in natural order as its reference (the frame stays frame 0 of the sequence, so frames and
  timestamps still match one to one: what a recording that starts before contact gives);
  any other value names the reference file in each folder (``bg.png``, or its stem ``bg``,
  any letter case), which is then not a frame. A folder that also holds a
  reference-named file is an error either way (two candidates). :func:`scan_image_folder`
  also takes an explicit reference file.
- **Per-trial labels** (optional): ``labels.json`` in the folder, one JSON object of label
  name -> string, number or boolean (``{"object": "cable", "slip": "slip",
  "slip_onset_s": 1.5}``); the key ``split`` (``train``, ``val`` or ``test``) sets the
  trial's split instead. The labels are set on the trial; ``--trial-labels`` and ``--label``
  may add others but not contradict them (an error naming the file).
- **Frame times** (``t_s``, seconds from the trial's time origin): from ``timestamps.csv``
  when present, either one column (``t_s``, one row per frame in frame order) or two
  columns (``file,t_s``); the header row is optional and ``t_s`` values are stored as
  written. A header ``t_unix_s`` (or ``file,t_unix_s``) marks Unix epoch seconds instead:
  they are stored relative to the first frame and the first frame's epoch time goes into
  the trial attribute ``time_origin_unix_s`` (as the mapped-CSV ingest does). Times must be
  finite and must not decrease in frame order. Without the file, frames are taken to be
  evenly spaced at :data:`DEFAULT_FRAME_RATE_HZ` = 30 Hz, the rate DIGIT streams at
  (paper 002, sec. III: "DIGIT runs at 30Hz"), the trial records the assumption in
  its attribute ``frame_rate_assumed_hz``, and the ingest returns a note saying so.
- **Pixels**: stored as (height, width, 3) uint8 RGB. Grayscale (``L``, ``1``) frames are
  replicated to three channels, alpha (``RGBA``, ``LA``, palette transparency) is dropped
  without compositing, palette/CMYK/YCbCr frames are converted by Pillow. 16-bit and
  float images are an error (their values do not fit uint8 without a choice of scaling).
  EXIF orientation tags are ignored: pixels are stored as encoded.

All frames and reference frames of one ingest share one size, which becomes the sensor's
``width_px``/``height_px`` (DIGIT: 320 x 240; 640 x 480 and other sizes are read alike).
``px_per_mm`` (``tactile ingest --px-per-mm``), the gel's scale in pixels per millimetre,
becomes the sensor attribute ``px_per_mm`` that the visuotactile chain's calibration and
height maps read (they refuse a file without it). Frames are decoded and written in small
batches, so memory stays bounded for sequences of any length; every frame, reference and
timestamps file is recorded as a source (``source_index`` of a trial lists its frames in
order, then its reference, then its ``timestamps.csv`` if any).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..config_file import read_text
from ..errors import InputError
from ..natural import natural_key
from ..progress import Progress
from ..store.writer import StoreWriter
from .contract import (
    FormatOptions,
    IngestFormat,
    RecordingSummary,
    StreamSummary,
    TrialSummary,
)
from .csv_records import csv_records
from .stamps import interval_jitter_s, stamp_stats

#: Suffixes of the frames read (lower case).
IMAGE_SUFFIXES = {".png", ".jpg", ".jpeg"}
#: Frame rate assumed when a folder has no timestamps.csv: DIGIT's 30 Hz (paper 002).
DEFAULT_FRAME_RATE_HZ = 30.0
#: Names (without suffix, any letter case) of the no-contact reference frame.
REFERENCE_STEMS = ("reference", "ref", "background", "no_contact")
#: Optional per-folder frame-time file.
TIMESTAMPS_FILE = "timestamps.csv"
#: Optional per-folder trial-label file (a JSON object of label name -> value).
LABELS_FILE = "labels.json"
#: ``reference`` value that takes each folder's first frame as its reference.
REFERENCE_FIRST = "first"
#: Splits a ``labels.json`` may set.
SPLITS = ("train", "val", "test")
#: Image files that are refused rather than skipped, so no frame is silently dropped.
UNSUPPORTED_IMAGE_SUFFIXES = {".bmp", ".tif", ".tiff", ".gif", ".webp"}
#: Target bytes of decoded frames held before one write to HDF5.
FRAME_BATCH_BYTES = 8 << 20

_REFERENCE_HINT = ("name it reference.png (accepted names: "
                   + ", ".join(REFERENCE_STEMS) + " with suffix .png, .jpg or .jpeg), or "
                   "pass `reference='first'` (the first frame is the no-contact one) or "
                   "`reference=NAME`")


@dataclass(frozen=True)
class ImageFolder:
    """One trial's files, found and checked before any frame is decoded.

    frames: frame files in natural name order; t_s: (n_frames,) float64 seconds from the
    trial's time origin; frame_rate_assumed_hz: the rate ``t_s`` was made from when the
    folder had no timestamps file and no rate was given, else None; time_origin_unix_s:
    Unix time of ``t_s = 0`` when the timestamps file gave epoch times, else None.
    """

    folder: Path
    frames: tuple[Path, ...]
    reference: Path
    timestamps_file: Path | None
    t_s: np.ndarray
    frame_rate_assumed_hz: float | None
    time_origin_unix_s: float | None = None
    labels_file: Path | None = None
    labels: tuple[tuple[str, str | int | float], ...] = ()
    split: str | None = None
    #: the trial's name when it is not the folder's own (:func:`folder_trial_names`)
    name: str | None = None

    @property
    def trial_name(self) -> str:
        return self.name if self.name is not None else self.folder.resolve().name


class ImageFolderOptions(FormatOptions):
    """Options of the image-folder format."""

    sensor_name: str | None = None
    """Name of the visuotactile sensor (default ``visuotactile``)."""
    width_px: int | None = None
    """Frame width in px: checked against the frames (which set it)."""
    height_px: int | None = None
    """Frame height in px: checked against the frames (which set it)."""
    frame_rate_hz: float | None = None
    """Frame rate of folders without a timestamps.csv (default: 30 Hz assumed, with a
    note)."""
    reference: str | None = None
    """The no-contact reference frame of every folder: ``first`` (the first frame in
    natural order, kept as frame 0) or a file name or stem in each folder (default: the file
    named reference, ref, background or no_contact)."""
    px_per_mm: float | None = None
    """Pixels per millimetre on the gel (DIGIT-like: 16), stored as the sensor attribute
    ``px_per_mm`` that calibration and height maps read."""


def has_image_files(folder: Path) -> bool:
    """Whether ``folder`` holds PNG/JPG files directly (hidden files not counted)."""
    return any(p.suffix.lower() in IMAGE_SUFFIXES and not p.name.startswith(".") and p.is_file()
               for p in folder.iterdir())


def image_sequence_folders(folder: Path) -> list[Path]:
    """The trial folders an input folder stands for: itself when it holds frames, else its
    subfolders (in natural name order) when they are image-sequence folders, else none.

    A folder of image-sequence folders (``digit/press_01/``, ``digit/press_02/``, ...) is
    ingested as one trial per subfolder. A subfolder without frames beside ones with
    frames is an InputError naming it, rather than a trial skipped without a word.
    """
    if has_image_files(folder):
        return [folder]
    subfolders = sorted((p for p in folder.iterdir() if p.is_dir() and not p.name.startswith(".")),
                        key=lambda p: natural_key(p.name))
    with_frames = [p for p in subfolders if has_image_files(p)]
    without = [p for p in subfolders if p not in with_frames]
    if with_frames and without:
        raise InputError(f"holds image-sequence folders ({with_frames[0].name}, ...) and "
                         f"{without[0].name}/, which has no PNG/JPG frames; move it out, or pass "
                         "the sequence folders themselves", path=folder)
    return with_frames


def scan_image_folder(
    folder: Path,
    *,
    reference: Path | None = None,
    frame_rate_hz: float | None = None,
    reference_name: str | None = None,
) -> ImageFolder:
    """List a trial folder's frames, find its reference frame and settle the frame times.

    reference: an explicit no-contact frame file (then the folder must not hold a
    reference-named file too); by default it is found by name (:data:`REFERENCE_STEMS`).
    reference_name: ``"first"`` (the first frame, which stays a frame) or the name or stem
    of the reference file in this folder (see the module docstring).
    frame_rate_hz: the rate of evenly spaced frames in Hz, for folders without
    ``timestamps.csv`` (giving both is an error); by default
    :data:`DEFAULT_FRAME_RATE_HZ` is assumed and recorded as assumed.
    No image is decoded here, so a bad layout fails before any heavy work.
    """
    if not folder.is_dir():
        raise InputError("the images format reads folders of PNG/JPG frames (one folder per "
                         "trial); pass the folder, not a file", path=folder)
    if frame_rate_hz is not None and not (np.isfinite(frame_rate_hz) and frame_rate_hz > 0):
        raise InputError(f"`frame_rate_hz` (={frame_rate_hz}) must be a positive number of Hz")
    images: list[Path] = []
    timestamps: list[Path] = []
    label_files: list[Path] = []
    for path in folder.iterdir():
        if path.name.startswith(".") or not path.is_file():
            continue
        suffix = path.suffix.lower()
        if suffix in IMAGE_SUFFIXES:
            images.append(path)
        elif suffix in UNSUPPORTED_IMAGE_SUFFIXES:
            raise InputError(f"{suffix} images are not read (frames must be PNG or JPG); convert "
                             "the sequence to PNG (lossless) or move the file out", path=path)
        elif path.name.lower() == TIMESTAMPS_FILE:
            timestamps.append(path)
        elif path.name.lower() == LABELS_FILE:
            label_files.append(path)
    named_refs = sorted((p for p in images if p.stem.lower() in REFERENCE_STEMS),
                        key=lambda p: natural_key(p.name))
    frames = tuple(sorted((p for p in images if p.stem.lower() not in REFERENCE_STEMS),
                          key=lambda p: natural_key(p.name)))
    if reference is not None and reference_name is not None:
        raise InputError("give a reference file or `reference`, not both", path=folder)
    if reference_name is not None:
        frames, ref = _pick_reference(folder, images, named_refs, frames, reference_name)
    elif reference is not None:
        if named_refs:
            raise InputError(f"a reference frame was given ({reference}) and the folder holds "
                             f"{named_refs[0].name} too; keep one of them", path=folder)
        if not reference.is_file() or reference.suffix.lower() not in IMAGE_SUFFIXES:
            raise InputError("the reference frame must be an existing PNG or JPG file",
                             path=reference)
        frames = tuple(p for p in frames if p.resolve() != reference.resolve())
        ref = reference
    elif not named_refs:
        raise InputError(f"no reference (no-contact) frame found; {_REFERENCE_HINT}", path=folder)
    elif len(named_refs) > 1:
        raise InputError(f"several reference frames ({', '.join(p.name for p in named_refs)}); "
                         "keep exactly one", path=folder)
    else:
        ref = named_refs[0]
    if not frames:
        raise InputError(f"no frames besides the reference {ref.name}; add the PNG/JPG frames "
                         "of the sequence", path=folder)
    if len(timestamps) > 1:
        raise InputError(f"several timestamp files ({', '.join(p.name for p in timestamps)}); "
                         f"keep one named {TIMESTAMPS_FILE}", path=folder)
    ts_file = timestamps[0] if timestamps else None
    assumed: float | None = None
    origin: float | None = None
    if ts_file is not None:
        if frame_rate_hz is not None:
            raise InputError(f"both {TIMESTAMPS_FILE} and a frame rate ({frame_rate_hz} Hz) were "
                             "given; drop one", path=ts_file)
        times = read_timestamps(ts_file, frames)
        t_s, origin = times.t_s, times.time_origin_unix_s
    else:
        rate = DEFAULT_FRAME_RATE_HZ if frame_rate_hz is None else float(frame_rate_hz)
        assumed = rate if frame_rate_hz is None else None
        t_s = np.arange(len(frames), dtype=np.float64) / rate
    if len(label_files) > 1:
        raise InputError(f"several label files ({', '.join(p.name for p in label_files)}); "
                         f"keep one named {LABELS_FILE}", path=folder)
    labels_file = label_files[0] if label_files else None
    labels, split = read_folder_labels(labels_file) if labels_file else ((), None)
    return ImageFolder(folder=folder, frames=frames, reference=ref, timestamps_file=ts_file,
                       t_s=t_s, frame_rate_assumed_hz=assumed, time_origin_unix_s=origin,
                       labels_file=labels_file, labels=labels, split=split)


def _pick_reference(folder: Path, images: list[Path], named_refs: list[Path],
                    frames: tuple[Path, ...], reference_name: str
                    ) -> tuple[tuple[Path, ...], Path]:
    """(frames, reference) for ``reference_name`` = ``first`` or a file name/stem."""
    if reference_name == REFERENCE_FIRST:
        if named_refs:
            raise InputError(f"`reference='first'` was given and the folder holds "
                             f"{named_refs[0].name} too; drop `reference` to use that file, or "
                             "move it out", path=folder)
        if not frames:
            raise InputError("has no PNG/JPG frames, so there is no first frame to take as "
                             "the reference", path=folder)
        return frames, frames[0]
    wanted = reference_name.casefold()
    matches = sorted((p for p in images if wanted in (p.name.casefold(), p.stem.casefold())),
                     key=lambda p: natural_key(p.name))
    if not matches:
        raise InputError(f"no reference frame named {reference_name!r} (`reference`); name a "
                         "PNG/JPG file in every folder, or use `reference='first'`", path=folder)
    if len(matches) > 1:
        raise InputError(f"several files match `reference` {reference_name!r} "
                         f"({', '.join(p.name for p in matches)}); give the full file name",
                         path=folder)
    ref = matches[0]
    others = [p for p in named_refs if p != ref]
    if others:
        raise InputError(f"`reference` names {ref.name} and the folder holds {others[0].name} "
                         "too; keep one of them", path=folder)
    return tuple(p for p in frames if p != ref), ref


def read_folder_labels(path: Path) -> tuple[tuple[tuple[str, str | int | float], ...],
                                            str | None]:
    """The labels and split of a trial folder's ``labels.json``: one JSON object of label
    name -> string, number or boolean (stored as 0/1); key ``split`` sets the trial's split.
    Every problem is an InputError naming the file."""
    import json

    try:
        raw = json.loads(read_text(path, "label file"))
    except json.JSONDecodeError as exc:
        raise InputError(f"is not valid JSON ({exc.msg}); write one object like "
                         '{"object": "cable", "slip_onset_s": 1.5}', path=path,
                         where=f"line {exc.lineno}") from None
    if not isinstance(raw, dict):
        raise InputError(f"holds a JSON {type(raw).__name__}, expected one object of label "
                         'name -> value like {"object": "cable"}', path=path)
    labels: list[tuple[str, str | int | float]] = []
    split: str | None = None
    for key, value in raw.items():
        if not key.strip():
            raise InputError("has an empty label name", path=path)
        if key == "split":
            if value not in SPLITS:
                raise InputError(f"split {value!r} is not one of {', '.join(SPLITS)}", path=path)
            split = value
            continue
        if isinstance(value, bool):
            value = int(value)
        if isinstance(value, float) and not np.isfinite(value):
            raise InputError(f"label {key!r} is not finite", path=path)
        if not isinstance(value, str | int | float):
            raise InputError(f"label {key!r} is a JSON {type(value).__name__}; a label is a "
                             "string, a number or true/false", path=path)
        labels.append((key.strip(), value))
    return tuple(labels), split


@dataclass(frozen=True)
class FrameTimes:
    """Frame times read from a timestamps file.

    t_s: (n_frames,) float64 seconds from the trial's time origin; time_origin_unix_s: Unix
    time in seconds of ``t_s = 0`` (the first frame) for epoch input, else None.
    """

    t_s: np.ndarray
    time_origin_unix_s: float | None


def read_timestamps(path: Path, frames: Sequence[Path]) -> FrameTimes:
    """Frame times from a ``timestamps.csv``, in the order of ``frames``.

    One column ``t_s`` (row k is frame k) or two columns ``file,t_s`` (every frame named
    once); the header row is optional, except that epoch seconds need the header
    ``t_unix_s`` (``file,t_unix_s``); blank lines are skipped.
    """
    rows: list[tuple[int, list[str]]] = []
    for line_no, row in csv_records(read_text(path, "timestamps file"), path):
        cells = [c.strip() for c in row]
        if any(cells):
            rows.append((line_no, cells))
    if not rows:
        raise InputError("is empty; write one time in seconds per frame (column t_s)", path=path)
    header = [c.lower() for c in rows[0][1]]
    epoch = header in (["t_unix_s"], ["file", "t_unix_s"])
    if epoch or header in (["t_s"], ["file", "t_s"]):
        rows = rows[1:]
    n_cols = len(header)
    if n_cols not in (1, 2):
        raise InputError(f"has {n_cols} columns, expected 1 (t_s) or 2 (file,t_s)", path=path,
                         where=f"line {rows[0][0] if rows else 1}")
    names: list[str] = []
    values = np.empty(len(rows), dtype=np.float64)
    for i, (line_no, cells) in enumerate(rows):
        if len(cells) != n_cols:
            raise InputError(f"has {len(cells)} columns, expected {n_cols} like the first row",
                             path=path, where=f"line {line_no}")
        try:
            values[i] = float(cells[-1])
        except ValueError:
            raise InputError(f"{cells[-1]!r} is not a time in seconds (a header, if any, must be "
                             "t_s, file,t_s, t_unix_s or file,t_unix_s)", path=path,
                             where=f"line {line_no}") from None
        if not np.isfinite(values[i]):
            raise InputError(f"time {cells[-1]!r} is not finite", path=path,
                             where=f"line {line_no}")
        if n_cols == 2:
            names.append(cells[0])
    if n_cols == 1:
        if len(values) != len(frames):
            raise InputError(f"has {len(values)} times but the folder has {len(frames)} frames; "
                             "write one row per frame, in frame name order", path=path)
        t_s = values
    else:
        index = {p.name: k for k, p in enumerate(frames)}
        t_s = np.full(len(frames), np.nan)
        for (line_no, _), name, value in zip(rows, names, values, strict=True):
            if name not in index:
                raise InputError(f"names {name!r}, which is not a frame in the folder",
                                 path=path, where=f"line {line_no}")
            if not np.isnan(t_s[index[name]]):
                raise InputError(f"names {name!r} a second time", path=path,
                                 where=f"line {line_no}")
            t_s[index[name]] = value
        missing = [frames[k].name for k in np.flatnonzero(np.isnan(t_s))]
        if missing:
            more = f" and {len(missing) - 3} more" if len(missing) > 3 else ""
            raise InputError(f"has no time for frame(s) {', '.join(missing[:3])}{more}; "
                             "give every frame a row", path=path)
    back = np.flatnonzero(np.diff(t_s) < 0)
    if back.size:
        k = int(back[0]) + 1
        raise InputError(f"frame {frames[k].name} (t_s = {t_s[k]}) is earlier than the frame "
                         f"before it, {frames[k - 1].name} (t_s = {t_s[k - 1]}); frames are read "
                         "in natural name order and their times must not decrease", path=path)
    if epoch:
        return FrameTimes(t_s=t_s - t_s[0], time_origin_unix_s=float(t_s[0]))
    return FrameTimes(t_s=t_s, time_origin_unix_s=None)


def load_rgb(path: Path) -> np.ndarray:
    """Decode one PNG/JPG file to (height, width, 3) uint8 RGB (conversions: module doc).

    Raises :class:`InputError` naming the file when it is not a readable 8-bit image.
    """
    from PIL import Image, UnidentifiedImageError  # imported when frames are decoded

    try:
        with Image.open(path) as im:
            if im.mode == "F" or im.mode.startswith("I"):
                raise InputError(f"is a 16-bit or floating-point image (mode {im.mode}); save the "
                                 "frames as 8-bit PNG", path=path)
            if im.mode in ("P", "PA") and "transparency" in im.info:
                # Pillow warns when a palette with transparency goes straight to RGB
                im = im.convert("RGBA")
            rgb = np.asarray(im.convert("RGB"), dtype=np.uint8)
    except UnidentifiedImageError:
        raise InputError("is not a PNG or JPG image Pillow can read (corrupt or mislabelled); "
                         "replace or remove the file", path=path) from None
    except (OSError, SyntaxError, ValueError, Image.DecompressionBombError) as exc:
        detail = " ".join(str(exc).split())
        raise InputError(f"cannot decode the image ({detail}); the file is corrupt or "
                         "truncated: replace or remove it", path=path) from None
    return rgb


def _check_size(image: np.ndarray, path: Path, size_hw: tuple[int, int], size_from: Path) -> None:
    h, w = image.shape[:2]
    if (h, w) != size_hw:
        raise InputError(f"image is {w}x{h} px (width x height) but {size_from} is "
                         f"{size_hw[1]}x{size_hw[0]} px; all frames and reference frames of one "
                         "ingest must share one size (ingest other sizes separately)", path=path)


def nominal_frame_rate_hz(folders: Sequence[ImageFolder]) -> float:
    """The sensor's nominal rate in Hz: 1 / the median positive frame interval over all
    trials (rounded to 1e-6 Hz, so evenly spaced 30 Hz times give 30.0), or
    :data:`DEFAULT_FRAME_RATE_HZ` when no trial has two distinct frame times."""
    intervals = np.concatenate([np.diff(f.t_s) for f in folders])
    intervals = intervals[intervals > 0]
    if not intervals.size:
        return DEFAULT_FRAME_RATE_HZ
    return round(float(1.0 / np.median(intervals)), 6)


def ingest_image_sequence(inputs: Sequence[Path], options: ImageFolderOptions,
                          writer: StoreWriter, progress: Progress) -> list[str]:
    """Add one visuotactile sensor and one trial per input folder to ``writer``.

    The sensor is named ``options.sensor_name`` (default ``visuotactile``); its size
    comes from the frames and must match ``options.width_px``/``height_px`` when given.
    An input folder that holds image-sequence folders rather than frames stands for them
    (:func:`image_sequence_folders`). Progress counts frames. Returns the notes for the
    user: one line when frame times were assumed (folders without ``timestamps.csv`` and no
    ``frame_rate_hz``), naming the rate and how to give the real one.
    """
    px_per_mm = options.px_per_mm
    if px_per_mm is not None and not (np.isfinite(px_per_mm) and px_per_mm > 0):
        raise InputError(f"`px_per_mm` (={px_per_mm}) must be a positive number of pixels per "
                         "millimetre")
    folders = scan_inputs(inputs, options)
    first_ref = folders[0].reference
    reference0 = load_rgb(first_ref)
    size_hw = (int(reference0.shape[0]), int(reference0.shape[1]))
    for option, value, actual in (("`width_px`", options.width_px, size_hw[1]),
                                  ("`height_px`", options.height_px, size_hw[0])):
        if value is not None and value != actual:
            raise InputError(f"{option} is {value} px but the frames are "
                             f"{size_hw[1]}x{size_hw[0]} px (width x height); drop {option} or "
                             "fix it", path=first_ref)
    sensor = writer.add_sensor(
        options.sensor_name or "visuotactile", kind="visuotactile",
        sample_rate_hz=nominal_frame_rate_hz(folders), width_px=size_hw[1], height_px=size_hw[0],
        description="visuotactile camera frames ingested from image-sequence folders",
        px_per_mm=None if px_per_mm is None else float(px_per_mm))
    progress.start(sum(len(f.frames) for f in folders), "frames")
    for folder in folders:
        _write_trial(folder, writer, sensor, size_hw, first_ref, progress)
    progress.finish()
    return assumed_rate_notes(folders)


def scan_inputs(inputs: Sequence[Path], options: ImageFolderOptions) -> list[ImageFolder]:
    """Every trial folder of the inputs, scanned (:func:`scan_image_folder`); an input
    folder that holds image-sequence folders stands for them."""
    # a folder with neither frames nor sequence folders is scanned as it is, for its error
    trial_folders = [f for p in inputs for f in ((image_sequence_folders(p) or [p])
                                                 if p.is_dir() else [p])]
    scanned = [scan_image_folder(p, frame_rate_hz=options.frame_rate_hz,
                                 reference_name=options.reference) for p in trial_folders]
    names = folder_trial_names([f.folder for f in scanned])
    return [f if f.trial_name == n else replace(f, name=n) for f, n in zip(scanned, names,
                                                                           strict=True)]


def folder_trial_names(folders: Sequence[Path]) -> list[str]:
    """One trial name per frame folder: the folders' names, or, when two names are equal
    (``object001/066_60_mm`` and ``object002/066_60_mm``, as lift sets keep one folder per
    object), each folder's path below the folders' common folder, parts joined by ``__``
    (``object001__066_60_mm``), so that a trial-label table can name each one."""
    resolved = [f.resolve() for f in folders]
    names = [f.name for f in resolved]
    if len(set(names)) == len(names):
        return names
    common = Path(os.path.commonpath([f.parent for f in resolved]))
    return ["__".join(f.relative_to(common).parts) for f in resolved]


def assumed_rate_notes(folders: Sequence[ImageFolder]) -> list[str]:
    """One note naming the folders whose frame times were assumed evenly spaced, the rate
    assumed and how to give the real one (empty list when no time was assumed)."""
    assumed = [f for f in folders if f.frame_rate_assumed_hz is not None]
    if not assumed:
        return []
    rate = assumed[0].frame_rate_assumed_hz
    if len(assumed) == 1:
        who, where = f"{assumed[0].trial_name} has", "the folder"
    else:
        more = f" and {len(assumed) - 3} more" if len(assumed) > 3 else ""
        names = ", ".join(f.trial_name for f in assumed[:3]) + more
        who, where = f"{len(assumed)} folders ({names}) have", "each folder"
    return [f"{who} no {TIMESTAMPS_FILE}: frames taken as evenly spaced at {rate:g} Hz "
            "(DIGIT's rate; recorded as the trial attribute frame_rate_assumed_hz); give the "
            f"real rate with `frame_rate_hz=HZ`, or a {TIMESTAMPS_FILE} (t_s per frame) in "
            f"{where}"]


def _write_trial(folder: ImageFolder, writer: StoreWriter, sensor: str, size_hw: tuple[int, int],
                 size_from: Path, progress: Progress) -> None:
    reference = load_rgb(folder.reference)
    _check_size(reference, folder.reference, size_hw, size_from)
    extra: dict[str, float] = {}
    if folder.frame_rate_assumed_hz is not None:
        extra["frame_rate_assumed_hz"] = folder.frame_rate_assumed_hz
    if folder.time_origin_unix_s is not None:
        extra["time_origin_unix_s"] = folder.time_origin_unix_s
    trial = writer.trial(folder.trial_name, **extra)
    if folder.labels:
        trial.set_labels(**dict(folder.labels))
    if folder.split is not None:
        trial.set_split(folder.split)
    appender = trial.frames(sensor, reference=reference)
    n_batch = max(1, min(len(folder.frames), FRAME_BATCH_BYTES // reference.nbytes))
    batch = np.empty((n_batch, *reference.shape), dtype=np.uint8)
    sources: list[int] = []
    fill = 0
    for k, path in enumerate(folder.frames):
        sources.append(writer.add_source(path))
        frame = load_rgb(path)
        _check_size(frame, path, size_hw, size_from)
        batch[fill] = frame
        fill += 1
        if fill == n_batch or k == len(folder.frames) - 1:
            appender.append(batch[:fill], folder.t_s[k + 1 - fill:k + 1])
            fill = 0
        progress.advance(1)
    appender.close()
    sources.append(writer.add_source(folder.reference))
    if folder.timestamps_file is not None:
        sources.append(writer.add_source(folder.timestamps_file))
    if folder.labels_file is not None:
        sources.append(writer.add_source(folder.labels_file))
    # set after streaming: the writer's trial() takes sources up front, which would mean
    # hashing every frame before the first one is decoded
    trial.set_sources(sources)


def describe_image_folders(path: Path, options: ImageFolderOptions,
                           fmt: IngestFormat) -> RecordingSummary:
    """The trials of an image-sequence folder (or a folder of them), read-only: the layout,
    reference, timestamps and labels checked as an ingest does; the frame size read from
    the first reference's header (no frame is decoded)."""
    from PIL import Image

    folders = scan_inputs([path], options)
    width = height = None
    try:
        with Image.open(folders[0].reference) as im:
            width, height = im.size
    except (OSError, SyntaxError, ValueError, Image.DecompressionBombError):
        pass  # the ingest names a frame it cannot decode; the summary leaves the size out
    trials, intervals, size = [], [], 0
    for f in folders:
        files = [*f.frames, f.reference]
        size += sum(p.stat().st_size for p in files)
        trials.append(TrialSummary(
            name=f.trial_name, source=str(f.folder), counts={"frames": len(f.frames)},
            duration_s=float(f.t_s[-1] - f.t_s[0]) if len(f.t_s) else None,
            labels=dict(f.labels)))
        intervals.append(f.t_s)
    stats = [stamp_stats(t) for t in intervals]
    steps = np.concatenate([np.diff(t) for t in intervals])
    positive = steps[steps > 0]
    stream = StreamSummary(
        name="frames", type="frames", count=sum(len(f.frames) for f in folders), unit="frames",
        rate_hz=float(1.0 / np.median(positive)) if len(positive) else None,
        jitter_s=interval_jitter_s(steps),
        t_first_s=float(folders[0].t_s[0]) if len(folders) == 1 else None,
        t_last_s=float(folders[0].t_s[-1]) if len(folders) == 1 else None,
        span_s=sum(t.duration_s or 0.0 for t in trials), size_bytes=size, width_px=width,
        height_px=height, repeated_stamps=sum(st.n_repeated for st in stats),
        out_of_order_stamps=sum(st.n_out_of_order for st in stats),
        extra={"references": sorted({f.reference.name for f in folders}, key=natural_key),
               "timestamps_files": sum(f.timestamps_file is not None for f in folders)})
    notes = assumed_rate_notes(folders)
    if options.px_per_mm is None:
        notes.append("no `px_per_mm`: the visuotactile calibration and height maps need the "
                     "gel's scale (pixels per millimetre; DIGIT-like: 16)")
    return RecordingSummary(file=str(path), format=fmt.name, title=fmt.title, size_bytes=size,
                            streams=[stream], trials=trials, notes=notes)


class ImageFolderFormat(IngestFormat[ImageFolderOptions]):
    """Image-sequence folders of visuotactile sensors (see the module docstring)."""

    name = "images"
    title = "image-sequence folder"
    summary = ("folders of PNG/JPG frames with a no-contact reference frame (DIGIT, "
               "GelSight), or a folder of such folders; one trial per folder")
    Options = ImageFolderOptions

    def sniff(self, path: Path) -> bool:
        """A folder with PNG/JPG frames in it or in one of its subfolders."""
        try:
            if not path.is_dir():
                return False
            return has_image_files(path) or any(
                p.is_dir() and not p.name.startswith(".") and has_image_files(p)
                for p in path.iterdir())
        except OSError:
            return False

    def describe(self, path: Path, options: ImageFolderOptions) -> RecordingSummary:
        return describe_image_folders(path, options, self)

    def read(self, inputs: Sequence[Path], options: ImageFolderOptions, writer: StoreWriter,
             progress: Progress) -> list[str]:
        return ingest_image_sequence(inputs, options, writer, progress)


IMAGES = ImageFolderFormat()

__all__ = [
    "DEFAULT_FRAME_RATE_HZ",
    "IMAGES",
    "IMAGE_SUFFIXES",
    "FrameTimes",
    "ImageFolderFormat",
    "ImageFolderOptions",
    "assumed_rate_notes",
    "describe_image_folders",
    "folder_trial_names",
    "has_image_files",
    "image_sequence_folders",
    "REFERENCE_STEMS",
    "TIMESTAMPS_FILE",
    "LABELS_FILE",
    "REFERENCE_FIRST",
    "read_folder_labels",
    "ImageFolder",
    "ingest_image_sequence",
    "load_rgb",
    "nominal_frame_rate_hz",
    "read_timestamps",
    "scan_image_folder",
    "scan_inputs",
]
