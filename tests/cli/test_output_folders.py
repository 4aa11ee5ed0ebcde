"""Output folders of every command (issue 20): a file where a folder is expected is one
error line before any work; a failure or Ctrl-C leaves no output and no hidden temporary
folder, and an earlier output intact; a success leaves no temporary folder."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

from tactile_cli import interrupt
from tactile_cli.cli import app
from tactile_cli.errors import InputError

from .test_plot import _file

runner = CliRunner()
ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(autouse=True)
def _no_interrupt_left():
    yield
    interrupt.clear()


@pytest.fixture(scope="module")
def rec(tmp_path_factory):
    return _file(tmp_path_factory.mktemp("rec") / "rec.h5")


def _one_error_line(result, *words: str) -> str:
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("tactile: error: ")
    for word in words:
        assert word in lines[0]
    return lines[0]


def _hidden(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


def _tree(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in folder.rglob("*")
            if p.is_file()}


COMMANDS = {
    "plot": lambda f, x: ["plot", str(f), "--out", str(x)],
    "frames": lambda f, x: ["frames", str(f), "--out", str(x)],
    "slip-rate": lambda f, x: ["slip-rate", str(f), "--plot", str(x)],
    "accumulate": lambda f, x: ["accumulate", str(f), "--plot", str(x)],
    "grade": lambda f, x: ["grade", str(f), "--plot", str(x)],
    "fit-fos": lambda f, x: ["fit-fos", str(f), "--plot", str(x), "--no-write"],
    "samples": lambda f, x: ["samples", str(x)],
    "simulate": lambda f, x: ["simulate", "marker-events", "--out", str(x)],
    "report": lambda f, x: ["report", "--data", str(f), "--out", str(x)],
}


@pytest.mark.parametrize("command", sorted(COMMANDS))
@pytest.mark.parametrize("where", ["target", "parent"])
def test_a_file_where_the_output_folder_goes_is_one_line_exit_2(tmp_path, rec, command, where):
    blocker = tmp_path / "taken"
    blocker.write_bytes(b"my file")
    out = blocker if where == "target" else blocker / "figs"
    result = runner.invoke(app, COMMANDS[command](rec, out))
    _one_error_line(result, str(blocker), "is a file")
    assert blocker.read_bytes() == b"my file"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["taken"]


@pytest.mark.parametrize("args", [["accumulate", "{rec}", "--out", "{d}"],
                                  ["accumulate", "{rec}", "--csv", "{d}", "--overwrite"],
                                  ["ingest", "{csv}", "--width", "32", "--height", "24",
                                   "--out", "{d}"]])
def test_a_folder_where_an_output_file_goes_is_one_line_exit_2(tmp_path, rec, args):
    from tactile_cli.samples import write_events_csv

    csv = tmp_path / "ev.csv"
    write_events_csv(csv, 100, width=32, height=24, seed=0)
    d = tmp_path / "d"
    d.mkdir()
    result = runner.invoke(app, [a.format(rec=rec, d=d, csv=csv) for a in args])
    _one_error_line(result, str(d))
    assert list(d.iterdir()) == []


@pytest.mark.slow
def test_plot_success_leaves_no_temporary_and_keeps_other_files(tmp_path, rec):
    out = tmp_path / "figs"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    result = runner.invoke(app, ["plot", str(rec), "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert (out / "notes.txt").read_text() == "mine" and (out / "index.html").is_file()
    assert _hidden(tmp_path) == [] and _hidden(out) == []


def test_plot_failing_midway_leaves_nothing(tmp_path, rec, monkeypatch):
    from tactile_cli.plots import quicklook

    def boom(*args, **kwargs):
        raise InputError("damaged stream", path=rec, where="/trials/t0/signals/acc")

    monkeypatch.setattr(quicklook, "_signals_figure", boom)  # after the events PNG is written
    out = tmp_path / "new" / "figs"
    result = runner.invoke(app, ["plot", str(rec), "--out", str(out)])
    _one_error_line(result, "damaged stream")
    assert list(tmp_path.iterdir()) == []  # nor the parent it would have created


@pytest.mark.slow
def test_frames_failing_midway_keeps_the_earlier_output(tmp_path, rec, monkeypatch):
    from tactile_cli.spatial import render

    out = tmp_path / "frames"
    assert runner.invoke(app, ["frames", str(rec), "--out", str(out)]).exit_code == 0
    before = _tree(out)
    sheets = []
    real = render.contact_sheet

    def second_fails(*args, **kwargs):
        sheets.append(1)
        if len(sheets) == 2:
            raise InputError("damaged trial", path=rec, where="/trials/t1")
        return real(*args, **kwargs)

    monkeypatch.setattr(render, "contact_sheet", second_fails)
    result = runner.invoke(app, ["frames", str(rec), "--out", str(out), "--overwrite"])
    _one_error_line(result, "damaged trial")
    assert _tree(out) == before
    assert _hidden(tmp_path) == [] and _hidden(out) == []


@pytest.mark.slow
def test_frames_interrupted_exits_130_and_keeps_the_earlier_output(tmp_path, rec, monkeypatch):
    from tactile_cli.spatial import render

    out = tmp_path / "frames"
    assert runner.invoke(app, ["frames", str(rec), "--out", str(out)]).exit_code == 0
    before = _tree(out)
    real = render.contact_sheet

    def ctrl_c(*args, **kwargs):
        interrupt.request()  # what the CLI's SIGINT handler does
        return real(*args, **kwargs)

    monkeypatch.setattr(render, "contact_sheet", ctrl_c)
    result = runner.invoke(app, ["frames", str(rec), "--out", str(out), "--overwrite"])
    assert result.exit_code == 130, result.output
    assert "interrupted" in result.stderr and "Traceback" not in result.output
    assert _tree(out) == before
    assert _hidden(tmp_path) == [] and _hidden(out) == []


@pytest.mark.slow
def test_frames_overwrite_replaces_trial_folders_atomically(tmp_path, rec):
    out = tmp_path / "frames"
    assert runner.invoke(app, ["frames", str(rec), "--out", str(out)]).exit_code == 0
    again = runner.invoke(app, ["frames", str(rec), "--out", str(out)])
    _one_error_line(again, "--overwrite")
    result = runner.invoke(app, ["frames", str(rec), "--out", str(out), "--overwrite",
                                 "--sheet-only", "--trial", "t0"])
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in (out / "t0").iterdir()) == ["contact_sheet.png"]
    assert any((out / "t1").glob("frame_*.png"))  # the trial not drawn again is kept
    assert _hidden(tmp_path) == [] and _hidden(out) == []


@pytest.mark.slow
def test_samples_success_leaves_no_temporary(tmp_path):
    out = tmp_path / "s"
    result = runner.invoke(app, ["samples", str(out), "--n-events", "1000"])
    assert result.exit_code == 0, result.output
    assert (out / "taxel").is_dir() and f"--mapping {out / 'taxel'}" in result.stdout
    assert _hidden(tmp_path) == []


@pytest.mark.slow
def test_plot_stops_on_sigint(tmp_path):
    big = _file(tmp_path / "big.h5", n_trials=40)
    out = tmp_path / "figs"
    out.mkdir()
    (out / "index.html").write_text("earlier page")
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen(
        [sys.executable, "-m", "tactile_cli", "plot", str(big), "--out", str(out),
         "--max-trials", "40"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, cwd=ROOT)
    deadline = time.monotonic() + 60
    while not list(tmp_path.glob(".figs.tmp-*/*.png")):  # wait until it is drawing
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "plot never started drawing"
        time.sleep(0.02)
    proc.send_signal(signal.SIGINT)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130, stderr
    assert stderr.strip() == ("tactile: error: interrupted; no output was written and earlier "
                              "outputs are intact")
    assert _tree(out) == {"index.html": b"earlier page"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["big.h5", "figs"]
