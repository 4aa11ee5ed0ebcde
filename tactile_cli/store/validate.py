"""Check an HDF5 file against the tactile schema spec and list every violation.

Structure (groups, datasets, dtypes, ranks, attributes) comes from the node rules of the
spec; content rules (equal lengths, polarity values, monotonic time, pixel ranges, the
millisecond index, finite signals, positive rates, class codes, annotation order) come from
its ``checks`` list. Large datasets are read in blocks, so a file with tens of millions of
events validates in bounded memory.

A damaged file is reported, never raised: a node or a check that cannot be read (a corrupt
chunk, a metadata checksum error, a retyped attribute) becomes one violation at its HDF5
path with the HDF5 message on one line; a file HDF5 cannot open at all is a report with
``readable=False``.
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Collection, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from .spec import NodeSpec, Spec, load_spec, pattern_to_regex

#: Elements read per block when a check scans a dataset.
BLOCK = 1 << 22
#: Checks that read every value of a dataset (skipped for datasets verified while written).
_VALUE_SCANS = frozenset({"values_in", "non_decreasing", "increasing", "finite",
                          "below_sensor_attr", "class_codes"})
#: What goes wrong when h5py reads a damaged or retyped node.
_READ_ERRORS = (OSError, RuntimeError, KeyError, ValueError, TypeError, IndexError,
                AttributeError, OverflowError)


def _flat(exc: BaseException) -> str:
    """An HDF5 or OS error message on one line."""
    return " ".join(str(exc).split()) or exc.__class__.__name__


@dataclass(frozen=True)
class Violation:
    """One way a file breaks the schema, at an HDF5 path."""

    h5_path: str
    message: str
    #: The source file the trial at ``h5_path`` was made from, when the file records it.
    source: str | None = None

    def __str__(self) -> str:
        origin = f" (from {self.source})" if self.source else ""
        return f"{self.h5_path}: {self.message}{origin}"


@dataclass
class ValidationReport:
    """Outcome of :func:`validate_file`."""

    file: str
    schema_version: str | None
    violations: list[Violation] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    #: False when the file is missing or HDF5 cannot open it (the one violation says why).
    readable: bool = True

    @property
    def ok(self) -> bool:
        return not self.violations

    def as_dict(self) -> dict[str, Any]:
        return {
            "file": self.file,
            "valid": self.ok,
            "readable": self.readable,
            "schema_version": self.schema_version,
            "violations": [{"path": v.h5_path, "message": v.message,
                            **({"source": v.source} if v.source else {})}
                           for v in self.violations],
            "notes": self.notes,
        }


def validate_file(
    path: str | Path, *, spec: Spec | None = None, verified: Collection[str] = ()
) -> ValidationReport:
    """Validate one file; never raises for a bad file, only reports.

    verified: HDF5 paths of datasets whose content the caller has already checked with the
    same rules while writing them (the writer's event appender does); their value scans
    (ranges, polarity, time order, finiteness) are skipped, every other check still runs.
    """
    spec = spec or load_spec()
    report = ValidationReport(file=str(path), schema_version=None)
    p = Path(path)
    try:
        if p.is_symlink() and not p.exists():
            raise FileNotFoundError(path)
        if p.is_dir():
            raise IsADirectoryError("is a folder")
        h5 = h5py.File(p, "r")
    except FileNotFoundError:
        report.readable = False
        why = ("file not found" if not p.is_symlink() else
               "is a symbolic link that does not resolve (broken, or a loop)")
        report.violations.append(Violation("/", why))
        return report
    except IsADirectoryError:
        report.readable = False
        report.violations.append(Violation("/", "is a folder, not a tactile HDF5 file"))
        return report
    except (OSError, RuntimeError, ValueError) as exc:
        report.readable = False
        report.violations.append(Violation("/", f"not a readable HDF5 file ({_flat(exc)})"))
        return report
    try:
        with h5:
            _Validator(h5, spec, report, frozenset(verified)).run()
    except _READ_ERRORS as exc:  # closing a damaged file; every read is guarded below
        report.violations.append(Violation("/", f"cannot be read ({_flat(exc)})"))
    return report


class _Validator:
    def __init__(
        self,
        h5: h5py.File,
        spec: Spec,
        report: ValidationReport,
        verified: frozenset[str] = frozenset(),
    ):
        self.h5 = h5
        self.verified = verified
        self.spec = spec
        self.report = report
        self.strict = True  # False for a newer minor version: unknown nodes are allowed
        self.read: set[str] = set()  # datasets whose every value a check has read

    def fail(self, h5_path: str, message: str) -> None:
        self.report.violations.append(Violation(h5_path, message))

    def _guarded(self, h5_path: str, func, *args) -> None:
        """Run one node check or content check; a read failure is one violation there."""
        try:
            func(*args)
        except _READ_ERRORS as exc:
            self.fail(h5_path, f"cannot be read ({exc.__class__.__name__}: {_flat(exc)})")

    # -- driver -----------------------------------------------------------------------
    def run(self) -> None:
        try:
            if not self._check_version():
                return
        except _READ_ERRORS as exc:
            self.fail("/", f"root attributes cannot be read ({_flat(exc)})")
            return
        try:
            paths = self._all_paths()
        except _READ_ERRORS as exc:
            self.fail("/", f"the file's groups cannot be listed ({_flat(exc)}); it is damaged")
            return
        instances: dict[str, list[tuple[str, dict[str, str]]]] = {
            n.path: [] for n in self.spec.nodes
        }
        for p in paths:
            m = self.spec.match(p)
            if m is None:
                if self._inside_open_node(p):
                    continue
                if self.strict:
                    self.fail(p, "not part of the schema (unknown group or dataset name)")
                continue
            node, values = m
            instances[node.path].append((p, values))
            self._guarded(p, self._check_node, node, p)
        self._guarded("/", self._check_required, instances, set(paths))
        for check in self.spec.checks:
            self._run_check(check, instances)
        for p in paths:
            if re.fullmatch(r"/trials/[^/]+/annotations", p):
                self._guarded(p, self._check_annotations_in_trial, p)
        for p in paths:  # every chunk once, so a damaged one is reported wherever it is
            if p not in self.read and p not in self.verified:
                self._guarded(p, self._read_through, p)
        try:
            self._name_sources()
        except _READ_ERRORS:
            pass  # the sources table is reported by the checks above

    def _name_sources(self) -> None:
        """Point each violation inside a trial at the source file it came from (the
        trial's ``source_index`` into ``/provenance/sources/path``), so an ingest that
        breaks the schema names the input to fix."""
        if not self.report.violations or "/provenance/sources/path" not in self.h5:
            return
        table = self.h5["/provenance/sources/path"]
        if h5py.check_string_dtype(table.dtype) is None or table.ndim != 1:
            return
        paths = table.asstr()[()]
        named: dict[str, str | None] = {}
        out = []
        for v in self.report.violations:
            m = re.match(r"/trials/([^/ ]+)", v.h5_path)
            if m and m[1] not in named:
                named[m[1]] = None
                group = self.h5.get(f"/trials/{m[1]}")
                index = group.attrs.get("source_index") if group is not None else None
                idx = np.atleast_1d(np.asarray(index)) if index is not None else np.empty(0)
                if idx.dtype.kind in "iu" and idx.size and ((0 <= idx) & (idx < len(paths))).all():
                    named[m[1]] = ", ".join(str(paths[i]) for i in idx)
            out.append(Violation(v.h5_path, v.message, named[m[1]]) if m else v)
        self.report.violations[:] = out

    def _check_version(self) -> bool:
        attrs = self.h5["/"].attrs
        name = _as_str(attrs.get("schema_name"))
        version = _as_str(attrs.get("schema_version"))
        self.report.schema_version = version
        if name != self.spec.name:
            self.fail(
                "/",
                f"attribute schema_name is {name!r}, expected {self.spec.name!r}: "
                "this is not a tactile file; create one with `tactile ingest`",
            )
            return False
        if version is None or not re.fullmatch(r"\d+\.\d+", version):
            self.fail("/", f"attribute schema_version is {version!r}, expected MAJOR.MINOR")
            return False
        major, minor = (int(v) for v in version.split("."))
        if major != self.spec.major:
            self.fail(
                "/",
                f"schema version {version} is not readable by this tool (reads "
                f"{self.spec.major}.x); re-create the file with `tactile ingest` of this version",
            )
            return False
        if minor > self.spec.minor:
            self.strict = False
            self.report.notes.append(
                f"file schema {version} is newer than this tool's {self.spec.version}: "
                "nodes this tool does not know were not checked"
            )
        return True

    def _all_paths(self) -> list[str]:
        paths = ["/"]
        self.h5.visit(lambda name: paths.append("/" + name))
        return paths

    def _inside_open_node(self, h5_path: str) -> bool:
        for node in self.spec.nodes:
            if node.rules.get("open"):
                prefix = node.regex.pattern
                if re.match(prefix + "/", h5_path):
                    return True
        return False

    # -- per-node rules -------------------------------------------------------------
    def _check_node(self, node: NodeSpec, h5_path: str) -> None:
        obj = self.h5[h5_path]
        rules = node.rules
        if node.type == "group":
            if not isinstance(obj, h5py.Group):
                self.fail(h5_path, "expected a group, found a dataset")
                return
        else:
            if not isinstance(obj, h5py.Dataset):
                self.fail(h5_path, "expected a dataset, found a group")
                return
            self._check_dataset(rules, obj, h5_path)
        if "name_enum" in rules:
            allowed = self.spec.enums[rules["name_enum"]]
            name = h5_path.rsplit("/", 1)[1]
            if name not in allowed:
                self.fail(h5_path, f"group name {name!r} is not one of {allowed}")
        self._check_attributes(rules.get("attributes", {}), obj, h5_path)

    def _check_dataset(self, rules: dict[str, Any], ds: h5py.Dataset, h5_path: str) -> None:
        want = rules.get("dtype")
        if want == "string":
            if h5py.check_string_dtype(ds.dtype) is None:
                self.fail(h5_path, f"dtype is {ds.dtype}, expected a string dataset")
            elif "pattern" in rules and ds.size:
                rx = re.compile(rules["pattern"])
                for i, v in enumerate(np.atleast_1d(ds.asstr()[()])):
                    if not rx.fullmatch(v):
                        self.fail(h5_path, f"element {i} ({v!r}) does not match {rules['pattern']}")
                        break
        elif want is not None and ds.dtype != np.dtype(want):
            self.fail(h5_path, f"dtype is {ds.dtype}, expected {want}")
        if "dtype_kind" in rules:
            kinds = {"int": "iu", "float": "f"}
            ok = "".join(kinds[k] for k in rules["dtype_kind"])
            if ds.dtype.kind not in ok:
                self.fail(h5_path, f"dtype is {ds.dtype}, expected one of {rules['dtype_kind']}")
        if "ndim" in rules and ds.ndim != rules["ndim"]:
            self.fail(h5_path, f"has {ds.ndim} dimensions {ds.shape}, expected {rules['ndim']}")

    def _check_attributes(
        self, attr_rules: dict[str, Any], obj: h5py.HLObject, h5_path: str
    ) -> None:
        attrs = obj.attrs
        for key, rule in attr_rules.items():
            if key == "*":
                continue
            required = rule.get("required", False)
            if "required_if" in rule:
                required = any(_as_str(attrs.get(k)) in v for k, v in rule["required_if"].items())
            if key not in attrs:
                if required:
                    self.fail(h5_path, f"missing attribute {key!r}")
                continue
            self._check_value(rule, attrs[key], f"{h5_path} (attribute {key!r})")
        if "*" in attr_rules:
            for key in attrs:
                if key not in attr_rules:
                    self._check_value(attr_rules["*"], attrs[key], f"{h5_path} (attribute {key!r})")

    def _check_value(self, rule: dict[str, Any], value: Any, where: str) -> None:
        kind = rule.get("type")
        value = _plain(value)
        if kind == "string" and not isinstance(value, str):
            self.fail(where, f"value {_short(value)} is not a string")
            return
        if kind == "integer" and (not isinstance(value, (int, np.integer))
                                  or isinstance(value, bool)):
            self.fail(where, f"value {_short(value)} is not an integer")
            return
        if kind == "number":
            if not isinstance(value, (int, float, np.number)) or isinstance(value, bool):
                self.fail(where, f"value {_short(value)} is not a number")
                return
            if not np.isfinite(value):  # JSON numbers are finite; so are the schema's
                self.fail(where, f"value {_short(value)} is not a finite number")
                return
        if kind == "string_or_number" and not isinstance(value, (str, int, float, np.number)):
            self.fail(where, f"value {_short(value)} is not a string or a number")
            return
        if kind == "integer_array":
            arr = np.atleast_1d(np.asarray(value))
            if arr.dtype.kind not in "iu":
                self.fail(where, f"value {_short(value)} is not an array of integers")
            return
        if "const" in rule and value != rule["const"]:
            self.fail(where, f"value {_short(value)}, expected {rule['const']!r}")
        if "enum" in rule:
            allowed = self.spec.enums[rule["enum"]]
            if value not in allowed:
                self.fail(where, f"value {_short(value)} is not one of {allowed}")
        if "pattern" in rule and not re.match(rule["pattern"], value):
            self.fail(where, f"value {_short(value)} does not match {rule['pattern']}")
        if "minimum" in rule and not value >= rule["minimum"]:
            self.fail(where, f"value {_short(value)} is below the minimum {rule['minimum']}")
        if "maximum" in rule and not value <= rule["maximum"]:
            self.fail(where, f"value {_short(value)} is above the maximum {rule['maximum']:g}")
        if "exclusive_minimum" in rule and not value > rule["exclusive_minimum"]:
            self.fail(where, f"value {_short(value)} must be above {rule['exclusive_minimum']}")
        if "ref" in rule:
            target = rule["ref"].replace("{value}", str(value))
            if target not in self.h5 or not isinstance(self.h5[target], h5py.Group):
                self.fail(where, f"refers to {target}, which does not exist")
            elif "ref_kind" in rule:
                kind_there = _as_str(self.h5[target].attrs.get("kind"))
                if kind_there not in rule["ref_kind"]:
                    self.fail(
                        where,
                        f"refers to sensor {target} of kind {kind_there!r}, "
                        f"expected one of {rule['ref_kind']}",
                    )

    def _check_required(
        self, instances: dict[str, list[tuple[str, dict[str, str]]]], present: set[str]
    ) -> None:
        for node in self.spec.nodes:
            rules = node.rules
            if rules.get("required") and not node.placeholders:
                if node.path not in present:
                    self.fail(node.path, f"required {node.type} is missing")
                continue
            parent_rule = rules.get("required_if_parent")
            # a required node under a placeholder is required in every instance of its parent
            if rules.get("required") or rules.get("required_if_parent_exists") or parent_rule:
                for parent_path, values in instances.get(node.parent_path, []):
                    if parent_rule:
                        pattrs = self.h5[parent_path].attrs
                        if not any(_as_str(pattrs.get(k)) in v for k, v in parent_rule.items()):
                            continue
                    child = _fill(node.path, values)
                    if child not in present:
                        self.fail(child, f"required {node.type} is missing")

    # -- content checks ---------------------------------------------------------------
    def _expand(
        self, pattern: str, instances: dict[str, list[tuple[str, dict[str, str]]]]
    ) -> Iterator[str]:
        """Concrete paths matching a pattern that exist in the file."""
        if pattern in instances:
            for p, _ in instances[pattern]:
                yield p
            return
        regex, _ = pattern_to_regex(pattern)
        for found in instances.values():
            for p, _ in found:
                if regex.fullmatch(p):
                    yield p

    def _run_check(
        self, check: dict[str, Any], instances: dict[str, list[tuple[str, dict[str, str]]]]
    ) -> None:
        name = check["check"]
        if name == "same_length":
            self._guarded(check["paths"][0].rsplit("/", 1)[0], self._check_same_length,
                          check["paths"], instances)
            return
        for p in list(self._expand(check["path"], instances)):
            if p in self.verified and name in _VALUE_SCANS:
                continue
            self._guarded(p, self._run_one, name, check, p)

    def _run_one(self, name: str, check: dict[str, Any], p: str) -> None:
        """Content check ``name`` on the concrete node ``p``."""
        obj = self.h5[p]
        if name == "values_in":
            self._scan(
                obj,
                p,
                lambda a, allowed=check["values"]: ~np.isin(a, allowed),
                f"values outside {check['values']}",
            )
        elif name == "non_decreasing":
            self._check_non_decreasing(obj, p)
        elif name == "increasing":
            self._check_non_decreasing(obj, p, strict=True)
        elif name == "finite":
            self._scan(obj, p, lambda a: ~np.isfinite(a), "non-finite values (NaN or inf)")
        elif name == "below_sensor_attr":
            self._check_below_sensor_attr(obj, p, check["attr"])
        elif name == "ms_index":
            self._check_ms_index(obj, p)
        elif name == "columns_match_channels":
            self._check_columns(obj, p)
        elif name == "same_length_as":
            other = _sibling_from_pattern(p, check["path"], check["as"])
            if other in self.h5 and len(self.h5[other]) != len(obj):
                self.fail(p, f"has {len(obj)} rows, {other} has {len(self.h5[other])}")
        elif name == "frame_geometry":
            self._check_frames(obj, p)
        elif name == "sample_rate":
            self._check_sample_rate(obj, p, check.get("zero_allowed_for", []))
        elif name == "class_codes":
            self._check_class_codes(obj, p, check.get("unlabelled"))
        elif name == "not_before":
            other = _sibling_from_pattern(p, check["path"], check["as"])
            self._check_not_before(obj, p, other)
        elif name == "columns_same_length":
            self._check_columns_same_length(obj, p)
        else:  # a spec from a newer tool may name checks this one lacks
            self.report.notes.append(f"check {name!r} of the spec is not known to this tool")

    def _check_same_length(
        self, patterns: list[str], instances: dict[str, list[tuple[str, dict[str, str]]]]
    ) -> None:
        first_regex, _ = pattern_to_regex(patterns[0])
        groups: dict[tuple[str, ...], list[str]] = {}
        for pat in patterns:
            regex, _ = pattern_to_regex(pat)
            for p in self._expand(pat, instances):
                key = tuple(sorted(regex.fullmatch(p).groupdict().items()))  # type: ignore[union-attr]
                groups.setdefault(key, []).append(p)
        for members in groups.values():
            lengths = {}
            for p in members:
                obj = self.h5[p]
                if isinstance(obj, h5py.Dataset) and obj.ndim >= 1:
                    lengths[p] = obj.shape[0]
            if len(set(lengths.values())) > 1:
                desc = ", ".join(f"{k.rsplit('/', 1)[1]}={v}" for k, v in lengths.items())
                parent = members[0].rsplit("/", 1)[0]
                self.fail(parent, f"datasets that must have equal length differ: {desc}")

    def _numeric(self, ds: h5py.Dataset, p: str) -> bool:
        """Whether ``ds`` holds numbers a value scan can read (a dtype violation is
        reported by the node rules; a scalar or a string dataset is not scanned)."""
        return ds.ndim >= 1 and ds.dtype.kind in "biuf"

    @staticmethod
    def _rows_per_block(ds: h5py.Dataset) -> int:
        """Rows read at once: :data:`BLOCK` elements, however wide a row is."""
        row = int(np.prod(ds.shape[1:], dtype=np.int64)) if ds.ndim > 1 else 1
        return max(1, BLOCK // max(1, row))

    def _read_through(self, p: str) -> None:
        """Read every chunk of dataset ``p`` (decompression checks each one)."""
        ds = self.h5[p]
        if not isinstance(ds, h5py.Dataset):
            return
        if ds.ndim == 0 or ds.size == 0:
            ds[()]
            return
        step = self._rows_per_block(ds)
        for start in range(0, ds.shape[0], step):
            ds[start : start + step]

    def _scan(self, ds: h5py.Dataset, p: str, bad_mask, what: str) -> None:
        if not self._numeric(ds, p):
            return
        self.read.add(p)
        step = self._rows_per_block(ds)
        for start in range(0, ds.shape[0], step):
            block = ds[start : start + step]
            bad = bad_mask(block)
            if bad.any():
                rows = bad.reshape(len(block), -1)
                r = int(np.flatnonzero(rows.any(axis=1))[0])
                value = block[r] if block.ndim == 1 else block[r][rows[r].reshape(block[r].shape)]
                where = f"index {r + start}" if block.ndim == 1 else f"row {r + start}"
                self.fail(p, f"{what}, first at {where} (value {_plain(_first(value))!r})")
                return

    def _check_non_decreasing(self, ds: h5py.Dataset, p: str, *, strict: bool = False) -> None:
        if not self._numeric(ds, p) or ds.ndim != 1:
            return
        self.read.add(p)
        prev = None
        worse = "does not increase" if strict else "goes backwards"
        for start in range(0, ds.shape[0], BLOCK):
            block = ds[start : start + BLOCK]
            if block.size and prev is not None:
                block = np.concatenate([[prev], block])
                start -= 1
            d = np.diff(block)
            bad = ~(d > 0) if strict else d < 0  # NaN steps fail the strict test
            if bad.any():
                i = int(np.flatnonzero(bad)[0])
                self.fail(
                    p,
                    f"time {worse} at index {start + i + 1} ({block[i + 1]} after {block[i]})",
                )
                return
            if block.size:
                prev = block[-1]

    def _sensor_of(self, p: str) -> h5py.Group | None:
        group = self.h5[p.rsplit("/", 1)[0]] if isinstance(self.h5[p], h5py.Dataset) else self.h5[p]
        name = _as_str(group.attrs.get("sensor"))
        target = f"/sensors/{name}"
        if name is None or target not in self.h5:
            return None  # reported by the attribute rule
        return self.h5[target]

    def _check_below_sensor_attr(self, ds: h5py.Dataset, p: str, attr: str) -> None:
        sensor = self._sensor_of(p)
        if sensor is None or attr not in sensor.attrs:
            return
        limit = _plain(sensor.attrs[attr])
        if not isinstance(limit, (int, np.integer)) or isinstance(limit, bool):
            return  # reported by the sensor's attribute rule
        self._scan(ds, p, lambda a: a >= limit, f"values >= {attr} of {sensor.name} ({limit})")

    def _check_ms_index(self, group: h5py.Group, p: str) -> None:
        if (
            not all(k in group for k in ("t", "ms_to_idx"))
            or "ms_index_origin_us" not in group.attrs
        ):
            return
        t, idx = group["t"], group["ms_to_idx"][()]
        origin = _plain(group.attrs["ms_index_origin_us"])
        if not isinstance(origin, (int, np.integer)) or idx.ndim != 1 or idx.dtype.kind not in "iu":
            return  # reported by the attribute and dataset rules
        origin = int(origin)
        n = t.shape[0]
        if idx.size == 0:
            if n:
                self.fail(f"{p}/ms_to_idx", "is empty but the trial has events")
            return
        if idx[0] != 0 or (np.diff(idx) < 0).any() or idx[-1] > n:
            self.fail(
                f"{p}/ms_to_idx", "must start at 0, never decrease and stay <= the event count"
            )
            return
        # spot-check: each sampled entry points at the first event at or after its millisecond
        probe = np.unique(np.linspace(0, idx.size - 1, num=min(idx.size, 64)).astype(np.int64))
        for k in probe:
            i = int(idx[k])
            edge = origin + 1000 * int(k)
            if (i < n and t[i] < edge) or (i > 0 and t[i - 1] >= edge):
                self.fail(
                    f"{p}/ms_to_idx",
                    f"entry {k} ({i}) is not the first event at or after {edge} us",
                )
                return

    def _check_sample_rate(self, group: h5py.Group, p: str, zero_ok: list[str]) -> None:
        """A sensor's ``sample_rate_hz``: finite and > 0, or 0 for the kinds in
        ``zero_ok`` (event cameras: asynchronous)."""
        rate, kind = _plain(group.attrs.get("sample_rate_hz")), _as_str(group.attrs.get("kind"))
        if not isinstance(rate, (int, float, np.number)) or isinstance(rate, bool):
            return  # missing or not a number: reported by the attribute rule
        if not np.isfinite(rate) or rate < 0:
            return  # reported by the attribute rule
        if rate == 0 and kind not in zero_ok:
            self.fail(f"{p} (attribute 'sample_rate_hz')",
                      f"value 0 is allowed only for sensors of kind {', '.join(zero_ok)} "
                      f"(this one is {kind!r}); a sampled sensor needs its rate > 0")

    def _check_class_codes(self, ds: h5py.Dataset, p: str, unlabelled: int | None) -> None:
        """Per-sample class codes: whole numbers ``0 <= code < len(classes)`` (or the
        ``unlabelled`` code); labels without ``classes`` are numbers, NaN where unknown."""
        if "classes" not in ds.attrs:
            return
        classes = np.atleast_1d(np.asarray(ds.attrs["classes"]))
        if classes.dtype.kind not in "OSU":
            self.fail(f"{p} (attribute 'classes')", f"is {classes.dtype}, expected strings")
            return
        k = int(classes.size)
        low = unlabelled if unlabelled is not None else 0
        self._scan(
            ds, p,
            lambda a: ((a != np.round(a)) | (a < 0) | (a >= k)) & (a != low),
            f"class codes outside 0..{k - 1} of its {k} classes"
            + (f" (nor {unlabelled}, unlabelled)" if unlabelled is not None else ""),
        )

    def _check_not_before(self, ds: h5py.Dataset, p: str, other: str) -> None:
        """Each value of ``ds`` (end_s) is at or after the same row of ``other`` (start_s)."""
        if other not in self.h5 or not isinstance(self.h5[other], h5py.Dataset):
            return
        first = self.h5[other]
        if not (self._numeric(ds, p) and self._numeric(first, other)) or ds.shape != first.shape:
            return  # reported by the node rules and the equal-length check
        end, start = ds[()], first[()]
        bad = np.flatnonzero(end < start)
        if bad.size:
            i = int(bad[0])
            self.fail(p, f"row {i} ends at {_plain(end[i])!r} s, before it starts "
                         f"({other.rsplit('/', 1)[1]} = {_plain(start[i])!r} s)")

    def _trial_end_s(self, trial: h5py.Group) -> float:
        """A trial's end, seconds: the latest of ``duration_s``, the last event and each
        stream's last sample (0 when none is readable; those are reported elsewhere)."""
        ends = [0.0]
        dur = _plain(trial.attrs.get("duration_s"))
        if isinstance(dur, (int, float)) and not isinstance(dur, bool) and np.isfinite(dur):
            ends.append(float(dur))
        ev = trial.get("events")
        if isinstance(ev, h5py.Group) and isinstance(ev.get("t"), h5py.Dataset):
            t = ev["t"]
            origin = _plain(ev.attrs.get("t_origin_us", ev.attrs.get("ms_index_origin_us")))
            if t.ndim == 1 and t.shape[0] and t.dtype.kind in "iu" \
                    and isinstance(origin, (int, np.integer)):
                ends.append((int(t[-1]) + 1 - int(origin)) * 1e-6)
        signals = trial.get("signals")
        for stream in signals.values() if isinstance(signals, h5py.Group) else []:
            t_s = stream.get("t_s") if isinstance(stream, h5py.Group) else None
            if isinstance(t_s, h5py.Dataset) and t_s.ndim == 1 and t_s.shape[0] \
                    and t_s.dtype.kind in "iuf" and np.isfinite(t_s[-1]):
                ends.append(float(t_s[-1]))
        return max(ends)

    def _check_annotations_in_trial(self, p: str) -> None:
        """No annotation starts after the trial's end by more than 60 s plus the trial's
        length (as the reader: ``ANNOTATION_SLACK_S`` of store/trials.py)."""
        group = self.h5[p]
        start = group.get("start_s") if isinstance(group, h5py.Group) else None
        if not isinstance(start, h5py.Dataset) or not self._numeric(start, p) \
                or start.ndim != 1:
            return  # reported by the node rules
        end_s = self._trial_end_s(self.h5[p.rsplit("/", 1)[0]])
        starts = np.asarray(start[()], dtype=np.float64)
        late = np.flatnonzero(starts > 2 * end_s + 60.0)
        if end_s > 0 and late.size:
            i = int(late[0])
            self.fail(f"{p}/start_s", f"row {i} starts at {float(starts[i])!r} s, after the "
                                      f"trial's end ({end_s:g} s: its duration_s, last event "
                                      "or last sample)")

    def _check_columns_same_length(self, group: h5py.Group, p: str) -> None:
        """A table group (one row per trial): every dataset is a column of one length."""
        if not isinstance(group, h5py.Group):
            return
        lengths: dict[str, int] = {}
        for name, obj in group.items():
            if not isinstance(obj, h5py.Dataset):
                continue
            if obj.ndim < 1:
                self.fail(f"{p}/{name}", "is a scalar; expected a column (one row per trial)")
                continue
            lengths[name] = int(obj.shape[0])
        if len(set(lengths.values())) > 1:
            desc = ", ".join(f"{k}={v}" for k, v in lengths.items())
            self.fail(p, f"columns that must have equal length differ: {desc}")

    def _check_columns(self, ds: h5py.Dataset, p: str) -> None:
        sensor = self._sensor_of(p)
        if sensor is None or ds.ndim != 2:
            return
        if "channel_names" not in sensor:
            self.fail(p, f"has {ds.shape[1]} columns but sensor {sensor.name} names no "
                         "channels (channel_names is missing)")
            return
        n = sensor["channel_names"].shape[0]
        if ds.shape[1] != n:
            self.fail(p, f"has {ds.shape[1]} columns, sensor {sensor.name} names {n} channels")

    def _check_frames(self, group: h5py.Group, p: str) -> None:
        sensor = self._sensor_of(p)
        if sensor is None or "images" not in group or "reference" not in group:
            return
        h, w = _plain(sensor.attrs.get("height_px")), _plain(sensor.attrs.get("width_px"))
        if not all(isinstance(v, (int, np.integer)) for v in (h, w)):
            h = w = None  # reported by the sensor's attribute rules
        for name in ("images", "reference"):
            shape = group[name].shape
            hw = shape[-3:-1]
            if h is not None and w is not None and hw != (int(h), int(w)):
                self.fail(
                    f"{p}/{name}", f"frames are {hw[1]}x{hw[0]}, sensor {sensor.name} is {w}x{h}"
                )
            if shape[-1] != 3:
                self.fail(f"{p}/{name}", f"last axis has {shape[-1]} colour channels, expected 3")


def _fill(pattern: str, values: dict[str, str]) -> str:
    for k, v in values.items():
        pattern = pattern.replace("{" + k + "}", v)
    return pattern


def _sibling_from_pattern(concrete: str, pattern: str, other_pattern: str) -> str:
    regex, _ = pattern_to_regex(pattern)
    m = regex.fullmatch(concrete)
    return _fill(other_pattern, m.groupdict() if m else {})


def _first(value: Any) -> Any:
    """The first element of an array (the value a scan reports), else the value."""
    if isinstance(value, np.ndarray):
        return value.reshape(-1)[0] if value.size else value
    return value


def _short(value: Any, limit: int = 60) -> str:
    """A value's repr on one line, at most ``limit`` characters (an array attribute's repr
    spans lines)."""
    if isinstance(value, np.ndarray):
        text = f"array of {value.dtype} {value.shape} " + " ".join(
            np.array2string(value.reshape(-1)[:8], separator=",", threshold=8).split())
    else:
        text = " ".join(repr(value).split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _plain(value: Any) -> Any:
    if isinstance(value, bytes):
        return value.decode("utf-8", "replace")
    if isinstance(value, np.ndarray) and value.ndim == 0:
        return value.item()
    if isinstance(value, np.generic):
        return value.item()
    return value


def _as_str(value: Any) -> str | None:
    value = _plain(value)
    return value if isinstance(value, str) else None


def check_readable(path: str | Path) -> str:
    """Version gate for readers: returns the file's schema version or raises SchemaError."""
    from ..errors import SchemaError

    spec = load_spec()
    with h5py.File(path, "r") as h5:
        name = _as_str(h5.attrs.get("schema_name"))
        version = _as_str(h5.attrs.get("schema_version")) or "?"
    if name != spec.name:
        raise SchemaError(
            f"{path}: not a tactile HDF5 file (schema_name {name!r}); "
            "create one with `tactile ingest`"
        )
    major, _, minor = version.partition(".")
    if major != str(spec.major):
        raise SchemaError(
            f"{path}: schema version {version} cannot be read by this tool "
            f"(reads {spec.major}.x); re-create it with this version's `tactile ingest`"
        )
    if minor.isdigit() and int(minor) > spec.minor:
        warnings.warn(
            f"{path}: schema {version} is newer than this tool's {spec.version}; "
            "parts it does not know are ignored",
            stacklevel=2,
        )
    return version
