"""Per-pixel surface normals from a tactile image with the paper's MLP, in numpy.

Paper 002, sec. II-B: a 5-32-32-32-3 network maps each pixel's position and colour
difference from the no-contact reference, (x, y, dR, dG, dB), to its surface normal
(nx, ny, nz); a variant takes the absolute colour (x, y, R, G, B). The network is trained
by ``tactile train`` (``family: mlp``, ``window: 1``, regression heads ``nx, ny, nz``) on
the calibration pixel table; :class:`NormalModel` reads that run once (torch is imported
only then, inside ``learn/``) and infers with float32 numpy:

- the input standardisation and the summary-feature standardisation are folded into the
  first layer, the target de-standardisation into the last (exact algebra, no change of
  the function);
- every bias rides inside its matmul (a constant-1 input column and a constant-1 unit
  carried through the hidden layers), so a layer is one matmul and one ReLU;
- the (H * W, 6) input buffer [colour, x, y, 1] is kept per frame size: only the colour
  columns are written per frame;
- pixels go through the layers in tiles of :data:`TILE_PX` (the activations stay in the
  L2 cache), each tile with one-threaded BLAS (threadpoolctl), the tiles shared between
  ``workers`` threads (numpy's matmul releases the GIL): a tile's rows and its BLAS
  threads do not depend on ``workers``, so the normals are bit-identical for any
  ``workers``.

Inputs: x = column index, y = row index (pixels); dR = R(frame) - R(reference) as a signed
float in 0-255 units.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..store.trials import TactileFile, Trial
from .sensor_unit import SensorCalibration, check_frames

#: channel lists the model may be trained on (in any order), by input kind
_KIND_CHANNELS = {"difference": {"x", "y", "dR", "dG", "dB"},
                  "absolute": {"x", "y", "R", "G", "B"}}
_HEADS = ("nx", "ny", "nz")
#: pixels per tile: 2048 x 32 float32 = 256 KiB per activation buffer, inside L2
TILE_PX = 2048


def default_workers() -> int:
    """Threads for inference and the FFTs: the CPUs this process may use (at most 8)."""
    try:
        n = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        n = os.cpu_count() or 1
    return max(1, min(8, n))


@dataclass
class NormalModel:
    """The folded float32 MLP. Build it with :meth:`from_run` (or :meth:`from_arrays`).

    channels: the run's input channels in model order; input_kind: ``difference`` or
    ``absolute``; w_xy: (2, h1) first-layer weights of x and y (raw pixels); w_colour: (3,
    h1) of the colour channels in R, G, B order (raw 0-255 units); b1: (h1,); hidden:
    [(W (in, out), b)] further trunk layers (ReLU after each); w_out: (h_last, 3), b_out:
    (3,) to (nx, ny, nz) in target units (before normalising to unit length).
    """

    channels: tuple[str, ...]
    input_kind: str
    w_xy: np.ndarray
    w_colour: np.ndarray
    b1: np.ndarray
    hidden: list[tuple[np.ndarray, np.ndarray]]
    w_out: np.ndarray
    b_out: np.ndarray
    run_dir: Path | None = None
    #: the unit, frame size and scale the run was calibrated on (None: not recorded)
    calibration: SensorCalibration | None = None
    _input_cache: dict[tuple[int, int], np.ndarray] = field(default_factory=dict, repr=False)
    _aug: tuple[np.ndarray, list[np.ndarray], np.ndarray] | None = field(default=None,
                                                                          repr=False)

    # -- construction ----------------------------------------------------------------------
    @classmethod
    def from_run(cls, run_dir: str | Path) -> NormalModel:
        """Read a run of ``tactile train configs/train_mlp_normals.yaml``; one InputError
        naming the run folder if it is not such a run."""
        from ..learn.dense_weights import dense_arrays
        from ..learn.runs import RUN_JSON, read_run_info

        model = cls.from_arrays(dense_arrays(run_dir))
        record = read_run_info(run_dir).get("sensor_unit")
        if record is not None:
            model.calibration = SensorCalibration.from_dict(record,
                                                            path=Path(run_dir) / RUN_JSON)
        return model

    def check_frames(self, tf: TactileFile, trial: Trial,
                     px_per_mm: float | None) -> list[str]:
        """:func:`.sensor_unit.check_frames` against this model's calibration: InputError
        on another frame size, warnings (returned) on another unit or scale."""
        return check_frames(self.calibration, tf, trial, run=self.run_dir,
                            px_per_mm=px_per_mm)

    @classmethod
    def from_arrays(cls, arrays: object) -> NormalModel:
        """Fold a :class:`tactile_cli.learn.dense_weights.DenseArrays` (see the module
        docstring) into a :class:`NormalModel`."""
        a = arrays
        path = getattr(a, "path", None)
        channels = tuple(a.channels)  # type: ignore[attr-defined]
        kind = next((k for k, names in _KIND_CHANNELS.items()
                     if set(channels) == names and len(channels) == 5), None)
        if kind is None:
            raise InputError(f"run has input channels {list(channels)}; a normal model needs "
                             "x, y, dR, dG, dB (or x, y, R, G, B)", path=path)
        heads = a.heads  # type: ignore[attr-defined]
        if set(heads) != set(_HEADS):
            raise InputError(f"run has heads {sorted(heads)}; a normal model needs regression "
                             "heads nx, ny, nz", path=path)
        if any(len(heads[h]) != 1 for h in _HEADS):
            raise InputError("run has hidden head layers; a normal model needs "
                             "`head_hidden: []` (the paper's 5-32-32-32-3)", path=path)
        # inputs -> summary features -> standardised features: an affine map z = x A + c
        c = len(channels)
        rows = np.asarray(a.feature_rows)  # type: ignore[attr-defined]
        a_mat = np.zeros((c, rows.size))
        for j, r in enumerate(rows):
            if r >= 0:
                a_mat[r, j] = 1.0 / a.in_std[r]  # type: ignore[attr-defined]
        shift = np.where(rows >= 0, -a.in_mean[np.maximum(rows, 0)]  # type: ignore[attr-defined]
                         / a.in_std[np.maximum(rows, 0)], 0.0)  # type: ignore[attr-defined]
        fm, fs = a.feature_mean, a.feature_std  # type: ignore[attr-defined]
        a_mat = a_mat / fs
        shift = (shift - fm) / fs
        trunk = list(a.trunk)  # type: ignore[attr-defined]
        if not trunk:
            raise InputError("run has no hidden layers; a normal model needs `hidden: [...]`",
                             path=path)
        w1, b1 = trunk[0]
        w1f = a_mat @ w1
        b1f = shift @ w1 + b1
        order = {name: i for i, name in enumerate(channels)}
        colour = ("dR", "dG", "dB") if kind == "difference" else ("R", "G", "B")
        w_xy = np.stack([w1f[order["x"]], w1f[order["y"]]])
        w_colour = np.stack([w1f[order[k]] for k in colour])
        scale = np.array([a.target_scale.get(h, (0.0, 1.0)) for h in _HEADS])  # type: ignore[attr-defined]
        w_out = np.concatenate([heads[h][0][0] for h in _HEADS], axis=1) * scale[:, 1]
        b_out = np.concatenate([heads[h][0][1] for h in _HEADS]) * scale[:, 1] + scale[:, 0]
        f32 = np.float32
        return cls(channels=channels, input_kind=kind, w_xy=w_xy.astype(f32),
                   w_colour=w_colour.astype(f32), b1=b1f.astype(f32),
                   hidden=[(w.astype(f32), b.astype(f32)) for w, b in trunk[1:]],
                   w_out=w_out.astype(f32), b_out=b_out.astype(f32),
                   run_dir=None if path is None else Path(path))

    # -- inference -------------------------------------------------------------------------
    def _augmented(self) -> tuple[np.ndarray, list[np.ndarray], np.ndarray]:
        """Weights with the bias as an extra input row and a constant-1 unit carried
        through every hidden layer (the bias add costs nothing inside the matmul):
        first (6, h1 + 1) for [colour, x, y, 1], hidden [(h + 1, h' + 1)], out (h + 1, 3)."""
        if self._aug is None:
            def aug(w: np.ndarray, b: np.ndarray, *, carry: bool) -> np.ndarray:
                top = np.concatenate([w, b[None, :]], axis=0)
                if not carry:
                    return np.ascontiguousarray(top, dtype=np.float32)
                one = np.zeros((top.shape[0], 1), dtype=np.float32)
                one[-1, 0] = 1.0
                return np.ascontiguousarray(np.concatenate([top, one], axis=1), np.float32)

            first = aug(np.concatenate([self.w_colour, self.w_xy]), self.b1, carry=True)
            hidden = [aug(w, b, carry=True) for w, b in self.hidden]
            out = aug(self.w_out, self.b_out, carry=False)
            self._aug = (first, hidden, out)
        return self._aug

    def _inputs(self, height: int, width: int) -> np.ndarray:
        """(H * W, 6) float32 buffer [colour (filled per frame), x, y, 1]; cached per size."""
        key = (height, width)
        if key not in self._input_cache:
            yy, xx = np.mgrid[0:height, 0:width]
            buf = np.zeros((height * width, 6), dtype=np.float32)
            buf[:, 3], buf[:, 4], buf[:, 5] = xx.ravel(), yy.ravel(), 1.0
            self._input_cache = {key: buf}  # one size at a time: frames of a file share it
        return self._input_cache[key]

    def _raw(self, inputs: np.ndarray, *, workers: int) -> np.ndarray:
        """(n, 6) [colour, x, y, 1] -> (n, 3) float32 network outputs (not yet unit)."""
        first, hidden, w_out = self._augmented()
        n = inputs.shape[0]
        out = np.empty((n, 3), dtype=np.float32)
        width = first.shape[1]
        zero = np.float32(0.0)

        def tiles(starts: range) -> None:
            a = np.empty((TILE_PX, width), dtype=np.float32)
            b = np.empty((TILE_PX, width), dtype=np.float32)
            keep = np.empty((TILE_PX, width), dtype=bool)
            for s in starts:
                e = min(s + TILE_PX, n)
                x, y, k = a[: e - s], b[: e - s], keep[: e - s]
                np.matmul(inputs[s:e], first, out=x)
                for w in hidden:
                    np.greater(x, zero, out=k)  # ReLU as a masked product: the fastest here
                    np.multiply(x, k, out=x)
                    np.matmul(x, w, out=y)
                    x, y = y, x
                np.greater(x, zero, out=k)
                np.multiply(x, k, out=x)
                np.matmul(x, w_out, out=out[s:e])

        # Bit-identical for every `workers`: a GEMM's summation order depends on its rows
        # and on BLAS's own thread count (OpenBLAS splits a threaded GEMM into other
        # kernels and edges than a one-threaded one; Haswell and Zen kernels differ in the
        # last bit). So every tile is TILE_PX rows from a multiple of TILE_PX and runs
        # with one-threaded BLAS, workers=1 included; workers only share out the tiles.
        n_tiles = -(-n // TILE_PX)
        workers = max(1, min(workers, n_tiles))
        with _blas_threads(1):
            if workers == 1:
                tiles(range(0, n, TILE_PX))
                return out
            # each thread takes every workers-th tile (numpy releases the GIL in matmul):
            # no nested thread pools fighting over the cores
            with ThreadPoolExecutor(workers) as pool:
                list(pool.map(tiles, [range(i * TILE_PX, n, workers * TILE_PX)
                                      for i in range(workers)]))
        return out

    def predict(self, frame: np.ndarray, reference: np.ndarray, *,
                workers: int | None = None, active: np.ndarray | None = None) -> np.ndarray:
        """(H, W, 3) uint8 RGB frame and no-contact reference -> (H, W, 3) float32 unit
        normals (nx, ny, nz). ``active``: optional (H, W) bool; pixels outside it are not
        run through the network and get the flat normal (0, 0, 1). A prediction of zero
        length (never seen in practice) is returned as the flat normal too."""
        frame = np.asarray(frame)
        reference = np.asarray(reference)
        if frame.ndim != 3 or frame.shape[-1] != 3 or frame.shape != reference.shape:
            raise ValueError(f"`frame` {frame.shape} and `reference` {reference.shape} must be "
                             "(H, W, 3) of the same size")
        h, w = frame.shape[:2]
        inputs = self._inputs(h, w)
        if self.input_kind == "absolute":
            inputs[:, :3] = frame.reshape(-1, 3)
        else:
            np.subtract(frame.reshape(-1, 3), reference.reshape(-1, 3), out=inputs[:, :3],
                        dtype=np.float32)
        workers = default_workers() if workers is None else workers
        if active is None:
            return _unit(self._raw(inputs, workers=workers)).reshape(h, w, 3)
        flat = np.asarray(active, dtype=bool).ravel()
        out = np.zeros((h * w, 3), dtype=np.float32)
        out[:, 2] = 1.0
        if flat.any():
            out[flat] = _unit(self._raw(inputs[flat], workers=workers))
        return out.reshape(h, w, 3)

    def predict_pixels(self, table: np.ndarray) -> np.ndarray:
        """(n, 5) float32 rows in the run's channel order -> (n, 3) float32 unit normals."""
        t = np.asarray(table, dtype=np.float32)
        if t.ndim != 2 or t.shape[1] != len(self.channels):
            raise ValueError(f"`table` has shape {t.shape}; expected (n, {len(self.channels)}) "
                             f"with channels {list(self.channels)}")
        order = {name: i for i, name in enumerate(self.channels)}
        colour = (("dR", "dG", "dB") if self.input_kind == "difference" else ("R", "G", "B"))
        inputs = np.ones((t.shape[0], 6), dtype=np.float32)
        inputs[:, :5] = t[:, [order[k] for k in (*colour, "x", "y")]]
        return _unit(self._raw(inputs, workers=1))


class _blas_threads:  # noqa: N801 (a context manager used like a function)
    """Limit BLAS to ``n`` threads inside the block (threadpoolctl: every BLAS loaded when
    it is first used, numpy's OpenBLAS among them), restoring the previous counts after
    it."""

    def __init__(self, n: int):
        self.n = n
        self._limit: object | None = None

    #: one controller per process (finding the BLAS libraries costs ~0.3 ms, a limit 10 us)
    _controller: object | None = None

    def __enter__(self) -> None:
        if _blas_threads._controller is None:
            from threadpoolctl import ThreadpoolController

            _blas_threads._controller = ThreadpoolController()
        self._limit = _blas_threads._controller.limit(  # type: ignore[attr-defined]
            limits=self.n, user_api="blas")

    def __exit__(self, *exc: object) -> None:
        if self._limit is not None:
            self._limit.unregister()  # type: ignore[attr-defined]


def _unit(raw: np.ndarray) -> np.ndarray:
    norm = np.sqrt(np.einsum("ij,ij->i", raw, raw))
    bad = ~(norm > 0)
    norm[bad] = 1.0
    out = raw / norm[:, None]
    out[bad] = (0.0, 0.0, 1.0)
    return out.astype(np.float32, copy=False)


__all__ = ["TILE_PX", "NormalModel", "default_workers"]
