"""The documentation's examples fail the build when they fail (issue 23).

Builds a throw-away Sphinx project with the gallery settings of ``docs/conf.py`` (the same
``sphinx_gallery_conf``, pointed at a temporary examples folder) once with a passing and once with a
failing example, with ``-W`` as CI builds. Needs the ``docs`` extra; skipped without it.
"""

import os
import runpy
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

pytest.importorskip("sphinx_gallery")

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"


def _project(tmp_path: Path, example: str) -> Path:
    src = tmp_path / "src"
    (src / "examples").mkdir(parents=True)
    (src / "examples" / "GALLERY_HEADER.rst").write_text("Examples\n========\n")
    (src / "examples" / "plot_example.py").write_text(example)
    (src / "index.rst").write_text("Test\n====\n\n.. toctree::\n\n   gallery/index\n")
    (src / "conf.py").write_text(textwrap.dedent(f"""
        import sys
        sys.path.insert(0, {str(DOCS)!r})
        import runpy
        _conf = runpy.run_path({str(DOCS / "conf.py")!r})
        extensions = ["sphinx_gallery.gen_gallery"]
        sphinx_gallery_conf = dict(_conf["sphinx_gallery_conf"], examples_dirs=["examples"], gallery_dirs=["gallery"])
        suppress_warnings = ["config.cache"]
        exclude_patterns = ["_build", "examples/**"]
        """))
    return src


def _build(src: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-b", "html", str(src),
                           str(src / "_build")], capture_output=True, text=True, timeout=300,
                          env={**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"})


def test_gallery_settings_execute_every_example():
    conf = runpy.run_path(str(DOCS / "conf.py"))["sphinx_gallery_conf"]
    assert conf["abort_on_example_error"] is True
    assert conf["only_warn_on_example_error"] is False
    examples = sorted((DOCS / "examples").rglob("*.py"))
    assert examples, "no examples under docs/examples"
    assert all(p.name.startswith("plot_") for p in examples), "an example without plot_ would not run"


def test_passing_example_builds(tmp_path):
    res = _build(_project(tmp_path, '"""\nPasses\n======\n"""\nprint(1 + 1)\n'))
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]


def test_failing_example_fails_the_build(tmp_path):
    res = _build(_project(tmp_path, '"""\nFails\n=====\n"""\nraise RuntimeError("this example is broken")\n'))
    assert res.returncode != 0
    assert "this example is broken" in res.stdout + res.stderr
