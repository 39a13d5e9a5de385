"""Deprecated alias: the code lives in :mod:`sins_sim.config.schema` (issue 23); import it from there."""

import warnings as _warnings

from sins_sim.config import schema as _moved
from sins_sim.config.schema import *  # noqa: F401,F403
from sins_sim.config.schema import __all__  # noqa: F401

_warnings.warn("sins_sim.jobs.schema moved to sins_sim.config.schema", DeprecationWarning, stacklevel=2)


def __getattr__(name):
    """Names outside ``__all__`` (helpers, private names) forwarded to the new module."""
    return getattr(_moved, name)
