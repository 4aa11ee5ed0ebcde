"""Every command on a seeded corpus of damaged inputs (issue 20): counts per outcome class.

    .venv/bin/python benchmarks/fuzz_corpus.py [--seed 0] [--n-random 4] [--json] [--markdown]
        [--findings FILE] [--work DIR] [--only CMD,...] [--max-cases N]

The corpus (tests/fuzz/corpus.py) copies valid inputs of every kind and damages each copy
in one way; each command that takes such an input runs on it in a forked child with a time
limit (tests/fuzz/runner.py), and the run is classed: ok-refused, ok-accepted, traceback,
multi-line, leftover, input-changed, accepted-corrupt, bad-exit or hang. Prints the counts
per class and per command (``--markdown``: as tables for benchmarks/RESULTS.md; ``--json``:
every run). ``--findings`` writes one line per failing run: command, mutation, outcome,
detail (a traceback's last line). Nothing is written anywhere else but the work folder.
"""

from __future__ import annotations

import argparse
import collections
import json
import random
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tests.fuzz import corpus as fuzz_corpus  # noqa: E402
from tests.fuzz import runner  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--n-random", type=int, default=4,
                    help="random byte flips per compressed dataset (half) and per file")
    ap.add_argument("--work", type=Path, default=None, help="work folder (default: a temp one)")
    ap.add_argument("--only", default="", help="comma-separated commands to run")
    ap.add_argument("--max-cases", type=int, default=0, help="stop after this many runs")
    ap.add_argument("--timeout", type=int, default=120, help="seconds per run")
    ap.add_argument("--max-seconds", type=float, default=0,
                    help="stop starting runs after this long (the runs go in a seeded random "
                         "order, so a partial result is a random sample of the corpus)")
    ap.add_argument("--json", action="store_true", help="print every run as JSON")
    ap.add_argument("--markdown", action="store_true", help="print the counts as tables")
    ap.add_argument("--findings", type=Path, default=None,
                    help="write one line per failing run to this file")
    args = ap.parse_args(argv)

    work = args.work or Path(tempfile.mkdtemp(prefix="tactile-fuzz-"))
    work.mkdir(parents=True, exist_ok=True)
    runner.preload()
    t0 = time.perf_counter()
    corpus = fuzz_corpus.build_corpus(work, seed=args.seed, n_random=args.n_random)
    cases = corpus.cases
    if args.only:
        keep = set(args.only.split(","))
        cases = [c for c in cases if c.command in keep]
    order = random.Random(args.seed).sample(range(len(cases)), len(cases))
    cases = [cases[i] for i in order]
    if args.max_cases:
        cases = cases[: args.max_cases]
    scratch = work / "scratch"
    scratch.mkdir(exist_ok=True)
    results = []
    for i, case in enumerate(cases, 1):
        if args.max_seconds and time.perf_counter() - t0 > args.max_seconds:
            break
        results.append(runner.run_case(corpus, case, scratch, timeout_s=args.timeout))
        if i % 50 == 0:
            print(f"[{i}/{len(cases)}] {time.perf_counter() - t0:.0f} s", file=sys.stderr,
                  flush=True)
    seconds = time.perf_counter() - t0

    by_class = collections.Counter(r.outcome for r in results)
    by_command: dict[str, collections.Counter] = collections.defaultdict(collections.Counter)
    for r in results:
        by_command[r.command][r.outcome] += 1
    damaged = {r.damaged for r in results}
    summary = {"seed": args.seed, "n_random": args.n_random, "damaged_inputs": len(damaged),
               "corpus_inputs": len(corpus.damaged), "corpus_runs": len(corpus.cases),
               "runs": len(results), "seconds": round(seconds, 1),
               "by_class": dict(by_class),
               "by_command": {k: dict(v) for k, v in sorted(by_command.items())}}
    if args.findings:
        lines = [f"{r.command}\t{r.mutation}\t{r.damaged}\t{r.outcome}\t"
                 f"{r.detail or r.first_stderr}" for r in results if r.outcome not in runner.OK]
        args.findings.write_text("\n".join(lines) + ("\n" if lines else ""))
    if args.json:
        print(json.dumps({**summary, "runs_detail": [r.as_dict() for r in results]}, indent=1))
    elif args.markdown:
        print(markdown(summary))
    else:
        print(f"{len(results)} runs on {len(damaged)} damaged inputs, {seconds:.0f} s")
        for cls in runner.CLASSES:
            print(f"  {cls:17s} {by_class.get(cls, 0)}")
    return 0


def markdown(summary: dict) -> str:
    classes = [c for c in runner.CLASSES if any(c in v for v in summary["by_command"].values())]
    out = [f"{summary['runs']} runs of {summary['corpus_runs']} on {summary['damaged_inputs']} "
           f"of {summary['corpus_inputs']} damaged inputs "
           f"(seed {summary['seed']}, n-random {summary['n_random']}), "
           f"{summary['seconds']:.0f} s", "",
           "| outcome | runs |", "| --- | ---: |"]
    out += [f"| {c} | {summary['by_class'].get(c, 0)} |" for c in runner.CLASSES]
    out += ["", "| command | " + " | ".join(classes) + " |",
            "| --- |" + " ---: |" * len(classes)]
    for cmd, counts in summary["by_command"].items():
        out.append(f"| {cmd} | " + " | ".join(str(counts.get(c, 0)) for c in classes) + " |")
    return "\n".join(out)


if __name__ == "__main__":
    raise SystemExit(main())
