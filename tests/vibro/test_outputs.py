"""`tactile vibro-model` and `tactile detect-contact`: an interrupted --overwrite leaves the
previous figure byte-identical (the new one is built beside it and swapped in only at the
end), and what the library verbs return is what the commands print (issue 33, issue 30
item 2)."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from tactile_cli import interrupt
from tactile_cli.cli import app

runner = CliRunner()
REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(autouse=True)
def _no_interrupt_left():
    yield
    interrupt.clear()


def _interrupting(real):
    def plot(*args, **kwargs):
        interrupt.request()  # what the CLI's SIGINT handler does
        return real(*args, **kwargs)
    return plot


def test_vibro_model_interrupted_overwrite_keeps_the_earlier_figure(tmp_path, monkeypatch):
    from tactile_cli.vibro import plots

    out = tmp_path / "m.png"
    args = ["vibro-model", str(REPO / "configs" / "vibro_model.yaml"), "--plot", str(out)]
    assert runner.invoke(app, args).exit_code == 0
    before = out.read_bytes()
    monkeypatch.setattr(plots, "plot_model_spectra", _interrupting(plots.plot_model_spectra))
    res = runner.invoke(app, [*args, "--overwrite"])
    assert res.exit_code == 130, res.output
    assert "interrupted" in res.stderr and "Traceback" not in res.output
    assert out.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.png"]


@pytest.mark.slow
def test_detect_contact_interrupted_overwrite_keeps_the_earlier_figure(scene, tmp_path,
                                                                       monkeypatch):
    from tactile_cli.vibro import plots

    path, _ = scene
    out = tmp_path / "d.png"
    assert runner.invoke(app, ["detect-contact", str(path), "--plot", str(out)]).exit_code == 0
    before = out.read_bytes()
    monkeypatch.setattr(plots, "plot_detections", _interrupting(plots.plot_detections))
    res = runner.invoke(app, ["detect-contact", str(path), "--plot", str(out), "--overwrite"])
    assert res.exit_code == 130, res.output
    assert out.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.png"]


def test_the_command_prints_what_the_library_verb_returns(scene, tmp_path):
    from tactile_cli import detect_contact_file

    path, _ = scene
    found = detect_contact_file(path, propose_band=True)
    res = runner.invoke(app, ["detect-contact", str(path), "--find-band"])
    assert res.exit_code == 0, res.output
    for line in found.summary_lines():
        assert line in res.stdout
    assert found.table() is not None and found.table()[2][0][0] == "contact_00"


def test_samples_out_replays_through_follow_and_is_never_the_input(scene, tmp_path):
    path, _ = scene
    text = tmp_path / "s.txt"
    res = runner.invoke(app, ["detect-contact", str(path), "--trial", "contact_00",
                              "--samples-out", str(text)])
    assert res.exit_code == 0, res.output
    assert res.stdout.startswith("contact_00: ") and str(text) in res.stdout
    again = runner.invoke(app, ["detect-contact", str(path), "--trial", "contact_00",
                                "--samples-out", str(text)])
    assert again.exit_code == 2 and "--overwrite" in again.stderr
    before = path.read_bytes()
    same = runner.invoke(app, ["detect-contact", str(path), "--trial", "contact_00",
                               "--samples-out", str(path), "--overwrite"])
    assert same.exit_code == 2 and "is the input" in same.stderr
    assert path.read_bytes() == before
    live = runner.invoke(app, ["detect-contact", str(text), "--follow", "--json"])
    assert live.exit_code == 0, live.output
    assert '"n_samples"' in live.stdout.splitlines()[-1]
