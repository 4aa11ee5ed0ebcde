"""Where a task runs does not change its numbers (issue 30): a local Dask worker gets one
BLAS and one OpenMP thread from distributed's environment, and a task run in this process
(``workers=0``) gets the same limits for its duration."""

from __future__ import annotations

from threadpoolctl import threadpool_info, threadpool_limits

from tactile_cli.batch import map_tasks


def _thread_counts(spec: int) -> dict[str, list[int]]:
    """The thread counts of the BLAS and OpenMP libraries loaded where the task runs."""
    out: dict[str, list[int]] = {}
    for lib in threadpool_info():
        out.setdefault(lib["user_api"], []).append(lib["num_threads"])
    return out


def test_a_task_in_this_process_runs_one_threaded_as_on_a_worker():
    with threadpool_limits(limits=2):
        before = _thread_counts(0)
        results = list(map_tasks(_thread_counts, [0, 1], workers=0))
        assert [r.ok for r in results] == [True, True]
        for r in results:
            assert {api: set(n) for api, n in r.value.items()} == {
                api: {1} for api in before}
        assert _thread_counts(0) == before  # given back after each task
