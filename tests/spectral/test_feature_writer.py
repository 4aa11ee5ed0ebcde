"""The one feature-stream writer (issue 30 item 5): both chains' feature streams are
written by `spectral.stream_features.write_feature_stream`; `window_plan` checks a window
and hop against a stream before any work."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tactile_cli.errors import InputError
from tactile_cli.spectral.stream_features import (
    FEATURE_STREAM,
    FeatureSensor,
    FeatureTrial,
    window_plan,
    write_feature_stream,
)
from tactile_cli.store import StoreWriter
from tactile_cli.store.trials import TactileFile


def _source(path: Path) -> Path:
    with StoreWriter(path, command="test") as w:
        s = w.add_sensor("acc", kind="accelerometer", sample_rate_hz=100,
                         channel_names=["x", "y"], channel_units="g")
        for name in ("a", "b"):
            t = w.trial(name, labels={"object": name}, split="train")
            t.write_signal("acc", sensor=s, data=np.zeros((50, 2)), t_s=np.arange(50) / 100)
        w.commit()
    return path


def test_the_writer_copies_trials_and_writes_one_sensor_per_name(tmp_path: Path):
    src = _source(tmp_path / "src.h5")
    sensor = FeatureSensor("acc_spectral", ("gamma_full", "g2_full"), "accelerometer", 4.0,
                           {"window_s": 0.5, "description": "test"})

    def trials(tf):
        for k, trial in enumerate(tf.trials()):
            values = np.array([[0.5, np.nan], [0.25, 1.0]]) + k
            yield FeatureTrial(trial, sensor, values, np.array([0.5, 0.75]),
                               {"slip": (np.array([0, 1]), ("rest", "slip"))})

    done = write_feature_stream(src, tmp_path / "f.h5", trials, config={"k": 1})
    assert (done.n_trials, done.n_windows) == (2, 4)
    with TactileFile(done.out) as tf:
        b = tf.trial("b")
        sig = b.signal(FEATURE_STREAM)
        assert list(sig.channel_names) == ["gamma_full", "g2_full"]
        np.testing.assert_array_equal(sig.data, np.array([[1.5, 0.0], [1.25, 2.0]],
                                                          dtype=np.float32))
        assert b.labels["object"] == "b" and b.split == "train"
        assert sig.sample_labels["slip"].classes == ("rest", "slip")


def test_the_writer_refuses_other_channels_for_one_sensor_and_writes_nothing(tmp_path: Path):
    src = _source(tmp_path / "src.h5")

    def trials(tf):
        for k, trial in enumerate(tf.trials()):
            channels = ("gamma_full",) if k == 0 else ("gamma_low",)
            yield FeatureTrial(trial, FeatureSensor("s", channels, "accelerometer", 1.0),
                               np.zeros((1, 1)), np.array([0.1]))

    with pytest.raises(InputError, match="trial 'b' gives other feature channels"):
        write_feature_stream(src, tmp_path / "f.h5", trials)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["src.h5"]


@pytest.mark.parametrize(("window_s", "hop_s", "match"), [
    (1.0, 1e-6, "`hop_s` \\(=1e-06\\) is shorter than one sample"),
    (float("nan"), 0.1, "`window_s` \\(=nan\\) must be a positive"),
    (1.0, float("inf"), "`hop_s` \\(=inf\\) must be a positive"),
    (1.0, -0.1, "`hop_s` \\(=-0.1\\) must be a positive"),
])
def test_window_plan_refuses_absurd_windows(window_s, hop_s, match):
    with pytest.raises(InputError, match=match):
        window_plan(window_s, hop_s, 100.0, 1000, 2, what="'acc'")


def test_window_plan_gives_samples_and_bounds_memory(monkeypatch):
    from tactile_cli import config_file

    assert window_plan(1.0, 0.25, 100.0, 1000, 2, what="'acc'") == (100, 25)
    monkeypatch.setattr(config_file, "machine_memory_bytes", lambda: 1 << 16)
    with pytest.raises(InputError, match="needs about .* for the 37 windows of 'acc'"):
        window_plan(1.0, 0.25, 100.0, 1000, 2, what="'acc'")
