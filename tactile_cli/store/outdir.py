"""Output folders built atomically: a hidden temporary folder beside the target, renamed
into place on success.

Files already go through :class:`~tactile_cli.store.StoreWriter` (temporary file, rename);
this module does the same for folders (figures, frames, run and evaluation folders, scene
and sample folders)::

    check_output_folder(out, overwrite=overwrite)   # before any work: one InputError
    ...read and check the inputs...
    with output_folder(out, overwrite=overwrite) as tmp:
        write_everything_into(tmp)
    # out is complete, or (error, Ctrl-C) untouched and no temporary folder is left

The temporary folder is ``.<name>.tmp-<pid>`` beside the target. While it exists it is
registered with the store's live temporaries, so the CLI's interrupt handling removes it
even when a second signal lands outside the ``with`` block's cleanup.

Two ways of putting the result in place:

- replace (default): the finished folder becomes ``out``. An existing non-empty ``out`` is
  an error unless ``overwrite``; then the old folder is renamed aside, the new one renamed
  in and the old one deleted.
- merge (``merge=True``, for commands that add to a folder: one subfolder per trial, one
  evaluation per name): each entry of the finished folder replaces the entry of the same
  name in ``out`` (the same rename-aside swap); other entries of ``out`` are kept. The
  command decides beforehand which existing entries it may replace.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from ..errors import InputError
from ..interrupt import raise_if_requested
from .writer import _LIVE_TEMPORARIES, process_alive


def _file_ancestor(path: Path) -> Path | None:
    """The nearest existing ancestor of ``path`` that is not a folder, if any."""
    for parent in path.parents:
        if parent.exists():
            return None if parent.is_dir() else parent
    return None


def check_output_folder(out: str | Path, *, overwrite: bool = False,
                        merge: bool = False) -> Path:
    """Refuse, with one :class:`InputError`, an output folder that cannot be written:
    ``out`` is a file, a parent of it is a file, or (unless ``overwrite`` or ``merge``)
    ``out`` is a folder that is not empty. Returns ``out`` as a Path."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InputError("is a file; give a folder for the output", path=out)
    blocker = _file_ancestor(out)
    if blocker is not None:
        raise InputError(f"is a file, so the output folder {out} cannot be made inside it; "
                         "give another folder", path=blocker)
    if not (overwrite or merge) and out.is_dir() and any(out.iterdir()):
        raise InputError("output folder exists and is not empty; pass `overwrite=True` to "
                         "replace it", path=out)
    return out


def check_output_file(out: str | Path, *, overwrite: bool = False) -> Path:
    """Refuse, with one :class:`InputError`, an output file that cannot be written: ``out``
    is a folder, exists (unless ``overwrite``), or its parent folder is missing or a file.
    Returns ``out`` as a Path."""
    out = Path(out)
    if out.is_dir():
        raise InputError("is a folder; give a file name for the output", path=out)
    if out.exists() and not overwrite:
        raise InputError("output exists; pass `overwrite=True` to replace it", path=out)
    if out.parent.exists() and not out.parent.is_dir():
        raise InputError("is a file, not a folder; give an output path in a folder",
                         path=out.parent)
    if not out.parent.exists():
        raise InputError("output folder does not exist", path=out.parent)
    return out


def temporary_name(out: Path) -> Path:
    """The hidden temporary folder of ``out`` for this process."""
    return out.with_name(f".{out.name}.tmp-{os.getpid()}")


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        path.unlink(missing_ok=True)


def _remove_stale(out: Path) -> None:
    """Delete temporary siblings of ``out`` left by killed runs (their pid is gone)."""
    for tmp in out.parent.glob(f".{out.name}.*-*"):
        kind, _, pid = tmp.name.rpartition("-")
        if pid.isdigit() and kind.endswith((".tmp", ".old")) and not process_alive(int(pid)):
            _remove(tmp)


def _make_parents(folder: Path) -> list[Path]:
    """Create ``folder`` and its missing parents; returns those created, outermost first."""
    missing = [p for p in [folder, *folder.parents] if not p.exists()][::-1]
    for p in missing:
        try:
            p.mkdir()
        except OSError as exc:
            raise InputError(f"cannot create the output's folder ({exc.strerror})",
                             path=p) from None
    return missing


def _swap(new: Path, dest: Path) -> None:
    """Rename ``new`` to ``dest``; an existing ``dest`` is renamed aside first (and put back
    if the second rename fails), then deleted."""
    if not (dest.exists() or dest.is_symlink()):
        os.replace(new, dest)
        return
    old = dest.with_name(f".{dest.name}.old-{os.getpid()}")
    _remove(old)
    os.replace(dest, old)
    try:
        os.replace(new, dest)
    except BaseException:
        os.replace(old, dest)
        raise
    _remove(old)


def _move_into_place(tmp: Path, out: Path, *, overwrite: bool, merge: bool) -> None:
    if not out.exists() or (out.is_dir() and not any(out.iterdir())):
        os.replace(tmp, out)  # rename() replaces an empty folder
    elif merge:
        for entry in sorted(tmp.iterdir()):
            _swap(entry, out / entry.name)
        tmp.rmdir()
    elif overwrite:
        _swap(tmp, out)
    else:  # appeared while we worked
        raise InputError("output folder exists and is not empty; pass `overwrite=True` to "
                         "replace it", path=out)


@contextmanager
def output_folder(out: str | Path, *, overwrite: bool = False,
                  merge: bool = False) -> Iterator[Path]:
    """Build folder ``out`` in a hidden temporary folder (yielded) and put it in place when
    the block ends without an error; see the module docstring for ``overwrite`` and
    ``merge``. An error or interrupt removes the temporary folder (and any parent folders
    this call created) and leaves an earlier ``out`` as it was."""
    out = check_output_folder(out, overwrite=overwrite, merge=merge)
    created = _make_parents(out.parent)
    tmp = temporary_name(out)
    _LIVE_TEMPORARIES.add(tmp)  # registered before it exists: no unguarded window
    try:
        _remove_stale(out)
        _remove(tmp)
        try:
            tmp.mkdir()
        except OSError as exc:
            raise InputError(f"cannot write in the output's folder ({exc.strerror})",
                             path=out.parent) from None
        yield tmp
        raise_if_requested()
        check_output_folder(out, overwrite=overwrite, merge=merge)  # changed while we worked?
        _move_into_place(tmp, out, overwrite=overwrite, merge=merge)
    except BaseException:
        _remove(tmp)
        for folder in reversed(created):
            try:
                folder.rmdir()
            except OSError:  # not empty: someone else wrote there meanwhile
                break
        raise
    finally:
        _LIVE_TEMPORARIES.discard(tmp)
