"""Candidate effects that could explain the gap (step 4 of the diagnosis).

Every catalogue effect (``sins_sim.models.effects``) that the experiment can
show is fitted together with the nominal parameters on each axis with a
significant gap (:func:`sins_sim.identification.refit.fit_axis`), from the
best of a few starts of its parameters (:func:`_effect_starts`; for
``block_mode`` including the residual's peaks). ``gap_reduction`` is the
fraction of the excess residual power over the floor it removes; the
``score`` is the RMS residual on held-out data, so an extra parameter that
only fits noise gains nothing. See :mod:`sins_sim.identification.diagnose`.

.. autosummary::

   explain
"""

from __future__ import annotations

import math
import time

import numpy as np

from sins_sim.identification.refit import DiagnoseSettings, EffectSet, effects_of
from sins_sim.identification.verdict import closes, excess_power
from sins_sim.io.recording import NOMINAL_KEYS, Recording
from sins_sim.models.effects import EFFECTS
from sins_sim.units import ARCSEC

__all__ = ["explain"]


def _effect_starts(cls, axis: str, loc: dict, fs_hz: float) -> list:
    name = cls.name
    if name == "piezo_lag":
        return [{"tau_s": x} for x in (3e-5, 1e-4, 3e-4, 1e-3)]
    if name == "viscous_damping":
        return [{"zeta": x} for x in (1e-4, 5e-4, 2e-3)]
    if name == "resonance_drift":
        return [{"rate_hz_per_s": x} for x in (-0.3, 0.0, 0.3)]
    if name == "readout_delay":
        return [{"delay_s": x} for x in (3e-6, 2e-5, 1e-4, 4e-4)]
    if name == "scale_factor":
        return [{"error": 0.0}]
    if name == "block_mode":
        freqs = [f for f in loc.get("peaks_hz", []) if f > 5.0]
        freqs += [60.0, 120.0, 250.0, 500.0, 1000.0, 2000.0]
        freqs = [f for f in freqs if f < 0.45 * fs_hz * 4]
        return [{"frequency_hz": f, "zeta": 0.08, "gain": g} for f in freqs for g in (-0.3, 0.3)]
    if name == "lock_in":
        return [{"threshold_rad_s": w, "phase_rad": p} for w in (1e-3, 4e-3) for p in (0.0, 1.6, 3.1, 4.7)]
    if name == "axis_coupling":
        return None
    return None


def _prefixed(effect, axis: str) -> dict:
    """A fitted effect's (or effect set's) values named ``"<effect>.<param>"``."""
    return {f"{e.name}.{k}": val for e in effects_of(effect) for k, val in e.values(axis).items()}


def _own(values: dict, name: str, in_set: bool) -> dict:
    """The values of effect ``name`` alone (an effect set names its members' values ``"<effect>.<param>"``)."""
    if not in_set:
        return dict(values)
    pre = name + "."
    return {k[len(pre):]: val for k, val in values.items() if k.startswith(pre)}


def explain(rec: Recording, settings: DiagnoseSettings, fits: dict, floors: dict, excess: dict, tol: dict,
            sig_axes: list, locs: dict, fit_effect, timing: dict, progress=None, base: dict | None = None,
            names=None, settled=(), reuse: dict | None = None) -> tuple:
    """Fit every catalogue effect the experiment can show on the axes with a significant gap, best first.

    Parameters
    ----------
    rec : Recording
    settings : DiagnoseSettings
        ``effects`` (the catalogue effects to try) and ``close_fraction``.
    fits : dict
        The baseline refit per axis (``AxisFit``).
    floors, excess, tol : dict
        Per axis: the noise floor (``noise_floor``), the baseline's excess power over it (rad^2)
        and the tolerance of the gap's significance (rad).
    sig_axes : list of str
        The axes with a significant gap.
    locs : dict
        The localisation per axis (its peaks start ``block_mode``).
    fit_effect : callable(cls, starts) -> dict
        The fits with the effect class ``cls`` on ``sig_axes`` (axis -> ``AxisFit``), started
        from the baseline and on each axis ``a`` from the effect starts ``starts[a]``.
    timing : dict
        The seconds each candidate took are added under its name.
    progress : callable(str) or None
    base : dict or None
        Axis -> the effect classes already selected on it (greedy forward selection, per axis): each
        candidate is fitted together with them there (an
        :class:`~sins_sim.identification.refit.EffectSet`), started from their values in ``fits``;
        ``fits`` is then the selected model, and the gap reduction is relative to it.
    names : sequence of str or None
        The effects to try (default ``settings.effects`` or the whole catalogue).
    settled : collection of str
        Axes already at the floor: no candidate is fitted there (their fits stay).
    reuse : dict or None
        Effect name -> the first round's fits (axis -> ``AxisFit``): on an axis with nothing selected
        the candidate's model is the first round's, so its fit is taken instead of repeated.

    Returns
    -------
    candidates : list of dict
        Ranked by score (held-out RMS, arcsec), best first; ``axes`` are those the effect was
        fitted on (``sig_axes`` less ``settled``).
    skipped : dict
        Effect name -> why it was not tried.
    """
    candidates = []
    skipped = {}
    base = base or {}
    moving = rec.sins_angle is not None and float(np.ptp(rec.sins_angle)) > 0.0
    if names is None:
        names = tuple(EFFECTS) if settings.effects is None else settings.effects
    base_ex = sum(excess[a] for a in sig_axes)
    fs = rec.fs_hz
    for name in names:
        cls = EFFECTS[name]
        if cls.needs_motion and not moving:
            skipped[name] = "the block does not move in this recording: the effect cannot show"
            continue
        if rec.n_axes < cls.min_axes:
            skipped[name] = f"needs at least {cls.min_axes} axes"
            continue
        t0 = time.perf_counter()
        cfits = dict(fits)
        classes, starts, applied = {}, {}, []
        for a in sig_axes:
            if a in settled:
                continue  # at the floor already: the effect is not tried there (the fit stays)
            applied.append(a)
            held_cls = base.get(a, ())
            if not held_cls and reuse is not None and name in reuse:
                cfits[a] = reuse[name][a]  # nothing selected on this axis yet: the first round's fit is this model
                continue
            new = _effect_starts(cls, a, locs[a], fs)
            if held_cls:
                classes[a] = EffectSet(tuple(held_cls) + (cls,))
                held = _prefixed(fits[a].effect, a)
                starts[a] = [{**held, **{f"{name}.{k}": val for k, val in st.items()}} for st in (new or [{}])]
            else:
                classes[a] = cls
                starts[a] = new
        if classes:
            cfits.update(fit_effect(classes, starts, list(classes)))
        cand_axes = {a: excess_power(cfits[a], floors[a]) for a in sig_axes}
        cand_ex = sum(cand_axes.values())
        red = 1.0 - cand_ex / base_ex if base_ex > 0 else 0.0
        held = math.sqrt(np.mean([cfits[a].heldout_rms ** 2 for a in sig_axes]))
        # the gap is closed when what is left on every axis is within the tolerance, or a small
        # fraction of the excess it started from (a large effect leaves model error of its own size)
        gap_closed = closes({a: math.sqrt(cand_axes[a]) for a in sig_axes}, excess, tol, settings)
        candidates.append({
            "effect": name, "fits": cfits, "n_params": len(cls.fit_space(sig_axes[0], rec.axes)),
            "n_axes": len(applied),
            "rms_rad": math.sqrt(np.mean([cfits[a].rms ** 2 for a in rec.axes])),
            "gap_reduction": float(red), "score": held / ARCSEC, "closes_gap": bool(gap_closed),
            "remaining_excess_arcsec": {a: math.sqrt(cand_axes[a]) / ARCSEC for a in sig_axes},
            "params": {a: _own(cfits[a].effect.values(a), name, bool(base.get(a))) for a in applied},
            "uncertainty": {a: _own({k: val for k, val in cfits[a].sigma.items()
                                     if k not in NOMINAL_KEYS and not k.startswith("start_")}, name,
                                    bool(base.get(a))) for a in applied},
            "axes": applied,
            "nfev": sum(cfits[a].nfev for a in classes),
        })
        timing[name if not any(base.values()) else f"{name} (greedy)"] = time.perf_counter() - t0
        if progress:
            progress(f"candidate {name}")
    candidates.sort(key=lambda c: c["score"])
    return candidates, skipped
