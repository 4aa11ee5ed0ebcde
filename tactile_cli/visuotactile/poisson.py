"""Height maps from surface gradients: paper 002, eq. 9, and a fast Poisson solver.

Eq. 9: the normal (nx, ny, nz) of a surface h(x, y) gives its gradients
``dh/dx = -nx / nz`` and ``dh/dy = -ny / nz`` (the inverse of the scene's
``render.surface_normals``: normal = (-dh/dx, -dh/dy, 1) / norm with gradients in mm per
mm, x = column index to the right, y = row index down). ``nz`` is floored at
:data:`NZ_FLOOR` so that a steep or mispredicted pixel does not give an infinite slope.

The height map is the least-squares surface whose discrete gradients match those: the
Poisson equation ``lap(h) = div(g)`` on the pixel grid, solved in one pass with a type-I
discrete sine transform (Dirichlet ``h = 0`` on a border around the frame: the gel is
flat away from contact). With the 5-point Laplacian the DST-I diagonalises the system
exactly; its eigenvalues are ``2 cos(pi k / (N + 1)) - 2`` for ``k = 1..N`` per axis. (A
DCT (Neumann) solver needs ``2 cos(pi k / N) - 2`` for ``k = 0..N-1``; solvers that build
that grid over 1..N shrink every frequency's height and recover only part of a contact's
peak, worse for larger contacts.) The padded size is chosen so that the DST's internal
FFT of length 2 (N + 1) is fast (``scipy.fft.next_fast_len`` of N + 1).

Gradient sampling: the normal model predicts gradients at pixel centres
(``sampling="centre"``); they are averaged onto the faces between pixels before the
divergence is taken. ``sampling="face"`` takes ``gx[i, j] = (h[i, j + 1] - h[i, j]) /
spacing`` exactly (what :func:`face_gradients` computes), for which the solver inverts the
gradients to machine precision.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
import scipy.fft as sfft

#: smallest nz used in eq. 9 (slopes are at most sqrt(1 - f^2) / f = 9.95, about 84 deg)
NZ_FLOOR = 0.1
#: minimum zero border (pixels) around the frame in the Dirichlet solve
MIN_PAD_PX = 2


def gradients_from_normals(normals: np.ndarray, *, nz_floor: float = NZ_FLOOR
                           ) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 9: (..., H, W, 3) unit normals -> (gx, gy), each (..., H, W), in mm per mm:
    ``gx = -nx / max(nz, nz_floor)``, ``gy = -ny / max(nz, nz_floor)``."""
    n = np.asarray(normals)
    if n.shape[-1] != 3:
        raise ValueError(f"`normals` has shape {n.shape}; expected (..., H, W, 3)")
    if not nz_floor > 0:
        raise ValueError(f"`nz_floor` (={nz_floor}) must be > 0")
    nz = np.maximum(n[..., 2], np.asarray(nz_floor, dtype=n.dtype))
    return -n[..., 0] / nz, -n[..., 1] / nz


def fast_dst1_len(n: int) -> int:
    """The smallest N >= n whose DST-I is fast: N + 1 has only prime factors <= 11
    (pocketfft's DST-I of length N runs an FFT of length 2 (N + 1); N + 1 = 337, a
    prime, makes the 2-D solve four times slower than N + 1 = 336)."""
    return sfft.next_fast_len(n + 1, real=False) - 1


@dataclass
class PoissonSolver:
    """A Dirichlet Poisson solver for frames of one size; reuse it across frames.

    height, width: frame size in pixels; px_per_mm: pixels per mm (heights come out in mm);
    pad_px: at least this zero border on each side (rounded up to a fast DST size);
    workers: threads for ``scipy.fft``; dtype: float64 (default) or float32 (about twice
    as fast, relative error ~1e-6).
    """

    height: int
    width: int
    px_per_mm: float
    pad_px: int = MIN_PAD_PX
    workers: int = 1
    dtype: type = np.float64

    def __post_init__(self) -> None:
        if self.height < 1 or self.width < 1:
            raise ValueError(f"frame size ({self.height}, {self.width}) must be positive")
        if not (np.isfinite(self.px_per_mm) and self.px_per_mm > 0):
            raise ValueError(f"`px_per_mm` (={self.px_per_mm}) must be a positive number")
        if self.pad_px < 1:
            raise ValueError(f"`pad_px` (={self.pad_px}) must be >= 1")
        self.rows = fast_dst1_len(self.height + 2 * self.pad_px)
        self.cols = fast_dst1_len(self.width + 2 * self.pad_px)
        self.top = (self.rows - self.height) // 2
        self.left = (self.cols - self.width) // 2
        ky = np.arange(1, self.rows + 1)
        kx = np.arange(1, self.cols + 1)
        lam = ((2 * np.cos(np.pi * ky / (self.rows + 1)) - 2)[:, None]
               + (2 * np.cos(np.pi * kx / (self.cols + 1)) - 2)[None, :])
        # lam < 0 everywhere (k >= 1): no zero mode with Dirichlet borders
        self._inv_lam = (1.0 / lam).astype(self.dtype)

    @property
    def padded_shape(self) -> tuple[int, int]:
        return self.rows, self.cols

    def solve_laplace(self, f: np.ndarray) -> np.ndarray:
        """(rows, cols) right-hand side on the padded grid -> (rows, cols) u with
        ``lap5(u) = f`` and u = 0 outside (grid units: spacing 1)."""
        spec = sfft.dstn(np.asarray(f, dtype=self.dtype), type=1, workers=self.workers,
                         overwrite_x=True)
        spec *= self._inv_lam
        return sfft.idstn(spec, type=1, workers=self.workers, overwrite_x=True)

    def divergence(self, gx: np.ndarray, gy: np.ndarray, *,
                   sampling: Literal["centre", "face"] = "centre") -> np.ndarray:
        """(H, W) gradients (mm per mm) -> (rows, cols) div on the padded grid, in grid
        units (already multiplied by the pixel spacing in mm)."""
        gx = np.asarray(gx, dtype=self.dtype)
        gy = np.asarray(gy, dtype=self.dtype)
        if gx.shape != (self.height, self.width) or gy.shape != gx.shape:
            raise ValueError(f"gradients {gx.shape}, {gy.shape} do not match the solver's "
                             f"frame ({self.height}, {self.width})")
        r, c = self.rows, self.cols
        t, lft = self.top, self.left
        h, w = self.height, self.width
        spacing = self.dtype(1.0 / self.px_per_mm)
        if sampling == "centre":
            # the face between centres j and j + 1 gets their mean and faces at the frame's
            # edge half of the one centre inside (the pad's gradient is zero), so the
            # divergence at cell j is the central difference 0.5 (g[j + 1] - g[j - 1]) of
            # the zero-padded gradients: four shifted adds into one padded array
            div = np.zeros((r, c), dtype=self.dtype)
            half = self.dtype(0.5) * spacing
            sx = gx * half
            sy = gy * half
            div[t:t + h, lft - 1:lft + w - 1] += sx  # pixel j is cell j - 1's right side
            div[t:t + h, lft + 1:lft + w + 1] -= sx  # ... and cell j + 1's left side
            div[t - 1:t + h - 1, lft:lft + w] += sy
            div[t + 1:t + h + 1, lft:lft + w] -= sy
            return div
        if sampling != "face":
            raise ValueError(f"`sampling` (={sampling!r}) must be 'centre' or 'face'")
        # face values fx[i, j] between pixel j and j + 1 (padded grid, zero outside)
        fx = np.zeros((r, c + 1), dtype=self.dtype)
        fy = np.zeros((r + 1, c), dtype=self.dtype)
        fx[t:t + h, lft + 1:lft + w + 1] = gx
        fy[t + 1:t + h + 1, lft:lft + w] = gy
        div = (fx[:, 1:] - fx[:, :-1]) + (fy[1:, :] - fy[:-1, :])
        div *= spacing
        return div

    def integrate(self, gx: np.ndarray, gy: np.ndarray, *,
                  sampling: Literal["centre", "face"] = "centre") -> np.ndarray:
        """(H, W) gradients in mm per mm -> (H, W) heights in mm (dtype of the solver)."""
        u = self.solve_laplace(self.divergence(gx, gy, sampling=sampling))
        return u[self.top:self.top + self.height, self.left:self.left + self.width]


def face_gradients(height_mm: np.ndarray, px_per_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """Forward differences of (H, W) heights (mm) as ``sampling="face"`` reads them:
    ``gx[i, j] = (h[i, j + 1] - h[i, j]) * px_per_mm`` with h = 0 past the last column,
    likewise gy. Returns (gx, gy) in mm per mm. An (H, W) array holds one face per pixel,
    so the face into the first column (and row) is not represented: integrating these
    gradients returns ``height_mm`` exactly when it is 0 on its first row and column (the
    gel is flat at the frame's edge)."""
    h = np.asarray(height_mm, dtype=np.float64)
    gx = (np.concatenate([h[:, 1:], np.zeros((h.shape[0], 1))], axis=1) - h) * px_per_mm
    gy = (np.concatenate([h[1:, :], np.zeros((1, h.shape[1]))], axis=0) - h) * px_per_mm
    return gx, gy


def integrate_gradients(gx: np.ndarray, gy: np.ndarray, px_per_mm: float, *,
                        pad_px: int = MIN_PAD_PX, workers: int = 1,
                        sampling: Literal["centre", "face"] = "centre") -> np.ndarray:
    """One-off form of :class:`PoissonSolver`: (H, W) gradients (mm per mm) -> (H, W)
    float64 heights (mm), h = 0 on a zero border of at least ``pad_px`` pixels."""
    gx = np.asarray(gx)
    solver = PoissonSolver(gx.shape[0], gx.shape[1], px_per_mm, pad_px=pad_px,
                           workers=workers)
    return solver.integrate(gx, gy, sampling=sampling)


__all__ = ["MIN_PAD_PX", "NZ_FLOOR", "PoissonSolver", "face_gradients", "fast_dst1_len",
           "gradients_from_normals", "integrate_gradients"]
