"""Running many independent tasks at once on Dask: the execution layer of ``tactile sweep``.

The only package that imports dask and distributed (issue 14, item 4; the foundation of
issue 18). It knows nothing of tactile data: it maps a picklable function over picklable
task specs (paths and plain dicts) on a ``distributed`` cluster, a local one over this
machine's cores or an existing one at a scheduler address, and yields one
:class:`TaskResult` per task as they finish; a task that raises is a failed result with its
one-line message and never stops the others. See :mod:`._dask`.
"""

from ._dask import SCHEDULER_ENV as SCHEDULER_ENV
from ._dask import BatchCounts as BatchCounts
from ._dask import TaskResult as TaskResult
from ._dask import default_workers as default_workers
from ._dask import map_tasks as map_tasks
from ._dask import one_line as one_line

__all__ = ["SCHEDULER_ENV", "BatchCounts", "TaskResult", "default_workers", "map_tasks",
           "one_line"]
