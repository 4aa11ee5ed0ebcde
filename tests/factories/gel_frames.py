"""Small synthetic gel-sensor data for the visuotactile tests (helper HEIGHT's factory).

Independent of the scene simulator (``visuotactile/render.py``) on purpose: a few lines of
shading that map a height field to RGB through its surface normals, so the normal model,
the Poisson solver and the slip signal can be tested against exactly known heights.

Conventions (as the scene's): x = column index (pixels, right), y = row index (pixels,
down); heights in mm (indentation, >= 0); normal = (-dh/dx, -dh/dy, 1) / norm with the
gradients in mm per mm (pixel gradients times ``px_per_mm``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tactile_cli.store import StoreWriter

PX_PER_MM = 20.0
#: three coloured lights (unit directions), one per colour channel, as in a DIGIT
_LIGHTS = np.array([[0.8, 0.0, 0.6], [-0.4, 0.69, 0.6], [-0.4, -0.69, 0.6]])


def sphere_cap(shape: tuple[int, int], centre_px: tuple[float, float], radius_mm: float,
               depth_mm: float, px_per_mm: float = PX_PER_MM) -> np.ndarray:
    """(H, W) float64 mm: a sphere of ``radius_mm`` pressed ``depth_mm`` into the gel at
    ``centre_px`` (x, y); 0 outside the contact circle."""
    h, w = shape
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
    r2 = ((xx - centre_px[0]) ** 2 + (yy - centre_px[1]) ** 2) / px_per_mm**2
    inside = r2 < radius_mm**2
    z = np.where(inside, np.sqrt(np.maximum(radius_mm**2 - r2, 0.0)), 0.0)
    return np.maximum(z - (radius_mm - depth_mm), 0.0)


def sphere_cap_gradients(shape: tuple[int, int], centre_px: tuple[float, float],
                         radius_mm: float, depth_mm: float, px_per_mm: float = PX_PER_MM
                         ) -> tuple[np.ndarray, np.ndarray]:
    """Analytic (dh/dx, dh/dy) in mm/mm of :func:`sphere_cap` at the pixel centres."""
    h, w = shape
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
    dx_mm = (xx - centre_px[0]) / px_per_mm
    dy_mm = (yy - centre_px[1]) / px_per_mm
    r2 = dx_mm**2 + dy_mm**2
    a2 = radius_mm**2 - (radius_mm - depth_mm) ** 2  # contact radius squared
    inside = r2 < a2
    z = np.sqrt(np.maximum(radius_mm**2 - r2, 1e-12))
    return np.where(inside, -dx_mm / z, 0.0), np.where(inside, -dy_mm / z, 0.0)


def normals_of(height_mm: np.ndarray, px_per_mm: float = PX_PER_MM) -> np.ndarray:
    """(..., H, W) mm -> (..., H, W, 3) unit normals (central differences)."""
    gy, gx = np.gradient(np.asarray(height_mm, dtype=np.float64), axis=(-2, -1))
    gx, gy = gx * px_per_mm, gy * px_per_mm
    n = np.stack([-gx, -gy, np.ones_like(gx)], axis=-1)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def shade(height_mm: np.ndarray, *, px_per_mm: float = PX_PER_MM, noise_std: float = 0.0,
          rng: np.random.Generator | None = None) -> np.ndarray:
    """(..., H, W) mm -> (..., H, W, 3) uint8: position-dependent base colour plus a
    coloured light per channel on the surface normal (and Gaussian camera noise)."""
    height_mm = np.asarray(height_mm, dtype=np.float64)
    h, w = height_mm.shape[-2:]
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
    base = np.stack([90 + 30 * xx / w, 100 + 25 * yy / h, 110 - 20 * xx / w], axis=-1)
    n = normals_of(height_mm, px_per_mm)
    flat = _LIGHTS[:, 2]
    rgb = base + 160.0 * (n @ _LIGHTS.T - flat)
    if noise_std:
        rng = rng or np.random.default_rng(0)
        rgb = rgb + rng.normal(0.0, noise_std, rgb.shape)
    return np.clip(np.rint(rgb), 0, 255).astype(np.uint8)


def random_caps(rng: np.random.Generator, n: int, shape: tuple[int, int] = (48, 64),
                px_per_mm: float = PX_PER_MM) -> list[np.ndarray]:
    """``n`` ball presses of random centre, radius (1-3 mm) and depth (0.2-0.6 mm)."""
    h, w = shape
    return [sphere_cap(shape, (rng.uniform(0.25 * w, 0.75 * w), rng.uniform(0.25 * h, 0.75 * h)),
                       rng.uniform(1.0, 3.0), rng.uniform(0.2, 0.6), px_per_mm)
            for _ in range(n)]


def make_pixel_table(path: Path, *, n_presses: int = 6, shape: tuple[int, int] = (48, 64),
                     seed: int = 0, noise_std: float = 1.0) -> Path:
    """A pixel table like the scene's calibration step writes: one trial per press, stream
    ``pixels`` (channels x, y, dR, dG, dB, R, G, B; one sample per pixel) with numeric
    per-sample labels nx, ny, nz (the true unit normal); its sensor records the unit
    (``digit``, the sensor of :func:`make_frames_file`), frame size and ``px_per_mm`` as
    ``tactile normal-labels`` does."""
    rng = np.random.default_rng(seed)
    h, w = shape
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    reference = shade(np.zeros(shape), noise_std=noise_std, rng=rng)
    with StoreWriter(path, command="tests.factories.gel_frames") as wr:
        s = wr.add_sensor("pixels", kind="visuotactile", sample_rate_hz=1000.0,
                          width_px=w, height_px=h, px_per_mm=PX_PER_MM, sensor_unit="digit",
                          sensor_unit_from="sensor name",
                          channel_names=["x", "y", "dR", "dG", "dB", "R", "G", "B"],
                          channel_units=["px", "px", "", "", "", "", "", ""])
        for i, cap in enumerate(random_caps(rng, n_presses, shape)):
            frame = shade(cap, noise_std=noise_std, rng=rng)
            diff = frame.astype(np.float32) - reference.astype(np.float32)
            data = np.concatenate([xx.reshape(-1, 1), yy.reshape(-1, 1), diff.reshape(-1, 3),
                                   frame.reshape(-1, 3).astype(np.float32)], axis=1)
            nrm = normals_of(cap).reshape(-1, 3)
            trial = wr.trial(f"ball_{i:02d}", labels={"object": "ball"})
            trial.write_signal("pixels", sensor=s, data=data,
                               t_s=np.arange(h * w, dtype=np.float64) * 1e-3,
                               sample_labels={k: (nrm[:, j].astype(np.float32), None)
                                              for j, k in enumerate(("nx", "ny", "nz"))})
        wr.commit()
    return path


TRAIN_YAML = """\
version: 1
seed: 0
data:
  stream: pixels
  channels: [x, y, dR, dG, dB]
  window: 1
  stride: 1
  pad: none
  transform: none
  normalise: true
  targets:
    - {name: nx, kind: regression}
    - {name: ny, kind: regression}
    - {name: nz, kind: regression}
  split: {mode: random, val_fraction: 0.2}
model:
  family: mlp
  hidden: [32, 32, 32]
  features: [last]
  head_hidden: []
  dropout: 0.0
optim:
  optimizer: adam
  lr: 0.003
  batch_size: 512
  epochs: 3
  patience: 3
  threads: 1
"""


def moving_cap_heights(rng: np.random.Generator, *, n_frames: int, shape: tuple[int, int],
                       slip: bool, onset_frame: int, speed_px: float, radius_mm: float,
                       depth_mm: float, px_per_mm: float = PX_PER_MM) -> np.ndarray:
    """(n_frames, H, W) heights: a ball held still, then (when ``slip``) sliding along +x
    by ``speed_px`` pixels per frame from ``onset_frame`` on."""
    h, w = shape
    x0, y0 = rng.uniform(0.35 * w, 0.45 * w), rng.uniform(0.4 * h, 0.6 * h)
    out = np.empty((n_frames, h, w))
    for k in range(n_frames):
        dx = speed_px * max(0, k - onset_frame + 1) if slip else 0.0
        out[k] = sphere_cap(shape, (x0 + dx, y0), radius_mm, depth_mm, px_per_mm)
    return out


def make_frames_file(path: Path, *, n_trials: int = 4, n_frames: int = 45,
                     shape: tuple[int, int] = (48, 64), seed: int = 0, noise_std: float = 1.0,
                     onset_frame: int = 36, speed_px: float = 1.5, rate_hz: float = 30.0,
                     radius_mm: float = 2.0, depth_mm: float = 0.4,
                     px_per_mm: float | None = PX_PER_MM) -> dict[str, np.ndarray]:
    """An ingested-looking visuotactile file: trials ``t_00``... alternating slip /
    no_slip (labels ``slip``, ``slip_onset_s``, ``object``), frames rendered by
    :func:`shade` at ``rate_hz``; sensor ``digit`` with ``px_per_mm`` (None: left out).
    Returns trial -> (n_frames, H, W) true heights (mm)."""
    rng = np.random.default_rng(seed)
    h, w = shape
    truth = {}
    with StoreWriter(path, command="tests.factories.gel_frames") as wr:
        extra = {} if px_per_mm is None else {"px_per_mm": float(px_per_mm)}
        s = wr.add_sensor("digit", kind="visuotactile", sample_rate_hz=rate_hz, width_px=w,
                          height_px=h, **extra)
        reference = shade(np.zeros(shape), noise_std=noise_std, rng=rng)
        t_s = np.arange(n_frames) / rate_hz
        for i in range(n_trials):
            slip = i % 2 == 0
            heights = moving_cap_heights(rng, n_frames=n_frames, shape=shape, slip=slip,
                                         onset_frame=onset_frame, speed_px=speed_px,
                                         radius_mm=radius_mm, depth_mm=depth_mm)
            name = f"t_{i:02d}"
            truth[name] = heights.astype(np.float32)
            labels = {"object": "ball", "slip": "slip" if slip else "no_slip"}
            if slip:
                labels["slip_onset_s"] = float(t_s[onset_frame])
            trial = wr.trial(name, labels=labels)
            images = shade(heights, noise_std=noise_std, rng=rng)
            trial.write_frames(sensor=s, images=images, t_s=t_s, reference=reference)
        wr.commit()
    return truth


_RUNS: dict[tuple[str, str, tuple[int, ...]], Path] = {}


def normal_run(folder: Path, *, channels: str = "x, y, dR, dG, dB",
               hidden: tuple[int, ...] = (32, 32, 32)) -> Path:
    """A small normal network (5-32-32-32-3 or the ``hidden`` widths, 3 epochs on
    :func:`make_pixel_table`) trained once per process and folder by
    ``tactile_cli.learn.train.train``; returns the run folder."""
    key = (str(folder), channels, hidden)
    if key not in _RUNS:
        from tactile_cli.learn import parse_config
        from tactile_cli.learn.train import train

        folder.mkdir(parents=True, exist_ok=True)
        table = folder / "pixels.h5"
        if not table.exists():
            make_pixel_table(table)
        tag = "diff" if "dR" in channels else "abs"
        import yaml

        text = TRAIN_YAML.replace("x, y, dR, dG, dB", channels).replace(
            "hidden: [32, 32, 32]", f"hidden: {list(hidden)}")
        config = parse_config(yaml.safe_load(text))
        out = folder / f"run_{tag}" if hidden == (32, 32, 32) else folder / (
            f"run_{tag}_" + "x".join(map(str, hidden)))
        train(config, [table], out)
        _RUNS[key] = out
    return _RUNS[key]
