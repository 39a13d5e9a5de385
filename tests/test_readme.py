"""The README stays a front page (issue 23): under 150 lines, the quick start first.

The two quick-start commands are a contract that CI runs (``.ci/run``), so they must be the README's first
code block, exactly; everything else lives in the documentation site (``docs/``).
"""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
QUICK_START = [
    "pip install -e . && sins-sim run scenarios/nav-trajectory-file.yaml --out out/nav-trajectory-file",
    'pip install -e ".[test]" && pytest',
]


def _code_blocks(text: str) -> list[list[str]]:
    return [block.strip("\n").splitlines() for block in re.findall(r"^```[^\n]*\n(.*?)^```", text, re.M | re.S)]


def test_readme_under_150_lines():
    n = len(README.read_text(encoding="utf-8").splitlines())
    assert n < 150, f"README.md has {n} lines; move detail into docs/ (issue 23: at most 150)"


def test_quick_start_is_the_first_code_block():
    blocks = _code_blocks(README.read_text(encoding="utf-8"))
    assert blocks, "README.md has no code block"
    assert blocks[0] == QUICK_START


def test_quick_start_matches_ci():
    """The second quick-start command is the one .ci/run executes."""
    assert QUICK_START[1] in (ROOT / ".ci" / "run").read_text(encoding="utf-8")


def test_code_block_parser_sees_a_wrong_first_block():
    """The check can fail: a README whose first block differs is told apart."""
    assert _code_blocks("```bash\npip install sins-sim\n```\n")[0] != QUICK_START


def test_readme_figure_exists_and_is_small():
    for rel in re.findall(r"!\[[^\]]*\]\(([^)]+)\)", README.read_text(encoding="utf-8")):
        path = ROOT / rel
        assert path.is_file(), rel
        assert path.stat().st_size < 200_000, f"{rel}: {path.stat().st_size} bytes; keep the README figure under 200 kB"
