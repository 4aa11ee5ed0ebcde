"""Where the channels of a non-matrix tactile sensor lie on it: electrode layouts as images.

Issue 34, item 4. A BioTac SP is not a taxel grid: its 24 impedance electrodes sit at
irregular places on the fingertip. The grasp-stability paper behind ``biotac_grasps``
(Zapata-Impata, Gil and Torres, arXiv 1809.05551) lays them out as a small image so that a
2-D CNN sees which electrodes are neighbours. :func:`layout_grid` does this for any layout
of :data:`LAYOUTS`: the electrode positions (mm, on the sensor's unrolled face) are
rounded to a grid of ``cell_mm`` cells; every cell gets the value of its electrode, and an
empty cell either 0 (``fill="zero"``) or the value of the nearest electrode
(``fill="nearest"``, a Voronoi fill, so the image has no artificial edges around each
electrode). The result is an index map: image cell -> channel, which the
``cnn2d_layout`` family applies as one gather (:mod:`.layout_cnn`), so the image costs no
arithmetic and exports to ONNX as a ``Gather``.

Channels of several sensors of one layout (three fingers of a hand: 72 = 3 x 24 values)
become image channels: the channels are read as consecutive blocks of the layout's
electrodes, in the layout's electrode order.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# BioTac SP sensing electrodes 1..24, (x, y) in mm on the unrolled face of the sensor, x
# across the finger (electrodes 1..10 on one side, 11..20 their mirror images, 21..24 on
# the midline) and y along it from the tip. Taken as facts from the electrode locations
# that Shadow Robot's `sr_gui_biotac` ships for the BioTac SP (SynTouch's 24-electrode
# layout; parameters `sensing_electrodes_x_locations` / `_y_locations`,
# https://docs.ros.org/en/kinetic/api/sr_gui_biotac/html/biotac_8py_source.html). The
# grasp paper's 12 x 11 image (the dataset's `Dataset Processing` notebook, distribution 7)
# places the electrodes in the same rows and columns order.
_BIOTAC_SP_X_MM = (5.00, 3.65, 6.45, 4.40, 2.70, 6.45, 4.40, 1.50, 4.00, 4.50,
                   -5.00, -3.65, -6.45, -4.40, -2.70, -6.45, -4.40, -1.50, -4.00, -4.50,
                   0.00, 1.95, -1.95, 0.00)
_BIOTAC_SP_Y_MM = (4.38, 6.38, 14.78, 15.50, 18.50, 19.08, 20.00, 21.00, 23.00, 25.00,
                   4.38, 6.38, 14.78, 15.50, 18.50, 19.08, 20.00, 21.00, 23.00, 25.00,
                   7.38, 11.50, 11.50, 15.20)

#: Named layouts: name -> (n_electrodes, 2) positions in mm (x across, y along the sensor).
LAYOUTS: dict[str, np.ndarray] = {
    "biotac_sp": np.column_stack([_BIOTAC_SP_X_MM, _BIOTAC_SP_Y_MM]),
}
FILLS: tuple[str, ...] = ("zero", "nearest")


@dataclass(frozen=True)
class LayoutGrid:
    """A layout rasterised: ``index`` (rows, cols) int64, the electrode of each cell (-1 for
    an empty cell with ``fill="zero"``); ``cells`` (n_electrodes, 2) the (row, col) of each
    electrode. Row 0 is the smallest y, column 0 the largest x (the paper's orientation)."""

    name: str
    cell_mm: float
    fill: str
    index: np.ndarray
    cells: np.ndarray

    @property
    def shape(self) -> tuple[int, int]:
        return int(self.index.shape[0]), int(self.index.shape[1])

    @property
    def n_electrodes(self) -> int:
        return int(self.cells.shape[0])


def layout_positions(name: str) -> np.ndarray:
    """(n, 2) electrode positions in mm of layout ``name``; ValueError naming the known
    layouts otherwise."""
    if name not in LAYOUTS:
        raise ValueError(f"`layout` (={name!r}) must be one of {', '.join(sorted(LAYOUTS))}")
    return LAYOUTS[name]


def layout_grid(name: str, *, cell_mm: float = 1.0, fill: str = "nearest") -> LayoutGrid:
    """Rasterise layout ``name`` at ``cell_mm`` per cell (see the module docstring).

    Raises ValueError when two electrodes fall into one cell (``cell_mm`` too coarse: the
    message names them and the largest cell that separates every pair), or for an unknown
    layout or fill."""
    if fill not in FILLS:
        raise ValueError(f"`fill` (={fill!r}) must be one of {', '.join(FILLS)}")
    if not (np.isfinite(cell_mm) and cell_mm > 0):
        raise ValueError(f"`cell_mm` (={cell_mm}) must be > 0")
    pos = layout_positions(name)
    col = np.round((pos[:, 0].max() - pos[:, 0]) / cell_mm).astype(np.int64)
    row = np.round((pos[:, 1] - pos[:, 1].min()) / cell_mm).astype(np.int64)
    cells = np.column_stack([row, col])
    _, first, counts = np.unique(cells, axis=0, return_index=True, return_counts=True)
    if (counts > 1).any():
        clash = cells[first[counts > 1][0]]
        who = np.flatnonzero((cells == clash).all(axis=1)) + 1
        raise ValueError(f"`cell_mm` (={cell_mm}) puts electrodes {', '.join(map(str, who))} "
                         f"of layout {name!r} into one cell; use at most "
                         f"{_largest_separating_cell(pos):.3g}")
    shape = (int(row.max()) + 1, int(col.max()) + 1)
    if fill == "zero":
        index = np.full(shape, -1, dtype=np.int64)
        index[row, col] = np.arange(pos.shape[0])
    else:  # the nearest electrode of each cell centre, in cell units (ties: lower index)
        rr, cc = np.meshgrid(np.arange(shape[0]), np.arange(shape[1]), indexing="ij")
        d2 = (rr[..., None] - row) ** 2 + (cc[..., None] - col) ** 2
        index = np.argmin(d2, axis=-1).astype(np.int64)
    return LayoutGrid(name, float(cell_mm), fill, index, cells)


def _largest_separating_cell(pos: np.ndarray) -> float:
    """A cell size (mm) at which no two electrodes share a cell: half the smallest
    per-axis separation of the pairs that are closest."""
    dx = np.abs(pos[:, None, 0] - pos[None, :, 0])
    dy = np.abs(pos[:, None, 1] - pos[None, :, 1])
    sep = np.maximum(dx, dy)
    np.fill_diagonal(sep, np.inf)
    return float(sep.min() / 2)


def gather_index(grid: LayoutGrid, n_channels: int) -> tuple[np.ndarray, int]:
    """The channel index of every pixel of every image channel, for ``n_channels``
    channels read as consecutive blocks of the layout's electrodes: ((k, rows, cols) int64
    index into the channels, -1 for a zero cell; k = n_channels / n_electrodes). Raises
    ValueError when ``n_channels`` is not a multiple of the electrode count."""
    n = grid.n_electrodes
    if n_channels % n:
        raise ValueError(f"{n_channels} channels are not whole blocks of the {n} electrodes "
                         f"of layout {grid.name!r}: list each sensor's {n} electrodes in "
                         "`data.channels`, in the layout's order")
    k = n_channels // n
    blocks = np.arange(k)[:, None, None] * n
    index = np.where(grid.index >= 0, grid.index[None] + blocks, -1)
    return index.astype(np.int64), k


__all__ = ["FILLS", "LAYOUTS", "LayoutGrid", "gather_index", "layout_grid", "layout_positions"]
