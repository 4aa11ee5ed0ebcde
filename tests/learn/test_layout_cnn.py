"""The electrode-layout image and the ``cnn2d_layout`` family (issue 34, item 4): the
BioTac SP's 24 electrodes at their places, three fingers as image channels."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from tactile_cli.errors import InputError
from tactile_cli.learn import export
from tactile_cli.learn.config import parse_config
from tactile_cli.learn.evaluate import evaluate
from tactile_cli.learn.heads import HeadSpec
from tactile_cli.learn.layouts import LAYOUTS, gather_index, layout_grid
from tactile_cli.learn.models import build_model
from tactile_cli.learn.train import train

from ..factories.grasp_tables import CHANNELS, write_grasp_file

HEADS = [HeadSpec("slipped", "classification", "trial", 1.0, ("0", "1"))]


def _model(**extra):
    raw = {"data": {"stream": "electrodes", "channels": ["e"], "window": 1,
                    "targets": [{"name": "slipped", "source": "trial"}]},
           "model": {"family": "cnn2d_layout", "channels": [4], **extra}}
    return parse_config(raw).model


def test_the_biotac_sp_layout_gives_each_electrode_its_own_cell_and_mirrors_the_sides():
    pos = LAYOUTS["biotac_sp"]
    assert pos.shape == (24, 2)
    np.testing.assert_array_equal(pos[10:20, 0], -pos[:10, 0])  # 11..20 mirror 1..10
    np.testing.assert_array_equal(pos[10:20, 1], pos[:10, 1])
    for cell_mm in (0.5, 1.0, 1.5, 2.0):
        grid = layout_grid("biotac_sp", cell_mm=cell_mm, fill="zero")
        assert len({tuple(c) for c in grid.cells}) == 24
        assert (grid.index >= 0).sum() == 24
        np.testing.assert_array_equal(grid.cells[10:20, 0], grid.cells[:10, 0])  # same rows
    assert layout_grid("biotac_sp", cell_mm=1.5).shape == (15, 10)


def test_a_cell_too_coarse_names_the_electrodes_and_a_size_that_works():
    with pytest.raises(InputError, match=r"`cell_mm` \(=4.0\) puts electrodes .* into one "
                                         r"cell; use at most 0.\d+"):
        _model(cell_mm=4.0)


def test_the_image_holds_each_electrode_at_its_cell_and_the_nearest_elsewhere():
    for fill in ("zero", "nearest"):
        trunk = build_model(_model(fill=fill), window=1, n_channels=72, heads=HEADS).trunk
        x = torch.arange(1, 73, dtype=torch.float32).reshape(1, 1, 72)
        image = trunk.image(x)[0].numpy()
        grid = layout_grid("biotac_sp", cell_mm=1.5, fill=fill)
        assert image.shape == (3, 15, 10)
        for finger in range(3):
            for e, (r, c) in enumerate(grid.cells):
                assert image[finger, r, c] == finger * 24 + e + 1
            if fill == "zero":
                assert (image[finger] == 0).sum() == 150 - 24
            else:
                index, _ = gather_index(grid, 72)
                np.testing.assert_array_equal(image[finger], index[finger] + 1)


def test_channels_that_are_not_whole_sensors_are_refused():
    with pytest.raises(InputError, match="70 channels are not whole blocks of the 24 "
                                         "electrodes of layout 'biotac_sp'"):
        build_model(_model(), window=1, n_channels=70, heads=HEADS)


@pytest.mark.slow
def test_a_layout_cnn_trains_evaluates_and_exports(tmp_path):
    data = tmp_path / "grasps.h5"
    write_grasp_file(data, n_grasps=40)
    cfg = parse_config({
        "seed": 0,
        "data": {"stream": "electrodes", "channels": ["ff_biotac_*", "mf_biotac_*",
                                                      "th_biotac_*"], "window": 1,
                 "targets": [{"name": "slipped", "source": "trial"}],
                 "split": {"mode": "stratified", "by": "slipped", "val_fraction": 0.25}},
        "model": {"family": "cnn2d_layout", "channels": [4, 8]},
        "optim": {"epochs": 3, "batch_size": 8}})
    result = train(cfg, [data], tmp_path / "run", command="tests")
    assert result.family == "cnn2d_layout" and result.n_params > 0
    resolved = (tmp_path / "run" / "config.resolved.yaml").read_text()
    assert all(name in resolved for name in CHANNELS)
    for fmt in ("onnx", "torchscript"):
        out = export.export_run(tmp_path / "run", tmp_path / f"m.{fmt}", format=fmt,
                                command="tests")
        metrics = evaluate(tmp_path / "run", [data], name=fmt, exported=out.path,
                           latency=False, command="tests")
        assert metrics.extra["exported"]["max_abs_diff"] <= 1e-5
