"""`tactile report`: one self-contained HTML page with runs, comparison and data files."""

from __future__ import annotations

import base64
import json
from html.parser import HTMLParser

import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.learn.perturb import perturb_evaluate
from tactile_cli.learn.report import build_report
from tactile_cli.store.provenance import sha256_of

from .tiny_runs import tiny_runs

runner = CliRunner()
PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="session")
def runs(tmp_path_factory, action_file, heldout_file):
    return tiny_runs(tmp_path_factory, action_file, heldout_file)


class _Links(HTMLParser):
    """Every attribute that can load something: src, href, and <link>/<script> tags."""

    def __init__(self) -> None:
        super().__init__()
        self.src: list[str] = []
        self.href: list[str] = []
        self.tags: set[str] = set()
        self.captions: list[str] = []
        self._in_caption = False

    def handle_starttag(self, tag, attrs):
        self.tags.add(tag)
        for key, value in attrs:
            if key == "src":
                self.src.append(value)
            elif key == "href":
                self.href.append(value)
        self._in_caption = tag == "figcaption"

    def handle_endtag(self, tag):
        if tag == "figcaption":
            self._in_caption = False

    def handle_data(self, data):
        if self._in_caption:
            self.captions.append(data)


def _png(path, text: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(2, 1.5))
    ax.set_title(text)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=40)
    plt.close(fig)


@pytest.mark.slow
def test_report_is_self_contained_and_holds_every_section(runs, heldout_file, tmp_path):
    perturb_evaluate(runs["lstm"], [heldout_file], ["noise", "lowpass"],
                     {"noise": [30, -20], "lowpass": [0.25, 0.01]}, name="rep")
    perturb_evaluate(runs["mlp"], [heldout_file], ["noise", "lowpass"],
                     {"noise": [30, -20], "lowpass": [0.25, 0.01]}, name="rep")
    figs = tmp_path / "figs"
    _png(figs / "fits" / "fos_press_light.png", "press")
    _png(figs / "slip" / "slip_g1_level02.png", "slip")
    res = build_report(list(runs.values()), tmp_path / "report", data_paths=[heldout_file],
                       figure_dirs=[figs], command="tactile report test")
    page = res.index.read_text(encoding="utf-8")
    links = _Links()
    links.feed(page)
    assert not links.tags & {"script", "link", "iframe", "object", "embed"}
    assert links.src and all(s.startswith("data:image/png;base64,") for s in links.src)
    for s in links.src:
        assert base64.b64decode(s.split(",", 1)[1])[:8] == PNG
    assert all(h.startswith("#") for h in links.href)  # in-page links only
    assert "http://" not in page and "https://" not in page and "url(" not in page

    # 3 runs x (curves + confusion) + compare chart + one chart per perturbation name
    # (other tests of the session may have added some) + 2 extra figures
    assert len(links.src) == 3 * 2 + 1 + len(res.perturbations) + 2
    assert "the model this scene needs:" in page
    assert res.comparisons == ["heldout"] and "rep" in res.perturbations
    for family, run in runs.items():
        m = json.loads((run / "eval" / "heldout" / "metrics.json").read_text())
        assert f"{100 * m['accuracy']:.2f} %" in page
        assert f"{m['heads']['action']['per_class'][1]['f1']:.5f}" in page  # press F1
        assert f"{m['model']['n_params']:,}" in page
        assert f"{family}/{family}" in page
    assert "training curves" in " ".join(links.captions)
    # captions say what a figure shows, not where its file lies
    assert ("first-order fits of the press region (eq. 16), one panel per trial: force grade "
            "light") in links.captions
    assert any(c.startswith("slip: ROI centroids") and c.endswith(": trial g1_level02")
               for c in links.captions)
    assert not [c for c in links.captions if c.endswith(".png")]
    assert "heldout.h5" in page and "12 (" in page  # data summary: 12 trials

    record = json.loads(res.provenance.read_text())
    assert record["command"] == "tactile report test" and record["tool_version"]
    roles = {(i["role"], i["path"]): i["sha256"] for i in record["inputs"]}
    assert roles[("data", str(heldout_file))] == sha256_of(heldout_file)
    assert ("figure", str(figs / "slip" / "slip_g1_level02.png")) in roles
    assert sum(1 for r, _ in roles if r == "metrics") >= 3
    assert sum(1 for r, _ in roles if r == "perturb") >= 2
    assert not [p for p in res.index.parent.iterdir() if p.name.startswith(".")]


def test_report_errors_name_the_missing_input(runs, tmp_path):
    with pytest.raises(InputError, match="figure folder not found"):
        build_report([runs["lstm"]], tmp_path / "r", figure_dirs=[tmp_path / "nope"])
    with pytest.raises(InputError, match="data file not found"):
        build_report([runs["lstm"]], tmp_path / "r", data_paths=[tmp_path / "x.h5"])
    with pytest.raises(InputError, match="nothing to report"):
        build_report([], tmp_path / "r")
    assert not (tmp_path / "r").exists()  # nothing written before the checks


@pytest.mark.slow
def test_cli_report_prints_the_page_path(runs, heldout_file, action_file, tmp_path):
    out = tmp_path / "rep"
    # `--data a.h5 b.h5` (a shell glob): b.h5 lands among the run arguments and, being a
    # file, is taken as a data file
    res = runner.invoke(app, ["report", str(runs["lstm"]), str(runs["fnn"]), "--out", str(out),
                              "--data", str(heldout_file), str(action_file)])
    assert res.exit_code == 0, res.output
    assert res.stdout == f"{out / 'index.html'}\n"
    record = json.loads((out / "report.json").read_text())
    assert record["runs"] == [str(runs["lstm"]), str(runs["fnn"])]
    assert record["data"] == [str(heldout_file), str(action_file)]
    assert (out / "index.html").is_file()

    missing = runner.invoke(app, ["report", str(tmp_path / "nope"), "--out", str(out)])
    assert missing.exit_code == 2
    assert missing.stderr == (f"tactile: error: {tmp_path / 'nope'}: run folder not found "
                              "(give the folder `tactile train` wrote)\n")
    no_out = runner.invoke(app, ["report", str(runs["lstm"])])
    assert no_out.exit_code == 2
    assert no_out.stderr == "tactile: error: give the output folder with --out DIR\n"


def test_the_comparison_table_gains_per_group_accuracy_where_runs_have_it():
    """Trials decided together (`decide_by`, e.g. both cameras of an experiment): the
    comparison table shows the per-group figure with its interval beside the per-trial one;
    a run without it gets an empty cell."""
    from tactile_cli.learn.report import _comparison_extra

    def metrics(group):
        head = {"per_trial": {"majority_accuracy": 0.9, "majority_accuracy_ci95": [0.8, 0.95]}}
        if group is not None:
            head["per_group"] = {"by": "experiment", "majority_accuracy": group,
                                 "majority_accuracy_ci95": [group - 0.1, 1.0]}
        return {"primary_head": "slip", "heads": {"slip": head}}

    header, cols = _comparison_extra([metrics(0.93), metrics(None)])
    assert header == ["per trial (%) [95 % CI]", "per experiment (%) [95 % CI]"]
    assert cols[1] == ["93.00 [83.00, 100.00]", ""]
    assert _comparison_extra([metrics(None)])[0] == ["per trial (%) [95 % CI]"]
