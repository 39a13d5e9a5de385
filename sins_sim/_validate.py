"""Input checks shared by every parameter object.

Each check raises one ``ValueError`` whose message names the field and the
rule, so that a bad configuration is reported before any kernel runs.
"""

from __future__ import annotations

import math
from numbers import Real

import numpy as np


def _name(owner: str, field: str) -> str:
    return f"{owner}.{field}" if owner else field


def finite(owner: str, field: str, value) -> float:
    """Return ``value`` as float; reject non-numbers, NaN and infinities."""
    if isinstance(value, bool) or not isinstance(value, (Real, np.floating, np.integer)):
        raise ValueError(f"{_name(owner, field)}: must be a finite number, got {value!r}")
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{_name(owner, field)}: must be a finite number, got {value!r}")
    return value


def positive(owner: str, field: str, value) -> float:
    """A finite number > 0."""
    value = finite(owner, field, value)
    if value <= 0.0:
        raise ValueError(f"{_name(owner, field)}: must be > 0, got {value!r}")
    return value


def non_negative(owner: str, field: str, value) -> float:
    """A finite number >= 0."""
    value = finite(owner, field, value)
    if value < 0.0:
        raise ValueError(f"{_name(owner, field)}: must be >= 0, got {value!r}")
    return value


def integer_ratio(owner: str, field: str, high: float, low: float, what: str) -> int:
    """``high / low`` as an int >= 1; reject a ratio that is not an integer."""
    ratio = high / low
    n = int(round(ratio))
    if n < 1 or abs(ratio - n) > 1e-9 * max(1.0, ratio):
        raise ValueError(
            f"{_name(owner, field)}: {what} must be an integer >= 1, got {ratio!r}"
        )
    return n


def choice(owner: str, field: str, value, allowed) -> str:
    """One of a fixed set of names."""
    if value not in allowed:
        raise ValueError(
            f"{_name(owner, field)}: must be one of {sorted(allowed)}, got {value!r}"
        )
    return value


def finite_array(owner: str, field: str, value, ndim: int = 1) -> np.ndarray:
    """A float64 array of the given rank with no NaN or inf."""
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim != ndim:
        raise ValueError(f"{_name(owner, field)}: must be a {ndim}-D array, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        bad = int(np.flatnonzero(~np.isfinite(arr.ravel()))[0])
        raise ValueError(f"{_name(owner, field)}: must be finite everywhere (NaN/inf at index {bad})")
    return arr


def unknown_key(key: str, allowed, names=None) -> str:
    """The rule for an unknown key: ``unknown key; did you mean 'coning'? (allowed: ...)``.

    The suggestion is the closest allowed key by :func:`difflib.get_close_matches` (ratio >= 0.6,
    the library's default cut-off); ``names`` optionally maps more spellings to an allowed key (a
    key's name without its unit suffix, so ``amplitud_arcmin`` still finds ``amplitude_arcmin``).
    No suggestion when nothing is that close.

    Examples
    --------
    >>> unknown_key("conig", ["coning", "sculling"])
    "unknown key; did you mean 'coning'? (allowed: coning, sculling)"
    >>> unknown_key("xyz", ["coning"])
    'unknown key (allowed: coning)'
    """
    import difflib

    allowed = sorted(allowed)
    spellings = {a: a for a in allowed}
    spellings.update({k: v for k, v in (names or {}).items() if k not in spellings})
    close = difflib.get_close_matches(key, list(spellings), n=1)
    hint = f"; did you mean {spellings[close[0]]!r}?" if close else ""
    return f"unknown key{hint} (allowed: {', '.join(allowed)})"
