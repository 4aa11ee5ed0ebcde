"""The model registry: six network families with multi-task heads, and their loss.

Every network takes a batch of normalised windows ``(batch, window, channels)`` float32
and returns one output per head: ``(batch, n_classes)`` logits for a classification head,
``(batch,)`` for a regression head (a standardised value). A family is a *trunk* that
turns a window into a feature vector; the heads are small fully connected networks on it
(issue 4, item 1):

- ``lstm``: LSTM over the window, last hidden state of the last layer (paper 000, sec. 5,
  Table I: one LSTM layer, a fully connected layer, softmax; softmax is in the loss);
- ``cnn1d``: 1-D convolutions over time ('same' padding, ReLU, max-pool), flattened;
- ``cnn2d_spectrogram``: log-magnitude STFT of each channel (``torch.stft``, Hann window,
  no centring), channels as image channels, 2-D convolutions, flattened (paper 001,
  sec. 5.3);
- ``fnn``: fully connected layers on the flattened window (paper 001, sec. 5.1);
- ``mlp``: fully connected layers on per-channel summary features of the window (mean,
  std, min, max, last, slope; computed inside the model, so latency includes them, and
  standardised by training statistics held in buffers).
- ``cnn2d_layout``: the channels laid out as an image at their places on the sensor (an
  electrode layout such as the BioTac SP's), 2-D convolutions, flattened
  (:mod:`.layout_cnn`; issue 34).
- ``cnn2d_frames``: image sequences (``data.stream: frames``), a 2-D CNN per frame and an
  LSTM or temporal convolution over the frames (:mod:`.frame_cnn`; issue 35).

The classic families (logistic regression, random forest, gradient boosting, SVM) are not
networks and not in this registry: :mod:`.classic`.

The loss of several heads is paper 001's eq. 3, ``TL = CE_motion + CE_texture + L2_speed``,
with a configurable weight per head: ``sum_h w_h loss_h`` (cross-entropy, optionally
class-weighted, for classification; mean squared error for regression).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import torch
from torch import Tensor, nn
from torch.nn import functional as F

from .config import (
    FEATURE_NAMES,
    Cnn1dConfig,
    Cnn2dSpectrogramConfig,
    FnnConfig,
    FramesConfig,
    LstmConfig,
    MlpConfig,
    ModelConfig,
)
from .frame_cnn import FrameSequenceTrunk
from .heads import HeadSpec
from .layout_cnn import LayoutCnnTrunk


def _dense(in_features: int, sizes: Sequence[int], dropout: float) -> tuple[nn.Sequential, int]:
    layers: list[nn.Module] = []
    for size in sizes:
        layers += [nn.Linear(in_features, size), nn.ReLU()]
        if dropout:
            layers.append(nn.Dropout(dropout))
        in_features = size
    return nn.Sequential(*layers), in_features


class LstmTrunk(nn.Module):
    """(B, W, C) -> (B, hidden): the last hidden state of the top LSTM layer."""

    def __init__(self, cfg: LstmConfig, window: int, n_channels: int):
        super().__init__()
        self.lstm = nn.LSTM(n_channels, cfg.hidden, num_layers=cfg.layers, batch_first=True,
                            dropout=cfg.dropout if cfg.layers > 1 else 0.0)
        self.out_features = cfg.hidden

    def forward(self, x: Tensor) -> Tensor:
        _, (h, _) = self.lstm(x)
        return h[-1]


class Cnn1dTrunk(nn.Module):
    """(B, W, C) -> (B, channels[-1] * W'): convolutions over time, flattened."""

    def __init__(self, cfg: Cnn1dConfig, window: int, n_channels: int):
        super().__init__()
        layers: list[nn.Module] = []
        length, cin = window, n_channels
        for cout in cfg.channels:
            layers += [nn.Conv1d(cin, cout, cfg.kernel, padding="same"), nn.ReLU()]
            if cfg.pool > 1 and length >= cfg.pool:
                layers.append(nn.MaxPool1d(cfg.pool))
                length //= cfg.pool
            if cfg.dropout:
                layers.append(nn.Dropout(cfg.dropout))
            cin = cout
        self.net = nn.Sequential(*layers, nn.Flatten())
        self.out_features = cin * length

    def forward(self, x: Tensor) -> Tensor:
        return self.net(x.transpose(1, 2))


class Cnn2dSpectrogramTrunk(nn.Module):
    """(B, W, C) -> (B, D): log(1 + |STFT|) per channel as a (C, F, T) image, then
    convolutions (F = n_fft // 2 + 1 bins, T = 1 + (W - n_fft) // hop frames)."""

    def __init__(self, cfg: Cnn2dSpectrogramConfig, window: int, n_channels: int):
        super().__init__()
        if cfg.n_fft > window:
            raise ValueError(f"`n_fft` (={cfg.n_fft}) must be <= the window (={window})")
        self.n_fft, self.hop = cfg.n_fft, cfg.hop
        self.register_buffer("stft_window", torch.hann_window(cfg.n_fft, periodic=True),
                             persistent=False)
        height, width = cfg.n_fft // 2 + 1, 1 + (window - cfg.n_fft) // cfg.hop
        layers: list[nn.Module] = []
        cin = n_channels
        for cout in cfg.channels:
            layers += [nn.Conv2d(cin, cout, cfg.kernel, padding="same"), nn.ReLU()]
            if height >= 2 and width >= 2:
                layers.append(nn.MaxPool2d(2))
                height, width = height // 2, width // 2
            if cfg.dropout:
                layers.append(nn.Dropout(cfg.dropout))
            cin = cout
        self.net = nn.Sequential(*layers, nn.Flatten())
        self.out_features = cin * height * width

    def spectrogram(self, x: Tensor) -> Tensor:
        """(B, W, C) -> (B, C, F, T) log(1 + magnitude)."""
        b, w, c = x.shape
        flat = x.transpose(1, 2).reshape(b * c, w)
        spec = torch.stft(flat, self.n_fft, hop_length=self.hop, win_length=self.n_fft,
                          window=self.stft_window, center=False, return_complex=True)
        mag = torch.log1p(spec.abs())
        return mag.reshape(b, c, mag.shape[-2], mag.shape[-1])

    def forward(self, x: Tensor) -> Tensor:
        return self.net(self.spectrogram(x))


class FnnTrunk(nn.Module):
    """(B, W, C) -> (B, hidden[-1]): dense layers on the flattened window."""

    def __init__(self, cfg: FnnConfig, window: int, n_channels: int):
        super().__init__()
        dense, self.out_features = _dense(window * n_channels, cfg.hidden, cfg.dropout)
        self.net = nn.Sequential(nn.Flatten(), dense)

    def forward(self, x: Tensor) -> Tensor:
        return self.net(x)


class SummaryFeatures(nn.Module):
    """(B, W, C) -> (B, len(features) * C) summary features, feature-major, standardised
    with ``feature_mean`` / ``feature_std`` (buffers set from the training windows)."""

    def __init__(self, features: Sequence[str], window: int, n_channels: int):
        super().__init__()
        unknown = set(features) - set(FEATURE_NAMES)
        if unknown:
            raise ValueError(f"`features` has unknown names {sorted(unknown)}; "
                             f"choose from {FEATURE_NAMES}")
        self.features = tuple(features)
        idx = torch.arange(window, dtype=torch.float32) - (window - 1) / 2
        denom = float((idx**2).sum()) or 1.0
        self.register_buffer("slope_weights", idx / denom, persistent=False)
        n = len(self.features) * n_channels
        self.register_buffer("feature_mean", torch.zeros(n))
        self.register_buffer("feature_std", torch.ones(n))
        self.out_features = n

    def raw(self, x: Tensor) -> Tensor:
        parts = []
        for name in self.features:
            if name == "mean":
                parts.append(x.mean(dim=1))
            elif name == "std":
                parts.append(x.std(dim=1, correction=0))
            elif name == "min":
                parts.append(x.amin(dim=1))
            elif name == "max":
                parts.append(x.amax(dim=1))
            elif name == "last":
                parts.append(x[:, -1])
            elif name == "slope":
                parts.append(torch.einsum("bwc,w->bc", x, self.slope_weights))
            elif name == "range":
                parts.append(x.amax(dim=1) - x.amin(dim=1))
            elif name == "diff_std":
                parts.append(torch.diff(x, dim=1).std(dim=1, correction=0) if x.shape[1] > 1
                             else torch.zeros_like(x[:, 0]))
            else:  # skew, kurtosis: standardised moments, 0 without spread
                parts.append(_moment(x, 3 if name == "skew" else 4))
        return torch.cat(parts, dim=1)

    def forward(self, x: Tensor) -> Tensor:
        return (self.raw(x) - self.feature_mean) / self.feature_std


def _moment(x: Tensor, order: int) -> Tensor:
    """(B, W, C) -> (B, C) skewness (order 3) or excess kurtosis (order 4) over the window;
    0 where a channel is constant over the window (tested on its range: the float32 mean
    of equal values can differ from them by a rounding step, and that step's moments are
    noise)."""
    centred = x - x.mean(dim=1, keepdim=True)
    var = (centred**2).mean(dim=1)
    ok = (x.amax(dim=1) > x.amin(dim=1)) & (var > 0)
    m = (centred**order).mean(dim=1) / torch.where(ok, var, torch.ones_like(var)) ** (order / 2)
    if order == 4:
        m = m - 3.0
    return torch.where(ok, m, torch.zeros_like(m))


class MlpTrunk(nn.Module):
    """(B, W, C) -> (B, hidden[-1]): dense layers on standardised summary features."""

    def __init__(self, cfg: MlpConfig, window: int, n_channels: int):
        super().__init__()
        self.summary = SummaryFeatures(cfg.features, window, n_channels)
        self.dense, self.out_features = _dense(self.summary.out_features, cfg.hidden,
                                               cfg.dropout)

    def forward(self, x: Tensor) -> Tensor:
        return self.dense(self.summary(x))


#: family name -> trunk class, built as ``cls(config, window, n_channels)`` (and the
#: image-sequence input's :class:`~.config.FramesConfig` for ``cnn2d_frames``).
REGISTRY: dict[str, Callable[..., nn.Module]] = {
    "lstm": LstmTrunk,
    "cnn1d": Cnn1dTrunk,
    "cnn2d_spectrogram": Cnn2dSpectrogramTrunk,
    "fnn": FnnTrunk,
    "mlp": MlpTrunk,
    "cnn2d_layout": LayoutCnnTrunk,
    "cnn2d_frames": FrameSequenceTrunk,
}


class MultiTaskNet(nn.Module):
    """A trunk and one head per target; ``forward`` returns ``{head name: output}``."""

    def __init__(self, trunk: nn.Module, heads: Sequence[HeadSpec], head_hidden: Sequence[int],
                 dropout: float = 0.0):
        super().__init__()
        if not heads:
            raise ValueError("`heads` is empty: a network needs at least one output")
        self.trunk = trunk
        self.head_specs = tuple(heads)
        blocks = []
        for head in heads:
            dense, width = _dense(trunk.out_features, head_hidden, dropout)
            blocks.append(nn.Sequential(dense, nn.Linear(width, head.n_outputs)))
        self.heads = nn.ModuleList(blocks)

    def forward(self, x: Tensor) -> dict[str, Tensor]:
        features = self.trunk(x)
        out = {}
        for spec, block in zip(self.head_specs, self.heads, strict=True):
            y = block(features)
            out[spec.name] = y if spec.kind == "classification" else y.squeeze(-1)
        return out


def build_model(cfg: ModelConfig, *, window: int, n_channels: int,
                heads: Sequence[HeadSpec], frames: FramesConfig | None = None
                ) -> MultiTaskNet:
    """The network of ``cfg.family`` for windows of (window, n_channels) and these heads;
    ``frames``: the image-sequence input (``data.frames``) that ``cnn2d_frames`` needs."""
    if cfg.family not in REGISTRY:
        raise ValueError(f"`family` (={cfg.family!r}) must be one of {tuple(REGISTRY)}")
    if cfg.family == "cnn2d_frames":
        trunk: nn.Module = FrameSequenceTrunk(cfg, window, n_channels, frames)  # type: ignore[arg-type]
    else:
        trunk = REGISTRY[cfg.family](cfg, window, n_channels)
    return MultiTaskNet(trunk, heads, cfg.head_hidden, cfg.dropout)


def count_parameters(model: nn.Module) -> int:
    """Trained numbers of the model: its parameters, or for a classic family
    (:class:`.classic.ClassicNet`) the numbers its estimator stores (``n_parameters``)."""
    stored = getattr(model, "n_parameters", None)
    if stored is not None:
        return int(stored)
    return int(sum(p.numel() for p in model.parameters()))


def state_size_bytes(model: nn.Module) -> int:
    """Bytes of the tensors in the state dict (parameters and persistent buffers), or of a
    classic family's stored ONNX model (``size_bytes``)."""
    stored = getattr(model, "size_bytes", None)
    if stored is not None:
        return int(stored)
    return int(sum(t.numel() * t.element_size() for t in model.state_dict().values()))


@dataclass
class LossParts:
    """The total loss and each head's (unweighted) part."""

    total: Tensor
    parts: dict[str, Tensor]


def multitask_loss(outputs: Mapping[str, Tensor], targets: Mapping[str, Tensor],
                   heads: Sequence[HeadSpec],
                   class_weights: Mapping[str, Tensor] | None = None) -> LossParts:
    """Paper 001, eq. 3: ``sum_h weight_h * loss_h``, cross-entropy (with the head's class
    weights, if any) for classification heads and mean squared error for regression.

    outputs: head -> (B, k) logits or (B,) values; targets: head -> (B,) int64 class index
    or float32 value.
    """
    parts: dict[str, Tensor] = {}
    total: Tensor | None = None
    for head in heads:
        out, y = outputs[head.name], targets[head.name]
        if head.kind == "classification":
            w = None if class_weights is None else class_weights.get(head.name)
            part = F.cross_entropy(out, y, weight=w)
        else:
            part = F.mse_loss(out, y)
        parts[head.name] = part
        total = head.weight * part if total is None else total + head.weight * part
    if total is None:
        raise ValueError("`heads` is empty")
    return LossParts(total, parts)


__all__ = ["REGISTRY", "Cnn1dTrunk", "Cnn2dSpectrogramTrunk", "FnnTrunk", "LossParts",
           "LstmTrunk", "MlpTrunk", "MultiTaskNet", "SummaryFeatures", "build_model",
           "count_parameters", "multitask_loss", "state_size_bytes"]
