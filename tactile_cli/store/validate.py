"""Check an HDF5 file against the tactile schema spec and list every violation.

Structure (groups, datasets, dtypes, ranks, attributes) comes from the node rules of the
spec; content rules (equal lengths, polarity values, monotonic time, pixel ranges, the
millisecond index) come from its ``checks`` list. Large datasets are read in blocks, so a
file with tens of millions of events validates in bounded memory.
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
_VALUE_SCANS = frozenset({"values_in", "non_decreasing", "finite", "below_sensor_attr"})


@dataclass(frozen=True)
class Violation:
    """One way a file breaks the schema, at an HDF5 path."""

    h5_path: str
    message: str

    def __str__(self) -> str:
        return f"{self.h5_path}: {self.message}"


@dataclass
class ValidationReport:
    """Outcome of :func:`validate_file`."""

    file: str
    schema_version: str | None
    violations: list[Violation] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.violations

    def as_dict(self) -> dict[str, Any]:
        return {
            "file": self.file,
            "valid": self.ok,
            "schema_version": self.schema_version,
            "violations": [{"path": v.h5_path, "message": v.message} for v in self.violations],
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
    try:
        h5 = h5py.File(path, "r")
    except FileNotFoundError:
        report.violations.append(Violation("/", "file not found"))
        return report
    except OSError as exc:
        report.violations.append(
            Violation("/", f"not a readable HDF5 file ({exc.__class__.__name__})")
        )
        return report
    with h5:
        _Validator(h5, spec, report, frozenset(verified)).run()
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

    def fail(self, h5_path: str, message: str) -> None:
        self.report.violations.append(Violation(h5_path, message))

    # -- driver -----------------------------------------------------------------------
    def run(self) -> None:
        if not self._check_version():
            return
        paths = self._all_paths()
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
            self._check_node(node, p)
        self._check_required(instances, set(paths))
        for check in self.spec.checks:
            self._run_check(check, instances)

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
            self.fail(where, f"value {value!r} is not a string")
            return
        if kind == "integer" and not isinstance(value, (int, np.integer)):
            self.fail(where, f"value {value!r} is not an integer")
            return
        if kind == "number" and not isinstance(value, (int, float, np.number)):
            self.fail(where, f"value {value!r} is not a number")
            return
        if kind == "string_or_number" and not isinstance(value, (str, int, float, np.number)):
            self.fail(where, f"value {value!r} is not a string or a number")
            return
        if kind == "integer_array":
            arr = np.atleast_1d(np.asarray(value))
            if arr.dtype.kind not in "iu":
                self.fail(where, f"value {value!r} is not an array of integers")
            return
        if "const" in rule and value != rule["const"]:
            self.fail(where, f"value {value!r}, expected {rule['const']!r}")
        if "enum" in rule:
            allowed = self.spec.enums[rule["enum"]]
            if value not in allowed:
                self.fail(where, f"value {value!r} is not one of {allowed}")
        if "pattern" in rule and not re.match(rule["pattern"], value):
            self.fail(where, f"value {value!r} does not match {rule['pattern']}")
        if "minimum" in rule and not value >= rule["minimum"]:
            self.fail(where, f"value {value!r} is below the minimum {rule['minimum']}")
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
            self._check_same_length(check["paths"], instances)
            return
        for p in list(self._expand(check["path"], instances)):
            if p in self.verified and name in _VALUE_SCANS:
                continue
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

    def _scan(self, ds: h5py.Dataset, p: str, bad_mask, what: str) -> None:
        for start in range(0, ds.shape[0], BLOCK):
            block = ds[start : start + BLOCK]
            bad = bad_mask(block)
            if bad.any():
                i = int(np.flatnonzero(bad.reshape(len(block), -1).any(axis=1))[0]) + start
                self.fail(p, f"{what}, first at index {i} (value {_plain(ds[i])!r})")
                return

    def _check_non_decreasing(self, ds: h5py.Dataset, p: str) -> None:
        prev = None
        for start in range(0, ds.shape[0], BLOCK):
            block = ds[start : start + BLOCK]
            if prev is not None and block.size and block[0] < prev:
                self.fail(p, f"time goes backwards at index {start} ({block[0]} after {prev})")
                return
            d = np.diff(block)
            if (d < 0).any():
                i = int(np.flatnonzero(d < 0)[0])
                self.fail(
                    p,
                    f"time goes backwards at index {start + i + 1} "
                    f"({block[i + 1]} after {block[i]})",
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
        limit = int(sensor.attrs[attr])
        self._scan(ds, p, lambda a: a >= limit, f"values >= {attr} of {sensor.name} ({limit})")

    def _check_ms_index(self, group: h5py.Group, p: str) -> None:
        if (
            not all(k in group for k in ("t", "ms_to_idx"))
            or "ms_index_origin_us" not in group.attrs
        ):
            return
        t, idx = group["t"], group["ms_to_idx"][()]
        origin = int(group.attrs["ms_index_origin_us"])
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

    def _check_columns(self, ds: h5py.Dataset, p: str) -> None:
        sensor = self._sensor_of(p)
        if sensor is None or "channel_names" not in sensor or ds.ndim != 2:
            return
        n = sensor["channel_names"].shape[0]
        if ds.shape[1] != n:
            self.fail(p, f"has {ds.shape[1]} columns, sensor {sensor.name} names {n} channels")

    def _check_frames(self, group: h5py.Group, p: str) -> None:
        sensor = self._sensor_of(p)
        if sensor is None or "images" not in group or "reference" not in group:
            return
        h, w = sensor.attrs.get("height_px"), sensor.attrs.get("width_px")
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
