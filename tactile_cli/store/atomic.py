"""The one atomic writer for single files (bytes, text, JSON, CSV, figures): a hidden
temporary file beside the target, renamed over it only when complete.

Every output of the toolkit is written this way or through :mod:`.outdir` (folders),
:class:`~tactile_cli.store.StoreWriter` (new HDF5 files) or
:class:`~tactile_cli.store.update.DerivedUpdate` (``/derived`` groups of an existing file),
which share this module's pieces:

- the temporary name ``.<name>.tmp-<pid>[.ext]`` (``.gitignore`` and the stale-file sweep
  know it), registered in :data:`LIVE_TEMPORARIES` before it exists, so the CLI's interrupt
  handling removes it whatever the moment of the signal;
- :func:`check_output_file`: before any work, a file output is refused when it is a folder,
  exists without ``overwrite``, has no folder, cannot be written (a probe file is created
  and removed: read-only mounts, immutable folders) or overlaps an input
  (:mod:`.input_guard`);
- :func:`swap_into_place`: the finished result replaces the target in one rename; an old
  target is replaced only then, so an error or interrupt leaves it byte-identical;
- a failure of the file system while writing (disk full, permission) is one
  :class:`InputError` naming the output, and nothing is left behind.

Only ``store/`` renames files into place (``tests/store/test_atomic.py`` checks the source).
"""

from __future__ import annotations

import errno
import json
import os
import shutil
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from ..errors import InputError
from ..input_guard import refuse_overlap
from ..interrupt import raise_if_requested

#: Temporary files and folders of writers in this process that are neither committed nor
#: aborted yet. A signal can arrive between a writer's constructor and its ``with`` block,
#: where no cleanup code runs; the CLI removes whatever is left here when interrupted.
LIVE_TEMPORARIES: set[Path] = set()

#: errno values that mean "this place cannot be written", reported as one line
_WRITE_ERRNOS = {errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EPERM,
                 errno.EIO, errno.EFBIG, errno.ENAMETOOLONG, errno.EMFILE}


def remove(path: Path) -> None:
    """Delete a file, link or folder tree if it is there."""
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        path.unlink(missing_ok=True)


def remove_live_temporaries() -> None:
    """Delete the temporary files and folders of every unfinished writer of this process."""
    for tmp in list(LIVE_TEMPORARIES):
        remove(tmp)
        LIVE_TEMPORARIES.discard(tmp)


def process_alive(pid: int) -> bool:
    """Whether process ``pid`` is running. A killed process its parent has not yet reaped (a
    zombie, Linux ``/proc/<pid>/stat`` state Z) is dead: it writes nothing any more."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # alive, owned by someone else
        return True
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:  # no /proc (not Linux), or it just went
        return True
    return stat.rpartition(")")[2].split()[:1] != ["Z"]


def _named(out: Path) -> Path:
    """``out``, or for ``.`` and ``..`` the absolute path of that folder: its temporary
    siblings go beside it, under its own name."""
    return Path(os.path.abspath(out)) if out.name in ("", ".", "..") else out


def temporary_path(out: Path, *, kind: str = "tmp", keep_suffix: bool = False) -> Path:
    """``.<name>.<kind>-<pid>`` beside ``out`` (``kind``: ``tmp`` for results being built,
    ``old`` for a replaced target on its way out); ``keep_suffix`` appends ``out``'s suffix
    for libraries that choose a format by it."""
    out = _named(out)
    suffix = out.suffix if keep_suffix else ""
    return out.with_name(f".{out.name}.{kind}-{os.getpid()}{suffix}")


def remove_stale_temporaries(out: Path) -> None:
    """Delete temporary siblings of ``out`` left by killed writers (SIGKILL, power loss):
    ``.<name>.tmp-<pid>[.ext]`` and ``.<name>.old-<pid>`` whose process is gone."""
    out = _named(Path(out))
    prefix = f".{out.name}."
    try:
        siblings = list(out.parent.glob(f".{out.name}.*-*"))
    except OSError:
        return
    for tmp in siblings:
        rest = tmp.name[len(prefix):]
        kind, sep, tail = rest.partition("-")
        pid = tail.split(".", 1)[0]
        if sep and kind in ("tmp", "old") and pid.isdigit() and not process_alive(int(pid)):
            remove(tmp)


def _nearest_existing(path: Path) -> Path:
    for p in [path, *path.parents]:
        if p.exists():
            return p
    return Path(".")


def _immutable(path: Path) -> bool:
    """Whether Linux marks ``path`` immutable or append-only (``chattr +i`` / ``+a``)."""
    try:
        import array
        import fcntl
    except ImportError:  # pragma: no cover - not on Linux
        return False
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    except OSError:
        return False
    try:
        flags = array.array("l", [0])
        fcntl.ioctl(fd, 0x80086601, flags)  # FS_IOC_GETFLAGS
        return bool(flags[0] & 0x30)  # FS_IMMUTABLE_FL | FS_APPEND_FL
    except OSError:
        return False
    finally:
        os.close(fd)


def check_writable(out: str | Path) -> Path:
    """Refuse, with one :class:`InputError`, an output that cannot be written: the nearest
    existing folder at or above it refuses a new file (a probe file is made and removed),
    or an existing ``out`` is immutable. Returns ``out`` as a Path."""
    out = Path(out)
    if out.exists() and _immutable(out):
        raise InputError("cannot be replaced (the file system marks it immutable); "
                         "give another output", path=out)
    folder = _nearest_existing(out.parent)
    if not folder.is_dir():
        return out  # a file where a folder is needed: the callers say so in their words
    probe = folder / f".tactile-probe.tmp-{os.getpid()}"
    try:
        fd = os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    except FileExistsError:
        return out
    except OSError as exc:
        reason = exc.strerror or exc.__class__.__name__
        raise InputError(f"cannot write in this folder ({reason}); give an output in a "
                         "folder you can write to", path=folder) from None
    os.close(fd)
    probe.unlink(missing_ok=True)
    return out


def check_output_file(out: str | Path, *, overwrite: bool = False) -> Path:
    """Refuse, with one :class:`InputError`, an output file that cannot be written: ``out``
    is a folder, exists (unless ``overwrite``), its parent folder is missing or a file, it
    cannot be written, or it overlaps an input of the current command. Returns ``out``."""
    out = Path(out)
    if out.is_dir():
        raise InputError("is a folder; give a file name for the output", path=out)
    refuse_overlap(out)
    if out.exists() and not overwrite:
        raise InputError("output exists; pass `overwrite=True` to replace it", path=out)
    if out.parent.exists() and not out.parent.is_dir():
        raise InputError("is a file, not a folder; give an output path in a folder",
                         path=out.parent)
    if not out.parent.exists():
        raise InputError("output folder does not exist", path=out.parent)
    return check_writable(out)


def write_error(exc: OSError, out: Path) -> InputError:
    """The one-line error for a file-system failure while writing ``out``."""
    reason = exc.strerror or exc.__class__.__name__
    return InputError(f"cannot write the output ({reason}); nothing was written", path=out)


def _is_write_failure(exc: OSError, tmp: Path) -> bool:
    if exc.errno not in _WRITE_ERRNOS:
        return False
    names = {str(n) for n in (exc.filename, exc.filename2) if n is not None}
    return not names or any(n.startswith(str(tmp)) or n == str(tmp.parent) for n in names)


def swap_into_place(new: Path, dest: Path) -> None:
    """Rename finished ``new`` (file or folder) to ``dest`` at the last moment. An existing
    ``dest`` is renamed aside first (put back if the second rename fails), then deleted, so
    at every instant ``dest`` is either the old result or the new one."""
    raise_if_requested()
    refuse_overlap(dest)
    try:
        if not (dest.exists() or dest.is_symlink()):
            os.replace(new, dest)
            return
        if new.is_dir() == dest.is_dir() and not new.is_dir():
            os.replace(new, dest)  # a file over a file: one atomic rename
            return
        old = temporary_path(dest, kind="old")
        remove(old)
        os.replace(dest, old)
        try:
            os.replace(new, dest)
        except BaseException:
            os.replace(old, dest)
            raise
        remove(old)
    except OSError as exc:
        if exc.errno in _WRITE_ERRNOS:
            raise write_error(exc, dest) from None
        raise


@contextmanager
def atomic_file(out: str | Path, *, overwrite: bool = False,
                keep_suffix: bool = False) -> Iterator[Path]:
    """Build file ``out`` at a temporary path (yielded) and rename it into place when the
    block ends without an error; see the module docstring. ``overwrite``: replace an
    existing ``out`` (only at the end). ``keep_suffix``: the temporary path ends in
    ``out``'s suffix (for writers that pick a format by it)."""
    out = check_output_file(out, overwrite=overwrite)
    tmp = temporary_path(out, keep_suffix=keep_suffix)
    LIVE_TEMPORARIES.add(tmp)  # registered before it exists: no unguarded window
    try:
        remove_stale_temporaries(out)
        remove(tmp)
        try:
            yield tmp
        except OSError as exc:
            if _is_write_failure(exc, tmp):
                raise write_error(exc, out) from None
            raise
        if not tmp.exists():
            raise RuntimeError(f"nothing was written to the temporary file of {out}")
        if out.exists() and not overwrite:  # appeared while we worked
            raise InputError("output exists; pass `overwrite=True` to replace it", path=out)
        swap_into_place(tmp, out)
    finally:
        remove(tmp)
        LIVE_TEMPORARIES.discard(tmp)


def write_bytes(out: str | Path, data: bytes, *, overwrite: bool = False) -> Path:
    """Write ``data`` to file ``out`` atomically; returns ``out``."""
    with atomic_file(out, overwrite=overwrite) as tmp:
        tmp.write_bytes(data)
    return Path(out)


def write_text(out: str | Path, text: str, *, overwrite: bool = False) -> Path:
    """Write ``text`` (UTF-8) to file ``out`` atomically; returns ``out``."""
    return write_bytes(out, text.encode("utf-8"), overwrite=overwrite)


def write_json(out: str | Path, obj: Any, *, overwrite: bool = False, indent: int | None = 2,
               sort_keys: bool = False) -> Path:
    """Write ``obj`` as JSON (NaN and infinity refused: strict JSON) to ``out`` atomically,
    with a final newline; returns ``out``."""
    text = json.dumps(obj, indent=indent, allow_nan=False, sort_keys=sort_keys) + "\n"
    return write_text(out, text, overwrite=overwrite)


def save_figure(fig: Any, out: str | Path, *, meta: Mapping[str, str] | None = None,
                dpi: int = 100, overwrite: bool = False, close: bool = True,
                **savefig: Any) -> Path:
    """Save a matplotlib figure to ``out`` atomically (format from ``out``'s suffix, PNG
    when it has none), with ``meta`` as its text chunks; the figure is closed afterwards
    unless ``close=False``. Returns ``out``."""
    out = Path(out)
    fmt = out.suffix.lstrip(".").lower() or "png"
    try:
        with atomic_file(out, overwrite=overwrite) as tmp:
            fig.savefig(tmp, format=fmt, dpi=dpi, metadata=dict(meta or {}), **savefig)
    finally:
        if close:
            import matplotlib.pyplot as plt

            plt.close(fig)
    return out


__all__ = ["LIVE_TEMPORARIES", "atomic_file", "check_output_file", "check_writable",
           "process_alive", "remove_live_temporaries", "remove_stale_temporaries",
           "save_figure", "swap_into_place", "temporary_path", "write_bytes", "write_error",
           "write_json", "write_text"]
