"""Add derived results (fits, features, predictions) to an existing tactile HDF5 file safely.

A later command (``tactile fit-fos``, ...) writes its results into ``/derived/{kind}/{name}``
of the file it read. HDF5 has no transactions, and a process killed half-way through an
in-place write can leave the whole file unreadable, so the file is never written in place:

1. the file is copied to a hidden temporary ``.<name>.tmp-<pid>`` in the same folder
   (registered with the writer's live temporaries, so Ctrl-C in the CLI removes it);
2. the copy is opened ``r+`` and the new groups, with their provenance attributes
   (``command``, ``tool_version``, ``created_utc``, ``config_json``, ``inputs_json``), are
   written into it;
3. the whole copy is validated against the schema, flushed to disk (fsync) and renamed over
   the original in one ``os.replace``.

On any error or interrupt the temporary file is deleted and the original is untouched (byte
for byte). An existing group is only replaced with ``overwrite=True``; replacing unlinks the
old group in the copy (HDF5 does not shrink the file for the freed space, which `h5repack`
reclaims if it matters).
"""

from __future__ import annotations

import json
import os
from collections.abc import Collection, Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any, TypeAlias

import h5py
import numpy as np

from .._version import __version__
from ..errors import InputError
from ..interrupt import raise_if_requested
from .atomic import LIVE_TEMPORARIES, check_writable, remove_stale_temporaries, temporary_path
from .provenance import current_command, utc_now
from .spec import load_spec
from .validate import check_readable
from .writer import _STR, safe_name, validate_and_swap

#: Bytes per block when copying the file (the copy checks for an interrupt between blocks).
COPY_BLOCK = 1 << 24
#: A writable ``/derived/{kind}/{name}`` group, as :meth:`DerivedUpdate.group` hands it out
#: (fill it with :func:`write_columns`, so callers outside ``store/`` need no h5py).
DerivedGroup: TypeAlias = h5py.Group


def derived_path(kind: str, name: str) -> str:
    """The HDF5 path ``/derived/{kind}/{name}``."""
    return f"/derived/{kind}/{name}"


def write_columns(
    group: DerivedGroup,
    columns: Mapping[str, np.ndarray | Sequence[Any]],
    *,
    strings: Collection[str] = (),
    attrs: Mapping[str, Any] | None = None,
) -> None:
    """Write ``columns`` as datasets of ``group`` (e.g. from :meth:`DerivedUpdate.group`),
    in the mapping's order, then set ``attrs`` on the group.

    Columns named in ``strings`` are stored with HDF5's variable-length UTF-8 string dtype
    (what :meth:`TactileFile.derived <tactile_cli.store.trials.TactileFile.derived>` decodes
    with ``strings=``); the others with their numpy dtype.
    """
    for key, values in columns.items():
        if key in strings:
            group.create_dataset(key, data=np.asarray(values, dtype=object), dtype=_STR)
        else:
            group.create_dataset(key, data=values)
    for key, value in (attrs or {}).items():
        group.attrs[key] = value


def check_derived_targets(
    path: str | Path, targets: Sequence[tuple[str, str]], *, overwrite: bool = False
) -> None:
    """Raise :class:`InputError` unless every ``(kind, name)`` group can be written to ``path``.

    Checks that the file exists, is a readable tactile file of this major version, that
    ``kind`` is one the schema allows (fits, features, predictions), that ``name`` is a
    valid link name, and that no group of that name exists unless ``overwrite``. Cheap: run
    it before the heavy work so that a refused write fails fast.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError("file not found", path=path)
    kinds = tuple(load_spec().enums["derived_kind"])
    for kind, name in targets:
        if kind not in kinds:
            raise ValueError(f"`kind` (={kind!r}) must be one of {kinds}.")
        if safe_name(name) != name:
            raise ValueError(f"`name` (={name!r}) must use only letters, digits and _ . -")
    try:
        check_readable(path)
        with h5py.File(path, "r") as h5:
            existing = [derived_path(k, n) for k, n in targets if derived_path(k, n) in h5]
    except OSError as exc:
        raise InputError(f"not a readable HDF5 file ({exc})", path=path) from None
    if existing and not overwrite:
        raise InputError(
            f"{existing[0]} exists already; pass `overwrite=True` to replace it", path=path
        )


class DerivedUpdate:
    """Write new ``/derived`` groups into a copy of a tactile file, then swap it in.

    Use as a context manager and call :meth:`commit`; leaving the block without it (or by
    an exception) removes the copy and leaves the original as it was::

        with DerivedUpdate(path, [("fits", "fos_press")], config={...}, inputs={...}) as up:
            g = up.group("fits", "fos_press")
            g.create_dataset("alpha", data=alpha)
            up.commit()

    Parameters
    ----------
    path:
        An existing tactile HDF5 file.
    targets:
        The ``(kind, name)`` groups this update creates, checked before anything is copied
        (see :func:`check_derived_targets`).
    command:
        The command line recorded on each group; default: this process's command line.
    config, inputs:
        JSON-ready mappings recorded as ``config_json`` / ``inputs_json`` on each group.
    overwrite:
        Replace groups that exist already (otherwise that is an :class:`InputError`).
    """

    def __init__(
        self,
        path: str | Path,
        targets: Sequence[tuple[str, str]],
        *,
        command: str | None = None,
        config: Mapping[str, Any] | None = None,
        inputs: Mapping[str, Any] | None = None,
        overwrite: bool = False,
    ):
        self.path = Path(path)
        self.targets = [(str(k), str(n)) for k, n in targets]
        if not self.targets:
            raise ValueError("`targets` is empty: name at least one (kind, name) group.")
        check_derived_targets(self.path, self.targets, overwrite=overwrite)
        self.attrs = {
            "command": command if command is not None else current_command(),
            "tool_version": __version__,
            "created_utc": utc_now(),
        }
        if config is not None:
            self.attrs["config_json"] = json.dumps(config, sort_keys=True, default=str)
        if inputs is not None:
            self.attrs["inputs_json"] = json.dumps(inputs, sort_keys=True, default=str)
        check_writable(self.path)
        self.tmp = temporary_path(self.path)
        self._groups: dict[tuple[str, str], h5py.Group] = {}
        self._committed = False
        remove_stale_temporaries(self.path)
        LIVE_TEMPORARIES.add(self.tmp)  # registered before it exists: no unguarded window
        self._h5: h5py.File | None = None
        try:
            self._copy()
            self._h5 = h5py.File(self.tmp, "r+")
            for kind, name in self.targets:
                where = derived_path(kind, name)
                if where in self._h5:
                    del self._h5[where]
                group = self._h5.require_group(f"/derived/{kind}").create_group(name)
                for key, value in self.attrs.items():
                    group.attrs[key] = value
                self._groups[(kind, name)] = group
        except BaseException:
            self.abort()
            raise

    def _copy(self) -> None:
        with open(self.path, "rb") as src, open(self.tmp, "wb") as dst:
            while block := src.read(COPY_BLOCK):
                raise_if_requested()
                dst.write(block)
        os.chmod(self.tmp, os.stat(self.path).st_mode & 0o7777)

    def __enter__(self) -> DerivedUpdate:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if not self._committed:
            self.abort()

    def group(self, kind: str, name: str) -> DerivedGroup:
        """The new (empty, provenance-stamped) group ``/derived/{kind}/{name}`` of the copy."""
        if (kind, name) not in self._groups:
            raise KeyError(f"({kind!r}, {name!r}) is not a target of this update; targets: "
                           f"{self.targets}")
        return self._groups[(kind, name)]

    def abort(self) -> None:
        """Close and delete the copy; the original file is not touched."""
        if self._h5 is not None:
            try:
                self._h5.close()
            finally:
                self._h5 = None
        self.tmp.unlink(missing_ok=True)
        LIVE_TEMPORARIES.discard(self.tmp)

    def commit(self) -> Path:
        """Close and validate the copy, then rename it over the original; returns the path."""
        raise_if_requested()
        if self._h5 is None:
            raise RuntimeError("the update is closed")
        self._h5.close()
        self._h5 = None
        validate_and_swap(self.tmp, self.path,
                          breaks=f"{self.path}: the updated file would break the schema",
                          outcome="the file was left unchanged", in_place=True)
        self._committed = True
        return self.path


@contextmanager
def update_derived(
    path: str | Path,
    kind: str,
    name: str,
    *,
    command: str | None = None,
    config: Mapping[str, Any] | None = None,
    inputs: Mapping[str, Any] | None = None,
    overwrite: bool = False,
) -> Iterator[h5py.Group]:
    """Yield the new group ``/derived/{kind}/{name}`` of a copy of ``path``; on a normal exit
    validate the copy and swap it in, on an exception discard it (see :class:`DerivedUpdate`).

    An existing group of that name without ``overwrite`` raises :class:`InputError` naming
    the file and the HDF5 path (before anything is copied).
    """
    with DerivedUpdate(path, [(kind, name)], command=command, config=config, inputs=inputs,
                       overwrite=overwrite) as update:
        yield update.group(kind, name)
        update.commit()
