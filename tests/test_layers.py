"""The package's import direction (style.md): cli -> jobs -> results -> config -> identification -> plan -> simulation
-> {models, filters, navigation} -> _kernels -> units. models/, filters/ and navigation/ never import
each other; config/ and results/ never import jobs/, bench/ or cli, and inside config/ a file's path reads top to bottom
(reference -> {scenario, sweep, experiment, log} -> imu -> {filter_params, effects_schema, block_schema} -> yaml_io
-> schema -> errors), and a scenario's configuration enters the plan (sins_sim.plan) through one entry point.
Checked on the source with ``ast`` (module-level and function-level imports alike)."""

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
    # the paper figures draw eq. 9 itself; the aided-run figures read the filter's state layout (navigation.ekf)
    "plots": {"units", "earth", "models", "navigation"},
    "simulation": BASE | {"models", "filters", "navigation", "io"},
    # the resolve stage: builds what the engine runs from configuration's checked keys (the engine never imports it)
    "plan": BASE | {"simulation", "models", "filters", "navigation", "io"},
    "identification": BASE | {"plan", "simulation", "models", "filters", "navigation", "io", "plots"},
    # config reaches the physics through the plan (scenarios, IMU files and experiment files alike)
    "config": BASE | {"plan", "simulation", "models", "filters", "navigation", "io"},
    # the result objects: below the commands, above configuration; figures through plots/ and the diagnosis'
    # own figures (lazily); no engine, no command
    "results": BASE | {"config", "identification", "plots"},
    "jobs": BASE | {"results", "config", "plan", "simulation", "models", "filters", "navigation", "io", "identification",
                    "plots"},
}

#: inside config/: module -> its rank, top (0) to bottom; a module imports only modules of a higher rank
CONFIG_ORDER = {"reference": 0, "scenario": 1, "sweep": 1, "experiment": 1, "log": 1, "imu": 2, "filter_params": 3,
                "effects_schema": 3, "block_schema": 3, "vibration_spec": 3, "yaml_io": 4, "schema": 5, "errors": 6}
#: jobs/ modules kept as deprecated aliases of the config/ modules (for code outside the package) -> their home
MOVED_TO_CONFIG = {m: f"sins_sim.config.{m}" for m in ("schema", "yaml_io", "scenario", "imu", "filter_params",
                                                       "effects_schema", "reference")}
MOVED_TO_CONFIG["sweep.schema"] = "sins_sim.config.sweep"
MOVED_TO_CONFIG["advisories"] = "sins_sim.plan.advisories"  # they need the physics: the plan's (issue 38)
#: config/ module -> the names it may import from sins_sim.plan: one entry point per file format
PLAN_ENTRIES = {"scenario": {"resolve_plan", "PlanError"}, "imu": {"resolve_imu", "PlanError"},
                "experiment": {"resolve_experiment", "PlanError"}}


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


def test_config_reads_top_to_bottom():
    """Every config/ module is ranked, and imports only config/ modules ranked below it (no sibling, no climb)."""
    files = sorted((PKG / "config").glob("*.py"))
    assert {p.stem for p in files} - {"__init__"} == set(CONFIG_ORDER)
    bad = []
    for path in files:
        if path.stem == "__init__":
            continue
        for target, line in _imports(path):
            parts = target.split(".")
            if parts[:2] == ["sins_sim", "config"] and len(parts) > 2 and parts[2] != path.stem:
                if CONFIG_ORDER[parts[2]] <= CONFIG_ORDER[path.stem]:
                    bad.append(f"config/{path.name}:{line} imports {target}")
    assert not bad, "; ".join(bad)


@pytest.mark.parametrize("name, path", list(_modules()), ids=lambda x: str(x) if isinstance(x, str) else "")
def test_the_package_imports_configuration_from_config(name, path):
    """The jobs/ aliases of the moved modules are for code outside the package: nothing in sins_sim imports them
    (the aliases import the config/ modules), so the layering is the code's, not the aliases'."""
    old = {f"sins_sim.jobs.{m}": new for m, new in MOVED_TO_CONFIG.items()}
    bad = [f"{path.name}:{line} imports {t} (now {old[t]})" for t, line in _imports(path) if t in old]
    assert not bad, "; ".join(bad)


def test_the_old_paths_still_work_with_a_deprecation_warning():
    """``sins_sim.jobs.scenario`` & co. are the config/ modules themselves (one ConfigError class, so ``except
    ConfigError`` catches either spelling; patching through the old path patches the real module), and importing
    an old path warns once, naming the new one."""
    import importlib
    import sys
    import warnings

    for m, new in MOVED_TO_CONFIG.items():
        sys.modules.pop(f"sins_sim.jobs.{m}", None)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            old = importlib.import_module(f"sins_sim.jobs.{m}")
        assert old is importlib.import_module(new), m
        assert [str(w.message) for w in caught if w.category is DeprecationWarning] == \
            [f"sins_sim.jobs.{m} moved to {new}"]
    from sins_sim.config import errors, scenario
    from sins_sim.jobs.schema import ConfigError

    assert ConfigError is errors.ConfigError
    assert not hasattr(scenario, "run_scenario")  # the jobs <-> config cycle is gone: run_scenario lives in jobs.run


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


def test_configuration_enters_the_plan_through_one_entry_point():
    """config/ checks keys, units and ranges; what needs the physics is the plan's (sins_sim.plan), which a scenario
    enters through ``resolve_plan``, an IMU file (``load_imu``) through ``resolve_imu`` and an experiment file
    (``experiment_from_dict``) through ``resolve_experiment``, nothing else: no config module calls the engine's helpers
    (``simulation``, ``_kernels``) on a file's path."""
    bad = []
    for path in sorted((PKG / "config").glob("*.py")):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("sins_sim.plan"):
                names = {a.name for a in node.names}
                if not names <= PLAN_ENTRIES.get(path.stem, set()):
                    bad.append(f"config/{path.name}:{node.lineno} imports {sorted(names)} from {node.module}")
            if (path.stem in PLAN_ENTRIES and isinstance(node, ast.ImportFrom) and node.module
                    and node.module.startswith(("sins_sim.simulation", "sins_sim._kernels"))):
                bad.append(f"config/{path.name}:{node.lineno} imports {node.module} (the plan's business)")
    assert not bad, "; ".join(bad)


def test_no_test_imports_the_tests_directory_as_a_package():
    """CI runs ``pytest`` from a clean clone, where ``tests`` has no ``__init__.py`` and is not on ``sys.path``:
    a test that shares another's helpers imports the module by its bare name (pytest puts ``tests/`` on the path),
    never ``tests.test_x`` (which imports only when the working directory happens to be on ``sys.path``, as under
    ``python -m pytest``: the twelfth landing failed on exactly that)."""
    offenders = []
    for path in sorted((PKG.parent / "tests").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            names = ([node.module or ""] if isinstance(node, ast.ImportFrom)
                     else [a.name for a in node.names] if isinstance(node, ast.Import) else [])
            offenders += [f"{path.name}:{node.lineno} {n}" for n in names if n == "tests" or n.startswith("tests.")]
    assert not offenders, offenders
