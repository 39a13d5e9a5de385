"""Case families beyond the mutation classes of ``generate.py`` (issue 25): one module per family.

A module here defines ``FAMILY = Family(...)``: the kind it reports under, its share of the generated cases, how
to make one case from a seeded ``random.Random``, the command line it runs through (full tier) and, where a check
without the engine can tell, an in-process validation (fast tier). Modules are found by name, so adding a family
is adding a file.
"""

from __future__ import annotations

import importlib
import pkgutil
import random
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable


@dataclass(frozen=True)
class Made:
    """One case as a family makes it (``generate`` gives it its id)."""

    cls: str
    expect: str  # "valid" or "invalid"
    what: str
    files: dict = field(default_factory=dict)  # file name -> bytes
    main: str = ""
    gap: str | None = None


@dataclass(frozen=True)
class Family:
    """A family of fuzz cases.

    ``command(folder)`` is the argument list after ``sins-sim`` (paths inside ``folder``); ``validate(folder)``
    loads and checks the case's files without running an engine and raises ``ValueError`` naming the field where
    the command would refuse (``None``: the fast tier skips the family and only the full tier runs it).
    """

    kind: str
    weight: float
    classes: tuple
    make: Callable[[random.Random], Made]
    command: Callable[[Path], list]
    validate: Callable[[Path], None] | None = None


def families() -> dict:
    """Every family in this package, by kind (sorted, so generation stays deterministic)."""
    found = {}
    for info in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
        fam = getattr(importlib.import_module(f"{__name__}.{info.name}"), "FAMILY", None)
        if isinstance(fam, Family):
            if fam.kind in found:
                raise ValueError(f"two fuzz families report kind {fam.kind!r}")
            found[fam.kind] = fam
    return found
