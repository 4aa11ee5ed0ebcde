"""One small simulated VibroTouch scene shared by the chain's tests (seed 7: neither a
tuning seed nor a held-out benchmark seed, see benchmarks/vibrotouch.py)."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app

SCENE_YAML = """\
contact_trials: 2
touch_trials: 1
touches_per_trial: 3
gap_mm: [0.02, 0.03]
after_contact_s: 3.0
"""


@pytest.fixture(scope="session")
def scene(tmp_path_factory):
    """(path of the scene file, the simulate command's JSON summary)."""
    folder = tmp_path_factory.mktemp("vibrotouch")
    cfg = folder / "scene.yaml"
    cfg.write_text(SCENE_YAML)
    out = folder / "scene.h5"
    result = CliRunner().invoke(app, ["simulate", "vibrotouch", "--config", str(cfg), "--out",
                                      str(out), "--seed", "7", "--json", "--no-progress"])
    assert result.exit_code == 0, result.output
    return out, json.loads(result.output)
