"""The import rules of ARCHITECTURE.md, read from the source (imports inside functions
included): who may import whom, no cycle between packages, and which package alone may
import h5py, typer, torch, JAX and dask."""

from __future__ import annotations

import ast
import functools
from collections import defaultdict
from pathlib import Path

import pytest

import tactile_cli

ROOT = Path(tactile_cli.__file__).parent

#: Modules at the top of the package that every package may import (they import no
#: package of ours but each other).
FOUNDATIONS = {"errors", "progress", "interrupt", "config_file", "vocabulary", "natural",
               "input_guard", "threads", "text_table", "_version"}
#: Method packages: any stream may enter them.
METHODS = {"learn", "fos", "grade", "spectral"}
#: Sensor chains, by chain: what only one sensor's data can enter. The event-camera chain of
#: paper 000 predates the one-package rule and spans four packages, which share one chain.
CHAINS = {"event camera": {"scene", "spatial", "synth"}, "accelerometer": {"accel"},
          "visuotactile": {"visuotactile"}, "active vibration": {"vibro"},
          "taxel array": {"taxel"}}
CHAIN_UNITS = set().union(*CHAINS.values())
#: ARCHITECTURE.md's table, row by row: a unit -> the units it may import (besides itself).
#: Every unit of the package has a row (test_every_unit_has_a_rule).
RULES: dict[str, set[str]] = {
    **{f: FOUNDATIONS for f in FOUNDATIONS},
    "store": FOUNDATIONS,
    "batch": FOUNDATIONS,
    "ingest": FOUNDATIONS | {"store", "batch"},
    "samples": FOUNDATIONS | {"store"},
    "events": FOUNDATIONS | {"store"},
    "plots": FOUNDATIONS | {"store"},
    **{m: FOUNDATIONS | METHODS | {"store", "events", "batch"} for m in METHODS},
    **{u: FOUNDATIONS | METHODS | {"store", "events", "batch"} | members
       for members in CHAINS.values() for u in members},
    # the package's lazy verb table, the command line and its entry point
    "__init__": None,  # anything but cli/
    "cli": None,  # anything; nothing imports cli/ (test_no_library_module_imports_the_cli)
    "__main__": {"cli"},
}
#: Third-party packages that one package alone may import, and that package.
OWNERS = {"h5py": {"store"}, "isal": {"store"}, "typer": {"cli"}, "torch": {"learn"},
          "onnx": {"learn"}, "onnxruntime": {"learn"}, "onnxscript": {"learn"},
          "skl2onnx": {"learn"},
          "jax": {"fos"}, "optimistix": {"fos"}, "dask": {"batch"}, "distributed": {"batch"}}


def _unit(path: Path) -> str:
    """The package (or top-level module) a source file belongs to."""
    rel = path.relative_to(ROOT)
    return rel.parts[0] if len(rel.parts) > 1 else rel.stem


def _imports(path: Path) -> tuple[set[str], set[str]]:
    """(units of ours, third-party top-level names) that one file imports."""
    rel = path.relative_to(ROOT.parent).with_suffix("")
    module = list(rel.parts)
    package = module[:-1]  # the package a relative import starts from
    ours, theirs = set(), set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        names: list[str] = []
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[:len(package) - (node.level - 1)]
                full = base + (node.module.split(".") if node.module else [])
                if not node.module:
                    names += [".".join(full + [a.name]) for a in node.names]
                names.append(".".join(full))
            elif node.module:
                names.append(node.module)
        elif isinstance(node, ast.Import):
            names += [a.name for a in node.names]
        for name in names:
            parts = name.split(".")
            if parts[0] == "tactile_cli":
                if len(parts) > 1:
                    ours.add(parts[1])
            else:
                theirs.add(parts[0])
    return ours, theirs


@functools.cache
def _graph() -> tuple[dict[str, set[str]], dict[str, set[str]]]:
    units: dict[str, set[str]] = defaultdict(set)
    third: dict[str, set[str]] = defaultdict(set)
    for path in ROOT.rglob("*.py"):
        me = _unit(path)
        ours, theirs = _imports(path)
        units[me] |= {u for u in ours
                      if (ROOT / u).is_dir() or (ROOT / f"{u}.py").is_file()} - {me}
        for name in theirs:
            third[name].add(me)
    return units, third


def test_no_library_module_imports_the_cli():
    units, _ = _graph()
    assert sorted(u for u, deps in units.items() if "cli" in deps and u != "__main__") == []


def violations(units: dict[str, set[str]]) -> list[str]:
    """Every arrow of ``units`` (unit -> units it imports) that the table forbids, as
    ``"a -> b"``; an arrow into ``cli`` from anywhere but ``__main__`` and ``__init__``'s
    absence of it included."""
    found = []
    for unit, deps in sorted(units.items()):
        allowed = RULES.get(unit)
        for dep in sorted(deps - {unit}):
            if dep == "cli" and unit != "__main__":
                found.append(f"{unit} -> {dep}")
            elif allowed is not None and dep not in allowed:
                found.append(f"{unit} -> {dep}")
    return found


def test_every_unit_has_a_rule():
    units, _ = _graph()
    assert sorted(set(units) - set(RULES)) == []


def test_the_import_table_holds():
    units, _ = _graph()
    assert violations(units) == []


def test_the_table_catches_planted_violations():
    units, _ = _graph()
    planted = {k: set(v) for k, v in units.items()}
    planted["vibro"] |= {"taxel"}  # chain -> another chain
    planted["errors"] |= {"store"}  # a foundation -> a package
    planted["store"] |= {"learn"}  # the store -> a method
    planted["ingest"] |= {"learn"}  # ingest -> a method
    planted["events"] |= {"scene"}  # events -> a chain
    planted["samples"] |= {"batch"}
    planted["fos"] |= {"visuotactile"}  # a method -> a chain
    planted["learn"] |= {"cli"}  # the library -> the command line
    assert violations(planted) == ["errors -> store", "events -> scene", "fos -> visuotactile",
                                   "ingest -> learn", "learn -> cli", "samples -> batch",
                                   "store -> learn", "vibro -> taxel"]
    # the event-camera chain's packages may import each other; two chains may not
    assert violations({"synth": {"spatial", "fos"}, "spatial": {"scene"}}) == []
    assert violations({"accel": {"visuotactile"}}) == ["accel -> visuotactile"]


def test_architecture_md_names_every_package_of_the_table():
    text = (ROOT.parent / "ARCHITECTURE.md").read_text(encoding="utf-8")
    for unit in RULES:
        if unit.startswith("_"):
            continue
        assert f"`{unit}" in text or f"{unit}/" in text or f"{unit}.py" in text, unit


def _cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One import cycle of ``graph`` (unit -> units it imports) as a path, or None."""
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(u: str) -> list[str] | None:
        state[u] = 1
        stack.append(u)
        for v in sorted(graph.get(u, ())):
            if state.get(v) == 1:
                return stack[stack.index(v):] + [v]
            if v not in state and (found := visit(v)) is not None:
                return found
        stack.pop()
        state[u] = 2
        return None

    for u in sorted(graph):
        if u not in state and (found := visit(u)) is not None:
            return found
    return None


def test_the_cycle_finder_finds_cycles():
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": set()}) is None


def test_no_cycle_between_packages():
    units, _ = _graph()
    assert _cycle(units) is None


def test_heavy_and_format_libraries_stay_in_their_package():
    _, third = _graph()
    for name, owners in OWNERS.items():
        assert third.get(name, set()) <= owners, (name, sorted(third[name] - owners))


def test_the_rules_see_real_imports():
    """The reader of this test finds the arrows that are known to exist (so an empty
    graph cannot pass the rules above)."""
    units, third = _graph()
    assert {"store", "errors"} <= units["ingest"]
    assert "store" in units["learn"] and "cli" in units["__main__"]
    assert third["h5py"] == {"store"} or "store" in third["h5py"]
    assert "torch" in third and "learn" in third["torch"]
    assert "batch" in units["learn"] and third["distributed"] == {"batch"}


@pytest.mark.slow
def test_package_exposes_each_chain_verb_without_loading_torch_or_jax():
    import subprocess
    import sys

    code = ("import sys, tactile_cli as tc; "
            "heavy = [m for m in ('torch', 'jax', 'optimistix') if m in sys.modules]; "
            "print(heavy); "
            "print(all(callable(getattr(tc, v)) for v in tc._VERBS)); "
            "print(sorted(set(tc._VERBS) - set(dir(tc))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.split("\n")[:3] == ["[]", "True", "[]"]
