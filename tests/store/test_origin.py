"""Where trials come from (`tactile_cli.store.origin`): labels first, then the file's
command, never a guess of "recorded"."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from tactile_cli.store import StoreWriter
from tactile_cli.store.origin import (
    command_origin,
    data_origin,
    describe_origin,
    unknown_origin,
)


def _file(path, trials: dict[str, dict], *, command: str = "tactile ingest x.npy"):
    """A tactile file with one small signal per trial and the given trial labels."""
    with StoreWriter(path, command=command) as w:
        acc = w.add_sensor("acc", kind="accelerometer", sample_rate_hz=100,
                           channel_names=["a"], channel_units=["g"])
        for name, labels in trials.items():
            w.trial(name, labels=labels).write_signal(
                "acc", sensor=acc, data=np.zeros((10, 1), np.float32),
                t_s=np.arange(10) / 100)
        w.commit()
    return path


def test_labels_give_the_origin_dataset_and_lab(tmp_path):
    rec = _file(tmp_path / "bt.h5", {
        f"mat{i}_1": {"origin": "recorded", "dataset": "biotac_slide20",
                      "lab": "Gao et al., IROS 2020"} for i in range(3)})
    o = data_origin([rec])
    assert o["kind"] == "recorded"
    assert o["datasets"] == ["biotac_slide20"] and o["labs"] == ["Gao et al., IROS 2020"]
    (f,) = o["files"]
    assert f["path"] == str(rec) and f["kind"] == "recorded" and f["n_trials"] == 3
    assert f["trials"] == {"recorded": 3} and f["from"] == "labels"
    json.dumps(o)  # JSON-ready
    assert describe_origin(o) == "recorded: biotac_slide20 · Gao et al., IROS 2020"


def test_files_of_different_origins_are_mixed(tmp_path):
    sim = _file(tmp_path / "scene.h5", {"g1_level01": {"origin": "simulated",
                                                       "dataset": "marker-events seed 1"}})
    rec = _file(tmp_path / "x.h5", {"a": {"origin": "Recorded ", "dataset": "xela_slip"}})
    o = data_origin([sim, rec])
    assert o["kind"] == "mixed"
    assert [f["kind"] for f in o["files"]] == ["simulated", "recorded"]
    assert o["datasets"] == ["marker-events seed 1", "xela_slip"]
    assert describe_origin(o) == "mixed: simulated (scene.h5), recorded (x.h5)"


def test_trials_of_one_file_can_be_mixed_and_unlabelled_trials_are_unknown(tmp_path):
    p = _file(tmp_path / "m.h5", {"a": {"origin": "recorded"}, "b": {}, "c": {"origin": "real"}})
    (f,) = data_origin([p])["files"]
    assert f["kind"] == "mixed" and f["trials"] == {"recorded": 1, "unknown": 2}
    assert any("'real' is not one of recorded, simulated, synthetic" in n for n in f["notes"])


def test_command_decides_for_unlabelled_trials_but_never_says_recorded(tmp_path):
    synth = _file(tmp_path / "s.h5", {"synth_00000": {}},
                  command="tactile synth --n 1 --out s.h5")
    o = data_origin([synth])
    assert o["kind"] == "synthetic" and o["files"][0]["from"] == "command"
    plain = _file(tmp_path / "p.h5", {"t": {"object": "box"}})
    o = data_origin([plain])
    assert o["kind"] == "unknown" and o["files"][0]["from"] == "none"
    assert describe_origin(o) == "unknown (no origin label on the trials)"
    assert command_origin("/usr/bin/tactile synth -o x.h5") == "synthetic"
    assert command_origin("python -m tactile_cli synth") is None  # not the tactile entry
    assert command_origin("tactile ingest a.csv") is None
    assert command_origin("tactile 'unbalanced") is None
    assert command_origin("") is None


def test_a_missing_or_damaged_file_is_unknown_with_a_note(tmp_path):
    bad = tmp_path / "bad.h5"
    bad.write_bytes(b"not hdf5")
    o = data_origin([tmp_path / "gone.h5", bad])
    assert o["kind"] == "unknown"
    notes = [f["notes"][0] for f in o["files"]]
    assert "file not found" in notes[0] and "not a readable HDF5 file" in notes[1]
    assert describe_origin(o).startswith("unknown (not read: file not found")
    assert data_origin([])["kind"] == "unknown"
    u = unknown_origin(["a.h5"], "data file no longer at its path")
    assert u["kind"] == "unknown" and u["files"][0]["notes"] == ["data file no longer at its path"]


@pytest.mark.parametrize("kind", ["simulated", "synthetic"])
def test_describe_without_dataset(kind):
    assert describe_origin({"kind": kind, "datasets": [], "labs": []}) == kind


def test_the_real_recordings_mappings_label_their_origin_and_lab():
    from tactile_cli.ingest.mapping import load_mapping

    configs = Path(__file__).resolve().parents[2] / "configs"
    xela = load_mapping(configs / "xela_slip.yaml").trials.labels
    biotac = load_mapping(configs / "biotac_slide20.yaml").trials.labels
    assert xela == {"origin": "recorded", "dataset": "xela_slip",
                    "lab": "Intelligent Manipulation Lab (Nazari et al., CoRL 2022)"}
    assert biotac == {"origin": "recorded", "dataset": "biotac_slide20",
                      "lab": "Gao et al., IROS 2020"}
