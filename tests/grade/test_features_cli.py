"""Areas of the press region from HDF5 files and CSV tables, and `tactile grade`."""

from __future__ import annotations

import json

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.grade import default_config_path, load_areas, load_config, press_area
from tactile_cli.store import StoreWriter
from tactile_cli.vocabulary import ACTIONS, BIN_S

from ..factories.press_regions import expected_press, level_alpha

runner = CliRunner()


def test_press_area_sums_the_bins_whose_centre_is_inside():
    t = (np.arange(10) + 0.5) * 0.02
    net = np.arange(10) * 10
    assert press_area(net, t, 0.04, 0.1) == 20 + 30 + 40  # centres 0.05, 0.07, 0.09


def _stream_file(path, levels, *, annotate=False, with_labels=True):
    """A synth-like file: per trial a `net` count stream with per-sample action labels."""
    truth = {}
    with StoreWriter(path, command="test") as w:
        s = w.add_sensor("event_counts", kind="event_camera", sample_rate_hz=1 / BIN_S,
                         channel_names=["net"], channel_units="events/bin", width_px=640,
                         height_px=480, bin_s=BIN_S)
        for level in levels:
            press = np.round(expected_press(float(level_alpha(level))))
            net = np.concatenate([np.full(20, 3.0), press, np.full(30, 500.0)])
            t_s = (np.arange(net.size) + 0.5) * BIN_S
            lab = np.concatenate([np.zeros(20), np.ones(press.size), np.full(30, 2)])
            labels = {"force_level": int(level), "force_grade": ["light", "small", "small medium",
                      "medium", "small big", "big"][(level - 1) // 2]} if with_labels else {}
            ann = [(0.4, 0.4 + 10 * BIN_S, "press")] if annotate else ()
            tw = w.trial(f"level{level:02d}", labels=labels, annotations=ann)
            tw.write_signal("event_counts", sensor=s, data=net, t_s=t_s,
                            sample_labels={"action": (lab.astype(np.int8), ACTIONS)})
            truth[tw.name] = press[:10].sum() if annotate else press.sum()
        w.commit()
    return truth


def test_areas_from_a_count_stream_with_sample_labels(tmp_path):
    truth = _stream_file(tmp_path / "s.h5", [1, 6, 12])
    areas = load_areas([tmp_path / "s.h5"])
    assert {a.trial: a.area for a in areas} == truth
    assert {a.source for a in areas} == {"sample_labels"}
    assert areas[1].labels == {"force_level": 6, "force_grade": "small medium"}


def test_annotations_take_precedence(tmp_path):
    truth = _stream_file(tmp_path / "s.h5", [3], annotate=True)
    (a,) = load_areas([tmp_path / "s.h5"])
    assert (a.area, a.source) == (truth["level03"], "annotations")


def test_areas_from_events_with_an_annotated_press(tmp_path):
    rng = np.random.default_rng(0)
    t = np.sort(rng.integers(0, 2_000_000, 5000))
    t[0] = 0
    p = rng.choice(np.array([-1, 1], np.int8), 5000)
    with StoreWriter(tmp_path / "e.h5", command="test") as w:
        w.add_sensor("cam", kind="event_camera", sample_rate_hz=0, width_px=640, height_px=480)
        tw = w.trial("t0", annotations=[(0.5, 1.2, "press")], labels={"force_level": 4})
        app_ = tw.events("cam")
        app_.append(np.zeros(5000, np.uint16), np.zeros(5000, np.uint16), t, p)
        app_.close()
        w.commit()
    (a,) = load_areas([tmp_path / "e.h5"])
    # bins of 20 ms whose centre lies in [0.5, 1.2): bins 25 .. 59, i.e. t in [0.5, 1.2) s
    inside = (t >= 500_000) & (t < 1_200_000)
    assert a.area == p[inside].sum() and a.source == "annotations"


def test_csv_areas_and_bad_rows(tmp_path):
    good = tmp_path / "a.csv"
    good.write_text("trial,area,level\nt1,27000,1\nt2,42000.5,big\nt3,33000,\n")
    rows = load_areas([good])
    assert [(r.trial, r.area, r.labels) for r in rows] == [
        ("t1", 27000.0, {"force_level": 1}), ("t2", 42000.5, {"force_grade": "big"}),
        ("t3", 33000.0, {})]
    bad = tmp_path / "b.csv"
    bad.write_text("trial,area\nt1,27000\nt2,lots\n")
    with pytest.raises(InputError, match=r"b.csv, line 3: area 'lots' is not a number"):
        load_areas([bad])
    (tmp_path / "c.csv").write_text("name,value\n")
    with pytest.raises(InputError, match="line 1: header"):
        load_areas([tmp_path / "c.csv"])


# -- CLI ---------------------------------------------------------------------------------------
def _csv(tmp_path):
    cfg = load_config(default_config_path())
    meds = [g["median"] for g in cfg.provenance["per_grade"]]
    lines = ["trial,area,level"] + [f"t{k},{m},{2 * k + 1}" for k, m in enumerate(meds)]
    lines.append(f"wrong,{meds[3]},1")  # a light trial with a medium area: 3 grades off
    path = tmp_path / "areas.csv"
    path.write_text("\n".join(lines) + "\n")
    return path


def test_cli_table(tmp_path):
    result = runner.invoke(app, ["grade", str(_csv(tmp_path))])
    assert result.exit_code == 0, result.output
    assert "t3" in result.output and "medium->medium=1.00" in result.output
    assert "7 labelled trials: 85.7 % graded right, 0.0 % off by one grade, 14.3 % worse" \
        in result.output
    assert "Pearson r of area with force level" in result.output


def test_cli_json(tmp_path):
    result = runner.invoke(app, ["grade", str(_csv(tmp_path)), "--json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.output)
    assert data["summary"]["accuracy"] == pytest.approx(6 / 7)
    assert data["summary"]["worse"] == pytest.approx(1 / 7)
    t0 = data["trials"][0]
    assert (t0["grade"], t0["true_grade"], t0["true_level"], t0["error"]) == \
        ("light", "light", 1, 0)
    assert t0["crisp"] == pytest.approx(0.0, abs=1e-12)
    assert t0["firing"]["very_small->light"] == 1.0 and len(t0["firing"]) == 6
    assert data["trials"][-1]["error"] == 3 and data["method"] == "closed_form"


def test_cli_unknown_config_key_exits_2(tmp_path):
    raw = yaml.safe_load(default_config_path().read_text())
    raw["output"]["resolutoin"] = 5
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump(raw, sort_keys=False))
    result = runner.invoke(app, ["grade", str(_csv(tmp_path)), "--config", str(bad)])
    assert result.exit_code == 2
    assert "unknown key `output.resolutoin`" in result.output
    assert str(bad) in result.output


def test_cli_bad_csv_row_exits_2(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("trial,area\nt1,100\nt2,100,7\n")
    result = runner.invoke(app, ["grade", str(bad)])
    assert result.exit_code == 2
    assert f"tactile: error: {bad}, line 3: 3 fields, expected 2 (trial,area)" in result.output


@pytest.mark.slow
def test_cli_calibrate_and_plot(tmp_path):
    truth = _stream_file(tmp_path / "s.h5", list(range(1, 13)) * 2)
    assert len(truth) == 24
    out = tmp_path / "new.yaml"
    result = runner.invoke(app, ["grade", str(tmp_path / "s.h5"), "--calibrate", "--out",
                                 str(out), "--plot", str(tmp_path / "fig"), "--json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.output)
    assert data["summary"]["accuracy"] == 1.0
    assert data["summary"]["pearson_r"] > 0.99
    cfg = load_config(out)
    assert cfg.provenance["n_trials"] == 24
    assert cfg.provenance["inputs"][0]["path"] == str(tmp_path / "s.h5")
    assert out.read_text().startswith("# tactile grade config calibrated by")
    for name in ("membership.png", "inference.png", "area_vs_level.png"):
        assert (tmp_path / "fig" / name).stat().st_size > 10_000
    again = runner.invoke(app, ["grade", str(tmp_path / "s.h5"), "--calibrate", "--out",
                                str(out)])
    assert again.exit_code == 2 and "pass --overwrite" in again.output
    alone = runner.invoke(app, ["grade", str(tmp_path / "s.h5"), "--out", str(out)])
    assert alone.exit_code == 2 and "add --calibrate" in alone.output


def test_cli_unlabelled_calibration_and_bad_label_key(tmp_path):
    _stream_file(tmp_path / "s.h5", [1, 2], with_labels=False)
    result = runner.invoke(app, ["grade", str(tmp_path / "s.h5"), "--calibrate", "--out",
                                 str(tmp_path / "n.yaml")])
    assert result.exit_code == 2 and "needs labelled trials" in result.output
    result = runner.invoke(app, ["grade", str(tmp_path / "s.h5"), "--label-key", "force"])
    assert result.exit_code == 2 and "must be force_grade or force_level" in result.output


def test_fitted_press_gain_as_the_input(tmp_path):
    import h5py

    from tactile_cli.fos.table import COLUMNS, STRING_COLUMNS

    path = tmp_path / "s.h5"
    _stream_file(path, [2, 11])
    with h5py.File(path, "a") as h5:
        g = h5.create_group("derived/fits/fos_press")
        values = {"trial": ["level02", "level11"], "alpha": [1448.2, np.nan],
                  "status": ["converged", "max_steps"], "order_verdict": ["first_order"] * 2}
        for c in COLUMNS:
            if c in STRING_COLUMNS:
                g.create_dataset(c, data=np.array(values[c], dtype=object),
                                 dtype=h5py.string_dtype())
            else:
                g.create_dataset(c, data=np.array(values.get(c, [0.5, 0.5]), dtype=float))
    a, b = load_areas([path], kind="fos_alpha")
    assert (a.trial, a.area, a.source, a.labels["force_level"]) == \
        ("level02", 1448.2, "fos_press", 2)
    assert np.isnan(b.area) and b.status == "press fit not converged: max_steps"
    with pytest.raises(InputError, match="no /derived/fits/fos_press; write it with "
                                         "`tactile fit-fos"):
        load_areas([_copy_without_fits(tmp_path)], kind="fos_alpha")


def _copy_without_fits(tmp_path):
    path = tmp_path / "plain.h5"
    _stream_file(path, [1])
    return path


def test_segmentation_gives_the_region_of_a_trial_without_annotations(tmp_path):
    from ..factories.event_counts import make_trial

    trial = make_trial(np.random.default_rng(5))
    net = (trial.positive - trial.negative).astype(float)
    with StoreWriter(tmp_path / "u.h5", command="test") as w:
        s = w.add_sensor("event_counts", kind="event_camera", sample_rate_hz=1 / BIN_S,
                         channel_names=["net"], channel_units="events/bin", width_px=64,
                         height_px=48, bin_s=BIN_S)
        for name, values in (("found", net), ("flat", np.zeros(100))):
            w.trial(name).write_signal("event_counts", sensor=s, data=values,
                                       t_s=(np.arange(values.size) + 0.5) * BIN_S)
        w.commit()
    found, flat = load_areas([tmp_path / "u.h5"])
    tl = trial.timeline
    assert found.source == "segmentation" and found.status == "ok"
    assert found.region_start_s == pytest.approx(tl.press_start_s, abs=2 * BIN_S)
    assert found.region_end_s == pytest.approx(tl.slip_start_s, abs=3 * BIN_S)
    assert found.area == press_area(net, (np.arange(net.size) + 0.5) * BIN_S,
                                    found.region_start_s, found.region_end_s)
    assert np.isnan(flat.area) and flat.status.startswith("segmentation failed: ")
