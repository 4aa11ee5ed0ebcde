"""The learning commands' outputs against their inputs (issue 33): an output that is an
input, contains one or lies inside an input folder, with and without ``--overwrite``;
absurd thread, worker and job counts; configs nested tens of thousands deep. Every case
must be refused in one line with every input byte-identical: the runner hashes ``{IN}``
(here a copy of the corpus's data and config folders) and ``{RUN}`` before and after.

:func:`add_learn_output_cases` is called by :func:`tests.fuzz.corpus.build_corpus`.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

#: A YAML mapping nested this deep: far past the readers' bound (config_file.MAX_NESTING)
#: and past Python's recursion limit
DEEP = 50_000


def _deep_yaml(p: Path) -> None:
    p.write_text("a: " + "[" * DEEP + "]" * DEEP + "\n")


def _deep_mapping(p: Path) -> None:
    p.write_text("".join(f"{' ' * i}k{i}:\n" for i in range(1500)) + " " * 1500 + "v: 1\n")


def add_learn_output_cases(add: Callable, case: Callable, base: Path, refuse: str) -> None:
    """The cases (see the module docstring); ``add`` and ``case`` are build_corpus's."""
    cfg = "{BASE}/cfg/train.yaml"
    h5 = add("learn-io", base / "h5", "h5", "data-folder", "clash", None)
    data = "{IN}/counts.h5"
    train = ["train", cfg, "--data", data, "--no-progress"]
    cases = [
        # an output that is the input, contains it, or (a run's files) replaces it
        ("train", [*train, "--out", data, "--overwrite"]),
        ("train", [*train, "--out", "{IN}", "--overwrite"]),
        ("train", [*train, "--out", "{IN}", "--overwrite", "--cv", "2"]),
        ("train", [*train, "--out", "{IN}/run", "--cv", "2", "--jobs", "4096"]),
        ("evaluate", ["evaluate", "{RUN}", "--data", data, "--no-latency", "--threads",
                      "4096"]),
        ("evaluate", ["evaluate", "{RUN}", "--data", data, "--each", "--workers", "4096"]),
        ("perturb", ["perturb", "{RUN}", "--data", data, "--kinds", "noise", "--out",
                     "{IN}"]),
        ("perturb", ["perturb", "{RUN}", "--data", data, "--kinds", "scale", "--levels",
                     "scale=1e9"]),
        ("compare", ["compare", "{RUN}", "--out", "{RUN}/.."]),
        ("report", ["report", "{RUN}", "--data", data, "--out", "{IN}"]),
        ("export", ["export", "{RUN}", "--out", "{RUN}/model.pt", "--overwrite"]),
        ("export", ["export", "{RUN}", "--out", "{RUN}/run", "--overwrite"]),
        ("detect-delay", ["detect-delay", "{BASE}/chains/run_vibro", "--data",
                          "{BASE}/h5/prepared.h5", "--threads", "4096"]),
    ]
    for command, argv in cases:
        case(h5, command, argv, refuse)

    sweep = add("learn-io", base / "cfg", "cfg", "config-folder", "clash", None)
    for argv in (["--out", "{IN}", "--overwrite"], ["--out", "{IN}/sweep.yaml", "--overwrite"],
                 ["--out", "{OUT}/sw", "--workers", "4096"]):
        case(sweep, "sweep", ["sweep", "{IN}/sweep.yaml", "--no-progress", *argv], refuse)

    for name, apply in (("yaml-deep-lists", _deep_yaml), ("yaml-deep-mapping", _deep_mapping)):
        d = add("learn-io", base / "cfg" / "sweep.yaml", "sweep.yaml", name, "config", apply)
        case(d, "sweep", ["sweep", "{IN}", "--out", "{OUT}/sw", "--workers", "0",
                          "--no-progress"], refuse)
        d = add("learn-io", base / "cfg" / "train.yaml", "train.yaml", name, "config", apply)
        case(d, "train", ["train", "{IN}", "--data", "{BASE}/h5/counts.h5", "--out",
                          "{OUT}/run", "--no-progress"], refuse)
