"""The spatial chain's event trials (tactile_cli/spatial/trial_events.py): which trials have
events, and the chain's wording for a trial it cannot read."""

from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.spatial import event_trial_names, spatial_events
from tactile_cli.store import StoreWriter
from tactile_cli.store.trials import TactileFile

runner = CliRunner()


@pytest.fixture
def mixed_file(tmp_path):
    """Trials ``ev`` (one event), ``empty`` (an events group without events) and ``sig``
    (a sampled stream only)."""
    path = tmp_path / "mixed.h5"
    with StoreWriter(path, command="test") as w:
        cam = w.add_sensor("cam", kind="event_camera", sample_rate_hz=0, width_px=4,
                           height_px=3)
        acc = w.add_sensor("acc", kind="accelerometer", sample_rate_hz=100,
                           channel_names=["x"], channel_units=["g"])
        ev = w.trial("ev").events(cam)
        ev.append(np.array([1]), np.array([2]), np.array([10]), np.array([1], dtype=np.int8))
        ev.close()
        w.trial("empty").events(cam).close()
        w.trial("sig").write_signal("acc", sensor=acc, data=np.zeros((5, 1), np.float32),
                                    t_s=np.arange(5) / 100)
        w.commit()
    return path


def test_event_trials_and_the_spatial_wording(mixed_file):
    with TactileFile(mixed_file) as tf:
        assert event_trial_names(tf) == ["ev", "empty"]
        te = spatial_events(tf.trial("ev"))
        assert te.n_events == 1 and (te.sensor.width_px, te.sensor.height_px) == (4, 3)
        with pytest.raises(InputError) as err:
            spatial_events(tf.trial("sig"))
        assert str(err.value) == (f"{mixed_file}, /trials/sig: trial has no events (the "
                                  "spatial chain needs an event-camera recording)")
        with pytest.raises(InputError) as err:
            spatial_events(tf.trial("empty"))
        assert str(err.value) == f"{mixed_file}, /trials/empty/events: trial has no events"


def test_frames_command_names_a_trial_without_events(mixed_file, tmp_path):
    r = runner.invoke(app, ["frames", str(mixed_file), "--out", str(tmp_path / "o"),
                            "-t", "sig"])
    assert r.exit_code == 2
    assert "trial has no events (the spatial chain needs an event-camera recording)" in r.output
