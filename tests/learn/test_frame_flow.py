"""The gel's motion block by block (``data.frames.change: flow``, learn/frame_flow.py):
known shifts of a textured image recovered, a still frame gives no motion, frames become
dy/dx planes in px, and the refusals."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter
from scipy.ndimage import shift as shift_image

from tactile_cli.errors import InputError
from tactile_cli.learn.config import FramesConfig, parse_config
from tactile_cli.learn.data import read_trials, resolve_channels
from tactile_cli.learn.frame_flow import block_shifts
from tactile_cli.learn.frames import frame_channel_names, frame_series

from ..factories.frame_sequences import WIDTH, write_lift_file


def _texture(seed: int = 0, shape=(240, 320)) -> np.ndarray:
    """A marker-skin-like grey texture: smoothed noise, 0-255."""
    noise = gaussian_filter(np.random.default_rng(seed).random(shape), 2.0)
    return 255 * (noise - noise.min()) / np.ptp(noise)


@pytest.mark.parametrize("shift", [(2.0, -3.0), (1.5, 0.5), (-4.25, 2.75)])
def test_a_known_shift_of_a_texture_is_recovered_in_every_block(shift):
    image = _texture()
    moved = shift_image(image, shift, order=3, mode="wrap")
    got = block_shifts(image, moved, 6, 8)
    assert got.shape == (6, 8, 2)
    error = got - np.array(shift)
    # every block within 1.25 px; the frame's mean within 15 % of the shift + 0.2 px, and
    # never past it (the window's edges see content that moved in, which pulls a block's
    # estimate toward 0: about 13 % at 4 px in blocks of 40 px)
    assert np.abs(error).max() < 1.25, np.abs(error).max()
    mean = got.mean(axis=(0, 1))
    assert (np.abs(mean - shift) <= 0.15 * np.abs(shift) + 0.2).all(), mean
    assert (np.abs(mean) <= np.abs(shift) + 0.1).all(), mean


def test_a_still_frame_and_a_flat_block_give_no_motion():
    image = _texture(1)
    assert np.abs(block_shifts(image, image, 6, 8)).max() < 0.2
    flat = np.full((240, 320), 128.0)
    assert np.abs(block_shifts(flat, flat, 6, 8)).max() < 0.5


def test_opposite_motions_of_two_halves_are_told_apart():
    """A slip at one edge: the left half of the gel moves down, the right half up."""
    image = _texture(2)
    moved = image.copy()
    moved[:, :160] = shift_image(image, (3.0, 0.0), order=3, mode="wrap")[:, :160]
    moved[:, 160:] = shift_image(image, (-3.0, 0.0), order=3, mode="wrap")[:, 160:]
    got = block_shifts(image, moved, 6, 8)
    assert (got[:, :4, 0] > 2.0).all() and (got[:, 4:, 0] < -2.0).all()


class _Frames:
    """What frame_series reads of a trial's frames."""

    def __init__(self, images: np.ndarray):
        self.images, self.reference = images, images[0]
        self.shape, self.n_frames = images.shape[1:], len(images)
        self.path, self.where = "lifts.h5", "/trials/t0/frames"

    def __getitem__(self, k: int) -> np.ndarray:
        return self.images[k]


def test_frames_become_dy_dx_planes_of_motion_since_the_kept_frame_before():
    base = _texture(3, (48, 64))
    steps = [(0.0, 0.0), (2.0, 0.0), (2.0, 0.0), (2.0, -2.0)]  # cumulative shifts
    images = np.stack([np.repeat(shift_image(base, s, order=3, mode="wrap")[..., None], 3,
                                 axis=2).round().astype(np.uint8) for s in steps])
    cfg = FramesConfig(width=2, height=2, change="flow", reference="first")
    series = frame_series(_Frames(images), cfg)
    assert series.shape == (4, 8)
    assert cfg.planes == ("dy", "dx") and cfg.unit == "px"
    assert frame_channel_names(cfg)[:2] == ["dy_r0_c0", "dy_r0_c1"]
    dy, dx = series[:, :4].mean(axis=1), series[:, 4:].mean(axis=1)
    np.testing.assert_allclose(dy, [0, 2, 0, 0], atol=0.4)
    np.testing.assert_allclose(dx, [0, 0, 0, -2], atol=0.4)


def test_flow_refuses_colour_and_blocks_under_8_px(tmp_path):
    with pytest.raises(ValueError, match="`change: flow` measures the motion of the grey"):
        FramesConfig(change="flow", colour=True)
    path = tmp_path / "lifts.h5"
    write_lift_file(path, n_lifts=2)
    raw = {"seed": 0,
           "data": {"stream": "frames", "channels": ["*"], "window": 3, "stride": 3,
                    "frames": {"width": WIDTH // 4, "height": 2, "change": "flow"},
                    "targets": [{"name": "slipped", "source": "trial"}]},
           "model": {"family": "cnn2d_frames", "channels": [4], "embed": 8, "hidden": 8}}
    cfg = parse_config(raw)
    with pytest.raises(InputError, match="blocks of 4 x 12 px; a block needs at least 8 px"):
        read_trials([path], resolve_channels(cfg.data, [path]))
    raw["data"]["frames"] = {"width": 2, "height": 1, "change": "flow"}
    cfg = parse_config(raw)
    series = read_trials([path], resolve_channels(cfg.data, [path]))
    first = series[0]
    assert first.x.shape[1] == 4 and set(first.channel_units) == {"px"}
    assert first.channel_names == ("dy_r0_c0", "dy_r0_c1", "dx_r0_c0", "dx_r0_c1")
    assert np.isfinite(first.x).all()
