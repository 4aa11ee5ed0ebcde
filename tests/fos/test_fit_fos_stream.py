"""`tactile fit-fos FILE --stream NAME`: step fits of a sampled stream over annotated
regions, per channel and on the channel mean, and the one-line errors."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app

from ..factories.fos_counts import use_test_compilation_cache
from .stream_steps import write_stream_file

runner = CliRunner()


@pytest.fixture(scope="module", autouse=True)
def _compilation_cache():
    use_test_compilation_cache()


@pytest.fixture(scope="module")
def source(tmp_path_factory):
    path = tmp_path_factory.mktemp("stream") / "skin.h5"
    return path, write_stream_file(path)


def _fit(path, *args):
    result = runner.invoke(app, ["fit-fos", str(path), "--stream", "taxels", *args, "--json"])
    assert result.exit_code == 0, result.output
    return json.loads(result.stdout)


@pytest.mark.slow
def test_per_channel_recovers_tau_and_alpha(source, tmp_path):
    path, truth = source
    csv_path = tmp_path / "fits.csv"
    out = _fit(path, "--channels", "fz_*", "--region-label", "press", "--csv", str(csv_path))
    fits = out["regions"]["taxels"]["fits"]
    assert len(fits) == len(truth)
    by_key = {(f["trial"], f["channel"]): f for f in fits}
    for tr in truth:
        f = by_key[(tr["trial"], tr["channel"])]
        assert f["region"] == "press" and f["units"] == "N" and f["model"] == "step"
        assert f["status"] == "converged"
        assert f["tau_s"] == pytest.approx(tr["tau_s"], rel=0.03)
        assert f["alpha"] == pytest.approx(tr["alpha"], abs=0.02)
        assert f["baseline"] == pytest.approx(tr["offset"], abs=0.01)
        assert f["order_verdict"] in ("first_order", "undecided")
    with open(csv_path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == len(truth) and {"trial", "channel", "region", "alpha", "tau_s",
                                        "status", "order_verdict"} <= set(rows[0])


def test_mean_of_channels(source):
    path, truth = source
    out = _fit(path, "--channels", "fz_*", "--reduce", "mean", "--region-label", "press")
    fits = out["regions"]["taxels"]["fits"]
    assert [f["trial"] for f in fits] == ["trial_0", "trial_1", "trial_2"]
    for f in fits:
        chans = [tr for tr in truth if tr["trial"] == f["trial"]]
        mean_alpha = np.mean([tr["alpha"] for tr in chans])
        assert f["channel"] == "mean(fz_*)" and f["status"] == "converged"
        assert f["alpha"] == pytest.approx(mean_alpha, rel=0.03)
        taus = [tr["tau_s"] for tr in chans]  # a mean of steps: tau between the extremes
        assert min(taus) * 0.95 < f["tau_s"] < max(taus) * 1.05


@pytest.mark.slow
def test_every_annotation_by_default_and_table(source):
    path, _ = source
    out = _fit(path, "--channels", "fz_0")
    regions = [(f["trial"], f["region"]) for f in out["regions"]["taxels"]["fits"]]
    assert regions == [(f"trial_{k}", r) for k in range(3) for r in ("press", "release")]
    result = runner.invoke(app, ["fit-fos", str(path), "--stream", "taxels", "--channels",
                                 "fz_1", "--region-label", "press"])
    assert result.exit_code == 0, result.output
    assert "fz_1" in result.output and "alpha (N)" in result.output


@pytest.mark.parametrize("args, message", [
    (["--stream", "nope"], "no stream 'nope'"),
    (["--stream", "taxels", "--channels", "fx_*"], "--channels (='fx_*') matches no channel"),
    (["--stream", "taxels", "--region-label", "slip"], "no annotations labelled 'slip'"),
    (["--stream", "taxels", "--reduce", "mean"],
     "--reduce mean averages channels of different units"),
    (["--channels", "fz_*"], "applies with --stream"),
    (["--stream", "taxels", "--press-duration", "0.5"], "--press-duration applies with "
                                                         "--model pulse"),
    (["--stream", "taxels", "--regions", "detect", "--region-label", "press"],
     "found in the signal are labelled rise or fall"),
    (["--min-snr", "5"], "--min-snr applies with --stream"),
])
def test_errors(source, args, message):
    path, _ = source
    result = runner.invoke(app, ["fit-fos", str(path), *args])
    assert result.exit_code == 2, result.output
    assert message in result.output and len(result.output.strip().splitlines()) == 1


def test_trial_without_annotations(tmp_path):
    path = tmp_path / "bare.h5"
    write_stream_file(path, n_trials=1, annotate=False)
    result = runner.invoke(app, ["fit-fos", str(path), "--stream", "taxels"])
    assert result.exit_code == 2 and "no annotations to fit" in result.output
