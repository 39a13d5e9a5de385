"""The package's import direction (style.md): cli -> jobs -> identification -> simulation ->
{models, filters, navigation} -> _kernels -> units. models/, filters/ and navigation/ never import
each other. Checked on the source with ``ast`` (module-level and function-level imports alike)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parents[1] / "sins_sim"
BASE = {"units", "earth", "_validate", "errors", "_kernels", "_version"}

#: layer -> the sins_sim layers it may import (besides itself)
ALLOWED = {
    "units": set(),
    "_version": set(),
    "_validate": {"units"},
    "errors": set(),
    "earth": set(),
    "_kernels": {"units", "earth"},
    "models": BASE,
    "filters": BASE,
    "navigation": BASE,
    "io": BASE,
    "plots": {"units", "earth", "models"},  # the paper figures draw eq. 9 itself
    "simulation": BASE | {"models", "filters", "navigation", "io"},
    "identification": BASE | {"simulation", "models", "filters", "navigation", "io", "plots"},
    "jobs": BASE | {"simulation", "models", "filters", "navigation", "io", "identification", "plots"},
}


def _layer(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def _modules():
    for path in sorted(PKG.rglob("*.py")):
        rel = path.relative_to(PKG.parent).with_suffix("")
        name = ".".join(rel.parts)
        if name.endswith(".__init__"):
            name = name[: -len(".__init__")]
        yield name, path


def _imports(path: Path):
    tree = ast.parse(path.read_text())
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("sins_sim"):
            if node.module == "sins_sim":  # from sins_sim import earth -> sins_sim.earth
                for alias in node.names:
                    yield f"sins_sim.{alias.name}", node.lineno
            else:
                yield node.module, node.lineno
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("sins_sim"):
                    yield alias.name, node.lineno


@pytest.mark.parametrize("name, path", list(_modules()), ids=lambda x: str(x) if isinstance(x, str) else "")
def test_imports_point_one_way(name, path):
    layer = _layer(name)
    if layer not in ALLOWED:  # cli, bench, the package root: top of the stack
        return
    bad = []
    for target, line in _imports(path):
        tl = _layer(target)
        if tl and tl != layer and tl not in ALLOWED[layer]:
            bad.append(f"{path.name}:{line} imports {target}")
    assert not bad, f"layer '{layer}' may import only {sorted(ALLOWED[layer])}: " + "; ".join(bad)


def test_import_linter_contracts_are_kept():
    """The layer contract declared in pyproject.toml ([tool.importlinter]), checked by import-linter."""
    import os
    import subprocess
    import sys

    exe = os.path.join(os.path.dirname(sys.executable), "lint-imports")
    root = PKG.parent
    out = subprocess.run([exe, "--config", str(root / "pyproject.toml")], cwd=root, capture_output=True, text=True)
    assert out.returncode == 0, out.stdout[-3000:]
    assert "0 broken" in out.stdout
