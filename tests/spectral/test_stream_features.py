"""`tactile features spectral FILE --stream NAME`: Gamma and G2 of any multichannel stream
per window and band, with the stream's per-sample labels carried over (issue 15, item 4)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.signal import lfilter
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.store import validate_file
from tactile_cli.store.trials import TactileFile
from tactile_cli.store.writer import StoreWriter

runner = CliRunner()
RATE = 1000.0
NAMES = ["a_x", "a_y", "a_z", "b_x", "b_y", "b_z"]


@pytest.fixture(scope="module")
def recording(tmp_path_factory) -> Path:
    """Two 3 s trials of 6 channels: ``common``, every channel a differently filtered copy
    of one source (plus 1 % noise); ``independent``, white noise per channel. Per-sample
    label ``phase``: rest for the first second, move after."""
    path = tmp_path_factory.mktemp("streams") / "rec.h5"
    rng = np.random.default_rng(3)
    n = int(3 * RATE)
    source = rng.standard_normal(n)
    common = np.stack([lfilter([1.0, 0.3 * k], [1.0, -0.2 * k / 6], source)
                       for k in range(6)], axis=1)
    common += 0.01 * rng.standard_normal(common.shape)
    independent = rng.standard_normal((n, 6))
    phase = (np.arange(n) >= RATE).astype(np.int64)
    with StoreWriter(path, command="test") as w:
        w.add_sensor("acc", kind="accelerometer", sample_rate_hz=RATE, channel_names=NAMES,
                     channel_units="g")
        for name, data in (("common", common), ("independent", independent)):
            tw = w.trial(name, labels={"origin": "synthetic", "dataset": "test"})
            tw.write_signal("accel", sensor="acc", data=data, t_s=np.arange(n) / RATE,
                            sample_labels={"phase": (phase, ("rest", "move"))})
        w.commit()
    return path


def test_any_stream_gives_coherence_of_its_channels_and_keeps_labels(recording, tmp_path):
    out = tmp_path / "features.h5"
    res = runner.invoke(app, ["features", "spectral", str(recording), "--out", str(out),
                              "--stream", "accel", "--group", "a_*", "--group", "b_*",
                              "--band", "low=10-100", "--nperseg", "128", "--json"])
    assert res.exit_code == 0, res.output
    info = json.loads(res.stdout)
    assert info["groups"] == [["a_x", "a_y", "a_z"], ["b_x", "b_y", "b_z"]]
    assert info["channels"] == [f"{f}_{b}" for f in ("gamma", "g2", "g2_groups")
                                for b in ("low", "full")]
    assert validate_file(out).ok
    with TactileFile(out) as tf:
        common = tf.trial("common").signal("spectral_features")
        noise = tf.trial("independent").signal("spectral_features")
        cols = {c: i for i, c in enumerate(common.channel_names)}
        # 1 s windows every 0.25 s over 3 s: 9 windows, stamped at their last sample
        assert common.data.shape == (9, 6)
        np.testing.assert_allclose(common.t_s, 1.0 - 1 / RATE + 0.25 * np.arange(9))
        for col in ("g2_full", "g2_low"):
            assert common.data[:, cols[col]].min() > 0.9, col
            assert noise.data[:, cols[col]].max() < 0.3, col
        # across the arrays each is one summed channel; their relative phase turns with
        # frequency (different filters), so the band-summed coherence stays below 1
        assert common.data[:, cols["g2_groups_full"]].min() > 0.75
        assert noise.data[:, cols["g2_groups_full"]].max() < 0.3
        assert common.data[:, cols["gamma_full"]].min() > noise.data[:, cols["gamma_full"]].max()
        phase = common.sample_labels["phase"]
        assert phase.classes == ("rest", "move")
        assert list(phase.values) == [0] + [1] * 8   # the label at each window's end


def test_stream_options_are_checked(recording, tmp_path):
    out = str(tmp_path / "f.h5")
    cases = [
        (["--stream", "accel", "--group", "c_*"], "no channel matches c_*"),
        (["--stream", "accel", "--group", "a_x"], "a_x is one channel"),
        (["--stream", "accel", "--band", "low"], "give NAME=LOW-HIGH"),
        (["--stream", "nope"], "no trial has a stream 'nope'"),
        (["--group", "a_*"], "--group and --band go with --stream"),
    ]
    for args, message in cases:
        res = runner.invoke(app, ["features", "spectral", str(recording), "--out", out, *args])
        assert res.exit_code == 2, (args, res.output)
        assert message in res.stderr and "Traceback" not in res.output, (args, res.stderr)
        assert not Path(out).exists()


def test_many_files_on_a_worker_equal_one_file_runs(recording, tmp_path):
    import os
    import shutil

    from ..ingest.test_ingest_out_dir import h5_differences

    second = tmp_path / "again.h5"
    shutil.copyfile(recording, second)
    bad = tmp_path / "broken.h5"
    bad.write_text("not HDF5\n")
    args = ["--stream", "accel", "--group", "a_*", "--group", "b_*", "--nperseg", "128"]
    single = tmp_path / "single.h5"
    res = runner.invoke(app, ["features", "spectral", str(recording), "--out", str(single),
                              *args])
    assert res.exit_code == 0, res.output
    folder = tmp_path / "features"
    res = runner.invoke(app, ["features", "spectral", str(recording), str(second), str(bad),
                              "--out-dir", str(folder), *args, "--workers", "1", "--json",
                              "--no-progress"])
    assert res.exit_code == 2, res.output
    got = json.loads(res.stdout)
    assert got["counts"] == {"ok": 2, "skipped": 0, "failed": 1}
    assert f"{bad}: failed: " in res.stderr and "Traceback" not in res.output
    assert sorted(p.name for p in folder.iterdir()) == ["again.h5", "rec.h5"]
    assert h5_differences(single, folder / "rec.h5", {"created_utc", "command"}) == []
    # started again: the up-to-date output is skipped, the changed input redone
    later = os.path.getmtime(folder / "again.h5") + 10
    os.utime(second, (later, later))
    res = runner.invoke(app, ["features", "spectral", str(recording), str(second),
                              "--out-dir", str(folder), *args, "--workers", "0",
                              "--no-progress"])
    assert res.exit_code == 0, res.output
    assert "1 ok, 1 skipped (up to date), 0 failed" in res.stdout


def test_out_or_out_dir(recording, tmp_path):
    res = runner.invoke(app, ["features", "spectral", str(recording)])
    assert res.exit_code == 2 and "give --out (one input) or --out-dir" in res.stderr
    res = runner.invoke(app, ["features", "spectral", str(recording), "--out-dir",
                              str(tmp_path / "f")])
    assert res.exit_code == 2 and "--out-dir goes with --stream (the taxel-slip layout" in res.stderr
    res = runner.invoke(app, ["features", "spectral", str(recording), str(recording),
                              "--out", str(tmp_path / "o.h5"), "--stream", "accel"])
    assert res.exit_code == 2 and "--out takes one input" in res.stderr
