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
- the first layer is split into its colour part and its position part ([x, y, 1], kept
  per frame size), two K = 3 products added, so no (n, 6) input is assembled;
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
import threading
import weakref
from collections.abc import Callable
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
#: pixels per tile: 4096 x 33 float32 = 528 KiB per activation buffer (inside this
#: machine's 1 MiB L2 per core); 1,024, 2,048 and 8,192 were not faster at 320x240 in
#: interleaved timings
TILE_PX = 4096


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
    _input_cache: dict[tuple[int, int, int], np.ndarray] = field(default_factory=dict, repr=False)
    _aug: tuple[np.ndarray, list[np.ndarray], np.ndarray] | None = field(default=None,
                                                                          repr=False)
    _halved: tuple[np.ndarray, list[np.ndarray], np.ndarray] | None = field(default=None,
                                                                             repr=False)
    #: per worker tile buffers, the worker threads (kept across frames), one caller a time
    _buffers: dict[int, tuple[np.ndarray, ...]] = field(default_factory=dict, repr=False)
    _pool: tuple[int, ThreadPoolExecutor] | None = field(default=None, repr=False)
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False)

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

    def _positions(self, height: int, width: int, stride: int = 1) -> np.ndarray:
        """(height * width, 3) float32 [x, y, 1], row-major, of a frame's pixels (stride 1)
        or of the centres of its ``stride`` x ``stride`` blocks (x = stride * j + (stride -
        1) / 2 in frame pixels); cached per size."""
        key = (height, width, stride)
        if key not in self._input_cache:
            yy, xx = np.mgrid[0:height, 0:width]
            pos = np.empty((height * width, 3), dtype=np.float32)
            centre = (stride - 1) / 2
            pos[:, 0] = xx.ravel() * stride + centre
            pos[:, 1] = yy.ravel() * stride + centre
            pos[:, 2] = 1.0
            self._input_cache = {key: pos}  # one size at a time: frames of a file share it
        return self._input_cache[key]

    def _run(self, colour: np.ndarray, pos: np.ndarray, *, workers: int,
             sink: Callable[[int, np.ndarray], None]) -> None:
        """The network over n pixels in tiles. colour: (n, 3) float32 contiguous (dR, dG, dB
        or R, G, B); pos: (n, 3) float32 contiguous [x, y, 1]; ``sink(start, raw)`` gets
        each tile's outputs as a (3, rows) float32 array (nx, ny, nz, not yet unit), rows
        ``start`` to ``start + rows``, and must copy what it keeps.

        Layout (this is where the time goes at camera rate): every array a tile touches is
        contiguous. The first layer is ``colour @ W_colour + [x, y, 1] @ W_position`` (two
        K = 3 products, so no (n, 6) input is assembled column by column: numpy's strided
        column copies cost more than the network's first layer), and the last layer writes
        its outputs planar, (3, rows), which the sinks read as contiguous rows."""
        first, hidden, w_out_t = self._tile_weights()
        w_colour, w_pos = first[:3], first[3:]
        n = colour.shape[0]
        # layers may differ in width (e.g. 5-32-16-3): flat buffers of the widest, each
        # layer's activations a contiguous (rows, width) view at their start
        widest = max(w.shape[1] for w in (first, *hidden))
        h1 = first.shape[1]

        def tiles(worker: int, starts: range) -> None:
            a, b, mag, o = self._tile_buffers(worker, widest)
            for s in starts:
                rows = min(s + TILE_PX, n) - s
                cur, spare = a, b
                x = cur[: rows * h1].reshape(rows, h1)
                p = spare[: rows * h1].reshape(rows, h1)
                np.matmul(colour[s:s + rows], w_colour, out=x)
                np.matmul(pos[s:s + rows], w_pos, out=p)
                np.add(x, p, out=x)
                for w in hidden:
                    m = mag[: x.size].reshape(x.shape)
                    np.abs(x, out=m)
                    np.add(x, m, out=x)  # 2 ReLU(x)
                    y = spare[: rows * w.shape[1]].reshape(rows, w.shape[1])
                    np.matmul(x, w, out=y)
                    x, cur, spare = y, spare, cur
                m = mag[: x.size].reshape(x.shape)
                np.abs(x, out=m)
                np.add(x, m, out=x)
                raw = o[: 3 * rows].reshape(3, rows)
                np.matmul(w_out_t, x.T, out=raw)
                sink(s, raw)

        # Bit-identical for every `workers`: a GEMM's summation order depends on its rows
        # and on BLAS's own thread count (OpenBLAS splits a threaded GEMM into other
        # kernels and edges than a one-threaded one; Haswell and Zen kernels differ in the
        # last bit). So every tile is TILE_PX rows from a multiple of TILE_PX and runs
        # with one-threaded BLAS, workers=1 included; workers only share out the tiles.
        n_tiles = -(-n // TILE_PX)
        workers = max(1, min(workers, n_tiles))
        with self._lock, _blas_threads(1):
            if workers == 1:
                tiles(0, range(0, n, TILE_PX))
                return
            # each thread takes every workers-th tile (numpy releases the GIL in matmul):
            # no nested thread pools fighting over the cores
            if self._pool is None or self._pool[0] != workers:
                if self._pool is not None:
                    self._pool[1].shutdown()
                pool = ThreadPoolExecutor(workers, thread_name_prefix="normals")
                weakref.finalize(self, pool.shutdown, wait=False)  # threads end with the model
                self._pool = (workers, pool)
            list(self._pool[1].map(tiles, range(workers),
                                   [range(i * TILE_PX, n, workers * TILE_PX)
                                    for i in range(workers)]))

    def _tile_weights(self) -> tuple[np.ndarray, list[np.ndarray], np.ndarray]:
        """:meth:`_augmented`'s weights as the tiles use them, made once: ReLU is taken as
        x + |x| = 2 ReLU(x) (two plain float passes, no mask) and the 2 taken back by
        halving every layer after the first (exact in binary floating point: the products
        and sums are the same bits as ReLU(x) @ W); the last layer transposed, (3, h + 1),
        to write its outputs planar."""
        if self._halved is None:
            first, hidden, w_out = self._augmented()
            self._halved = (first, [w * np.float32(0.5) for w in hidden],
                            np.ascontiguousarray(w_out.T * np.float32(0.5)))
        return self._halved

    def _tile_buffers(self, worker: int, widest: int
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Worker ``worker``'s tile buffers (two activations, |x| of the ReLU, the outputs),
        kept across frames with the worker threads (measured with the paper's network at
        320x240 on two workers: 13.4 ms a frame with fresh buffers and threads per frame,
        10.0 ms with kept ones)."""
        bufs = self._buffers.get(worker)
        if bufs is None or bufs[0].size < TILE_PX * widest:
            bufs = (np.empty(TILE_PX * widest, dtype=np.float32),
                    np.empty(TILE_PX * widest, dtype=np.float32),
                    np.empty(TILE_PX * widest, dtype=np.float32),
                    np.empty(3 * TILE_PX, dtype=np.float32))
            self._buffers[worker] = bufs
        return bufs

    def _unit_planar(self, colour: np.ndarray, pos: np.ndarray, *, workers: int
                     ) -> np.ndarray:
        """(n, 3) colour and positions -> (3, n) float32 unit normals, planar."""
        out = np.empty((3, colour.shape[0]), dtype=np.float32)

        def sink(s: int, raw: np.ndarray) -> None:
            rows = raw.shape[1]
            norm = np.sqrt(np.einsum("ij,ij->j", raw, raw))
            bad = ~(norm > 0)  # a prediction of zero length: the flat normal
            norm[bad] = 1.0
            np.divide(raw, norm, out=out[:, s:s + rows])
            if bad.any():
                out[:, s:s + rows][:, bad] = np.array([[0.0], [0.0], [1.0]], np.float32)

        self._run(colour, pos, workers=workers, sink=sink)
        return out

    def _frame_colour(self, frame: np.ndarray, reference: np.ndarray) -> np.ndarray:
        """(H, W, 3) frame and reference -> (H * W, 3) float32 network colour inputs."""
        frame = np.asarray(frame)
        reference = np.asarray(reference)
        if frame.ndim != 3 or frame.shape[-1] != 3 or frame.shape != reference.shape:
            raise ValueError(f"`frame` {frame.shape} and `reference` {reference.shape} must be "
                             "(H, W, 3) of the same size")
        colour = np.empty((frame.shape[0] * frame.shape[1], 3), dtype=np.float32)
        if self.input_kind == "absolute":
            np.copyto(colour, frame.reshape(-1, 3), casting="unsafe")
        else:
            np.subtract(frame.reshape(-1, 3), reference.reshape(-1, 3), out=colour,
                        dtype=np.float32)
        return colour

    def predict(self, frame: np.ndarray, reference: np.ndarray, *,
                workers: int | None = None, active: np.ndarray | None = None) -> np.ndarray:
        """(H, W, 3) uint8 RGB frame and no-contact reference -> (H, W, 3) float32 unit
        normals (nx, ny, nz). ``active``: optional (H, W) bool; pixels outside it are not
        run through the network and get the flat normal (0, 0, 1). A prediction of zero
        length (never seen in practice) is returned as the flat normal too."""
        colour = self._frame_colour(frame, reference)
        h, w = frame.shape[:2]
        pos = self._positions(h, w)
        workers = default_workers() if workers is None else workers
        if active is None:
            return np.ascontiguousarray(
                self._unit_planar(colour, pos, workers=workers).T).reshape(h, w, 3)
        flat = np.asarray(active, dtype=bool).ravel()
        out = np.zeros((h * w, 3), dtype=np.float32)
        out[:, 2] = 1.0
        if flat.any():
            out[flat] = self._unit_planar(np.ascontiguousarray(colour[flat]),
                                          np.ascontiguousarray(pos[flat]),
                                          workers=workers).T
        return out.reshape(h, w, 3)

    def gradients(self, frame: np.ndarray, reference: np.ndarray, *, nz_floor: float,
                  workers: int | None = None, stride: int = 1
                  ) -> tuple[np.ndarray, np.ndarray]:
        """(H, W, 3) uint8 frame and reference -> eq. 9's surface gradients (gx, gy), each
        (H, W) float32 in mm per mm, straight from the network's outputs: with n the raw
        output, ``gx = -nx / max(nz, nz_floor * |n|)`` is ``-nx' / max(nz', nz_floor)`` of
        the unit normal n' = n / |n| (:func:`.poisson.gradients_from_normals` of
        :meth:`predict`, equal to float32 rounding) without writing the normals out. A
        prediction of zero length gives the flat gradient (0, 0).

        ``stride`` k > 1: one prediction per k x k block of pixels, from the block's mean
        colour at the block's centre; the gradients are then (ceil(H / k), ceil(W / k))
        (a frame whose size is not a multiple of k is extended by repeating its last row
        and column)."""
        if not nz_floor > 0:
            raise ValueError(f"`nz_floor` (={nz_floor}) must be > 0")
        if stride == 1:
            colour = self._frame_colour(frame, reference)
            h, w = frame.shape[:2]
        else:
            colour, (h, w) = self._block_colour(frame, reference, stride)
        n = h * w
        gx = np.empty(n, dtype=np.float32)
        gy = np.empty(n, dtype=np.float32)
        floor = np.float32(nz_floor)
        tiny = np.float32(np.finfo(np.float32).tiny)

        def sink(s: int, raw: np.ndarray) -> None:
            rows = raw.shape[1]
            den = np.sqrt(np.einsum("ij,ij->j", raw, raw))
            den *= floor
            np.maximum(den, raw[2], out=den)
            np.maximum(den, tiny, out=den)  # |n| = 0: nx = ny = 0, so the gradient is 0
            np.negative(den, out=den)
            np.divide(raw[0], den, out=gx[s:s + rows])
            np.divide(raw[1], den, out=gy[s:s + rows])

        self._run(colour, self._positions(h, w, stride),
                  workers=default_workers() if workers is None else workers, sink=sink)
        return gx.reshape(h, w), gy.reshape(h, w)

    def _block_colour(self, frame: np.ndarray, reference: np.ndarray, stride: int
                      ) -> tuple[np.ndarray, tuple[int, int]]:
        """The network's colour input per ``stride`` x ``stride`` block: (n_blocks, 3)
        float32 block means, and the block grid's (rows, cols)."""
        if not (isinstance(stride, int | np.integer) and stride >= 1):
            raise ValueError(f"`stride` (={stride!r}) must be a whole number >= 1")
        frame = np.asarray(frame)
        reference = np.asarray(reference)
        if frame.ndim != 3 or frame.shape[-1] != 3 or frame.shape != reference.shape:
            raise ValueError(f"`frame` {frame.shape} and `reference` {reference.shape} must be "
                             "(H, W, 3) of the same size")
        k = int(stride)
        h, w = -(-frame.shape[0] // k), -(-frame.shape[1] // k)
        # int16: a sum of k <= MAX_STRIDE (16) values of -255..255 along a block's column
        if self.input_kind == "absolute":
            d = frame.astype(np.int16)
        else:
            d = np.subtract(frame, reference, dtype=np.int16)
        extra = (h * k - frame.shape[0], w * k - frame.shape[1])
        if any(extra):
            d = np.pad(d, ((0, extra[0]), (0, extra[1]), (0, 0)), mode="edge")
        # the k rows of a block: contiguous adds; then the k pixels of a block row as one
        # (k * 3) -> 3 product with the averaging matrix (numpy's reductions and adds over
        # a 3-wide strided axis are 15x slower than this product at 320x240)
        rows3 = d.reshape(h, k, w * k * 3)
        rows = rows3[:, 0].copy()
        for i in range(1, k):
            rows += rows3[:, i]
        pool = np.zeros((k * 3, 3), dtype=np.float32)
        for j in range(k):
            pool[j * 3:(j + 1) * 3] = np.eye(3, dtype=np.float32) / np.float32(k * k)
        colour = rows.reshape(h * w, k * 3).astype(np.float32) @ pool
        return colour, (h, w)

    def predict_pixels(self, table: np.ndarray) -> np.ndarray:
        """(n, 5) float32 rows in the run's channel order -> (n, 3) float32 unit normals."""
        t = np.asarray(table, dtype=np.float32)
        if t.ndim != 2 or t.shape[1] != len(self.channels):
            raise ValueError(f"`table` has shape {t.shape}; expected (n, {len(self.channels)}) "
                             f"with channels {list(self.channels)}")
        order = {name: i for i, name in enumerate(self.channels)}
        colour = (("dR", "dG", "dB") if self.input_kind == "difference" else ("R", "G", "B"))
        pos = np.ones((t.shape[0], 3), dtype=np.float32)
        pos[:, :2] = t[:, [order["x"], order["y"]]]
        return np.ascontiguousarray(self._unit_planar(
            np.ascontiguousarray(t[:, [order[k] for k in colour]]), pos, workers=1).T)


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


__all__ = ["TILE_PX", "NormalModel", "default_workers"]
