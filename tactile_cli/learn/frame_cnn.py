"""The ``cnn2d_frames`` family: a 2-D CNN per frame, aggregated over time (issue 35).

A window ``(B, W, C)`` of the image-sequence input (:mod:`.frames`; C = planes x height x
width values a frame, plane-major) is restored to ``B x W`` images ``(planes, height,
width)``; each goes through the same frame encoder ('same' 2-D convolutions with ReLU, a
2 x 2 max-pool after each while the image is at least 2 x 2, then a dense layer of
``embed`` features with ReLU), and the ``W`` frame features are aggregated over time:

- ``temporal: lstm``: an LSTM over the frames, its last hidden state (the decision at the
  window's last frame, causal: the CNN-LSTM of Li et al., ICRA 2018, on GelSight lifts);
- ``temporal: conv``: 1-D 'same' convolutions over the frames with ReLU, then the mean
  over the window.

A window as long as the trial (``data.window`` = frames a trial, ``pad: zero``) decides per
trial; ``stride: 1`` with ``pad: zero`` decides at every frame from the frames before it.
"""

from __future__ import annotations

from torch import Tensor, nn

from ..errors import InputError
from .config import Cnn2dFramesConfig, FramesConfig


class FrameSequenceTrunk(nn.Module):
    """(B, W, planes * height * width) -> (B, hidden)."""

    def __init__(self, cfg: Cnn2dFramesConfig, window: int, n_channels: int,
                 frames: FramesConfig | None):
        super().__init__()
        if frames is None:
            raise InputError("model.family cnn2d_frames needs data.stream: frames")
        if n_channels != frames.n_values:
            raise InputError(f"model.family cnn2d_frames needs every pixel of data.frames "
                             f"({frames.n_values} values a frame: {len(frames.planes)} "
                             f"plane(s) x {frames.height} x {frames.width}), got {n_channels} "
                             "channels; use data.channels: [\"*\"]")
        self.planes, self.height, self.width = len(frames.planes), frames.height, frames.width
        layers: list[nn.Module] = []
        height, width, cin = self.height, self.width, self.planes
        for cout in cfg.channels:
            layers += [nn.Conv2d(cin, cout, cfg.kernel, padding="same"), nn.ReLU()]
            if height >= 2 and width >= 2:
                layers.append(nn.MaxPool2d(2))
                height, width = height // 2, width // 2
            if cfg.dropout:
                layers.append(nn.Dropout(cfg.dropout))
            cin = cout
        self.encoder = nn.Sequential(*layers, nn.Flatten(),
                                     nn.Linear(cin * height * width, cfg.embed), nn.ReLU())
        self.temporal = cfg.temporal
        if cfg.temporal == "lstm":
            self.lstm = nn.LSTM(cfg.embed, cfg.hidden, num_layers=cfg.temporal_layers,
                                batch_first=True,
                                dropout=cfg.dropout if cfg.temporal_layers > 1 else 0.0)
        else:
            convs: list[nn.Module] = []
            cin = cfg.embed
            for _ in range(cfg.temporal_layers):
                convs += [nn.Conv1d(cin, cfg.hidden, cfg.temporal_kernel, padding="same"),
                          nn.ReLU()]
                cin = cfg.hidden
            self.tconv = nn.Sequential(*convs)
        self.out_features = cfg.hidden

    def frame_features(self, x: Tensor) -> Tensor:
        """(B, W, C) -> (B, W, embed): every frame through the encoder."""
        b, w = x.shape[0], x.shape[1]
        images = x.reshape(b * w, self.planes, self.height, self.width)
        return self.encoder(images).reshape(b, w, -1)

    def forward(self, x: Tensor) -> Tensor:
        feats = self.frame_features(x)
        if self.temporal == "lstm":
            _, (h, _) = self.lstm(feats)
            return h[-1]
        return self.tconv(feats.transpose(1, 2)).mean(dim=2)


__all__ = ["FrameSequenceTrunk"]
