"""A tiny synthetic visuotactile press: an image-sequence folder as `tactile ingest` reads it.

The reference (no-contact) frame mimics a DIGIT-style gel lit by coloured LEDs from
different sides (smooth red/green/blue gradients, paper 002 sec. II); each frame adds a
contact imprint, a dome-shaped colour change whose radius grows frame by frame as an
object presses in. The layout follows :mod:`tactile_cli.ingest.image_sequence`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

import numpy as np
from PIL import Image

#: Colour change (R, G, B) at the centre of the imprint, in 8-bit levels.
IMPRINT_RGB = np.array([60.0, -35.0, 45.0])


def write_image_sequence(
    folder: str | Path,
    *,
    n_frames: int,
    width: int,
    height: int,
    seed: int,
    fmt: Literal["png", "jpg"] = "png",
    mode: Literal["RGB", "L", "RGBA"] = "RGB",
    frame_rate_hz: float | None = None,
) -> dict[str, Any]:
    """Write ``reference.<fmt>`` and ``frame_0.<fmt>`` ... ``frame_{n-1}.<fmt>`` (names not
    zero-padded, so reading them needs natural order) into ``folder`` (created if needed).

    mode: pixel format of the files: ``"L"`` grayscale and ``"RGBA"`` (alpha 128, PNG only)
    test the conversion to RGB. frame_rate_hz: when given, a ``timestamps.csv`` (header
    ``t_s``) with frames evenly spaced at this rate is written; otherwise none, and the
    returned times are those the ingest assumes (30 Hz).

    Returns the ground truth as ingest should store it: ``images`` (n_frames, height, width, 3)
    uint8 RGB, ``reference`` (height, width, 3) uint8 RGB, ``t_s`` (n_frames,) float64 s,
    ``frame_files`` (list of paths in frame order), ``reference_file``, ``timestamps_file``
    (path or None) and ``contact_radius_px`` (n_frames,). PNG is lossless, so a PNG round
    trip is exact; JPG is lossy and its pixels only approximate the returned arrays.
    """
    if n_frames < 1 or width < 1 or height < 1:
        raise ValueError(f"`n_frames`, `width`, `height` (={n_frames}, {width}, {height}) "
                         "must all be >= 1")
    if fmt not in ("png", "jpg"):
        raise ValueError(f"`fmt` (={fmt!r}) must be 'png' or 'jpg'")
    if mode not in ("RGB", "L", "RGBA"):
        raise ValueError(f"`mode` (={mode!r}) must be 'RGB', 'L' or 'RGBA'")
    if fmt == "jpg" and mode == "RGBA":
        raise ValueError("`mode` 'RGBA' needs `fmt` 'png' (JPEG has no alpha channel)")
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)

    y, x = np.mgrid[0:height, 0:width].astype(np.float64)
    u, v = x / max(1, width - 1), y / max(1, height - 1)
    background = np.stack([90 + 70 * u, 80 + 70 * v, 150 - 60 * np.hypot(u - 0.5, v - 0.5)],
                          axis=-1)
    reference_f = background + rng.normal(0.0, 2.0, background.shape)

    cx, cy = rng.uniform(0.35, 0.65) * (width - 1), rng.uniform(0.35, 0.65) * (height - 1)
    r_max = 0.3 * min(width, height)
    radius_px = r_max * np.arange(1, n_frames + 1) / n_frames
    d2 = (x - cx) ** 2 + (y - cy) ** 2
    # (n_frames, height, width) dome depth in [0, 1] for every frame at once
    dome = np.clip(1.0 - d2[None] / np.maximum(radius_px, 0.5)[:, None, None] ** 2, 0.0, 1.0)
    frames_f = (background[None] + dome[..., None] * IMPRINT_RGB
                + rng.normal(0.0, 2.0, (n_frames, height, width, 3)))

    reference, images = _quantise(reference_f, mode), _quantise(frames_f, mode)
    suffix = "jpg" if fmt == "jpg" else "png"
    reference_file = folder / f"reference.{suffix}"
    _save(reference, reference_file, mode)
    frame_files = []
    for k in range(n_frames):
        path = folder / f"frame_{k}.{suffix}"
        _save(images[k], path, mode)
        frame_files.append(path)

    rate = 30.0 if frame_rate_hz is None else float(frame_rate_hz)
    t_s = np.arange(n_frames, dtype=np.float64) / rate
    timestamps_file = None
    if frame_rate_hz is not None:
        timestamps_file = folder / "timestamps.csv"
        timestamps_file.write_text("t_s\n" + "".join(f"{t!r}\n" for t in t_s.tolist()))
    return {"images": images, "reference": reference, "t_s": t_s, "frame_files": frame_files,
            "reference_file": reference_file, "timestamps_file": timestamps_file,
            "contact_radius_px": radius_px}


def _quantise(rgb: np.ndarray, mode: str) -> np.ndarray:
    """(..., 3) float levels to uint8 RGB as ingest will see them: for ``L`` one gray level
    (ITU-R 601 luma) replicated to three channels."""
    if mode == "L":
        gray = rgb @ np.array([0.299, 0.587, 0.114])
        rgb = np.repeat(gray[..., None], 3, axis=-1)
    return np.clip(np.rint(rgb), 0, 255).astype(np.uint8)


def _save(rgb: np.ndarray, path: Path, mode: str) -> None:
    # Image.fromarray infers L / RGB / RGBA from the array shape (its mode= is deprecated)
    if mode == "L":
        pixels = np.ascontiguousarray(rgb[..., 0])
    elif mode == "RGBA":
        alpha = np.full((*rgb.shape[:2], 1), 128, dtype=np.uint8)  # not opaque: alpha is dropped
        pixels = np.concatenate([rgb, alpha], axis=-1)
    else:
        pixels = rgb
    options = {"quality": 95} if path.suffix == ".jpg" else {}
    Image.fromarray(pixels).save(path, **options)


__all__ = ["write_image_sequence"]
