"""`tactile plot FILE... --out DIR`: quick-look PNGs and one self-contained HTML page."""

from __future__ import annotations

import base64
import re

import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.store import StoreWriter

runner = CliRunner()
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _file(path, n_trials=2):
    """Trials with an accelerometer stream (and a per-sample label), events and frames."""
    rng = np.random.default_rng(0)
    with StoreWriter(path, command="test") as w:
        acc = w.add_sensor(
            "acc", kind="accelerometer", sample_rate_hz=100, channel_names=["x", "y"],
            channel_units="g",
        )
        cam = w.add_sensor("dvs", kind="event_camera", sample_rate_hz=0, width_px=32, height_px=24)
        gel = w.add_sensor("gel", kind="visuotactile", sample_rate_hz=10, width_px=32, height_px=24)
        for i in range(n_trials):
            trial = w.trial(f"t{i}", labels={"object": "wood"})
            state = (np.arange(100) >= 50).astype(np.int8)
            trial.write_signal(
                "acc", sensor=acc, data=rng.normal(size=(100, 2)), t_s=np.arange(100) / 100,
                sample_labels={"slip": (state, ["stick", "slip"])},
            )
            n = 500
            events = trial.events(cam)
            events.append(
                rng.integers(0, 32, n), rng.integers(0, 24, n),
                np.sort(rng.integers(0, 1_000_000, n)), rng.choice([-1, 1], n).astype(np.int8),
            )
            events.close()
            reference = np.full((24, 32, 3), 128, np.uint8)
            images = rng.integers(0, 255, (3, 24, 32, 3), dtype=np.uint8)
            trial.write_frames(sensor=gel, images=images, t_s=np.arange(3) / 10,
                               reference=reference)
        w.commit()
    return path


@pytest.mark.slow
def test_plot_writes_pngs_and_html_page(tmp_path):
    f = _file(tmp_path / "rec.h5")
    out = tmp_path / "figs"
    result = runner.invoke(app, ["plot", str(f), "--out", str(out)])
    assert result.exit_code == 0, result.output
    page = out / "index.html"
    assert result.output.strip() == f"wrote {page}"
    pngs = sorted(p.name for p in out.glob("*.png"))
    assert pngs == [f"rec__t{i}__{kind}.png" for i in (0, 1)
                    for kind in ("events", "frames", "signals")]
    for name in pngs:
        assert (out / name).read_bytes().startswith(PNG_MAGIC), name
    # self-contained: every figure embedded as a data URI, with its summary beside it
    html = page.read_text(encoding="utf-8")
    embedded = re.findall(r"src='data:image/png;base64,([^']+)'", html)
    assert sorted(base64.b64decode(d) for d in embedded) == sorted(
        (out / name).read_bytes() for name in pngs
    )
    assert "<h2>rec.h5</h2>" in html and "2 trials" in html
    for sensor in ("acc", "dvs", "gel"):
        assert f"<td>{sensor}</td>" in html
    assert "rec.h5 / t0 (object=wood): events per 20 ms" in html


@pytest.mark.slow
def test_plot_max_trials_limits_the_figures(tmp_path):
    f = _file(tmp_path / "rec.h5", n_trials=3)
    out = tmp_path / "figs"
    result = runner.invoke(app, ["plot", str(f), "-o", str(out), "--max-trials", "1"])
    assert result.exit_code == 0, result.output
    assert {p.name.split("__")[1] for p in out.glob("*.png")} == {"t0"}
    assert "3 trials" in (out / "index.html").read_text(encoding="utf-8")


def test_plot_missing_input_is_one_line_exit_2(tmp_path):
    good = _file(tmp_path / "rec.h5", n_trials=1)
    missing = tmp_path / "nope.h5"
    out = tmp_path / "figs"
    result = runner.invoke(app, ["plot", str(good), str(missing), "--out", str(out)])
    assert result.exit_code == 2
    assert result.stderr == f"tactile: error: {missing}: file not found\n"
    assert result.stdout == ""
    assert not out.exists()  # checked before anything is drawn or written
