"""The small things users of a command line expect: ``python -m sins_sim``, shell completion, ``--version``."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path


ROOT = Path(__file__).resolve().parents[1]
ENV = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}


# --- python -m sins_sim ---------------------------------------------------------------------------------------
def test_python_dash_m_runs_the_cli():
    """``python -m sins_sim`` is the ``sins-sim`` command: same help, and bad input gives the same status 2."""
    r = subprocess.run([sys.executable, "-m", "sins_sim", "--help"], capture_output=True, text=True, env=ENV,
                       timeout=60)
    assert r.returncode == 0, r.stderr
    assert "usage: sins-sim" in r.stdout and "schema" in r.stdout
    r = subprocess.run([sys.executable, "-m", "sins_sim", "schema", "nonsense"], capture_output=True, text=True,
                       env=ENV, timeout=60)
    assert r.returncode == 2 and "invalid choice: 'nonsense'" in r.stderr
