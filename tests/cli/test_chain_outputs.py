"""Nothing lost in the sensor-chain commands (issue 33): an output that is an input,
contains one or lies inside an input folder is refused in one line before any work, with
or without --overwrite, and the inputs keep every byte; an output folder that cannot be
written is one line; a live stream's non-finite, absurd or over-long sample is refused
with its line; deeply nested configs are one line.

The refusals come before any input is read, so most inputs here are placeholder bytes: the
point is that they are never touched."""

from __future__ import annotations

import hashlib
import shutil
import subprocess
from pathlib import Path

import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app

runner = CliRunner()
ROOT = Path(__file__).resolve().parents[2]


def _tree_hash(folder: Path) -> str:
    """SHA-256 over every path and byte under ``folder``."""
    h = hashlib.sha256()
    for p in sorted(folder.rglob("*")):
        h.update(str(p.relative_to(folder)).encode())
        if p.is_file():
            h.update(p.read_bytes())
    return h.hexdigest()


def _one_error_line(result, *words: str) -> str:
    assert result.exit_code == 2, (result.exit_code, result.output)
    assert "Traceback" not in result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("tactile: error: ")
    for word in words:
        assert word in lines[0], lines[0]
    return lines[0]


@pytest.fixture
def work(tmp_path: Path) -> Path:
    """Placeholder inputs: a tactile file, a model config, a run folder, a scene folder of
    frames, and valid scene configs of the simulators."""
    (tmp_path / "rec.h5").write_bytes(b"placeholder recording, never to be overwritten\n")
    shutil.copyfile(ROOT / "configs" / "vibro_model.yaml", tmp_path / "model.yaml")
    run = tmp_path / "run"
    run.mkdir()
    (run / "model.pt").write_bytes(b"weights")
    scene = tmp_path / "scene"
    (scene / "trials" / "t0").mkdir(parents=True)
    (scene / "trials" / "t0" / "frame_0000.png").write_bytes(b"png")
    (scene / "scene.json").write_text('{"optics": {"px_per_mm": 16}}\n')
    (tmp_path / "vibrotouch.yaml").write_text("contact_trials: 1\ntouch_trials: 0\n")
    (tmp_path / "taxel.yaml").write_text("presets: [pvdf]\ntrials_per_class: 1\n")
    (tmp_path / "digit.yaml").write_text("version: 1\n")
    (tmp_path / "vibro_slip.yaml").write_text("orientations_deg: [0]\n")
    return tmp_path


#: (command line with {w} for the work folder; the option whose value names the input)
SAME_AS_INPUT = [
    ("slip-interface {w}/rec.h5 --out {w}/rec.h5 --overwrite", "--out"),
    ("slip-interface {w}/rec.h5 --plot {w}/rec.h5 --overwrite", "--plot"),
    ("features spectral {w}/rec.h5 --out {w}/rec.h5 --overwrite", "--out"),
    ("features spectral {w}/rec.h5 --stream s --out {w}/rec.h5", "--out"),
    ("features spectral {w}/rec.h5 --stream s --out-dir {w} --overwrite --workers 0", "output"),
    ("detect-contact {w}/rec.h5 --plot {w}/rec.h5 --overwrite", "--plot"),
    ("detect-contact {w}/rec.h5 --trial t --samples-out {w}/rec.h5 --overwrite",
     "--samples-out"),
    ("detect-contact {w}/rec.h5 --config {w}/model.yaml --plot {w}/model.yaml --overwrite",
     "--plot"),
    ("vibro-model {w}/model.yaml --plot {w}/model.yaml --overwrite", "--plot"),
    ("heightmap {w}/rec.h5 --model {w}/run --out {w}/rec.h5 --overwrite", "--out"),
    ("heightmap {w}/rec.h5 --model {w}/run --out {w}/run/model.pt --overwrite", "--out"),
    ("heightmap {w}/rec.h5 --model {w}/run --out {w}/h.h5 --plot {w}", "--plot"),
    ("heightmap {w}/rec.h5 --model {w}/run --out {w}/h.h5 --truth {w}/scene "
     "--plot {w}/scene/figs", "--plot"),
    ("normal-labels {w}/rec.h5 --out {w}/rec.h5 --overwrite", "--out"),
    ("normal-labels {w}/rec.h5 --out {w}/p.h5 --plot {w} --overwrite", "--plot"),
    ("slip-signal {w}/rec.h5 --plot {w}", "--plot"),
    ("monitor {w}/scene --plot {w}/scene --overwrite", "--plot"),
    ("monitor {w}/scene --plot {w}/scene/trials/t0 --overwrite", "--plot"),
    ("monitor {w}/scene --plot {w}", "--plot"),
    ("monitor {w}/rec.h5 --plot {w}/rec.h5 --overwrite", "--plot"),
    ("accel-prepare {w}/rec.h5 --out {w}/rec.h5 --overwrite", "--out"),
    ("accel-prepare {w}/rec.h5 --out-dir {w} --overwrite --workers 0", "output"),
    ("simulate vibrotouch --config {w}/vibrotouch.yaml --out {w}/vibrotouch.yaml --overwrite",
     "input"),
    ("simulate taxel-slip --config {w}/taxel.yaml --out {w}/taxel.yaml --overwrite", "input"),
    ("simulate digit-press {w} --config {w}/digit.yaml --overwrite", "input"),
    ("simulate vibro-slip --out {w} --config {w}/vibro_slip.yaml --overwrite", "input"),
    ("simulate digit-avoidance {w} --config {w}/digit.yaml --overwrite", "input"),
]


@pytest.mark.parametrize(("line", "option"), SAME_AS_INPUT,
                         ids=[f"{i}-{c.split()[0]}" for i, (c, _) in enumerate(SAME_AS_INPUT)])
def test_an_output_that_is_holds_or_lies_in_an_input_is_refused_and_inputs_kept(
        work: Path, line: str, option: str):
    before = _tree_hash(work)
    result = runner.invoke(app, line.format(w=work).split())
    if "digit-avoidance" in line:  # its config is another scene's: refused all the same
        assert result.exit_code == 2 and "Traceback" not in result.output
    else:
        message = _one_error_line(result, option)
        assert "input" in message, message
    assert _tree_hash(work) == before


def _chattr(flag: str, path: Path) -> bool:
    try:
        return subprocess.run(["chattr", flag, str(path)], capture_output=True).returncode == 0
    except OSError:
        return False


UNWRITABLE = [
    "vibro-model {w}/model.yaml --plot {ro}/m.png",
    "detect-contact {w}/rec.h5 --plot {ro}/d.png",
    "detect-contact {w}/rec.h5 --trial t --samples-out {ro}/s.txt",
    "slip-interface {w}/rec.h5 --out {ro}/r.json",
    "slip-interface {w}/rec.h5 --plot {ro}/r.png",
    "features spectral {w}/rec.h5 --out {ro}/f.h5",
    "features spectral {w}/rec.h5 --stream s --out {ro}/f.h5",
    "heightmap {w}/rec.h5 --model {w}/run --out {ro}/h.h5",
    "heightmap {w}/rec.h5 --model {w}/run --out {w}/h.h5 --plot {ro}/figs",
    "normal-labels {w}/rec.h5 --out {ro}/p.h5",
    "normal-labels {w}/rec.h5 --out {w}/p.h5 --plot {ro}/figs",
    "slip-signal {w}/rec.h5 --plot {ro}/figs",
    "monitor {w}/rec.h5 --plot {ro}/figs",
    "accel-prepare {w}/rec.h5 --out {ro}/p.h5",
    "simulate taxel-slip --config {w}/taxel.yaml --out {ro}/s.h5",
    "simulate digit-press {ro}/scene --config {w}/digit.yaml",
]


@pytest.mark.parametrize("line", UNWRITABLE, ids=[c.split()[0] + f"-{i}"
                                                  for i, c in enumerate(UNWRITABLE)])
def test_an_output_folder_that_cannot_be_written_is_one_line(work: Path, line: str):
    ro = work / "ro"
    ro.mkdir()
    if not _chattr("+i", ro):
        pytest.skip("chattr +i is not permitted on this file system")
    try:
        before = _tree_hash(work)
        result = runner.invoke(app, line.format(w=work, ro=ro).split())
        _one_error_line(result, str(ro), "cannot write")
        assert _tree_hash(work) == before
    finally:
        _chattr("-i", ro)


@pytest.mark.parametrize(("text", "line_no"), [
    ("0.1\n0.2\nnan\n0.3\n", 3), ("0.1\ninf\n", 2), ("1e400\n", 1), ("-1e9\n", 1),
    ("0.1\n" + "1" * 5000 + "\n", 2), ("0.1\n0.2\n" + "7" * 2000, 3),
])
@pytest.mark.parametrize("where", ["file", "stdin"])
def test_a_live_stream_refuses_a_non_finite_absurd_or_over_long_sample(tmp_path, text, line_no,
                                                                     where):
    stream = tmp_path / "s.txt"
    stream.write_text(text)
    args = ["detect-contact", str(stream) if where == "file" else "-", "--follow"]
    result = runner.invoke(app, args, input=text if where == "stdin" else None)
    message = _one_error_line(result, f"line {line_no}")
    assert "no event" in message or "longer than" in message
    assert "contact at" not in result.stdout


def test_a_live_stream_of_twenty_megabytes_on_one_line_is_refused_without_reading_it_all(
        tmp_path):
    stream = tmp_path / "s.txt"
    with open(stream, "w") as f:
        f.write("0.1\n" + "9" * 20_000_000 + "\n")
    result = runner.invoke(app, ["detect-contact", str(stream), "--follow"])
    line = _one_error_line(result)
    assert "line 2 is longer than 1024 characters" in line


def test_follow_input_refuses_an_infinite_rate_in_the_library(tmp_path):
    from tactile_cli.errors import InputError
    from tactile_cli.vibro import follow_input

    stream = tmp_path / "s.txt"
    stream.write_text("0.1\n")
    with pytest.raises(InputError, match="`rate_hz` \\(=inf\\)"):
        follow_input(stream, rate_hz=float("inf"))


def _deep(path: Path, depth: int = 200) -> Path:
    path.write_text("a: " + "[" * depth + "]" * depth + "\n")
    return path


@pytest.mark.parametrize("args", [
    ["vibro-model", "{deep}"],
    ["detect-contact", "{w}/rec.h5", "--config", "{deep}"],
    ["slip-interface", "{w}/rec.h5", "--config", "{deep}"],
    ["features", "spectral", "{w}/rec.h5", "--config", "{deep}", "--out", "{w}/f.h5"],
    ["simulate", "vibrotouch", "--config", "{deep}", "--out", "{w}/v.h5"],
    ["simulate", "digit-press", "{w}/s", "--config", "{deep}"],
])
def test_deeply_nested_configs_are_one_line(work: Path, args):
    deep = _deep(work / "deep.yaml")
    result = runner.invoke(app, [a.format(w=work, deep=deep) for a in args])
    assert "nested" in _one_error_line(result)


def test_a_scene_json_nested_deeply_is_one_line(work: Path):
    scene = work / "scene"
    (scene / "scene.json").write_text('{"optics": ' + "[" * 5_000 + "]" * 5_000 + "}")
    result = runner.invoke(app, ["monitor", str(scene)])
    line = _one_error_line(result, "scene.json")
    assert "nested" in line


@pytest.mark.parametrize(("args", "words"), [
    (["detect-contact", "{w}/rec.h5", "--band", "580,570"], ["--band", "low < high"]),
    (["detect-contact", "{w}/rec.h5", "--band", "a,b"], ["--band 'a,b'"]),
    (["simulate", "taxel-slip", "--out", "{w}/t.h5", "--preset", "toaster"], ["--preset"]),
    (["simulate", "digit-press", "{w}/s", "--objects", ","], ["--objects"]),
    (["simulate", "digit-press", "{w}/s", "--trials", "1000000000000"], ["--trials"]),
    (["simulate", "digit-avoidance", "{w}/s", "--object", "toaster"], ["--object"]),
    (["simulate", "vibrotouch", "--out", "{w}/v.h5", "--contact-trials", "0",
      "--touch-trials", "0"], ["nothing to simulate"]),
])
def test_absurd_options_are_one_line_naming_the_flag(work: Path, args, words):
    before = _tree_hash(work)
    result = runner.invoke(app, [a.format(w=work) for a in args])
    _one_error_line(result, *words)
    assert _tree_hash(work) == before


def _command_modules() -> tuple[Path, set[str]]:
    """cli/ and the names of its command modules (the shared pieces start with ``_``)."""
    cli = ROOT / "tactile_cli" / "cli"
    return cli, {p.stem for p in cli.glob("*.py")
                 if not p.stem.startswith("_") and p.stem != "progress"}


def test_no_command_module_imports_another_command_module():
    """Issue 30 item 2: command modules share code through cli/_options, _output, _batch
    and the library, never through each other (cli/__init__ registers them all)."""
    import ast

    cli, commands = _command_modules()
    for path in sorted(cli.glob("*.py")):
        if path.stem == "__init__":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.level == 1 and node.module:
                assert node.module.split(".")[0] not in commands, (path.stem, node.module)


def test_no_function_in_cli_has_more_than_60_body_lines():
    """Issue 30 item 2: a command parses, calls one library verb and prints."""
    import ast

    cli, _ = _command_modules()
    for path in sorted(cli.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                first = node.body[0]
                start = first.end_lineno + 1 if (isinstance(first, ast.Expr) and isinstance(
                    first.value, ast.Constant)) else first.lineno
                assert node.end_lineno - start + 1 <= 60, (path.stem, node.name)

