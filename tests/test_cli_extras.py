"""The small things users of a command line expect: ``python -m sins_sim``, shell completion, ``--version``."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from sins_sim.cli import build_parser, main
from sins_sim.jobs.completion import _subparsers, completion_script

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


# --- shell completion ---------------------------------------------------------------------------------------------
def test_completion_script_lists_every_subcommand(capsys):
    assert main(["completion", "bash"]) == 0
    script = capsys.readouterr().out
    subcommands = list(_subparsers(build_parser()))
    assert {"run", "sweep", "schema", "completion"} <= set(subcommands)
    for name in subcommands:
        assert f"        {name})" in script  # one case arm per subcommand
    assert script.rstrip().endswith("complete -o filenames -o bashdefault -F _sins_sim sins-sim")


def test_completion_rejects_other_shells(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["completion", "fish"])
    assert exc.value.code == 2
    with pytest.raises(ValueError, match="shell: must be one of"):
        completion_script(build_parser(), "fish")


def _complete(words: list, shell_script: str) -> list:
    """What bash offers for the last word of ``words`` (run the generated function as bash's completer would)."""
    array = " ".join("'" + w + "'" for w in words)
    prog = f"{shell_script}\nCOMP_WORDS=({array}); COMP_CWORD={len(words) - 1}; _sins_sim; printf '%s\\n' \"${{COMPREPLY[@]}}\""
    r = subprocess.run(["bash", "-c", prog], capture_output=True, text=True, timeout=30)
    assert r.returncode == 0, r.stderr
    return [w for w in r.stdout.splitlines() if w]


@pytest.mark.skipif(shutil.which("bash") is None, reason="bash is not installed")
def test_bash_completes_subcommands_flags_and_choices(tmp_path):
    script = completion_script(build_parser(), "bash")
    assert _complete(["sins-sim", "s"], script) == ["simulate-recording", "schema", "separation-study", "sweep"]
    assert _complete(["sins-sim", "run", "--fi"], script) == ["--filter-parameters"]
    assert _complete(["sins-sim", "run", "--filter-parameters", ""], script) == ["true", "nominal"]
    assert _complete(["sins-sim", "schema", "tr"], script) == ["trajectory"]
    assert _complete(["sins-sim", "run", "--seed", ""], script) == []  # a number: no file names offered
    (tmp_path / "mission.yaml").write_text("")
    assert _complete(["sins-sim", "run", str(tmp_path / "mis")], script) == [str(tmp_path / "mission.yaml")]


@pytest.mark.skipif(shutil.which("zsh") is None, reason="zsh is not installed")
def test_zsh_script_loads():
    script = completion_script(build_parser(), "zsh")
    r = subprocess.run(["zsh", "-f", "-c", script + "\n(( $+functions[_sins_sim] ))"], capture_output=True,
                       text=True, timeout=30)
    assert r.returncode == 0, r.stderr


def test_zsh_script_is_the_bash_script_through_bashcompinit():
    bash = completion_script(build_parser(), "bash")
    zsh = completion_script(build_parser(), "zsh")
    assert "bashcompinit" in zsh and zsh.endswith(bash)
