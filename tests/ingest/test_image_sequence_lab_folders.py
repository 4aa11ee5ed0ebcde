"""Image-sequence folders as labs store them: frames named by index, the reference given by
name or taken as the first frame (`--reference`), a per-trial labels.json, 320x240 and
480x640 frames, the gel scale (`--px-per-mm`)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.store.trials import TactileFile

runner = CliRunner()


def _frames(folder: Path, n: int, *, size_hw: tuple[int, int], names: str = "{k}.png",
            seed: int = 0) -> list[np.ndarray]:
    """n random RGB frames named ``names.format(k=k)`` (k = 0..n-1); returns them."""
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    images = [rng.integers(0, 256, (*size_hw, 3), dtype=np.uint8) for _ in range(n)]
    for k, image in enumerate(images):
        Image.fromarray(image).save(folder / names.format(k=k))
    return images


def _ingest(*args: str) -> tuple[int, str]:
    res = runner.invoke(app, ["ingest", *args, "--no-progress"])
    return res.exit_code, res.output


@pytest.mark.slow
@pytest.mark.parametrize("size_hw", [(240, 320), (480, 640)])
def test_reference_first_keeps_frame_zero(tmp_path: Path, size_hw: tuple[int, int]) -> None:
    trial = tmp_path / "digit" / "press_01"
    images = _frames(trial, 12, size_hw=size_hw)  # 0.png ... 11.png, natural order
    out = tmp_path / "out.h5"
    code, output = _ingest(str(tmp_path / "digit"), "--reference", "first", "--px-per-mm",
                           "16.5", "--out", str(out))
    assert code == 0, output
    with TactileFile(out) as f:
        frames = f.trial("press_01").frames()
        assert len(frames) == 12 and frames.shape == (*size_hw, 3)
        assert np.array_equal(frames.reference, images[0])
        assert np.array_equal(frames[0], images[0]) and np.array_equal(frames[10], images[10])
        sensor = f.sensor(frames.sensor_name)
        assert (sensor.width_px, sensor.height_px) == (size_hw[1], size_hw[0])
        assert sensor.attrs["px_per_mm"] == 16.5
        assert frames.t_s[3] == pytest.approx(0.1)


def test_reference_by_name_is_not_a_frame(tmp_path: Path) -> None:
    trial = tmp_path / "grasp_3"
    images = _frames(trial, 5, size_hw=(480, 640), names="frame{k:03d}.png")
    background = np.full((480, 640, 3), 90, dtype=np.uint8)
    Image.fromarray(background).save(trial / "BG.png")
    out = tmp_path / "out.h5"
    code, output = _ingest(str(trial), "--reference", "bg", "--out", str(out))
    assert code == 0, output
    with TactileFile(out) as f:
        frames = f.trial("grasp_3").frames()
        assert len(frames) == 5
        assert np.array_equal(frames.reference, background)
        assert np.array_equal(frames[4], images[4])


def test_labels_json_per_trial(tmp_path: Path) -> None:
    root = tmp_path / "session"
    for name, labels in (("t1", {"object": "cable", "slip": "slip", "slip_onset_s": 1.5,
                                 "split": "test"}),
                         ("t2", {"object": "box", "slip": "no_slip", "lit": True})):
        _frames(root / name, 3, size_hw=(240, 320), names="img_{k}.png")
        (root / name / "labels.json").write_text(json.dumps(labels))
    csv = tmp_path / "more.csv"
    csv.write_text("trial,operator\nt1,ann\nt2,bob\n")
    out = tmp_path / "out.h5"
    code, output = _ingest(str(root), "--reference", "first", "--trial-labels", str(csv),
                           "--out", str(out))
    assert code == 0, output
    with TactileFile(out) as f:
        t1, t2 = f.trial("t1"), f.trial("t2")
        assert t1.labels == {"object": "cable", "slip": "slip", "slip_onset_s": 1.5,
                             "operator": "ann"}
        assert t1.split == "test" and t2.split == ""
        assert t2.labels["lit"] == 1 and t2.labels["operator"] == "bob"
        sources = [s.path for s in f.sources]
        assert any(p.endswith("t1/labels.json") for p in sources)


@pytest.mark.slow
def test_labels_json_errors_name_the_file(tmp_path: Path) -> None:
    trial = tmp_path / "t1"
    _frames(trial, 2, size_hw=(240, 320))
    labels = trial / "labels.json"
    for text, message in (("{\"object\": \"cable\",}", "is not valid JSON"),
                          ("[1, 2]", "expected one object"),
                          ("{\"object\": {\"a\": 1}}", "'object' is a JSON dict"),
                          ("{\"split\": \"holdout\"}", "split 'holdout'")):
        labels.write_text(text)
        code, output = _ingest(str(trial), "--reference", "first", "--out",
                               str(tmp_path / "o.h5"))
        assert code == 2, output
        assert "labels.json" in output and message in output, output
        assert not (tmp_path / "o.h5").exists()
    # a --trial-labels value that contradicts labels.json
    labels.write_text("{\"object\": \"cable\"}")
    csv = tmp_path / "l.csv"
    csv.write_text("trial,object\nt1,box\n")
    code, output = _ingest(str(trial), "--reference", "first", "--trial-labels", str(csv),
                           "--out", str(tmp_path / "o.h5"))
    assert code == 2 and "contradicts" in output and "l.csv" in output


def test_reference_errors(tmp_path: Path) -> None:
    trial = tmp_path / "t1"
    _frames(trial, 3, size_hw=(240, 320))
    out = str(tmp_path / "o.h5")
    code, output = _ingest(str(trial), "--reference", "nothere", "--out", out)
    assert code == 2 and "no reference frame named 'nothere'" in output and "--reference" in output
    Image.fromarray(np.zeros((240, 320, 3), np.uint8)).save(trial / "reference.png")
    code, output = _ingest(str(trial), "--reference", "first", "--out", out)
    assert code == 2 and "reference.png" in output
    # without --reference the named file is the reference, as before
    code, output = _ingest(str(trial), "--out", out)
    assert code == 0, output
    code, output = _ingest(str(trial), "--px-per-mm", "0", "--out", out, "--overwrite")
    assert code == 2


def test_sizes_must_match(tmp_path: Path) -> None:
    _frames(tmp_path / "s" / "a", 2, size_hw=(240, 320))
    _frames(tmp_path / "s" / "b", 2, size_hw=(480, 640))
    code, output = _ingest(str(tmp_path / "s"), "--reference", "first", "--out",
                           str(tmp_path / "o.h5"))
    assert code == 2 and "640x480" in output and "320x240" in output


def test_out_dir_carries_reference_scale_and_labels_json(tmp_path: Path) -> None:
    """`--out-dir` (one file per input, in this process) applies --reference first,
    --px-per-mm and each folder's labels.json exactly as `--out` does."""
    inputs = []
    for name, obj in (("a", "cable"), ("b", "box")):
        images = _frames(tmp_path / "raw" / name, 4, size_hw=(240, 320), seed=len(obj))
        (tmp_path / "raw" / name / "labels.json").write_text(json.dumps({"object": obj}))
        inputs.append((name, obj, images))
    out_dir = tmp_path / "h5"
    code, output = _ingest(*(str(tmp_path / "raw" / n) for n, _, _ in inputs),
                           "--reference", "first", "--px-per-mm", "12.5",
                           "--out-dir", str(out_dir), "--workers", "0")
    assert code == 0, output
    for name, obj, images in inputs:
        with TactileFile(out_dir / f"{name}.h5") as f:
            frames = f.trial(name).frames()
            assert np.array_equal(frames.reference, images[0]) and len(frames) == 4
            assert f.sensor(frames.sensor_name).attrs["px_per_mm"] == 12.5
            assert f.trial(name).labels["object"] == obj


def test_folders_of_one_name_under_two_objects_are_two_named_trials(tmp_path: Path) -> None:
    """Lift sets keep a folder per object whose lift folders repeat across objects
    (``object001/066_60_mm``, ``object002/066_60_mm``): each is its own trial, named by its
    path below the common folder, and a trial-label table reaches each one."""
    first = _frames(tmp_path / "object001" / "066_60_mm", 3, size_hw=(24, 32), seed=1)
    second = _frames(tmp_path / "object002" / "066_60_mm", 3, size_hw=(24, 32), seed=2)
    _frames(tmp_path / "object002" / "067_00_mm", 3, size_hw=(24, 32), seed=3)
    labels = tmp_path / "labels.csv"
    labels.write_text("trial,slipped\nobject001__066_60_mm,1\nobject002__066_60_mm,0\n"
                      "object002__067_00_mm,1\n", encoding="utf-8")
    out = tmp_path / "out.h5"
    code, output = _ingest(str(tmp_path / "object001"), str(tmp_path / "object002"),
                           "--reference", "first", "--trial-labels", str(labels),
                           "--out", str(out))
    assert code == 0, output
    with TactileFile(out) as f:
        assert f.trial_names == ["object001__066_60_mm", "object002__066_60_mm",
                                 "object002__067_00_mm"]
        one, two = f.trial("object001__066_60_mm"), f.trial("object002__066_60_mm")
        assert np.array_equal(one.frames()[2], first[2])
        assert np.array_equal(two.frames()[2], second[2])
        assert (one.labels["slipped"], two.labels["slipped"]) == (1, 0)


def test_folders_of_distinct_names_keep_their_names(tmp_path: Path) -> None:
    _frames(tmp_path / "object001" / "066_60_mm", 2, size_hw=(24, 32))
    _frames(tmp_path / "object002" / "065_00_mm", 2, size_hw=(24, 32))
    out = tmp_path / "out.h5"
    code, output = _ingest(str(tmp_path / "object001"), str(tmp_path / "object002"),
                           "--reference", "first", "--out", str(out))
    assert code == 0, output
    with TactileFile(out) as f:
        assert f.trial_names == ["066_60_mm", "065_00_mm"]
