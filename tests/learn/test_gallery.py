"""Figure galleries of `tactile report`: what a PNG shows, from its name; one gallery per
kind, many near-duplicates drawn as one grid with their count."""

from __future__ import annotations

from pathlib import Path

import pytest

from tactile_cli.learn.gallery import (
    MAX_GRID,
    describe_figure,
    group_figures,
)


@pytest.mark.parametrize(("rel", "caption"), [
    ("xela_slip__data_sample_2022-02-21-10-00-00__signals.png",
     "quick look: file xela_slip.h5: trial data_sample_2022-02-21-10-00-00, sampled streams"),
    ("scene__g1_level01__events.png", "quick look: file scene.h5: trial g1_level01, events per "
     "20 ms and net polarity per pixel"),
    ("fits/fos_press_small_medium.png", "first-order fits of the press region (eq. 16), one "
     "panel per trial: force grade small medium"),
    ("fits/fos_slip.png", "first-order fits of the slip region (eq. 17), one panel per trial: "
     "all trials"),
    ("frames/g1_level06/contact_sheet.png", "event frames with the ROIs (contact sheet, "
     "Fig. 13): trial g1_level06"),
    ("frames/g1_level06/frame_0012.png", "event frames of trial g1_level06: frame 12"),
    ("slip/slip_g2_level11.png", "slip: ROI centroids, velocity (eq. 20) and displacement "
     "(eq. 21) over the slip region (Fig. 23): trial g2_level11"),
    ("grade/membership.png", "fuzzy force grading: membership functions of area and force "
     "(Figs. 20-21)"),
    ("counts/g1_level06.png", "event counts per bin with the action regions (Fig. 10): trial "
     "g1_level06"),
    ("runs/lstm/curves.png", "training curves: loss and validation accuracy per epoch: run lstm"),
    ("scene/confusion_action.png", "confusion matrix of action (rows true, columns predicted): "
     "evaluation scene"),
    ("misc/my_plot_v2.png", "figures in misc: my plot v2"),
    ("top.png", "other figures: top"),
])
def test_captions_say_what_a_figure_shows(rel, caption):
    assert describe_figure(rel).caption == caption


def test_figures_of_one_kind_form_one_gallery_in_natural_order():
    rels = [f"slip/slip_g1_level{k}.png" for k in (10, 2, 1)] + [
        "fits/fos_slip_light.png", "fits/fos_press_light.png", "fits/fos_press_big.png",
        "grade/inference.png", "counts/g1_level06.png",
        "b__t1__signals.png", "a__t1__events.png", "a__t2__events.png"]
    galleries = group_figures([Path(r) for r in rels], {"b": 0, "a": 1})
    titles = [g.title for g in galleries]
    assert titles == [
        "event counts per bin with the action regions (Fig. 10)",
        "first-order fits of the press region (eq. 16), one panel per trial",
        "first-order fits of the slip region (eq. 17), one panel per trial",
        "slip: ROI centroids, velocity (eq. 20) and displacement (eq. 21) over the slip region "
        "(Fig. 23)",
        "fuzzy force grading",
        "quick look: file b.h5",  # ranked first: say, the file of recorded data
        "quick look: file a.h5",
    ]
    slip = galleries[3]
    assert [f.subject for f in slip.figures] == ["trial g1_level1", "trial g1_level2",
                                                 "trial g1_level10"]
    assert not slip.is_grid  # three figures are drawn as they are
    assert [f.subject for f in galleries[1].figures] == ["force grade light", "force grade big"]


def test_fits_per_grade_go_lightest_first_and_other_names_after_them():
    grades = ["big", "small_big", "medium", "small_medium", "small", "light"]
    rels = [Path(f"fits/fos_press_{g}.png") for g in ["zzz", *grades, "all"]]
    (fits,) = group_figures(rels)
    assert [f.subject for f in fits.figures] == [
        "force grade light", "force grade small", "force grade small medium",
        "force grade medium", "force grade small big", "force grade big",
        "force grade all", "force grade zzz"]


def test_many_near_duplicates_are_one_grid_of_evenly_spread_figures():
    rels = [f"slip/slip_g{g}_level{k:02d}.png" for g in (1, 2) for k in range(1, 13)]
    (g,) = group_figures(rels)
    assert g.is_grid and len(g.figures) == 24
    shown = g.shown()
    assert len(shown) == MAX_GRID
    assert shown[0].subject == "trial g1_level01" and shown[-1].subject == "trial g2_level12"
    assert len({f.path for f in shown}) == MAX_GRID
