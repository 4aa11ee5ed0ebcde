"""Hostile text inputs of `tactile ingest` and `tactile grade` (issue 20): a byte that is not
UTF-8, swapped accelerometer columns, a symlink loop. Each is one stderr line naming the
file and line, exit 2, no traceback, no output file, the input unchanged."""

from __future__ import annotations

import hashlib
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.samples import write_all

runner = CliRunner()


@pytest.fixture(scope="module")
def samples(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("damaged_text") / "s"
    write_all(out, n_events=2000)
    return out


def _spoil(path: Path, line: int, column: int) -> None:
    """Put byte 0xff at 1-based (line, column)."""
    lines = path.read_bytes().split(b"\n")
    row = bytearray(lines[line - 1])
    row[column - 1] = 0xFF
    lines[line - 1] = bytes(row)
    path.write_bytes(b"\n".join(lines))


def _digest(root: Path) -> dict[str, str]:
    return {str(p): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(root.rglob("*")) if p.is_file()}


def _one_error(result) -> str:
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("tactile: error: "), result.stderr
    return lines[0]


CASES = {
    # name: (file to spoil, its line, the ingest arguments)
    "events.csv": ("events.csv", 3, ["events.csv", "--width", "640", "--height", "480"]),
    "taxel csv": ("taxel/wood_1.csv", 4, ["taxel", "--mapping", "taxel/taxels.yaml"]),
    "taxel header": ("taxel/wood_1.csv", 1, ["taxel", "--mapping", "taxel/taxels.yaml"]),
    "accel tree": ("accel_tree/wood/0/0.16/data.csv", 5,
                   ["accel_tree", "--format", "accel-tree"]),
    "timestamps": ("visuotactile/press_01/timestamps.csv", 3, ["visuotactile/press_01"]),
    "mapping yaml": ("taxel/taxels.yaml", 2, ["taxel", "--mapping", "taxel/taxels.yaml"]),
}


@pytest.mark.slow
@pytest.mark.parametrize("name", CASES)
def test_a_byte_that_is_not_utf8_names_the_file_line_and_column(name, samples, tmp_path):
    root = tmp_path / "in"
    shutil.copytree(samples, root)
    rel, line, args = CASES[name]
    _spoil(root / rel, line, 2)
    before = _digest(root)
    out = tmp_path / "out.h5"
    argv = ["ingest", *[str(root / a) if (root / a).exists() else a for a in args],
            "--out", str(out)]
    error = _one_error(runner.invoke(app, argv))
    assert error == (f"tactile: error: {root / rel}, line {line}: not UTF-8 text (byte 0xff at "
                     "column 2); save the file as UTF-8")
    assert not out.exists() and not list(tmp_path.glob("*.h5*"))
    assert _digest(root) == before


def test_swapped_velocity_columns_of_the_accel_tree_are_refused(samples, tmp_path):
    root = tmp_path / "tree"
    shutil.copytree(samples / "accel_tree", root)
    headed = [p for p in root.rglob("*.csv") if p.read_text().startswith("acc_l_x")]
    assert headed
    path = headed[0]
    path.write_text(path.read_text().replace("slip_v,slide_v", "slide_v,slip_v", 1))
    out = tmp_path / "a.h5"
    error = _one_error(runner.invoke(app, ["ingest", str(root), "--format", "accel-tree",
                                           "--out", str(out)]))
    assert error.startswith(f"tactile: error: {path}, line 1: header column 7 is 'slide_v'")
    assert "must be v_slip" in error
    assert not out.exists()


@pytest.mark.slow
def test_a_symlink_loop_is_not_reported_as_missing(tmp_path):
    (tmp_path / "a.csv").symlink_to(tmp_path / "b.csv")
    (tmp_path / "b.csv").symlink_to(tmp_path / "a.csv")
    (tmp_path / "gone.csv").symlink_to(tmp_path / "nowhere.csv")
    out = tmp_path / "out.h5"
    for cmd in (["ingest", str(tmp_path / "a.csv"), "--out", str(out)],
                ["grade", str(tmp_path / "a.csv")]):
        assert _one_error(runner.invoke(app, cmd)) == (
            f"tactile: error: {tmp_path / 'a.csv'}: file is a symlink loop; point the link at a "
            "real file")
    assert "is a broken symlink" in _one_error(
        runner.invoke(app, ["ingest", str(tmp_path / "gone.csv"), "--out", str(out)]))
    assert not out.exists()


def test_a_grade_csv_with_a_byte_that_is_not_utf8(tmp_path):
    path = tmp_path / "areas.csv"
    path.write_bytes(b"trial,area\nt1,10\nt2,1\xff2\n")
    error = _one_error(runner.invoke(app, ["grade", str(path)]))
    assert error == (f"tactile: error: {path}, line 3: not UTF-8 text (byte 0xff at column 5); "
                     "save the file as UTF-8")
