"""``tactile report``: one self-contained HTML page of runs, their comparison and data files.

Issue 4, item 10; issue 11, item 5 (the report says where every number comes from). The
page (``OUT/index.html``) needs no other file: every figure is a base64 PNG inside an
``<img src="data:image/png;base64,...">`` and the style sheet is inline; nothing is loaded
from elsewhere. It holds, in order:

1. **where the numbers come from**: one row per result (run and evaluation) with the origin
   of the data it was evaluated on and trained on (recorded, with the data set and lab;
   simulated; synthetic: :mod:`tactile_cli.store.origin`), whether the evaluated
   recordings are independent of the training data, the accuracy per window and per trial
   with their 95 % intervals and the cross-validated mean and spread; results on recorded
   data first;
2. for every evaluation name that two or more runs share, the comparison of
   :mod:`.compare` (table with the origin columns, the model the scene needs, the
   accuracy-latency chart with the Pareto front), tagged with the data's origin;
3. for every perturbation name (``RUN/perturb/<name>/``, :mod:`.perturb`) the chart with
   one line per run and the breaking points;
4. per run (recorded data first), tagged with the origin of its training and evaluation
   data: the config summary, the training curves, and per evaluation its warnings, the
   cross-validation folds (mean and spread over folds), the paper-000 Table I metrics with
   bootstrap intervals and every class's support (a class without support is flagged), the
   per-trial results (majority vote, mean probability), regression errors, the confusion
   matrices and the cost;
5. a summary of each given data file with its origin (recorded first);
6. the figures of each extra figure folder, grouped by what they show
   (:mod:`.gallery`), captioned in words; many figures of one kind (one per trial) are
   one grid with their count.

The origin of an evaluation is metrics.json's ``origin`` (written by ``tactile evaluate``),
else it is read from the data files metrics.json names when they are still there, else
``unknown``; the origin of the training data is run.json's ``origin``, else read from its
data files the same way.

``OUT/report.json`` beside it records the provenance: command, tool version, time, every
input read (run.json, metrics.json, perturb.json, data and figure files, with SHA-256)
and the origin of every result. Both are written atomically (temporary file +
``os.replace``).
"""

from __future__ import annotations

import base64
import html
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .._version import __version__
from ..errors import InputError, TactileError
from ..input_guard import check_outputs
from ..store.atomic import write_text
from ..store.origin import UNKNOWN, data_origin, describe_origin, unknown_origin
from ..store.outdir import check_output_folder, output_folder
from ..store.provenance import current_command, sha256_of, utc_now
from . import runs
from .compare import (
    SPREAD_EVAL,
    SPREAD_JSON,
    check_run_folder,
    compare,
    eval_names,
    plot_comparison,
    read_spread_record,
    run_labels,
    spread_runs,
    table_rows,
)
from .gallery import Gallery, group_figures
from .perturb import find_perturbations, level_text, load_perturbation, plot_perturbations

INDEX_HTML = "index.html"
REPORT_JSON = "report.json"

#: Results on data of these origins come first, in this order.
ORIGIN_RANK = {"recorded": 0, "mixed": 1, "simulated": 2, "synthetic": 3, UNKNOWN: 4}

_CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Helvetica,Arial,sans-serif;margin:2em auto;
max-width:1150px;color:#222;line-height:1.4;padding:0 1em}
h1{font-size:1.6em}h2{border-bottom:2px solid #ddd;padding-bottom:.2em;margin-top:2em}
h3{margin-top:1.5em}h4{margin:1em 0 .3em}h5{margin:.8em 0 .3em;font-size:1em}
table{border-collapse:collapse;margin:.5em 0 1em;font-size:.88em}
th,td{border:1px solid #ccc;padding:.25em .55em;text-align:right;vertical-align:top}
th{background:#f3f3f3}td.l,th.l{text-align:left}
tr.needed td{background:#fff6cc}tr.front td:first-child{font-weight:bold}
tr.absent td{color:#999;background:#fafafa}tr.mean td{font-weight:bold}
figure{margin:.5em 0 1.2em;display:inline-block;vertical-align:top}
figure img{max-width:100%;border:1px solid #eee}
figcaption{font-size:.85em;color:#555}
.grid{display:grid;grid-template-columns:repeat(auto-fill,minmax(250px,1fr));gap:.5em}
.grid figure{margin:0}
.note{color:#8a4b00;background:#fff4e5;padding:.3em .6em;border-left:3px solid #f0a040}
.warn{color:#7a0000;background:#fdecec;padding:.3em .6em;border-left:3px solid #d04040}
.muted{color:#777;font-size:.85em}code{font-size:.9em}
.tag{display:inline-block;padding:0 .45em;border-radius:.6em;font-size:.8em;font-weight:bold;
color:#fff;background:#888;margin-right:.3em;vertical-align:middle}
.tag.recorded{background:#2e7d32}.tag.simulated{background:#1565c0}
.tag.synthetic{background:#6a1b9a}.tag.mixed{background:#e65100}
.origin{margin:.2em 0 .6em}
nav ul{columns:2}
"""


@dataclass
class ReportResult:
    """Where the report went and what it holds."""

    index: Path
    provenance: Path
    runs: list[str]
    comparisons: list[str]  # evaluation names compared
    perturbations: list[str]
    data_files: list[str]
    figures: list[str]
    notes: list[str] = field(default_factory=list)
    origins: list[dict[str, Any]] = field(default_factory=list)  # one per result


# -- small HTML pieces -----------------------------------------------------------------------
def _e(value: Any) -> str:
    return html.escape(str(value), quote=True)


def _img(png: bytes, alt: str) -> str:
    data = base64.b64encode(png).decode("ascii")
    return f'<img src="data:image/png;base64,{data}" alt="{_e(alt)}">'


def _figure(png: bytes, caption: str) -> str:
    return f"<figure>{_img(png, caption)}<figcaption>{_e(caption)}</figcaption></figure>"


def _fmt(value: Any, digits: int = 4) -> str:
    if value is None:
        return ""
    if isinstance(value, bool):
        return "yes" if value else ""
    if isinstance(value, int):
        return f"{value:,}"
    if isinstance(value, float):
        if not math.isfinite(value):
            return ""
        return f"{value:.{digits}g}" if abs(value) < 1e5 else f"{value:,.0f}"
    return str(value)


def _fixed(value: Any, digits: int = 5) -> str:
    """A fraction with ``digits`` decimals; empty for None or NaN."""
    if not isinstance(value, int | float) or isinstance(value, bool) or not math.isfinite(value):
        return ""
    return f"{value:.{digits}f}"


def _pct(value: Any) -> str:
    """A fraction as a percentage with two decimals; empty for None or NaN."""
    if not isinstance(value, int | float) or isinstance(value, bool) or not math.isfinite(value):
        return ""
    return f"{100 * value:.2f}"


def _ci(ci: Any) -> str:
    """``[lo, hi]`` (fractions) as ``[80.10, 89.20]`` (%); empty when absent."""
    if not isinstance(ci, list | tuple) or len(ci) != 2 or not all(_pct(c) for c in ci):
        return ""
    return f"[{_pct(ci[0])}, {_pct(ci[1])}]"


def _pct_ci(value: Any, ci: Any) -> str:
    """``85.00 [80.10, 89.20]``: a percentage with its 95 % interval when there is one."""
    text = _pct(value)
    interval = _ci(ci)
    return f"{text} {interval}" if text and interval else text


def _mean_sd(mean: Any, sd: Any) -> str:
    """``84.50 ± 3.20`` (percentages) of fractions; the mean alone without a spread."""
    m = _pct(mean)
    s = _pct(sd)
    return f"{m} ± {s}" if m and s else m


def _table(header: Sequence[str], rows: Sequence[Sequence[Any]], *, left: int = 1,
           row_class: Sequence[str] | None = None) -> str:
    """An HTML table; the first ``left`` columns are left-aligned."""
    head = "".join(f'<th class="{"l" if i < left else ""}">{_e(h)}</th>'
                   for i, h in enumerate(header))
    body = []
    for r, row in enumerate(rows):
        cls = f' class="{row_class[r]}"' if row_class and row_class[r] else ""
        cells = "".join(f'<td class="{"l" if i < left else ""}">{_e(c)}</td>'
                        for i, c in enumerate(row))
        body.append(f"<tr{cls}>{cells}</tr>")
    return f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(body)}</tbody></table>"


def _kv(pairs: Sequence[tuple[str, Any]]) -> str:
    return _table(("key", "value"), [(k, v) for k, v in pairs], left=2)


def _list(value: Any) -> list[Any]:
    """``value`` if it is a list, else empty (a damaged record never breaks the page)."""
    return value if isinstance(value, list) else []


def _dict(value: Any) -> dict[str, Any]:
    """``value`` if it is a JSON object, else empty."""
    return value if isinstance(value, dict) else {}


def _kind(origin: Mapping[str, Any]) -> str:
    kind = str(origin.get("kind") or UNKNOWN)
    return kind if kind in ORIGIN_RANK else UNKNOWN


def _rank(origin: Mapping[str, Any]) -> int:
    return ORIGIN_RANK[_kind(origin)]


def _tag(origin: Mapping[str, Any], prefix: str = "") -> str:
    """The origin as a coloured tag and its description (data set, lab)."""
    kind = _kind(origin)
    text = describe_origin(origin)
    rest = text[len(kind):].lstrip(": ") if text.startswith(kind) else text
    lead = f"{_e(prefix)} " if prefix else ""
    return (f"{lead}<span class='tag {_e(kind)}'>{_e(kind)}</span>"
            + (_e(rest) if rest else ""))


class _Inputs:
    """Every file the report read, for report.json."""

    def __init__(self) -> None:
        self.items: list[dict[str, Any]] = []
        self._seen: set[str] = set()

    def add(self, role: str, path: Path) -> None:
        key = str(Path(path).resolve())
        if key in self._seen or not Path(path).is_file():
            return
        self._seen.add(key)
        self.items.append({"role": role, "path": str(path),
                           "size_bytes": Path(path).stat().st_size, "sha256": sha256_of(path)})


# -- where the numbers come from -------------------------------------------------------------
class _Origins:
    """The origin of data files, read once per set of files."""

    def __init__(self) -> None:
        self._cache: dict[tuple[str, ...], dict[str, Any]] = {}
        self._sources: dict[str, list[tuple[str, str]]] = {}

    def of_paths(self, paths: Sequence[str]) -> dict[str, Any]:
        """:func:`data_origin` of ``paths``, or unknown when one of them is gone."""
        key = tuple(paths)
        if key not in self._cache:
            gone = [p for p in paths if not Path(p).is_file()]
            if not paths:
                self._cache[key] = unknown_origin([], "no data files recorded")
            elif gone:
                self._cache[key] = unknown_origin(
                    paths, f"data file {gone[0]} is no longer at the path recorded")
            else:
                self._cache[key] = data_origin(list(paths))
        return self._cache[key]

    def of_record(self, record: Mapping[str, Any]) -> dict[str, Any]:
        """A run.json's or metrics.json's ``origin``, else that of its ``data`` files."""
        stored = record.get("origin")
        if isinstance(stored, dict) and isinstance(stored.get("kind"), str):
            return stored
        return self.of_paths([str(d["path"]) for d in _list(record.get("data"))
                              if isinstance(d, dict) and d.get("path")])

    def h5_sources(self, path: str) -> list[tuple[str, str]]:
        """(path, sha256) of the tactile files ``path`` was made from (``tactile synth
        --fits``: the fits file), read from its provenance; empty when it is gone."""
        if path not in self._sources:
            from ..store.trials import TactileFile

            found: list[tuple[str, str]] = []
            if Path(path).is_file():
                try:
                    with TactileFile(path) as f:
                        found = [(s.path, s.sha256) for s in f.sources
                                 if s.path.lower().endswith((".h5", ".hdf5")) and s.sha256]
                except TactileError:
                    found = []
            self._sources[path] = found
        return self._sources[path]


def _independence(info: Mapping[str, Any], m: Mapping[str, Any], origins: _Origins) -> str:
    """Whether the evaluated recordings are independent of the training data: held-out
    folds, a held-out split, the training files themselves, files the training data were
    made from (``synth --fits``), or none of them."""
    cv = m.get("cv")
    if isinstance(cv, dict) and cv:
        by = f" by {cv['by']}" if cv.get("by") else ""
        if cv.get("k") == "loto":
            return "held out: the trials of each fold (leave one trial out)"
        return (f"held out: the trials of each fold ({cv.get('k')}-fold {cv.get('mode', '')}"
                f"{by} cross-validation)")
    if _list(m.get("overlaps_training")):
        if m.get("split") == "all":
            return "no (the evaluated data include the training trials)"
        return f"held out: the {m.get('split')} trials of the training file(s)"
    seen = _dict(m.get("trained_recordings"))
    if isinstance(seen.get("n_trials"), int) and seen["n_trials"] > 0:
        return (f"no ({seen['n_trials']} of {seen.get('n_evaluated')} evaluated trials were "
                "read from source files the run was trained on)")
    evaluated: set[str] = set()
    for d in (d for d in _list(m.get("data")) if isinstance(d, dict)):
        evaluated.update(str(h) for h in [d.get("sha256"), *_list(d.get("recordings_sha256"))]
                         if isinstance(h, str))
    train = [str(d.get("path")) for d in _list(info.get("data")) if isinstance(d, dict)]
    if not train or not all(Path(p).is_file() for p in train):
        return "not checked (training files not found)"
    made_from = [Path(src).name for p in train for src, sha in origins.h5_sources(p)
                 if sha in evaluated]
    if made_from:
        return (f"no (the training data were made from {', '.join(sorted(set(made_from)))}, "
                "which holds the evaluated recordings)")
    return "yes (no file or source shared with the training data)"


@dataclass
class _Result:
    """One evaluation of one run, with where its data come from."""

    run: Path
    label: str
    name: str
    metrics: dict[str, Any]
    evaluated_on: dict[str, Any]
    trained_on: dict[str, Any]
    independent: str

    @property
    def anchor(self) -> str:
        return f"eval-{self.label}-{self.name}"

    def record(self) -> dict[str, Any]:
        return {"run": str(self.run), "label": self.label, "evaluation": self.name,
                "evaluated_on": self.evaluated_on, "trained_on": self.trained_on,
                "independent": self.independent}


def _results(dirs: Sequence[Path], labels: Sequence[str], infos: Sequence[dict[str, Any]],
             origins: _Origins, inputs: _Inputs) -> list[_Result]:
    """Every evaluation of every run, recorded data first (stable otherwise)."""
    out = []
    for d, label, info in zip(dirs, labels, infos, strict=True):
        trained = origins.of_record(info)
        for name in eval_names(d):
            path = d / runs.EVAL_DIR / name / runs.METRICS_JSON
            m = runs.read_metrics(path)
            inputs.add("metrics", path)
            out.append(_Result(d, label, name, m, origins.of_record(m), trained,
                               _independence(info, m, origins)))
    return sorted(out, key=lambda r: _rank(r.evaluated_on))


def _primary(m: Mapping[str, Any]) -> dict[str, Any]:
    head = (m.get("heads") or {}).get(m.get("primary_head") or "")
    return head if isinstance(head, dict) else {}


def _scores(m: Mapping[str, Any]) -> list[str]:
    """The primary head's name, accuracy per window and per trial (with intervals), the
    cross-validated mean ± sd and the macro F1 of one evaluation, as text."""
    head = _primary(m)
    cv = _dict(m.get("cv"))
    pt = _dict(head.get("per_trial"))
    return [str(head.get("head", "")),
            _pct_ci(head.get("accuracy"), head.get("accuracy_ci95")),
            _pct_ci(pt.get("majority_accuracy"), pt.get("majority_accuracy_ci95")),
            _mean_sd(cv.get("accuracy_mean"), cv.get("accuracy_std")),
            _fixed(head.get("macro_f1"), 4)]


def _origin_summary(results: Sequence[_Result]) -> str:
    """What the results rest on, in words: per origin of the evaluated data, how many
    results and what they were trained on; and, when none is on recorded data, that."""
    groups: dict[str, list[_Result]] = {}
    for r in results:
        groups.setdefault(describe_origin(r.evaluated_on), []).append(r)
    parts = []
    for text, rs in groups.items():
        trained = " / ".join(sorted({describe_origin(r.trained_on) for r in rs}))
        parts.append(f"{len(rs)} result{'s' if len(rs) > 1 else ''} evaluated on {text}, "
                     f"trained on {trained}")
    sentence = "; ".join(parts) + "."
    kinds = {_kind(r.evaluated_on) for r in results}
    if "recorded" not in kinds:
        sentence += (" None is on recorded data: every accuracy below comes from simulated "
                     "or synthetic data." if kinds <= {"simulated", "synthetic"} else
                     " None is known to be on recorded data.")
    return sentence


def _overview_section(results: Sequence[_Result]) -> str:
    """The table of every result with the origin of its data (recorded first)."""
    if not results:
        return ("<p class='muted'>no evaluation yet: run <code>tactile evaluate RUN --data "
                "FILE</code> on each run.</p>")
    header = ("result", "evaluation", "evaluated on", "trained on",
              "evaluated data independent of training?", "head",
              "accuracy per window (%) [95 % CI]", "per trial, majority vote (%) [95 % CI]",
              "cross-validated accuracy (%, mean ± sd over folds)", "macro F1")
    rows = []
    for r in results:
        cells = [f"<a href='#{_e(r.anchor)}'>{_e(r.label)}</a>", _e(r.name),
                 _tag(r.evaluated_on), _tag(r.trained_on), _e(r.independent),
                 *(_e(v) for v in _scores(r.metrics))]
        rows.append("<tr>" + "".join(f"<td class='{'l' if i < 6 else ''}'>{c}</td>"
                                     for i, c in enumerate(cells)) + "</tr>")
    head_html = "".join(f"<th class='{'l' if i < 6 else ''}'>{_e(h)}</th>"
                        for i, h in enumerate(header))
    kinds = {_kind(r.evaluated_on) for r in results}
    lead = ("Results on recorded data come first. " if "recorded" in kinds else "") + (
        "A tag says where each result's data come from: <span class='tag recorded'>recorded"
        "</span>by a sensor (with the data set and the lab), <span class='tag simulated'>"
        "simulated</span>recordings of a simulated scene with known ground truth, "
        "<span class='tag synthetic'>synthetic</span>model-based or generated training "
        "data. Intervals are bootstrap 95 % intervals over trials.")
    return (f"<p><b>{_e(_origin_summary(results))}</b></p><p>{lead}</p>"
            f"<table><thead><tr>{head_html}</tr></thead><tbody>"
            f"{''.join(rows)}</tbody></table>")


# -- comparisons -----------------------------------------------------------------------------
def _comparison_extra(points_metrics: Sequence[dict[str, Any]]
                      ) -> tuple[list[str], list[list[str]]]:
    """Columns the comparison table gains when some run has them: per-trial accuracy,
    per-group accuracy (trials decided together, ``data.decide_by``) and the
    cross-validated mean ± sd."""
    per_trial = [_dict(_primary(m).get("per_trial")) for m in points_metrics]
    per_group = [_dict(_primary(m).get("per_group")) for m in points_metrics]
    cvs = [_dict(m.get("cv")) for m in points_metrics]
    header, cols = [], []
    if any(p.get("majority_accuracy") is not None for p in per_trial):
        header.append("per trial (%) [95 % CI]")
        cols.append([_pct_ci(p.get("majority_accuracy"), p.get("majority_accuracy_ci95"))
                     for p in per_trial])
    if any(p.get("majority_accuracy") is not None for p in per_group):
        by = sorted({str(p["by"]) for p in per_group if p.get("by")})
        header.append(f"per {' / '.join(by) or 'group'} (%) [95 % CI]")
        cols.append([_pct_ci(p.get("majority_accuracy"), p.get("majority_accuracy_ci95"))
                     for p in per_group])
    if any(c for c in cvs):
        header.append("CV accuracy (%, mean ± sd)")
        cols.append([_mean_sd(c.get("accuracy_mean"), c.get("accuracy_std")) for c in cvs])
    return header, cols


def _comparison_table(cmp: Any, by_run: Mapping[str, _Result]) -> str:
    results = [by_run.get(p.run) for p in cmp.points]
    extra_head, extra_cols = _comparison_extra([r.metrics if r else {} for r in results])
    rows, classes = [], []
    for i, row in enumerate(table_rows(cmp)):
        r = results[i]
        rows.append([row["label"], describe_origin(r.evaluated_on) if r else UNKNOWN,
                     describe_origin(r.trained_on) if r else UNKNOWN,
                     f"{row['score_pct']:.2f}", f"{row['delta_pp']:+.2f}",
                     *(col[i] for col in extra_cols),
                     _fmt(row["latency_ms_median"]), _fmt(row["latency_ms_p95"]),
                     _fmt(row["windows_per_s"] and round(row["windows_per_s"])),
                     _fmt(row["n_params"]), _fmt(row["size_mb"]),
                     "yes" if row["pareto"] else "", "yes" if row["within_margin"] else "",
                     "needed" if row["needed"] else ("fastest" if row["fastest"] else "")])
        classes.append(" ".join(c for c, on in (("needed", row["needed"]),
                                                ("front", row["pareto"])) if on))
    return _table((
        "run", "evaluated on", "trained on", f"{cmp.metric_label} (%)", "vs best (pp)",
        *extra_head, "batch-1 median (ms)", "batch-1 p95 (ms)", "windows/s", "parameters",
        "size (MB)", "Pareto", f"within {cmp.margin_pp:g} pp", "choice"), rows, left=3,
        row_class=classes)


def _comparison_sections(units: Sequence[Path], members: Mapping[Path, Sequence[Path]],
                         results: Sequence[_Result], margin_pp: float, metric: str,
                         notes: list[str]) -> tuple[str, list[str]]:
    """One comparison per evaluation name two or more units share, recorded data first. A
    unit is a run folder or a seed-spread folder (``members``: its seed runs), which is one
    point at its seeds' mean, never its seeds against each other. Spreads beside plain runs
    with no name in common are also compared at their own evaluation (what ``tactile
    compare`` does with them)."""
    def names_of(u: Path) -> list[str]:
        return eval_names(members[u][0]) if u in members else eval_names(u)

    by_name: dict[str, list[Path]] = {}
    for u in units:
        for name in names_of(u):
            by_name.setdefault(name, []).append(u)
    groups = [(name, us, name) for name, us in by_name.items() if len(us) >= 2]
    spreads = [u for u in units if u in members]
    plain = [u for u in units if u not in members]
    shared = sorted(set.intersection(*(set(names_of(u)) for u in plain))) if plain else []
    if spreads and plain and len(shared) == 1 and not any(
            set(spreads) & set(us) and set(plain) & set(us) for _, us, _ in groups):
        # the runs' one evaluation beside the spreads' own, as `tactile compare` reads them
        groups.append((None, list(units), f"{shared[0]} and the spreads' own"))

    def first_run(u: Path) -> Path:
        return members[u][0] if u in members else u

    def eval_name(u: Path, name: str | None) -> str:
        if name is not None:
            return name
        return SPREAD_EVAL if u in members else shared[0]

    origin_of = {(str(r.run), r.name): r.evaluated_on for r in results}

    def origin(us: Sequence[Path], name: str | None) -> Mapping[str, Any]:
        return origin_of.get((str(first_run(us[0])), eval_name(us[0], name)), {})

    groups.sort(key=lambda g: (_rank(origin(g[1], g[0])), g[2]))
    parts, done = [], []
    for name, us, title in groups:
        chosen = metric
        if metric == "auto":
            mine = [r for r in results if any(r.run == first_run(u) and r.name ==
                                              eval_name(u, name) for u in us)]
            voted = mine and all(isinstance(_primary(r.metrics).get("per_trial"), dict)
                                 for r in mine)
            pooled = mine and all(isinstance(_primary(r.metrics).get("per_group"), dict)
                                  for r in mine)
            chosen = ("group_accuracy" if pooled else "trial_accuracy" if voted
                      else "accuracy")
        try:
            cmp = compare(us, data_name=name, margin_pp=margin_pp, metric=chosen)
        except TactileError as exc:
            msg = f"evaluation {title!r} not compared: {exc}"
            notes.append(msg)
            parts.append(f"<h3>{_e(title)}</h3><p class='origin'>"
                         f"{_tag(origin(us, name), 'data:')}</p><p class='note'>{_e(msg)}</p>")
            continue
        notes.extend(cmp.notes)
        done.append(title)
        by_run: dict[str, _Result] = {}
        for u in us:  # a spread's row has its seeds' mean: no one seed's intervals beside it
            r = next((r for r in results if r.run == first_run(u)
                      and r.name == eval_name(u, name)), None)
            if r is not None:
                by_run[str(u)] = r if u not in members else _Result(
                    run=u, label=r.label, name=r.name, metrics={}, evaluated_on=r.evaluated_on,
                    trained_on=r.trained_on, independent=r.independent)
        first = cmp.points[0]
        data = ", ".join(Path(str(d["path"])).name for d in first.data)
        parts.append(
            f"<h3 id='cmp-{_e(title)}'>{_e(title)}</h3>"
            f"<p class='origin'>{_tag(origin(us, name), 'evaluated on')}</p>"
            f"<p>{len(cmp.points)} runs evaluated on {_e(data)} (split {_e(first.split)}, "
            f"{first.n_windows:,} windows). <b>{_e(cmp.summary())}</b>.</p>"
            + "".join(f"<p class='note'>{_e(n)}</p>" for n in cmp.notes
                      if "seed" in n)
            + _comparison_table(cmp, by_run)
            + _figure(plot_comparison(cmp), f"{cmp.metric_label} against latency per window "
                      f"(batch 1, median) on {title}; dashed: Pareto front"))
    return "".join(parts), done


def _perturbation_sections(run_dirs: Sequence[Path], inputs: _Inputs) -> tuple[str, list[str]]:
    by_name: dict[str, list[Path]] = {}
    for d in run_dirs:
        for name, path in find_perturbations(d).items():
            by_name.setdefault(name, []).append(path)
    parts = []
    for name, paths in sorted(by_name.items()):
        results = []
        for p in paths:
            results.append(load_perturbation(p))
            inputs.add("perturb", p)
        rows = []
        for r in results:
            for k in r.kinds:
                for b in k.breaking:
                    rows.append((r.label, k.kind, b.direction,
                                 "none within the levels" if b.level is None
                                 else level_text(k, b.level),
                                 "" if b.accuracy is None else f"{100 * b.accuracy:.2f}",
                                 level_text(k, b.last_ok), f"{100 * r.clean_accuracy:.2f}",
                                 f"{100 * r.threshold:.2f} ({r.threshold_rule})"))
        parts.append(
            f"<h3>{_e(name)}</h3>"
            + _figure(plot_perturbations(results), f"accuracy against perturbation level on "
                      f"{name}, one line per run; X: breaking point")
            + _table(("run", "kind", "direction", "breaking level", "accuracy there (%)",
                      "last level above", "clean (%)", "threshold (%)"), rows, left=3))
    return "".join(parts), sorted(by_name)


# -- runs ------------------------------------------------------------------------------------
def _config_summary(d: Path, info: dict[str, Any], cfg: dict[str, Any]) -> str:
    data = cfg.get("data", {})
    model = dict(cfg.get("model", {}))
    optim = cfg.get("optim", {})
    tr = info.get("training", {})
    split = info.get("split", {})
    targets = ", ".join(f"{t.get('name')} ({t.get('kind', 'classification')}, "
                        f"{t.get('source', 'sample')})" for t in data.get("targets", []))
    family = model.pop("family", "?")
    if isinstance(tr.get("folds"), list):  # a cross-validated run: one model per fold
        training = (f"{len(tr['folds'])} folds, one model each; wall time "
                    f"{_fmt(info.get('wall_time_s'), 3)} s")
    else:
        training = (f"{tr.get('epochs_run')} epochs, best {tr.get('best_epoch')} (val "
                    f"accuracy {_fmt(tr.get('best_val_accuracy'))}), "
                    f"{_fmt(tr.get('train_time_s'), 3)} s on {tr.get('threads')} thread(s)")
    pairs: list[tuple[str, Any]] = [
        ("model", f"{family}: " + ", ".join(f"{k}={v}" for k, v in model.items())),
        ("parameters / size", f"{_fmt(info.get('model', {}).get('n_params'))} / "
                              f"{_fmt(info.get('model', {}).get('size_mb'))} MB"),
        ("data", f"stream {data.get('stream')}, channels {data.get('channels')}, window "
                 f"{data.get('window')}, stride {data.get('stride')}, pad {data.get('pad')}, "
                 f"transform {data.get('transform')}, label {data.get('label_rule')} "
                 f"(delay {data.get('label_delay')})"),
        ("targets", targets),
        ("split", ", ".join(f"{k} {v}" for k, v in split.items() if k != "warnings")),
        ("optimiser", f"{optim.get('optimizer')} lr {optim.get('lr')}, batch "
                      f"{optim.get('batch_size')}, epochs {optim.get('epochs')}, patience "
                      f"{optim.get('patience')} on {optim.get('monitor')}"),
        ("training", training),
        ("seed", info.get("seed")),
        ("trained on", "; ".join(f"{x.get('path')} ({x.get('n_trials')} trials, sha256 "
                                 f"{str(x.get('sha256', ''))[:12]})"
                                 for x in info.get("data", []))),
        ("versions", ", ".join(f"{k} {v}" for k, v in info.get("versions", {}).items())),
        ("command", info.get("command", "")),
        ("created", info.get("created_utc", "")),
    ]
    return _kv(pairs)


def _warnings_html(m: Mapping[str, Any]) -> str:
    """metrics.json ``warnings`` (zero support, one present class, CV plan) as red notes."""
    found = [w for w in _list(m.get("warnings")) if isinstance(w, str)]
    return "".join(f"<p class='warn'>warning: {_e(w)}</p>" for w in dict.fromkeys(found))


def _cv_html(cv: Mapping[str, Any]) -> str:
    """A cross-validated evaluation: the plan, every fold and the mean ± sd over folds."""
    folds = [f for f in _list(cv.get("folds")) if isinstance(f, dict)]
    per_trial = any(f.get("per_trial_accuracy") is not None for f in folds)
    by = f", grouped or stratified by {cv['by']}" if cv.get("by") else ""
    n = cv.get("n_folds") or len(folds)
    text = (f"<p><b>Cross-validated</b> ({_e(cv.get('k'))}-fold, {_e(cv.get('mode'))}{_e(by)}): "
            f"each fold's model scored on its own held-out trials. Accuracy "
            f"{_e(_mean_sd(cv.get('accuracy_mean'), cv.get('accuracy_std')))} %, macro F1 "
            f"{_e(_fixed(cv.get('macro_f1_mean'), 4))} ± {_e(_fixed(cv.get('macro_f1_std'), 4))}"
            f" (mean ± sd over {_e(n)} folds). The tables below pool the held-out windows of "
            "every fold (each window once).</p>")
    header = ["fold", "trials", "windows", "accuracy (%)", "macro F1"]
    if per_trial:
        header.append("per trial, majority vote (%)")
    rows, classes = [], []
    for f in folds:
        row = [f.get("fold"), _fmt(f.get("n_trials")), _fmt(f.get("n_windows")),
               _pct(f.get("accuracy")), _fixed(f.get("macro_f1"), 4)]
        rows.append(row + ([_pct(f.get("per_trial_accuracy"))] if per_trial else []))
        classes.append("")
    mean = ["mean ± sd", "", "", _mean_sd(cv.get("accuracy_mean"), cv.get("accuracy_std")),
            f"{_fixed(cv.get('macro_f1_mean'), 4)} ± {_fixed(cv.get('macro_f1_std'), 4)}"]
    if per_trial:
        mean.append(_mean_sd(cv.get("per_trial_accuracy_mean"),
                             cv.get("per_trial_accuracy_std")))
    rows.append(mean)
    classes.append("mean")
    return text + _table(header, rows, row_class=classes)


def _class_table(head: Mapping[str, Any]) -> tuple[str, bool]:
    """Table I rows of a classification head: per class precision, recall, F1, support; a
    class without support is greyed and flagged. Returns the table and whether any was."""
    rows, classes, absent_any = [], [], False
    for c in (c for c in _list(head.get("per_class")) if isinstance(c, dict)):
        absent = bool(c.get("absent")) or c.get("support") == 0
        absent_any |= absent
        rows.append((c.get("name"), _fixed(c.get("precision")), _fixed(c.get("recall")),
                     "" if absent else _fixed(c.get("f1")), _fmt(c.get("support")),
                     "no support: left out of the macro F1" if absent else ""))
        classes.append("absent" if absent else "")
    rows.append(("overall accuracy", "", "", _fixed(head.get("accuracy")), _fmt(head.get("n")),
                 f"95 % CI {_ci(head.get('accuracy_ci95'))} %" if _ci(head.get("accuracy_ci95"))
                 else ""))
    rows.append(("macro F1", "", "", _fixed(head.get("macro_f1")), "",
                 f"95 % CI {_ci(head.get('macro_f1_ci95'))} %" if _ci(head.get("macro_f1_ci95"))
                 else ""))
    classes += ["", ""]
    return _table(("class", "precision", "recall", "F1", "support", "note"), rows,
                  row_class=classes), absent_any


def _per_trial_html(head: Mapping[str, Any]) -> str:
    """Per-trial decisions of a trial-level head (majority vote, mean probability)."""
    pt = head.get("per_trial")
    if not isinstance(pt, dict):
        return ""
    return (f"<p>per trial ({_fmt(pt.get('n_trials'))} trials): majority vote "
            f"<b>{_e(_pct(pt.get('majority_accuracy')))} %</b> "
            f"{_e(_ci(pt.get('majority_accuracy_ci95')))}, mean probability "
            f"{_e(_pct(pt.get('mean_probability_accuracy')))} % "
            f"{_e(_ci(pt.get('mean_probability_accuracy_ci95')))}"
            + (f", majority-vote macro F1 {_e(_fixed(pt.get('majority_macro_f1'), 4))}"
               if pt.get("majority_macro_f1") is not None else "")
            + " (95 % bootstrap intervals over trials)</p>")


def _classification_html(head: Mapping[str, Any], folder: Path, inputs: _Inputs) -> str:
    name = str(head.get("head", ""))
    interval = _ci(head.get("accuracy_ci95"))
    out = [f"<p><b>{_e(name)}</b>: accuracy per window {_e(_pct(head.get('accuracy')))} %"
           + (f" (95 % CI {_e(interval)} %, bootstrap over trials)" if interval else "")
           + " (Table I form)</p>"]
    table, absent = _class_table(head)
    out.append(table)
    if absent:
        out.append("<p class='muted'>greyed: classes with no window in the evaluated data; "
                   "their recall and F1 mean nothing and they are left out of the macro F1."
                   "</p>")
    if head.get("accuracy_excluding_boundaries") is not None:
        out.append(f"<p class='muted'>without the {_fmt(head.get('n_near_boundary'))} windows "
                   f"within {_e(head.get('boundary_margin'))} sample(s) of a label change: "
                   f"accuracy {_e(_pct(head['accuracy_excluding_boundaries']))} %</p>")
    out.append(_per_trial_html(head))
    png = folder / f"confusion_{name}.png"
    if png.is_file():
        inputs.add("figure", png)
        out.append(_figure(png.read_bytes(), f"confusion matrix of {name} "
                                             "(rows true, columns predicted)"))
    return "".join(out)


def _cost_table(m: Mapping[str, Any]) -> str:
    lat = m.get("latency") or {}
    model = m.get("model") or {}
    return _table(
        ("parameters", "size (MB)", "model.pt (bytes)", "batch-1 median (ms)",
         "batch-1 p95 (ms)", f"windows/s (batch {lat.get('large_batch', '')})", "threads",
         "CPU"),
        [(_fmt(model.get("n_params")), _fmt(model.get("size_mb")),
          _fmt(model.get("file_size_bytes")), _fmt(lat.get("batch1_ms_median")),
          _fmt(lat.get("batch1_ms_p95")),
          _fmt(lat.get("windows_per_s") and round(lat["windows_per_s"])),
          _fmt(lat.get("threads")), lat.get("cpu", "not measured"))], left=0)


def _eval_section(r: _Result, inputs: _Inputs) -> str:
    m = r.metrics
    folder = r.run / runs.EVAL_DIR / r.name
    data = ", ".join(f"{x.get('path')} ({x.get('n_trials')} trials)"
                     for x in _list(m.get("data")) if isinstance(x, dict))
    out = [f"<h4 id='{_e(r.anchor)}'>evaluation {_e(r.name)}</h4>",
           f"<p class='origin'>{_tag(r.evaluated_on, 'evaluated on')} &middot; "
           f"independent of the training data: {_e(r.independent)}</p>",
           f"<p>{_e(data)}; split {_e(m.get('split'))}; {_fmt(m.get('n_trials'))} trials, "
           f"{_fmt(m.get('n_windows'))} windows.</p>", _warnings_html(m)]
    if m.get("overlaps_training") and m.get("split") == "all":
        out.append(f"<p class='note'>{_e(', '.join(m['overlaps_training']))} was used to "
                   "train this run: these metrics include training trials.</p>")
    out += [f"<p class='note'>{_e(n)}</p>" for n in _list(m.get("notes"))]
    if _dict(m.get("cv")):
        out.append(_cv_html(m["cv"]))
    for head in (m.get("heads") or {}).values():
        if head.get("kind") == "classification":
            out.append(_classification_html(head, folder, inputs))
        else:
            out.append(f"<p><b>{_e(head.get('head'))}</b> (regression): MAE "
                       f"{_fmt(head.get('mae'))}, RMSE {_fmt(head.get('rmse'))} over "
                       f"{_fmt(head.get('n'))} windows</p>")
    out.append(_cost_table(m))
    return "".join(out)


def _run_section(d: Path, label: str, info: dict[str, Any], results: Sequence[_Result],
                 trained_on: Mapping[str, Any], inputs: _Inputs) -> str:
    inputs.add("run", d / runs.RUN_JSON)
    cfg = runs.read_run_config(d).model_dump(mode="json")
    inputs.add("config", d / runs.CONFIG_YAML)
    evaluated = {describe_origin(r.evaluated_on): r.evaluated_on for r in results}
    tags = "".join(f"<p class='origin'>{_tag(o, 'evaluated on')}</p>"
                   for o in evaluated.values())
    out = [f"<h3 id='run-{_e(label)}'>{_e(label)}</h3>",
           f"<p class='origin'>{_tag(trained_on, 'trained on')}</p>{tags}",
           f"<p class='muted'>{_e(d)}</p>", _config_summary(d, info, cfg or {})]
    curves = d / runs.CURVES_PNG
    if curves.is_file():
        inputs.add("figure", curves)
        out.append(_figure(curves.read_bytes(), "training curves: loss and validation "
                                                "accuracy per epoch (dashed: best epoch)"))
    elif not isinstance(info.get("training", {}).get("folds"), list):
        out.append("<p class='note'>no curves.png in the run folder</p>")
    if not results:
        out.append(f"<p class='note'>not evaluated yet: run <code>tactile evaluate {_e(d)} "
                   "--data FILE</code></p>")
    for r in results:
        out.append(_eval_section(r, inputs))
    for name, path in find_perturbations(d).items():
        p = load_perturbation(path)
        out.append(f"<h4>perturbation {_e(name)}</h4><p>clean accuracy "
                   f"{100 * p.clean_accuracy:.2f} %, threshold {100 * p.threshold:.2f} % "
                   f"({_e(p.threshold_rule)}), seed {p.seed}; chart in the perturbation "
                   "section.</p>")
    return "".join(out)


def _run_order(dirs: Sequence[Path], results: Sequence[_Result]) -> list[int]:
    """Indices of ``dirs``: runs with a result on recorded data first (stable)."""
    best = {str(d): min((_rank(r.evaluated_on) for r in results if r.run == d),
                        default=len(ORIGIN_RANK)) for d in dirs}
    return sorted(range(len(dirs)), key=lambda i: best[str(dirs[i])])


# -- data files and figures ------------------------------------------------------------------
def _data_section(path: Path, origin: Mapping[str, Any], inputs: _Inputs) -> str:
    from ..store.reader import summarize

    s = summarize(path)
    inputs.add("data", path)
    sensors = _table(("sensor", "kind", "rate (Hz)", "channels", "geometry", "units"),
                     [(x.name, x.kind, _fmt(x.sample_rate_hz), x.n_channels, x.geometry,
                       ", ".join(x.units)) for x in s.sensors], left=2)
    splits: dict[str, int] = {}
    streams: dict[str, int] = {}
    for t in s.trials:
        splits[t.split or "(none)"] = splits.get(t.split or "(none)", 0) + 1
        for st in t.streams:
            streams[st] = streams.get(st, 0) + 1
    labels = []
    for key, counts in s.label_counts.items():
        shown = ", ".join(f"{k}: {v}" for k, v in counts.items()) if len(counts) <= 15 \
            else f"{len(counts)} distinct values"
        labels.append((key, shown))
    n_events = sum(t.n_events for t in s.trials)
    return (f"<h3>{_e(path.name)}</h3><p class='origin'>{_tag(origin)}</p>"
            f"<p class='muted'>{_e(path)}</p>"
            + _kv([("schema / tool version", f"{s.schema_version} / {s.tool_version}"),
                   ("created", s.created_utc), ("command", s.command),
                   ("trials", f"{len(s.trials):,} ({_fmt(s.total_duration_s, 5)} s in all); "
                              "splits " + ", ".join(f"{k} {v}" for k, v in splits.items())),
                   ("streams", ", ".join(f"{k} ({v} trials)" for k, v in streams.items())
                    or "none"),
                   ("events", f"{n_events:,}"), ("sources", s.n_sources)])
            + sensors + (_table(("trial label", "values (trials)"), labels, left=2)
                         if labels else ""))


def _gallery_html(folder: Path, g: Gallery, file_origins: Mapping[str, dict[str, Any]],
                  inputs: _Inputs) -> str:
    """One kind of figure: a heading that says what they show (and the origin of the file a
    quick look shows), then the figures; more than a few as one grid of small figures."""
    shown = g.shown()
    count = (f"{len(g.figures)} figures" + (f", {len(shown)} shown (evenly spread)"
                                            if len(shown) < len(g.figures) else "")
             if len(g.figures) > 1 else "1 figure")
    origin = file_origins.get(g.file or "")
    head = (f"<h4>{_e(g.title)} <span class='muted'>({_e(count)})</span></h4>"
            + (f"<p class='origin'>{_tag(origin)}</p>" if origin else ""))
    figs = []
    for f in shown:
        p = folder / f.path
        inputs.add("figure", p)
        figs.append(_figure(p.read_bytes(), f.subject if g.is_grid else f.caption))
    body = f"<div class='grid'>{''.join(figs)}</div>" if g.is_grid else "".join(figs)
    rest = [f.subject for f in g.figures if f not in shown]
    more = (f"<p class='muted'>not shown: {_e(', '.join(rest))}</p>" if rest else "")
    return head + body + more


def _figure_section(folder: Path, file_origins: Mapping[str, dict[str, Any]],
                    inputs: _Inputs) -> tuple[str, list[str]]:
    """The PNGs under ``folder``, grouped by what they show (:mod:`.gallery`)."""
    pngs = sorted(p for p in folder.rglob("*.png") if p.is_file()
                  and not any(part.startswith(".") for part in p.relative_to(folder).parts))
    rank = {stem: _rank(o) for stem, o in file_origins.items()}
    galleries = group_figures([p.relative_to(folder) for p in pngs], rank)
    parts = [f"<h3>{_e(folder.name)}/</h3><p class='muted'>{_e(folder)}</p>"]
    parts += [_gallery_html(folder, g, file_origins, inputs) for g in galleries]
    if not pngs:
        parts.append("<p class='note'>no PNG files in this folder</p>")
    return "".join(parts), [str(p) for p in pngs]


# -- the page --------------------------------------------------------------------------------
def _spread_table(record: dict[str, Any]) -> str:
    """A seed spread's record (or a spread evaluation's) as a table: a row per seed, then
    the mean, SD, min, max and spread."""
    from .seed_spread import LABELS, METRICS

    summary = _dict(record.get("summary"))
    names = [n for n in METRICS if n in summary]
    rows = [[f"seed {_dict(r).get('seed')}", *(_pct(_dict(r).get(n)) for n in names),
             _dict(r).get("n_trials", "")] for r in _list(record.get("by_seed"))]
    for stat in ("mean", "sd", "min", "max", "spread"):
        rows.append([stat, *(_pct(_dict(summary.get(n)).get(stat)) for n in names), ""])
    return _table(["seed", *(f"{LABELS[n]} (%)" for n in names), "trials"], rows)


def _spread_section(folder: Path, inputs: _Inputs) -> str:
    """One ``tactile seed-spread`` folder: every seed's figures, their mean, SD and spread,
    the notes and the dot plot; then each of its evaluations on other recordings
    (``tactile evaluate SPREAD --data FILE``) beside the spread's own figures."""
    from .spread_eval import FIGURE, RECORD, read_spread_eval

    record_path = folder / SPREAD_JSON
    inputs.add("seed spread", record_path)
    record = read_spread_record(record_path)
    cv = record.get("cv")
    how = ("leave-one-trial-out cross-validation" if cv == "loto" else
           f"{cv}-fold cross-validation, split {_dict(record.get('split')).get('mode', '?')}"
           if cv is not None else "scored on " + ", ".join(
               str(_dict(d).get("path")) for d in _list(record.get("eval_data"))))
    html = (f"<h3>{_e(folder.name)}</h3><p>config <code>{_e(record.get('config'))}</code>; "
            f"{_e(how)}; the figures of trials each seed's model never saw.</p>"
            + _spread_table(record))
    html += "".join(f"<p class='note'>{_e(n)}</p>" for n in _list(record.get("notes")))
    png = folder / "seed_spread.png"
    if png.is_file():
        inputs.add("figure", png)
        html += _figure(png.read_bytes(), f"{folder.name}: each seed's figure (dots), the "
                        "mean and one SD")
    for path in sorted((folder / runs.EVAL_DIR).glob(f"*/{RECORD}")):
        inputs.add("seed spread evaluation", path)
        ev = read_spread_eval(path)
        files = ", ".join(str(_dict(d).get("path")) for d in _list(ev.get("data")))
        html += (f"<h4>{_e(folder.name)} on {_e(files)}</h4><p>every seed's model scored "
                 f"on recordings the spread was not scored on (evaluation "
                 f"<code>{_e(path.parent.name)}</code>).</p>" + _spread_table(ev))
        html += "".join(f"<p class='note'>{_e(n)}</p>"
                        for n in [*_list(ev.get("against_own")), *_list(ev.get("notes"))])
        png = path.parent / FIGURE
        if png.is_file():
            inputs.add("figure", png)
            html += _figure(png.read_bytes(), f"{folder.name} on {files}: each seed's figure")
    return html


def _check_inputs(run_dirs: Sequence[str | Path], data_paths: Sequence[str | Path],
                  figure_dirs: Sequence[str | Path]
                  ) -> tuple[list[Path], list[Path], list[Path], dict[Path, list[Path]]]:
    """The inputs as paths, each checked before anything is written; a seed-spread folder
    stands for its seed runs (the last item: each spread folder -> its seed runs)."""
    dirs: list[Path] = []
    spreads: dict[Path, list[Path]] = {}
    for d in map(Path, run_dirs):
        members = spread_runs(d)
        if members is None:
            dirs.append(check_run_folder(d))
        else:
            spreads[d] = members
            dirs.extend(members)
    datas = [Path(p) for p in data_paths]
    figs = [Path(p) for p in figure_dirs]
    if not dirs and not datas and not figs:
        raise InputError("nothing to report; give `run_dirs`, `data_paths` or `figure_dirs`")
    for p in datas:
        if not p.is_file():
            raise InputError("data file not found", path=p)
    for p in figs:
        if not p.is_dir():
            raise InputError("figure folder not found (`figure_dirs` takes folders)", path=p)
    return dirs, datas, figs, spreads


def _page(heading: str, created: str, cmd: str, sections: Sequence[tuple[str, str, str]],
          notes: Sequence[str]) -> str:
    """The HTML page: title, table of contents, notes, then ``(anchor, title, html)``
    sections that are not empty."""
    toc = "".join(f"<li><a href='#{a}'>{_e(t)}</a></li>" for a, t, h in sections if h)
    body = [f"<h1>{_e(heading)}</h1><p class='muted'>created {_e(created)} by tactile "
            f"{_e(__version__)}: <code>{_e(cmd)}</code></p>", f"<nav><ul>{toc}</ul></nav>"]
    body += [f"<p class='note'>{_e(n)}</p>" for n in notes]
    body += [f"<h2 id='{a}'>{_e(t)}</h2>{h}" for a, t, h in sections if h]
    body.append(f"<h2>Provenance</h2><p class='muted'>inputs and their SHA-256 are in "
                f"{REPORT_JSON} beside this page.</p>")
    return ("<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'>"
            f"<meta name='generator' content='tactile {_e(__version__)}'>"
            f"<title>{_e(heading)}</title><style>{_CSS}</style></head><body>"
            + "\n".join(body) + "</body></html>\n")


def build_report(
    run_dirs: Sequence[str | Path],
    out_dir: str | Path,
    *,
    data_paths: Sequence[str | Path] = (),
    figure_dirs: Sequence[str | Path] = (),
    title: str | None = None,
    margin_pp: float = 0.5,
    metric: str = "auto",
    command: str | None = None,
) -> ReportResult:
    """Write ``OUT/index.html`` and ``OUT/report.json`` (see the module docstring).

    Raises :class:`InputError` before writing anything when a run folder, data file or
    figure folder is missing."""
    dirs, datas, figs, spreads = _check_inputs(run_dirs, data_paths, figure_dirs)
    check_outputs({"out_dir": out_dir}, [*(d / runs.RUN_JSON for d in dirs), *datas],
                  trees=figs)
    out = check_output_folder(out_dir, merge=True)  # added to; a file there is refused

    inputs, origins = _Inputs(), _Origins()
    notes: list[str] = []
    infos = []
    for d in dirs:
        infos.append(runs.read_run_info(d))
        runs.read_run_config(d)  # a damaged config is refused before anything is written
    labels = run_labels(dirs, [i["model"]["family"] for i in infos])
    results = _results(dirs, labels, infos, origins, inputs)
    units = [Path(d) for d in run_dirs]
    cmp_html, compared = _comparison_sections(units, spreads, results, margin_pp, metric,
                                              notes)
    pert_html, perturbed = _perturbation_sections(dirs, inputs)
    run_html = "".join(
        _run_section(dirs[i], labels[i], infos[i], [r for r in results if r.run == dirs[i]],
                     origins.of_record(infos[i]), inputs)
        for i in _run_order(dirs, results))
    data_origins = {p: origins.of_paths([str(p)]) for p in datas}
    data_html = "".join(_data_section(p, data_origins[p], inputs)
                        for p in sorted(datas, key=lambda p: _rank(data_origins[p])))
    file_origins = {p.stem: o for p, o in data_origins.items()}
    fig_parts, fig_names = [], []
    for f in figs:
        part, names = _figure_section(f, file_origins, inputs)
        fig_parts.append(part)
        fig_names += names

    seeds_html = "".join(_spread_section(f, inputs) for f in spreads)
    created = utc_now()
    cmd = command if command is not None else current_command()
    heading = title or f"tactile report: {len(dirs)} run(s)"
    sections = [
        ("origins", "Where the numbers come from", _overview_section(results) if dirs else ""),
        ("compare", "Comparison: accuracy against latency", (
            cmp_html or "<p class='muted'>no evaluation is shared by two or more runs; "
                        "evaluate them on the same data to compare.</p>") if dirs else ""),
        ("seeds", "Seed spreads: how much of a figure is the seed", seeds_html),
        ("perturb", "Stability under perturbation", pert_html),
        ("runs", "Runs", run_html),
        ("data", "Data files", data_html),
        ("figures", "Figures", "".join(fig_parts)),
    ]
    page = _page(heading, created, cmd, sections, notes)

    index = out / INDEX_HTML
    record = {
        "format": "tactile-report", "format_version": 1, "tool_version": __version__,
        "created_utc": created, "command": cmd, "index": str(index),
        "runs": [str(d) for d in dirs], "seed_spreads": [str(f) for f in spreads],
        "compared": compared, "perturbations": perturbed,
        "data": [str(p) for p in datas], "figure_dirs": [str(p) for p in figs],
        "origins": [r.record() for r in results],
        "data_origins": {str(p): o for p, o in data_origins.items()},
        "notes": notes, "inputs": inputs.items,
    }
    prov = out / REPORT_JSON
    with output_folder(out, merge=True) as tmp:  # both files moved in together
        write_text(tmp / INDEX_HTML, page)
        write_text(tmp / REPORT_JSON, runs.dumps(record) + "\n")
    return ReportResult(index, prov, [str(d) for d in dirs], compared, perturbed,
                        [str(p) for p in datas], fig_names, notes,
                        [r.record() for r in results])


__all__ = ["INDEX_HTML", "ORIGIN_RANK", "REPORT_JSON", "ReportResult", "build_report"]
