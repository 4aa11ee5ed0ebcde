"""Three tiny trained and evaluated runs (LSTM, FNN, MLP) shared by the compare, perturb
and report tests: trained once per test session (about 5 s) whichever module asks first."""

from __future__ import annotations

from pathlib import Path

from tactile_cli.learn.evaluate import evaluate
from tactile_cli.learn.train import train

from .conftest import tiny_config

FAMILIES = {
    "lstm": {"family": "lstm", "hidden": 16},
    "fnn": {"family": "fnn", "hidden": [16]},
    "mlp": {"family": "mlp", "hidden": [16]},
}
_CACHE: dict[str, dict[str, Path]] = {}


def tiny_runs(tmp_path_factory, action_file: Path, heldout_file: Path) -> dict[str, Path]:
    """family -> run folder, each trained 10 epochs on ``action_file`` and evaluated on
    ``heldout_file`` (RUN/eval/<heldout stem>/, latency measured)."""
    key = str(heldout_file)
    if key not in _CACHE:
        root = tmp_path_factory.mktemp("tiny_runs")
        out = {}
        for family, model in FAMILIES.items():
            cfg = tiny_config(model=model, data={"label_delay": 5}, optim={"epochs": 10})
            run = root / family
            train(cfg, [action_file], run, command="tests")
            evaluate(run, [heldout_file], command="tests")
            out[family] = run
        _CACHE[key] = out
    return _CACHE[key]
