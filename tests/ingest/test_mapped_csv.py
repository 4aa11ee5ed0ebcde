"""`ingest --mapping`: generic sensor CSVs, the Xela and BioTac worked examples, bad input."""

from __future__ import annotations

import csv
import hashlib
import time
from pathlib import Path

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.ingest import ingest
from tactile_cli.ingest.mapping import load_mapping
from tactile_cli.samples.signals import write_taxel_recording
from tactile_cli.store import validate_file

from ..conftest import REPO, shared_path

runner = CliRunner()
CONFIGS = REPO / "configs"


class RecordingProgress:
    """A Progress that remembers what it was told."""

    def __init__(self) -> None:
        self.total: float | None = None
        self.done = 0.0
        self.finished = False

    def start(self, total: float, description: str) -> None:
        self.total = total

    def advance(self, amount: float = 1) -> None:
        self.done += amount

    def finish(self) -> None:
        self.finished = True


def _ingest(inputs, mapping, out, **kw) -> Path:
    return ingest([Path(p) for p in inputs], out, options={"mapping": Path(mapping)},
                  command="test", **kw)


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


# -- round trip of the synthetic taxel recording ------------------------------------------------
def test_taxel_recording_round_trip(tmp_path):
    truth = write_taxel_recording(tmp_path / "raw", seed=3)
    progress = RecordingProgress()
    out = _ingest([tmp_path / "raw"], truth["mapping"], tmp_path / "t.h5", progress=progress)
    assert validate_file(out).ok
    assert progress.total == 4 and progress.done == 4 and progress.finished
    with h5py.File(out) as h5:
        sensor = h5["sensors/taxels"]
        assert sensor.attrs["kind"] == "taxel_array"
        assert sensor.attrs["sample_rate_hz"] == pytest.approx(100.0, rel=1e-6)
        assert list(sensor["channel_names"].asstr()[()]) == truth["channels"]
        assert set(sensor["channel_units"].asstr()[()]) == {"kPa"}
        paths = list(h5["provenance/sources/path"].asstr()[()])
        shas = list(h5["provenance/sources/sha256"].asstr()[()])
        assert sorted(h5["trials"]) == sorted(truth["trials"])
        for name, want in truth["trials"].items():
            g = h5["trials"][name]
            assert {k: v for k, v in g["labels"].attrs.items()} == want["labels"]
            assert g.attrs["time_origin_unix_s"] == want["time_origin_unix_s"]
            sig = g["signals/taxels"]
            np.testing.assert_array_equal(sig["data"][()], want["data"])
            np.testing.assert_allclose(sig["t_s"][()], want["t_s"], rtol=0, atol=1e-9)
            np.testing.assert_array_equal(sig["sample_labels/slip"][()], want["slip"])
            assert list(sig["sample_labels/slip"].attrs["classes"]) == truth["classes"]
            (index,) = g.attrs["source_index"]
            assert paths[index] == str(want["path"])
            assert shas[index] == _sha256(want["path"])
        assert "taxels" in h5.attrs["mapping_json"]


def test_configs_are_valid_mappings():
    for name in ("mapping_example.yaml", "xela_slip.yaml", "biotac_slide20.yaml"):
        mapping = load_mapping(CONFIGS / name)
        assert mapping.streams


def _example_recording(root: Path) -> dict:
    """Files laid out as configs/mapping_example.yaml describes (force + headerless vibration)."""
    folder = root / "denim"
    folder.mkdir(parents=True)
    n_force, n_vib = 6, 10
    t_ms = np.array([5.0, 15.0, 25.0, 35.0, 45.0, 55.0])
    force = np.arange(n_force * 3, dtype=np.float32).reshape(n_force, 3) / 4
    speed = np.linspace(0.0, 0.02, n_force)
    phase = ["approach", "press", "press", "slide", "slide", "release"]
    rows = [f"{t:g},{f[0]:g},{f[1]:g},{f[2]:g},{s:.4f},{p}"
            for t, f, s, p in zip(t_ms, force, speed, phase, strict=True)]
    (folder / "denim_01_force.csv").write_text("t_ms,fx,fy,fz,speed,phase\n"
                                               + "\n".join(rows) + "\n")
    vib = np.linspace(-1, 1, n_vib * 3).astype(np.float32).reshape(n_vib, 3)
    vib_text = "\n".join(",".join(f"{v:.9g}" for v in r) for r in vib)
    (folder / "denim_01_vib.csv").write_text(vib_text)  # no header, no final newline
    return {"t_ms": t_ms, "force": force, "speed": speed, "phase": phase, "vib": vib}


def test_mapping_example_ingests_what_it_documents(tmp_path):
    truth = _example_recording(tmp_path / "recordings")
    out = _ingest([tmp_path / "recordings"], CONFIGS / "mapping_example.yaml", tmp_path / "e.h5")
    with h5py.File(out) as h5:
        assert list(h5["trials"]) == ["denim_01"]
        g = h5["trials/denim_01"]
        assert dict(g["labels"].attrs) == {"texture": "denim", "take": "01", "rig": "finger_v2"}
        assert "time_origin_unix_s" not in g.attrs  # not an epoch clock
        force = g["signals/force"]
        assert force.attrs["sensor"] == "fingertip_ft"
        np.testing.assert_array_equal(force["data"][()], truth["force"])
        np.testing.assert_allclose(force["t_s"][()], (truth["t_ms"] - 5.0) / 1000, atol=1e-12)
        classes = list(force["sample_labels/phase"].attrs["classes"])
        assert [classes[c] for c in force["sample_labels/phase"][()]] == truth["phase"]
        np.testing.assert_allclose(force["sample_labels/speed_m_s"][()], truth["speed"], atol=1e-12)
        assert list(h5["sensors/fingertip_ft/channel_names"].asstr()[()]) == [
            "force_x", "force_y", "force_z"]
        assert h5["sensors/fingertip_ft"].attrs["sample_rate_hz"] == pytest.approx(100.0)
        vib = g["signals/vibration"]
        np.testing.assert_array_equal(vib["data"][()], truth["vib"])
        np.testing.assert_array_equal(vib["t_s"][()], np.arange(10) / 2000.0)
        assert h5["sensors/vibration"].attrs["sample_rate_hz"] == 2000.0


# -- trailing delimiter, unroll, folder layout, row-by-row join ---------------------------------
UNROLL_MAPPING = """\
trials: {layout: file, glob: "*.csv"}
files: {"{stem}.csv": {trailing_delimiter: true}}
streams:
  - {name: slow, file: "{stem}.csv", kind: pressure, channels: [q], units: counts,
     time: {column: t, epoch: true}}
  - {name: fast, file: "{stem}.csv", kind: pressure, channels: ["s*"], unroll: {channel: s},
     units: counts, time: {column: t, epoch: true}}
"""


def test_trailing_delimiter_and_unroll(tmp_path):
    raw = tmp_path / "raw"
    raw.mkdir()
    (raw / "r.csv").write_text("t,q,s1,s2,s3\n"
                               "100.00,7,10,11,12,\n100.03,8,20,21,22,\n100.09,9,30,31,32,\n")
    (tmp_path / "m.yaml").write_text(UNROLL_MAPPING)
    out = _ingest([raw], tmp_path / "m.yaml", tmp_path / "u.h5")
    with h5py.File(out) as h5:
        g = h5["trials/r"]
        assert g.attrs["time_origin_unix_s"] == 100.0
        np.testing.assert_array_equal(g["signals/slow/data"][:, 0], [7, 8, 9])  # not shifted
        fast = g["signals/fast"]
        np.testing.assert_array_equal(fast["data"][:, 0], [10, 11, 12, 20, 21, 22, 30, 31, 32])
        # k/3 of the way to the next row; the last row repeats the previous 0.06 s step
        want = [0, 0.01, 0.02, 0.03, 0.05, 0.07, 0.09, 0.11, 0.13]
        np.testing.assert_allclose(fast["t_s"][()], want, atol=1e-9)
        slow_hz = g["signals/slow"].attrs["sample_rate_hz"]
        assert fast.attrs["sample_rate_hz"] == pytest.approx(3 * slow_hz)
    # the same file read without `trailing_delimiter` is refused, with the fix in the message
    (tmp_path / "m2.yaml").write_text(UNROLL_MAPPING.replace("trailing_delimiter: true",
                                                             "trailing_delimiter: false"))
    with pytest.raises(InputError, match=r"r\.csv, line 2: row has 6 fields, expected 5 .*"
                                         r"set `trailing_delimiter: true`"):
        _ingest([raw], tmp_path / "m2.yaml", tmp_path / "u2.h5")


FOLDER_MAPPING = """\
trials: {layout: folder, glob: "run_*", pattern: 'run_(?P<run>\\d+)$'}
streams:
  - name: skin
    file: skin.csv
    kind: taxel_array
    channels: [a, b]
    units: counts
    time: {file: robot.csv, column: time, rate_from: {file: meta.csv, column: hz}}
    sample_labels: [{name: slip, file: labels.csv, column: slip, classes: [still, slipping]}]
  - {name: robot, file: robot.csv, kind: robot_state, channels: [v], units: m/s,
     time: {column: time}}
"""


def _folder_trial(folder: Path, n_skin: int = 4, hz: float = 50.0) -> None:
    folder.mkdir(parents=True)
    (folder / "skin.csv").write_text("a,b\n" + "".join(f"{i},{10 * i}\n" for i in range(n_skin)))
    (folder / "robot.csv").write_text("v,time\n"
                                      + "".join(f"0.{i},{0.02 * i:.2f}\n" for i in range(4)))
    (folder / "labels.csv").write_text("slip\n0.0\n1.0\n1.0\n0.0\n")
    (folder / "meta.csv").write_text(f"note,hz\nx,{hz}\n")


def test_folder_layout_joins_files_row_by_row(tmp_path):
    _folder_trial(tmp_path / "raw" / "run_1", hz=50.0)
    _folder_trial(tmp_path / "raw" / "run_2", hz=52.0)
    (tmp_path / "m.yaml").write_text(FOLDER_MAPPING)
    out = _ingest([tmp_path / "raw"], tmp_path / "m.yaml", tmp_path / "f.h5")
    with h5py.File(out) as h5:
        assert sorted(h5["trials"]) == ["run_1", "run_2"]
        skin = h5["trials/run_2/signals/skin"]
        np.testing.assert_array_equal(skin["data"][()], [[0, 0], [1, 10], [2, 20], [3, 30]])
        np.testing.assert_allclose(skin["t_s"][()], [0, 0.02, 0.04, 0.06])
        np.testing.assert_array_equal(skin["sample_labels/slip"][()], [0, 1, 1, 0])
        assert skin.attrs["sample_rate_hz"] == 52.0  # per trial, from meta.csv
        assert h5["sensors/skin"].attrs["sample_rate_hz"] == 51.0  # median over trials
        assert h5["sensors/robot"].attrs["sample_rate_hz"] == pytest.approx(50.0)
        assert h5["trials/run_1/labels"].attrs["run"] == "1"
    # one trial folder given directly is itself a trial
    out = _ingest([tmp_path / "raw" / "run_1"], tmp_path / "m.yaml", tmp_path / "one.h5")
    with h5py.File(out) as h5:
        assert list(h5["trials"]) == ["run_1"]


def test_joined_files_with_different_row_counts_are_an_error(tmp_path):
    _folder_trial(tmp_path / "raw" / "run_1", n_skin=3)
    (tmp_path / "m.yaml").write_text(FOLDER_MAPPING)
    with pytest.raises(InputError, match=r"run_1: the files of trial 'run_1' joined row by row "
                                         r"for stream 'skin' differ in row count \(skin\.csv 3 "
                                         r"rows, robot\.csv 4 rows, labels\.csv 4 rows\)"):
        _ingest([tmp_path / "raw"], tmp_path / "m.yaml", tmp_path / "f.h5")
    assert not (tmp_path / "f.h5").exists()


# -- bad input, through the library and the CLI --------------------------------------------------
def _one_trial(root: Path) -> dict:
    return write_taxel_recording(root, objects=("foam",), repeats=1, seconds=0.1, seed=1)


def _edit_line(path: Path, line: int, edit) -> None:
    lines = path.read_text().splitlines()
    lines[line - 1] = edit(lines[line - 1])
    path.write_text("\n".join(lines) + "\n")


def _set_field(index: int, value: str):
    def edit(text: str) -> str:
        fields = text.split(",")
        fields[index] = value
        return ",".join(fields)
    return edit


CSV_CASES = {
    "short row": (5, lambda s: ",".join(s.split(",")[:-3]),
                  r"line 5: row has 15 fields, expected 18"),
    "extra column": (4, lambda s: s + ",1.5", r"line 4: row has 19 fields, expected 18"),
    "not a number": (6, _set_field(3, "1.2.3"), r"line 6, column 'p_r0c2': column 'p_r0c2' holds "
                                                r"'1\.2\.3', which is not a number"),
    "empty field": (6, _set_field(2, ""), r"line 6, column 'p_r0c1': column 'p_r0c1' holds an "
                                          r"empty field"),
    "nan value": (3, _set_field(16, "-nan"), r"line 3, column 'p_r3c3': column 'p_r3c3' holds nan"),
    "time goes back": (7, _set_field(0, "1699999999.000000"), r"line 7, column 'timestamp': time "
                                                              r"goes back"),
    "unknown class": (4, _set_field(17, "wobble"), r"line 4, column 'state': label 'wobble' is not "
                                                   r"one of the classes stick, slip"),
    "blank line": (5, lambda s: "", r"line 5: blank line inside the data"),
}


@pytest.mark.parametrize("case", list(CSV_CASES))
def test_bad_csv_rows_name_file_and_line(tmp_path, case):
    truth = _one_trial(tmp_path / "raw")
    (path,) = [t["path"] for t in truth["trials"].values()]
    line, edit, message = CSV_CASES[case]
    _edit_line(path, line, edit)
    outdir = tmp_path / "out"
    outdir.mkdir()
    with pytest.raises(InputError, match=message) as info:
        _ingest([tmp_path / "raw"], truth["mapping"], outdir / "x.h5")
    assert str(info.value).startswith(f"{path}, line {line}")
    assert "\n" not in str(info.value)
    assert list(outdir.iterdir()) == []  # no output, no temporary file


MAPPING_CASES = {
    "missing column": (lambda t: t.replace('channels: ["p_r*"]', 'channels: ["p_r*", p_zz]'),
                       "{csv}, line 1: column 'p_zz' (named by `streams.taxels.channels` in {map}) "
                       "is not in the file"),
    "unknown key": (lambda t: t.replace("    units: kPa", "    unit: kPa"),
                    "{map}, line 15: unknown key `streams[0](taxels).unit` (allowed here: name, "
                    "file, sensor, kind"),
    "not yaml": (lambda t: t.replace("  layout: file", "  layout: [file"),
                 "{map}, line 5, column 7: not valid YAML (expected ',' or ']', but got ':', "
                 "while parsing a flow sequence that starts at line 4)"),
    "pattern no glob match": (lambda t: t.replace('glob: "*.csv"', 'glob: "*.tsv"'),
                              "{raw}: no file matches `trials.glob` '*.tsv' here"),
}


@pytest.mark.parametrize("case", list(MAPPING_CASES))
def test_bad_mapping_names_file_and_line(tmp_path, case):
    truth = _one_trial(tmp_path / "raw")
    (path,) = [t["path"] for t in truth["trials"].values()]
    mapping = tmp_path / "bad.yaml"
    edit, message = MAPPING_CASES[case]
    mapping.write_text(edit(truth["mapping"].read_text()))
    outdir = tmp_path / "out"
    outdir.mkdir()
    with pytest.raises(InputError) as info:
        _ingest([tmp_path / "raw"], mapping, outdir / "x.h5")
    assert str(info.value).startswith(message.format(csv=path, map=mapping, raw=tmp_path / "raw"))
    assert list(outdir.iterdir()) == []


def test_header_less_file_checked_against_column_names(tmp_path):
    raw = tmp_path / "raw"
    raw.mkdir()
    (raw / "a.csv").write_text("1,2\n3,4\n5\n")
    (tmp_path / "m.yaml").write_text(
        "trials: {layout: file, glob: '*.csv'}\ncsv: {header: false, column_names: [x, y]}\n"
        "streams: [{name: s, file: '{stem}.csv', kind: pressure, channels: [x, y], units: kPa, "
        "time: {sample_rate_hz: 10}}]\n")
    with pytest.raises(InputError, match=r"a\.csv, line 3: row has 1 fields, expected 2 like "
                                         r"the `column_names` \(a short or cut-off row\)"):
        _ingest([raw], tmp_path / "m.yaml", tmp_path / "x.h5")


@pytest.mark.parametrize(
    ("case", "message"),
    [("short row", "{csv}, line 5: row has 15 fields, expected 18"),
     ("unknown key", "{map}, line 15: unknown key `streams[0](taxels).unit`"),
     ("missing column", "{csv}, line 1: column 'p_zz'")],
)
def test_cli_bad_input_is_one_line_exit_2(tmp_path, case, message):
    truth = _one_trial(tmp_path / "raw")
    (path,) = [t["path"] for t in truth["trials"].values()]
    mapping = truth["mapping"]
    if case == "short row":
        _edit_line(path, 5, CSV_CASES["short row"][1])
    else:
        mapping = tmp_path / "bad.yaml"
        mapping.write_text(MAPPING_CASES[case][0](truth["mapping"].read_text()))
    outdir = tmp_path / "out"
    outdir.mkdir()
    out = outdir / "x.h5"
    result = runner.invoke(app, ["ingest", str(tmp_path / "raw"), "--mapping", str(mapping),
                                 "--out", str(out)])
    assert result.exit_code == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1
    assert lines[0].startswith("tactile: error: " + message.format(csv=path, map=mapping))
    assert list(outdir.iterdir()) == []


def test_cli_mapped_csv_success(tmp_path):
    truth = _one_trial(tmp_path / "raw")
    out = tmp_path / "x.h5"
    result = runner.invoke(app, ["ingest", str(tmp_path / "raw"), "--mapping",
                                 str(truth["mapping"]), "--out", str(out), "--label", "batch=3"])
    assert result.exit_code == 0, result.stderr
    assert f"wrote {out}" in result.stdout
    with h5py.File(out) as h5:
        assert h5["trials/foam_1/labels"].attrs["batch"] == 3


# -- real recordings: Xela uSkin slip -------------------------------------------------------------
@pytest.fixture(scope="module")
def xela(tmp_path_factory):
    root = shared_path("xela_slip")
    out = tmp_path_factory.mktemp("xela") / "xela.h5"
    t0 = time.perf_counter()
    _ingest([root], CONFIGS / "xela_slip.yaml", out)
    return root, out, time.perf_counter() - t0


def _csv_rows(path: Path) -> list[list[str]]:
    with open(path, newline="") as f:
        return list(csv.reader(f))


def test_xela_all_trials(xela):
    root, out, seconds = xela
    assert seconds > 0  # the time is benchmarks' to measure, not a test's
    assert validate_file(out).ok
    folders = sorted(p for p in root.iterdir() if p.is_dir())
    with h5py.File(out) as h5:
        assert sorted(h5["trials"]) == [p.name for p in folders]
        for sensor in ("sensor1", "sensor2"):
            s = h5["sensors"][sensor]
            assert s.attrs["kind"] == "taxel_array"
            names = list(s["channel_names"].asstr()[()])
            assert len(names) == 48 and names[:4] == ["txl1_x", "txl1_y", "txl1_z", "txl2_x"]
            assert 59.7 < s.attrs["sample_rate_hz"] < 60.0
        steps, slip_by_date, fail_total = {}, {}, 0
        for folder in folders:
            g = h5["trials"][folder.name]
            raw_steps = len(_csv_rows(folder / "xela_sensor1.csv")) - 1
            sig = g["signals/sensor1"]
            steps[folder.name] = sig["data"].shape[0]
            assert sig["data"].shape == (raw_steps, 48)
            assert g["signals/sensor2/data"].shape == (raw_steps, 48)
            meta = _csv_rows(folder / "meta_data.csv")
            assert sig.attrs["sample_rate_hz"] == float(meta[1][meta[0].index("frequency_hz")])
            robot = _csv_rows(folder / "robot_state.csv")
            t_raw = np.array([float(r[robot[0].index("time")]) for r in robot[1:]])
            np.testing.assert_allclose(sig["t_s"][()], t_raw - t_raw[0], atol=1e-12)
            slip = sig["sample_labels/slip"][()]
            assert list(sig["sample_labels/slip"].attrs["classes"]) == ["no_slip", "slip"]
            np.testing.assert_array_equal(slip, g["signals/sensor2/sample_labels/slip"][()])
            date = g["labels"].attrs["date"]
            assert folder.name.startswith(f"data_sample_{date}")
            slip_by_date[date] = slip_by_date.get(date, 0) + int(slip.sum())
            fail_total += int(sig["sample_labels/fail"][()].sum())
        assert min(steps.values()) == 259 and max(steps.values()) == 404
        assert sum(steps.values()) == 2195
        assert slip_by_date == {"2022-02-21": 0, "2022-02-22": 196}
        assert fail_total > 0


def test_xela_values_match_the_raw_text(xela):
    root, out, _ = xela
    folder = sorted(p for p in root.iterdir() if p.is_dir())[-1]
    rows = _csv_rows(folder / "xela_sensor2.csv")
    want = np.array(rows[1:], dtype=np.float64).astype(np.float32)
    labels = np.array(_csv_rows(folder / "slip_label.csv")[1:], dtype=np.float64)
    with h5py.File(out) as h5:
        sig = h5["trials"][folder.name]["signals/sensor2"]
        np.testing.assert_array_equal(sig["data"][()], want)
        np.testing.assert_array_equal(sig["sample_labels/slip"][()], labels[:, 0])
        np.testing.assert_array_equal(sig["sample_labels/fail"][()], labels[:, 1])
        assert h5["trials"][folder.name]["signals/marker/data"].shape[1] == 7


def test_xela_trial_with_a_short_file_is_refused(tmp_path):
    src = shared_path("xela_slip")
    folder = sorted(p for p in src.iterdir() if p.is_dir())[0]
    copy = tmp_path / "xela" / folder.name
    copy.mkdir(parents=True)
    for f in folder.iterdir():
        text = f.read_text()
        if f.name == "slip_label.csv":
            text = "".join(text.splitlines(keepends=True)[:-1])  # drop the last step
        (copy / f.name).write_text(text)
    with pytest.raises(InputError, match=r"differ in row count \(xela_sensor1\.csv 404 rows, "
                                         r"robot_state\.csv 404 rows, slip_label\.csv 403 rows\)"):
        _ingest([tmp_path / "xela"], CONFIGS / "xela_slip.yaml", tmp_path / "x.h5")


# -- real recordings: BioTac sliding over 20 materials --------------------------------------------
@pytest.fixture(scope="module")
def biotac(tmp_path_factory):
    root = shared_path("biotac_slide20")
    out = tmp_path_factory.mktemp("biotac") / "biotac.h5"
    t0 = time.perf_counter()
    _ingest([root], CONFIGS / "biotac_slide20.yaml", out)
    return root, out, time.perf_counter() - t0


@pytest.mark.slow
def test_biotac_all_trials(biotac):
    root, out, seconds = biotac
    assert seconds > 0  # the time is benchmarks/ingest.py's to measure, not a test's
    assert validate_file(out).ok
    with h5py.File(out) as h5:
        trials = h5["trials"]
        assert len(trials) == 200
        materials = [trials[t]["labels"].attrs["material"] for t in trials]
        assert sorted(set(materials)) == sorted(f"mat{m}" for m in range(1, 21))
        assert all(materials.count(m) == 10 for m in set(materials))
        assert 99 < h5["sensors/biotac"].attrs["sample_rate_hz"] < 101
        assert 2178 < h5["sensors/pac"].attrs["sample_rate_hz"] < 2222
        assert 140 < h5["sensors/wrench"].attrs["sample_rate_hz"] < 160
        assert h5["sensors/wrench"].attrs["kind"] == "force_torque"
        assert len(h5["sensors/biotac/channel_names"]) == 22
        for name in trials:
            g = trials[name]
            n = g["signals/biotac/data"].shape[0]
            assert n in (600, 799, 800)  # 10, 8 and 182 trials (the README says 600 or 800)
            assert g["signals/pac/data"].shape == (22 * n, 1)
            assert g["signals/wrench/data"].shape[1] == 6
            assert g["signals/velocity/data"].shape[1] == 3
            assert min(g["signals"][s]["t_s"][0] for s in g["signals"]) == 0.0


def test_biotac_columns_are_not_shifted_by_the_trailing_comma(biotac):
    root, out, _ = biotac
    with h5py.File(out) as h5:
        names = list(h5["sensors/biotac/channel_names"].asstr()[()])
        assert names[:3] == ["tdc", "tac", "pdc"] and names[-1] == "ele19"
        for material, sample in (("mat1", 1), ("mat13", 7), ("mat20", 10)):
            g = h5["trials"][f"{material}_{sample}"]
            assert g["labels"].attrs["material"] == material
            lines = (root / material / f"{material}_{sample}_bio.csv").read_text().splitlines()
            rows = [line.split(",") for line in lines[1:]]
            assert all(r[-1] == "" for r in rows)  # the quirk is there
            raw = np.array([r[:-1] for r in rows], dtype=np.float64)  # 45 fields per row
            data = g["signals/biotac/data"][()]
            np.testing.assert_array_equal(data[:, names.index("ele19")], raw[:, -1])
            np.testing.assert_array_equal(data[:, names.index("tdc")], raw[:, 1])
            assert data[:, names.index("tdc")].max() < 64  # the small counter-like column
            np.testing.assert_array_equal(g["signals/pac/data"][:, 0], raw[:, 4:26].ravel())
            origin = g.attrs["time_origin_unix_s"]
            t_bio = g["signals/biotac/t_s"][()] + origin
            np.testing.assert_allclose(t_bio, raw[:, 0], rtol=0, atol=1e-6)
            np.testing.assert_allclose(g["signals/pac/t_s"][::22], t_bio - origin, atol=1e-9)
            cw_lines = (root / material / f"{material}_{sample}_cw.csv").read_text().splitlines()
            cw = np.array([line.split(",") for line in cw_lines[1:]], dtype=np.float64)
            np.testing.assert_array_equal(g["signals/wrench/data"][()],
                                          cw[:, 1:].astype(np.float32))
            np.testing.assert_allclose(g["signals/wrench/t_s"][()] + origin, cw[:, 0], atol=1e-6)
            assert np.isfinite(g["signals/velocity/data"][()]).all()


def test_biotac_nan_velocity_columns_are_refused_when_selected(tmp_path):
    root = shared_path("biotac_slide20")
    mapping = tmp_path / "with_nan.yaml"
    mapping.write_text((CONFIGS / "biotac_slide20.yaml").read_text()
                       .replace("channels: [x, y, z]\n    channel_names: [v_x, v_y, v_z]",
                                "channels: [x, y, z, a]"))
    trial = root / "mat1" / "mat1_1_bio.csv"  # one trial, given as its file
    with pytest.raises(InputError, match=r"mat1_1_cv\.csv, line 2, column 'a': column 'a' holds "
                                         r"nan \(values must be finite; leave the column out"):
        _ingest([trial], mapping, tmp_path / "x.h5")
    assert not (tmp_path / "x.h5").exists()
    out = _ingest([trial], CONFIGS / "biotac_slide20.yaml", tmp_path / "ok.h5")
    with h5py.File(out) as h5:
        assert list(h5["trials"]) == ["mat1_1"]


def test_biotac_mapping_keeps_a_session_whose_logger_repeats_a_stamp(tmp_path):
    """A later session of the same set whose logger wrote one BioTac row twice at the same
    stamp: the shipped mapping keeps the recording (`stamps: drop_repeats`) and counts what
    it dropped, instead of refusing the whole folder."""
    import shutil

    root = shared_path("biotac_slide20")
    folder = tmp_path / "session" / "mat1"
    folder.mkdir(parents=True)
    for suffix in ("bio", "cw", "cv"):
        shutil.copy(root / "mat1" / f"mat1_1_{suffix}.csv", folder)
    lines = (folder / "mat1_1_bio.csv").read_text().splitlines(keepends=True)
    lines.insert(101, lines[100])  # data row 100 written twice
    (folder / "mat1_1_bio.csv").write_text("".join(lines))
    out = _ingest([tmp_path / "session"], CONFIGS / "biotac_slide20.yaml", tmp_path / "x.h5")
    with h5py.File(out) as h5, h5py.File(
            _ingest([root / "mat1" / "mat1_1_bio.csv"], CONFIGS / "biotac_slide20.yaml",
                    tmp_path / "clean.h5")) as clean:
        got, want = h5["trials/mat1_1/signals/biotac"], clean["trials/mat1_1/signals/biotac"]
        np.testing.assert_array_equal(got["data"][()], want["data"][()])
        assert got.attrs["stamps_repeated"] == 1 and got.attrs["stamps_dropped"] == 1
        assert got.attrs["stamps_policy"] == "drop_repeats"
        assert h5["trials/mat1_1/signals/pac/data"].shape == \
            clean["trials/mat1_1/signals/pac/data"].shape


def test_xela_slip_mapping_keeps_a_trial_whose_clock_repeats_a_step(tmp_path):
    """A later Xela trial whose robot clock writes one step time twice: the shipped mapping
    keeps the trial (`stamps: drop_repeats`), dropping that step from every stream and its
    slip labels alike, so samples and labels stay aligned."""
    import shutil

    trial = shared_path("xela_slip") / "data_sample_2022-02-22-08-10-01"
    copy = tmp_path / "later" / trial.name
    shutil.copytree(trial, copy)
    state = (copy / "robot_state.csv").read_text().splitlines(keepends=True)
    header = state[0].rstrip("\n").split(",")
    col = header.index("time")
    cells = state[51].rstrip("\n").split(",")  # data row 50 takes row 49's time
    cells[col] = state[50].rstrip("\n").split(",")[col]
    state[51] = ",".join(cells) + "\n"
    (copy / "robot_state.csv").write_text("".join(state))
    out = _ingest([tmp_path / "later"], CONFIGS / "xela_slip.yaml", tmp_path / "x.h5")
    clean = _ingest([trial], CONFIGS / "xela_slip.yaml", tmp_path / "clean.h5")
    with h5py.File(out) as h5, h5py.File(clean) as ref:
        (name,) = list(h5["trials"])
        for stream in ("sensor1", "sensor2", "robot", "marker"):
            where = f"trials/{name}/signals/{stream}"
            got, want = h5[where], ref[where]
            np.testing.assert_array_equal(got["data"][()], np.delete(want["data"][()], 50, 0))
            assert got.attrs["stamps_dropped"] == 1
        got, want = h5[f"trials/{name}/signals/sensor1"], ref[f"trials/{name}/signals/sensor1"]
        for label in ("slip", "fail"):
            np.testing.assert_array_equal(got[f"sample_labels/{label}"][()],
                                          np.delete(want[f"sample_labels/{label}"][()], 50))
