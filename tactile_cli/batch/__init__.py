"""Running many independent tasks at once on Dask: the execution layer of ``tactile sweep``.

The only package that imports dask and distributed (issue 14, item 4; the foundation of
issue 18). It knows nothing of tactile data: it maps a picklable function over picklable
task specs (paths and plain dicts) on a ``distributed`` cluster, a local one over this
machine's cores or an existing one at a scheduler address, and yields one
:class:`TaskResult` per task as they finish; a task that raises is a failed result with its
one-line message and never stops the others. See :mod:`._dask`.

On top of it, :func:`run_each` runs a file-to-file step over many inputs (one
:class:`FileItem` per input, planned and skipped by the caller, filled in as tasks finish):
the shape of ``tactile ingest --out-dir``, ``tactile fit-fos`` over several files and
``tactile evaluate --each``. See :mod:`._files`.
"""

from ._dask import SCHEDULER_ENV as SCHEDULER_ENV
from ._dask import BatchCounts as BatchCounts
from ._dask import TaskResult as TaskResult
from ._dask import default_workers as default_workers
from ._dask import map_tasks as map_tasks
from ._dask import one_line as one_line
from ._files import FileBatchResult as FileBatchResult
from ._files import FileCounts as FileCounts
from ._files import FileItem as FileItem
from ._files import newest_mtime as newest_mtime
from ._files import plan_outputs as plan_outputs
from ._files import run_each as run_each

__all__ = ["SCHEDULER_ENV", "BatchCounts", "FileBatchResult", "FileCounts", "FileItem",
           "TaskResult", "default_workers", "map_tasks", "newest_mtime", "one_line", "plan_outputs",
           "run_each"]
