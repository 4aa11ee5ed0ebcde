from __future__ import annotations

import pytest

from tactile_cli.taxel import TaxelSceneConfig, simulate_taxel_slip


@pytest.fixture(scope="session")
def taxel_file(tmp_path_factory):
    """A small scene: every preset, 10 trials per slip type, seed 101 (a test seed; the
    reported figures use other seeds)."""
    out = tmp_path_factory.mktemp("taxel") / "scene.h5"
    simulate_taxel_slip(TaxelSceneConfig(trials_per_class=10), out, seed=101)
    return out
