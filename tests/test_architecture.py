"""The import rules of ARCHITECTURE.md, read from the source (imports inside functions
included): who may import whom, no cycle between packages, and which package alone may
import h5py, typer, torch, JAX and dask."""

from __future__ import annotations

import ast
from collections import defaultdict
from pathlib import Path

import tactile_cli

ROOT = Path(tactile_cli.__file__).parent

#: Modules at the top of the package that every package may import (they import no
#: package of ours but each other).
FOUNDATIONS = {"errors", "progress", "interrupt", "config_file", "vocabulary", "natural",
               "_version"}
#: Method packages: any stream may enter them.
METHODS = {"learn", "fos", "grade", "spectral"}
#: Third-party packages that one package alone may import, and that package.
OWNERS = {"h5py": {"store"}, "typer": {"cli"}, "torch": {"learn"},
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


def test_store_imports_no_domain_package():
    units, _ = _graph()
    assert units["store"] <= FOUNDATIONS, units["store"] - FOUNDATIONS


def test_foundations_import_only_foundations():
    units, _ = _graph()
    for unit in FOUNDATIONS:
        assert units.get(unit, set()) <= FOUNDATIONS, (unit, units[unit])


def test_batch_imports_only_foundations():
    """batch/ (the Dask execution layer) knows nothing of tactile data."""
    units, _ = _graph()
    assert units["batch"] <= FOUNDATIONS, units["batch"] - FOUNDATIONS


def test_methods_import_no_sensor_chain():
    """learn/, fos/, grade/ take any stream: they may use store/, events/ (the one place
    raw events become a count stream), batch/ (runs on Dask) and each other, never a
    chain's package."""
    units, _ = _graph()
    allowed = FOUNDATIONS | METHODS | {"store", "events", "batch"}
    for unit in METHODS:
        assert units[unit] <= allowed, (unit, units[unit] - allowed)


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
