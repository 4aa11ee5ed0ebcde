"""Tables whose rows are trials or samples (`layout: rows`, issue 12, items 2 and 5): one
trial per row with a one-sample stream, label and group columns as trial labels, the
worked example configs/grasp_rows.yaml, a grouped MLP/FNN training on one vector per trial,
and one-line errors (file, line, column) that leave no output behind.
"""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.ingest import ingest
from tactile_cli.store import validate_file

from ..conftest import REPO

runner = CliRunner()
MAPPING = REPO / "configs" / "grasp_rows.yaml"
TRAIN = REPO / "configs" / "train_mlp_grasp_rows.yaml"
OBJECTS = ["mug", "box", "can", "ball", "cup", "jar"]


def write_grasps(path: Path, *, n: int = 36, n_electrodes: int = 6, seed: int = 0) -> np.ndarray:
    """A grasp table ``object,slipped,e1..eN`` with one row per grasp; electrodes shifted by
    +2 when the grasp slipped. Returns the (n, n_electrodes) values as written."""
    rng = np.random.default_rng(seed)
    slipped = np.arange(n) % 2
    values = np.round(rng.normal(size=(n, n_electrodes)) + 2.0 * slipped[:, None], 4)
    lines = ["object,slipped," + ",".join(f"e{i + 1}" for i in range(n_electrodes))]
    for i in range(n):
        cells = ",".join(f"{v:.4f}" for v in values[i])
        lines.append(f"{OBJECTS[i % len(OBJECTS)]},{slipped[i]},{cells}")
    path.write_text("\n".join(lines) + "\n")
    return values


def _mapping(tmp_path: Path, **trials) -> Path:
    doc = yaml.safe_load(MAPPING.read_text())
    doc["trials"].update(trials)
    path = tmp_path / "map.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def _ingest(table: Path, mapping: Path, out: Path) -> Path:
    return ingest([table], out, options={"mapping": mapping}, command="test")


def _nothing_written(folder: Path, out: Path) -> None:
    assert not out.exists()
    assert [p.name for p in folder.iterdir() if ".tmp-" in p.name] == []


def test_each_row_is_a_trial_with_one_sample(tmp_path):
    values = write_grasps(tmp_path / "grasps.csv")
    out = _ingest(tmp_path / "grasps.csv", MAPPING, tmp_path / "g.h5")
    assert validate_file(out).ok
    with h5py.File(out) as f:
        assert len(f["trials"]) == 36
        for i in (0, 7, 35):
            trial = f[f"trials/grasps_{i + 1}"]
            labels = dict(trial["labels"].attrs)
            assert labels == {"slipped": i % 2, "object": OBJECTS[i % 6], "dataset": "grasp_rows"}
            signal = trial["signals/electrodes"]
            np.testing.assert_array_equal(signal["t_s"][()], [0.0])
            np.testing.assert_allclose(signal["data"][()], values[i:i + 1], rtol=1e-6)
        names = list(f["sensors/electrodes/channel_names"].asstr()[()])
        assert names == [f"e{k}" for k in range(1, 7)]


def test_names_from_row_fields(tmp_path):
    write_grasps(tmp_path / "grasps.csv", n=6)
    mapping = _mapping(tmp_path, name="{object}_{row}")
    out = _ingest(tmp_path / "grasps.csv", mapping, tmp_path / "g.h5")
    with h5py.File(out) as f:
        assert list(f["trials"]) == ["mug_1", "box_2", "can_3", "ball_4", "cup_5", "jar_6"]


def test_rows_are_samples_makes_one_trial(tmp_path):
    table = tmp_path / "press.csv"
    table.write_text("object,t,e1,e2\nmug,0.0,1,2\nmug,0.1,3,4\nmug,0.2,5,6\n")
    doc = yaml.safe_load(MAPPING.read_text())
    doc["trials"].update(rows_are="samples", label_columns=[])
    doc["streams"][0].update(channels=["e*"], time={"column": "t", "unit": "s"})
    mapping = tmp_path / "map.yaml"
    mapping.write_text(yaml.safe_dump(doc))
    out = _ingest(table, mapping, tmp_path / "p.h5")
    with h5py.File(out) as f:
        assert list(f["trials"]) == ["press"]
        assert f["trials/press/labels"].attrs["object"] == "mug"
        np.testing.assert_array_equal(f["trials/press/signals/electrodes/data"][()],
                                      [[1, 2], [3, 4], [5, 6]])
    table.write_text("object,t,e1,e2\nmug,0.0,1,2\nbox,0.1,3,4\n")
    with pytest.raises(InputError, match=r"press\.csv, line 3, column 'object': column 'object' "
                                         r"holds 'box' here but 'mug' on line 2"):
        _ingest(table, mapping, tmp_path / "p2.h5")
    _nothing_written(tmp_path, tmp_path / "p2.h5")


@pytest.mark.slow
@pytest.mark.parametrize("family", ["mlp", "fnn"])
def test_train_one_vector_per_trial_grouped_by_object(tmp_path, family):
    pytest.importorskip("torch")
    write_grasps(tmp_path / "grasps.csv")
    data = _ingest(tmp_path / "grasps.csv", MAPPING, tmp_path / "g.h5")
    config = yaml.safe_load(TRAIN.read_text())
    config["optim"]["epochs"] = 2
    config["model"]["family"] = family
    if family == "fnn":
        config["model"].pop("features")
    path = tmp_path / "train.yaml"
    path.write_text(yaml.safe_dump(config))
    run = tmp_path / "run"
    result = runner.invoke(app, ["train", str(path), "--data", str(data), "--out", str(run)])
    assert result.exit_code == 0, result.output
    import json

    info = json.loads((run / "run.json").read_text())
    assert info["split"]["mode"] == "group" and info["split"]["by"] == "object"
    assert sum(info["split"]["trials"].values()) == 36
    splits: dict[str, set[str]] = {}
    import csv

    with h5py.File(data) as f:
        for row in csv.DictReader((run / "split.csv").read_text().splitlines()):
            obj = f[f"trials/{row['trial']}/labels"].attrs["object"]
            splits.setdefault(obj, set()).add(row["split"])
    assert all(len(sides) == 1 for sides in splits.values())  # an object stays on one side


BAD = {
    "empty label": ("object,slipped,e1\nmug,,1.0\n", None,
                    r"t\.csv, line 2, column 'slipped': empty label cell"),
    "missing group column": ("thing,slipped,e1\nmug,1,1.0\n", None,
                             r"t\.csv, line 1: column 'object' \(named by `trials.group` in "
                             r".*map\.yaml\) is not in the file"),
    "bad electrode": ("object,slipped,e1\nmug,1,abc\n", None,
                      r"t\.csv, line 2, column 'e1': column 'e1' holds 'abc', which is not a "
                      r"number"),
    "no channel match": ("object,slipped,x1\nmug,1,1.0\n", None,
                         r"t\.csv, line 1: pattern 'e\*' .* matches no column"),
    "time with row trials": ("object,slipped,e1\nmug,1,1.0\n", {"time": {"sample_rate_hz": 1}},
                             r"map\.yaml.*`streams.electrodes.time`: with `layout: rows` and "
                             r"`rows_are: trials` each row is one sample at t = 0"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_tables_are_one_line_and_write_nothing(tmp_path, case):
    text, stream_extra, message = BAD[case]
    table = tmp_path / "t.csv"
    table.write_text(text)
    doc = yaml.safe_load(MAPPING.read_text())
    doc["streams"][0].update(stream_extra or {})
    mapping = tmp_path / "map.yaml"
    mapping.write_text(yaml.safe_dump(doc))
    out = tmp_path / "o.h5"
    result = runner.invoke(app, ["ingest", str(table), "--mapping", str(mapping), "--out",
                                 str(out), "--no-progress"])
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("tactile: error: ")
    import re

    assert re.search(message, lines[0]), lines[0]
    _nothing_written(tmp_path, out)


def test_rows_keys_belong_to_the_rows_layout(tmp_path):
    doc = yaml.safe_load(MAPPING.read_text())
    doc["trials"]["layout"] = "file"
    doc["streams"][0]["time"] = {"sample_rate_hz": 1}
    mapping = tmp_path / "map.yaml"
    mapping.write_text(yaml.safe_dump(doc))
    table = tmp_path / "t.csv"
    write_grasps(table, n=2)
    with pytest.raises(InputError, match=r"map\.yaml, line \d+: .*`group`, `label_columns`, "
                                         r"`rows_are` belong to `layout: rows`"):
        _ingest(table, mapping, tmp_path / "o.h5")
