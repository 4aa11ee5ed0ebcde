"""``tactile report``: one self-contained HTML page of runs, their comparison and data files.

Issue 4, item 10. The page (``OUT/index.html``) needs no other file: every figure is a
base64 PNG inside an ``<img src="data:image/png;base64,...">`` and the style sheet is
inline; nothing is loaded from elsewhere. It holds, in order:

1. for every evaluation name that two or more runs share, the comparison of
   :mod:`.compare` (table, the model the scene needs, the accuracy-latency chart with the
   Pareto front);
2. for every perturbation name (``RUN/perturb/<name>/``, :mod:`.perturb`) the chart with
   one line per run and the breaking points;
3. per run: the config summary (model, data, optimiser, training), the training curves
   (``curves.png``), and per evaluation the paper-000 Table I metrics (per-class
   precision, recall, F1, support, overall accuracy), regression errors, the confusion
   matrices and the cost (parameters, size, latency, throughput);
4. a summary of each given data file (:func:`tactile_cli.store.reader.summarize`);
5. every PNG under each extra figure folder, captioned with its path in that folder.

``OUT/report.json`` beside it records the provenance: command, tool version, time and
every input read (run.json, metrics.json, perturb.json, data and figure files, with
SHA-256). Both are written atomically (temporary file + ``os.replace``).
"""

from __future__ import annotations

import base64
import html
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .._version import __version__
from ..errors import InputError, TactileError
from ..store.outdir import check_output_folder, output_folder
from ..store.writer import current_command, sha256_of, utc_now
from . import runs
from .compare import (
    check_run_folder,
    compare,
    eval_names,
    plot_comparison,
    run_labels,
    table_rows,
    write_atomic,
)
from .perturb import find_perturbations, level_text, load_perturbation, plot_perturbations

INDEX_HTML = "index.html"
REPORT_JSON = "report.json"

_CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Helvetica,Arial,sans-serif;margin:2em auto;
max-width:1150px;color:#222;line-height:1.4;padding:0 1em}
h1{font-size:1.6em}h2{border-bottom:2px solid #ddd;padding-bottom:.2em;margin-top:2em}
h3{margin-top:1.5em}h4{margin:1em 0 .3em}
table{border-collapse:collapse;margin:.5em 0 1em;font-size:.88em}
th,td{border:1px solid #ccc;padding:.25em .55em;text-align:right;vertical-align:top}
th{background:#f3f3f3}td.l,th.l{text-align:left}
tr.needed td{background:#fff6cc}tr.front td:first-child{font-weight:bold}
figure{margin:.5em 0 1.2em;display:inline-block;vertical-align:top}
figure img{max-width:100%;border:1px solid #eee}
figcaption{font-size:.85em;color:#555}
.note{color:#8a4b00;background:#fff4e5;padding:.3em .6em;border-left:3px solid #f0a040}
.muted{color:#777;font-size:.85em}code{font-size:.9em}
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


# -- sections --------------------------------------------------------------------------------
def _comparison_sections(run_dirs: Sequence[Path], margin_pp: float, metric: str,
                         notes: list[str]) -> tuple[str, list[str]]:
    by_name: dict[str, list[Path]] = {}
    for d in run_dirs:
        for name in eval_names(d):
            by_name.setdefault(name, []).append(d)
    parts, done = [], []
    for name, dirs in sorted(by_name.items()):
        if len(dirs) < 2:
            continue
        try:
            cmp = compare(dirs, data_name=name, margin_pp=margin_pp, metric=metric)
        except TactileError as exc:
            msg = f"evaluation {name!r} not compared: {exc}"
            notes.append(msg)
            parts.append(f"<h3>{_e(name)}</h3><p class='note'>{_e(msg)}</p>")
            continue
        notes.extend(cmp.notes)
        done.append(name)
        rows, classes = [], []
        for row in table_rows(cmp):
            rows.append((row["label"], f"{row['score_pct']:.2f}", f"{row['delta_pp']:+.2f}",
                         _fmt(row["latency_ms_median"]), _fmt(row["latency_ms_p95"]),
                         _fmt(row["windows_per_s"] and round(row["windows_per_s"])),
                         _fmt(row["n_params"]), _fmt(row["size_mb"]),
                         "yes" if row["pareto"] else "", "yes" if row["within_margin"] else "",
                         "needed" if row["needed"] else ("fastest" if row["fastest"] else "")))
            classes.append(" ".join(c for c, on in (("needed", row["needed"]),
                                                    ("front", row["pareto"])) if on))
        table = _table((
            "run", f"{cmp.metric_label} (%)", "vs best (pp)", "batch-1 median (ms)",
            "batch-1 p95 (ms)", "windows/s", "parameters", "size (MB)", "Pareto",
            f"within {cmp.margin_pp:g} pp", "choice"), rows, row_class=classes)
        first = cmp.points[0]
        data = ", ".join(Path(str(d["path"])).name for d in first.data)
        parts.append(
            f"<h3 id='cmp-{_e(name)}'>{_e(name)}</h3>"
            f"<p>{len(cmp.points)} runs evaluated on {_e(data)} (split {_e(first.split)}, "
            f"{first.n_windows:,} windows). <b>{_e(cmp.summary())}</b>.</p>{table}"
            + _figure(plot_comparison(cmp), f"{cmp.metric_label} against latency per window "
                      f"(batch 1, median) on {name}; dashed: Pareto front"))
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


def _config_summary(d: Path, info: dict[str, Any], cfg: dict[str, Any]) -> str:
    data = cfg.get("data", {})
    model = dict(cfg.get("model", {}))
    optim = cfg.get("optim", {})
    tr = info.get("training", {})
    targets = ", ".join(f"{t.get('name')} ({t.get('kind', 'classification')}, "
                        f"{t.get('source', 'sample')})" for t in data.get("targets", []))
    family = model.pop("family", "?")
    pairs: list[tuple[str, Any]] = [
        ("model", f"{family}: " + ", ".join(f"{k}={v}" for k, v in model.items())),
        ("parameters / size", f"{_fmt(info.get('model', {}).get('n_params'))} / "
                              f"{_fmt(info.get('model', {}).get('size_mb'))} MB"),
        ("data", f"stream {data.get('stream')}, channels {data.get('channels')}, window "
                 f"{data.get('window')}, stride {data.get('stride')}, pad {data.get('pad')}, "
                 f"transform {data.get('transform')}, label {data.get('label_rule')} "
                 f"(delay {data.get('label_delay')})"),
        ("targets", targets),
        ("split", f"{info.get('split', {}).get('mode')}: trials "
                  f"{info.get('split', {}).get('trials')}, windows "
                  f"{info.get('split', {}).get('windows')}"),
        ("optimiser", f"{optim.get('optimizer')} lr {optim.get('lr')}, batch "
                      f"{optim.get('batch_size')}, epochs {optim.get('epochs')}, patience "
                      f"{optim.get('patience')} on {optim.get('monitor')}"),
        ("training", f"{tr.get('epochs_run')} epochs, best {tr.get('best_epoch')} (val "
                     f"accuracy {_fmt(tr.get('best_val_accuracy'))}), "
                     f"{_fmt(tr.get('train_time_s'), 3)} s on {tr.get('threads')} thread(s)"),
        ("seed", info.get("seed")),
        ("trained on", "; ".join(f"{x.get('path')} ({x.get('n_trials')} trials, sha256 "
                                 f"{str(x.get('sha256', ''))[:12]})"
                                 for x in info.get("data", []))),
        ("versions", ", ".join(f"{k} {v}" for k, v in info.get("versions", {}).items())),
        ("command", info.get("command", "")),
        ("created", info.get("created_utc", "")),
    ]
    return _kv(pairs)


def _eval_section(d: Path, name: str, inputs: _Inputs) -> str:
    folder = d / runs.EVAL_DIR / name
    path = folder / runs.METRICS_JSON
    m = runs.read_metrics(path)
    inputs.add("metrics", path)
    data = ", ".join(f"{x.get('path')} ({x.get('n_trials')} trials)" for x in m.get("data", []))
    out = [f"<h4>evaluation {_e(name)}</h4>",
           f"<p>{_e(data)}; split {_e(m.get('split'))}; {_fmt(m.get('n_trials'))} trials, "
           f"{_fmt(m.get('n_windows'))} windows.</p>"]
    if m.get("overlaps_training") and m.get("split") == "all":
        out.append(f"<p class='note'>{_e(', '.join(m['overlaps_training']))} was used to "
                   "train this run: these metrics include training trials.</p>")
    out += [f"<p class='note'>{_e(n)}</p>" for n in m.get("notes") or []]
    for head in m.get("heads", {}).values():
        if head.get("kind") == "classification":
            rows = [(c["name"], f"{c['precision']:.5f}", f"{c['recall']:.5f}", f"{c['f1']:.5f}",
                     _fmt(c["support"])) for c in head["per_class"]]
            rows.append(("overall accuracy", "", "", f"{head['accuracy']:.5f}",
                         _fmt(head["n"])))
            rows.append(("macro F1", "", "", _fmt(head.get("macro_f1"), 5), ""))
            caption = ""
            if head.get("accuracy_excluding_boundaries") is not None:
                caption = (f"<p class='muted'>without the {_fmt(head['n_near_boundary'])} "
                           f"windows within {head['boundary_margin']} sample(s) of a label "
                           f"change: accuracy {100 * head['accuracy_excluding_boundaries']:.2f}"
                           " %</p>")
            out.append(f"<p><b>{_e(head['head'])}</b>: accuracy "
                       f"{100 * head['accuracy']:.2f} % (Table I form)</p>")
            out.append(_table(("class", "precision", "recall", "F1", "support"), rows))
            out.append(caption)
            png = folder / f"confusion_{head['head']}.png"
            if png.is_file():
                inputs.add("figure", png)
                out.append(_figure(png.read_bytes(), f"confusion matrix of {head['head']} "
                                                     "(rows true, columns predicted)"))
        else:
            out.append(f"<p><b>{_e(head['head'])}</b> (regression): MAE {_fmt(head['mae'])}, "
                       f"RMSE {_fmt(head['rmse'])} over {_fmt(head['n'])} windows</p>")
    lat = m.get("latency") or {}
    model = m.get("model") or {}
    out.append(_table(
        ("parameters", "size (MB)", "model.pt (bytes)", "batch-1 median (ms)",
         "batch-1 p95 (ms)", f"windows/s (batch {lat.get('large_batch', '')})", "threads",
         "CPU"),
        [(_fmt(model.get("n_params")), _fmt(model.get("size_mb")),
          _fmt(model.get("file_size_bytes")), _fmt(lat.get("batch1_ms_median")),
          _fmt(lat.get("batch1_ms_p95")),
          _fmt(lat.get("windows_per_s") and round(lat["windows_per_s"])),
          _fmt(lat.get("threads")), lat.get("cpu", "not measured"))], left=0))
    return "".join(out)


def _run_section(d: Path, label: str, inputs: _Inputs) -> str:
    info_path = d / runs.RUN_JSON
    info = runs.read_run_info(d)
    inputs.add("run", info_path)
    cfg_path = d / runs.CONFIG_YAML
    cfg = runs.read_run_config(d).model_dump(mode="json")
    inputs.add("config", cfg_path)
    out = [f"<h3 id='run-{_e(label)}'>{_e(label)}</h3><p class='muted'>{_e(d)}</p>",
           _config_summary(d, info, cfg or {})]
    curves = d / runs.CURVES_PNG
    if curves.is_file():
        inputs.add("figure", curves)
        out.append(_figure(curves.read_bytes(), "training curves: loss and validation "
                                                "accuracy per epoch (dashed: best epoch)"))
    else:
        out.append("<p class='note'>no curves.png in the run folder</p>")
    names = eval_names(d)
    if not names:
        out.append(f"<p class='note'>not evaluated yet: run <code>tactile evaluate {_e(d)} "
                   "--data FILE</code></p>")
    for name in names:
        out.append(_eval_section(d, name, inputs))
    for name, path in find_perturbations(d).items():
        r = load_perturbation(path)
        out.append(f"<h4>perturbation {_e(name)}</h4><p>clean accuracy "
                   f"{100 * r.clean_accuracy:.2f} %, threshold {100 * r.threshold:.2f} % "
                   f"({_e(r.threshold_rule)}), seed {r.seed}; chart in the perturbation "
                   "section.</p>")
    return "".join(out)


def _data_section(path: Path, inputs: _Inputs) -> str:
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
    return (f"<h3>{_e(path.name)}</h3><p class='muted'>{_e(path)}</p>"
            + _kv([("schema / tool version", f"{s.schema_version} / {s.tool_version}"),
                   ("created", s.created_utc), ("command", s.command),
                   ("trials", f"{len(s.trials):,} ({_fmt(s.total_duration_s, 5)} s in all); "
                              "splits " + ", ".join(f"{k} {v}" for k, v in splits.items())),
                   ("streams", ", ".join(f"{k} ({v} trials)" for k, v in streams.items())
                    or "none"),
                   ("events", f"{n_events:,}"), ("sources", s.n_sources)])
            + sensors + (_table(("trial label", "values (trials)"), labels, left=2)
                         if labels else ""))


def _figure_section(folder: Path, inputs: _Inputs) -> tuple[str, list[str]]:
    pngs = sorted(p for p in folder.rglob("*.png") if p.is_file()
                  and not p.name.startswith("."))
    parts, names = [], []
    for p in pngs:
        rel = str(p.relative_to(folder))
        inputs.add("figure", p)
        parts.append(_figure(p.read_bytes(), rel))
        names.append(str(p))
    if not pngs:
        parts.append("<p class='note'>no PNG files in this folder</p>")
    return f"<h3>{_e(folder)}</h3>" + "".join(parts), names


# -- the page --------------------------------------------------------------------------------
def build_report(
    run_dirs: Sequence[str | Path],
    out_dir: str | Path,
    *,
    data_paths: Sequence[str | Path] = (),
    figure_dirs: Sequence[str | Path] = (),
    title: str | None = None,
    margin_pp: float = 0.5,
    metric: str = "accuracy",
    command: str | None = None,
) -> ReportResult:
    """Write ``OUT/index.html`` and ``OUT/report.json`` (see the module docstring).

    Raises :class:`InputError` before writing anything when a run folder, data file or
    figure folder is missing."""
    dirs = [check_run_folder(Path(d)) for d in run_dirs]
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
    out = check_output_folder(out_dir, merge=True)  # added to; a file there is refused

    inputs = _Inputs()
    notes: list[str] = []
    families = []
    for d in dirs:
        families.append(runs.read_run_info(d)["model"]["family"])
        runs.read_run_config(d)  # a damaged config is refused before anything is written
    labels = run_labels(dirs, families)
    cmp_html, compared = _comparison_sections(dirs, margin_pp, metric, notes)
    pert_html, perturbed = _perturbation_sections(dirs, inputs)
    run_html = "".join(_run_section(d, lab, inputs) for d, lab in zip(dirs, labels,
                                                                       strict=True))
    data_html = "".join(_data_section(p, inputs) for p in datas)
    fig_parts, fig_names = [], []
    for f in figs:
        part, names = _figure_section(f, inputs)
        fig_parts.append(part)
        fig_names += names

    created = utc_now()
    cmd = command if command is not None else current_command()
    heading = title or f"tactile report: {len(dirs)} run(s)"
    toc = []
    body = [f"<h1>{_e(heading)}</h1><p class='muted'>created {_e(created)} by tactile "
            f"{_e(__version__)}: <code>{_e(cmd)}</code></p>"]
    if dirs:
        toc.append("<li><a href='#compare'>comparison</a></li>")
        body.append("<h2 id='compare'>Comparison: accuracy against latency</h2>")
        body.append(cmp_html or "<p class='muted'>no evaluation is shared by two or more "
                                "runs; evaluate them on the same data to compare.</p>")
    if pert_html:
        toc.append("<li><a href='#perturb'>stability under perturbation</a></li>")
        body.append("<h2 id='perturb'>Stability under perturbation</h2>" + pert_html)
    if dirs:
        toc.append("<li><a href='#runs'>runs</a></li>")
        body.append("<h2 id='runs'>Runs</h2>" + run_html)
    if datas:
        toc.append("<li><a href='#data'>data files</a></li>")
        body.append("<h2 id='data'>Data files</h2>" + data_html)
    if figs:
        toc.append("<li><a href='#figures'>figures</a></li>")
        body.append("<h2 id='figures'>Figures</h2>" + "".join(fig_parts))
    if notes:
        body.insert(1, "".join(f"<p class='note'>{_e(n)}</p>" for n in notes))
    body.insert(1, f"<nav><ul>{''.join(toc)}</ul></nav>")
    body.append(f"<h2>Provenance</h2><p class='muted'>inputs and their SHA-256 are in "
                f"{REPORT_JSON} beside this page.</p>")
    page = ("<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'>"
            f"<meta name='generator' content='tactile {_e(__version__)}'>"
            f"<title>{_e(heading)}</title><style>{_CSS}</style></head><body>"
            + "\n".join(body) + "</body></html>\n")

    index = out / INDEX_HTML
    record = {
        "format": "tactile-report", "format_version": 1, "tool_version": __version__,
        "created_utc": created, "command": cmd, "index": str(index),
        "runs": [str(d) for d in dirs], "compared": compared, "perturbations": perturbed,
        "data": [str(p) for p in datas], "figure_dirs": [str(p) for p in figs],
        "notes": notes, "inputs": inputs.items,
    }
    prov = out / REPORT_JSON
    with output_folder(out, merge=True) as tmp:  # both files moved in together
        write_atomic(tmp / INDEX_HTML, page)
        write_atomic(tmp / REPORT_JSON, runs.dumps(record) + "\n")
    return ReportResult(index, prov, [str(d) for d in dirs], compared, perturbed,
                        [str(p) for p in datas], fig_names, notes)


__all__ = ["INDEX_HTML", "REPORT_JSON", "ReportResult", "build_report"]
