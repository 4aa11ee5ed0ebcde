"""Every public name of :mod:`tactile_cli.spectral` is exported and used in the test module of
the source module that defines it (``_stft.py`` -> ``test_stft.py``), beyond its import."""

from __future__ import annotations

import ast
import inspect
from pathlib import Path

import tactile_cli.spectral as spectral

HERE = Path(__file__).parent


def _exported() -> dict[str, str]:
    """Public name -> the source module it is imported from in ``spectral/__init__.py``."""
    tree = ast.parse(Path(spectral.__file__).read_text())
    return {alias.asname or alias.name: node.module.lstrip("_")
            for node in tree.body if isinstance(node, ast.ImportFrom) and node.level == 1
            for alias in node.names}


def _used_names(path: Path) -> set[str]:
    """Names a test module uses outside its import statements."""
    used = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Name):
            used.add(node.id)
        elif isinstance(node, ast.Attribute):
            used.add(node.attr)
    return used


def test_all_lists_every_public_name():
    public = {name for name, obj in vars(spectral).items()
              if not name.startswith("_") and not inspect.ismodule(obj)}
    assert sorted(spectral.__all__) == sorted(public) == sorted(_exported())


def test_every_public_name_is_used_by_its_modules_tests():
    missing = []
    for name, module in _exported().items():
        path = HERE / f"test_{module}.py"
        if not path.exists() or name not in _used_names(path):
            missing.append(f"{name} ({path.name})")
    assert missing == []
