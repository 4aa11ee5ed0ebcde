"""Videos of camera-based tactile sensors (DIGIT, GelSight; Touch and Go keeps one
``video.mp4`` per touch) into the tactile store: one trial per video file.

Read with PyAV (``av``): FFmpeg's demuxers and decoders in-process (every container and codec
labs record with: MP4/H.264, AVI/MJPEG, MKV/FFV1, MOV), with each frame's presentation
timestamp from the container, no ffmpeg executable and no temporary files, one decoded frame
at a time (memory stays bounded). OpenCV, the usual alternative, gives no reliable per-frame
timestamps for variable-frame-rate files.

- **Inputs**: a video file (``.mp4``, ``.avi``, ``.mov``, ``.mkv``, ``.webm``, ``.m4v``), or a
  folder of them (one trial per file, natural name order); the first video stream of each
  file is read. A trial is named by its file stem; when stems repeat (``exp_1/camera_0.avi``,
  ``exp_2/camera_0.avi``, as labs keep one folder per experiment) every trial is named by its
  path below the inputs' common folder, parts joined by ``__`` (``exp_1__camera_0``), so a
  trial-label table can name each one (:func:`video_trial_names`).
- **Frame times** (``t_s``): every frame's presentation timestamp (pts x the stream's time
  base), relative to the first frame (the container's start offset is kept as the trial
  attribute ``video_start_s`` when it is not 0); variable frame rates are kept as they are.
  A frame without a timestamp, or timestamps that go back, are errors naming the frame.
- **Pixels**: decoded to (height, width, 3) uint8 RGB; every video of one ingest shares one
  size, which becomes the sensor's ``width_px``/``height_px``.
- **Reference** (``reference``): ``first`` (the default) or the index of the frame of each
  video that shows the gel without contact; it stays a frame of the sequence.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..natural import natural_key
from ..progress import Progress
from ..store.writer import StoreWriter
from .contract import FormatOptions, IngestFormat, RecordingSummary, StreamSummary, TrialSummary
from .stamps import interval_jitter_s, stamp_stats

#: Suffixes of the videos read (lower case).
VIDEO_SUFFIXES = (".mp4", ".avi", ".mov", ".mkv", ".webm", ".m4v")
#: Decoded frames held before one write (bytes of RGB).
FRAME_BATCH_BYTES = 8 << 20


class VideoOptions(FormatOptions):
    """Options of the video format."""

    sensor_name: str | None = None
    """Name of the visuotactile sensor (default ``visuotactile``)."""
    reference: str | None = None
    """The no-contact reference frame of every video: ``first`` (the default) or a frame
    index (0-based); the reference stays a frame of the sequence."""
    px_per_mm: float | None = None
    """Pixels per millimetre on the gel, stored as the sensor attribute ``px_per_mm``."""


def video_files(path: Path) -> list[Path]:
    """The videos an input stands for: itself, or a folder's videos in natural name order."""
    if path.is_dir():
        return sorted((p for p in path.iterdir() if p.is_file() and not p.name.startswith(".")
                       and p.suffix.lower() in VIDEO_SUFFIXES), key=lambda p: natural_key(p.name))
    return [path]


def video_trial_names(files: Sequence[Path]) -> list[str]:
    """One trial name per video: the file stems, or, when two stems are equal, each file's
    path below the files' common folder without its suffix, parts joined by ``__``."""
    stems = [f.stem for f in files]
    if len(set(stems)) == len(stems):
        return stems
    resolved = [f.resolve() for f in files]
    common = Path(os.path.commonpath([f.parent for f in resolved]))
    return ["__".join(f.relative_to(common).with_suffix("").parts) for f in resolved]


def _reference_index(options: VideoOptions) -> int:
    ref = options.reference
    if ref is None or ref == "first":
        return 0
    if ref.isdigit():
        return int(ref)
    raise InputError(f"`reference` (={ref!r}) must be `first` or a frame index (0, 1, ...) "
                     "for videos")


def _errors() -> tuple[type[BaseException], ...]:
    import av

    return (av.error.FFmpegError, ValueError, OSError)


def _open(path: Path) -> Any:
    from .robot_recording import require_robot_extra

    require_robot_extra("videos", ("av",))
    import av

    try:
        container = av.open(str(path))
    except _errors() as exc:
        detail = " ".join(str(exc).split())
        raise InputError(f"cannot open the video ({detail}); the file is damaged or not a "
                         "video", path=path) from None
    if not container.streams.video:
        container.close()
        raise InputError("holds no video stream", path=path)
    return container


def _damaged(path: Path, exc: BaseException, k: int) -> InputError:
    detail = " ".join(str(exc).split())
    return InputError(f"cannot decode the video after {k} frame(s) ({detail}); the file is "
                      "damaged or cut short", path=path)


def _frames(path: Path) -> Any:
    """``(k, t_s, rgb)`` of every frame of the first video stream, t_s from its pts."""
    container = _open(path)
    try:
        stream = container.streams.video[0]
        base = stream.time_base
        k = 0
        try:
            for frame in container.decode(stream):
                if frame.pts is None:
                    raise InputError(f"frame {k} has no presentation timestamp", path=path)
                yield k, float(frame.pts * base), frame.to_ndarray(format="rgb24")
                k += 1
        except _errors() as exc:
            raise _damaged(path, exc, k) from None
        if k == 0:
            raise InputError("holds no video frames (empty or undecodable stream)", path=path)
    finally:
        container.close()


def ingest_videos(inputs: Sequence[Path], options: VideoOptions, writer: StoreWriter,
                  progress: Progress) -> list[str]:
    """One visuotactile sensor and one trial per video (module docstring)."""
    ref_index = _reference_index(options)
    files = [f for p in inputs for f in video_files(p)]
    if not files:
        raise InputError(f"holds no videos ({', '.join(VIDEO_SUFFIXES)})", path=inputs[0])
    sensor = options.sensor_name or "visuotactile"
    size: tuple[int, int] | None = None
    intervals: list[np.ndarray] = []
    progress.start(len(files), "videos")
    for path, name in zip(files, video_trial_names(files), strict=True):
        source = writer.add_source(path)
        trial = writer.trial(name, sources=[source])
        pending: list[np.ndarray] = []
        times: list[float] = []
        all_t: list[float] = []
        appender = None
        t0 = None
        for k, t, rgb in _frames(path):
            if size is None:
                size = rgb.shape[:2]
            elif rgb.shape[:2] != size:
                raise InputError(f"frame {k} is {rgb.shape[1]}x{rgb.shape[0]} px but the videos "
                                 f"before are {size[1]}x{size[0]} px; ingest other sizes "
                                 "separately", path=path)
            if t0 is None:
                t0 = t
                if t0 != 0:
                    trial.group.attrs["video_start_s"] = t0
            if all_t and t - t0 < all_t[-1]:
                raise InputError(f"frame {k}'s timestamp ({t:.6f} s) is earlier than the frame "
                                 "before it; the container's timestamps are damaged",
                                 path=path)
            all_t.append(t - t0)
            pending.append(rgb)
            times.append(t - t0)
            if appender is None and len(pending) > ref_index:
                appender = trial.frames(sensor, reference=pending[ref_index])
            if appender is not None and len(pending) * rgb.nbytes >= FRAME_BATCH_BYTES:
                appender.append(np.stack(pending), np.asarray(times))
                pending, times = [], []
        if appender is None:
            raise InputError(f"has {len(all_t)} frame(s), so there is no frame {ref_index} to "
                             "take as the reference; lower `reference`", path=path)
        if pending:
            appender.append(np.stack(pending), np.asarray(times))
        appender.close()
        intervals.append(np.diff(all_t))
        progress.advance(1)
    progress.finish()
    steps = np.concatenate(intervals)
    positive = steps[steps > 0]
    rate = round(float(1.0 / np.median(positive)), 6) if len(positive) else 0.0
    assert size is not None
    px = options.px_per_mm
    writer.add_sensor(sensor, kind="visuotactile", sample_rate_hz=rate, width_px=size[1],
                      height_px=size[0], description="camera frames ingested from video",
                      px_per_mm=None if px is None else float(px))
    return []


def describe_videos(path: Path, options: VideoOptions, fmt: IngestFormat[Any]) -> RecordingSummary:
    """Codec, size, frame count and rate of every video, from the container's packets (no
    frame is decoded)."""
    files = video_files(path)
    if not files:
        raise InputError(f"holds no videos ({', '.join(VIDEO_SUFFIXES)})", path=path)
    streams, trials, total = [], [], 0
    for f, name in zip(files, video_trial_names(files), strict=True):
        container = _open(f)
        try:
            stream = container.streams.video[0]
            base = stream.time_base
            pts = [p.pts for p in container.demux(stream) if p.pts is not None]
            codec = stream.codec_context.name
            width, height = stream.codec_context.width, stream.codec_context.height
        except _errors() as exc:
            raise _damaged(f, exc, 0) from None
        finally:
            container.close()
        t = np.sort(np.asarray(pts, dtype=np.float64)) * float(base)
        stats = stamp_stats(t)
        size = f.stat().st_size
        total += size
        streams.append(StreamSummary(
            name=name, type="frames", count=len(t), unit="frames", rate_hz=stats.rate_hz,
            jitter_s=interval_jitter_s(np.diff(t)), t_first_s=float(t[0]) if len(t) else None,
            t_last_s=float(t[-1]) if len(t) else None,
            span_s=float(t[-1] - t[0]) if len(t) else None, size_bytes=size, width_px=width,
            height_px=height, extra={"codec": codec, "file": f.name}))
        trials.append(TrialSummary(name=name, source=str(f), counts={"frames": len(t)},
                                   duration_s=float(t[-1] - t[0]) if len(t) else None))
    notes = [] if any(s.count for s in streams) else ["no video frames in the file(s)"]
    return RecordingSummary(file=str(path), format=fmt.name, title=fmt.title, size_bytes=total,
                            streams=streams, trials=trials, notes=notes)


class VideoFormat(IngestFormat[VideoOptions]):
    """Video files of camera-based tactile sensors (module docstring)."""

    name = "video"
    title = "video"
    summary = ("video files (.mp4, .avi, .mov, .mkv, ...) of a camera-based sensor, or a folder "
               "of them; one trial per video, frame times from the container")
    suffixes = VIDEO_SUFFIXES
    Options = VideoOptions

    def sniff(self, path: Path) -> bool:
        try:
            if path.is_dir():
                return any(p.suffix.lower() in VIDEO_SUFFIXES and p.is_file()
                           for p in path.iterdir())
            return path.suffix.lower() in VIDEO_SUFFIXES
        except OSError:
            return False

    def describe(self, path: Path, options: VideoOptions) -> RecordingSummary:
        return describe_videos(path, options, self)

    def read(self, inputs: Sequence[Path], options: VideoOptions, writer: StoreWriter,
             progress: Progress) -> list[str]:
        return ingest_videos(inputs, options, writer, progress)


VIDEO = VideoFormat()

__all__ = ["VIDEO", "VIDEO_SUFFIXES", "VideoFormat", "VideoOptions", "describe_videos",
           "ingest_videos", "video_files", "video_trial_names"]
