"""``tactile simulate vibrotouch`` and ``tactile detect-contact``: the scene's ground truth,
the triggers of paper 003 (sec. 2.4) finding it, the stream matching the offline detector,
and the commands' outputs and errors."""

from __future__ import annotations

import io
import json

import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.store.origin import data_origin
from tactile_cli.store.trials import TactileFile
from tactile_cli.vibro import DetectorConfig, detect_contacts, find_band, follow
from tactile_cli.vibro.pipeline import detect_trial

runner = CliRunner()


def test_scene_writes_both_rates_truth_and_origin(scene):
    path, summary = scene
    assert summary["n_trials"] == 3
    with TactileFile(path) as f:
        assert f.trial_names == ["contact_00", "contact_01", "touch_00"]
        t = f.trial("contact_00")
        accel, force = t.signal("accel"), t.signal("force")
        assert accel.sample_rate_hz == 2500 and force.sample_rate_hz == 1000
        assert accel.channel_units == ("g",) and force.channel_names == ("f_y", "f_z")
        labels = t.labels
        assert labels["origin"] == "simulated" and labels["dataset"] == "vibrotouch seed 7"
        contact = labels["contact_s"]
        assert 1.0 + 0.02 / 0.01 <= contact <= 1.0 + 0.03 / 0.01   # calibration + gap / speed
        assert any(a.label == "contact" and a.start_s == pytest.approx(contact)
                   for a in t.annotations)
        # the force channel: noise of mean |.| about 0.015 N before contact
        before = force.data[force.t_s < contact, 1]
        assert np.abs(before - before.mean()).mean() == pytest.approx(0.015, rel=0.15)
        touches = [a for a in f.trial("touch_00").annotations if a.label == "touch"]
        assert len(touches) == 3
        # provenance: the command, the resolved config and seed, the config file's hash
        assert f.attrs["command"] and f.attrs["tool_version"]
        assert json.loads(f.attrs["config_json"])["seed"] == 7
        assert [src.path.endswith("scene.yaml") for src in f.sources] == [True]
    origin = data_origin([path])
    assert origin["kind"] == "simulated" and origin["datasets"] == ["vibrotouch seed 7"]


@pytest.mark.slow
def test_same_seed_same_samples(scene, tmp_path):
    path, _ = scene
    cfg = tmp_path / "s.yaml"
    cfg.write_text("contact_trials: 1\ntouch_trials: 0\ngap_mm: [0.02, 0.03]\n"
                   "after_contact_s: 3.0\n")
    out = tmp_path / "again.h5"
    result = runner.invoke(app, ["simulate", "vibrotouch", "-c", str(cfg), "--out", str(out),
                                 "--seed", "7", "--no-progress"])
    assert result.exit_code == 0, result.output
    with TactileFile(path) as a, TactileFile(out) as b:
        np.testing.assert_array_equal(a.trial("contact_00").signal("accel").data,
                                      b.trial("contact_00").signal("accel").data)


def test_vibration_finds_the_contact_before_the_force_sensor(scene):
    path, _ = scene
    with TactileFile(path) as f:
        report = detect_contacts(f, DetectorConfig())
    for det in report.trials[:2]:
        s = det.summary
        assert s["vibration_false_alarms"] == 0, s
        assert 0 <= s["vibration_delay_s"] < 1.0, s          # found within a second
        assert s["force_s"] is None or s["force_s"] > s["vibration_s"], s
        assert s["vibration_snr"] > s["vibration_false_alarms"] + 2.0
    touch = report.trials[2].summary
    assert touch["force_hits"] == 3 and touch["force_false_alarms"] == 0
    assert touch["vibration_hits"] >= 2, touch
    totals = report.totals()
    assert totals["n_contacts"] == 2 and totals["vibration_detected"] == 2


def test_stream_gives_the_offline_events(scene):
    path, _ = scene
    cfg = DetectorConfig()
    with TactileFile(path) as f:
        for name in ("contact_00", "touch_00"):
            trial = f.trial(name)
            offline = detect_trial(trial, cfg).vibration.events
            x = trial.signal("accel").data[:, 0]
            text = "\n".join(repr(float(v)) for v in x) + "\n"
            seen: list[float] = []
            result = follow(io.StringIO(text), cfg, rate_hz=2500.0, name="-",
                            scenario=trial.labels["scenario"], on_event=seen.append)
            assert seen == [a for a, _ in offline]
            closed = [e for e in result.events if e[1] is not None]  # the last may be open
            assert len(result.events) == len(offline) and closed == offline[:len(closed)]
            assert result.n_updates == 1 + (len(x) - 500) // 25
            assert np.median(result.latencies_ms) < 10.0       # well inside the 10 ms refresh


def test_band_finder_names_a_band_that_separates_contact(scene):
    path, _ = scene
    with TactileFile(path) as f:
        proposal = find_band(f, DetectorConfig(), width_hz=10)
        report = detect_contacts(f, DetectorConfig(band_hz=proposal.band_hz),
                                 trials=["contact_00", "contact_01"])
    assert proposal.score > 2 and proposal.band_hz[1] - proposal.band_hz[0] == pytest.approx(10)
    assert report.totals()["vibration_detected"] == 2


@pytest.mark.slow
def test_detect_contact_command_json_plot_and_follow(scene, tmp_path):
    path, _ = scene
    png = tmp_path / "fig.png"
    result = runner.invoke(app, ["detect-contact", str(path), "--json", "--plot", str(png),
                                 "--find-band"])
    assert result.exit_code == 0, result.output
    out = json.loads(result.output)
    assert out["totals"]["n_contacts"] == 2 and out["band"]["band_hz"]
    assert png.read_bytes()[:4] == b"\x89PNG"
    text = tmp_path / "contact_00.txt"
    result = runner.invoke(app, ["detect-contact", str(path), "--trial", "contact_00",
                                 "--samples-out", str(text)])
    assert result.exit_code == 0, result.output
    result = runner.invoke(app, ["detect-contact", "-", "--follow", "--json"],
                           input=text.read_text())
    assert result.exit_code == 0, result.output
    lines = [json.loads(line) for line in result.output.splitlines()]
    offline = next(t for t in out["trials"] if t["trial"] == "contact_00")
    assert lines[0] == {"event": "contact", "start_s": offline["vibration_events_s"][0]}
    assert lines[-1]["n_updates"] > 0 and lines[-1]["latency_ms"]["max"] >= 0
    result = runner.invoke(app, ["detect-contact", str(text), "--follow"])
    assert result.exit_code == 0 and "per-update latency" in result.output


def test_errors_are_one_line_with_flags(scene, tmp_path):
    path, _ = scene
    result = runner.invoke(app, ["detect-contact", str(path), "--band", "580,570"])
    assert result.exit_code == 2 and "--band" in result.output
    bad = tmp_path / "bad.txt"
    bad.write_text("0.1\nnot-a-number\n")
    result = runner.invoke(app, ["detect-contact", str(bad), "--follow"])
    assert result.exit_code == 2
    assert "line 2: 'not-a-number' is not a number" in result.output
    result = runner.invoke(app, ["detect-contact", str(path), "--band", "1300,1310"])
    assert result.exit_code == 2 and "band" in result.output
    result = runner.invoke(app, ["simulate", "vibrotouch", "--out", str(path)])
    assert result.exit_code == 2 and "--overwrite" in result.output
    cfg = tmp_path / "c.yaml"
    cfg.write_text("band_hz: [570, 580]\nwobble: 1\n")
    result = runner.invoke(app, ["detect-contact", str(path), "--config", str(cfg)])
    assert result.exit_code == 2 and "wobble" in result.output


def test_vibro_model_command(tmp_path):
    png = tmp_path / "m.png"
    result = runner.invoke(app, ["vibro-model", "configs/vibro_model.yaml", "--json", "--plot",
                                 str(png)])
    assert result.exit_code == 0, result.output
    out = json.loads(result.output)
    assert out["resonances_free"] and out["resonances_contact"]
    assert png.read_bytes()[:4] == b"\x89PNG"
    result = runner.invoke(app, ["vibro-model", "configs/vibro_model.yaml"])
    assert result.exit_code == 0 and "contact:" in result.output
    result = runner.invoke(app, ["vibro-model", str(tmp_path / "nope.yaml")])
    assert result.exit_code == 2


def test_follow_reads_a_file_while_it_grows(tmp_path):
    import threading
    import time

    from tactile_cli.vibro.stream import read_samples

    path = tmp_path / "live.txt"
    path.write_text("0.5\n1.5\n")

    def write_more():
        with open(path, "a") as f:
            for k in range(5):
                time.sleep(0.02)
                f.write(f"{k}.2")          # a line written in two pieces
                f.flush()
                time.sleep(0.01)
                f.write("5\n")
                f.flush()

    writer = threading.Thread(target=write_more)
    with open(path) as src:
        writer.start()
        values = np.concatenate(list(read_samples(src, name=str(path), chunk=3,
                                                  follow_s=0.3, poll_s=0.002)))
    writer.join()
    np.testing.assert_allclose(values, [0.5, 1.5, 0.25, 1.25, 2.25, 3.25, 4.25])


def test_an_unknown_scenario_label_is_one_input_error(scene, tmp_path):
    """Found by the damaged-input corpus: a scenario label other than contact or touch was
    scored as a contact trial without a word."""
    import shutil

    import h5py

    path, _ = scene
    bad = tmp_path / "s.h5"
    shutil.copyfile(path, bad)
    with h5py.File(bad, "r+") as f:
        first = sorted(f["trials"])[0]
        f[f"trials/{first}/labels"].attrs["scenario"] = "party"
    result = runner.invoke(app, ["detect-contact", str(bad)])
    assert result.exit_code == 2 and "scenario is 'party'" in result.output
    assert len(result.output.strip().splitlines()) == 1
