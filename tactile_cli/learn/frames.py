"""Image sequences as a window input (issue 35, item 1): ``data.stream: frames``.

A trial's image frames (``/trials/{trial}/frames``, written by ``tactile ingest`` from
image folders or by the simulators) become a series of ``n_frames`` samples of
``planes x height x width`` channels: each frame minus the reference frame (the stored
no-contact frame, or the trial's first frame), area-averaged down to the configured size
(every output pixel the mean of the camera pixels it covers; sizes need not divide), in
levels of the 8-bit camera (-255 to 255), grey (ITU-R BT.601 luma of the difference) or
red, green and blue. The values are plane-major (all of plane 0's rows, then plane 1's),
so ``window.reshape(W, planes, height, width)`` restores the images; a channel is named
``<plane>_r<row>_c<col>`` (:func:`frame_channel_names`). The sample period is the median
step of the frame times (``step`` times it when only every ``step``-th frame is kept).
From there the frames are windows like any stream: the same
splits, normalisation (per pixel, from the training trials), windows, evaluation,
perturbation and export.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..errors import InputError
from ..store.trials import Frames
from .config import FramesConfig

#: ITU-R BT.601 luma weights of red, green and blue.
LUMA = np.array([0.299, 0.587, 0.114], dtype=np.float32)
#: The unit of every frame channel of a difference of levels (``change: flow``: px).
FRAME_UNIT = "levels"


def frame_channel_names(cfg: FramesConfig) -> list[str]:
    """The channel names of the frame input, plane-major then row-major:
    ``grey_r00_c00``, ``grey_r00_c01``, ... (digits padded to the largest index)."""
    rd, cd = len(str(cfg.height - 1)), len(str(cfg.width - 1))
    return [f"{p}_r{r:0{rd}d}_c{c:0{cd}d}" for p in cfg.planes
            for r in range(cfg.height) for c in range(cfg.width)]


def area_downsample(image: np.ndarray, height: int, width: int) -> np.ndarray:
    """(H, W, P) -> (height, width, P) float32: each output pixel the mean of the input
    pixels whose rows ``[i H / height, (i + 1) H / height)`` (floored) and columns it
    covers; ``height <= H`` and ``width <= W``."""
    h0, w0 = image.shape[:2]
    if height > h0 or width > w0:
        raise ValueError(f"cannot downsample {h0} x {w0} to {height} x {width}")
    rows = (np.arange(height) * h0) // height
    cols = (np.arange(width) * w0) // width
    summed = np.add.reduceat(np.add.reduceat(image.astype(np.float64), rows, axis=0),
                             cols, axis=1)
    counts = np.diff(np.append(rows, h0))[:, None] * np.diff(np.append(cols, w0))[None, :]
    return (summed / counts[:, :, None]).astype(np.float32)


def _grey(image: np.ndarray) -> np.ndarray:
    """(H, W, 3) pixels -> (H, W) float64 luma."""
    return image.astype(np.float64) @ LUMA.astype(np.float64)


def _planes(small: np.ndarray, cfg: FramesConfig) -> np.ndarray:
    """(height, width, 3) -> (planes * height * width,) plane-major."""
    if not cfg.colour:
        small = _grey(small)[:, :, None]
    return np.ascontiguousarray(small.transpose(2, 0, 1), dtype=np.float32).reshape(-1)


def frame_difference(image: np.ndarray, reference: np.ndarray, cfg: FramesConfig
                     ) -> np.ndarray:
    """One (H, W, 3) uint8 frame minus the reference -> (planes * height * width,)
    float32 values, plane-major. Area means and luma are linear, so the frame and the
    reference are each reduced first and then subtracted (the same values, up to float
    rounding, as reducing the difference; far fewer operations)."""
    return (_planes(area_downsample(image, cfg.height, cfg.width), cfg)
            - _planes(area_downsample(reference, cfg.height, cfg.width), cfg))


def frame_series(frames: Frames, cfg: FramesConfig) -> np.ndarray:
    """(ceil(n_frames / step), planes * height * width) float32: every ``step``-th frame
    of a trial (all by default) as its difference from the reference (or, with ``change:
    previous``, from the kept frame before it)
    (:class:`~.config.FramesConfig`); InputError naming the trial when the frames are
    smaller than the configured size or there is no stored reference for
    ``reference: stored``."""
    h0, w0 = frames.shape[:2]
    if cfg.height > h0 or cfg.width > w0:
        raise InputError(f"frames of {w0} x {h0} px are smaller than data.frames "
                         f"({cfg.width} x {cfg.height}); set data.frames.width and height "
                         "to at most the camera's", path=frames.path, where=frames.where)
    if frames.n_frames == 0:
        return np.zeros((0, cfg.n_values), np.float32)
    if cfg.reference == "first":
        reference = frames[0]
    else:
        try:
            reference = frames.reference
        except (KeyError, InputError):
            raise InputError("the trial stores no reference frame; set data.frames.reference: "
                             "first, or ingest the folder with its no-contact frame",
                             path=frames.path,
                             where=frames.where) from None
    kept = range(0, frames.n_frames, cfg.step)
    if cfg.change == "flow":
        return _flow_series(frames, reference, kept, cfg)
    ref = _planes(area_downsample(reference, cfg.height, cfg.width), cfg)
    out = np.empty((len(kept), cfg.n_values), np.float32)
    for i, k in enumerate(kept):
        small = _planes(area_downsample(frames[k], cfg.height, cfg.width), cfg)
        out[i] = small - ref
        if cfg.change == "previous":
            ref = small
    return out


def _flow_series(frames: Frames, reference: np.ndarray, kept: range, cfg: FramesConfig
                 ) -> np.ndarray:
    """(len(kept), 2 * height * width) float32: each kept frame's block shifts (dy plane,
    then dx plane) since the kept frame before it (the first: since the reference)."""
    from .frame_flow import MIN_BLOCK_PX, block_shifts, block_size

    bh, bw = block_size(frames.shape[0], frames.shape[1], cfg.height, cfg.width)
    if min(bh, bw) < MIN_BLOCK_PX:
        raise InputError(f"data.frames with `change: flow` cuts {frames.shape[1]} x "
                         f"{frames.shape[0]} px frames into {cfg.width} x {cfg.height} blocks "
                         f"of {bw} x {bh} px; a block needs at least {MIN_BLOCK_PX} px a "
                         "side: lower data.frames.width and height", path=frames.path,
                         where=frames.where)
    before = _grey(reference)
    out = np.empty((len(kept), cfg.n_values), np.float32)
    for i, k in enumerate(kept):
        grey = _grey(frames[k])
        out[i] = block_shifts(before, grey, cfg.height, cfg.width).transpose(2, 0, 1).ravel()
        before = grey
    return out


def select_columns(values: np.ndarray, names: Sequence[str], channels: Sequence[str]
                   ) -> np.ndarray:
    """The columns of ``values`` (named ``names``) in the order of ``channels``."""
    index = {n: i for i, n in enumerate(names)}
    if list(channels) == list(names):
        return values
    return np.ascontiguousarray(values[:, [index[c] for c in channels]])


__all__ = ["FRAME_UNIT", "LUMA", "area_downsample", "frame_channel_names",
           "frame_difference", "frame_series", "select_columns"]
