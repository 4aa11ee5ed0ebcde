"""Height maps of a visuotactile recording (paper 002, sec. II-B, Fig. 2).

Per frame: the normal model (:mod:`.normals`) predicts a unit normal per pixel from the
frame and its no-contact reference, eq. 9 turns normals into gradients and the DST
Poisson solver (:mod:`.poisson`) integrates them into heights in mm
(:class:`HeightMapper`). :func:`heightmap_file` does it for every trial of an ingested
file and writes a new tactile HDF5 file.

Output layout (no schema change: a sampled stream holds any per-frame vector). Per trial
the stream ``height_mm``, data (n_frames, H * W) float32 mm, row-major (row 0 first),
``t_s`` the frame times; sensor ``heightmap`` (kind ``visuotactile``, ``width_px``,
``height_px``, ``px_per_mm``, the frame rate; channels ``r<row>c<col>`` in unit mm).
:func:`read_height_maps` gives them back as (n_frames, H, W). Trial labels, splits and
annotations are copied; the provenance lists the input file and the model run's
``model.pt`` (SHA-256), and the config records the run folder.

Skipping flat pixels (``skip_below``): pixels whose colour differs from the reference by
less than ``skip_below`` (0-255 units, every channel) are taken as flat (normal
(0, 0, 1)) without running the network. Off by default; its cost in height RMSE is
measured next to its speed by ``benchmarks/heightmap.py``.

Blocks (``stride`` k > 1, for camera rate): one network prediction per k x k block of
pixels, from the block's mean colour difference at the block's centre; eq. 9 and the
Poisson solve on the block grid (k / px_per_mm mm per block); the heights interpolated
bilinearly back to every pixel (:meth:`HeightMapper._to_pixels`). About k^2 less work
for the network and the solve; heights lose detail finer than a block. Its speed and
height RMSE beside every-pixel maps: ``benchmarks/heightmap.py``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..interrupt import raise_if_requested
from ..progress import NullProgress, Progress
from ..store import StoreWriter
from ..store.trials import TactileFile, Trial
from .normals import NormalModel, default_workers
from .poisson import NZ_FLOOR, PoissonSolver, gradients_from_normals

STREAM = "height_mm"
SENSOR = "heightmap"
#: The gel scales a camera can have, pixels per mm (a pixel from 1 m down to 0.1 um): a
#: scale outside makes heights that vanish (or overflow) in float32.
PX_PER_MM_RANGE = (1e-3, 1e4)


def check_px_per_mm(value: object, *, what: str | None = None,
                    path: str | Path | None = None, where: str | None = None) -> float:
    """``value`` as a gel scale in pixels per mm inside :data:`PX_PER_MM_RANGE`; one
    :class:`InputError` otherwise, naming the argument ``px_per_mm`` or ``what`` (``"sensor
    attribute px_per_mm"``)."""
    lo, hi = PX_PER_MM_RANGE
    ok = (isinstance(value, int | float | np.integer | np.floating)
          and not isinstance(value, bool) and bool(np.isfinite(value)) and lo <= value <= hi)
    if not ok:
        shown = f"`px_per_mm` (={value!r})" if what is None else f"{what} is {value!r}; it"
        raise InputError(f"{shown} must be a gel scale from {lo:g} to {hi:g} pixels per mm",
                         path=path, where=where)
    return float(value)  # type: ignore[arg-type]


@dataclass
class HeightMapper:
    """Frame -> height map. model: a :class:`NormalModel`; px_per_mm: the gel's scale;
    workers: threads (network tiles and FFTs); skip_below: see the module docstring
    (None: off); nz_floor: eq. 9's floor on nz; stride: see the module docstring (1:
    every pixel)."""

    model: NormalModel
    px_per_mm: float
    workers: int = field(default_factory=default_workers)
    skip_below: float | None = None
    nz_floor: float = NZ_FLOOR
    stride: int = 1
    _solvers: dict[tuple[int, int], PoissonSolver] = field(default_factory=dict, repr=False)
    _upsample: dict[tuple[int, int], tuple[np.ndarray, ...]] = field(default_factory=dict,
                                                                    repr=False)

    def __post_init__(self) -> None:
        check_px_per_mm(self.px_per_mm)
        if self.skip_below is not None and not (np.isfinite(self.skip_below)
                                                and self.skip_below >= 0):
            raise InputError(f"`skip_below` (={self.skip_below}) must be >= 0 colour units")
        self.stride = check_stride(self.stride, skip_below=self.skip_below)

    def solver(self, height: int, width: int) -> PoissonSolver:
        """The Poisson solver of a (height, width) gradient grid (at the mapper's stride:
        its pixels are ``stride`` frame pixels wide)."""
        key = (height, width)
        if key not in self._solvers:
            self._solvers[key] = PoissonSolver(height, width, self.px_per_mm / self.stride,
                                               workers=self.workers, dtype=np.float32)
        return self._solvers[key]

    def normals(self, frame: np.ndarray, reference: np.ndarray) -> np.ndarray:
        """(H, W, 3) uint8 frame and reference -> (H, W, 3) float32 unit normals."""
        if self.skip_below is None:
            return self.model.predict(frame, reference, workers=self.workers)
        diff = np.abs(frame.astype(np.int16) - reference.astype(np.int16)).max(axis=-1)
        return self.model.predict(frame, reference, workers=self.workers,
                                  active=diff >= self.skip_below)

    def __call__(self, frame: np.ndarray, reference: np.ndarray) -> np.ndarray:
        """(H, W, 3) uint8 frame and reference -> (H, W) float32 heights in mm."""
        if self.skip_below is None:  # gradients straight from the network, no normals kept
            gx, gy = self.model.gradients(frame, reference, nz_floor=self.nz_floor,
                                          workers=self.workers, stride=self.stride)
        else:
            gx, gy = gradients_from_normals(self.normals(frame, reference),
                                            nz_floor=self.nz_floor)
        heights = self.solver(*gx.shape).integrate(gx, gy)
        if self.stride == 1:
            return heights
        return self._to_pixels(heights, frame.shape[:2])

    def _to_pixels(self, coarse: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
        """(h, w) heights of the stride's blocks -> (H, W) heights of the frame's pixels:
        bilinear between block centres (pixel centre i sits at block coordinate
        (i + 0.5) / k - 0.5), the edge blocks' values held beyond their centres."""
        key = (int(shape[0]), int(shape[1]))
        if key not in self._upsample:
            axes = []
            for n_px, n_blocks in zip(key, coarse.shape, strict=True):
                at = np.clip((np.arange(n_px) + 0.5) / self.stride - 0.5, 0, n_blocks - 1)
                i0 = np.floor(at).astype(np.intp)
                i1 = np.minimum(i0 + 1, n_blocks - 1)
                wt = (at - i0).astype(np.float32)
                axes += [i0, i1, wt]
            self._upsample = {key: tuple(axes)}
        r0, r1, rw, c0, c1, cw = self._upsample[key]
        rows = coarse[r0] * (1 - rw)[:, None] + coarse[r1] * rw[:, None]
        return (rows[:, c0] * (1 - cw) + rows[:, c1] * cw).astype(np.float32, copy=False)


#: the largest block side of ``stride``: a 16 x 16 block is 1.7 mm at 9.45 px/mm (the
#: GelSight presses in ../shared/data)
MAX_STRIDE = 16


def check_stride(value: object, *, skip_below: float | None = None) -> int:
    """``value`` as a block side from 1 to :data:`MAX_STRIDE`; one InputError otherwise, or
    when blocks (``value`` > 1) come with ``skip_below`` (two ways of skipping work)."""
    ok = (isinstance(value, int | np.integer) and not isinstance(value, bool)
          and 1 <= value <= MAX_STRIDE)
    if not ok:
        raise InputError(f"`stride` (={value!r}) must be a whole number of pixels from 1 to "
                         f"{MAX_STRIDE}")
    if value > 1 and skip_below is not None:  # type: ignore[operator]
        raise InputError("`skip_below` and `stride` > 1 cannot be combined: choose one way "
                         "of skipping work")
    return int(value)  # type: ignore[arg-type]


def frames_px_per_mm(tf: TactileFile, trial: Trial, px_per_mm: float | None) -> float:
    """``px_per_mm`` if given, else the frames sensor's attribute; one InputError naming
    the file otherwise."""
    if px_per_mm is not None:
        return check_px_per_mm(px_per_mm)
    name = trial.frames().sensor_name
    value = tf.sensor(name).attrs.get("px_per_mm") if name in tf.sensor_names else None
    if value is None:
        raise InputError(f"sensor {name!r} has no px_per_mm attribute; ingest the images with "
                         "`tactile ingest --px-per-mm` or pass `px_per_mm`", path=tf.path,
                         where=f"/sensors/{name}")
    return check_px_per_mm(value, what="px_per_mm", path=tf.path, where=f"/sensors/{name}")


def absolute_folder(folder: str | Path) -> Path:
    """``folder`` made absolute, ``.`` and ``..`` removed (an output folder named ``.`` is
    the current folder, built beside it like any other)."""
    import os

    return Path(os.path.abspath(folder))


def check_frame_times(t_s: np.ndarray, trial: Trial) -> np.ndarray:
    """``t_s`` (n_frames,) of ``trial``'s frames, refused unless finite and strictly
    increasing (repeated times would make every frame-to-frame change look instant)."""
    t_s = np.asarray(t_s, dtype=np.float64)
    if not np.isfinite(t_s).all() or (t_s.size > 1 and not (np.diff(t_s) > 0).all()):
        raise InputError(f"trial {trial.name!r}: frame times are not finite and strictly "
                         "increasing; each frame needs its own time", path=trial.path,
                         where=f"{trial.where}/frames/t_s")
    return t_s


def frame_trials(tf: TactileFile) -> list[Trial]:
    """Trials of ``tf`` that hold frames; InputError when none does."""
    trials = [t for t in tf.trials() if t.has_frames]
    if not trials:
        raise InputError("no trial holds frames (an image sequence); ingest a visuotactile "
                         "recording with `tactile ingest`", path=tf.path)
    return trials


def trial_heights(mapper: HeightMapper, trial: Trial) -> tuple[np.ndarray, np.ndarray]:
    """(n_frames, H, W) float32 mm and (n_frames,) t_s of one trial's frames."""
    frames = trial.frames()
    if len(frames) == 0:
        raise InputError(f"trial {trial.name!r} holds 0 frames; a height map needs one",
                         path=trial.path, where=f"{trial.where}/frames")
    ref = frames.reference
    h, w = frames.shape[:2]
    out = np.empty((len(frames), h, w), dtype=np.float32)
    for k, (_, image) in enumerate(frames):
        raise_if_requested()
        out[k] = mapper(image, ref)
    return out, frames.t_s


def load_truth(truth_dir: Path, trial: str, shape: tuple[int, ...]) -> np.ndarray:
    """``truth_dir/<trial>.npz`` ``height_mm`` checked against ``shape``."""
    path = Path(truth_dir) / f"{trial}.npz"
    if not path.is_file():
        raise InputError(f"no ground truth for trial {trial!r} (expected {path.name} from "
                         "`tactile simulate digit-press`)", path=truth_dir)
    from .simulate import read_truth

    arrays = read_truth(path)
    if "height_mm" not in arrays:
        raise InputError("not a truth file with height_mm (no height_mm array in it)",
                         path=path)
    try:
        truth = np.asarray(arrays["height_mm"], dtype=np.float32)
    except (TypeError, ValueError) as exc:
        raise InputError(f"not a truth file with height_mm ({str(exc).splitlines()[0]})",
                         path=path) from None
    if not np.isfinite(truth).all():
        raise InputError("height_mm holds NaN or infinite heights", path=path)
    if truth.shape != shape:
        raise InputError(f"height_mm has shape {truth.shape}; the trial's height maps are "
                         f"{shape}", path=path)
    return truth


@dataclass(frozen=True)
class TrialHeights:
    """One trial's summary: frames, largest height (mm), RMSE against the truth over all
    pixels and over the truth's contact pixels (height > 0), mm (None without truth)."""

    trial: str
    n_frames: int
    peak_mm: float
    rmse_mm: float | None = None
    rmse_contact_mm: float | None = None
    true_peak_mm: float | None = None


@dataclass(frozen=True)
class HeightmapResult:
    """What :func:`heightmap_file` wrote: the output, per-trial summaries, the overall
    RMSE (root of the mean square over every pixel of every trial, mm), the time spent
    per frame (ms, reading included) and the folder of figures (``plot``), if any."""

    out: Path
    trials: list[TrialHeights]
    rmse_mm: float | None
    rmse_contact_mm: float | None
    ms_per_frame: float
    px_per_mm: float
    run_dir: str
    plot: Path | None = None
    #: one line each: frames of another unit or scale than the model's calibration
    warnings: list[str] = field(default_factory=list)

    def as_dict(self) -> dict[str, Any]:
        return {"out": str(self.out), "run": self.run_dir, "px_per_mm": self.px_per_mm,
                "warnings": list(self.warnings),
                "rmse_mm": self.rmse_mm, "rmse_contact_mm": self.rmse_contact_mm,
                "ms_per_frame": self.ms_per_frame,
                "trials": [t.__dict__ for t in self.trials]}

    def summary_lines(self) -> list[str]:
        lines = [f"warning: {w}" for w in self.warnings]
        lines += [f"wrote {self.out}: {sum(t.n_frames for t in self.trials)} height maps of "
                 f"{len(self.trials)} trial(s), {self.ms_per_frame:.1f} ms per frame (reading "
                 f"and writing included), px_per_mm {self.px_per_mm:g}"]
        if self.rmse_mm is not None:
            lines.append(f"height RMSE vs truth: {self.rmse_mm:.4f} mm over all pixels, "
                         f"{self.rmse_contact_mm:.4f} mm over contact pixels")
        return lines + ([f"wrote {self.plot}/height_*.png"] if self.plot is not None else [])


def _rmse(sq: float, n: int) -> float | None:
    return float(np.sqrt(sq / n)) if n else None


def _check_heightmap_outputs(path: str | Path, run_dir: str | Path, out: str | Path,
                             truth_dir: str | Path | None, plot: str | Path | None, *,
                             overwrite: bool) -> None:
    """Before any work: no output is, contains or lies inside an input (the frames file, the
    run's model, the truth folder); the outputs can be written."""
    from ..input_guard import check_outputs
    from ..store.atomic import check_output_file
    from ..store.outdir import check_output_folder

    check_outputs({"out": out, "plot": plot}, [path, Path(run_dir) / "model.pt"],
                  trees=[truth_dir])
    check_output_file(out, overwrite=overwrite)
    if plot is not None:
        check_output_folder(plot, merge=True)
    if truth_dir is not None and not Path(truth_dir).is_dir():
        raise InputError("truth folder not found (give a scene's truth/ folder)",
                         path=truth_dir)


def _figures(tf: TactileFile, folder: Path, peaks: dict[str, tuple[int, np.ndarray]],
             truth_dir: str | Path | None, px_per_mm: float) -> None:
    """One Fig. 2-style PNG per trial in ``folder``: its frame of largest height."""
    from .plots import height_figure

    for name, (k, heights) in peaks.items():
        true = None
        if truth_dir is not None:
            shape = (len(tf.trial(name).frames()), *heights.shape)
            true = load_truth(Path(truth_dir), name, shape)[k]
        height_figure(tf.trial(name).frames()[k], heights, px_per_mm,
                      folder / f"height_{name}.png", truth_mm=true, title=f"{name}, frame {k}")


def heightmap_file(path: str | Path, run_dir: str | Path, out: str | Path, *,
                   truth_dir: str | Path | None = None, px_per_mm: float | None = None,
                   skip_below: float | None = None, stride: int = 1,
                   workers: int | None = None,
                   trials: Sequence[str] | None = None, overwrite: bool = False,
                   command: str | None = None, progress: Progress | None = None,
                   plot: str | Path | None = None,
                   keep: dict[str, np.ndarray] | None = None) -> HeightmapResult:
    """Height maps of every frame of every trial with frames in ``path`` (or of
    ``trials``), written to the new file ``out`` (see the module docstring). With
    ``truth_dir`` (the scene's ``truth/``) the RMSE against the true heights is reported;
    with ``plot`` a folder gets one Fig. 2-style PNG per trial (the frame of largest
    height), same-named files replaced. ``workers`` threads (BLAS and OpenMP included;
    results do not depend on it). ``keep``, when given, receives trial -> (n_frames, H, W)
    heights. Outputs are checked before any work and written only when all succeeded."""
    import contextlib
    import time

    from ..store.outdir import output_folder
    from ..threads import check_threads, limit_threads

    plot = None if plot is None else absolute_folder(plot)
    _check_heightmap_outputs(path, run_dir, out, truth_dir, plot, overwrite=overwrite)
    threads = default_workers() if workers is None else check_threads(workers, "workers")
    progress = progress or NullProgress()
    with limit_threads(threads):
        model = NormalModel.from_run(run_dir)
    run_path = Path(run_dir)
    stride = check_stride(stride, skip_below=skip_below)  # before the model is loaded
    config = {"run": str(run_dir), "px_per_mm": px_per_mm, "skip_below": skip_below,
              "stride": stride,
              "truth": None if truth_dir is None else str(truth_dir),
              "nz_floor": NZ_FLOOR, "input_kind": model.input_kind,
              "sensor_unit": None if model.calibration is None
              else model.calibration.as_dict()}
    summaries: list[TrialHeights] = []
    peaks: dict[str, tuple[int, np.ndarray]] = {}
    sq_all = sq_contact = 0.0
    n_all = n_contact = 0
    n_frames = 0
    t0 = time.perf_counter()
    with TactileFile(path) as tf, limit_threads(threads):
        chosen = frame_trials(tf)
        if trials is not None:
            chosen = tf.trials(list(trials))
        scale = frames_px_per_mm(tf, chosen[0], px_per_mm)
        warnings = model.check_frames(tf, chosen[0], scale)
        mapper = HeightMapper(model, scale, skip_below=skip_below, stride=stride,
                              workers=threads)
        with StoreWriter(out, command=command, config=config, overwrite=overwrite) as w:
            source = w.add_source(path)
            model_source = w.add_source(run_path / "model.pt")
            progress.start(len(chosen), "height maps")
            sensor = None
            for trial in chosen:
                if not trial.has_frames:
                    raise InputError(f"trial {trial.name!r} holds no frames", path=tf.path)
                heights, t_s = trial_heights(mapper, trial)
                n, h, wd = heights.shape
                if sensor is None:
                    fr = trial.frames()
                    src = (tf.sensor(fr.sensor_name) if fr.sensor_name in tf.sensor_names
                           else None)
                    rate = src.sample_rate_hz if src is not None else 0.0
                    if not rate > 0:
                        step = np.median(np.diff(t_s)) if n > 1 else 0.0
                        rate = 1.0 / step if step > 0 else 30.0
                    sensor = w.add_sensor(
                        SENSOR, kind="visuotactile", sample_rate_hz=float(rate),
                        channel_names=[f"r{r}c{c}" for r in range(h) for c in range(wd)],
                        channel_units="mm", width_px=wd, height_px=h, px_per_mm=scale,
                        description="height maps from the MLP normals and Poisson "
                                    "integration (paper 002, sec. II-B); data row-major")
                    shape = (h, wd)
                elif (h, wd) != shape:
                    raise InputError(f"trial {trial.name!r} has frames of {wd}x{h} px; earlier "
                                     f"trials have {shape[1]}x{shape[0]}", path=tf.path)
                check_frame_times(t_s, trial)
                tw = w.trial(trial.name, labels=trial.labels, split=trial.split,
                             sources=[source, model_source],
                             annotations=[(a.start_s, a.end_s, a.label)
                                          for a in trial.annotations])
                tw.write_signal(STREAM, sensor=sensor, data=heights.reshape(n, -1), t_s=t_s)
                summary = TrialHeights(trial.name, n, float(heights.max(initial=0.0)))
                if truth_dir is not None:
                    truth = load_truth(Path(truth_dir), trial.name, heights.shape)
                    err = (heights - truth).astype(np.float64) ** 2
                    contact = truth > 0
                    sq_all += float(err.sum())
                    n_all += err.size
                    sq_contact += float(err[contact].sum())
                    n_contact += int(contact.sum())
                    summary = TrialHeights(trial.name, n, summary.peak_mm,
                                           _rmse(float(err.sum()), err.size),
                                           _rmse(float(err[contact].sum()),
                                                 int(contact.sum())),
                                           float(truth.max(initial=0.0)))
                if keep is not None:
                    keep[trial.name] = heights
                if plot is not None:
                    k = int(heights.reshape(n, -1).max(axis=1).argmax())
                    peaks[trial.name] = (k, heights[k].copy())
                summaries.append(summary)
                n_frames += n
                progress.advance()
            elapsed = time.perf_counter() - t0  # the figures are not height maps' time
            with (output_folder(plot, merge=True) if plot is not None
                  else contextlib.nullcontext()) as folder:
                if folder is not None:  # before the commit: both outputs or neither
                    _figures(tf, folder, peaks, truth_dir, scale)
                w.commit()
    return HeightmapResult(Path(out), summaries, _rmse(sq_all, n_all),
                           _rmse(sq_contact, n_contact),
                           1e3 * elapsed / max(1, n_frames), scale, str(run_dir),
                           None if plot is None else Path(plot), warnings)


def read_height_maps(trial: Trial) -> tuple[np.ndarray, np.ndarray, float]:
    """A heightmap file's trial -> (n_frames, H, W) float32 mm, (n_frames,) t_s and the
    sensor's px_per_mm; InputError naming the file when the trial has no such stream."""
    if not trial.has_signal(STREAM):
        raise InputError(f"trial {trial.name!r} has no {STREAM} stream; write one with "
                         "`tactile heightmap`", path=trial.path, where=trial.where)
    sig = trial.signal(STREAM)
    h, w = sig.sensor.height_px, sig.sensor.width_px
    if h is None or w is None or h * w != sig.data.shape[1]:
        raise InputError(f"sensor {sig.sensor.name!r} has width_px x height_px {w}x{h}, not "
                         f"the stream's {sig.data.shape[1]} values per frame",
                         path=trial.path, where=sig.where)
    return (sig.data.reshape(-1, h, w), sig.t_s,
            float(sig.sensor.attrs.get("px_per_mm", float("nan"))))


__all__ = ["PX_PER_MM_RANGE", "SENSOR", "STREAM", "HeightMapper", "HeightmapResult",
           "TrialHeights", "absolute_folder", "check_frame_times", "check_px_per_mm",
           "frame_trials", "frames_px_per_mm", "heightmap_file", "load_truth",
           "read_height_maps", "trial_heights"]
