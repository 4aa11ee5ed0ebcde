"""File-level verbs of the taxel-array chain (paper 004): read the trials of a
``tactile simulate taxel-slip`` file (or any file laid out the same way), compute the
slip-interface features and classify the slip interface.

- :func:`read_preset_trials`: one preset's trials as arrays (rest and slip segments);
- :func:`preset_features`: Gamma, single- and multi-finger G2 of every trial in every band
  of the best-band search and over the full spectrum, with contact estimation and the
  noise-floor gate;
- :func:`slip_interface`: Gaussian naive Bayes with ``folds``-fold cross-validation per
  trial (stratified by slip type): full spectrum, best band chosen inside each training
  set (nested; the headline) and best band chosen on all trials (optimistic);
- :func:`write_taxel_features`: Gamma and G2 per window and named band as a signal stream
  ``spectral_features`` that ``tactile train`` reads (through the one feature-stream
  writer, :func:`tactile_cli.spectral.stream_features.write_feature_stream`);
- :func:`slip_interface_file`: :func:`slip_interface` on a file with its config, and the
  result written as JSON and a figure (``tactile slip-interface``).

Folds are dealt per trial, seeded and independent of file order, by
:mod:`tactile_cli.learn.splits` (the same rule as ``tactile train --cv``; importing it does
not import torch).
"""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..learn.splits import stratified_fold_of
from ..progress import NullProgress, Progress
from ..spectral import (
    array_features,
    band_centre_width_hz,
    band_grid,
    finger_ensembles,
    multi_finger_g2,
)
from ..store.trials import TactileFile, Trial
from .config import SLIP_TYPES, FeatureConfig, WelchConfig
from .features import above_noise_floor, contact_taxels
from .simulate import REST, SLIP, pressure_stream, taxel_stream

FEATURES = ("gamma", "g2_single", "g2_multi")
FEATURE_STREAM = "spectral_features"


@dataclass(frozen=True)
class PresetTrials:
    """One preset's trials: ``rest``/``slip`` per finger (T, n, N) taxel samples,
    ``pressure`` (T, n_p, fingers) slip-segment pressure or None, ``slip_type`` (T,)."""

    preset: str
    names: tuple[str, ...]
    slip_type: np.ndarray
    rest: list[np.ndarray]
    slip: list[np.ndarray]
    rate_hz: float
    delays_s: np.ndarray | None
    pressure: np.ndarray | None
    pressure_rate_hz: float | None


def file_presets(tf: TactileFile) -> list[str]:
    """The presets (trial label ``preset``) of the file's trials, in first-seen order."""
    seen: dict[str, None] = {}
    for trial in tf.trials():
        p = trial.labels.get("preset")
        if p is not None and trial.has_signal(taxel_stream(str(p), 0)):
            seen[str(p)] = None
    if not seen:
        raise InputError("no taxel-array trials (trial label preset with streams "
                         "<preset>_f0, <preset>_f1, as tactile simulate taxel-slip writes)",
                         path=tf.path)
    for trial in tf.trials():  # a lost label would drop the trial from every result
        if trial.labels.get("preset") is None:
            streams = [taxel_stream(p, 0) for p in seen if trial.has_signal(taxel_stream(p, 0))]
            if streams:
                raise InputError(f"trial {trial.name!r} has the taxel stream {streams[0]} but "
                                 "no trial label preset; every taxel trial names its preset",
                                 path=tf.path, where=f"{trial.where}/labels")
    return list(seen)


def _segment(trial: Trial, label: str) -> tuple[float, float]:
    ann = trial.annotation(label)
    if ann is None:
        raise InputError(f"trial {trial.name!r} has no {label!r} annotation", path=trial.path)
    return ann.start_s, ann.end_s


def _delays(tf: TactileFile, stream: str, n: int) -> np.ndarray | None:
    attrs = tf.sensor(stream).attrs
    if attrs.get("sampling") != "sequential":
        return None
    return float(attrs.get("channel_delay_first_s", 0.0)) + \
        np.arange(n) * float(attrs.get("channel_delay_step_s", 0.0))


def read_preset_trials(tf: TactileFile, preset: str) -> PresetTrials:
    """Every trial of ``preset`` with a ``slip`` label, cut into its ``rest`` and ``slip``
    segments (the slip segments cut to the shortest)."""
    trials = [t for t in tf.trials() if str(t.labels.get("preset")) == preset]
    if not trials:
        raise InputError(f"no trials of preset {preset!r}", path=tf.path)
    fingers = 0
    while trials[0].has_signal(taxel_stream(preset, fingers)):
        fingers += 1
    rest: list[list[np.ndarray]] = [[] for _ in range(fingers)]
    slip: list[list[np.ndarray]] = [[] for _ in range(fingers)]
    pressure: list[np.ndarray] = []
    has_pressure = trials[0].has_signal(pressure_stream(preset))
    rate = p_rate = None
    for trial in trials:
        r0, r1 = _segment(trial, REST)
        s0, s1 = _segment(trial, SLIP)
        for k in range(fingers):
            sig = trial.signal(taxel_stream(preset, k))
            rate = sig.sample_rate_hz
            rest[k].append(sig.data[(sig.t_s >= r0) & (sig.t_s < r1)].astype(np.float64))
            slip[k].append(sig.data[(sig.t_s >= s0) & (sig.t_s < s1)].astype(np.float64))
        if has_pressure:
            sig = trial.signal(pressure_stream(preset))
            p_rate = sig.sample_rate_hz
            pressure.append(sig.data[(sig.t_s >= s0) & (sig.t_s < s1)].astype(np.float64))

    def stack(parts: list[np.ndarray]) -> np.ndarray:
        n = min(len(p) for p in parts)
        return np.stack([p[:n] for p in parts])

    labels = np.array([str(t.labels.get("slip", "")) for t in trials])
    bad = sorted(set(labels.tolist()) - set(SLIP_TYPES))
    if bad:
        raise InputError(f"trial label slip has values {bad}; expected hand or world",
                         path=tf.path)
    n_taxels = slip[0][0].shape[1]
    return PresetTrials(preset, tuple(t.name for t in trials), labels,
                        [stack(r) for r in rest], [stack(s) for s in slip], float(rate),
                        _delays(tf, taxel_stream(preset, 0), n_taxels),
                        stack(pressure) if has_pressure else None, p_rate)


@dataclass(frozen=True)
class FeatureValues:
    """One feature of every trial: ``values`` (T, n_bands) in the search bands, ``full``
    (T,) over the full spectrum; the bands' (f, w) in Hz; ``n_averages`` (n_bands,)
    segment-bin products per band and ``n_channels`` compared (rank deficient where
    n_averages < n_channels)."""

    values: np.ndarray
    full: np.ndarray
    f_hz: np.ndarray
    w_hz: np.ndarray
    n_averages: np.ndarray
    n_channels: int


@dataclass(frozen=True)
class PresetFeatures:
    preset: str
    slip_type: np.ndarray
    decided: np.ndarray
    """(T,) bool: above the noise floor (the gate)."""
    contact_counts: np.ndarray
    """(T, fingers) taxels estimated in contact."""
    features: dict[str, FeatureValues]


def _welch(fcfg: FeatureConfig, preset: str) -> WelchConfig:
    return fcfg.welch.get(preset) or fcfg.welch.get("biotac") or WelchConfig(nperseg=64)


def preset_features(pt: PresetTrials, fcfg: FeatureConfig) -> PresetFeatures:
    """Gamma, single-finger and multi-finger G2 of every trial of ``pt``."""
    wc = _welch(fcfg, pt.preset)
    nperseg = min(wc.nperseg, pt.slip[0].shape[1])
    n_bins = nperseg // 2 + 1
    lo, hi = band_grid(n_bins, wc.max_band_bins)
    lo_all, hi_all = np.append(lo, 1), np.append(hi, n_bins - 1)   # last: full spectrum
    delays = pt.delays_s if fcfg.sequential_correction else None
    feats, contacts = [], []
    for rest, slip in zip(pt.rest, pt.slip, strict=True):
        contact = contact_taxels(rest, slip, fcfg.contact_threshold) \
            if fcfg.contact_estimation else np.ones(slip.shape[::2], dtype=bool)
        contacts.append(contact)
        feats.append(array_features(slip, pt.rate_hz, lo_all, hi_all, nperseg=nperseg,
                                    noverlap=wc.noverlap(nperseg),
                                    delays_s=delays, contact=contact))
    decided = np.any([above_noise_floor(r, s, fcfg.gate_ratio)
                      for r, s in zip(pt.rest, pt.slip, strict=True)], axis=0)
    f_hz = feats[0].f_hz
    fc, fw = band_centre_width_hz(f_hz, lo, hi)
    n_avg = feats[0].n_averages
    n_taxels = int(max(c.sum(axis=-1).max() for c in contacts))
    out: dict[str, FeatureValues] = {}
    for name, attr in (("gamma", "gamma"), ("g2_single", "g2")):
        v = np.nanmean(np.stack([getattr(f, attr) for f in feats]), axis=0)
        out[name] = FeatureValues(v[:, :-1], v[:, -1], fc, fw, n_avg[:-1], n_taxels)
    if pt.pressure is not None:
        p_seg = min(wc.pressure_nperseg, pt.pressure.shape[1])
        from ..spectral import segment_spectra

        pf, spectra = segment_spectra(pt.pressure, float(pt.pressure_rate_hz), nperseg=p_seg,
                                      noverlap=wc.noverlap(p_seg))
        plo, phi = band_grid(len(pf), wc.max_band_bins)
        pc, pw = band_centre_width_hz(pf, plo, phi)
    else:
        spectra = finger_ensembles(feats, delays, contacts)
        plo, phi, pc, pw = lo, hi, fc, fw
    g = multi_finger_g2(spectra, np.append(plo, 1), np.append(phi, spectra.shape[-2] - 1))
    out["g2_multi"] = FeatureValues(g[:, :-1], g[:, -1], pc, pw,
                                    spectra.shape[-3] * (phi - plo + 1), spectra.shape[-1])
    return PresetFeatures(pt.preset, pt.slip_type, decided,
                          np.stack([c.sum(axis=-1) for c in contacts], axis=-1), out)


# -- classification ---------------------------------------------------------------------------
def stratified_folds(keys: tuple[str, ...] | list[str], classes: np.ndarray, k: int,
                     seed: int) -> np.ndarray:
    """(T,) fold index of each trial by :func:`tactile_cli.learn.splits.stratified_fold_of`
    (the ``stratified`` rule of ``cv_folds``; ``key`` = ``<file name>/<trial>``), so
    ``tactile train --cv k`` with ``data.split: {mode: stratified, by: slip}`` and the same
    seed makes the same folds. Independent of file order."""
    return np.asarray(stratified_fold_of(list(keys), classes.tolist(), k, seed),
                      dtype=np.int64)


def gnb_predict(x_train: np.ndarray, y_train: np.ndarray, x_test: np.ndarray) -> np.ndarray:
    """Gaussian naive Bayes on one feature per column, every column its own model:
    (n, B) training values, (n,) integer classes, (m, B) test values -> (m, B) predicted
    classes; the same rule as scikit-learn's GaussianNB (class priors from the training
    set, variances plus 1e-9 x the largest feature variance)."""
    classes = np.unique(y_train)
    eps = 1e-9 * x_train.var(axis=0)
    jll = []
    for c in classes:
        xc = x_train[y_train == c]
        mu, var = xc.mean(axis=0), xc.var(axis=0) + eps
        prior = len(xc) / len(x_train)
        jll.append(np.log(prior) - 0.5 * np.log(2 * np.pi * var)
                   - 0.5 * (x_test - mu) ** 2 / var)
    return classes[np.argmax(np.stack(jll), axis=0)]


def _cv_predictions(values: np.ndarray, y: np.ndarray, folds: np.ndarray) -> np.ndarray:
    """(T, B) out-of-fold predictions of every column."""
    pred = np.empty(values.shape, dtype=y.dtype)
    for f in np.unique(folds):
        test = folds == f
        pred[test] = gnb_predict(values[~test], y[~test], values[test])
    return pred


@dataclass(frozen=True)
class FeatureScore:
    """Accuracy (fraction) of one feature of one preset; bands as (f, w) Hz."""

    preset: str
    feature: str
    n_trials: int
    n_decided: int
    full_spectrum: float
    nested_best_band: float
    optimistic_best_band: float
    optimistic_band_hz: tuple[float, float]
    nested_bands_hz: tuple[tuple[float, float], ...]
    n_channels: int
    rank_deficient_bands: float
    """Share of the search bands whose CSD averages fewer segment-bin products than
    channels (G2 biased upward there)."""
    min_averages: int

    def as_dict(self) -> dict[str, Any]:
        common = Counter(self.nested_bands_hz).most_common(1)
        return {"preset": self.preset, "feature": self.feature, "n_trials": self.n_trials,
                "n_decided": self.n_decided, "full_spectrum": round(self.full_spectrum, 4),
                "nested_best_band": round(self.nested_best_band, 4),
                "optimistic_best_band": round(self.optimistic_best_band, 4),
                "optimistic_band_hz": [round(v, 3) for v in self.optimistic_band_hz],
                "nested_band_most_chosen_hz": [round(v, 3) for v in common[0][0]]
                if common else None,
                "n_channels": self.n_channels,
                "rank_deficient_bands": round(self.rank_deficient_bands, 4),
                "min_averages": self.min_averages}


def score_feature(fv: FeatureValues, y: np.ndarray, names: list[str], folds: np.ndarray,
                  fcfg: FeatureConfig, preset: str, feature: str, n_trials: int
                  ) -> FeatureScore:
    """Full-spectrum, nested best-band and optimistic best-band CV accuracy of one
    feature on the decided trials (``y`` integer classes, ``folds`` (T,))."""
    from sklearn.naive_bayes import GaussianNB

    values = np.nan_to_num(fv.values, nan=0.0)
    full = np.nan_to_num(fv.full, nan=0.0)[:, None]
    full_acc = float((_cv_predictions(full, y, folds)[:, 0] == y).mean())
    per_band = (_cv_predictions(values, y, folds) == y[:, None]).mean(axis=0)
    best = int(np.argmax(per_band))
    correct, chosen = 0, []
    for f in np.unique(folds):
        train, test = folds != f, folds == f
        tr_names = [n for n, t in zip(names, train, strict=True) if t]
        inner = stratified_folds(tr_names, y[train], fcfg.inner_folds, fcfg.seed + 1)
        inner_acc = (_cv_predictions(values[train], y[train], inner)
                     == y[train][:, None]).mean(axis=0)
        b = int(np.argmax(inner_acc))
        chosen.append((float(fv.f_hz[b]), float(fv.w_hz[b])))
        model = GaussianNB().fit(values[train][:, [b]], y[train])
        correct += int((model.predict(values[test][:, [b]]) == y[test]).sum())
    return FeatureScore(preset, feature, n_trials, len(y), full_acc, correct / len(y),
                        float(per_band[best]), (float(fv.f_hz[best]), float(fv.w_hz[best])),
                        tuple(chosen), fv.n_channels,
                        float((fv.n_averages < fv.n_channels).mean()),
                        int(fv.n_averages.min()))


@dataclass(frozen=True)
class SlipInterfaceResult:
    """Accuracy table of :func:`slip_interface`, per preset and feature; ``out`` and
    ``plot``: the JSON and figure :func:`slip_interface_file` wrote."""

    path: Path
    scores: tuple[FeatureScore, ...]
    folds: int
    inner_folds: int
    datasets: tuple[str, ...]
    elapsed_s: float
    features: dict[str, PresetFeatures] = field(default_factory=dict, repr=False)
    out: Path | None = None
    plot: Path | None = None

    def as_dict(self) -> dict[str, Any]:
        nested = [s.nested_best_band for s in self.scores]
        return {"file": str(self.path), "datasets": list(self.datasets),
                "folds": self.folds, "inner_folds": self.inner_folds,
                "classifier": "Gaussian naive Bayes (scikit-learn), one feature",
                "scores": [s.as_dict() for s in self.scores],
                "nested_at_least_85": sum(a >= 0.85 for a in nested),
                "n_combinations": len(nested), "elapsed_s": round(self.elapsed_s, 3)}

    def table(self) -> tuple[str, list[str], list[list[str]]]:
        """Title, columns and one row per preset and feature (accuracies in %)."""
        cols = ["preset", "feature", "trials", "decided", "full spectrum",
                "best band (nested)", "best band (optimistic)", "(f, w) Hz"]
        rows = [[s.preset, s.feature, str(s.n_trials), str(s.n_decided),
                 f"{100 * s.full_spectrum:.1f} %", f"{100 * s.nested_best_band:.1f} %",
                 f"{100 * s.optimistic_best_band:.1f} %",
                 f"({s.optimistic_band_hz[0]:.4g}, {s.optimistic_band_hz[1]:.4g})"]
                for s in self.scores]
        return (f"slip interface, {self.folds}-fold CV per trial ({', '.join(self.datasets)})",
                cols, rows)

    def summary_lines(self) -> list[str]:
        nested = [s.nested_best_band for s in self.scores]
        return [f"nested best band >= 85 %: {sum(a >= 0.85 for a in nested)} of "
                f"{len(nested)} preset x feature combinations"]


def slip_interface(path: str | Path, fcfg: FeatureConfig, *,
                   progress: Progress | None = None) -> SlipInterfaceResult:
    """Classify the slip interface (hand/world) of every preset's trials in ``path``
    (Tables 4-6): see the module docstring. Trials below the noise floor are left out
    (counted in ``n_trials - n_decided``)."""
    started = time.perf_counter()
    progress = progress or NullProgress()
    scores: list[FeatureScore] = []
    kept: dict[str, PresetFeatures] = {}
    with TactileFile(path) as tf:
        presets = file_presets(tf)
        datasets = sorted({str(t.labels.get("dataset", "")) for t in tf.trials()})
        progress.start(len(presets), "slip interface")
        for preset in presets:
            pt = read_preset_trials(tf, preset)
            pf = preset_features(pt, fcfg)
            kept[preset] = pf
            d = pf.decided
            y = (pt.slip_type[d] == "world").astype(np.int64)
            names = [f"{Path(path).name}/{n}" for n, keep in zip(pt.names, d, strict=True)
                     if keep]
            if min(np.bincount(y, minlength=2)) < fcfg.folds:
                raise InputError(f"preset {preset!r}: each slip type needs at least `folds` "
                                 f"(={fcfg.folds}) trials above the noise floor",
                                 path=tf.path)
            folds = stratified_folds(names, y, fcfg.folds, fcfg.seed)
            for feature in FEATURES:
                fv = pf.features[feature]
                sub = FeatureValues(fv.values[d], fv.full[d], fv.f_hz, fv.w_hz,
                                    fv.n_averages, fv.n_channels)
                scores.append(score_feature(sub, y, names, folds, fcfg, preset, feature,
                                            len(pt.names)))
            progress.advance(1)
        progress.finish()
    return SlipInterfaceResult(Path(path), tuple(scores), fcfg.folds, fcfg.inner_folds,
                               tuple(datasets), time.perf_counter() - started, kept)


def slip_interface_file(path: str | Path, *, config: str | Path | None = None,
                        folds: int | None = None, out: str | Path | None = None,
                        plot: str | Path | None = None, overwrite: bool = False,
                        progress: Progress | None = None) -> SlipInterfaceResult:
    """:func:`slip_interface` on the taxel file ``path`` with the feature config of the
    YAML file ``config`` (default: the built-in one) and ``folds`` outer folds when given;
    with ``out`` the result as JSON with its provenance, with ``plot`` the features
    against frequency (Fig. 12) as a PNG. Outputs are checked before any work (not an
    input, writable, not there unless ``overwrite``)."""
    import dataclasses
    import json

    from pydantic import ValidationError

    from ..input_guard import check_outputs
    from ..store.atomic import atomic_file, check_output_file, write_text
    from ..store.provenance import provenance_record
    from .config import load_feature_config
    from .plots import plot_feature_spectra

    check_outputs({"out": out, "plot": plot}, [path, config])
    for target in (out, plot):
        if target is not None:
            check_output_file(target, overwrite=overwrite)
    if out is not None and plot is not None and Path(out).resolve() == Path(plot).resolve():
        raise InputError("`out` and `plot` name the same file; give each its own", path=out)
    fcfg = load_feature_config(config) if config is not None else FeatureConfig()
    if folds is not None:
        try:
            fcfg = FeatureConfig.model_validate({**fcfg.model_dump(), "folds": folds})
        except ValidationError as exc:
            raise InputError(f"`folds` (={folds}): {exc.errors()[0]['msg']}") from None
    result = slip_interface(path, fcfg, progress=progress)
    if out is not None:
        record = provenance_record([path] + ([config] if config is not None else []),
                                   fcfg.model_dump(mode="json"))
        write_text(out, json.dumps({**result.as_dict(), "provenance": record}, indent=2)
                   + "\n", overwrite=overwrite)
    if plot is not None:
        with atomic_file(plot, overwrite=overwrite, keep_suffix=True) as tmp:
            plot_feature_spectra(result.features, tmp)
    return dataclasses.replace(result, out=None if out is None else Path(out),
                               plot=None if plot is None else Path(plot))


# -- the feature stream -----------------------------------------------------------------------
@dataclass(frozen=True)
class FeatureStreamResult:
    out: Path
    n_trials: int
    n_windows: int
    channels: tuple[str, ...]
    window_s: float
    hop_s: float
    rank_deficient: dict[str, bool]

    def as_dict(self) -> dict[str, Any]:
        return {"out": str(self.out), "n_trials": self.n_trials, "n_windows": self.n_windows,
                "stream": FEATURE_STREAM, "channels": list(self.channels),
                "window_s": self.window_s, "hop_s": self.hop_s,
                "rank_deficient": self.rank_deficient}

    def summary_lines(self) -> list[str]:
        flagged = [p for p, bad in self.rank_deficient.items() if bad]
        return [f"wrote {self.out}: {self.n_trials} trial(s), {self.n_windows} windows of "
                f"{self.window_s:g} s every {self.hop_s:g} s, {len(self.channels)} channels"
                + (f"; rank-deficient bands (G2 biased up) in {', '.join(flagged)}"
                   if flagged else "")]


def write_taxel_features(path: str | Path, out: str | Path, fcfg: FeatureConfig | None = None,
                         *, config: str | Path | None = None, command: str | None = None,
                         overwrite: bool = False, progress: Progress | None = None
                         ) -> FeatureStreamResult:
    """Gamma, single- and multi-finger G2 per window (``window_s`` every ``hop_s``) and
    per named band of ``fcfg.bands_hz`` (plus ``full``) for every taxel trial of ``path``,
    written to ``out`` as stream ``spectral_features`` (channels ``<feature>_<band>``,
    one sample per window at its end time) with per-window labels ``slip`` (rest, hand,
    world: the trial's slip type once the window's centre lies inside its slip segment),
    by the one feature-stream writer
    :func:`tactile_cli.spectral.stream_features.write_feature_stream`.
    ``fcfg``: the feature config, else the one in the YAML file ``config``, else the
    defaults. Contact is estimated once per trial (rest against slip segment). Windows
    whose CSD averages fewer segment-bin products than channels are flagged in the sensor
    attribute ``rank_deficient_bands``."""
    from ..input_guard import check_outputs
    from ..spectral.stream_features import (
        FeatureSensor,
        FeatureTrial,
        named_bins,
        window_plan,
        write_feature_stream,
    )
    from ..store.atomic import check_output_file
    from ..store.provenance import provenance_record
    from .config import load_feature_config

    progress = progress or NullProgress()
    check_outputs({"out": out}, [path, config])
    check_output_file(out, overwrite=overwrite)
    if fcfg is None:
        fcfg = load_feature_config(config) if config is not None else FeatureConfig()
    classes = (REST, *SLIP_TYPES)
    flags: dict[str, bool] = {}
    channels: list[tuple[str, ...]] = []

    def windows_of(tf: TactileFile) -> Iterator[FeatureTrial]:
        presets = file_presets(tf)
        progress.start(sum(str(t.labels.get("preset")) in presets for t in tf.trials()),
                       "spectral features")
        for preset in presets:
            wc = _welch(fcfg, preset)
            pt = read_preset_trials(tf, preset)
            rate = pt.rate_hz
            n_taxels = pt.slip[0].shape[-1]
            what = f"preset {preset!r}"
            win, hop = window_plan(fcfg.window_s, fcfg.hop_s, rate, 0, 0, what=what,
                                   path=tf.path)
            nperseg = min(wc.nperseg, win)
            if win < 8:
                raise InputError(f"`window_s` (={fcfg.window_s}) holds {win} samples of "
                                 f"preset {preset!r}; at least 8 are needed", path=tf.path)
            f_hz = np.fft.rfftfreq(nperseg, 1 / rate)
            band_names, lo, hi = named_bins(f_hz, fcfg.bands_hz.get(preset, {}))
            these = tuple(f"{feat}_{b}" for feat in FEATURES for b in band_names)
            channels.append(these)
            noverlap = wc.noverlap(nperseg)
            n_avg = ((win - noverlap) // (nperseg - noverlap)) * (hi - lo + 1)
            flags[preset] = bool((n_avg < n_taxels).any())
            sensor = FeatureSensor(
                f"{preset}_spectral", these, "taxel_array", 1.0 / fcfg.hop_s, {
                    "preset": preset, "window_s": fcfg.window_s, "hop_s": fcfg.hop_s,
                    "rank_deficient_bands": ",".join(
                        n for n, a in zip(band_names, n_avg, strict=True) if a < n_taxels),
                    "description": "power ratio Gamma and group square coherence G2 per "
                    "window and band (paper 004)"})
            delays = pt.delays_s if fcfg.sequential_correction else None
            for ti, name in enumerate(pt.names):
                trial = tf.trial(name)
                sigs = [trial.signal(taxel_stream(preset, k)) for k in range(len(pt.slip))]
                n = min(len(s.data) for s in sigs)
                window_plan(fcfg.window_s, fcfg.hop_s, rate, n, len(sigs) * n_taxels,
                            what=what, path=tf.path)
                data = np.stack([s.data.astype(np.float64) for s in sigs])  # (F, n, N)
                ends = np.arange(win, n + 1, hop)
                idx = ends[:, None] - win + np.arange(win)
                windows = data[:, :n][:, idx]                                # (F, W, win, N)
                contacts = [np.broadcast_to(
                    contact_taxels(pt.rest[k][ti], pt.slip[k][ti], fcfg.contact_threshold)
                    if fcfg.contact_estimation else np.ones(data.shape[-1], dtype=bool),
                    (len(ends), data.shape[-1])) for k in range(len(sigs))]
                feats = [array_features(windows[k], rate, lo, hi, nperseg=nperseg,
                                        noverlap=noverlap,
                                        delays_s=delays, contact=contacts[k])
                         for k in range(len(sigs))]
                gamma = np.nanmean([f.gamma for f in feats], axis=0)
                g2 = np.nanmean([f.g2 for f in feats], axis=0)
                g2m = multi_finger_g2(finger_ensembles(feats, delays, contacts), lo, hi)
                t_end = sigs[0].t_s[ends - 1] + 1.0 / rate
                s0, _ = _segment(trial, SLIP)
                centre = t_end - fcfg.window_s / 2
                label = np.where(centre > s0 + 1e-9, classes.index(pt.slip_type[ti]), 0)
                yield FeatureTrial(trial, sensor, np.concatenate([gamma, g2, g2m], axis=1),
                                   t_end, {"slip": (label.astype(np.int64), classes)})
                progress.advance(1)
        progress.finish()

    record = provenance_record([path] + ([config] if config is not None else []),
                               fcfg.model_dump(mode="json"))
    written = write_feature_stream(path, out, windows_of, command=command, config=record,
                                   overwrite=overwrite)
    return FeatureStreamResult(written.out, written.n_trials, written.n_windows,
                               channels[-1] if channels else (), fcfg.window_s, fcfg.hop_s,
                               flags)
