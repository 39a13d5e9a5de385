"""Warnings raised by sins-sim (imports nothing from the package)."""

from __future__ import annotations

import warnings


class HysteresisRegimeWarning(RuntimeWarning):
    """The paper's turning-point rule for eq. 10 left its domain of validity.

    Raised when half-cycles of the deflection (plant) or of ``D`` (correcting
    filter) become much shorter than the dither's: superposed vibration, not
    the dither, then makes the turning points (docs/theory/suspension.md). Consider ``hysteresis="masing"``.
    """


def warn_regime(who: str, count: int, since_s: float, signal: str, stacklevel: int = 3) -> None:
    """Issue one :class:`HysteresisRegimeWarning` for ``who`` (plant or filter)."""
    warnings.warn(
        f"{who}: {count} half-cycle(s) of {signal} shorter than a quarter dither period since "
        f"t = {since_s:.4g} s: vibration, not the dither, sets the turning points and the paper's "
        "hysteresis rule (eq. 10) is outside its domain; consider hysteresis='masing'",
        HysteresisRegimeWarning,
        stacklevel=stacklevel + 1,
    )
