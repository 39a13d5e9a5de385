"""The two constraints files (issue 40) agree with pyproject.toml.

``constraints/minimum.txt`` pins the oldest versions pyproject allows (CI runs the suite in it on some landings);
``constraints/ci.txt`` pins the exact versions CI's newest environment resolves to (the README's Install section
tells a user how to reproduce CI with it). Each pin must satisfy pyproject's range, every direct dependency must be
pinned, and a minimum pin must sit on the lower bound's own release (so raising a bound in pyproject without
raising the minimum file fails here).
"""

import re
from pathlib import Path

import pytest
from packaging.requirements import Requirement
from packaging.utils import canonicalize_name
from packaging.version import Version

try:
    import tomllib
except ImportError:  # Python 3.10: tomli is the same parser, when installed
    tomllib = pytest.importorskip("tomli", reason="Python 3.10 without tomli cannot read pyproject.toml")

ROOT = Path(__file__).resolve().parents[1]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]

# which of pyproject's extras each file is for (minimum.txt: `pip install -c ... -e ".[test]"`; ci.txt: test and docs)
FILES = {"minimum.txt": ("test",), "ci.txt": ("test", "docs")}


def _direct(extras: tuple[str, ...]) -> dict[str, Requirement]:
    reqs = [Requirement(r) for r in PYPROJECT["dependencies"]]
    for extra in extras:
        reqs += [Requirement(r) for r in PYPROJECT["optional-dependencies"][extra]]
    return {canonicalize_name(r.name): r for r in reqs}


def _pins(text: str, where: str) -> dict[str, Version]:
    """``name==version`` per line, comments and blank lines skipped; anything else is an error naming the line."""
    pins = {}
    for n, raw in enumerate(text.splitlines(), 1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        req = Requirement(line)
        specs = list(req.specifier)
        if len(specs) != 1 or specs[0].operator != "==":
            raise ValueError(f"{where}:{n}: {raw!r} is not an exact pin name==version")
        name = canonicalize_name(req.name)
        if name in pins:
            raise ValueError(f"{where}:{n}: {req.name} pinned twice")
        pins[name] = Version(specs[0].version)
    return pins


def _lower_bound(req: Requirement) -> Version | None:
    bounds = [Version(s.version) for s in req.specifier if s.operator in (">=", "==", "~=")]
    return max(bounds) if bounds else None


@pytest.mark.parametrize("fname", sorted(FILES))
def test_every_pin_is_in_pyprojects_range_and_every_direct_dependency_pinned(fname):
    direct = _direct(FILES[fname])
    pins = _pins((ROOT / "constraints" / fname).read_text(encoding="utf-8"), fname)
    assert "sins-sim" not in pins, f"{fname} pins the package itself"
    missing = sorted(set(direct) - set(pins))
    assert not missing, f"{fname} does not pin the direct dependencies {missing}"
    outside = [f"{name}=={pins[name]} (pyproject: {req.specifier})" for name, req in sorted(direct.items())
               if not req.specifier.contains(pins[name], prereleases=True)]
    assert not outside, f"{fname}: pins outside pyproject's range: {outside}"


def test_minimum_pins_sit_on_the_lower_bounds_release():
    """``numpy>=1.24`` is pinned 1.24.x: the release of the bound, its newest patch allowed (patches fix, not add)."""
    off = []
    pins = _pins((ROOT / "constraints" / "minimum.txt").read_text(encoding="utf-8"), "minimum.txt")
    for name, req in sorted(_direct(FILES["minimum.txt"]).items()):
        bound = _lower_bound(req)
        assert bound is not None, f"pyproject gives {req.name} no lower bound; the minimum file cannot be checked"
        k = len(bound.release)
        if pins[name].release[:k] != bound.release:
            off.append(f"{name}=={pins[name]} (pyproject: >={bound})")
    assert not off, f"minimum.txt is not at pyproject's lower bounds: {off}"


def test_ci_pins_are_newer_than_or_equal_to_the_minimum():
    mins = _pins((ROOT / "constraints" / "minimum.txt").read_text(encoding="utf-8"), "minimum.txt")
    ci = _pins((ROOT / "constraints" / "ci.txt").read_text(encoding="utf-8"), "ci.txt")
    older = [f"{n}: ci {ci[n]} < minimum {mins[n]}" for n in sorted(set(mins) & set(ci)) if ci[n] < mins[n]]
    assert not older, older


def test_the_checks_can_fail():
    """A pin outside its range, a loose specifier and a missing dependency are each told apart."""
    numpy = Requirement("numpy>=1.24")
    assert not numpy.specifier.contains(_pins("numpy==1.23.5\n", "x")["numpy"])
    with pytest.raises(ValueError, match=r"x:2: 'scipy>=1.11' is not an exact pin"):
        _pins("# c\nscipy>=1.11\n", "x")
    with pytest.raises(ValueError, match="pinned twice"):
        _pins("numpy==1.24.4\nNumPy==1.25.0\n", "x")
    assert "numpy" in set(_direct(())) - set(_pins("scipy==1.11.4\n", "x"))
    assert _lower_bound(Requirement("pyarrow>=14")) == Version("14")


def _readme_constraint_commands() -> dict[str, tuple[str, ...]]:
    """``pip install -c constraints/F -e ".[extras]"`` lines of the README's code blocks: file -> extras."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    blocks = re.findall(r"^```[^\n]*\n(.*?)^```", readme, re.M | re.S)
    found = {}
    for line in "\n".join(blocks).splitlines():
        m = re.match(r'pip install -c constraints/(\S+) -e "\.\[([\w,]+)\]" && pytest(\s|$)', line.strip())
        if m:
            found[m.group(1)] = tuple(m.group(2).split(","))
    return found


def test_readme_tells_how_to_reproduce_ci():
    """Both of CI's environments, as commands in a README code block, each with the extras its file pins for
    (``FILES``): a renamed file or a changed extra fails here."""
    assert _readme_constraint_commands() == FILES
    assert all((ROOT / "constraints" / f).is_file() for f in FILES)


def test_ci_runs_the_readme_command_in_either_environment():
    """``.ci/run`` pins the minimum through PIP_CONSTRAINT, so the README's one test command serves both."""
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    assert ci.count('pip install -e ".[test]" && pytest') == 1
    assert 'PIP_CONSTRAINT="$PWD/constraints/minimum.txt"' in ci and "unset PIP_CONSTRAINT" in ci
