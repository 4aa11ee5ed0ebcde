"""`tactile accel-prepare`: numbers checked before any work against the recordings' rate
(issue 33): a segment below one sample (1e-6 s hung), more segments than a prepared file
may hold, a cut-off the resampling cannot reach (1e-9 Hz gave a LinAlgError); the output is
never the input."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from tactile_cli.accel import VibroSceneConfig, simulate_vibro_slip
from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.ingest import ingest
from tactile_cli.spectral import limit_bandwidth, lowest_cutoff_hz

runner = CliRunner()


@pytest.fixture(scope="module")
def recording(tmp_path_factory) -> Path:
    """Three 1 s recordings at 8 kHz (one per texture), ingested."""
    root = tmp_path_factory.mktemp("accel")
    cfg = VibroSceneConfig.model_validate({"orientations_deg": [0], "motor_rps": [0.16],
                                           "duration_s": 1.0})
    simulate_vibro_slip(cfg, root / "scene", seed=0)
    out = root / "rec.h5"
    ingest([root / "scene"], out, format="accel-tree")
    return out


@pytest.mark.parametrize(("args", "words"), [
    (["--segment-s", "1e-6"], ["--segment-s (=1e-06) is shorter than one sample",
                               "8000 Hz"]),
    (["--segment-s", "0.000125"], ["24,000 segments of 1 samples (at most 10,000)"]),
    (["--segment-s", "0.0000625", "--cutoff-hz", "100"], ["shorter than one sample"]),
    (["--cutoff-hz", "1e-9"], ["--cutoff-hz (=1e-09) is below 4 Hz"]),
])
def test_absurd_numbers_are_refused_with_the_reason(recording: Path, tmp_path: Path, args,
                                                    words):
    out = tmp_path / "p.h5"
    res = runner.invoke(app, ["accel-prepare", str(recording), "--out", str(out),
                              "--no-progress", *args])
    assert res.exit_code == 2, res.output
    line = res.stderr.strip()
    assert len(line.splitlines()) == 1 and "Traceback" not in res.output
    for word in words:
        assert word in line, line
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_many_segments_within_the_bound_are_written(recording: Path, tmp_path: Path):
    res = runner.invoke(app, ["accel-prepare", str(recording), "--out", str(tmp_path / "p.h5"),
                              "--segment-s", "0.01", "--no-progress", "--json"])
    assert res.exit_code == 0, res.output
    assert "\"n_segments\": 300" in res.output


def test_the_output_is_never_the_input(recording: Path, tmp_path: Path):
    before = recording.read_bytes()
    for args in (["--out", str(recording), "--overwrite"],
                 ["--out-dir", str(recording.parent), "--overwrite", "--workers", "0"]):
        res = runner.invoke(app, ["accel-prepare", str(recording), "--no-progress", *args])
        assert res.exit_code == 2 and "is the input" in res.stderr, res.output
    assert recording.read_bytes() == before


def test_limit_bandwidth_refuses_a_cut_off_below_its_reach():
    import numpy as np

    assert lowest_cutoff_hz(8000.0) == 4.0
    with pytest.raises(ValueError, match="below 4 Hz"):
        limit_bandwidth(np.zeros((1000, 1)), 8000.0, 1e-9)
    y, rate = limit_bandwidth(np.zeros((1000, 1)), 8000.0, 4.0)
    assert rate == 8.0 and y.shape[1] == 1


def test_prepare_file_checks_numbers_in_the_library(recording: Path, tmp_path: Path):
    from tactile_cli.accel.prepare import prepare_file

    for kwargs in ({"segment_s": float("nan")}, {"segment_s": float("inf")},
                   {"cutoff_hz": float("inf")}, {"cutoff_hz": -1.0}):
        with pytest.raises(InputError):
            prepare_file(recording, tmp_path / "p.h5", **kwargs)
    assert list(tmp_path.iterdir()) == []
