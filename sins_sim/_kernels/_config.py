"""Numba options, set in one place for every kernel.

``cache=True`` keeps compiled machine code on disk (``__pycache__`` beside
the module, or ``NUMBA_CACHE_DIR``) so a second process does not recompile.
``error_model="numpy"`` makes a division by zero give inf/nan like numpy
instead of raising inside the kernel; inputs are validated before any
kernel runs, so that never reaches a user. ``fastmath`` stays off: the
streaming-equals-whole-array invariants are bit-exact only without it.
"""

from __future__ import annotations

import numba

JIT_OPTIONS = {"cache": True, "nogil": True, "error_model": "numpy", "fastmath": False}


def jit(func=None, **overrides):
    """``numba.njit`` with the package-wide options (``overrides`` win)."""
    options = {**JIT_OPTIONS, **overrides}
    if func is None:
        return lambda f: numba.njit(**options)(f)
    return numba.njit(**options)(func)
