"""Slider and grasped-object motion of the slip-slide rig (paper 001, sec. 3.1, Fig. 2).

A crank turns at ``motor_rps`` and moves the slider along the object,
``x_slider = -R cos(theta)``. The object carries two stops ``play_m`` either side of the
slider's rest position: the slider slides over the object (sliding) until it reaches a
stop, then pushes the object along against the gripper's friction (slippage) until the
crank's dead point; there the motor pauses for a random dwell (no motion), reverses, slides
back across the free travel and pushes the object the other way. That is a backlash:
``x_object = clip(x_object, x_slider - play, x_slider + play)``, stepped at
``kinematics_rate_hz``. On slippery objects (``drag_rate_hz`` > 0) sliding now and then
drags the object along for a moment (a short slip inside a slide, sec. 4).

The linear encoders (0.12 mm) are modelled by quantising both positions; velocities are
their central differences over ``velocity_window_s``, as the paper derived them (sec. 3.1).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .config import TextureConfig, VibroSceneConfig


@dataclass(frozen=True)
class Motion:
    """Motion of one recording at the kinematics rate (all arrays (m,), float64).

    t_s: seconds; slider_m, object_m: true positions (m); v_slider_m_s, v_object_m_s: true
    velocities (m/s); enc_v_slider_m_s, enc_v_object_m_s: velocities from the quantised
    encoder counts (what the CSV records); impacts: (k, 2) rows of (time s, closing speed
    m/s) when the slider reaches a stop while moving.
    """

    t_s: np.ndarray
    slider_m: np.ndarray
    object_m: np.ndarray
    v_slider_m_s: np.ndarray
    v_object_m_s: np.ndarray
    enc_v_slider_m_s: np.ndarray
    enc_v_object_m_s: np.ndarray
    impacts: np.ndarray


def crank_angle(n: int, rate_hz: float, motor_rps: float, dwell_s: tuple[float, float],
                rng: np.random.Generator) -> np.ndarray:
    """(n,) crank angle (rad) at ``rate_hz``: half turns at ``motor_rps`` separated by
    pauses at the dead points (0, pi, 2 pi, ...) drawn uniformly from ``dwell_s``."""
    theta = np.empty(n)
    half_turn = int(round(rate_hz / (2 * motor_rps)))
    i, k = 0, 0
    start = rng.uniform(0, np.pi)  # the recording starts somewhere in a half turn
    first = int(round((np.pi - start) / np.pi * half_turn))
    seg = np.minimum(np.arange(first), n)
    theta[: min(first, n)] = start + np.pi * seg[: min(first, n)] / half_turn
    i, k = min(first, n), 1
    while i < n:
        hold = int(round(rng.uniform(*dwell_s) * rate_hz))
        theta[i: i + hold] = k * np.pi
        i += hold
        if i >= n:
            break
        m = min(half_turn, n - i)
        theta[i: i + m] = k * np.pi + np.pi * np.arange(m) / half_turn
        i += m
        k += 1
    return theta


def simulate_motion(cfg: VibroSceneConfig, texture: TextureConfig, motor_rps: float,
                    rng: np.random.Generator) -> Motion:
    """The slider and object motion of one recording of ``cfg.duration_s`` seconds."""
    rate = cfg.kinematics_rate_hz
    n = int(round(cfg.duration_s * rate)) + 1
    dt = 1.0 / rate
    theta = crank_angle(n, rate, motor_rps, cfg.dwell_s, rng)
    slider = -cfg.crank_radius_m * np.cos(theta)
    v_slider = np.gradient(slider, dt)
    play = cfg.play_m
    obj = np.empty(n)
    x = slider[0]
    drag_left = 0
    drag_p = texture.drag_rate_hz * dt
    impacts: list[tuple[float, float]] = []
    touching = True
    draws = rng.random(n)
    lengths = rng.uniform(*cfg.drag_s, size=n)
    for i in range(n):
        s = slider[i]
        if drag_left > 0 and i > 0:
            x += cfg.drag_fraction * (s - slider[i - 1])
            drag_left -= 1
        elif abs(s - x) < play and abs(v_slider[i]) > 0.05 and draws[i] < drag_p:
            drag_left = int(lengths[i] * rate)
        lo, hi = s - play, s + play
        at_stop = x <= lo or x >= hi
        if at_stop and not touching:
            impacts.append((i * dt, abs(v_slider[i])))
        touching = at_stop
        x = min(max(x, lo), hi)
        obj[i] = x
    v_obj = np.gradient(obj, dt)
    res = cfg.encoder_resolution_m
    half = max(1, int(round(cfg.velocity_window_s * rate / 2)))
    t_s = np.arange(n) * dt
    return Motion(t_s, slider, obj, v_slider, v_obj,
                  _encoder_velocity(slider, res, half, dt), _encoder_velocity(obj, res, half, dt),
                  np.asarray(impacts, dtype=np.float64).reshape(-1, 2))


def _encoder_velocity(x_m: np.ndarray, resolution_m: float, half: int, dt: float) -> np.ndarray:
    """(n,) velocity (m/s) from positions quantised to ``resolution_m``: central difference
    over ``2 half`` steps (one-sided at the ends)."""
    q = np.round(x_m / resolution_m) * resolution_m
    padded = np.concatenate([np.full(half, q[0]), q, np.full(half, q[-1])])
    return (padded[2 * half:] - padded[: -2 * half]) / (2 * half * dt)
