"""What each output head of a network predicts: name, kind, classes and loss weight.

A head is resolved from a config target (:class:`~tactile_cli.learn.config.TargetConfig`)
and the data (the class names of a categorical label); the resolved heads are saved in
the run folder so that evaluation decodes predictions with the training's classes.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any, Literal


@dataclass(frozen=True)
class HeadSpec:
    """One output of a multi-task network.

    ``classes`` are the class names in index order (classification); empty for a
    regression head, which predicts one standardised value.
    """

    name: str
    kind: Literal["classification", "regression"]
    source: Literal["sample", "trial"]
    weight: float = 1.0
    classes: tuple[str, ...] = ()

    @property
    def n_outputs(self) -> int:
        return len(self.classes) if self.kind == "classification" else 1

    def as_dict(self) -> dict[str, Any]:
        out = asdict(self)
        out["classes"] = list(self.classes)
        return out

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> HeadSpec:
        return cls(name=str(d["name"]), kind=d["kind"], source=d["source"],
                   weight=float(d["weight"]), classes=tuple(str(c) for c in d["classes"]))


def primary_head(heads: list[HeadSpec] | tuple[HeadSpec, ...]) -> HeadSpec | None:
    """The first classification head: the one whose accuracy a run is known by."""
    return next((h for h in heads if h.kind == "classification"), None)


__all__ = ["HeadSpec", "primary_head"]
