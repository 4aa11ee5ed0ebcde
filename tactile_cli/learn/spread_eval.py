"""A seed spread scored on recordings it never saw: ``tactile evaluate SPREAD --data FILE``.

A spread (:mod:`.seed_spread`) says how much of a figure is the seed on the evaluation it was
made with. A lab that records a later session asks the next question: does the figure hold
there, and is the change larger than the seeds' spread? :func:`evaluate_spread` evaluates
every seed's model on ``data_paths`` as ``tactile evaluate`` does, into
``SPREAD/seed_S/eval/<name>/``, and reports each seed's figures beside their mean, sample SD,
min, max and spread, with the spread's own figures for comparison, in
``SPREAD/eval/<name>/``:

- ``spread_eval.json``: what was scored (the spread, its seeds, the data with SHA-256, the
  command and tool version), one row per seed, the summary, the spread's own summary and
  the notes;
- ``spread_eval.md``: the table; ``spread_eval.png``: a dot per seed, mean +- 1 SD.

Only a spread made without cross-validation (``seed-spread --eval-data``) has one model per
seed; a cross-validated seed has one per fold and no model of its whole data, so it is
refused in one line. A seed whose evaluation of the same files exists (a stopped call) is
read back; another evaluation of that name is replaced only with ``overwrite``. ``tactile
compare SPREAD_A SPREAD_B --data-name NAME`` ranks spreads on that evaluation.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from .._version import __version__
from ..errors import InputError
from ..input_guard import check_outputs
from ..store.atomic import write_json, write_text
from ..store.outdir import output_folder
from ..store.provenance import current_command, sha256_of, utc_now
from . import runs
from .compare import read_spread_record, spread_runs
from .seed_spread import (
    EVAL_NAME,
    LABELS,
    METRICS,
    RECORD_JSON,
    SeedRow,
    SeedSpread,
    plot_spread,
    seed_row,
    shared_warnings,
    summarise,
)

RECORD = "spread_eval.json"
TABLE = "spread_eval.md"
FIGURE = "spread_eval.png"
FORMAT = "tactile-seed-spread-eval"


def _same_data(metrics_path: Path, paths: Sequence[Path], split: str) -> bool:
    """Whether an evaluation record scored exactly these files (SHA-256) with ``split``."""
    try:
        record = json.loads(metrics_path.read_text(encoding="utf-8"))
        given = [d["sha256"] for d in record["data"]]
        return given == [sha256_of(p) for p in paths] and record.get("split") == split
    except (OSError, ValueError, KeyError, TypeError):
        return False


def own_figures_notes(own: dict[str, Any], here: dict[str, dict[str, float]],
                      n_trials: int | None = None) -> list[str]:
    """Per metric both summaries have: the spread's own mean against this evaluation's, and
    whether the change is larger than the seeds' SD there (the larger of the two SDs). A
    per-trial figure also says how much one of the ``n_trials`` trials weighs: a change of
    a trial or two is within what the trials drawn can give (see each seed's interval)."""
    def number(d: Any, key: str) -> float | None:
        v = d.get(key) if isinstance(d, dict) else None
        return float(v) if isinstance(v, int | float) and not isinstance(v, bool) else None

    notes = []
    for name in (n for n in METRICS if n in here):
        a, b = own.get(name) if isinstance(own, dict) else None, here[name]
        mean = number(a, "mean")
        if mean is None:  # the spread has no such figure (or a damaged record): nothing to set
            continue      # this one beside
        delta = 100 * (b["mean"] - mean)
        sd = 100 * max(number(a, "sd") or 0.0, b["sd"])
        size = ("larger than" if abs(delta) > sd else "within") + f" one seed SD, {sd:.2f} pp"
        if name.startswith("trial_") and n_trials:
            size += f"; one of the {n_trials} trials is {100 / n_trials:.1f} pp"
        notes.append(f"{LABELS[name]}: {100 * mean:.1f} % on the spread's own evaluation, "
                     f"{100 * b['mean']:.1f} % here ({delta:+.1f} pp; {size})")
    return notes


def evaluate_spread(
    spread: str | Path,
    data_paths: Sequence[str | Path] | None,
    *,
    name: str | None = None,
    split: str = "all",
    latency: bool = True,
    threads: int | None = None,
    overwrite: bool = False,
    device: str = "auto",
    shift_threshold_sd: float | None = None,
    command: str | None = None,
    plot: bool = True,
    on_seed: Callable[[SeedRow], None] | None = None,
) -> SeedSpread:
    """Evaluate every seed's model of ``spread`` on ``data_paths`` (module docstring).
    ``latency``: time the first seed's model at batch 1 (``tactile compare`` reads the first
    seed's cost; the seeds share the architecture). ``on_seed`` gets each seed's row."""
    from .data import data_files
    from .drift import SHIFT_THRESHOLD_SD
    from .evaluate import evaluate

    spread = Path(spread)
    members = spread_runs(spread)
    if members is None:
        raise InputError(f"not a seed-spread folder (no {RECORD_JSON}); make one with "
                         "`tactile seed-spread`", path=spread)
    record = read_spread_record(spread / RECORD_JSON)
    if record.get("cv") is not None:
        raise InputError("a cross-validated spread is scored on its held-out folds, and its "
                         "seeds have a model per fold, none of the whole data: to score other "
                         "recordings, make the spread without cross-validation, each seed scored "
                         "on held-out files (`tactile seed-spread` with its eval data), or "
                         "evaluate one fold's model "
                         "(SPREAD/seed_S/folds/fold_00)", path=spread)
    if not data_paths:
        raise InputError("no data files; give `data_paths`: the recordings to score every "
                         "seed's model on")
    if split not in ("all", "test"):
        raise InputError(f"`split` must be all or test, got {split!r}")
    paths = data_files(data_paths)
    name = name or runs.eval_dir_name(paths, split)
    if name == EVAL_NAME:
        raise InputError(f"the evaluation name {EVAL_NAME!r} is the spread's own; give "
                         "another `name`")
    runs.check_result_name(name, "name")
    out_dir = spread / runs.EVAL_DIR / name
    if out_dir.exists() and not overwrite:
        raise InputError("evaluation folder exists; pass `overwrite=True` to replace it or give "
                         "another `name`", path=out_dir)
    for m in members:
        if not (m / runs.RUN_JSON).is_file():
            raise InputError("the seed's run is missing; re-create the spread with "
                             "`tactile seed-spread`", path=m)
        have = m / runs.EVAL_DIR / name / runs.METRICS_JSON
        if have.parent.exists() and not overwrite and not _same_data(have, paths, split):
            raise InputError("holds another evaluation of that name; pass `overwrite=True` to "
                             "replace it or give another `name`", path=have.parent)
    check_outputs({"out": out_dir}, paths)
    command = command if command is not None else current_command()
    threshold = SHIFT_THRESHOLD_SD if shift_threshold_sd is None else shift_threshold_sd
    rows: list[SeedRow] = []
    for i, (seed, m) in enumerate(zip(record["seeds"], members, strict=True)):
        have = m / runs.EVAL_DIR / name / runs.METRICS_JSON
        timed = latency and i == 0
        if not overwrite and have.is_file() and _same_data(have, paths, split) and (
                not timed or json.loads(have.read_text(encoding="utf-8")).get("latency")):
            row = seed_row(seed, m, runs.read_metrics(have), 0.0, resumed=True)
        else:
            result = evaluate(m, paths, split=split, name=name,  # type: ignore[arg-type]
                              latency=timed, threads=threads, overwrite=True, device=device,
                              shift_threshold_sd=threshold, command=command)
            row = seed_row(seed, m, result.as_dict(), 0.0, resumed=False)
        rows.append(row)
        if on_seed is not None:
            on_seed(row)
    summary = summarise(rows)
    plan = {
        "format": FORMAT, "format_version": 1, "tool_version": __version__,
        "created_utc": utc_now(), "command": command, "spread": str(spread),
        "spread_sha256": sha256_of(spread / RECORD_JSON), "config": record.get("config"),
        "seeds": record["seeds"], "name": name, "split": split,
        "data": [{"path": str(p), "sha256": sha256_of(p)} for p in paths],
        "spread_summary": record.get("summary") or {},
    }
    result = SeedSpread(out_dir=out_dir, plan=plan, rows=rows, summary=summary)
    for text, seeds in shared_warnings(rows).items():
        who = "every seed" if len(seeds) == len(rows) else "seed(s) " + ", ".join(map(str, seeds))
        result.notes.append(f"{who}: {text}")
    plan["against_own"] = own_figures_notes(plan["spread_summary"], summary,
                                            rows[0].n_trials if rows else None)
    if len(rows) < 3:
        result.notes.append(f"{len(rows)} seed(s): too few for an SD to mean much")
    with output_folder(out_dir, overwrite=True) as tmp:
        write_text(tmp / TABLE, "\n".join([result.table(), "", *plan["against_own"]]) + "\n")
        if plot:
            plot_spread(result, tmp / FIGURE)
        write_json(tmp / RECORD, result.as_dict())
    return result


def read_spread_eval(path: Path) -> dict[str, Any]:
    """A ``spread_eval.json`` as a dict; one :class:`InputError` when it cannot be read."""
    redo = "re-create it with `tactile evaluate SPREAD --data FILE --overwrite`"
    try:
        record = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise InputError(f"not a readable seed-spread evaluation ({exc.__class__.__name__}); "
                         f"{redo}", path=path) from None
    if not isinstance(record, dict) or record.get("format") != FORMAT:
        raise InputError(f"not a seed-spread evaluation (format {FORMAT}); {redo}", path=path)
    return record


def spread_evaluations(spread: Path) -> list[dict[str, Any]]:
    """The evaluations of a spread on other recordings (``SPREAD/eval/*/spread_eval.json``),
    each as its record, in name order; unreadable ones are skipped by name in ``notes``."""
    out = []
    for path in sorted((spread / runs.EVAL_DIR).glob(f"*/{RECORD}")):
        try:
            out.append(read_spread_eval(path))
        except InputError:
            out.append({"name": path.parent.name, "unreadable": str(path)})
    return out


def spread_eval_summary(result: SeedSpread) -> str:
    """Lines for people: the table, each figure against the spread's own evaluation, and
    where the outputs are (the notes go to stderr as warnings)."""
    files = [RECORD, TABLE] + ([FIGURE] if (result.out_dir / FIGURE).exists() else [])
    return "\n".join([result.table(), *result.plan.get("against_own", []),
                      f"wrote {result.out_dir}: {', '.join(files)}"])


__all__ = ["FIGURE", "FORMAT", "RECORD", "evaluate_spread", "own_figures_notes",
           "read_spread_eval", "spread_eval_summary", "spread_evaluations"]
