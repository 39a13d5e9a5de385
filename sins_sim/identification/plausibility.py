"""Whether a candidate's fit needs parameters a unit cannot plausibly have (issue 24, item 4).

A fit can lower the residual with values no unit has: an effect switched on where it explains nothing, a
parameter pressed to the end of the range the catalogue declares, or nominal parameters bent to a
physical limit. Such a candidate is **implausible**; it is ranked after the plausible ones
(:func:`plausible_first`, used by the verdict's first step and by every greedy round), and its reasons are
in the JSON (``candidates[i].plausibility``, ``verdict.plausibility``) and the report.

The rules (:func:`candidate_plausibility`), each a reason in words:

``no gap there``
    The effect is fitted on an axis without a significant gap, or on an axis where it is switched on (a
    switch parameter, one whose range holds the value 0 at which the effect vanishes, e.g. ``tau_s``,
    ``threshold_rad_s``, ``gain``, ``c_<axis>``, and no phase, at least :data:`SWITCH_SIGMA` of its uncertainty from 0)
    but removes no more of that axis' excess power than the gap's detection tolerance (``tol^2``,
    :mod:`~sins_sim.identification.detection`): the axis shows no gap the effect explains, so the value is
    fitting something else (issue 24: a ``lock_in`` threshold of 4.2e-3 rad/s on an axis that carried only a
    bias drift).
``at the range's end``
    A fitted effect parameter at an end of the range its ``Param`` declares (``sins_sim.models.effects``; the
    same ranges the ``effects:`` schema of the configuration checks, ``sins_sim.config.effects_schema``),
    other than 0: the fit wanted a value beyond what the catalogue calls physical.
``nominal at a limit``
    The candidate's refit of the nominal parameters carries a plausibility flag
    (``report.plausibility_flags``: a physical limit of ``SuspensionParams``, a sign flip, a factor of 3
    off the header) that the baseline's refit does not: the effect only fits with a unit no data sheet
    describes.

.. autosummary::

   candidate_plausibility
   assess_plausibility
   plausible_first
"""

from __future__ import annotations

import math

from sins_sim.models.effects import EFFECTS
from sins_sim.units import ARCSEC

__all__ = ["candidate_plausibility", "assess_plausibility", "plausible_first", "SWITCH_SIGMA", "RANGE_END_REL"]

#: A switch parameter this many standard deviations from 0 counts as switched on (3: a two-sided normal
#: probability of 0.27 % that noise alone puts it there).
SWITCH_SIGMA = 3.0
#: A parameter within this fraction of its declared range's span from one end sits at that end (the fit's
#: bounds are the range itself, so a value the fit pressed there lands on it to the solver's precision).
RANGE_END_REL = 1e-6


def _param_ranges(effect: str, axis: str, axes) -> dict:
    cls = EFFECTS.get(effect)
    if cls is None:
        return {}
    return {p.name: (p.lo, p.hi) for p in cls.fit_space(axis, axes)}


def _is_switch(name: str, ranges: dict) -> bool:
    """Whether a fitted parameter switches its effect off at 0: its declared range holds 0, and it is no phase
    (a lock-in's backscatter phase holds 0 too, but at any phase the effect acts)."""
    return name in ranges and ranges[name][0] <= 0.0 <= ranges[name][1] and not name.startswith("phase")


def candidate_plausibility(c: dict, ref_fits: dict, floors: dict, tol: dict, sig_axes, rec_axes,
                           base_flags=None, nominal_flags=None) -> dict:
    """The plausibility of one candidate: ``{"plausible": bool, "reasons": [str, ...]}``.

    Parameters
    ----------
    c : dict
        The candidate (``explain``): ``effect``, ``fits``, ``params``, ``uncertainty``.
    ref_fits : dict
        The model the candidate extends (axis -> ``AxisFit``).
    floors, tol : dict
        Per axis the noise floor (``noise_floor``) and the gap's tolerance (rad).
    sig_axes : list of str
        The axes with a significant gap.
    rec_axes : sequence of str
        All axes of the recording.
    base_flags : list of dict or None
        ``report.plausibility_flags`` of the reference refit (flags it already has are no reason here).
    nominal_flags : callable or None
        ``fits -> flags`` (``report.plausibility_flags`` bound to the recording); ``None``: not checked.
    """
    from sins_sim.identification.verdict import excess_power  # verdict imports this module

    reasons = []
    for a, values in c["params"].items():
        if a not in sig_axes:
            reasons.append(f"{c['effect']} is fitted on axis {a}, which shows no gap")
            continue
        ranges = _param_ranges(c["effect"], a, rec_axes)
        sd = c.get("uncertainty", {}).get(a, {})
        gain = excess_power(ref_fits[a], floors[a]) - excess_power(c["fits"][a], floors[a])
        on = [k for k, val in values.items() if _is_switch(k, ranges)
              and sd.get(k) and math.isfinite(sd[k]) and abs(val) > SWITCH_SIGMA * sd[k]]
        if on and gain <= tol[a] ** 2:
            k = on[0]
            reasons.append(f"{c['effect']} needs {k} = {values[k]:.4g} (+- {sd[k]:.2g}) on axis {a}, where it removes "
                           f"{math.sqrt(max(gain, 0.0)) / ARCSEC:.3g} arcsec RMS of the excess, within the gap's "
                           f"tolerance {tol[a] / ARCSEC:.3g}: the axis shows no gap it explains")
        for k, val in values.items():
            if k not in ranges:
                continue
            lo, hi = ranges[k]
            span = hi - lo
            for end in (lo, hi):
                if end != 0.0 and abs(val - end) <= RANGE_END_REL * span:
                    reasons.append(f"{c['effect']} needs {k} = {val:.4g} on axis {a}, at the end of the range "
                                   f"[{lo:g}, {hi:g}] the catalogue declares physical")
    if nominal_flags is not None:
        seen = {(f["axis"], f["parameter"]) for f in (base_flags or [])}
        fits = {a: c["fits"][a] for a in c["params"] if a in c["fits"]}
        for f in nominal_flags(fits):
            if (f["axis"], f["parameter"]) not in seen:
                reasons.append(f"with {c['effect']}, the refit's {f['message']}")
    return {"plausible": not reasons, "reasons": reasons}


def assess_plausibility(candidates: list, ref_fits: dict, floors: dict, tol: dict, sig_axes, rec_axes,
                        nominal_flags=None) -> None:
    """Add ``plausibility`` to every candidate (in place); see :func:`candidate_plausibility`."""
    base_flags = nominal_flags(ref_fits) if nominal_flags is not None else None
    for c in candidates:
        c["plausibility"] = candidate_plausibility(c, ref_fits, floors, tol, sig_axes, rec_axes, base_flags,
                                                   nominal_flags)


def plausible_first(candidates: list) -> list:
    """``candidates`` (in their order) with the implausible ones after the plausible ones."""
    ok = [c for c in candidates if c.get("plausibility", {}).get("plausible", True)]
    return ok + [c for c in candidates if not c.get("plausibility", {}).get("plausible", True)]
