"""The real Xela press-and-lift trials (../shared/data/xela_press, issue 34 item 5): the
shipped mapping ingests them, and the step detector finds one press (a rise) in every
trial's z channels without raising (before this issue: ``IndexError: index 879 is out of
bounds for axis 0 with size 868``). The per-trial figures are benchmarks/xela_press_steps.py.
"""

from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.fos.stream import read_stream_curves
from tactile_cli.store.trials import TactileFile

from ..conftest import REPO, shared_path


@pytest.mark.slow
def test_every_xela_press_trial_gives_its_press_or_a_reason(tmp_path):
    source = shared_path("xela_press")
    out = tmp_path / "press.h5"
    result = CliRunner().invoke(app, ["ingest", str(source), "--mapping",
                                      str(REPO / "configs/xela_press.yaml"), "--out", str(out)])
    assert result.exit_code == 0, result.output
    with TactileFile(out) as tf:
        trials = list(tf.trial_names)
        rate = tf.trial(trials[0]).signal("sensor1").sample_rate_hz
    assert len(trials) == 20 and 36 < rate < 45
    for sensor in ("sensor1", "sensor2"):
        found = read_stream_curves(out, sensor, channels="txl*_z", reduce="mean",
                                   regions="detect", model="step", region_label="rise")
        first = {}
        for c in found.curves:
            first.setdefault(c.trial, c)
        assert set(first) | {k.split("/")[0] for k in found.not_fitted} == set(trials)
        presses = [c for c in first.values() if np.max(c.x) > 1000]  # counts above rest
        assert len(presses) >= 18, sensor
        # the command: the mean of all 48 channels, every step
        every = read_stream_curves(out, sensor, reduce="mean", regions="detect", model="step")
        assert {c.trial for c in every.curves} | {k.split("/")[0] for k in every.not_fitted} \
            == set(trials)
