"""Inputs of the slip-avoidance monitor (paper 002, secs. III and V): per-frame maps the
slip signal is taken on, and per-frame gripper-motion flags.

- ``intensity`` source (:func:`intensity_maps`): the frame's relative brightness change
  from the no-contact reference (percent), the background's change (LED flicker) removed
  and smoothed against camera noise -- a model-free stand-in for the height map;
- ``height`` source: height maps reconstructed by the trained normal network and the
  Poisson integration (:mod:`.normals`, :mod:`.heightmap`);
- :func:`mesh_slip_signal`: the slip signal of eq. (4) on a ``cols x rows`` mesh,
  computed by :func:`tactile_cli.visuotactile.mesh.slip_signal`;
- :func:`moving_flags`: which frames' signals include gripper motion, from intervals.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .mesh import slip_signal

#: The paper's default tactile mesh (columns, rows): one pixel in ten of 320 x 240.
DEFAULT_MESH = (32, 24)
#: Gaussian smoothing (px) of the intensity maps: with DIGIT-like camera noise (2 of 255)
#: the raw pixels' frame-to-frame noise summed over the mesh hides a slip (peaks about
#: 1.5 x the static signal on the avoidance scene, seed 1); smoothed by 2 px and with the
#: flicker removed, 3.4-6 x while quiet frames stay below 1.5 x.
INTENSITY_SMOOTH_PX = 2.0
#: Slip-signal sources of ``tactile monitor``.
SOURCES = ("intensity", "height")


def intensity_maps(frames: np.ndarray, reference: np.ndarray, *,
                   smooth_px: float = INTENSITY_SMOOTH_PX) -> np.ndarray:
    """(n, H, W, 3) uint8 frames and their (H, W, 3) uint8 reference -> (n, H, W) float32
    relative brightness change in percent: ``100 * ((I + 1) / (I_ref + 1) - 1)`` with ``I``
    the mean of R, G, B, minus each frame's median (the untouched background: a change of
    the LEDs' brightness scales the whole frame and would otherwise reach every mesh
    unit), smoothed by a Gaussian of ``smooth_px`` px (0: none) against camera noise."""
    frames = np.asarray(frames)
    bright = _channel_mean(frames)
    ref = _channel_mean(np.asarray(reference))
    maps = 100.0 * ((bright + 1.0) / (ref + 1.0) - 1.0)
    maps -= np.median(maps.reshape(maps.shape[0], -1), axis=1)[:, None, None]
    if smooth_px > 0:
        from scipy.ndimage import gaussian_filter

        maps = gaussian_filter(maps, (0, smooth_px, smooth_px), mode="nearest")
    return maps.astype(np.float32, copy=False)


def _channel_mean(images: np.ndarray) -> np.ndarray:
    """(..., C) -> (...) float32 mean over the last axis, equal to ``images.mean(axis=-1,
    dtype=np.float32)`` bit for bit (the float32 sum of C values of 0-255 is exact, then
    one division) and several times faster than numpy's reduction over a short last axis
    (15 ms against about 3 ms for a 640 x 480 RGB frame)."""
    n = images.shape[-1]
    if not (images.dtype in (np.uint8, np.uint16) and n * 65535 < 2**24):
        return images.mean(axis=-1, dtype=np.float32)  # sums that may round: numpy's order
    out = images[..., 0].astype(np.float32)
    for c in range(1, n):
        out += images[..., c]
    out /= np.float32(n)
    return out


def mesh_slip_signal(maps: np.ndarray, mesh: tuple[int, int] = DEFAULT_MESH) -> np.ndarray:
    """Slip signal of (n, H, W) maps on a ``(cols, rows)`` mesh: (n,) float, the first
    value NaN (no previous frame); see :func:`.mesh.slip_signal`."""
    return np.asarray(slip_signal(maps, mesh=mesh), dtype=np.float64)


def moving_flags(t_s: np.ndarray, intervals: Sequence[tuple[float, float]]) -> np.ndarray:
    """(n,) bool: True where frame ``k``'s slip signal (the change from frame ``k - 1``)
    spans gripper motion, i.e. the interval ``(t[k-1], t[k]]`` meets a motion interval
    ``[start, end]``: ``t[k] > start and t[k-1] < end`` (``t[-1]`` taken as -inf). The
    frame at which a command is given (``t[k] == start``) is not moving: the change it
    shows came before the command."""
    t = np.asarray(t_s, dtype=np.float64)
    prev = np.concatenate([[-np.inf], t[:-1]])
    flags = np.zeros(t.shape, dtype=bool)
    for start, end in intervals:
        flags |= (t > start) & (prev < end)
    return flags


__all__ = ["DEFAULT_MESH", "INTENSITY_SMOOTH_PX", "SOURCES", "intensity_maps",
           "mesh_slip_signal", "moving_flags"]
