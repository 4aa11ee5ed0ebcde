"""Issue 12, item 3: many curves in one CSV (``t, x1, x2, ...``) and a folder of CSVs,
fitted in one batched call, each curve named after its file and column, with the fits equal
to those of the same curves given one file each."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.fos.curve_csv import read_curves
from tactile_cli.fos.models import step_response

from ..factories.fos_counts import use_test_compilation_cache

runner = CliRunner()
TRUTH = {"fz_0": (2.0, 0.05), "fz_1": (1.2, 0.12), "fz_2 (N)": (0.7, 0.3)}


@pytest.fixture(scope="module", autouse=True)
def _compilation_cache():
    use_test_compilation_cache()


def _table(path, *, ragged=False):
    rng = np.random.default_rng(4)
    t = np.arange(120) * 0.01
    cols = {k: rng.normal(step_response(t, a, tau), 0.005) for k, (a, tau) in TRUTH.items()}
    lines = ["t (s)," + ",".join(cols)]
    for i, ti in enumerate(t):
        cells = [f"{cols[k][i]:.6f}" for k in cols]
        if ragged and i >= 60:
            cells[0] = ""  # fz_0 recorded for 0.6 s only
        lines.append(f"{ti:.2f}," + ",".join(cells))
    path.write_text("\n".join(lines) + "\n")
    return t, cols


def _fit(*args):
    result = runner.invoke(app, ["fit-fos", *map(str, args), "--model", "step", "--json"])
    assert result.exit_code == 0, result.output
    return {f["trial"]: f for f in json.loads(result.stdout)["regions"]["curve"]["fits"]}


def test_every_column_is_a_curve(tmp_path):
    path = tmp_path / "press.csv"
    _table(path, ragged=True)
    curves = read_curves(path)
    assert [c.name for c in curves] == ["press/fz_0", "press/fz_1", "press/fz_2"]
    assert [c.units for c in curves] == [None, None, "N"]
    assert [len(c.t_s) for c in curves] == [60, 120, 120]
    fits = _fit(path)
    assert list(fits) == ["press/fz_0", "press/fz_1", "press/fz_2"]
    for (alpha, tau), f in zip(TRUTH.values(), fits.values(), strict=True):
        assert f["status"] == "converged"
        assert f["tau_s"] == pytest.approx(tau, rel=0.03)
        assert f["alpha"] == pytest.approx(alpha, rel=0.02)
    assert fits["press/fz_0"]["n_points"] == 60 and fits["press/fz_2"]["units"] == "N"


@pytest.mark.slow
def test_a_folder_equals_its_files_one_by_one(tmp_path):
    folder = tmp_path / "curves"
    folder.mkdir()
    _table(folder / "b.csv")
    t, cols = _table(folder / "a.csv")
    (folder / "notes.txt").write_text("not a curve\n")
    together = _fit(folder)
    assert list(together) == [f"{s}/{c}" for s in ("a", "b") for c in ("fz_0", "fz_1", "fz_2")]
    single = tmp_path / "fz_1.csv"
    single.write_text("t,x\n" + "".join(f"{a:.2f},{b:.6f}\n" for a, b in
                                        zip(t, cols["fz_1"], strict=True)))
    alone = _fit(single)["fz_1"]
    assert together["a/fz_1"]["tau_s"] == pytest.approx(alone["tau_s"], rel=1e-7)
    assert together["a/fz_1"]["alpha"] == pytest.approx(alone["alpha"], rel=1e-7)


def test_folder_errors(tmp_path):
    empty = tmp_path / "empty"
    empty.mkdir()
    result = runner.invoke(app, ["fit-fos", str(empty), "--model", "step"])
    assert result.exit_code == 2
    assert result.stderr == f"tactile: error: {empty}: the folder holds no .csv files\n"
    both = tmp_path / "both"
    both.mkdir()
    _table(both / "press.csv")
    _table(tmp_path / "press.csv")
    result = runner.invoke(app, ["fit-fos", str(both), str(tmp_path / "press.csv"),
                                 "--model", "step"])
    assert result.exit_code == 2 and "two curves are named 'press/fz_0'" in result.stderr
