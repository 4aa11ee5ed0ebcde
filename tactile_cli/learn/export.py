"""``tactile export``: a trained run as one self-contained model file for the robot (issue 19).

The exported graph takes the raw window as the sensor gives it, ``(batch, window,
channels)`` float32 in the run's channel order and units, and does everything
``tactile evaluate`` does to it (:class:`DeployedModel`): the sample transform
(``signed_log1p``), the per-channel normalisation of the training split, the per-window
``center_scale`` when the config asks for it, the network (in-model features included:
the MLP's summary features, the CNN-2D's spectrogram), a softmax per classification head
and, per regression head, the value back in the label's units. One output per head, in
the run's head order: ``<head>.probabilities`` ``(batch, n_classes)`` or ``<head>.value``
``(batch,)``.

Formats: ``onnx`` (``torch.onnx.export``, dynamo exporter; run with onnxruntime or any
ONNX runtime, batch axis dynamic) and ``torchscript`` (``torch.jit.trace``; torch marks it
deprecated, so ONNX is the format to deploy). Next to the model a JSON sidecar
(``FILE.json``, format ``tactile-export`` 1) states the input shape, channel names and
units, sample period, window, stride and padding, the outputs with their label names, the
tool version and the run's provenance (its files with SHA-256, command, data). Both files
are written to temporary siblings and renamed, so an error leaves no file.

:class:`ExportedModel` reads an exported file back (onnxruntime or ``torch.jit.load``);
``tactile evaluate --exported FILE`` uses it to check the file against the run on the
evaluation windows and to time it at batch 1 (:func:`check_exported`).
"""

from __future__ import annotations

import contextlib
import io
import json
import logging
import time
import warnings
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Literal

import numpy as np
import torch
from torch import Tensor, nn

from .._version import __version__
from ..errors import InputError
from ..input_guard import check_outputs
from ..store.atomic import atomic_file, check_output_file
from ..store.provenance import current_command, sha256_of, utc_now
from . import runs
from .config import CLASSIC_FAMILIES
from .data import Normalisation, TrialSeries, WindowSet, make_windows
from .heads import HeadSpec
from .models import MultiTaskNet
from .train import predict

EXPORT_FORMAT = "tactile-export"
EXPORT_FORMAT_VERSION = 1
FORMATS = ("onnx", "torchscript")
INPUT_NAME = "window"

#: Families each format can carry. Every family of :data:`.models.REGISTRY` exports to both
#: (the CNN-2D's ``torch.stft`` becomes ONNX ``DFT``); a family added later that does not is
#: refused by name until it does.
#: The classic families (scikit-learn, :mod:`.classic`) go to ONNX only: their stored model
#: is an ONNX graph already, which the export puts behind the preprocessing
#: (:func:`.classic_onnx.deployed_graph`); TorchScript has no form for them.
EXPORTABLE: dict[str, frozenset[str]] = {
    "onnx": frozenset({"lstm", "cnn1d", "cnn2d_spectrogram", "fnn", "mlp", "cnn2d_layout",
                       "cnn2d_frames", *CLASSIC_FAMILIES}),
    "torchscript": frozenset({"lstm", "cnn1d", "cnn2d_spectrogram", "fnn", "mlp",
                              "cnn2d_layout", "cnn2d_frames"}),
}


def output_names(heads: Sequence[HeadSpec]) -> list[str]:
    """``<head>.probabilities`` per classification head, ``<head>.value`` per regression
    head, in head order: the exported model's outputs."""
    return [f"{h.name}.probabilities" if h.kind == "classification" else f"{h.name}.value"
            for h in heads]


def sidecar_path(model_path: str | Path) -> Path:
    """``FILE.json`` beside ``FILE`` (``model.onnx`` -> ``model.onnx.json``)."""
    p = Path(model_path)
    return p.with_name(p.name + ".json")


# -- the graph -------------------------------------------------------------------------------
class DeployedModel(nn.Module):
    """Raw windows ``(B, W, C)`` float32 in sensor units -> one tensor per head, in head
    order: ``(B, k)`` class probabilities or ``(B,)`` values in the label's units.

    The transform and normalisation run in float64, as :meth:`.data.Normalisation.apply`
    does, then the window is cast to float32 for the network, as evaluation feeds it.
    """

    def __init__(self, net: MultiTaskNet, norm: Normalisation, *, window_norm: str = "none"):
        super().__init__()
        self.net = net.eval()
        self.heads = tuple(net.head_specs)
        self.signed_log1p = norm.transform == "signed_log1p"
        self.normalise = bool(norm.enabled)
        self.center_scale = window_norm == "center_scale"
        self.window_norm = window_norm
        self.register_buffer("channel_mean", torch.as_tensor(norm.mean, dtype=torch.float64))
        self.register_buffer("channel_std", torch.as_tensor(norm.std, dtype=torch.float64))
        scale = [norm.targets.get(h.name, (0.0, 1.0)) for h in self.heads]
        self.register_buffer("target_mean", torch.tensor([m for m, _ in scale]))
        self.register_buffer("target_std", torch.tensor([s for _, s in scale]))

    def preprocess(self, x: Tensor) -> Tensor:
        """(B, W, C) raw -> (B, W, C) float32 network input."""
        y = x.to(torch.float64)
        if self.signed_log1p:
            y = torch.sign(y) * torch.log1p(torch.abs(y))
        if self.normalise:
            y = (y - self.channel_mean) / self.channel_std
        z = y.to(torch.float32)
        if self.center_scale:  # as .data.center_scale: a constant channel becomes zeros
            varies = z.amax(dim=1, keepdim=True) > z.amin(dim=1, keepdim=True)
            z = z - z.mean(dim=1, keepdim=True)
            peak = z.abs().amax(dim=1, keepdim=True)
            ok = varies & (peak > 0)
            z = torch.where(ok, z / torch.where(ok, peak, torch.ones_like(peak)),
                            torch.zeros_like(z))
        elif self.window_norm in ("center", "zscore"):  # as .preprocess.normalise_windows
            varies = z.amax(dim=1, keepdim=True) > z.amin(dim=1, keepdim=True)
            z = z - z.mean(dim=1, keepdim=True)
            if self.window_norm == "zscore":
                sd = torch.sqrt((z.to(torch.float64) ** 2).mean(dim=1, keepdim=True))
                sd = sd.to(torch.float32)
                ok = varies & (sd > 0)
                z = z / torch.where(ok, sd, torch.ones_like(sd))
            z = torch.where(varies, z, torch.zeros_like(z))
        return z

    def forward(self, x: Tensor) -> tuple[Tensor, ...]:
        raw = self.net(self.preprocess(x))
        out = []
        for i, head in enumerate(self.heads):
            y = raw[head.name]
            if head.kind == "classification":
                out.append(torch.softmax(y, dim=-1))
            else:
                out.append(y * self.target_std[i] + self.target_mean[i])
        return tuple(out)


def deployed_model(run: runs.Run) -> DeployedModel:
    """The run's network with its preprocessing, in eval mode (weights loaded and checked)."""
    return DeployedModel(run.load_model(), run.normalisation,
                         window_norm=run.config.data.window_norm).eval()


# -- the windows and the package's own outputs -----------------------------------------------
def raw_windows(trials: Sequence[TrialSeries], run: runs.Run) -> np.ndarray:
    """(n, window, channels) float32 raw windows (sensor units, padding included) of
    ``trials``: the very windows :func:`.data.make_windows` cuts for evaluation, in its
    order, before transform and normalisation."""
    d = run.config.data
    identity = Normalisation(list(d.channels), np.zeros(len(d.channels)),
                             np.ones(len(d.channels)), 0, enabled=False, transform="none")
    ws = replace(make_windows(trials, d, run.heads, identity), window_norm="none")
    return ws.windows()


def package_outputs(model: MultiTaskNet, ws: WindowSet, heads: Sequence[HeadSpec],
                    targets_scale: dict[str, tuple[float, float]]) -> dict[str, np.ndarray]:
    """What ``tactile evaluate`` makes of windows ``ws``: :func:`.train.predict`, then the
    softmax of each classification head (float64) and each regression value in the label's
    units (``out * std + mean``, as :func:`.metrics.head_metrics` decodes it). Keys:
    :func:`output_names`."""
    raw = predict(model, ws)
    out = {}
    for name, head in zip(output_names(heads), heads, strict=True):
        y = raw[head.name].astype(np.float64)
        if head.kind == "classification":
            e = np.exp(y - y.max(axis=1, keepdims=True))
            out[name] = e / e.sum(axis=1, keepdims=True)
        else:
            m, s = targets_scale.get(head.name, (0.0, 1.0))
            out[name] = y * s + m
    return out


# -- writing ---------------------------------------------------------------------------------
@dataclass
class ExportResult:
    """The files ``export_run`` wrote and what they hold."""

    path: Path
    sidecar: Path
    format: str
    family: str
    outputs: list[str]
    size_bytes: int
    sidecar_record: dict[str, Any]


@contextlib.contextmanager
def _quiet_exporter() -> Iterator[None]:
    """The exporters' progress prints, log lines and deprecation warnings kept off the
    terminal (a command prints one line; pytest turns warnings into errors)."""
    loggers = [logging.getLogger(n) for n in ("torch.onnx", "torch.export", "torch._dynamo",
                                              "onnxscript", "torch.fx")]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.ERROR)
    try:
        with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()), \
                contextlib.redirect_stderr(io.StringIO()):
            warnings.simplefilter("ignore")
            yield
    finally:
        for lg, level in zip(loggers, levels, strict=True):
            lg.setLevel(level)


def _first_line(exc: BaseException) -> str:
    text = " ".join(str(exc).strip().split("\n")[0].split())
    return f"{exc.__class__.__name__}: {text[:200]}" if text else exc.__class__.__name__


def _write_onnx(model: DeployedModel, example: Tensor, tmp: Path, sidecar: dict[str, Any]
                ) -> int:
    """Export to ``tmp``; returns the opset. The sidecar also goes into the file's metadata
    (key ``tactile.export``), so the model file alone says what it expects."""
    import onnx

    names = output_names(model.heads)
    with _quiet_exporter():
        torch.onnx.export(model, (example,), str(tmp), dynamo=True, input_names=[INPUT_NAME],
                          output_names=names, external_data=False,
                          dynamic_shapes=({0: torch.export.Dim("batch")},))
    proto = onnx.load(str(tmp))
    opset = next((o.version for o in proto.opset_import if o.domain in ("", "ai.onnx")), 0)
    sidecar["model"]["opset"] = int(opset)
    entry = proto.metadata_props.add()
    entry.key, entry.value = "tactile.export", json.dumps(sidecar)
    onnx.save(proto, str(tmp))
    return int(opset)


def _write_torchscript(model: DeployedModel, example: Tensor, tmp: Path,
                       sidecar: dict[str, Any]) -> None:
    with _quiet_exporter(), torch.no_grad():
        traced = torch.jit.trace(model, (example,))
        torch.jit.save(traced, str(tmp), _extra_files={"tactile.export.json":
                                                       json.dumps(sidecar)})


def _sources(run: runs.Run) -> list[dict[str, str]]:
    names = (runs.RUN_JSON, runs.CONFIG_YAML, run.weights_path.name, runs.NORMALISATION_JSON)
    return [{"path": str(run.path / n), "sha256": sha256_of(run.path / n)} for n in names]


#: Largest difference of a classic export's outputs from the run's own model with the
#: toolkit's preprocessing (:class:`DeployedModel`) on seeded probe windows.
CLASSIC_PROBE_TOL = 1e-5


def _probe_windows(run: runs.Run, n: int = 64) -> np.ndarray:
    """(n, W, C) float32 raw windows around the training data: seeded normal values of the
    (transformed) channel means and stds, transformed back to sensor units."""
    d, norm = run.config.data, run.normalisation
    rng = np.random.default_rng(0)
    v = norm.mean + norm.std * rng.standard_normal((n, d.window, len(d.channels)))
    if norm.transform == "signed_log1p":
        v = np.sign(v) * np.expm1(np.abs(v))
    return v.astype(np.float32)


def _write_classic_onnx(run: runs.Run, tmp: Path, sidecar: dict[str, Any]) -> None:
    """A classic run's stored ONNX graph behind the preprocessing, with the sidecar in its
    metadata; checked against :class:`DeployedModel` of the run's own model (the toolkit's
    preprocessing in torch) on probe windows, so that a preprocessing step the graph does
    not reproduce is an error and not a silent difference."""
    import onnx

    from .classic_onnx import deployed_graph, run_graph, session

    net = run.load_model()
    norm, d = run.normalisation, run.config.data
    (name,) = output_names(run.heads)
    proto = deployed_graph(net.model_bytes, transform=norm.transform,  # type: ignore[arg-type]
                           normalise=norm.enabled, mean=norm.mean, std=norm.std,
                           window_norm=d.window_norm, output_name=name, input_name=INPUT_NAME)
    sidecar["model"]["opset"] = int(next(o.version for o in proto.opset_import
                                         if o.domain in ("", "ai.onnx")))
    entry = proto.metadata_props.add()
    entry.key, entry.value = "tactile.export", json.dumps(sidecar)
    probe = _probe_windows(run)
    with torch.inference_mode():
        mine = DeployedModel(net, norm, window_norm=d.window_norm)(torch.from_numpy(probe))
    theirs = run_graph(session(proto.SerializeToString()), probe)
    diff = float(np.max(np.abs(theirs - mine[0].numpy())))
    if not diff <= CLASSIC_PROBE_TOL:
        raise InputError(f"the exported graph differs from the run's model with its "
                         f"preprocessing by {diff:.3g} on probe windows (more than "
                         f"{CLASSIC_PROBE_TOL:g}): a preprocessing step the classic export "
                         "does not reproduce; evaluate the run in place", path=run.path)
    onnx.save(proto, str(tmp))


def sidecar_record(run: runs.Run, fmt: str, model_file: str, *, command: str) -> dict[str, Any]:
    """The sidecar of an export of ``run`` (see the module docstring); ``model.sha256`` and,
    for ONNX, ``model.opset`` are filled in once the file exists."""
    d = run.config.data
    spec = run.input
    units: list[str] | None = list(spec.units) if spec is not None else None
    period = spec.sample_period_s if spec is not None else None
    names = output_names(run.heads)
    versions = {"tactile": __version__, "torch": torch.__version__}
    if fmt == "onnx":
        import onnx
        import onnxruntime

        versions |= {"onnx": onnx.__version__, "onnxruntime": onnxruntime.__version__}
    if run.config.model.family in CLASSIC_FAMILIES:
        versions |= {k: v for k, v in (run.info.get("versions") or {}).items()
                     if k in ("scikit-learn", "skl2onnx")}
    return {
        "format": EXPORT_FORMAT, "format_version": EXPORT_FORMAT_VERSION,
        "tool_version": __version__, "created_utc": utc_now(), "command": command,
        "versions": versions,
        "model": {"file": model_file, "format": fmt, "family": run.config.model.family,
                  "sha256": None},
        "input": {
            "name": INPUT_NAME, "shape": [None, d.window, len(d.channels)],
            "dims": ["batch", "samples", "channels"], "dtype": "float32",
            "channels": list(d.channels), "units": units,
            "stream": d.stream, "sensor": None if spec is None else spec.sensor,
            "sample_period_s": period,
            "sample_rate_hz": None if period is None else 1.0 / period,
            "window": d.window, "stride": d.stride, "pad": d.pad,
            "label_delay": d.label_delay,
            "note": ("raw samples in sensor units, oldest first; the last sample is the "
                     "newest. Before a trial has `window` samples the run padded with "
                     + ("zeros" if d.pad == "zero" else "the first sample"
                        if d.pad != "none" else "nothing (no window until it is full)")
                     + f". The outputs are for the sample `label_delay` (={d.label_delay}) "
                     "samples before the newest." + _baseline_note(d.baseline)),
        },
        "preprocessing": {
            "inside_model": True, "transform": run.normalisation.transform,
            "normalisation": {"enabled": run.normalisation.enabled,
                              "mean": [float(v) for v in run.normalisation.mean],
                              "std": [float(v) for v in run.normalisation.std]},
            "window_norm": d.window_norm,
            "baseline": {"mode": d.baseline.mode, "duration_ms": d.baseline.duration_ms,
                         "inside_model": False},
        },
        "outputs": [
            {"name": n, "head": h.name, "kind": h.kind, "source": h.source,
             **({"shape": [None, len(h.classes)], "labels": list(h.classes)}
                if h.kind == "classification" else {"shape": [None], "labels": None,
                                                    "units": "the label's units"})}
            for n, h in zip(names, run.heads, strict=True)
        ],
        "run": {
            "path": str(run.path), "created_utc": run.info.get("created_utc"),
            "command": run.info.get("command"), "config_file": run.info.get("config_file"),
            "seed": run.info.get("seed"), "data": run.info.get("data"),
            "versions": run.info.get("versions"), "input": run.info.get("input"),
            "sources": _sources(run),
        },
    }


def _baseline_note(baseline: Any) -> str:
    """What the caller subtracts before the graph when the run removed per-trial baselines
    (the level is a property of the trial, not of one window, so it stays outside)."""
    if baseline.mode == "none":
        return ""
    level = (f"the mean of the trial's first {baseline.duration_ms:g} ms"
             if baseline.mode == "start" else "the trial's median")
    return (f" The run removed each trial's resting level (data.baseline, mode "
            f"{baseline.mode}): subtract {level}, per channel, from every sample before "
            "feeding it.")


def export_run(run_dir: str | Path, out: str | Path, *,
               format: Literal["onnx", "torchscript"] = "onnx", overwrite: bool = False,
               command: str | None = None) -> ExportResult:
    """Export the run in ``run_dir`` to ``out`` (one model file) and ``out + '.json'`` (the
    sidecar). An existing file at either is an error unless ``overwrite``; a damaged run
    folder, one of another format version, a cross-validated run (give a fold) or a family
    the format cannot carry is an InputError before anything is written."""
    if format not in FORMATS:
        raise InputError(f"`format` (={format!r}) must be one of {', '.join(FORMATS)}")
    for target in (out, sidecar_path(out)):  # the model file and its sidecar
        check_outputs({"out": target}, runs.run_files(run_dir))
    out = check_output_file(out, overwrite=overwrite)
    side = check_output_file(sidecar_path(out), overwrite=overwrite)
    run = runs.load_run(run_dir)
    family = run.config.model.family
    if family not in EXPORTABLE[format]:
        raise InputError(f"the {family} family cannot be exported to {format} (exportable: "
                         f"{', '.join(sorted(EXPORTABLE[format]))})", path=run.path)
    classic = family in CLASSIC_FAMILIES
    model = None if classic else deployed_model(run)
    d = run.config.data
    # batch 2: an exporter specialises a size-1 dimension, and the batch axis must stay free
    example = torch.from_numpy(np.random.default_rng(0).standard_normal(
        (2, d.window, len(d.channels))).astype(np.float32))
    record = sidecar_record(run, format, out.name,
                            command=command if command is not None else current_command())
    # the sidecar's block is the outer one: the model lands first, then its description
    with atomic_file(side, overwrite=overwrite) as tmp_side, \
            atomic_file(out, overwrite=overwrite) as tmp_model:
        try:
            if model is None:
                _write_classic_onnx(run, tmp_model, record)
            elif format == "onnx":
                _write_onnx(model, example, tmp_model, record)
            else:
                _write_torchscript(model, example, tmp_model, record)
        except InputError:
            raise
        except Exception as exc:  # the exporter's failure, said on one line
            raise InputError(f"the {family} family could not be exported to {format} "
                             f"({_first_line(exc)})", path=run.path) from None
        record["model"]["sha256"] = sha256_of(tmp_model)
        tmp_side.write_text(runs.dumps(record) + "\n", encoding="utf-8")
    return ExportResult(out, side, format, family, output_names(run.heads),
                        out.stat().st_size, record)


# -- reading back ----------------------------------------------------------------------------
def read_sidecar(model_path: str | Path) -> dict[str, Any]:
    """The sidecar of an exported model file, checked (format, version, outputs)."""
    path = sidecar_path(model_path)
    redo = "re-create it with `tactile export`"
    if not Path(model_path).is_file():
        raise InputError(f"exported model file not found; {redo}", path=model_path)
    if not path.is_file():
        raise InputError(f"the exported model has no sidecar {path.name} beside it; {redo}",
                         path=path)
    rec = runs.checked_record(runs._parse_json(path, redo), path, fmt=EXPORT_FORMAT,
                              version=EXPORT_FORMAT_VERSION, redo=redo)
    model, outputs = rec.get("model"), rec.get("outputs")
    if not isinstance(model, dict) or model.get("format") not in FORMATS or not isinstance(
            outputs, list) or not all(isinstance(o, dict) and isinstance(o.get("name"), str)
                                      for o in outputs):
        raise InputError(f"the sidecar lacks `model.format` or `outputs`; {redo}", path=path)
    return rec


class ExportedModel:
    """An exported file run without the package's network code: onnxruntime for ONNX,
    ``torch.jit.load`` for TorchScript. ``model(windows)`` takes (n, W, C) float32 raw
    windows and returns ``{output name: array}``."""

    def __init__(self, path: str | Path, *, threads: int = 1):
        self.path = Path(path)
        self.sidecar = read_sidecar(self.path)
        self.format: str = self.sidecar["model"]["format"]
        self.names = [o["name"] for o in self.sidecar["outputs"]]
        self.threads = int(threads)
        try:
            if self.format == "onnx":
                import onnxruntime as ort

                opts = ort.SessionOptions()
                opts.intra_op_num_threads = self.threads
                opts.inter_op_num_threads = 1
                self._session = ort.InferenceSession(str(self.path), opts,
                                                     providers=["CPUExecutionProvider"])
                self.runtime = f"onnxruntime {ort.__version__}"
            else:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    self._module = torch.jit.load(str(self.path), map_location="cpu")
                self.runtime = f"torch.jit {torch.__version__}"
        except Exception as exc:
            raise InputError(f"the exported model cannot be loaded ({_first_line(exc)}); "
                             "re-create it with `tactile export`", path=self.path) from None

    def run_batch(self, windows: np.ndarray) -> list[np.ndarray]:
        x = np.ascontiguousarray(windows, dtype=np.float32)
        if self.format == "onnx":
            return self._session.run(None, {INPUT_NAME: x})
        previous = torch.get_num_threads()
        torch.set_num_threads(self.threads)
        try:
            with torch.inference_mode():
                return [t.numpy() for t in self._module(torch.from_numpy(x))]
        finally:
            torch.set_num_threads(previous)

    def __call__(self, windows: np.ndarray, *, batch_size: int = 4096) -> dict[str, np.ndarray]:
        parts: list[list[np.ndarray]] = [[] for _ in self.names]
        for lo in range(0, windows.shape[0], batch_size):
            for i, y in enumerate(self.run_batch(windows[lo:lo + batch_size])):
                parts[i].append(y)
        return {n: np.concatenate(p) for n, p in zip(self.names, parts, strict=True)}


def time_batch1(fn: Any, windows: np.ndarray, *, repeats: int = 300, warmup: int = 30
                ) -> dict[str, float | int]:
    """Median, 95th percentile and minimum (ms) of ``fn(window)`` at batch 1 over
    ``repeats`` calls cycling through ``windows`` after ``warmup`` calls (as
    :func:`.latency.measure_latency` times the torch model)."""
    n = windows.shape[0]
    singles = [np.ascontiguousarray(windows[i % n: i % n + 1], dtype=np.float32)
               for i in range(warmup + repeats)]
    for i in range(warmup):
        fn(singles[i])
    times = np.empty(repeats, dtype=np.int64)
    for i in range(repeats):
        x = singles[warmup + i]
        t0 = time.perf_counter_ns()
        fn(x)
        times[i] = time.perf_counter_ns() - t0
    ms = times / 1e6
    return {"batch1_ms_median": float(np.median(ms)), "batch1_ms_p95": float(np.percentile(
        ms, 95)), "batch1_ms_min": float(ms.min()), "batch1_repeats": repeats,
        "warmup": warmup}


def max_abs_diff(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> float:
    """Largest absolute difference over every output of two ``{name: array}`` results."""
    return max(float(np.max(np.abs(np.asarray(a[k], np.float64) - np.asarray(b[k], np.float64)),
                            initial=0.0)) for k in a)


def check_exported(path: str | Path, run: runs.Run, model: MultiTaskNet, ws: WindowSet,
                   raw: np.ndarray, *, latency: bool = True, threads: int | None = None
                   ) -> dict[str, Any]:
    """The exported file at ``path`` against ``run`` on the evaluation windows: the largest
    difference of its outputs from the package's (``ws``: the normalised windows;
    ``raw``: the same windows raw) and, with ``latency``, its batch-1 latency on up to
    2,048 of them (the seeded pick of :func:`.metrics.measure_latency_of`). A file exported
    from another run (its sidecar's model.pt or model.onnx SHA-256) is an InputError."""
    exported = ExportedModel(path, threads=1 if threads is None else threads)
    side = exported.sidecar
    want = sha256_of(run.weights_path)
    have = {s.get("sha256") for s in side.get("run", {}).get("sources", [])
            if isinstance(s, dict) and str(s.get("path", "")).endswith(run.weights_path.name)}
    if want not in have:
        raise InputError(f"was exported from another run than {run.path} (its "
                         f"{run.weights_path.name} differs); export this run with "
                         "`tactile export`", path=path)
    mine = package_outputs(model, ws, run.heads, run.normalisation.targets)
    theirs = exported(raw)
    record: dict[str, Any] = {
        "file": str(path), "format": exported.format, "sha256": sha256_of(path),
        "runtime": exported.runtime, "threads": exported.threads,
        "max_abs_diff": max_abs_diff(theirs, mine), "n_windows": int(raw.shape[0]),
        "latency": None,
    }
    if latency and raw.shape[0]:
        pick = np.sort(np.random.default_rng(0).choice(raw.shape[0], size=min(
            raw.shape[0], 2048), replace=False))
        record["latency"] = time_batch1(exported.run_batch, raw[pick])
    return record


__all__ = ["EXPORTABLE", "EXPORT_FORMAT", "EXPORT_FORMAT_VERSION", "FORMATS", "INPUT_NAME",
           "DeployedModel", "ExportResult", "ExportedModel", "check_exported",
           "deployed_model", "export_run", "max_abs_diff", "output_names", "package_outputs",
           "raw_windows", "read_sidecar", "sidecar_path", "sidecar_record", "time_batch1"]
