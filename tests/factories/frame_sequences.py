"""Small synthetic image-sequence files for the frame-sequence models (issue 35): one trial
per lift, ``n_frames`` RGB frames of 24 x 32 px from a camera sensor ``gel``, the stored
reference a flat grey gel, and the trial labels ``slipped`` (0/1) and ``object``.

The outcome is decidable from the frames: a held lift shows a contact blob that brightens
and stays where it is; a slipped one shows a blob that darkens and moves across the gel,
so both one frame's sign and the motion between frames tell the class.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tactile_cli.store import StoreWriter

HEIGHT, WIDTH = 24, 32


def lift_frames(slipped: bool, n_frames: int, rng: np.random.Generator) -> np.ndarray:
    """(n_frames, 24, 32, 3) uint8 frames of one lift."""
    yy, xx = np.mgrid[0:HEIGHT, 0:WIDTH]
    cy, cx = rng.uniform(8, 16), rng.uniform(8, 14)
    sign = -1.0 if slipped else 1.0
    frames = []
    for k in range(n_frames):
        x0 = cx + (1.5 * k if slipped else 0.0)
        blob = np.exp(-((yy - cy) ** 2 + (xx - x0) ** 2) / 18.0)
        level = 120.0 + sign * 60.0 * blob * min(1.0, (k + 1) / 3)
        image = level[:, :, None] * np.array([1.0, 0.9, 1.1]) + rng.normal(0, 2, (HEIGHT,
                                                                               WIDTH, 3))
        frames.append(np.clip(image, 0, 255).astype(np.uint8))
    return np.stack(frames)


def write_lift_file(path: Path, *, n_lifts: int = 16, n_frames: int = 6, n_objects: int = 2,
                    seed: int = 0) -> np.ndarray:
    """Write the file; returns the (n_lifts,) int outcome (1 = slipped), alternating."""
    rng = np.random.default_rng(seed)
    slipped = np.arange(n_lifts) % 2
    reference = np.full((HEIGHT, WIDTH, 3), 120, np.uint8)
    with StoreWriter(path, command="test") as w:
        cam = w.add_sensor("gel", kind="visuotactile", sample_rate_hz=30, width_px=WIDTH,
                           height_px=HEIGHT)
        for k in range(n_lifts):
            trial = w.trial(f"lift_{k + 1:02d}", labels={
                "slipped": int(slipped[k]), "object": f"obj{k % n_objects}",
                "lift": k, "origin": "synthetic", "dataset": "frame_sequences"})
            trial.write_frames(sensor=cam, images=lift_frames(bool(slipped[k]), n_frames, rng),
                               t_s=np.arange(n_frames) / 30.0, reference=reference)
        w.commit()
    return slipped
