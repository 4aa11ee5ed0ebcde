"""The Dask layer under faults (issue 18, items 3-4): a worker killed in the middle of a
task, and a scheduler with workers started as separate processes, as a cluster would."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tactile_cli.batch import map_tasks
from tactile_cli.errors import InputError
from tactile_cli.natural import natural_key
from tactile_cli.store.outdir import output_folder


def _write_or_die(spec: dict) -> str:
    """Build folder ``spec["out"]`` atomically; half-way through, kill this worker process
    (SIGKILL: no clean-up runs) on the first attempt (``once``) or on every one."""
    out, marker = Path(spec["out"]), Path(spec["marker"])
    with output_folder(out, overwrite=True) as tmp:
        (tmp / "first_half.txt").write_text("half")
        if spec["die"] == "always" or (spec["die"] == "once" and not marker.exists()):
            marker.touch()
            os.kill(os.getpid(), signal.SIGKILL)
        (tmp / "second_half.txt").write_text("done")
    return out.name


def _specs(root: Path, dies: dict[str, str]) -> list[dict]:
    return [{"out": str(root / name), "marker": str(root / f"{name}.marker"), "die": die}
            for name, die in dies.items()]


@pytest.mark.slow
def test_a_killed_worker_is_replaced_its_task_rerun_and_nothing_half_written(tmp_path):
    dies = {"once": "once", "never": "never", "always": "always"}
    results = {r.key: r for r in map_tasks(_write_or_die, _specs(tmp_path, dies),
                                            keys=list(dies), workers=2, retries=1)}
    # killed once: run again on a fresh worker and complete
    assert results["once"].ok and results["once"].value == "once"
    assert sorted(p.name for p in (tmp_path / "once").iterdir()) == ["first_half.txt",
                                                                     "second_half.txt"]
    assert results["never"].ok
    # killed on every attempt: reported, nothing under its name, the others finished
    assert not results["always"].ok
    assert "died every time it ran" in results["always"].error
    assert not (tmp_path / "always").exists()
    # its half-built temporaries (dead pids) go on the next write of that output
    assert list(tmp_path.glob(".always.tmp-*"))
    again = list(map_tasks(_write_or_die, _specs(tmp_path, {"always": "never"}),
                           keys=["always"], workers=0))
    assert again[0].ok and (tmp_path / "always" / "second_half.txt").is_file()
    assert not list(tmp_path.glob(".*.tmp-*"))


def test_negative_retries_are_refused():
    with pytest.raises(InputError, match="`retries`"):
        list(map_tasks(natural_key, ["a"], workers=1, retries=-1))


@pytest.mark.slow
def test_a_scheduler_and_a_worker_started_as_separate_processes(tmp_path):
    """The `scheduler` path end to end: `dask scheduler` and `dask worker` as their own
    processes on the loopback address, found through the scheduler file."""
    dask_cli = Path(sys.executable).with_name("dask")
    if not dask_cli.exists():
        pytest.skip("the dask command is not installed beside this Python")
    sched_file = tmp_path / "scheduler.json"
    quiet = {"stdout": subprocess.DEVNULL, "stderr": subprocess.DEVNULL}
    procs = [subprocess.Popen([str(dask_cli), "scheduler", "--host", "127.0.0.1", "--port",
                               "0", "--no-dashboard", "--scheduler-file", str(sched_file)],
                              **quiet)]
    try:
        deadline = time.monotonic() + 60
        while not sched_file.exists() and time.monotonic() < deadline:
            time.sleep(0.2)
        address = json.loads(sched_file.read_text())["address"]
        assert address.startswith("tcp://127.0.0.1:")
        procs.append(subprocess.Popen([str(dask_cli), "worker", "--scheduler-file",
                                       str(sched_file), "--nthreads", "1", "--nworkers", "1",
                                       "--no-dashboard", "--host", "127.0.0.1"], **quiet))
        names = ["mat10", "mat2", "mat1"]
        results = sorted(map_tasks(natural_key, names, scheduler=address), key=lambda r: r.index)
        assert [r.value for r in results] == [natural_key(n) for n in names]
        assert all(r.ok for r in results)
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()
