"""``tactile sweep`` (issue 14, item 4) and the Dask execution layer it runs on
(tactile_cli/batch): the grid and its n/a cells, overrides validated before any work, a real
sweep on a local cluster of worker processes, a restart that skips finished runs (sent to
a scheduler the test starts), a failed run reported in the table, and Ctrl-C."""

from __future__ import annotations

import csv
import json
import time
from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from tactile_cli import interrupt
from tactile_cli.batch import map_tasks
from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.interrupt import Interrupted
from tactile_cli.learn.sweep import SweepConfig, expand_grid, load_sweep

runner = CliRunner()
CONFIGS = Path(__file__).resolve().parents[2] / "configs"
#: A tiny FNN: a second or two per run on 2 cores.
TINY = {"optim.epochs": 1, "optim.patience": 0, "model.head_hidden": [8]}


@pytest.fixture(scope="module")
def vibro(tmp_path_factory) -> tuple[Path, Path]:
    """Prepared vibro-slip files of seeds 0 (train) and 1 (eval): 3 textures x 2 speeds,
    2 s each, in 0.5 s segments (24 trials per file)."""
    from tactile_cli.accel import VibroSceneConfig, simulate_vibro_slip
    from tactile_cli.accel.prepare import prepare_file
    from tactile_cli.ingest import ingest

    root = tmp_path_factory.mktemp("sweep_data")
    cfg = VibroSceneConfig.model_validate({"orientations_deg": [0], "motor_rps": [0.16, 0.48],
                                           "duration_s": 2.0})
    out = []
    for seed in (0, 1):
        simulate_vibro_slip(cfg, root / f"scene{seed}", seed=seed)
        ingest([root / f"scene{seed}"], root / f"scene{seed}.h5",
               format="accel-tree")
        out.append(prepare_file(root / f"scene{seed}.h5", root / f"prep{seed}.h5",
                                segment_s=0.5).out)
    return Path(out[0]), Path(out[1])


def _sweep(**changes) -> dict:
    raw = {
        "version": 1, "name": "tiny",
        "models": {
            "fnn": {"config": str(CONFIGS / "train_fnn_vibro.yaml"),
                    "overrides": {"model.hidden": [16]}},
            "cnn2d": {"config": str(CONFIGS / "train_cnn2d_vibro.yaml"),
                      "by_window": {400: {"model.n_fft": 40, "model.hop": 20}}},
        },
        "windows": [{"window": 50, "stride": 25}, {"window": 25, "stride": 25}],
        "channel_sets": {"Lx": ["L_x"], "bad": ["Q_x"]},
        "overrides": TINY,
        "targets": {"motion": 0.05},
    }
    raw.update(changes)
    return raw


def test_grid_order_names_overrides_and_na():
    raw = _sweep(windows=[{"window": 400, "stride": 200}, {"window": 25, "stride": 10}],
                 channel_sets={"L3R3": ["L_x", "L_y", "L_z", "R_x", "R_y", "R_z"],
                               "Lx": ["L_x"]})
    raw["models"]["fnn"]["overrides"]["optim.epochs"] = 2
    planned = expand_grid(SweepConfig.model_validate(raw))
    assert [r.name for r in planned] == [
        "fnn-w400-L3R3", "fnn-w400-Lx", "fnn-w25-L3R3", "fnn-w25-Lx",
        "cnn2d-w400-L3R3", "cnn2d-w400-Lx", "cnn2d-w25-L3R3", "cnn2d-w25-Lx"]
    by = {r.name: r for r in planned}
    fnn = by["fnn-w25-Lx"].config
    assert fnn["data"]["window"] == 25 and fnn["data"]["stride"] == 10
    assert fnn["data"]["channels"] == ["L_x"]
    assert fnn["optim"]["epochs"] == 2  # the model's overrides win over the sweep's
    assert fnn["model"]["hidden"] == [16]
    cnn = by["cnn2d-w400-L3R3"]
    assert cnn.family == "cnn2d_spectrogram" and cnn.config["model"]["n_fft"] == 40
    na = by["cnn2d-w25-Lx"]
    assert na.status == "n/a" and na.config is None and "window 25" in na.reason


def test_bad_override_and_bad_sweep_keys_are_one_line_errors(tmp_path: Path):
    (tmp_path / "a.h5").write_bytes(b"")
    raw = _sweep(train_data=[str(tmp_path / "a.h5")])
    raw["overrides"] = {**TINY, "optim.epoch": 3}
    path = tmp_path / "sweep.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    res = runner.invoke(app, ["sweep", str(path), "--out", str(tmp_path / "out")])
    assert res.exit_code == 2
    err = res.stderr.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in res.output
    assert str(path) in err and "run fnn-w50-Lx" in err and "unknown key `optim.epoch`" in err
    assert not (tmp_path / "out").exists()  # refused before any work

    raw = _sweep()
    raw["windowz"] = []
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    with pytest.raises(InputError, match=r"line \d+: unknown key `windowz`"):
        load_sweep(path)
    raw = _sweep(models={"f/n": {"config": "x.yaml"}})
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    with pytest.raises(InputError, match="must be letters"):
        load_sweep(path)


def _table(out: Path) -> dict[str, dict[str, str]]:
    with open(out / "table.csv", newline="") as f:
        return {r["run"]: r for r in csv.DictReader(f)}


@pytest.mark.slow
def test_sweep_on_a_local_cluster_then_restart_on_a_given_scheduler(vibro, tmp_path: Path,
                                                                     monkeypatch):
    from distributed import LocalCluster

    train, test = vibro
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "sweep.yaml"
    raw = _sweep(train_data=[str(train)], eval={"data": [str(test)], "split": "test"})
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    out = tmp_path / "out"
    res = runner.invoke(app, ["sweep", str(path), "--out", str(out), "--workers", "2",
                              "--no-progress"])
    assert res.exit_code == 2, res.output  # two runs failed: exit 2, after the table
    assert "local Dask cluster of 2 worker process(es)" in res.stdout
    assert "2 ok (0 finished before), 2 failed, 4 n/a" in res.stdout
    rows = _table(out)
    assert [r["status"] for r in rows.values()] == ["ok", "failed", "ok", "failed"] + ["n/a"] * 4
    assert "'Q_x' is not a channel" in rows["fnn-w50-bad"]["error"]
    assert "\n" not in rows["fnn-w50-bad"]["error"]
    assert "by_window lists no window 50" in rows["cnn2d-w50-Lx"]["error"]
    ok = rows["fnn-w50-Lx"]
    assert 0 <= float(ok["motion_acc_pct"]) <= 100 and float(ok["speed_cm_s_mae"]) >= 0
    assert int(ok["n_params"]) > 0 and float(ok["latency_ms"]) > 0
    for name in ("sweep.json", "table.md", "sweep_results.json", "accuracy_vs_window.png",
                 "speed_accuracy.png"):
        assert (out / name).stat().st_size > 0, name
    assert (out / "accuracy_vs_window.png").read_bytes()[:4] == b"\x89PNG"
    plan = json.loads((out / "sweep.json").read_text())
    assert plan["train_data"][0]["sha256"] and plan["sweep_file"]["path"] == str(path)
    assert len(plan["runs"]) == 8
    results = json.loads((out / "sweep_results.json").read_text())
    assert results["pick"]["run"] in ("fnn-w50-Lx", "fnn-w25-Lx")
    assert sorted(p.name for p in (out / "runs").iterdir()) == ["fnn-w25-Lx", "fnn-w50-Lx"]
    assert (out / "runs" / "fnn-w50-Lx" / "eval" / "prep1.test" / "metrics.json").is_file()

    # restart: one finished run kept, one removed; sent to a scheduler started here
    kept = out / "runs" / "fnn-w50-Lx" / "model.pt"
    mtime = kept.stat().st_mtime_ns
    import shutil

    shutil.rmtree(out / "runs" / "fnn-w25-Lx")
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None,
                      scheduler_kwargs={"dashboard_address": "127.0.0.1:0"}) as cluster:
        res = runner.invoke(app, ["sweep", str(path), "--out", str(out), "--scheduler",
                                  cluster.scheduler_address, "--json"])
    assert res.exit_code == 2, res.output
    result = json.loads(res.stdout)
    assert result["where"] == f"Dask scheduler {cluster.scheduler_address}"
    assert result["n_skipped"] == 1 and result["n_ok"] == 2 and result["n_failed"] == 2
    assert kept.stat().st_mtime_ns == mtime
    assert (out / "runs" / "fnn-w25-Lx" / "model.pt").is_file()


def _slow_double(x: int, marker: str | None = None) -> int:
    if not x:  # the long task: it would leave a mark when it finished
        time.sleep(60)
        if marker:
            Path(marker).write_text("finished")
    if x == 2:
        raise ValueError("two\nis bad")
    return 2 * x


def _long_or_short(spec: tuple[int, str]) -> int:
    return _slow_double(*spec)


@pytest.mark.slow
def test_map_tasks_reports_failures_and_stops_on_interrupt(tmp_path: Path):
    results = list(map_tasks(_slow_double, [1, 2, 3], workers=0))
    assert [(r.ok, r.value, r.error) for r in results] == [
        (True, 2, None), (False, None, "ValueError: two"), (True, 6, None)]
    seen, got = [], []

    def on_progress(c) -> None:
        seen.append(c)
        if c.done:
            interrupt.request()

    marker = tmp_path / "long-task-finished"
    try:
        with pytest.raises(Interrupted):
            for r in map_tasks(_long_or_short, [(1, str(marker)), (0, str(marker))],
                               workers=1, on_progress=on_progress):
                got.append(r.key)
    finally:
        interrupt.clear()
    # the short task's result came back, then the stop: the long task was not waited for
    # (its worker was stopped before it could finish and leave its mark)
    assert got == ["task-0"] and not marker.exists()
    assert seen[0].total == 2 and seen[0].running == 1


def test_channel_sets_by_name():
    """A list of paper 001's configuration names stands for those sets, in that order."""
    cfg = SweepConfig.model_validate(_sweep(channel_sets=["LzRz", "Lx"]))
    assert cfg.channel_sets == {"LzRz": ["L_z", "R_z"], "Lx": ["L_x"]}
    with pytest.raises(ValueError, match="unknown channel configuration"):
        SweepConfig.model_validate(_sweep(channel_sets=["L3R3", "L9"]))
    assert list(load_sweep(CONFIGS / "sweep_vibro.yaml").channel_sets) == [
        "L3R3", "L3", "LxRx", "Lx", "LyRy", "Ly", "LzRz", "Lz"]


def _tree(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file()}


def _one_run_sweep(tmp_path: Path, vibro, **changes) -> Path:
    train, test = vibro
    raw = _sweep(train_data=[str(train)], eval={"data": [str(test)], "split": "test"},
                 models={"fnn": {"config": str(CONFIGS / "train_fnn_vibro.yaml"),
                                 "overrides": {"model.hidden": [8]}}},
                 windows=[{"window": 50, "stride": 50}], channel_sets={"Lx": ["L_x"]},
                 targets={})
    raw.update(changes)
    path = tmp_path / "sweep.yaml"
    path.write_text(yaml.safe_dump(raw, sort_keys=False))
    return path


@pytest.mark.slow
def test_an_interrupted_overwrite_keeps_the_earlier_sweep_and_a_restart_resumes(
        vibro, tmp_path: Path, monkeypatch):
    """Issue 33, item 3: the new sweep is built beside the old one, which is replaced only
    when the new one is complete; a stopped one resumes there and skips its finished run."""
    from tactile_cli.learn import sweep as sweep_module

    path = _one_run_sweep(tmp_path, vibro)
    out = tmp_path / "sw"
    argv = ["sweep", str(path), "--out", str(out), "--workers", "0", "--no-progress"]
    assert runner.invoke(app, argv).exit_code == 0
    before = _tree(out)
    real = sweep_module.run_one

    def then_ctrl_c(spec):
        value = real(spec)
        interrupt.request()  # what the CLI's SIGINT handler does
        return value

    monkeypatch.setattr(sweep_module, "run_one", then_ctrl_c)
    res = runner.invoke(app, [*argv, "--overwrite"])
    assert res.exit_code == 130, res.output
    assert res.stderr.strip().splitlines()[-1] == (
        "tactile: error: interrupted; no output was written and earlier outputs are intact")
    assert _tree(out) == before  # eval/, history.csv, run.json, sweep.json: all as they were
    partial = sweep_module.partial_dir(out)
    assert (partial / "runs" / "fnn-w50-Lx" / "run.json").is_file()
    assert not [p for p in partial.rglob(".*") if ".tmp-" in p.name]
    monkeypatch.setattr(sweep_module, "run_one", real)
    res = runner.invoke(app, [*argv, "--overwrite", "--json"])
    assert res.exit_code == 0, res.output
    result = json.loads(res.stdout)
    assert result["n_skipped"] == 1 and result["out_dir"] == str(out)
    assert not partial.exists() and _tree(out) != before
    assert json.loads((out / "sweep_results.json").read_text())["out_dir"] == str(out)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sw", "sweep.yaml"]
    metrics = next((out / "runs" / "fnn-w50-Lx" / "eval").glob("*/metrics.json"))
    assert json.loads(metrics.read_text())["run"] == str((out / "runs" / "fnn-w50-Lx").resolve())


@pytest.mark.slow
def test_a_sweep_whose_every_run_failed_exits_2_with_its_table(vibro, tmp_path: Path):
    path = _one_run_sweep(tmp_path, vibro, windows=[{"window": 1_000_000, "stride": 50}])
    res = runner.invoke(app, ["sweep", str(path), "--out", str(tmp_path / "sw"), "--workers",
                              "0", "--no-progress"])
    assert res.exit_code == 2, res.output
    assert "0 ok (0 finished before), 1 failed, 0 n/a" in res.stdout
    assert "failed" in (tmp_path / "sw" / "table.md").read_text()


def test_a_grid_whose_every_channel_set_the_data_lacks_is_refused_before_any_work(
        vibro, tmp_path: Path):
    """When every run of the grid names a channel the training data lacks, no run could
    train: one line naming the set and the channels there are, nothing written (a grid
    with one good set runs it and lists the bad one as failed: the cluster test above)."""
    path = _one_run_sweep(tmp_path, vibro, channel_sets={"bad": ["Q_x"]})
    res = runner.invoke(app, ["sweep", str(path), "--out", str(tmp_path / "sw"), "--workers",
                              "0", "--no-progress"])
    assert res.exit_code == 2, res.output
    line = res.stderr.strip()
    assert len(line.splitlines()) == 1 and "Traceback" not in res.output
    assert "channel_sets.bad: 'Q_x' is not a channel of stream" in line and "L_x" in line
    assert not (tmp_path / "sw").exists()


@pytest.mark.slow
@pytest.mark.parametrize("text", ["a: " + "[" * 50_000 + "]" * 50_000 + "\n",
                                  "".join(f"{' ' * i}k{i}:\n" for i in range(1500))])
def test_a_sweep_file_nested_too_deep_is_one_line(tmp_path: Path, text: str):
    path = tmp_path / "sweep.yaml"
    path.write_text(text)
    res = runner.invoke(app, ["sweep", str(path), "--out", str(tmp_path / "sw")])
    assert res.exit_code == 2 and "Traceback" not in res.output
    assert len(res.stderr.strip().splitlines()) == 1 and str(path) in res.stderr
    assert not (tmp_path / "sw").exists()


def test_a_sweep_output_holding_its_inputs_or_unwritable_is_refused(vibro, tmp_path: Path,
                                                                    monkeypatch):
    import errno
    import os

    from tactile_cli.store import atomic

    path = _one_run_sweep(tmp_path, vibro)
    before = _tree(tmp_path)
    for out in (tmp_path, path):
        res = runner.invoke(app, ["sweep", str(path), "--out", str(out), "--overwrite",
                                  "--workers", "0"])
        assert res.exit_code == 2 and len(res.stderr.strip().splitlines()) == 1, res.output
    assert "--out contains the input" in res.stderr or "is a file" in res.stderr
    res = runner.invoke(app, ["sweep", str(path), "--out", str(tmp_path / "sw"), "--workers",
                              "4096"])
    assert res.exit_code == 2 and "--workers (=4096) must be a whole number" in res.stderr
    real_open = os.open

    def refuse(p, flags, *args):
        if ".tactile-probe" in str(p):
            raise PermissionError(errno.EACCES, "Permission denied", str(p))
        return real_open(p, flags, *args)

    monkeypatch.setattr(atomic.os, "open", refuse)
    res = runner.invoke(app, ["sweep", str(path), "--out", str(tmp_path / "sw"), "--workers",
                              "0"])
    assert res.exit_code == 2 and "cannot write in this folder" in res.stderr, res.output
    assert _tree(tmp_path) == before
