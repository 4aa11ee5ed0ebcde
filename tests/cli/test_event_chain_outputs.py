"""Nothing lost (issue 33) for the event-chain commands and their neighbours: accumulate,
fit-fos, frames, centroids, slip-rate, grade, synth, plot, samples.

For every output option: an output that is an input, or a folder that holds one, is one
error line before any work, with or without --overwrite, and the input is byte-identical
afterwards; an output folder that cannot be written is one line before any work; an
interrupted --overwrite leaves the previous output byte-identical (exit 130); numbers that
imply absurd work are refused with what they would cost."""

from __future__ import annotations

import errno
import hashlib
import os
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from tactile_cli import interrupt
from tactile_cli.cli import app
from tactile_cli.store import atomic

from ..factories.action_files import make_event_file
from ..factories.fos_counts import use_test_compilation_cache, write_counts_file
from ..fos.stream_steps import write_stream_file

runner = CliRunner()
ROOT = Path(__file__).resolve().parents[2]
ROIS = ROOT / "configs" / "rois_marker_scene.yaml"
CURVE = "t_s,x\n" + "".join(f"{0.02 * i:.2f},{10 * (1 - 0.6 ** i):.6f}\n" for i in range(40))


@pytest.fixture(autouse=True)
def _clean_interrupt():
    yield
    interrupt.clear()


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> dict[str, Path]:
    """Small valid inputs, built once; each test works on copies."""
    use_test_compilation_cache()
    base = tmp_path_factory.mktemp("inputs")
    make_event_file(base / "events.h5", n_trials=2, seed=1)
    write_counts_file(base / "counts.h5", n_trials=3, seed=2)
    write_stream_file(base / "stream.h5", n_trials=2)
    (base / "curve.csv").write_text(CURVE)
    (base / "grade_table.csv").write_text(  # areas of 12 force levels, every grade labelled
        "trial,area,level\n" + "".join(f"t{i},{20000 + 2500 * i},{i + 1}\n" for i in range(12)))
    shutil.copyfile(ROIS, base / "rois.yaml")
    return {p.stem: p for p in base.iterdir()}


@pytest.fixture
def work(inputs, tmp_path) -> dict[str, Path]:
    """Copies of the inputs in ``tmp_path/in`` (the dict has ``"dir"`` too)."""
    folder = tmp_path / "in"
    folder.mkdir()
    out = {"dir": folder}
    for name, path in inputs.items():
        out[name] = folder / path.name
        shutil.copyfile(path, out[name])
    return out


def _digests(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def _one_line(result, *words: str) -> str:
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("tactile: error: ")
    for word in words:
        assert word in lines[0], lines[0]
    return lines[0]


# ---------------------------------------------------------------- output is an input

IS_INPUT = {
    "accumulate --out": ["accumulate", "{events}", "--out", "{events}", "--overwrite"],
    "accumulate --csv": ["accumulate", "{events}", "--csv", "{events}", "--overwrite"],
    "fit-fos --csv (the HDF5 input)": ["fit-fos", "{stream}", "--stream", "taxels", "--csv",
                                       "{stream}", "--overwrite"],
    "fit-fos --csv (a CSV curve)": ["fit-fos", "{curve}", "--model", "step", "--csv",
                                    "{curve}", "--overwrite"],
    "centroids --out (the ROI config)": ["centroids", "{events}", "--rois", "{rois}", "--out",
                                         "{rois}", "--overwrite"],
    "centroids --out": ["centroids", "{events}", "--rois", "{rois}", "--out", "{events}",
                        "--overwrite"],
    "synth --out (the fits)": ["synth", "--fits", "{counts}", "--out", "{counts}",
                               "--overwrite"],
    "grade --out (the config)": ["grade", "{events}", "--config", "{rois}", "--calibrate",
                                 "--out", "{rois}", "--overwrite"],
    "grade --out (the data)": ["grade", "{events}", "--calibrate", "--out", "{events}",
                               "--overwrite"],
}


@pytest.mark.parametrize("case", sorted(IS_INPUT))
def test_an_output_that_is_an_input_is_refused_and_the_input_kept(work, case):
    before = _digests(work["dir"])
    argv = [a.format(**work) for a in IS_INPUT[case]]
    _one_line(runner.invoke(app, argv), "is the input", "never overwrites or deletes")
    assert _digests(work["dir"]) == before


HOLDS_INPUT = {
    "plot --out": ["plot", "{events}", "--out", "{dir}"],
    "frames --out": ["frames", "{events}", "--out", "{dir}", "--overwrite"],
    "slip-rate --plot": ["slip-rate", "{events}", "--plot", "{dir}"],
    "accumulate --plot": ["accumulate", "{events}", "--plot", "{dir}", "--overwrite"],
    "grade --plot": ["grade", "{events}", "--plot", "{dir}"],
    "fit-fos --plot": ["fit-fos", "{curve}", "--model", "step", "--plot", "{dir}",
                       "--overwrite"],
}


@pytest.mark.parametrize("case", sorted(HOLDS_INPUT))
def test_an_output_folder_that_holds_an_input_is_refused(work, case):
    before = _digests(work["dir"])
    argv = [a.format(**work) for a in HOLDS_INPUT[case]]
    _one_line(runner.invoke(app, argv), "contains the input")
    assert _digests(work["dir"]) == before


def test_fit_fos_csv_inside_a_folder_of_curves_is_refused(work):
    """The folder is the input (its *.csv are the curves): a table written into it would
    be read as a curve next time."""
    before = _digests(work["dir"])
    result = runner.invoke(app, ["fit-fos", str(work["dir"]), "--model", "step", "--csv",
                                 str(work["dir"] / "fits.csv")])
    _one_line(result, "lies inside the input folder")
    assert _digests(work["dir"]) == before


# ---------------------------------------------------------------- unwritable places

UNWRITABLE = {
    "accumulate --csv": ["accumulate", "{events}", "--csv", "{out}/a.csv"],
    "accumulate --plot": ["accumulate", "{events}", "--plot", "{out}/figs"],
    "fit-fos --csv": ["fit-fos", "{curve}", "--model", "step", "--csv", "{out}/f.csv"],
    "centroids --out": ["centroids", "{events}", "--rois", "{rois}", "--out", "{out}/c.h5"],
    "frames --out": ["frames", "{events}", "--out", "{out}/frames"],
    "slip-rate --plot": ["slip-rate", "{events}", "--plot", "{out}/figs"],
    "grade --out": ["grade", "{events}", "--calibrate", "--out", "{out}/g.yaml"],
    "synth --out": ["synth", "--n", "2", "--out", "{out}/s.h5"],
    "plot --out": ["plot", "{events}", "--out", "{out}/figs"],
    "samples": ["samples", "{out}/samples"],
}


@pytest.mark.parametrize("case", sorted(UNWRITABLE))
def test_an_output_folder_that_refuses_new_files_is_one_line_before_work(work, tmp_path,
                                                                         monkeypatch, case):
    """A read-only mount or an immutable folder: the probe file the store makes before any
    work is refused (the same answer as `chattr +i`, which needs privileges)."""
    out = tmp_path / "locked"
    out.mkdir()
    real_open = os.open

    def refuse(path, flags, *args):
        if ".tactile-probe" in str(path):
            raise PermissionError(errno.EROFS, "Read-only file system", str(path))
        return real_open(path, flags, *args)

    monkeypatch.setattr(atomic.os, "open", refuse)
    argv = [a.format(out=out, **work) for a in UNWRITABLE[case]]
    _one_line(runner.invoke(app, argv), "cannot write in this folder")
    assert list(out.iterdir()) == []


# ---------------------------------------------------------------- interrupted --overwrite

def _interrupt_during(monkeypatch, module: str, name: str) -> None:
    """Make ``module.name`` ask for an interrupt (what the CLI's SIGINT handler does) and go
    on: the writer stops at its next check, before its rename."""
    import importlib

    mod = importlib.import_module(module)
    real = getattr(mod, name)

    def wrapped(*args, **kwargs):
        interrupt.request()
        return real(*args, **kwargs)

    monkeypatch.setattr(mod, name, wrapped)


INTERRUPTED = {
    "accumulate --out": (["accumulate", "{events}", "--out", "{out}/a.h5", "--overwrite"],
                         "a.h5", "tactile_cli.events.recording", "_accumulate_trial"),
    "accumulate --csv": (["accumulate", "{events}", "--csv", "{out}/a.csv", "--overwrite"],
                         "a.csv", "tactile_cli.events.recording", "bin_rows"),
    "fit-fos --csv": (["fit-fos", "{curve}", "--model", "step", "--no-order", "--csv",
                       "{out}/f.csv", "--overwrite"], "f.csv", "tactile_cli.fos.table",
                      "fit_records"),
    "centroids --out": (["centroids", "{events}", "--rois", "{rois}", "--out", "{out}/c.h5",
                         "--overwrite"], "c.h5", "tactile_cli.spatial.stream",
                        "trial_centroid_stream"),
    "synth --out": (["synth", "--n", "3", "--out", "{out}/s.h5", "--overwrite"], "s.h5",
                    "tactile_cli.synth", "generate_trials"),
    "grade --out": (["grade", "{grade_table}", "--calibrate", "--out", "{out}/g.yaml",
                     "--overwrite"], "g.yaml", "tactile_cli.grade.pipeline",
                    "true_grade_index"),
}


@pytest.mark.parametrize("case", sorted(INTERRUPTED))
def test_an_interrupted_overwrite_keeps_the_previous_output(work, tmp_path, monkeypatch, case):
    argv, name, module, function = INTERRUPTED[case]
    out = tmp_path / "out"
    out.mkdir()
    previous = b"the previous output, kept byte for byte\n"
    (out / name).write_bytes(previous)
    _interrupt_during(monkeypatch, module, function)
    result = runner.invoke(app, [a.format(out=out, **work) for a in argv])
    assert result.exit_code == 130, result.output
    assert result.stderr.strip() == ("tactile: error: interrupted; no output was written and "
                                     "earlier outputs are intact")
    assert (out / name).read_bytes() == previous
    assert sorted(p.name for p in out.iterdir()) == [name]  # no temporary left


# ---------------------------------------------------------------- absurd numbers

ABSURD = {
    "fit-fos --stream, more curves than --max-curves": (
        ["fit-fos", "{stream}", "--stream", "taxels", "--max-curves", "10"],
        ("20 curves", "more than --max-curves (=10)", "of work on one core", "--reduce mean")),
    "fit-fos --stream --regions detect, every channel searched": (
        ["fit-fos", "{stream}", "--stream", "taxels", "--regions", "detect", "--max-curves",
         "4"], ("10 curves to search for steps", "--channels")),
    "fit-fos --press-duration inf": (["fit-fos", "{curve}", "--model", "pulse",
                                      "--press-duration", "inf"], ("not a finite number",)),
    "frames --window-ms 0.01": (["frames", "{events}", "--out", "{dir}/../frames",
                                 "--window-ms", "0.01"],
                                ("frames, more than 10,000 per trial", "min of drawing")),
    "frames --window-ms below 1 us": (["frames", "{events}", "--out", "{dir}/../frames",
                                       "--window-ms", "1e-5"], ("must be at least 1 us",)),
    "frames --median larger than the sensor": (
        ["frames", "{events}", "--out", "{dir}/../frames", "--median", "4001"],
        ("larger than the 640x480 px sensor",)),
    "synth --n 10^7": (["synth", "--n", "10000000", "--out", "{dir}/../s.h5"],
                       ("more than 20,000,000", "h of work", "of output")),
    "samples --n-events 10^10": (["samples", "{dir}/../samples", "--n-events", "10000000000"],
                                 ("--n-events", "of memory and disk")),
    "grade --overlap 0": (["grade", "{events}", "--calibrate", "--out", "{dir}/../g.yaml",
                           "--overlap", "0"], ("--overlap",)),
}


@pytest.mark.parametrize("case", sorted(ABSURD))
def test_numbers_that_imply_absurd_work_are_refused_with_their_cost(work, tmp_path, case):
    argv, words = ABSURD[case]
    before = _digests(work["dir"])
    _one_line(runner.invoke(app, [a.format(**work) for a in argv]), *words)
    assert _digests(work["dir"]) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in"]


# ---------------------------------------------------------------- regressions of issue 33

def test_fit_fos_plot_dot_with_overwrite_writes_the_figures_there(work, tmp_path, monkeypatch):
    """`--plot . --overwrite` raised a ValueError (a folder named `.` has no name for its
    temporary sibling) after the fit, and left the other outputs behind."""
    figs = tmp_path / "figs"
    figs.mkdir()
    monkeypatch.chdir(figs)
    result = runner.invoke(app, ["fit-fos", str(work["curve"]), "--model", "step",
                                 "--no-order", "--plot", ".", "--overwrite", "--csv", "f.csv"])
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in figs.iterdir()) == ["curve.png", "f.csv"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["figs", "in"]  # nothing hidden


def test_fit_fos_stream_of_76800_channels_is_refused_before_reading_samples(tmp_path,
                                                                          monkeypatch):
    """A 320 x 240 height map searched channel by channel ran past a minute; it is refused
    from the channel names, before any sample is read."""
    import numpy as np

    from tactile_cli.store import StoreWriter
    from tactile_cli.store.trials import Trial

    path = tmp_path / "heights.h5"
    n = 320 * 240
    with StoreWriter(path, command="test") as w:
        s = w.add_sensor("gel", kind="taxel_array", sample_rate_hz=30.0,
                         channel_names=[f"h{i}" for i in range(n)], channel_units="mm")
        w.trial("t0", annotations=[(0.1, 0.3, "press")]).write_signal(
            "height_mm", sensor=s, data=np.zeros((12, n), np.float32), t_s=np.arange(12) / 30)
        w.commit()

    def no_samples(*args, **kwargs):
        raise AssertionError("the samples were read before the size check")

    monkeypatch.setattr(Trial, "signal", no_samples)
    result = runner.invoke(app, ["fit-fos", str(path), "--stream", "height_mm", "--regions",
                                 "detect"])
    line = _one_line(result, "76,800 curves to search for steps", "about 7 min")
    assert "more than --max-curves (=4096)" in line
