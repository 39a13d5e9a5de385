"""The verdict of the diagnosis (step 5): none, the effect that closes the gap, or unknown.

``none`` when the refit nominal model sits at the floor (no axis with a
significant gap); the best-scoring effect when it closes the gap and removes
at least ``min_gap_reduction`` of the excess power, with the effects that do
as well within :data:`ALTERNATIVE_MARGIN` named as ``alternatives``; else
``unknown`` (the localisation is then the answer). See
:mod:`sins_sim.identification.diagnose`.

.. autosummary::

   give_verdict
"""

from __future__ import annotations

import math

import numpy as np

from sins_sim.identification.refit import DiagnoseSettings
from sins_sim.units import ARCSEC

__all__ = ["ALTERNATIVE_MARGIN", "give_verdict"]

#: Candidates scoring within this fraction of the best one are named as alternatives of the verdict.
ALTERNATIVE_MARGIN = 0.05


def give_verdict(fits: dict, sig_axes: list, candidates: list, settings: DiagnoseSettings) -> dict:
    """The verdict of a diagnosis from its baseline refit and its ranked candidates.

    Parameters
    ----------
    fits : dict
        The baseline refit per axis (``AxisFit``).
    sig_axes : list of str
        The axes with a significant gap (none: the verdict is ``none``).
    candidates : list of dict
        The candidates of :func:`sins_sim.identification.explain.explain`, best first.
    settings : DiagnoseSettings
        ``min_gap_reduction``.

    Returns
    -------
    dict
        ``effect`` (``none``, an effect's name or ``unknown``), ``gap_reduction``,
        ``alternatives`` and ``baseline_score`` (held-out RMS of the baseline, arcsec;
        None without a significant gap).
    """
    significant = bool(sig_axes)
    base_held = math.sqrt(np.mean([fits[a].heldout_rms ** 2 for a in sig_axes])) if sig_axes else math.nan
    if not significant:
        verdict = {"effect": "none", "gap_reduction": 0.0, "alternatives": []}
    else:
        best = candidates[0] if candidates else None
        if best is not None and best["closes_gap"] and best["gap_reduction"] >= settings.min_gap_reduction and \
                best["score"] < base_held / ARCSEC:
            # effects the data cannot tell from the best one: they close the gap as well and score
            # within ALTERNATIVE_MARGIN of it
            alts = [c["effect"] for c in candidates[1:] if c["closes_gap"]
                    and c["score"] <= best["score"] * (1.0 + ALTERNATIVE_MARGIN)]
            verdict = {"effect": best["effect"], "gap_reduction": best["gap_reduction"], "alternatives": alts}
        else:
            verdict = {"effect": "unknown", "gap_reduction": best["gap_reduction"] if best else 0.0,
                       "alternatives": []}
    verdict["baseline_score"] = base_held / ARCSEC if significant else None
    return verdict
