"""The accelerometer-fingertip chain (paper 001): scene, ingest, preparation, spectral
pieces, channel configurations and the detection delay."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.accel import CHANNEL_CONFIGS, VibroSceneConfig, simulate_vibro_slip
from tactile_cli.accel.delay import onset_delays, onset_outcomes
from tactile_cli.accel.prepare import prepare_file, segment_bounds
from tactile_cli.accel.simulate import draw_surfaces, simulate_recording
from tactile_cli.cli import app
from tactile_cli.ingest import ingest
from tactile_cli.learn.data import center_scale
from tactile_cli.spectral import (
    band_power,
    bandwidth_steps,
    limit_bandwidth,
    spectral_centroid,
    spectrogram,
    stft_lengths,
    welch_psd,
)
from tactile_cli.store import TactileFile

runner = CliRunner()
RATE = 8000.0


def _small(**kw) -> VibroSceneConfig:
    base = {"orientations_deg": [0, 45], "motor_rps": [0.16, 0.48], "duration_s": 2.0}
    return VibroSceneConfig.model_validate({**base, **kw})


def _recording(cfg: VibroSceneConfig, texture: str, rps: float, seed: int = 0):
    surfaces = draw_surfaces(cfg.textures[texture], np.random.default_rng([seed, 0]))
    return simulate_recording(cfg, texture, 0.0, rps, surfaces, np.random.default_rng(seed))


def _slip_samples(rec) -> np.ndarray:
    return rec.accel[np.abs(rec.velocity[:, 0]) >= 0.05]


@pytest.fixture(scope="module")
def scene(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("vibro") / "scene"
    simulate_vibro_slip(_small(), out, seed=0)
    return out


def test_scene_writes_the_paper_tree_and_ingests_unchanged(scene: Path, tmp_path: Path):
    csvs = sorted(p.relative_to(scene).as_posix() for p in scene.rglob("*.csv"))
    assert len(csvs) == 3 * 2 * 2 and "wood/45/0.48/data.csv" in csvs
    assert (scene / "wood/0/0.16/data.csv").read_text().splitlines()[0] == \
        "L_x,L_y,L_z,R_x,R_y,R_z,v_slip,v_slide"
    h5 = tmp_path / "scene.h5"
    ingest([scene], h5, format="accel-tree")
    with TactileFile(h5) as f:
        assert len(f.trial_names) == 12
        sig = f.trial("plastic_45_0.48").signal("accel")
        assert sig.data.shape == (16000, 6) and np.abs(sig.data).max() <= 1
        motion = sig.sample_labels["motion"]
        assert set(np.unique(motion.values)) == {0, 1, 2}  # no_motion, slide, slip all occur
    truth = json.loads((scene / "scene.json").read_text())
    assert truth["seed"] == 0 and len(truth["recordings"]) == 12


@pytest.mark.slow
def test_same_seed_same_bytes_other_seed_other_bytes(scene: Path, tmp_path: Path):
    simulate_vibro_slip(_small(), tmp_path / "again", seed=0)
    simulate_vibro_slip(_small(), tmp_path / "other", seed=1)
    rel = "aluminum/0/0.16/data.csv"
    assert (tmp_path / "again" / rel).read_bytes() == (scene / rel).read_bytes()
    assert (tmp_path / "other" / rel).read_bytes() != (scene / rel).read_bytes()


def test_roughness_shows_in_band_power():
    """Slip vibration power (200-1500 Hz) orders the textures by roughness."""
    cfg = _small(duration_s=4.0, motor_hum_g=0.0, grip_hum_g=0.0, impact_g_per_m_s=0.0)
    power = {t: band_power(_slip_samples(_recording(cfg, t, 0.32)), RATE, [(200, 1500)])
             [0, 0] for t in cfg.textures}
    assert power["wood"] > 10 * power["plastic"] > 0
    assert power["plastic"] > power["aluminum"]


def test_speed_raises_the_spectral_centroid():
    """Temporal frequency = speed / wavelength: faster slip, higher centroid."""
    cfg = _small(duration_s=4.0, motor_hum_g=0.0, grip_hum_g=0.0, impact_g_per_m_s=0.0,
                 noise_g=0.0)
    slow = spectral_centroid(_slip_samples(_recording(cfg, "wood", 0.16)), RATE, f_min_hz=20)
    fast = spectral_centroid(_slip_samples(_recording(cfg, "wood", 0.48)), RATE, f_min_hz=20)
    assert fast[0] > 1.3 * slow[0]


def test_the_1500_hz_lowpass_is_visible():
    """Sensor noise alone: its spectrum is flat below the cut-off and falls above it as a
    first-order low-pass does (-3 dB at 1.5 kHz, about 1/(1 + (f/fc)^2) in power)."""
    cfg = _small(slip_gain=0, slide_gain=0, motor_hum_g=0, grip_hum_g=0, impact_g_per_m_s=0,
                 noise_g=0.5,
                 duration_s=4.0)
    rec = _recording(cfg, "wood", 0.16)
    low, at_fc, high = band_power(rec.accel, RATE, [(100, 300), (1400, 1600), (3000, 3200)])
    assert at_fc[0] / low[0] == pytest.approx(0.5, rel=0.25)
    assert high[0] / low[0] < 0.3


def test_the_grip_rings_the_bar_mode_at_rest():
    """At rest the grip vibration is a peak at the bar's mode (shifted per set-up by at
    most a few spreads); without it the rest is sensor noise, flat below the cut-off."""
    def still_peak_hz(grip: float, texture: str) -> tuple[float, float]:
        cfg = _small(duration_s=4.0, grip_hum_g=grip, motor_hum_g=0.0, impact_g_per_m_s=0.0)
        surfaces = draw_surfaces(cfg.textures[texture], np.random.default_rng([0, 0]))
        rec = simulate_recording(cfg, texture, 0.0, 0.32, surfaces, np.random.default_rng(0),
                                 np.random.default_rng(1))
        still = rec.accel[np.abs(rec.velocity).max(axis=1) < 0.05, 0].astype(float)
        f, spec = welch_psd(still[:, None], RATE, nperseg=512)
        spec = spec[:, 0]
        band = (f > 200) & (f < 1400)
        return float(f[band][spec[band].argmax()]), float(spec[band].max() / np.median(
            spec[band]))
    for texture in ("plastic", "wood"):
        mode = VibroSceneConfig().textures[texture].mode_hz
        peak_hz, prominence = still_peak_hz(0.02, texture)
        assert abs(np.log(peak_hz / mode)) < 4 * 0.03 + 0.05
        assert prominence > 2
    assert still_peak_hz(0.0, "plastic")[1] < still_peak_hz(0.02, "plastic")[1] / 2


@pytest.mark.slow
def test_prepare_segments_and_speed(scene: Path, tmp_path: Path):
    h5 = tmp_path / "scene.h5"
    ingest([scene], h5, format="accel-tree")
    out = prepare_file(h5, tmp_path / "prep.h5", segment_s=0.5)
    assert out.n_segments == 12 * 4
    with TactileFile(out.out) as f:
        trial = f.trial("wood_0_0.48_s001")
        assert trial.labels["segment"] == "wood_0_0.48/s001"
        assert trial.labels["object"] == "wood"
        speed = trial.signal("accel").sample_labels["speed_cm_s"].values
        assert speed.shape == (4000,) and 0 <= speed.min() and speed.max() < 40
    limited = prepare_file(h5, tmp_path / "lim.h5", segment_s=1.0, cutoff_hz=125.0)
    with TactileFile(limited.out) as f:
        x = f.trial(f.trial_names[0]).signal("accel").data
        assert band_power(x, RATE, [(500, 4000)])[0].max() < 1e-6


def test_segment_bounds_join_a_short_tail():
    assert segment_bounds(9, 4) == [(0, 4), (4, 9)]
    assert segment_bounds(12, 4) == [(0, 4), (4, 8), (8, 12)]


def test_center_scale_spans_minus_one_to_one():
    x = np.random.default_rng(0).normal(3.0, 2.0, size=(5, 40, 3)).astype(np.float32)
    x[0, :, 1] = 7.0  # a constant channel becomes zeros
    y = center_scale(x)
    assert np.allclose(y.mean(axis=1)[1:], 0, atol=1e-6)
    assert np.allclose(np.abs(y[1:]).max(axis=1), 1.0)
    assert (y[0, :, 1] == 0).all()


def test_spectral_pieces():
    assert stft_lengths(400) == (80, 40, 20, 10) and stft_lengths(25) == ()
    assert spectrogram(np.zeros((2, 400, 3)), 40).shape == (2, 3 * 21, 19)
    assert bandwidth_steps(8000.0) == [4000, 2000, 1000, 500, 250, 125, 62.5, 31.25]
    t = np.arange(8000) / RATE
    tone = np.sin(2 * np.pi * 50 * t) + np.sin(2 * np.pi * 900 * t)
    y, rate = limit_bandwidth(tone, RATE, 250.0)
    assert rate == 500.0 and y.shape == (500, 1)
    assert band_power(y[50:-50], rate, [(30, 70)])[0, 0] > 0.4  # the 50 Hz tone stays


def test_channel_configurations():
    assert list(CHANNEL_CONFIGS) == ["L3R3", "L3", "LxRx", "Lx", "LyRy", "Ly", "LzRz", "Lz"]
    assert CHANNEL_CONFIGS["LyRy"] == ("L_y", "R_y")


def test_onset_delays():
    labels = np.array([0] * 10 + [2] * 20 + [1] * 10 + [2] * 5)
    ends = np.arange(0, 45, 5)
    pred = np.where(ends >= 20, 2, 0)
    pred[ends >= 30] = 1
    delays, n = onset_delays(labels, ends, pred, 2)
    assert n == 2 and delays == [11]  # onset 10, first slip call at 20; the second missed
    # run lengths: 20 samples (detected after 11) and 5 samples (the trial's end; missed)
    assert onset_outcomes(labels, ends, pred, 2) == [(20, 11), (5, None)]


def test_cli_simulate_help_json_and_errors(tmp_path: Path):
    res = runner.invoke(app, ["simulate", "vibro-slip", "--help"])
    assert res.exit_code == 0 and "--duration" in res.output and "--seed" in res.output
    cfg = tmp_path / "tiny.yaml"
    cfg.write_text("orientations_deg: [0]\nmotor_rps: [0.32]\n")
    res = runner.invoke(app, ["simulate", "vibro-slip", "--out", str(tmp_path / "s"), "-c",
                              str(cfg), "--duration", "0.5", "--seed", "4", "--json"])
    assert res.exit_code == 0, res.output
    assert json.loads(res.output)["n_recordings"] == 3
    res = runner.invoke(app, ["simulate", "vibro-slip", "--out", str(tmp_path / "s"), "-c",
                              str(cfg)])
    assert res.exit_code == 2 and "overwrite" in res.output
    cfg.write_text("motor_rpm: [1]\n")
    res = runner.invoke(app, ["simulate", "vibro-slip", "--out", str(tmp_path / "t"), "-c",
                              str(cfg)])
    assert res.exit_code == 2 and "motor_rpm" in res.output and "line 1" in res.output
    for cmd in (["accel-prepare", "--help"], ["detect-delay", "--help"]):
        assert runner.invoke(app, cmd).exit_code == 0


@pytest.mark.slow
def test_detect_delay_end_to_end(scene: Path, tmp_path: Path):
    """A tiny FNN trained for two epochs: the command runs, reports the keys, and the
    numbers hang together (the delay is the paper's definition, not a quality bar)."""
    h5 = tmp_path / "scene.h5"
    ingest([scene], h5, format="accel-tree")
    prepare_file(h5, tmp_path / "prep.h5", segment_s=0.5)
    config = Path(__file__).resolve().parents[2] / "configs" / "train_fnn_vibro.yaml"
    text = config.read_text().replace("hidden: [512, 256]", "hidden: [16]") \
        .replace("epochs: 20", "epochs: 2")
    tiny = tmp_path / "tiny.yaml"
    tiny.write_text(text)
    res = runner.invoke(app, ["train", str(tiny), "--data", str(tmp_path / "prep.h5"), "--out",
                              str(tmp_path / "run"), "--no-progress"])
    assert res.exit_code == 0, res.output
    res = runner.invoke(app, ["detect-delay", str(tmp_path / "run"), "--data",
                              str(tmp_path / "prep.h5"), "--split", "all", "--json"])
    assert res.exit_code == 0, res.output
    out = json.loads(res.output)
    assert {"delay_samples_ms", "inference_ms", "total_ms", "motion_accuracy"} <= set(out)
    assert out["n_onsets"] > 0 and 0 <= out["motion_accuracy"] <= 1
    assert 0 <= out["missed_long"] <= out["missed"] <= out["n_onsets"]
    assert out["n_onsets_long"] <= out["n_onsets"]
    if out["n_detected"]:
        assert out["total_ms"] == pytest.approx(out["delay_samples_ms"] + out["inference_ms"],
                                                abs=1e-3)
    res = runner.invoke(app, ["detect-delay", str(tmp_path / "run"), "--data",
                              str(tmp_path / "prep.h5"), "--stride", "0"])
    assert res.exit_code == 2


def test_the_shipped_scene_config_repeats_the_defaults():
    from tactile_cli.accel import load_vibro_config

    path = Path(__file__).resolve().parents[2] / "configs" / "scene_vibro_slip.yaml"
    assert load_vibro_config(path) == VibroSceneConfig()


def test_an_absurd_duration_override_is_one_input_error():
    """Found by the damaged-input corpus: `simulate vibro-slip --duration 1e9` ended in a
    pydantic traceback."""
    from tactile_cli.errors import InputError

    with pytest.raises(InputError, match="duration_s"):
        _small().with_duration(1e9)
    assert _small().with_duration(1.5).duration_s == 1.5
