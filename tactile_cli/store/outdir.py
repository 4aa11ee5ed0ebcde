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

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from ..errors import InputError
from ..input_guard import refuse_overlap
from ..interrupt import raise_if_requested
from .atomic import (
    LIVE_TEMPORARIES,
    check_writable,
    remove,
    remove_stale_temporaries,
    swap_into_place,
    temporary_path,
)


def _file_ancestor(path: Path) -> Path | None:
    """The nearest existing ancestor of ``path`` that is not a folder, if any."""
    for parent in path.parents:
        if parent.exists():
            return None if parent.is_dir() else parent
    return None


def check_output_folder(out: str | Path, *, overwrite: bool = False,
                        merge: bool = False) -> Path:
    """Refuse, with one :class:`InputError`, an output folder that cannot be written:
    ``out`` is a file, a parent of it is a file, (unless ``overwrite`` or ``merge``) ``out``
    is a folder that is not empty, it overlaps an input of the current command (see
    :mod:`.input_guard`), or its folder cannot be written. Returns ``out`` as a Path."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InputError("is a file; give a folder for the output", path=out)
    blocker = _file_ancestor(out)
    if blocker is not None:
        raise InputError(f"is a file, so the output folder {out} cannot be made inside it; "
                         "give another folder", path=blocker)
    refuse_overlap(out)
    if not (overwrite or merge) and out.is_dir() and any(out.iterdir()):
        raise InputError("output folder exists and is not empty; pass `overwrite=True` to "
                         "replace it", path=out)
    check_writable(out)
    return out


def temporary_name(out: Path) -> Path:
    """The hidden temporary folder of ``out`` for this process."""
    return temporary_path(out)


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


def _move_into_place(tmp: Path, out: Path, *, overwrite: bool, merge: bool) -> None:
    if merge and out.is_dir():  # entry by entry, never over the folder (it may be `.`)
        for entry in sorted(tmp.iterdir()):
            swap_into_place(entry, out / entry.name)
        tmp.rmdir()
    elif not out.exists() or (out.is_dir() and not any(out.iterdir())):
        swap_into_place(tmp, out)
    elif overwrite:
        swap_into_place(tmp, out)
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
    LIVE_TEMPORARIES.add(tmp)  # registered before it exists: no unguarded window
    try:
        remove_stale_temporaries(out)
        remove(tmp)
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
        remove(tmp)
        for folder in reversed(created):
            try:
                folder.rmdir()
            except OSError:  # not empty: someone else wrote there meanwhile
                break
        raise
    finally:
        LIVE_TEMPORARIES.discard(tmp)
