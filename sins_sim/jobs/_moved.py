"""The deprecated jobs/ paths of the configuration modules, which moved to :mod:`sins_sim.config` (issue 23)."""

from __future__ import annotations

import importlib
import sys
import warnings


def alias(old: str, new: str | None = None) -> None:
    """Make the module named ``old`` (``sins_sim.jobs.imu``) the very module of its new home
    (``sins_sim.config.imu``, or ``new``), with a :class:`DeprecationWarning` naming that home.

    The same module object under both names, not a copy of its names: ``except ConfigError`` catches
    either spelling, and a test that patches an attribute through the old path patches the real one.
    """
    new = new or old.replace("sins_sim.jobs.", "sins_sim.config.", 1)
    warnings.warn(f"{old} moved to {new}", DeprecationWarning, stacklevel=3)
    sys.modules[old] = importlib.import_module(new)
