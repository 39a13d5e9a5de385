"""Sim-to-real gap: refit, noise floor, localisation, candidate effects, verdict, report.

Given a recording (``sins_sim.io.recording``), :func:`diagnose_recording`

1. **refits** the nominal parameters ``f0, k1..k5`` of every axis by
   simulating the same experiment (same drive, block motion and readout
   instants, ``sins_sim.simulation.experiment``, exact integrator at about
   28.8 kHz) and minimising the residual with
   ``scipy.optimize.least_squares``. The axes are independent in the
   nominal model, so each axis is fitted alone (in parallel threads).
   Parametrisation: ``(F(a_ref), k1, k2, 1/Q(a_ref), k4, k5)`` relative to
   their nominal values, with ``F`` the harmonic-balance resonance and
   ``1/Q = k3 (1 + k4 a)`` at the measured dither amplitude ``a_ref``:
   what a dither shows directly, so the fit does not crawl along the
   valleys ``(f0, k1, k2)`` and ``(k3, k4)`` that a steady dither leaves.
   A weak prior (1 % on F, 30 % on the others) keeps unresolved directions
   at the nominal values. Stages: a grid over F (a dither far off phase is
   far from the quadratic regime), then ``F, 1/Q, k5``, then all six;
   the solver's unit step is one plausible variation of each parameter
   (``_XSCALE``). Uncertainty: from the Jacobian and the prior, the
   residual variance inflated by the residual's correlation length.
   A recording longer than ``1.5 window_s`` is fitted on its first
   ``window_s`` seconds and then refined on the whole of it;
2. estimates the **noise floor** from the data (:func:`noise_floor`): the
   quantisation ``q / sqrt(12)``, or more where the residual's
   high-frequency band (where the model has no content) says so;
3. **localises** the gap (:func:`localise`): per axis the excess of the
   residual's RMS over the floor; on the worst axis the band holding 90 %
   of the excess power (Welch spectrum) and its peaks, the time window
   holding 90 % of the excess energy (residual envelope), and for AFC
   sweeps the operating points (:func:`operating_points`, segments of
   constant drive amplitude and frequency found from ``drive_v``) ranked by
   their excess;
4. **explains**: every catalogue effect (``sins_sim.models.effects``) that
   the experiment can show is fitted together with the nominal parameters
   on each axis with a significant gap, from the best of a few starts of
   its parameters (for ``block_mode`` including the residual's peaks).
   ``gap_reduction`` is the fraction of the excess residual power over the
   floor it removes; the ``score`` is the RMS residual on held-out data
   (the recording is cut in blocks; even blocks fit, odd blocks score), so
   an extra parameter that only fits noise gains nothing;
5. gives a **verdict**: ``none`` when the refit nominal model sits at the
   floor (excess RMS below ``max(rel_tol * floor, abs_tol)``: a tolerance
   that covers integration-method, interpolation and noise differences
   between simulators); the best-scoring effect when it closes the gap
   (leaves an excess within the tolerance, or below ``close_fraction`` of
   the excess it started from, and removes at least ``min_gap_reduction``
   of the power), with the effects that do as well within
   ``ALTERNATIVE_MARGIN`` named as ``alternatives``; else ``unknown`` (the
   localisation is then the answer).

Conventions: the measured angle is ``counts * q + q / 2`` (the floor of the
counter makes ``counts * q`` half a quantum low on average). A recording
with ``initial_state = "unknown"`` is simulated from rest 6 time constants
``2 Q / omega`` before its start, the drive (and table motion) before
``t = 0`` continued as it starts; the suspension's state at ``t = 0`` is
then fitted as well (two more parameters: a change of deflection and of
its rate there, applied as a fictitious block kick that only the plant
sees), a constant (the counter's start) is profiled out, and the first
half time constant is left out.

The steps live in their own modules, re-exported here:
:mod:`~sins_sim.identification.refit` (settings, step 1),
:mod:`~sins_sim.identification.recording_inputs` (pre-roll, masks, coupling
sources), :mod:`~sins_sim.identification.localise` (steps 2 and 3),
:mod:`~sins_sim.identification.explain` (step 4),
:mod:`~sins_sim.identification.verdict` (step 5) and
:mod:`~sins_sim.identification.report` (the result, its JSON and
``report.md``); this module runs them (:func:`diagnose_recording`).

Functions
---------
.. autosummary::

   DiagnoseSettings
   noise_floor
   fit_axis
   localise
   operating_points
   diagnose_recording
   write_report
"""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace

import numpy as np

from sins_sim.identification.explain import explain
from sins_sim.identification.localise import localise, noise_floor, operating_points
from sins_sim.identification.recording_inputs import (_coupling_sources, _masks, _model_inputs, _table_angles, _tau,
                                                      _truncate)
from sins_sim.identification.refit import AxisFit, DiagnoseSettings, _Problem, _rms, fit_axis
from sins_sim.identification.report import Diagnosis, write_report
from sins_sim.identification.verdict import ALTERNATIVE_MARGIN, give_verdict  # noqa: F401 (re-exported)
from sins_sim.io.recording import Recording
from sins_sim.simulation.experiment import suspension_from_nominal
from sins_sim.units import ARCSEC

__all__ = ["DiagnoseSettings", "AxisFit", "Diagnosis", "noise_floor", "fit_axis", "localise", "operating_points",
           "diagnose_recording", "write_report"]


def diagnose_recording(rec: Recording, settings: DiagnoseSettings = DiagnoseSettings(), progress=None) -> Diagnosis:
    """Refit, noise floor, localisation, candidate effects and verdict for a recording."""
    import time

    t_start = time.perf_counter()
    timing = {}
    nominal = {a: suspension_from_nominal(rec.nominal[a]) for a in rec.axes}
    # a recording that starts mid-operation is simulated from rest 6 time constants earlier, the drive
    # before t = 0 continued as it starts, so that the model is in its steady state when the data begin
    n_pre = int(round(6.0 * _tau(nominal) * rec.fs_hz)) if rec.initial_state == "unknown" else 0
    offset = rec.initial_state == "unknown"
    q = rec.quantum_rad
    fs = rec.fs_hz
    sig0 = q / math.sqrt(12.0)
    table = _table_angles(rec)
    a_ref = {}
    for a in rec.axes:
        d = rec.angle(a) - table[a]
        half = d[rec.n_samples // 2:]
        a_ref[a] = max(math.sqrt(2.0) * float(np.std(half - np.mean(half))), 10.0 * q)

    def context(r: Recording):
        inputs = _model_inputs(r, n_pre)
        used, train = _masks(r, settings, nominal)
        coupled = _coupling_sources(r, inputs, settings.experiment, n_pre) if r.n_axes > 1 else None
        return inputs, used, train, {a: r.angle(a) + 0.5 * q for a in r.axes}, coupled

    full = context(rec)
    used = full[1]
    n_win = int(round(settings.window_s * fs)) + 1 if settings.window_s is not None else rec.n_samples
    win = context(_truncate(rec, n_win)) if rec.n_samples > 1.5 * n_win else None

    def problem(a, ctx, sett=settings):
        inputs, u, tr, ys, coupled = ctx
        return _Problem(inputs, a, ys[a], nominal[a], sett, u, tr, offset, sig0, coupled, a_ref[a], n_pre)

    def fit(a, cls=None, start=None, starts=None, sett=settings):
        """A fit on the whole recording, through its first window when it is long."""
        if win is None:
            return fit_axis(problem(a, full, sett), cls, start, starts)
        fw = fit_axis(problem(a, win, sett), cls, start, starts)
        ff = fit_axis(problem(a, full, sett), cls, start=fw, polish=True)
        ff.nfev += fw.nfev
        return ff

    def per_axis(axes, job):
        """``job(axis, settings)`` for every axis, in parallel threads when there are several."""
        if len(axes) > 1 and settings.threads > 1:
            inner = replace(settings, threads=max(1, settings.threads // len(axes)))
            with ThreadPoolExecutor(max_workers=min(settings.threads, len(axes))) as ex:
                return dict(zip(axes, ex.map(lambda a: job(a, inner), axes)))
        return {a: job(a, settings) for a in axes}

    # 1. baseline refit, per axis (independent in the nominal model)
    fits = per_axis(list(rec.axes), lambda a, sett: fit(a, sett=sett))
    if progress:
        progress("baseline")
    timing["baseline"] = time.perf_counter() - t_start
    # 2. noise floor and significance per axis
    floors = {a: noise_floor(fits[a].residual[used], q, fs) for a in rec.axes}
    tol = {a: max(settings.rel_tol * floors[a]["floor_rad"], settings.abs_tol_arcsec * ARCSEC) for a in rec.axes}
    excess = {a: max(0.0, fits[a].rms ** 2 - floors[a]["floor_rad"] ** 2) for a in rec.axes}
    sig_axes = [a for a in rec.axes if math.sqrt(excess[a]) > tol[a]]
    worst = max(rec.axes, key=lambda a: excess[a] / tol[a] ** 2)
    # 3. localisation on every axis; the gap on the worst one
    locs = {a: localise(fits[a].residual, floors[a]["floor_rad"], fs) for a in rec.axes}
    points = []
    if rec.experiment == "afc_sweep" or "afc" in rec.experiment:
        i = rec.axis_index(worst)
        ops = operating_points(rec.drive_v[:, i], rec.drive_fs_hz)
        r = fits[worst].residual
        for p in ops:
            i0, i1 = int(p["t_s"][0] * fs), int(p["t_s"][1] * fs)
            rms = _rms(r[i0:i1])
            ex = math.sqrt(max(0.0, rms ** 2 - floors[worst]["floor_rad"] ** 2)) if math.isfinite(rms) else math.nan
            points.append({**p, "residual_rms_arcsec": rms / ARCSEC, "excess_rms_arcsec": ex / ARCSEC})
    significant = bool(sig_axes)
    lw = locs[worst]
    gap = {"significant": significant, "axis": worst if significant else None,
           "band_hz": lw["band_hz"] if significant else None, "time_s": lw["time_s"] if significant else None,
           "peaks_hz": lw["peaks_hz"] if significant else [],
           "excess_rms_arcsec": {a: math.sqrt(excess[a]) / ARCSEC for a in rec.axes},
           "tolerance_arcsec": {a: tol[a] / ARCSEC for a in rec.axes},
           "significant_axes": sig_axes,
           "operating_points": sorted(points, key=lambda p: -(p["excess_rms_arcsec"] or 0.0))}
    base_rms = math.sqrt(np.mean([fits[a].rms ** 2 for a in rec.axes]))
    baseline = {"fits": fits, "rms_rad": base_rms}
    timing["localise"] = time.perf_counter() - t_start

    # 4. candidates on the significant axes
    def fit_effect(cls, starts):
        """The fits with the effect ``cls`` on the significant axes, from the baseline and ``starts[axis]``."""
        return per_axis(sig_axes, lambda a, sett: fit(a, cls, fits[a], starts[a], sett))

    candidates, skipped = [], {}
    if significant:
        candidates, skipped = explain(rec, settings, fits, floors, excess, tol, sig_axes, locs, fit_effect, timing,
                                      progress)
    # 5. the verdict
    verdict = give_verdict(fits, sig_axes, candidates, settings)
    timing["total"] = time.perf_counter() - t_start
    return Diagnosis(recording=rec, floors=floors, baseline=baseline, gap=gap, candidates=candidates,
                     verdict=verdict, localisation=locs, timing=timing, skipped=skipped)
