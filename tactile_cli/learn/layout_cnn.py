"""The ``cnn2d_layout`` family: 2-D convolutions over channels laid out at their places on
the sensor (issue 34, item 4; the electrode-image CNN of arXiv 1809.05551).

A window ``(B, W, C)`` becomes an image ``(B, W * k, rows, cols)``: each of the k sensors
of the layout (C = k x the layout's electrodes, consecutive blocks) and each sample of the
window is one image channel, each pixel the value of the electrode there (or of the nearest
one; :mod:`.layouts`). Then 'same' convolutions with ReLU, a 2 x 2 max-pool after each
while the image is at least 2 x 2, and a flatten into the heads, as the spectrogram CNN.
"""

from __future__ import annotations

import torch
from torch import Tensor, nn

from ..errors import InputError
from .config import Cnn2dLayoutConfig
from .layouts import gather_index, layout_grid


class LayoutCnnTrunk(nn.Module):
    """(B, W, C) -> (B, channels[-1] * rows' * cols'): the layout image, then convolutions."""

    def __init__(self, cfg: Cnn2dLayoutConfig, window: int, n_channels: int):
        super().__init__()
        grid = layout_grid(cfg.layout, cell_mm=cfg.cell_mm, fill=cfg.fill)
        try:
            index, k = gather_index(grid, n_channels)
        except ValueError as exc:
            raise InputError(f"model.layout: {exc}") from None
        self.window, self.n_channels = window, n_channels
        self.image_channels = window * k
        self.rows, self.cols = grid.shape
        # the zero cells read one extra channel that is always 0
        flat = torch.as_tensor(index.reshape(-1), dtype=torch.int64)
        self.register_buffer("pixel_channel", torch.where(flat < 0, n_channels, flat),
                             persistent=False)
        layers: list[nn.Module] = []
        height, width, cin = self.rows, self.cols, self.image_channels
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

    def image(self, x: Tensor) -> Tensor:
        """(B, W, C) -> (B, W * k, rows, cols): the window's samples at their places."""
        b = x.shape[0]
        padded = torch.cat([x, x.new_zeros(b, self.window, 1)], dim=2)
        pixels = torch.index_select(padded, 2, self.pixel_channel)
        return pixels.reshape(b, self.image_channels, self.rows, self.cols)

    def forward(self, x: Tensor) -> Tensor:
        return self.net(self.image(x))


__all__ = ["LayoutCnnTrunk"]
