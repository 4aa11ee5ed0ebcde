"""Imprint retention: did the contact imprint of the grasp survive the lift?

The slip signal of eq. 10 (:mod:`.slip`) measures how *much* the gel changes from frame to
frame. In a lift every trial changes a lot (the gripper closes, the object's weight comes
onto the gel), held or slipped, so its size does not tell them apart (RESULTS.md: 55-60 %
on the real GelSight lifts). What does is *where* the change goes: when the object holds,
the imprint the grasp made stays where it is and only deepens; when it slips, the imprint
slides along the gel or fades as the object leaves it. This module measures that.

- :func:`mesh_means`: (n, H, W) maps -> (n, rows, cols) area means over the cells of a
  ``cols x rows`` mesh (the pixels beyond a whole number of cells are left out). Area
  means, not the mesh's sampled pixels (:func:`.mesh.sample_mesh`): averaging a 20 x 20 px
  cell keeps camera noise out of the shape.
- :func:`imprint_change`: the grasp frame ``g`` is the frame of the strongest imprint
  (largest mean absolute change from the reference) within the first ``grasp_part`` of the
  trial's frames; the retention ``r_t`` is the Pearson correlation over the mesh between
  frame ``g``'s map and frame ``t``'s (1: the same imprint, deeper or shallower; lower: it
  moved or changed shape); the trial's imprint change is ``1 - r`` at its last frame.
  Dimensionless, 0 to 2. The maps are taken relative to the trial's first map (``baseline
  'first'``): a reference frame from another time (the gel or the light moved between
  recordings) otherwise adds one pattern to every map, which the correlation follows (on
  the real lifts, a reference from the next lift of the same object: 17 of 20 right from
  the reference as given, 20 of 20 from the first frame).
- :func:`best_threshold`: the change threshold that best separates labelled slipped from
  held trials (largest detection rate minus false-alarm rate; among ties, the middle one).
  A trial whose change is *above* the threshold slipped.
- :func:`threshold_by_cv` (``--threshold auto``): that threshold by leave-one-group-out CV
  (groups: the ``object`` label when every labelled trial has one and there are two
  objects or more, else each trial its own group), scored on the held-out group, with the
  pooled accuracy's 95 % Wilson interval over trials; the threshold used is the one
  chosen on every labelled trial.
- :func:`slip_imprint_file` (``tactile slip-imprint``): all of it for every trial of an
  ingested frames file, on the intensity maps of :func:`.signals.intensity_maps` (the
  frames' colour change from the reference: no calibration needed).

Settings and where they come from: ``grasp_part`` 2/3 and mesh 32 x 24 were chosen on the
20 GelSight lifts of ``../shared/data/gelsight_slip`` after looking at them (grasp parts
0.6-0.75 and meshes 16 x 12 to 64 x 48 decide 18-20 of them under leave-one-object-out;
``benchmarks/slip_imprint_gelsight.py`` prints the whole grid): the thresholds are
cross-validated, the settings are not, so a figure on those 20 lifts is not a held-out
result for the method as a whole. The assumption is a lift protocol: the grasp is complete
within the first ``grasp_part`` of the recording and the outcome shows at its end.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..progress import NullProgress, Progress
from ..store.trials import TactileFile
from .heightmap import check_frame_times
from .slip import trial_maps, wilson_interval

#: Mesh (columns, rows) of the area means: 20 x 20 px cells on a 640 x 480 frame.
DEFAULT_MESH = (32, 24)
#: Share of a trial's frames within which the grasp is complete (the grasp frame is the
#: strongest imprint among them).
DEFAULT_GRASP_PART = 2.0 / 3.0
#: what the maps are taken relative to (:func:`imprint_change`)
BASELINES = ("first", "reference")
#: ``threshold`` value that learns the threshold from labelled trials
THRESHOLD_AUTO = "auto"
#: trial-label values read as slipped / held
SLIP_VALUES = ("slip", "slipped", "fail", "1", "true", "yes")
HELD_VALUES = ("no_slip", "held", "ok", "success", "0", "false", "no")


def mesh_means(maps: np.ndarray, mesh: tuple[int, int] = DEFAULT_MESH) -> np.ndarray:
    """(n, H, W) maps -> (n, rows, cols) float64 means over the cells of a ``mesh =
    (cols, rows)``; cells of ``H // rows`` x ``W // cols`` px from the top-left corner.
    ValueError when the mesh is denser than the maps."""
    m = np.asarray(maps, dtype=np.float64)
    if m.ndim != 3:
        raise ValueError(f"`maps` must be (n_frames, H, W); got shape {m.shape}")
    cols, rows = int(mesh[0]), int(mesh[1])
    n, h, w = m.shape
    if cols < 1 or rows < 1 or cols > w or rows > h:
        raise ValueError(f"the mesh {cols}x{rows} does not fit maps of {w}x{h} px")
    ch, cw = h // rows, w // cols
    return m[:, :rows * ch, :cols * cw].reshape(n, rows, ch, cols, cw).mean(axis=(2, 4))


@dataclass(frozen=True)
class ImprintChange:
    """One trial's imprint retention. grasp_index: the grasp frame ``g``; energy: (n,)
    mean absolute map value per frame (map units); retention: (n,) correlation with frame
    ``g`` (NaN at and before ``g``); change: ``1 - retention[-1]``."""

    grasp_index: int
    energy: np.ndarray
    retention: np.ndarray
    change: float


def imprint_change(maps: np.ndarray, *, mesh: tuple[int, int] = DEFAULT_MESH,
                   grasp_part: float = DEFAULT_GRASP_PART,
                   baseline: str = "first") -> ImprintChange:
    """The imprint change of one trial's (n_frames, H, W) maps (module docstring).
    ``baseline``: ``first`` takes every map relative to the trial's first map (a lift's
    first frame is before contact; a reference frame taken at another time adds its own
    pattern to every map, which this removes; with ``--reference first`` the first map is
    zero and nothing changes), ``reference``: the maps as given. ValueError when there is
    no frame after the grasp frame, ``grasp_part`` is outside (0, 1), or the grasp frame
    holds no imprint (a constant map)."""
    if baseline not in BASELINES:
        raise ValueError(f"`baseline` (={baseline!r}) must be one of {', '.join(BASELINES)}")
    if not (0.0 < grasp_part < 1.0):
        raise ValueError(f"`grasp_part` (={grasp_part}) must be between 0 and 1 (the share "
                         "of the frames within which the grasp is complete)")
    cells = mesh_means(maps, mesh)
    if baseline == "first":
        cells = cells - cells[0]
    n = cells.shape[0]
    k = int(np.ceil(grasp_part * n))
    if n < 2 or k >= n:
        raise ValueError(f"{n} frames leave none after the grasp part ({grasp_part:g} of "
                         "them); the imprint needs frames after the grasp")
    flat = cells.reshape(n, -1)
    flat = flat - flat.mean(axis=1, keepdims=True)
    energy = np.abs(cells).mean(axis=(1, 2))
    g = int(np.argmax(energy[:max(k, 1)]))
    norms = np.linalg.norm(flat, axis=1)
    if norms[g] == 0:
        raise ValueError(f"frame {g} (the strongest of the grasp part) is constant over the "
                         "mesh: no contact imprint to follow")
    retention = np.full(n, np.nan)
    after = np.arange(g + 1, n)
    with np.errstate(invalid="ignore", divide="ignore"):
        retention[after] = flat[after] @ flat[g] / (norms[after] * norms[g])
    last = retention[-1]
    change = float(1.0 - last) if np.isfinite(last) else 1.0
    return ImprintChange(g, energy, retention, change)


@dataclass(frozen=True)
class ThresholdChoice:
    """The change threshold chosen on labelled trials, the range of thresholds as good
    (lo, hi), and the trials decided right under it."""

    threshold: float
    lo: float
    hi: float
    correct: int
    n_trials: int


def _candidates(changes: np.ndarray) -> np.ndarray:
    v = np.unique(changes)
    mids = (v[:-1] + v[1:]) / 2 if v.size > 1 else np.empty(0)
    return np.concatenate([[v[0] - 1e-6], mids, [v[-1] + 1e-6]])


def best_threshold(changes: Sequence[float], slipped: Sequence[bool]) -> ThresholdChoice:
    """The threshold on ``changes`` (one per labelled trial) with the largest detection
    rate minus false-alarm rate against ``slipped``; among tied candidates (midpoints
    between neighbouring changes) the middle one. ValueError without trials."""
    c = np.asarray(changes, dtype=np.float64)
    y = np.asarray(slipped, dtype=bool)
    if c.size == 0 or c.size != y.size:
        raise ValueError("no labelled trials to choose a threshold on")
    cands = _candidates(c)
    above = c[None, :] > cands[:, None]
    n_slip, n_held = int(y.sum()), int((~y).sum())
    dr = above[:, y].sum(axis=1) / n_slip if n_slip else np.zeros(cands.size)
    far = above[:, ~y].sum(axis=1) / n_held if n_held else np.zeros(cands.size)
    score = dr - far
    tied = np.flatnonzero(np.isclose(score, score.max()))
    pick = int(tied[(tied.size - 1) // 2])
    thr = float(cands[pick])
    right = int(((c > thr) == y).sum())
    # the candidate between changes v[i-1] and v[i] decides as any threshold in [v[i-1],
    # v[i]) does (a trial slips when its change is > the threshold): the range as good is
    # from the change below the first tied candidate up to the one above the last
    v = np.unique(c)
    lo = float(v[tied[0] - 1]) if tied[0] > 0 else float(cands[0])
    hi = float(v[tied[-1]]) if tied[-1] < v.size else float(cands[-1])
    return ThresholdChoice(thr, lo, hi, right, int(c.size))


@dataclass(frozen=True)
class ThresholdFold:
    """One held-out group: the threshold chosen without it and its trials decided right."""

    group: str
    threshold: float
    n_trials: int
    correct: int


@dataclass(frozen=True)
class ThresholdCV:
    """The threshold learned by leave-one-group-out CV (``--threshold auto``): threshold
    (chosen on every labelled trial: the one used), its tie range, the grouping, one fold
    per held-out group, the held-out decisions pooled (correct of n_trials, detection and
    false-alarm rates) and the accuracy's 95 % Wilson interval over trials."""

    threshold: float
    lo: float
    hi: float
    group_by: str
    folds: tuple[ThresholdFold, ...]
    correct: int
    n_trials: int
    detection_rate: float
    false_alarm_rate: float
    interval: tuple[float, float]

    @property
    def accuracy(self) -> float:
        return self.correct / self.n_trials if self.n_trials else float("nan")

    def as_dict(self) -> dict[str, object]:
        return {"threshold": self.threshold, "threshold_range": [self.lo, self.hi],
                "group_by": self.group_by, "n_groups": len(self.folds),
                "cv_correct": self.correct, "cv_trials": self.n_trials,
                "cv_accuracy": self.accuracy,
                "cv_accuracy_interval": [round(v, 4) for v in self.interval],
                "cv_detection_rate": _finite(self.detection_rate),
                "cv_false_alarm_rate": _finite(self.false_alarm_rate),
                "folds": [{"group": f.group, "threshold": f.threshold,
                           "n_trials": f.n_trials, "correct": f.correct}
                          for f in self.folds]}


def threshold_by_cv(changes: Sequence[float], slipped: Sequence[bool],
                    groups: Sequence[str], *, group_by: str = "object") -> ThresholdCV:
    """Leave one group out: per fold :func:`best_threshold` on the other groups, scored on
    the held-out one (module docstring). ValueError with fewer than two groups."""
    c = np.asarray(changes, dtype=np.float64)
    y = np.asarray(slipped, dtype=bool)
    g = np.asarray([str(x) for x in groups])
    names = list(dict.fromkeys(g.tolist()))
    if len(names) < 2:
        raise ValueError(f"`threshold='auto'` needs labelled trials of at least two groups "
                         f"({group_by}) to cross-validate; found {len(names)}")
    folds: list[ThresholdFold] = []
    decided = np.zeros(c.size, dtype=bool)
    for name in names:
        held = g == name
        choice = best_threshold(c[~held], y[~held])
        decided[held] = c[held] > choice.threshold
        folds.append(ThresholdFold(name, choice.threshold, int(held.sum()),
                                   int((decided[held] == y[held]).sum())))
    right = int((decided == y).sum())
    final = best_threshold(c, y)
    dr = float(decided[y].mean()) if y.any() else float("nan")
    far = float(decided[~y].mean()) if (~y).any() else float("nan")
    return ThresholdCV(final.threshold, final.lo, final.hi, group_by, tuple(folds), right,
                       int(c.size), dr, far, wilson_interval(right, int(c.size)))


def _finite(v: float) -> float | None:
    return float(v) if np.isfinite(v) else None


def read_slipped(labels: dict[str, object], label: str, *, path: str, trial: str
                 ) -> bool | None:
    """The trial label ``label`` as slipped (True) / held (False); None when absent;
    InputError naming the trial's labels for another value."""
    value = labels.get(label)
    if value is None or str(value).strip() == "":
        return None
    text = str(value).strip().lower()
    if text in SLIP_VALUES:
        return True
    if text in HELD_VALUES:
        return False
    raise InputError(f"trial {trial!r} has label {label}={value!r}; expected one of "
                     f"{', '.join(SLIP_VALUES)} (slipped) or {', '.join(HELD_VALUES)} (held)",
                     path=path, where=f"/trials/{trial}/labels")


@dataclass
class TrialImprint:
    """One trial: its object label, slipped label (None without one), imprint change and
    the decision under the threshold used (slipped: change above it)."""

    trial: str
    object: str | None
    slipped: bool | None
    imprint: ImprintChange
    t_s: np.ndarray
    decided_slip: bool

    @property
    def correct(self) -> bool | None:
        return None if self.slipped is None else self.decided_slip == self.slipped

    def as_dict(self, *, with_curve: bool = True) -> dict[str, object]:
        im = self.imprint
        out: dict[str, object] = {
            "trial": self.trial, "object": self.object,
            "label": None if self.slipped is None else ("slip" if self.slipped else "held"),
            "grasp_frame": im.grasp_index, "grasp_s": float(self.t_s[im.grasp_index]),
            "imprint_change": im.change, "decided": "slip" if self.decided_slip else "held",
            "correct": self.correct}
        if with_curve:
            out["t_s"] = [float(v) for v in self.t_s]
            out["retention"] = [_finite(float(v)) for v in im.retention]
            out["energy"] = [float(v) for v in im.energy]
        return out


@dataclass
class ImprintFileResult:
    """Every trial's imprint change and decision; ``threshold_cv`` when the threshold was
    learned (``auto``); ``in_sample``: right/labelled under the threshold used (tuned on the
    same trials when learned: not a held-out figure)."""

    path: str
    mesh: tuple[int, int]
    grasp_part: float
    label: str
    threshold: float
    trials: list[TrialImprint]
    baseline: str = "first"
    threshold_cv: ThresholdCV | None = None
    plot: str | None = None
    warnings: list[str] = field(default_factory=list)

    def labelled(self) -> list[TrialImprint]:
        return [t for t in self.trials if t.slipped is not None]

    def in_sample(self) -> tuple[int, int]:
        lab = self.labelled()
        return sum(bool(t.correct) for t in lab), len(lab)

    def as_dict(self, *, with_curve: bool = True) -> dict[str, object]:
        right, n = self.in_sample()
        return {
            "file": self.path, "source": "intensity",
            "mesh": f"{self.mesh[0]}x{self.mesh[1]}", "grasp_part": self.grasp_part,
            "baseline": self.baseline,
            "label": self.label,
            "threshold": THRESHOLD_AUTO if self.threshold_cv else self.threshold,
            "threshold_used": self.threshold,
            "threshold_cv": None if self.threshold_cv is None else self.threshold_cv.as_dict(),
            "labelled_trials": n, "correct": right if n else None,
            "accuracy": right / n if n else None,
            "accuracy_is_in_sample": bool(self.threshold_cv) and n > 0,
            "trials": [t.as_dict(with_curve=with_curve) for t in self.trials],
            "plot": self.plot, "warnings": list(self.warnings)}

    def table(self) -> tuple[str, list[str], list[list[str]]]:
        rows = [[t.trial, t.object or "-",
                 "-" if t.slipped is None else ("slip" if t.slipped else "held"),
                 str(t.imprint.grasp_index), f"{t.imprint.change:.4f}",
                 "slip" if t.decided_slip else "held",
                 "-" if t.correct is None else ("yes" if t.correct else "NO")]
                for t in self.trials]
        title = (f"imprint change on mesh {self.mesh[0]}x{self.mesh[1]}, grasp within the "
                 f"first {self.grasp_part:.2f} of the frames; slip when above "
                 f"{self.threshold:.4f}")
        return title, ["trial", "object", "label", "grasp frame", "change", "decided",
                       "right"], rows

    def summary_lines(self) -> list[str]:
        lines: list[str] = []
        cv = self.threshold_cv
        if cv is not None:
            lo, hi = cv.interval
            lines.append(
                f"held out ({cv.group_by}, {len(cv.folds)} folds): {cv.correct}/"
                f"{cv.n_trials} right = {100 * cv.accuracy:.1f} % [95 % Wilson "
                f"{100 * lo:.1f}, {100 * hi:.1f}]; thresholds per fold: "
                + ", ".join(f"{f.group} {f.threshold:.4f} ({f.correct}/{f.n_trials})"
                            for f in cv.folds))
            lines.append(f"threshold {cv.threshold:.4f} (chosen on all {cv.n_trials} "
                         f"labelled trials; as good from {cv.lo:.4f} up to {cv.hi:.4f})")
        right, n = self.in_sample()
        if n:
            tag = ("on the trials it was chosen on: not a held-out figure" if cv is not None
                   else "threshold given, not tuned here")
            lines.append(f"labelled trials decided right: {right}/{n} ({tag})")
        if self.plot:
            lines.append(f"wrote {self.plot}")
        return lines


def slip_imprint_file(path: str | os.PathLike[str], *, mesh: tuple[int, int] = DEFAULT_MESH,
                      grasp_part: float = DEFAULT_GRASP_PART,
                      threshold: float | str = THRESHOLD_AUTO, label: str = "slip",
                      baseline: str = "first",
                      trials: Sequence[str] | None = None, progress: Progress | None = None,
                      plot: str | os.PathLike[str] | None = None,
                      overwrite: bool = False) -> ImprintFileResult:
    """The imprint change of every trial of ``path`` (an ingested frames file with a
    reference frame), the slip decision per trial and, with trial label ``label``
    (slipped/held values: :data:`SLIP_VALUES`, :data:`HELD_VALUES`), its accuracy.

    threshold: a number (a trial slipped when its change is above it), or ``'auto'``: the
    threshold learned by :func:`threshold_by_cv` on the labelled trials. plot: a PNG of
    each trial's retention over time and the changes against the threshold (checked
    before any work; an existing file is replaced only with ``overwrite``)."""
    auto = isinstance(threshold, str)
    if auto and threshold != THRESHOLD_AUTO:
        raise InputError(f"`threshold` (={threshold!r}) must be a number or "
                         f"{THRESHOLD_AUTO!r}")
    if not auto and not np.isfinite(float(threshold)):  # type: ignore[arg-type]
        raise InputError(f"`threshold` (={threshold}) must be a finite number or "
                         f"{THRESHOLD_AUTO!r}")
    if not (0.0 < grasp_part < 1.0):
        raise InputError(f"`grasp_part` (={grasp_part}) must be between 0 and 1 (the share "
                         "of the frames within which the grasp is complete)")
    if baseline not in BASELINES:
        raise InputError(f"`baseline` (={baseline!r}) must be one of {', '.join(BASELINES)}")
    if plot is not None:
        from ..input_guard import check_outputs

        check_outputs({"plot": plot}, [path])
        plot = os.path.abspath(plot)
        if os.path.exists(plot) and not overwrite:
            raise InputError(f"{plot} exists; pass `overwrite` to replace it")
    prog = progress or NullProgress()
    found: list[tuple[str, str | None, bool | None, ImprintChange, np.ndarray]] = []
    with TactileFile(path) as tf:
        chosen = tf.trials(list(trials)) if trials is not None else tf.trials()
        if not chosen:
            raise InputError("the file holds no trials", path=tf.path)
        prog.start(len(chosen), "imprints")
        for t in chosen:
            slipped = read_slipped(t.labels, label, path=tf.path, trial=t.name)
            maps, t_s = trial_maps(t, "intensity", None)
            t_s = check_frame_times(t_s, t)
            try:
                im = imprint_change(maps, mesh=mesh, grasp_part=grasp_part,
                                    baseline=baseline)
            except ValueError as exc:
                raise InputError(f"trial {t.name!r}: {exc}", path=tf.path,
                                 where=f"/trials/{t.name}") from None
            obj = t.labels.get("object")
            found.append((t.name, None if obj is None else str(obj), slipped, im, t_s))
            prog.advance()
        cv = None
        if auto:
            lab = [f for f in found if f[2] is not None]
            if len({bool(f[2]) for f in lab}) < 2:
                raise InputError(f"`threshold='auto'` needs labelled trials of both classes "
                                 f"(trial label {label!r}: slipped and held); found "
                                 f"{len(lab)} labelled trials"
                                 + ("" if not lab else " of one class")
                                 + "; pass a number as `threshold`", path=tf.path)
            objects = [f[1] for f in lab]
            by_object = all(o is not None for o in objects) and len(set(objects)) >= 2
            groups = [str(o) for o in objects] if by_object else [f[0] for f in lab]
            cv = threshold_by_cv([f[3].change for f in lab], [bool(f[2]) for f in lab],
                                 groups, group_by="object" if by_object else "trial")
            used = cv.threshold
        else:
            used = float(threshold)  # type: ignore[arg-type]
    out = [TrialImprint(name, obj, slipped, im, t_s, im.change > used)
           for name, obj, slipped, im, t_s in found]
    result = ImprintFileResult(str(path), (int(mesh[0]), int(mesh[1])), float(grasp_part),
                               label, used, out, baseline=baseline, threshold_cv=cv)
    if plot is not None:
        _plot(result, plot)
        result.plot = str(plot)
    return result


def _plot(result: ImprintFileResult, out: str) -> None:
    """Retention over time per trial (left) and each trial's change against the threshold
    (right), coloured by label."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..store.atomic import save_figure

    colours = {True: "tab:red", False: "tab:blue", None: "0.5"}
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.2), width_ratios=(1.6, 1))
    for t in result.trials:
        ax.plot(t.t_s, t.imprint.retention, color=colours[t.slipped], lw=1, alpha=0.8)
    ax.axhline(1 - result.threshold, color="k", ls="--", lw=1,
               label=f"1 - threshold ({1 - result.threshold:.3f})")
    ax.set(xlabel="time (s)", ylabel="retention: correlation with the grasp frame",
           title="imprint retention (red: slipped, blue: held, grey: unlabelled)")
    ax.legend(loc="lower left", fontsize=8)
    floor = 1e-4  # changes below this (a perfectly kept imprint) are drawn at it
    for i, t in enumerate(result.trials):
        bx.plot(max(t.imprint.change, floor), i, "o", color=colours[t.slipped])
    bx.axvline(max(result.threshold, floor), color="k", ls="--", lw=1)
    bx.set_xscale("log")
    bx.set(xlabel="imprint change 1 - r (last frame)", yticks=[],
           title=f"slip when right of {result.threshold:.4f}")
    fig.tight_layout()
    save_figure(fig, out, overwrite=True,
                meta={"Source": result.path, "Software": "tactile slip-imprint"})


__all__ = ["BASELINES", "DEFAULT_GRASP_PART", "DEFAULT_MESH", "HELD_VALUES", "SLIP_VALUES",
           "THRESHOLD_AUTO", "ImprintChange", "ImprintFileResult", "ThresholdCV",
           "ThresholdChoice", "ThresholdFold", "TrialImprint", "best_threshold",
           "imprint_change", "mesh_means", "read_slipped", "slip_imprint_file",
           "threshold_by_cv"]
