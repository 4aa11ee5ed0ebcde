"""Issue 20: `grade` on a count stream whose sensor metadata is damaged refuses the file
with one line naming it (it used to skip the stream and report NaN areas, exit 0)."""

from __future__ import annotations

import shutil

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app

from .test_features_cli import _stream_file

runner = CliRunner()


@pytest.fixture(scope="module")
def counts(tmp_path_factory):
    path = tmp_path_factory.mktemp("counts") / "counts.h5"
    _stream_file(path, [1, 6, 12])
    return path


def _attr(key, value):
    return lambda h5: h5["sensors/event_counts"].attrs.__setitem__(key, value)


def _dataset(name, data):
    def edit(h5):
        del h5[f"sensors/event_counts/{name}"]
        if data is not None:
            h5[f"sensors/event_counts/{name}"] = data
    return edit


def _del_attr(key):
    return lambda h5: h5["sensors/event_counts"].attrs.__delitem__(key)


def _sensor_missing(h5):
    for trial in h5["trials"].values():
        trial["signals/event_counts"].attrs["sensor"] = "nowhere"


@pytest.mark.parametrize("edit", [
    _attr("sample_rate_hz", "fast"), _attr("sample_rate_hz", np.nan),
    _attr("sample_rate_hz", np.inf), _attr("sample_rate_hz", -50.0),
    _attr("sample_rate_hz", 1e300), _attr("sample_rate_hz", np.ones(3)),
    _attr("kind", "bogus"), _attr("kind", 3), _del_attr("kind"),
    _dataset("channel_names", np.array([1])), _dataset("channel_units", np.array([1])),
    _dataset("channel_names", None), _sensor_missing,
    _dataset("channel_names", np.array([], dtype=h5py.string_dtype())),
], ids=["rate-str", "rate-nan", "rate-inf", "rate-neg", "rate-1e300", "rate-array",
        "kind-bogus", "kind-int", "kind-deleted", "names-int", "units-int", "names-deleted",
        "sensor-missing", "names-short"])
def test_grade_refuses_damaged_sensor_metadata(counts, tmp_path, edit):
    bad = tmp_path / "bad.h5"
    shutil.copy(counts, bad)
    with h5py.File(bad, "a") as h5:
        edit(h5)
    before = bad.read_bytes()
    result = runner.invoke(app, ["grade", str(bad)])
    assert result.exit_code == 2, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("tactile: error: "), result.stderr
    assert str(bad) in lines[0] and "Traceback" not in result.output
    assert bad.read_bytes() == before
