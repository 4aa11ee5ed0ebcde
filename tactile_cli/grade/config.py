"""The grader's YAML config: membership functions of ``area`` and ``force``, the rule table.

A config holds one input variable (the area of net pressing events in the press region,
events) and one output variable (the pressing-force extent), each with named terms and
their membership functions (``trimf``, ``trapmf``, ``gaussmf``), and the rules of the
paper's Table III (``IF area is very_small THEN force is light``, ...). The output terms,
in order, are the grades. ``levels_per_grade`` maps integer force levels to grades (levels
1-2 are grade 0 with the default 2).

Unknown keys are errors, reported with the key's path and line. :func:`load_config` reads
and validates; :func:`save_config` writes a config atomically with a header comment and a
``provenance:`` key.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any, Literal

import numpy as np
import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from ..config_file import key_line, read_yaml
from ..errors import InputError
from ..store.atomic import write_text
from ..vocabulary import BIN_S
from .fuzzy import MF_KINDS, MamdaniSystem, MembershipFunction

_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


def normalise_grade(name: str) -> str:
    """``"Small medium"`` -> ``"small_medium"`` (labels and term names compare this way)."""
    return re.sub(r"[\s\-]+", "_", str(name).strip()).lower()


class _Strict(BaseModel):
    # NaN and infinities are errors (a universe or a bin of `inf` is never meant)
    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True,
                              allow_inf_nan=False)


class TermConfig(_Strict):
    """One term's membership function."""

    mf: Literal["trimf", "trapmf", "gaussmf"]
    params: list[float]

    @model_validator(mode="after")
    def _check(self) -> TermConfig:
        try:
            MembershipFunction(self.mf, tuple(self.params))
        except ValueError as exc:
            raise ValueError(str(exc)) from None
        return self

    def to_mf(self) -> MembershipFunction:
        return MembershipFunction(self.mf, tuple(self.params))


class VariableConfig(_Strict):
    name: str
    units: str = ""
    range: tuple[float, float]
    terms: dict[str, TermConfig]

    @field_validator("range")
    @classmethod
    def _range(cls, value: tuple[float, float]) -> tuple[float, float]:
        if not value[0] < value[1]:
            raise ValueError(f"range must be [low, high] with low < high, got {list(value)}")
        return value

    @field_validator("terms")
    @classmethod
    def _terms(cls, value: dict[str, TermConfig]) -> dict[str, TermConfig]:
        if not value:
            raise ValueError("at least one term is needed")
        for name in value:
            if not _NAME.match(name):
                raise ValueError(f"term name {name!r} must be letters, digits and _")
        return value


class OutputConfig(VariableConfig):
    resolution: int | None = Field(
        default=None, le=10_000_000,
        description="even points of the output universe (None: continuous), at most 10^7")

    @field_validator("resolution")
    @classmethod
    def _resolution(cls, value: int | None) -> int | None:
        if value is not None and value < 2:
            raise ValueError(f"resolution must be >= 2 or null, got {value}")
        return value


class RuleConfig(_Strict):
    if_: str = Field(alias="if")
    then: str


class FeatureConfig(_Strict):
    """What the input variable is. ``area`` (paper 000, Fig. 15): net events summed over
    the press region, in events. ``fos_alpha``: the press gain alpha_1 fitted by
    ``tactile fit-fos`` (``/derived/fits/fos_press``), events per bin, for protocols whose
    press duration varies (the area is proportional to alpha_1 times the duration)."""

    kind: Literal["area", "fos_alpha"] = "area"
    bin_s: float = BIN_S
    region: str = "press"

    @field_validator("bin_s")
    @classmethod
    def _bin(cls, value: float) -> float:
        if not 0 < value <= 3600:
            raise ValueError(f"bin_s must be > 0 and at most 3600 s, got {value}")
        return value


class GraderConfig(_Strict):
    """A validated grader config (see the module docstring and configs/grade_marker.yaml)."""

    version: Literal[1] = 1
    description: str = ""
    input: VariableConfig
    output: OutputConfig
    rules: list[RuleConfig]
    levels_per_grade: int = Field(default=2, ge=1, le=1000)
    feature: FeatureConfig = FeatureConfig()
    provenance: dict[str, Any] | None = None

    @model_validator(mode="after")
    def _check(self) -> GraderConfig:
        if not self.rules:
            raise ValueError("rules: at least one rule is needed")
        for k, rule in enumerate(self.rules):
            if rule.if_ not in self.input.terms:
                raise ValueError(f"rules[{k}].if: {rule.if_!r} is not an input term "
                                 f"({', '.join(self.input.terms)})")
            if rule.then not in self.output.terms:
                raise ValueError(f"rules[{k}].then: {rule.then!r} is not an output term "
                                 f"({', '.join(self.output.terms)})")
        unused = [t for t in self.output.terms if t not in {r.then for r in self.rules}]
        if unused:
            raise ValueError(f"output term(s) {', '.join(unused)} appear in no rule, so those "
                             "grades could never be given; add a rule or remove the term")
        if self.levels_per_grade < 1:
            raise ValueError(f"levels_per_grade must be >= 1, got {self.levels_per_grade}")
        try:
            system = self.system()
        except ValueError as exc:
            raise ValueError(str(exc)) from None
        gap = _uncovered_input(system)
        if gap is not None:
            raise ValueError(
                f"no rule fires for an input area of {gap:g} (the input terms used by the rules "
                "leave a gap there); widen the neighbouring terms")
        return self

    @property
    def grades(self) -> tuple[str, ...]:
        """Grade names, in order (the output terms)."""
        return tuple(self.output.terms)

    def system(self) -> MamdaniSystem:
        """The :class:`MamdaniSystem` this config describes."""
        in_names, out_names = list(self.input.terms), list(self.output.terms)
        return MamdaniSystem(
            input_terms=tuple(in_names),
            input_mfs=tuple(t.to_mf() for t in self.input.terms.values()),
            input_range=self.input.range,
            output_terms=tuple(out_names),
            output_mfs=tuple(t.to_mf() for t in self.output.terms.values()),
            output_range=self.output.range,
            rules=tuple((in_names.index(r.if_), out_names.index(r.then)) for r in self.rules),
            resolution=self.output.resolution,
        )

    def grade_of_level(self, level: int) -> int:
        """Grade index of an integer force level (1-based)."""
        return (int(level) - 1) // self.levels_per_grade

    def as_yaml_dict(self) -> dict[str, Any]:
        data = self.model_dump(mode="json", by_alias=True, exclude_none=True)
        data["output"]["resolution"] = self.output.resolution  # null is meaningful
        return data


def _uncovered_input(system: MamdaniSystem) -> float | None:
    """An input value where no rule fires, or None. The used terms are piecewise linear
    between their knots, so checking the knots and the midpoints between them suffices;
    Gaussians never reach 0."""
    used = {i for i, _ in system.rules}
    if any(not system.input_mfs[i].piecewise_linear for i in used):
        return None
    lo, hi = system.input_range
    knots = sorted({lo, hi, *(v for i in used for v in system.input_mfs[i].trapezoid
                              if lo <= v <= hi)})
    pts = np.array(sorted(set(knots) | {0.5 * (u + v) for u, v in zip(knots, knots[1:],
                                                                      strict=False)}))
    firing, _ = system.fire(pts)
    bad = np.flatnonzero(firing.max(axis=1) <= 0)
    return None if bad.size == 0 else float(pts[bad[0]])


# -- loading and saving ----------------------------------------------------------------------
def load_config(path: str | Path) -> GraderConfig:
    """Read and validate a grader config; any problem is one :class:`InputError` line
    naming the key and its line."""
    path = Path(path)
    text, raw = read_yaml(path)
    if not isinstance(raw, dict):
        raise InputError("a grader config is a YAML mapping with keys input, output, rules; "
                         "see configs/grade_marker.yaml", path=path)
    return config_from_dict(raw, path=path, text=text)


def config_from_dict(raw: dict[str, Any], *, path: str | Path | None = None,
                     text: str | None = None) -> GraderConfig:
    """Validate a config given as a dict (``path``/``text`` only locate errors)."""
    try:
        return GraderConfig.model_validate(raw)
    except ValidationError as exc:
        errors = exc.errors()
        err = max(errors, key=lambda e: (e["type"] == "extra_forbidden", len(e["loc"])))
        keys = [str(p) if not isinstance(p, int) else p for p in err["loc"]
                if not (isinstance(p, str) and p in MF_KINDS)]
        key = "".join(f"[{p}]" if isinstance(p, int) else (f".{p}" if i else p)
                      for i, p in enumerate(keys))
        msg = str(err["msg"]).removeprefix("Value error, ")
        if err["type"] == "extra_forbidden":
            message = f"unknown key `{key}`"
            allowed = _allowed(keys[:-1], raw)
            if allowed:
                message += f" (allowed here: {', '.join(allowed)})"
        elif err["type"] == "missing":
            message = f"missing key `{key}`"
        elif key:
            message = f"`{key}`: {msg}"
        else:
            message = msg
        line = key_line(text, keys, start=1) if text and keys else None
        raise InputError(message, path=path, where=None if line is None else f"line {line}") \
            from None


def _allowed(keys: list[Any], raw: dict[str, Any]) -> list[str]:
    model: Any = GraderConfig
    free = False
    for part in keys:
        if isinstance(part, int):
            continue
        if free:
            free = False
            continue
        field = model.model_fields.get(part) if isinstance(model, type) else None
        if field is None:
            return []
        ann = field.annotation
        origin = getattr(ann, "__origin__", None)
        args = getattr(ann, "__args__", ())
        if origin is dict:
            free, model = True, args[1]
        elif origin is list:
            model = args[0]
        else:
            model = ann
    if isinstance(model, type) and issubclass(model, BaseModel):
        return [f.alias or n for n, f in model.model_fields.items()]
    return []


def save_config(config: GraderConfig, path: str | Path, *, header: str = "",
                overwrite: bool = True) -> Path:
    """Write ``config`` as YAML to ``path`` atomically (``store.atomic.write_text``),
    with ``header`` as leading comment lines; an existing ``path`` is replaced only with
    ``overwrite``."""
    path = Path(path)
    data = config.as_yaml_dict()
    body = yaml.safe_dump(data, sort_keys=False, default_flow_style=None, width=100)
    comment = "".join(f"# {line}\n" if line else "#\n" for line in header.splitlines())
    text = comment + body
    config_from_dict(yaml.safe_load(text), path=path)  # what is written reads back
    return write_text(path, text, overwrite=overwrite)


__all__ = ["FeatureConfig", "GraderConfig", "OutputConfig", "RuleConfig", "TermConfig",
           "VariableConfig", "config_from_dict", "load_config", "normalise_grade",
           "save_config"]
