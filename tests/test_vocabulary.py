"""The shared action names and default bin width (tactile_cli/vocabulary.py).

Every config field and function that takes a bin width defaults to ``BIN_S``, so a 0.02
literal written back into one of them (and drifting from the others) fails here.
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import re
import subprocess
import sys
from pathlib import Path

import pytest

from tactile_cli.vocabulary import ACTIONS, BIN_S, action_index

PACKAGE = Path(__file__).resolve().parents[1] / "tactile_cli"
HEAVY = ("jax", "jaxlib", "optimistix", "equinox", "torch", "tactile_cli.fos")


def test_import_loads_no_heavy_package():
    code = ("import sys, tactile_cli.vocabulary\n"
            f"heavy = {HEAVY!r}\n"
            "print(sorted(m for m in sys.modules if m in heavy or m.startswith("
            "tuple(h + '.' for h in heavy))))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       check=True)
    assert r.stdout.strip() == "[]", r.stdout


def test_actions_and_bin_width():
    assert ACTIONS == ("approach", "press", "slip", "release")
    assert BIN_S == 0.02


@pytest.mark.parametrize(("label", "index"), [
    ("approach", 0), (" Press ", 1), ("SLIP", 2), ("release", 3), ("contact", None), ("", None),
])
def test_action_index(label, index):
    assert action_index(label) == index


@pytest.mark.parametrize(("module", "model"), [
    ("tactile_cli.scene.config", "MarkerSceneConfig"),
    ("tactile_cli.synth.config", "SynthConfig"),
    ("tactile_cli.learn.config", "DataConfig"),
    ("tactile_cli.grade.config", "FeatureConfig"),
])
def test_config_default_is_bin_s(module, model):
    cls = getattr(importlib.import_module(module), model)
    assert cls.model_fields["bin_s"].default == BIN_S


@pytest.mark.parametrize(("module", "name"), [
    ("tactile_cli.spatial.config", "CentroidOptions"),
    ("tactile_cli.events.segment", "Segmentation"),
])
def test_dataclass_default_is_bin_s(module, name):
    cls = getattr(importlib.import_module(module), name)
    assert {f.name: f.default for f in dataclasses.fields(cls)}["bin_s"] == BIN_S


@pytest.mark.parametrize(("module", "name"), [
    ("tactile_cli.events.accumulate", "bin_events"),
    ("tactile_cli.events.accumulate", "trial_counts"),
    ("tactile_cli.events.recording", "accumulate_file"),
    ("tactile_cli.events.segment", "segment_actions"),
    ("tactile_cli.events.segment", "segmentation_accuracy"),
    ("tactile_cli.fos.actions", "bin_centres_s"),
    ("tactile_cli.spatial.roi", "trial_roi_centroids"),
    ("tactile_cli.spatial.roi", "roi_centroid_series"),
    ("tactile_cli.grade.features", "load_areas"),
    ("tactile_cli.grade.features", "hdf5_areas"),
])
def test_function_default_is_bin_s(module, name):
    func = getattr(importlib.import_module(module), name)
    assert inspect.signature(func).parameters["bin_s"].default == BIN_S


def test_accumulate_command_default_is_bin_s():
    from tactile_cli.cli.accumulate import accumulate_command

    assert inspect.signature(accumulate_command).parameters["bin_ms"].default / 1000 == BIN_S


def test_no_bin_width_literal_in_defaults():
    # an annotated `bin_s` default written as a number (`bin_s: float = 0.02`,
    # `bin_s: float = Field(default=0.02, ...)`) instead of BIN_S; the annotation keeps
    # prose such as ``bin_s=0.02`` in docstrings and messages out
    literal = re.compile(r"\bbin_s\s*:[^=\n]+=\s*(?:Field\(\s*default\s*=\s*)?[\d.]")
    found = [f"{p.relative_to(PACKAGE.parent)}:{i}: {line.strip()}"
             for p in sorted(PACKAGE.rglob("*.py"))
             for i, line in enumerate(p.read_text().splitlines(), 1) if literal.search(line)]
    assert not found, found
