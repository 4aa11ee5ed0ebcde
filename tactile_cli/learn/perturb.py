"""Stability of a trained run: accuracy on perturbed copies of the evaluation data.

Issue 4, item 9. The perturbations are pure functions on one trial's samples, ``x`` of
shape (n_samples, n_channels) in the sensor's units (before the run's transform and
normalisation), each with an explicit seed; the same seed gives the same copy:

* :func:`add_noise`: additive white Gaussian noise at a signal-to-noise ratio in dB. The
  signal power is the mean square of each channel over the trial (DC included), so every
  channel of every trial gets noise of power ``P_channel / 10**(snr_db / 10)``.
* :func:`lowpass`: zero-phase Butterworth low-pass (``scipy.signal.butter`` order 4 as
  second-order sections, ``sosfiltfilt``). The cut-offs of :func:`lowpass_cutoffs` start
  at half the Nyquist frequency and halve step by step, the bandwidth study of paper 001,
  sec. 6.4 (there from 4 kHz down to 31.25 Hz in seven halvings).
* :func:`drop_samples`: a fraction of the samples is lost (at random positions) and each
  lost sample is replaced by the last sample received before it (``fill="hold"``, what a
  real-time reader that misses a packet shows; samples lost before the first received one
  take the first received value) or by linear interpolation between its received
  neighbours (``fill="interp"``). The length, and so the alignment with the per-sample
  labels, is kept. With one seed the lost sets are nested: a larger fraction loses the
  samples of the smaller one and more.
* :func:`thin_counts`: dropped events in an event-count stream; each event of a bin is
  kept independently with probability ``keep`` (binomial thinning, so the expected count
  is ``keep * count``). A signed count (``net``) is thinned in magnitude with its sign
  kept, which is exact when a bin's events share one polarity; when a trial has both
  ``positive`` and ``negative`` channels those are thinned and ``net`` is recomputed as
  their difference.
* :func:`scale_time`: the actions run ``factor`` times longer (0.5 = twice as fast, 2 =
  half as fast): the sequence is resampled to ``round(n factor)`` samples at the same
  sample rate (linear interpolation, sample centres aligned) and each per-sample label is
  taken from the nearest source sample, so label proportions are kept to within a sample
  per label change. For event counts (``conserve_sum``) the values are divided by the
  factor: the same events spread over more bins, as a slower press produces fewer events
  per bin.

:func:`perturb_evaluate` re-runs the run's evaluation pipeline (the functions of
:mod:`.data`, :func:`.train.predict` and :func:`.evaluate.head_metrics`, as ``tactile
evaluate`` does, refusing data of another sample period, channels or units than the
run's: :mod:`.inputs`) on perturbed copies held in memory (no data file is written), gives
the primary head's accuracy at every level and the breaking point: walking from the clean
data towards more severe levels, the first level where the accuracy falls below the
threshold (default 0.9 x the clean accuracy). Time scaling has two directions (faster and
slower) and a breaking point in each. Results go to ``RUN/perturb/<name>/``
(``perturb.json`` with provenance, ``perturb.csv``, ``perturb.png``);
:func:`plot_perturbations` draws one panel per kind and one line per run.
"""

from __future__ import annotations

import csv
import io
import math
import zlib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any, Literal

import numpy as np

from .._version import __version__
from ..errors import InputError
from ..store.outdir import check_output_folder, output_folder
from ..store.provenance import current_command, sha256_of, utc_now
from . import runs

PERTURB_DIR = "perturb"
PERTURB_JSON = "perturb.json"
PERTURB_CSV = "perturb.csv"
PERTURB_PNG = "perturb.png"
PERTURB_FORMAT = "tactile-perturb"
PERTURB_FORMAT_VERSION = 1

#: Kinds accepted by :func:`perturb_evaluate`; ``drop`` resolves to ``drop_events`` for
#: event-count streams and ``drop_samples`` otherwise.
KINDS: tuple[str, ...] = ("noise", "lowpass", "drop", "drop_events", "drop_samples", "scale")
DEFAULT_KINDS: tuple[str, ...] = ("noise", "lowpass", "drop", "scale")
#: Default levels, mild to severe: SNR (dB); cut-off as a fraction of the Nyquist
#: frequency (1/2 ... 1/128, seven halvings as in paper 001 sec. 6.4); fraction of
#: samples or events lost; time factor (both directions).
DEFAULT_LEVELS: dict[str, tuple[float, ...]] = {
    "noise": (40.0, 30.0, 20.0, 10.0, 5.0, 0.0, -5.0, -10.0),
    "lowpass": tuple(2.0 ** -k for k in range(1, 8)),
    "drop_events": (0.1, 0.2, 0.3, 0.5, 0.7, 0.9),
    "drop_samples": (0.1, 0.2, 0.3, 0.5, 0.7, 0.9),
    "scale": (0.5, 0.67, 0.8, 1.25, 1.5, 2.0),
}
LOWPASS_ORDER = 4


# -- pure perturbations ----------------------------------------------------------------------
def _as_2d(x: np.ndarray, name: str = "x") -> np.ndarray:
    a = np.asarray(x, dtype=np.float64)
    if a.ndim != 2:
        raise ValueError(f"`{name}` must be (n_samples, n_channels), got shape {a.shape}")
    return a


def add_noise(x: np.ndarray, snr_db: float, *, seed: int | Sequence[int]) -> np.ndarray:
    """(n, c) -> (n, c) float64: ``x`` plus Gaussian noise with per-channel power
    ``mean(x[:, j]**2) / 10**(snr_db / 10)`` (a silent channel stays silent)."""
    a = _as_2d(x)
    if not math.isfinite(snr_db):
        raise ValueError(f"`snr_db` (={snr_db}) must be finite")
    power = (a**2).mean(axis=0) if a.shape[0] else np.zeros(a.shape[1])
    sigma = np.sqrt(power / 10.0 ** (snr_db / 10.0))
    rng = np.random.default_rng(seed)
    return a + rng.standard_normal(a.shape) * sigma


def lowpass_cutoffs(fs_hz: float, n_steps: int = 7) -> np.ndarray:
    """(n_steps,) cut-offs in Hz: ``fs/4, fs/8, ...`` (Nyquist/2 halved step by step)."""
    if not fs_hz > 0:
        raise ValueError(f"`fs_hz` (={fs_hz}) must be > 0")
    return fs_hz / 2.0 * 2.0 ** -np.arange(1, n_steps + 1, dtype=np.float64)


def lowpass(x: np.ndarray, cutoff_hz: float, *, fs_hz: float, order: int = LOWPASS_ORDER
            ) -> np.ndarray:
    """(n, c) -> (n, c) float64 zero-phase Butterworth low-pass along the samples.

    The filter runs forwards and backwards (``sosfiltfilt``), so the amplitude response
    is the square of an order-``order`` Butterworth (-6 dB at the cut-off) and there is
    no delay. Trials shorter than the default edge padding are padded by ``n - 1``
    samples; a trial of fewer than 2 samples is returned unchanged."""
    from scipy.signal import butter, sosfiltfilt

    a = _as_2d(x)
    nyquist = fs_hz / 2.0
    if not 0 < cutoff_hz < nyquist:
        raise ValueError(f"`cutoff_hz` (={cutoff_hz}) must be in (0, Nyquist = {nyquist} Hz)")
    if a.shape[0] < 2:
        return a.copy()
    sos = butter(order, cutoff_hz, btype="low", fs=fs_hz, output="sos")
    default_pad = 3 * (2 * sos.shape[0] + 1)
    padlen = None if a.shape[0] > default_pad else a.shape[0] - 1
    return sosfiltfilt(sos, a, axis=0, padlen=padlen)


def drop_samples(x: np.ndarray, fraction: float, *, seed: int | Sequence[int],
                 fill: Literal["hold", "interp"] = "hold") -> np.ndarray:
    """(n, c) -> (n, c) float64 with ``round(fraction n)`` samples lost and refilled (see
    the module docstring); the lost positions are the first of one seeded permutation."""
    a = _as_2d(x)
    if not 0 <= fraction < 1:
        raise ValueError(f"`fraction` (={fraction}) must be in [0, 1)")
    if fill not in ("hold", "interp"):
        raise ValueError(f"`fill` (={fill!r}) must be hold or interp")
    n = a.shape[0]
    k = min(int(round(fraction * n)), n - 1)
    if k <= 0:
        return a.copy()
    lost = np.random.default_rng(seed).permutation(n)[:k]
    kept = np.ones(n, dtype=bool)
    kept[lost] = False
    idx = np.arange(n)
    if fill == "hold":
        last = np.where(kept, idx, -1)
        np.maximum.accumulate(last, out=last)
        first_kept = int(np.flatnonzero(kept)[0])
        src = np.where(last >= 0, last, first_kept)
        return a[src]
    good = np.flatnonzero(kept)
    return np.stack([np.interp(idx, good, a[good, j]) for j in range(a.shape[1])], axis=1)


def thin_counts(counts: np.ndarray, keep: float, *, seed: int | Sequence[int]) -> np.ndarray:
    """(n, c) event counts -> (n, c) float64: every event kept with probability ``keep``
    (binomial thinning of ``|count|``, sign kept). Counts must be whole numbers."""
    a = _as_2d(counts, "counts")
    if not 0 <= keep <= 1:
        raise ValueError(f"`keep` (={keep}) must be in [0, 1]")
    whole = np.round(a)
    if not np.allclose(a, whole, rtol=0, atol=1e-6):
        raise ValueError("`counts` must hold whole numbers of events per bin")
    magnitude = np.abs(whole).astype(np.int64)
    kept = np.random.default_rng(seed).binomial(magnitude, keep)
    return np.sign(whole) * kept


def scale_time(x: np.ndarray, labels: Mapping[str, np.ndarray] | None, factor: float, *,
               conserve_sum: bool = False) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Actions ``factor`` times longer: (n, c) -> (round(n factor), c) float64 and each
    (n,) label -> (round(n factor),) of the same dtype (nearest source sample).

    Output sample j sits at source position ``(j + 0.5) / factor - 0.5`` (clipped to the
    trial), so the first and last sample centres stay aligned; with ``conserve_sum`` the
    values are divided by ``factor`` (totals kept for counts)."""
    a = _as_2d(x)
    if not (math.isfinite(factor) and factor > 0):
        raise ValueError(f"`factor` (={factor}) must be > 0")
    n = a.shape[0]
    n_out = max(1, int(round(n * factor))) if n else 0
    u = np.clip((np.arange(n_out) + 0.5) / factor - 0.5, 0, max(n - 1, 0))
    src = np.arange(n, dtype=np.float64)
    out = np.stack([np.interp(u, src, a[:, j]) for j in range(a.shape[1])], axis=1) \
        if n else a.copy()
    if conserve_sum:
        out = out / factor
    nearest = np.clip(np.floor(u + 0.5).astype(np.int64), 0, max(n - 1, 0))
    new_labels = {}
    for name, lab in (labels or {}).items():
        lab = np.asarray(lab)
        if lab.shape[0] != n:
            raise ValueError(f"label {name!r} has {lab.shape[0]} values for {n} samples")
        new_labels[name] = lab[nearest] if n else lab.copy()
    return out, new_labels


# -- breaking points -------------------------------------------------------------------------
@dataclass(frozen=True)
class Direction:
    """Levels of one kind walked from mild to severe."""

    name: str
    order: tuple[int, ...]  # indices into the kind's levels, mild first


def directions(kind: str, levels: Sequence[float]) -> list[Direction]:
    """How the levels of ``kind`` go from mild to severe: SNR and cut-off downwards,
    dropped fraction upwards, time factor away from 1 in each direction."""
    lv = list(levels)
    idx = range(len(lv))
    if kind == "noise":
        return [Direction("lower SNR", tuple(sorted(idx, key=lambda i: -lv[i])))]
    if kind == "lowpass":
        return [Direction("lower cut-off", tuple(sorted(idx, key=lambda i: -lv[i])))]
    if kind in ("drop_events", "drop_samples"):
        return [Direction("more lost", tuple(sorted(idx, key=lambda i: lv[i])))]
    if kind == "scale":
        out = []
        faster = tuple(sorted((i for i in idx if lv[i] < 1), key=lambda i: -lv[i]))
        slower = tuple(sorted((i for i in idx if lv[i] > 1), key=lambda i: lv[i]))
        if faster:
            out.append(Direction("faster", faster))
        if slower:
            out.append(Direction("slower", slower))
        return out
    raise ValueError(f"unknown kind {kind!r}")


def breaking_index(accuracy: Sequence[float], order: Sequence[int], threshold: float
                   ) -> int | None:
    """The first index in ``order`` whose accuracy is below ``threshold`` (None: never)."""
    for i in order:
        if accuracy[i] < threshold:
            return int(i)
    return None


# -- results ---------------------------------------------------------------------------------
@dataclass
class LevelResult:
    """Accuracy and macro F1 (fractions) of the primary head at one level."""

    level: float
    accuracy: float
    macro_f1: float
    n_windows: int
    cutoff_hz: float | None = None  # lowpass with one sample rate over all trials


@dataclass
class BreakPoint:
    """Where accuracy first falls below the threshold in one direction (None: it never
    does within the levels tried); ``last_ok`` is the most severe level before it."""

    direction: str
    level: float | None
    accuracy: float | None
    last_ok: float | None


@dataclass
class KindResult:
    kind: str
    description: str
    level_name: str
    levels: list[LevelResult]
    breaking: list[BreakPoint]


@dataclass
class PerturbResult:
    """Accuracy of one run on perturbed copies of the evaluation data (``as_dict`` is
    perturb.json)."""

    run: str
    label: str
    family: str
    name: str
    split: str
    data: list[dict[str, Any]]
    primary_head: str
    n_trials: int
    clean_accuracy: float
    clean_macro_f1: float
    clean_n_windows: int
    threshold: float
    threshold_rule: str
    seed: int
    kinds: list[KindResult]
    sample_rate_hz: float | None
    out_dir: str | None = None
    command: str = ""
    created_utc: str = ""
    tool_version: str = __version__
    wall_time_s: float = 0.0
    notes: list[str] = field(default_factory=list)
    input: dict[str, Any] | None = None
    """The data's stream, sample period, channels and units, and whether they were checked
    against the run's (:func:`.inputs.input_record`; None in files written before)."""

    @property
    def clean_below_threshold(self) -> bool:
        return self.clean_accuracy < self.threshold

    def kind(self, kind: str) -> KindResult:
        for k in self.kinds:
            if k.kind == kind:
                return k
        raise KeyError(kind)

    def as_dict(self) -> dict[str, Any]:
        out = asdict(self)
        out = {"format": PERTURB_FORMAT, "format_version": PERTURB_FORMAT_VERSION, **out}
        out["clean_below_threshold"] = self.clean_below_threshold
        return out

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> PerturbResult:
        kinds = [KindResult(k["kind"], k["description"], k["level_name"],
                            [LevelResult(**lv) for lv in k["levels"]],
                            [BreakPoint(**b) for b in k["breaking"]]) for k in d["kinds"]]
        names = {f for f in cls.__dataclass_fields__ if f != "kinds"}
        return cls(kinds=kinds, **{k: v for k, v in d.items() if k in names})


def load_perturbation(path: str | Path) -> PerturbResult:
    """Read a perturb.json (or the folder holding it), checked: strict JSON, an object of
    format ``tactile-perturb``, every record complete and of the right type. Any problem is
    one InputError naming the file and how to re-create it."""
    from .runs import _parse_json, checked_record

    path = Path(path)
    if path.is_dir():
        path = path / PERTURB_JSON
    redo = "re-create it with `tactile perturb RUN --data FILE`"
    if not path.is_file():
        raise InputError(f"no perturb.json; {redo}", path=path)
    d = checked_record(_parse_json(path, redo), path, fmt=PERTURB_FORMAT, version=None,
                       redo=redo)
    kinds = d.get("kinds")
    if not isinstance(kinds, list) or not all(
            isinstance(k, dict) and isinstance(k.get("levels"), list)
            and isinstance(k.get("breaking"), list)
            and all(isinstance(x, dict) for x in [*k["levels"], *k["breaking"]])
            for k in kinds):
        raise InputError(f"`kinds` must list each perturbation with its levels and breaking "
                         f"points; {redo}", path=path)
    try:
        result = PerturbResult.from_dict(d)
    except (KeyError, TypeError, ValueError) as exc:
        what = exc.args[0] if isinstance(exc, KeyError) and exc.args else type(exc).__name__
        raise InputError(f"perturb.json is incomplete or mistyped ({what}); {redo}",
                         path=path) from None
    for k in result.kinds:
        for lv in k.levels:
            for name in ("level", "accuracy", "macro_f1", "n_windows", "cutoff_hz"):
                v = getattr(lv, name)
                number = isinstance(v, int | float) and not isinstance(v, bool)
                if not (number or (v is None and name != "level")) or (
                        number and math.isinf(v)):
                    raise InputError(f"kind {k.kind!r}: `{name}` (={v!r}) must be a finite "
                                     f"number; {redo}", path=path)
    return result


def find_perturbations(run_dir: str | Path) -> dict[str, Path]:
    """name -> perturb.json of every ``RUN/perturb/<name>/``."""
    d = Path(run_dir) / PERTURB_DIR
    if not d.is_dir():
        return {}
    return {p.name: p / PERTURB_JSON for p in sorted(d.iterdir())
            if (p / PERTURB_JSON).is_file()}


# -- the evaluation --------------------------------------------------------------------------
_DESCRIPTIONS = {
    "noise": ("additive Gaussian noise", "SNR (dB)"),
    "lowpass": (f"low-pass (Butterworth order {LOWPASS_ORDER}, zero phase)",
                "cut-off (fraction of Nyquist)"),
    "drop_events": ("dropped events (binomial thinning)", "fraction of events dropped"),
    "drop_samples": ("dropped samples (last sample held)", "fraction of samples dropped"),
    "scale": ("time-scaled actions", "time factor (x duration)"),
}


def resolve_kinds(kinds: Sequence[str], *, event_counts: bool) -> list[str]:
    """Validated kinds with ``drop`` resolved (event counts: events, else samples)."""
    out: list[str] = []
    for k in kinds:
        k = k.strip().replace("-", "_")
        if k not in KINDS:
            raise InputError(f"unknown perturbation kind {k!r}; choose from "
                             f"{', '.join(KINDS)}")
        if k == "drop":
            k = "drop_events" if event_counts else "drop_samples"
        if k == "drop_events" and not event_counts:
            raise InputError("drop_events needs an event-count stream (data.stream "
                             "event_counts); use drop_samples")
        if k not in out:
            out.append(k)
    if not out:
        raise InputError("no perturbation kinds given")
    return out


#: At most this many levels per kind (each is a whole evaluation of the data).
MAX_LEVELS = 100
#: Time factors of ``scale`` between these (a factor of 1e6 asks for a million times the
#: data in memory; see also the memory estimate in :func:`perturb_evaluate`).
SCALE_RANGE = (1e-3, 1e3)


def _check_levels(kind: str, levels: Sequence[float]) -> list[float]:
    lv = [float(v) for v in levels]
    if not lv:
        raise InputError(f"no levels for {kind}")
    if len(lv) > MAX_LEVELS:
        raise InputError(f"{len(lv)} {kind} levels: at most {MAX_LEVELS} (each is a whole "
                         "evaluation of the data)")
    bad: list[float] = []
    if kind == "lowpass":
        bad = [v for v in lv if not 0 < v < 1]
        rule = "a cut-off as a fraction of Nyquist in (0, 1)"
    elif kind in ("drop_events", "drop_samples"):
        bad = [v for v in lv if not 0 <= v < 1]
        rule = "a fraction in [0, 1)"
    elif kind == "scale":
        bad = [v for v in lv if not SCALE_RANGE[0] <= v <= SCALE_RANGE[1]]
        rule = f"a time factor from {SCALE_RANGE[0]:g} to {SCALE_RANGE[1]:g}"
    else:
        bad = [v for v in lv if not math.isfinite(v)]
        rule = "a finite SNR in dB"
    if bad:
        raise InputError(f"{kind} level {bad[0]:g} is not {rule}")
    if len(set(lv)) != len(lv):
        raise InputError(f"{kind} levels repeat: {lv}")
    return lv


def _trial_seed(seed: int, kind: str, key: str) -> list[int]:
    # independent of the level: one noise realisation scaled per SNR, nested lost sets
    return [int(seed), zlib.crc32(kind.encode()), zlib.crc32(key.encode())]


def _sample_rate(t_s: np.ndarray) -> float:
    if t_s.shape[0] < 2:
        return math.nan
    return float(1.0 / np.median(np.diff(t_s)))


def perturb_trial(trial: Any, kind: str, level: float, *, seed: int,
                  channels: Sequence[str], event_counts: bool) -> Any:
    """A perturbed copy of a :class:`~tactile_cli.learn.data.TrialSeries`."""
    x = trial.x.astype(np.float64)
    rng_seed = _trial_seed(seed, kind, trial.key)
    if kind == "noise":
        y = add_noise(x, level, seed=rng_seed)
    elif kind == "lowpass":
        fs = _sample_rate(trial.t_s)
        if not math.isfinite(fs):
            return replace(trial)
        y = lowpass(x, level * fs / 2.0, fs_hz=fs)
    elif kind == "drop_samples":
        y = drop_samples(x, level, seed=rng_seed)
    elif kind == "drop_events":
        y = _thin_channels(x, list(channels), 1.0 - level, rng_seed, trial)
    elif kind == "scale":
        y, labels = scale_time(x, trial.sample_labels, level, conserve_sum=event_counts)
        dt = 1.0 / _sample_rate(trial.t_s) if trial.t_s.shape[0] > 1 else 0.0
        t0 = float(trial.t_s[0]) if trial.t_s.shape[0] else 0.0
        t_s = t0 + dt * np.arange(y.shape[0])
        return replace(trial, x=y.astype(np.float32), t_s=t_s, sample_labels=labels)
    else:
        raise ValueError(f"unknown kind {kind!r}")
    return replace(trial, x=y.astype(np.float32))


def _thin_channels(x: np.ndarray, channels: list[str], keep: float, seed: list[int],
                   trial: Any) -> np.ndarray:
    try:
        y = thin_counts(x, keep, seed=seed)
    except ValueError as exc:
        raise InputError(f"cannot drop events: {exc} (is this an event-count stream?)",
                         path=trial.file, where=f"/trials/{trial.trial}") from None
    if {"positive", "negative", "net"} <= set(channels):
        pos, neg = y[:, channels.index("positive")], y[:, channels.index("negative")]
        y[:, channels.index("net")] = pos - neg
    return y


def _check_scale_memory(trials: Sequence[Any], factors: Sequence[float]) -> None:
    """Refuse time factors whose stretched copy of the data cannot fit in memory (the
    copy of every trial is held at once, float64)."""
    from ..config_file import check_fits_in_memory

    if not factors:
        return
    values = sum(int(np.prod(t.x.shape)) for t in trials)
    check_fits_in_memory(8.0 * values * max(factors), f"`levels` scale={max(factors):g}",
                         "for the time-scaled copy of the data", path=None, text=None,
                         keys=())


@dataclass
class _Pipeline:
    """The evaluation of a run on a list of trials (what ``tactile evaluate`` computes)."""

    run: Any
    model: Any

    def score(self, trials: Sequence[Any]) -> tuple[float, float, int]:
        from .data import make_windows
        from .evaluate import ClassificationMetrics, head_metrics
        from .train import predict

        cfg = self.run.config
        ws = make_windows(trials, cfg.data, self.run.heads, self.run.normalisation)
        if len(ws) == 0:
            return math.nan, math.nan, 0
        outputs = predict(self.model, ws)
        metrics, _ = head_metrics(self.run.heads, outputs, ws, self.run.normalisation.targets,
                                  cfg.data.boundary_margin)
        primary = next(m for m in metrics if isinstance(m, ClassificationMetrics))
        return primary.accuracy, primary.macro_f1, len(ws)


def perturb_evaluate(
    run: str | Path | runs.Run,
    data_paths: Sequence[str | Path],
    kinds: Sequence[str] = DEFAULT_KINDS,
    levels: Mapping[str, Sequence[float]] | None = None,
    threshold: float | None = None,
    *,
    relative_threshold: float = 0.9,
    split: Literal["all", "test"] = "all",
    seed: int = 0,
    name: str | None = None,
    write: bool = True,
    command: str | None = None,
    on_level: Callable[[str, float, float], None] | None = None,
) -> PerturbResult:
    """Accuracy of ``run`` on perturbed copies of ``data_paths`` (see the module docstring).

    kinds: of :data:`KINDS`; levels: kind -> levels (defaults :data:`DEFAULT_LEVELS`; a
    ``drop`` entry applies to whichever drop kind it resolves to). threshold: absolute
    accuracy (fraction) below which a level counts as broken; default
    ``relative_threshold`` x the clean accuracy. split: as ``tactile evaluate``. With
    ``write``, ``RUN/perturb/<name>/`` is written (name as the evaluation folder's).
    ``on_level(kind, level, accuracy)`` is called after every level.
    """
    import time

    from .data import check_heads_match, data_files, read_trials
    from .heads import primary_head
    from .inputs import checked_input, input_record
    from .splits import held_out_trials

    t_start = time.perf_counter()
    run_obj = run if isinstance(run, runs.Run) else runs.load_run(run)
    paths = data_files(data_paths)
    if split not in ("all", "test"):
        raise InputError(f"`split` must be all or test, got {split!r}")
    if threshold is not None and not 0 <= threshold <= 1:
        raise InputError(f"`threshold` must be an accuracy in [0, 1], got {threshold}")
    if not 0 < relative_threshold <= 1:
        raise InputError(f"relative threshold must be in (0, 1], got {relative_threshold}")
    if write:  # a file at RUN/perturb or RUN/perturb/<name> is refused before any work
        check_output_folder(run_obj.path / PERTURB_DIR
                            / (name or runs.eval_dir_name(paths, split)), overwrite=True)
    cfg = run_obj.config
    head = primary_head(run_obj.heads)
    if head is None:
        raise InputError("the run has no classification head; perturbation reports accuracy",
                         path=run_obj.path)
    event_counts = cfg.data.stream == "event_counts"
    kind_list = resolve_kinds(kinds, event_counts=event_counts)
    user_levels = {k.replace("-", "_"): v for k, v in (levels or {}).items()}
    for k in user_levels:
        if k not in KINDS:
            raise InputError(f"levels given for unknown kind {k!r}; choose from "
                             f"{', '.join(KINDS)}")
    plan: dict[str, list[float]] = {}
    for k in kind_list:
        given = user_levels.get(k, user_levels.get("drop") if k.startswith("drop_") else None)
        plan[k] = _check_levels(k, DEFAULT_LEVELS[k] if given is None else given)

    trials = read_trials(paths, cfg.data, trained=True)
    _check_scale_memory(trials, plan.get("scale", []))
    spec, input_notes = checked_input(trials, cfg.data.stream, run_obj.input, run_obj.path)
    check_heads_match(run_obj.heads, trials, stream=cfg.data.stream)
    if split == "test":
        trials = held_out_trials(trials, split_csv=run_obj.path / "split.csv",
                             split=cfg.data.split, seed=cfg.seed, targets=cfg.data.targets)
        if not trials:
            raise InputError("no trial of these files is in the test split; use `split='all'` "
                             "for data the run never saw")
    pipe = _Pipeline(run_obj, run_obj.load_model())
    clean_acc, clean_f1, clean_n = pipe.score(trials)
    if clean_n == 0:
        raise InputError(f"the data give no windows (window {cfg.data.window} samples)")
    rates = {round(_sample_rate(t.t_s), 9) for t in trials if t.t_s.shape[0] > 1}
    fs = rates.pop() if len(rates) == 1 else None
    notes = input_notes + ([] if fs is not None or "lowpass" not in plan else [
        "trials have different sample rates: low-pass cut-offs are fractions of each "
        "trial's Nyquist frequency"])
    thr = threshold if threshold is not None else relative_threshold * clean_acc
    rule = (f"absolute {threshold:g}" if threshold is not None
            else f"{relative_threshold:g} x clean accuracy")

    results = []
    for k in kind_list:
        level_results = []
        for lv in plan[k]:
            perturbed = [perturb_trial(t, k, lv, seed=seed, channels=cfg.data.channels,
                                       event_counts=event_counts) for t in trials]
            acc, f1, n = pipe.score(perturbed)
            cutoff = lv * fs / 2 if (k == "lowpass" and fs is not None) else None
            level_results.append(LevelResult(lv, acc, f1, n, cutoff))
            if on_level is not None:
                on_level(k, lv, acc)
        accs = [r.accuracy if math.isfinite(r.accuracy) else -math.inf for r in level_results]
        breaks = []
        for d in directions(k, plan[k]):
            i = breaking_index(accs, d.order, thr)
            pos = d.order.index(i) if i is not None else len(d.order)
            last_ok = plan[k][d.order[pos - 1]] if pos > 0 else None
            breaks.append(BreakPoint(d.name, None if i is None else plan[k][i],
                                     None if i is None else level_results[i].accuracy,
                                     last_ok))
        desc, level_name = _DESCRIPTIONS[k]
        if k == "scale" and event_counts:
            desc += ", counts divided by the factor"
        results.append(KindResult(k, desc, level_name, level_results, breaks))

    out_name = name or runs.eval_dir_name(paths, split)
    label = f"{cfg.model.family}/{run_obj.path.resolve().name}"
    result = PerturbResult(
        run=str(run_obj.path), label=label, family=cfg.model.family, name=out_name,
        split=split,
        data=[{"path": str(p), "sha256": sha256_of(p)} for p in paths],
        primary_head=head.name, n_trials=len(trials), clean_accuracy=clean_acc,
        clean_macro_f1=clean_f1, clean_n_windows=clean_n, threshold=float(thr),
        threshold_rule=rule, seed=int(seed), kinds=results, sample_rate_hz=fs,
        command=command if command is not None else current_command(),
        created_utc=utc_now(), wall_time_s=time.perf_counter() - t_start, notes=notes,
        input=input_record(spec, run_obj.input),
    )
    if write:
        out_dir = run_obj.path / PERTURB_DIR / out_name
        result.out_dir = str(out_dir)
        write_perturbation(result, out_dir)
    return result


# -- outputs ---------------------------------------------------------------------------------
def level_text(kind: KindResult, level: float | None) -> str:
    """A level as people read it: ``10 dB``, ``0.125 x Nyquist (3.12 Hz)``, ``30 %``,
    ``x1.5``; empty for None."""
    if level is None:
        return ""
    if kind.kind == "noise":
        return f"{level:g} dB"
    if kind.kind == "lowpass":
        hz = next((lv.cutoff_hz for lv in kind.levels if lv.level == level), None)
        return f"{level:g} x Nyquist" + ("" if hz is None else f" ({hz:.3g} Hz)")
    if kind.kind.startswith("drop_"):
        return f"{100 * level:g} %"
    return f"x{level:g}"


def perturbation_rows(results: Sequence[PerturbResult]) -> list[dict[str, Any]]:
    """One row per run, kind and level (accuracy in %), clean rows first."""
    rows = []
    for r in results:
        rows.append({"run": r.label, "kind": "clean", "level": "", "cutoff_hz": "",
                     "accuracy_pct": 100 * r.clean_accuracy, "macro_f1": r.clean_macro_f1,
                     "n_windows": r.clean_n_windows, "below_threshold": r.clean_below_threshold,
                     "breaking_point": ""})
        for k in r.kinds:
            breaks = {b.level for b in k.breaking if b.level is not None}
            for lv in k.levels:
                rows.append({"run": r.label, "kind": k.kind, "level": lv.level,
                             "cutoff_hz": "" if lv.cutoff_hz is None else lv.cutoff_hz,
                             "accuracy_pct": 100 * lv.accuracy, "macro_f1": lv.macro_f1,
                             "n_windows": lv.n_windows,
                             "below_threshold": lv.accuracy < r.threshold,
                             "breaking_point": lv.level in breaks})
    return rows


def _csv_text(rows: Sequence[dict[str, Any]]) -> str:
    buf = io.StringIO()
    if rows:
        w = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
        w.writeheader()
        w.writerows(rows)
    return buf.getvalue()


def write_perturbation(result: PerturbResult, out_dir: str | Path) -> Path:
    """``out_dir`` (replaced atomically as a whole): perturb.json, perturb.csv, perturb.png."""
    def fill(tmp: Path) -> None:
        runs.write_json(tmp / PERTURB_JSON, result.as_dict())
        (tmp / PERTURB_CSV).write_text(_csv_text(perturbation_rows([result])),
                                       encoding="utf-8")
        (tmp / PERTURB_PNG).write_bytes(plot_perturbations([result]))

    return runs.write_folder(Path(out_dir), fill, overwrite=True)


def write_perturbation_set(results: Sequence[PerturbResult], out_dir: str | Path, *,
                           command: str | None = None) -> dict[str, Path]:
    """The comparison of several runs in ``out_dir``: perturb.png (one line per run),
    perturb.csv and perturb.json (every result and the provenance), moved in together
    from a hidden folder beside it (other files in ``out_dir`` are kept)."""
    from ..store.atomic import write_bytes, write_text

    out = check_output_folder(out_dir, merge=True)
    record = {
        "format": "tactile-perturb-set", "format_version": 1, "tool_version": __version__,
        "created_utc": utc_now(),
        "command": command if command is not None else current_command(),
        "inputs": [{"run": r.run, "perturb_json": None if r.out_dir is None
                    else str(Path(r.out_dir) / PERTURB_JSON), "data": r.data}
                   for r in results],
        "results": [r.as_dict() for r in results],
    }
    # built beside ``out_dir`` and moved in only when all three are written
    with output_folder(out, merge=True) as tmp:
        write_bytes(tmp / PERTURB_PNG, plot_perturbations(results))
        write_text(tmp / PERTURB_CSV, _csv_text(perturbation_rows(results)))
        write_text(tmp / PERTURB_JSON, runs.dumps(record) + "\n")
    return {"png": out / PERTURB_PNG, "csv": out / PERTURB_CSV, "json": out / PERTURB_JSON}


def plot_perturbations(results: Sequence[PerturbResult]) -> bytes:
    """PNG bytes: one panel per kind, accuracy (%) against level, one line per run, the
    clean accuracy dotted, the threshold dashed (both in the run's colour) and every
    breaking point marked with an X. Axes run from mild (left) to severe (right)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FuncFormatter, NullFormatter

    if not results:
        raise ValueError("no results to plot")
    kinds: list[str] = []
    for r in results:
        for k in r.kinds:
            if k.kind not in kinds:
                kinds.append(k.kind)
    n = len(kinds)
    cols = min(n, 2)
    rows = -(-n // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(5.6 * cols, 3.9 * rows), squeeze=False)
    for ax in axes.flat[n:]:
        ax.set_visible(False)
    use_hz = all(r.sample_rate_hz is not None for r in results) and \
        len({r.sample_rate_hz for r in results}) == 1
    # one colour per family (as in the compare chart) when every run is of another family
    fams = [r.family for r in results]
    order = sorted(set(fams))
    colours = [f"C{order.index(f) % 10}" for f in fams] if len(order) == len(fams) \
        else [f"C{i % 10}" for i in range(len(results))]
    for ax, kind in zip(axes.flat, kinds, strict=False):
        title, xlabel = kind, kind
        for r, colour in zip(results, colours, strict=True):
            try:
                k = r.kind(kind)
            except KeyError:
                continue
            title, xlabel = k.description, k.level_name
            x = np.array([lv.level for lv in k.levels])
            if kind == "lowpass" and use_hz:
                x = np.array([lv.cutoff_hz for lv in k.levels], dtype=np.float64)
                xlabel = "cut-off (Hz)"
            y = np.array([100 * lv.accuracy for lv in k.levels])
            if kind == "scale" or kind.startswith("drop_"):  # the clean data sit at 1 / 0
                x = np.append(x, 1.0 if kind == "scale" else 0.0)
                y = np.append(y, 100 * r.clean_accuracy)
            order = np.argsort(x)
            ax.plot(x[order], y[order], marker="o", ms=4, color=colour,
                    label=f"{r.label} (clean {100 * r.clean_accuracy:.1f} %)")
            ax.axhline(100 * r.clean_accuracy, color=colour, ls=":", lw=1)
            ax.axhline(100 * r.threshold, color=colour, ls="--", lw=0.8, alpha=0.7)
            for b in k.breaking:
                if b.level is None:
                    continue
                j = [lv.level for lv in k.levels].index(b.level)
                bx = b.level if kind != "lowpass" or not use_hz else k.levels[j].cutoff_hz
                ax.scatter([bx], [100 * k.levels[j].accuracy], marker="X", s=110, color=colour,
                           edgecolors="black", zorder=5)
        if kind == "noise":
            ax.invert_xaxis()
        elif kind in ("lowpass", "scale"):
            ax.set_xscale("log", base=2)
            ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:.3g}"))
            ax.xaxis.set_minor_formatter(NullFormatter())
            if kind == "lowpass":
                ax.invert_xaxis()
            else:
                ax.axvline(1.0, color="0.6", lw=0.8)
        ax.set_title(title, fontsize=9)
        ax.set_xlabel(xlabel)
        ax.set_ylabel("accuracy (%)")
        ax.grid(alpha=0.3, which="both")
    handles, labels = axes.flat[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=min(len(labels), 3), fontsize=8,
               bbox_to_anchor=(0.5, 0.0))
    fig.suptitle("accuracy on perturbed data (dotted: clean, dashed: threshold, "
                 "X: breaking point)", fontsize=10)
    fig.tight_layout(rect=(0, 0.06 + 0.02 * (len(labels) // 3), 1, 0.96))
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100, metadata={"Software": f"tactile {__version__}"})
    plt.close(fig)
    return buf.getvalue()


# -- the verb of `tactile perturb` ----------------------------------------------------------------
def parse_threshold(text: str) -> tuple[float | None, float]:
    """``"0.9x"`` -> (None, 0.9): relative to the clean accuracy; ``"0.95"`` or ``"95%"``
    -> (0.95, 0.9): an absolute accuracy. Returns (absolute, relative) as
    :func:`perturb_evaluate` takes them."""
    t = text.strip().lower()
    try:
        if t.endswith("x"):
            rel = float(t[:-1])
            if not 0 < rel <= 1:
                raise ValueError
            return None, rel
        value = float(t[:-1]) / 100 if t.endswith("%") else float(t)
    except ValueError:
        raise InputError(f"`threshold` must be a factor of the clean accuracy like 0.9x or an "
                         f"accuracy like 0.95 or 95%, got {text!r}") from None
    if not 0 <= value <= 1:
        raise InputError(f"`threshold` {text!r} is not an accuracy in [0, 1] (or 0-100 %)")
    return value, 0.9


def parse_levels(items: Sequence[str] | Mapping[str, Sequence[float]] | None
                 ) -> dict[str, list[float]]:
    """``["noise=30,20,10", "scale=0.5,2"]`` -> {"noise": [30, 20, 10], "scale": [0.5, 2]}
    (a mapping is taken as it is)."""
    if isinstance(items, Mapping):
        return {k: [float(v) for v in vs] for k, vs in items.items()}
    out: dict[str, list[float]] = {}
    for item in items or []:
        kind, sep, values = item.partition("=")
        try:
            if not sep or not kind.strip():
                raise ValueError
            out[kind.strip()] = [float(v) for v in values.split(",") if v.strip()]
        except ValueError:
            raise InputError(f"`levels` takes KIND=V1,V2,... (e.g. noise=30,20,10), got "
                             f"{item!r}") from None
    return out


@dataclass
class PerturbRunsResult:
    """What ``tactile perturb`` reports: one result per run (each written to
    ``RUN/perturb/<name>/``) and the files of the combined chart, when ``out`` was given."""

    results: list[PerturbResult]
    chart: dict[str, Path] | None = None

    @property
    def notes(self) -> list[str]:
        return [n for r in self.results for n in r.notes]

    def as_dict(self) -> dict[str, Any] | list[dict[str, Any]]:
        """perturb.json of the one run, or the list of every run's."""
        payload = [r.as_dict() for r in self.results]
        return payload[0] if len(payload) == 1 else payload


def perturb_runs(
    run_dirs: Sequence[str | Path],
    data_paths: Sequence[str | Path],
    *,
    kinds: Sequence[str] | str = DEFAULT_KINDS,
    levels: Sequence[str] | Mapping[str, Sequence[float]] | None = None,
    threshold: str = "0.9x",
    split: Literal["all", "test"] = "all",
    seed: int = 0,
    name: str | None = None,
    out: str | Path | None = None,
    command: str | None = None,
    on_run: Callable[[Path], None] | None = None,
    on_level: Callable[[str, float, float], None] | None = None,
) -> PerturbRunsResult:
    """:func:`perturb_evaluate` for every run of ``run_dirs`` on ``data_paths`` (each
    writes ``RUN/perturb/<name>/``), and the combined chart of all of them in folder
    ``out`` when given (:func:`write_perturbation_set`). ``kinds``: names or one
    comma-separated string; ``levels``: kind -> levels, or ``KIND=V1,V2`` strings;
    ``threshold``: see :func:`parse_threshold`. Every option and output is checked before
    the first run is evaluated; ``on_run`` and ``on_level`` report progress."""
    from ..input_guard import check_outputs

    if not run_dirs:
        raise InputError("no run folder; give `run_dirs`")
    if not data_paths:
        raise InputError("no data files; give `data_paths`")
    kind_list = [k for k in (kinds.split(",") if isinstance(kinds, str) else kinds)
                 if k.strip()]
    absolute, relative = parse_threshold(threshold)
    level_map = parse_levels(levels)
    if split not in ("all", "test"):
        raise InputError(f"`split` must be all or test, got {split!r}")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise InputError(f"`seed` (={seed!r}) must be a whole number >= 0")
    folder = runs.check_result_name(name) or runs.eval_dir_name([Path(p) for p in data_paths],
                                                                split)
    for run in run_dirs:
        check_outputs({"out": out, "name": Path(run) / PERTURB_DIR / folder}, data_paths)
    if out is not None:  # the chart is added to an existing folder; a file there is refused
        check_output_folder(out, merge=True)
    results = []
    for run in run_dirs:
        if on_run is not None:
            on_run(Path(run))
        results.append(perturb_evaluate(
            run, data_paths, kind_list, level_map, absolute, relative_threshold=relative,
            split=split, seed=seed, name=name, command=command, on_level=on_level))
    chart = None
    if out is not None:
        chart = write_perturbation_set(results, out, command=command)
    return PerturbRunsResult(results, chart)


__all__ = ["DEFAULT_KINDS", "DEFAULT_LEVELS", "KINDS", "PERTURB_CSV", "PERTURB_DIR",
           "PERTURB_JSON", "PERTURB_PNG", "BreakPoint", "Direction", "KindResult",
           "LevelResult", "PerturbResult", "add_noise", "breaking_index", "directions",
           "drop_samples", "find_perturbations", "level_text", "load_perturbation", "lowpass",
           "lowpass_cutoffs", "parse_levels", "parse_threshold", "perturb_evaluate",
           "perturb_runs", "perturb_trial", "perturbation_rows", "plot_perturbations",
           "resolve_kinds", "scale_time", "thin_counts", "write_perturbation",
           "write_perturbation_set", "PerturbRunsResult"]
