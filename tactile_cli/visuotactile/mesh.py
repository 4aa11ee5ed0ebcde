"""Tactile meshes: evenly spaced pixels of a height map used as tactile units (paper 002,
sec. III-A and IV, Fig. 3).

A mesh of ``cols x rows`` units on an (H, W) map takes the pixel at the centre of each of
``cols x rows`` equal cells: column ``floor((k + 0.5) W / cols)`` for ``k = 0..cols-1``
(on a 320 x 240 map the 32 x 24 mesh is every tenth pixel, starting at pixel 5; the
320 x 240 mesh is every pixel). The paper's densities are :data:`MESH_SIZES`.

The slip signal of eq. 10 on a mesh, :func:`slip_signal`, lives here too, beside the units
it sums over: :mod:`.slip` (decisions, files) and :mod:`.signals` (the monitor's inputs)
both take it from here.
"""

from __future__ import annotations

import re

import numpy as np

#: The mesh densities of the paper (cols, rows), densest first.
MESH_SIZES: tuple[tuple[int, int], ...] = ((320, 240), (160, 120), (64, 48), (32, 24),
                                            (16, 12), (8, 6), (4, 3))
_MESH_RE = re.compile(r"^\s*(\d+)\s*[xX]\s*(\d+)\s*$")


def parse_mesh(text: str) -> tuple[int, int]:
    """``"32x24"`` -> (32, 24) (columns, rows); ValueError naming the text otherwise."""
    m = _MESH_RE.match(str(text))
    if not m or int(m.group(1)) < 1 or int(m.group(2)) < 1:
        raise ValueError(f"`mesh` (={text!r}) must be COLSxROWS with positive integers, "
                         "e.g. 32x24")
    return int(m.group(1)), int(m.group(2))


def mesh_indices(height: int, width: int, mesh: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Row indices (rows,) and column indices (cols,) of a ``mesh = (cols, rows)`` on an
    (height, width) map. ValueError when the mesh is denser than the map."""
    cols, rows = (int(v) for v in mesh)
    if cols < 1 or rows < 1:
        raise ValueError(f"`mesh` (={mesh}) must have at least one column and one row")
    if cols > width or rows > height:
        raise ValueError(f"`mesh` {cols}x{rows} is denser than the {width}x{height} map")
    r = np.floor((np.arange(rows) + 0.5) * height / rows).astype(np.intp)
    c = np.floor((np.arange(cols) + 0.5) * width / cols).astype(np.intp)
    return r, c


def sample_mesh(maps: np.ndarray, mesh: tuple[int, int]) -> np.ndarray:
    """(..., H, W) maps -> (..., rows, cols) values at the mesh's units (a view-free copy)."""
    maps = np.asarray(maps)
    r, c = mesh_indices(maps.shape[-2], maps.shape[-1], mesh)
    return maps[..., r[:, None], c[None, :]]


def mesh_mask(height: int, width: int, mesh: tuple[int, int]) -> np.ndarray:
    """(height, width) bool, True at the mesh's units (for figures like Fig. 3)."""
    r, c = mesh_indices(height, width, mesh)
    mask = np.zeros((height, width), dtype=bool)
    mask[r[:, None], c[None, :]] = True
    return mask


def slip_signal(heights: np.ndarray, mesh: tuple[int, int] | None = None) -> np.ndarray:
    """Eq. 10. heights: (n_frames, H, W) maps (mm, or any map unit); mesh: (cols, rows) of
    the tactile mesh, None for every pixel. Returns (n_frames,) float64, ``S[0] = NaN``."""
    h = np.asarray(heights)
    if h.ndim != 3:
        raise ValueError(f"`heights` has shape {h.shape}; expected (n_frames, H, W)")
    units = h if mesh is None else sample_mesh(h, mesh)
    out = np.full(h.shape[0], np.nan)
    if h.shape[0] > 1:
        d = np.abs(np.diff(units.astype(np.float64, copy=False), axis=0))
        out[1:] = d.reshape(d.shape[0], -1).sum(axis=1)
    return out


__all__ = ["slip_signal", "MESH_SIZES", "mesh_indices", "mesh_mask", "parse_mesh", "sample_mesh"]
