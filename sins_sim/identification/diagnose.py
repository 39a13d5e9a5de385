"""Sim-to-real gap: refit, noise floor, localisation, candidate effects, verdict, report.

Given a recording (``sins_sim.io.recording``), :func:`diagnose_recording`

0. **checks the data** (:mod:`~sins_sim.identification.checks`): dead, saturated or noisy
   channels, impossible jumps, counts that are no continuous angle, a sign convention opposite to
   the header's. Each failure is a finding naming the axis and the time; a recording with a
   finding gets no verdict (status ``invalid data``);
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
5. with the bias-drift nuisance on (a still bench) and no ``meta.site``, reads the **steady rate** vector the
   nuisance took across the axes (:mod:`~sins_sim.identification.steady_rate`): the Earth's rate (then the
   finding asks for the site and gives the Earth's axis in the unit's axes), a plausible gyro bias, or
   unknown (``verdict.steady_rate``). With ``meta.site`` the model itself carries the Earth's rate
   (``sins_sim.simulation.site``, through the table's angle where a table moves); then it
   gives a **verdict** (:mod:`~sins_sim.identification.verdict`, where the criteria and their
   sources are): ``none`` when the refit nominal model sits at the floor (the excess RMS is
   within what noise gives at the false-alarm level ``gap_alpha`` over the axes, for the number of
   effectively independent samples: :mod:`~sins_sim.identification.detection`, floored by
   ``abs_tol``, which covers integration-method and interpolation differences between
   simulators); else the best candidate (the one with the fewest
   parameters among those the held-out data cannot tell from the best-scoring one, leaving out fits
   that lack the feature defining their effect, such as a block mode without a resonance) when it is
   significant
   against the baseline on held-out data (Diebold-Mariano) and by the nested F-test, with status
   ``explained`` when it closes the gap (leaves an excess within the tolerance, or below
   ``close_fraction`` of the excess it started from, and removes at least ``min_gap_reduction``
   of the power; effects that do as well within ``ALTERNATIVE_MARGIN`` are named as
   ``alternatives``) or ``partly explained`` when it closes at least a quarter of the gap and is
   clearly ahead of the runner-up on held-out data (``explained_fraction`` and the ``remainder``:
   axis, band, time window); else ``unknown`` (the localisation is then the answer);
6. **selects further effects greedily, per axis**: a selected effect is kept on the axes where it
   removes at least ``MIN_STEP`` of what the model before it left there; with what each axis holds
   in the model, each remaining candidate is added (on an axis holding nothing yet the first round's
   fit is that model; axes at the floor are left alone); the next one is selected when it is
   significant against the selected model and removes at least ``MIN_STEP`` of what remains. The
   verdict lists the selected effects in order, with the share of the gap each closes and the axes
   it is kept on (``verdict.effects``).
7. says a **close call** (:mod:`~sins_sim.identification.discriminate`): when other candidates close
   the gap as well as the verdict's effect, they join ``alternatives`` and ``verdict.close_call``
   gives each one's explained fraction and the experiment that would separate them (Box & Hill 1967).

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
from dataclasses import replace

import numpy as np

from sins_sim.identification.checks import check_recording, require_inputs
from sins_sim.identification.detection import axis_level, gap_test
from sins_sim.identification.discriminate import close_call
from sins_sim.identification.explain import explain
from sins_sim.identification.localise import localise, noise_floor, operating_points
from sins_sim.identification.recording_inputs import (_coupling_sources, _masks, _model_inputs, _table_angles, _tau,
                                                      _truncate)
from sins_sim.identification.refit import (CANCEL, AxisFit, DiagnoseSettings, _Problem, _rms, blas_threads, fit_axis,
                                          worker_pool)
from sins_sim.identification.plausibility import assess_plausibility, plausible_first
from sins_sim.identification.report import Diagnosis, plausibility_flags, write_report
from sins_sim.identification.steady_rate import steady_rate, table_scale_as_earth
from sins_sim.identification.verdict import (ALTERNATIVE_MARGIN, MAX_EFFECTS, MIN_PARTIAL, MIN_STEP,  # noqa: F401
                                             _step,
                                             assess, closes, excess_power, first_step, give_verdict,
                                             keep_dominant, resolved_first)
from sins_sim.models.effects import EFFECTS
from sins_sim.io.recording import Recording
from sins_sim.simulation.experiment import suspension_from_nominal
from sins_sim.units import ARCSEC

__all__ = ["DiagnoseSettings", "AxisFit", "Diagnosis", "noise_floor", "fit_axis", "localise", "operating_points",
           "diagnose_recording", "write_report"]


def diagnose_recording(rec: Recording, settings: DiagnoseSettings = DiagnoseSettings(), progress=None) -> Diagnosis:
    """Refit, noise floor, localisation, candidate effects and verdict for a recording."""
    CANCEL.clear()
    with blas_threads(1):  # the parallelism is the worker threads' (refit.blas_threads says why)
        return _diagnose(rec, settings, progress)


def _diagnose(rec: Recording, settings: DiagnoseSettings, progress=None) -> Diagnosis:
    import time

    t_start = time.perf_counter()
    timing = {}
    require_inputs(rec, settings.block_s)
    nominal = {a: suspension_from_nominal(rec.nominal[a]) for a in rec.axes}
    # a recording that starts mid-operation is simulated from rest 6 time constants earlier, the drive
    # before t = 0 continued as it starts, so that the model is in its steady state when the data begin
    n_pre = int(round(6.0 * _tau(nominal) * rec.fs_hz)) if rec.initial_state == "unknown" else 0
    offset = rec.initial_state == "unknown"
    q = rec.quantum_rad
    fs = rec.fs_hz
    sig0 = q / math.sqrt(12.0)
    table = _table_angles(rec)
    drift = settings.bias_drift and rec.sins_angle is None  # see DiagnoseSettings.bias_drift
    if settings.checks:
        # 0. the data checks: a recording with a finding gets no verdict
        findings = check_recording(rec, table)
        timing["checks"] = time.perf_counter() - t_start
        if findings:
            verdict = {"effect": "invalid_data", "status": "invalid data", "explained_fraction": None,
                       "gap_reduction": None, "effects": [], "alternatives": [], "remainder": None,
                       "findings": findings}
            return Diagnosis(recording=rec, floors={}, baseline={}, gap={}, candidates=[], verdict=verdict,
                             timing=timing, findings=findings)
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
        return _Problem(inputs, a, ys[a], nominal[a], sett, u, tr, offset, sig0, coupled, a_ref[a], n_pre,
                        drift=drift)

    shared = {}  # axis -> the baseline polish's Jacobian columns of the nominal parameters and start state

    def fit(a, cls=None, start=None, starts=None, sett=settings):
        """A fit on the whole recording, through its first window when it is long.

        The polish of a candidate effect against the baseline (the first round) reuses the baseline
        polish's Jacobian columns of the nominal parameters and the start state on the same axis (the
        chord method needs only an approximate Jacobian; its steps are accepted on the true cost): it
        differences only the effect's parameters, a few model runs of the whole recording instead of
        about ten. Later rounds, whose models carry effects the baseline lacks, difference every column
        (with the baseline's columns there the fit of a 20 s recording came out several sigma off).
        """
        if win is None:
            return fit_axis(problem(a, full, sett), cls, start, starts)
        fw = fit_axis(problem(a, win, sett), cls, start, starts, uncertainty=False)  # the polish has its own
        hint = shared.get(a) if start is None or start.effect is None else None  # candidates against the baseline
        ff = fit_axis(problem(a, full, sett), cls, start=fw, polish=True, jac_hint=hint, keep_jac=cls is None)
        if cls is None:
            shared[a] = ff.shared_jac
            ff.shared_jac = None
        ff.nfev += fw.nfev
        return ff

    def per_axis(axes, job):
        """``job(axis, settings)`` for every axis, in parallel threads when there are several."""
        if len(axes) > 1 and settings.threads > 1:
            inner = replace(settings, threads=max(1, settings.threads // len(axes)))
            with worker_pool(min(settings.threads, len(axes))) as ex:
                return dict(zip(axes, ex.map(lambda a: job(a, inner), axes)))
        return {a: job(a, settings) for a in axes}

    # 1. baseline refit, per axis (independent in the nominal model)
    fits = per_axis(list(rec.axes), lambda a, sett: fit(a, sett=sett))
    if progress:
        progress("baseline")
    timing["baseline"] = time.perf_counter() - t_start
    # 2. noise floor and significance per axis
    floors = {a: noise_floor(fits[a].residual[used], q, fs) for a in rec.axes}
    # the gap's test per axis: the residual's power against the floor's at the Sidak level of the axes
    # (detection.gap_test), its tolerance floored by the model-error allowance
    level = axis_level(settings.gap_alpha, rec.n_axes)
    tests = {a: gap_test(fits[a].residual[used], floors[a], level) for a in rec.axes}
    tol = {a: max(tests[a]["tolerance_rad"], settings.rel_tol * floors[a]["floor_rad"],
                  settings.abs_tol_arcsec * ARCSEC) for a in rec.axes}
    excess = {a: excess_power(fits[a], floors[a]) for a in rec.axes}
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
           "test": {a: {"statistic": "mean square residual / floor^2", "ratio": tests[a]["ratio"],
                        "critical_ratio": tests[a]["critical_ratio"], "p_value": tests[a]["p_value"],
                        "n_eff": tests[a]["n_eff"], "floor_dof": tests[a]["floor_dof"],
                        "alpha_axis": level, "alpha": settings.gap_alpha} for a in rec.axes},
           "significant_axes": sig_axes,
           "operating_points": sorted(points, key=lambda p: -(p["excess_rms_arcsec"] or 0.0))}
    base_rms = math.sqrt(np.mean([fits[a].rms ** 2 for a in rec.axes]))
    baseline = {"fits": fits, "rms_rad": base_rms}
    timing["localise"] = time.perf_counter() - t_start

    # 4. candidates on the significant axes, against the baseline
    def fit_effect_from(start_fits):
        def fit_effect(classes, starts, axes):
            """The fits with ``classes[axis]`` on ``axes``, from ``start_fits`` and ``starts[axis]``."""
            return per_axis(axes, lambda a, sett: fit(a, classes[a], start_fits[a], starts[a], sett))
        return fit_effect

    def ex(f, a):
        return excess_power(f, floors[a])

    def hold(step, prev, prev_base):
        """Keep the step's effect on the axes where it removes at least MIN_STEP of what the previous model
        left there (if on none, where it removes anything); elsewhere the previous model stays. Returns the
        selected model (axis -> fit) and its effects per axis, and updates the step to what is kept."""
        gain = {a: ex(prev[a], a) - ex(step["fits"][a], a) for a in sig_axes}
        keep = [a for a in sig_axes if gain[a] > 0.0 and gain[a] >= MIN_STEP * ex(prev[a], a)]
        keep = keep or [a for a in sig_axes if gain[a] > 0.0] or list(sig_axes)
        cur = {**prev, **{a: step["fits"][a] for a in keep}}
        cur_base = {**prev_base, **{a: prev_base.get(a, ()) + (EFFECTS[step["effect"]],) for a in keep}}
        left = {a: math.sqrt(ex(cur[a], a)) for a in sig_axes}
        step.update(fits=cur, axes=keep, params={a: v for a, v in step["params"].items() if a in keep},
                    uncertainty={a: v for a, v in step["uncertainty"].items() if a in keep},
                    explained_fraction=float(sum(gain[a] for a in keep) / base_total) if base_total > 0 else 0.0,
                    closes_gap=closes(left, excess, tol, settings))
        return cur, cur_base

    def finish_contenders(cands):
        """The candidates that can be named or be a rival (closing at least ``MIN_PARTIAL`` of the gap), their
        fits continued from where the candidate budget left them, the others as they are; best first.

        The held-out test that ranks two candidates compares their fitted models: a fit the candidate budget
        (``candidate_nfev``) stopped in a valley short of its optimum predicts worse than the effect can, and
        the test then prefers its rival for the budget's sake (issue 39: a drive lag fitted 17 sigma short of
        its true 76 us lost to the readout delay in 2 of 40 dither-only recordings). The continuation is a
        polish (``fit_axis(..., polish=True)``) with the baseline's budget ``max_nfev``; it only
        accepts steps that lower the training cost; the Jacobian is updated at each (``chord=False``: with the
        start's Jacobian kept, the drive lag crept a third of the way along its valley in 30 evaluations).
        """
        names = [c["effect"] for c in cands if c["gap_reduction"] >= MIN_PARTIAL]
        if not names:
            return cands
        t0 = time.perf_counter()
        refined = {}
        for c in cands:
            if c["effect"] not in names:
                continue
            cls = EFFECTS[c["effect"]]
            done = per_axis(list(c["axes"]), lambda a, sett, c=c, cls=cls: fit_axis(
                problem(a, full, sett), cls, start=c["fits"][a], polish=True, max_nfev=settings.max_nfev, chord=False))
            refined[c["effect"]] = {**c["fits"], **done}
        again, _ = explain(rec, settings, fits, floors, excess, tol, sig_axes, locs, fit_effect_from(fits), {},
                           None, names=names, reuse=refined)
        for c in again:
            c["nfev"] = sum(c["fits"][a].nfev for a in c["axes"])
        timing["finish contenders"] = time.perf_counter() - t0
        out = [c for c in cands if c["effect"] not in names] + again
        return sorted(out, key=lambda c: c["score"])

    candidates, skipped = [], {}
    steps = None
    remainder = None
    train = full[2]
    n_nom = 6 + (2 if offset else 0) + (2 if drift else 0)  # the bias drift's two nuisance terms too
    def flags_of(fs_):
        return plausibility_flags(rec, fs_)

    if significant:
        candidates, skipped = explain(rec, settings, fits, floors, excess, tol, sig_axes, locs,
                                      fit_effect_from(fits), timing, progress)
        candidates = finish_contenders(candidates)
        assess(candidates, fits, sig_axes, train, used, n_nom)
        assess_plausibility(candidates, fits, floors, tol, sig_axes, rec.axes, flags_of)
        candidates = plausible_first(candidates)  # implausible fits ranked after the plausible ones
        base_held = math.sqrt(np.mean([fits[a].heldout_rms ** 2 for a in sig_axes]))
        steps = first_step(candidates, base_held, settings)
        # 5. greedy forward selection, per axis: the next effect on what the selected ones leave; an effect is
        # kept on the axes where it helps (a recording can carry one effect on x and another on y)
        base_total = sum(excess[a] for a in sig_axes)
        first_round = {c["effect"]: c["fits"] for c in candidates}
        cur, cur_base = fits, {}
        if steps:
            cur, cur_base = hold(steps[0], cur, cur_base)
        while steps and len(steps) < MAX_EFFECTS and settings.max_effects > len(steps):
            rem = {a: ex(cur[a], a) for a in sig_axes}
            settled = [a for a in sig_axes if math.sqrt(rem[a]) <= tol[a]]
            if len(settled) == len(sig_axes):
                break  # at the floor
            chosen = {s["effect"] for s in steps}
            names = [c["effect"] for c in candidates if c["effect"] not in chosen and c["gap_reduction"] > 0.0]
            names = names[:settings.greedy_candidates]
            if not names:
                break
            cur_locs = {a: localise(cur[a].residual, floors[a]["floor_rad"], fs) for a in sig_axes}
            more, _ = explain(rec, settings, cur, floors, rem, tol, sig_axes, {**locs, **cur_locs},
                              fit_effect_from(cur), timing, progress, base=cur_base, names=names, settled=settled,
                              reuse=first_round)
            n_ref = {a: n_nom + sum(len(c.fit_space(a, rec.axes)) for c in cur_base.get(a, ())) for a in sig_axes}
            assess(more, cur, sig_axes, train, used, n_ref)
            assess_plausibility(more, cur, floors, tol, sig_axes, rec.axes, flags_of)
            cur_held = math.sqrt(np.mean([cur[a].heldout_rms ** 2 for a in sig_axes])) / ARCSEC
            pick = next((c for c in plausible_first(resolved_first(more))
                         if c["significant"] and c["gap_reduction"] >= MIN_STEP and c["score"] < cur_held), None)
            if pick is None:
                break
            steps.append(_step(pick, 0.0, False))
            cur, cur_base = hold(steps[-1], cur, cur_base)
        steps = keep_dominant(steps)  # a lone first effect not clearly ahead is named only when dominant
        if steps and not (steps[-1]["closes_gap"] and sum(s["explained_fraction"] for s in steps)
                          >= settings.min_gap_reduction):
            last = steps[-1]["fits"]
            w = max(sig_axes, key=lambda a: last[a].rms ** 2 - floors[a]["floor_rad"] ** 2)
            lw_ = localise(last[w].residual, floors[w]["floor_rad"], fs)
            remainder = {"axis": w, "band_hz": lw_["band_hz"], "peaks_hz": lw_["peaks_hz"], "time_s": lw_["time_s"],
                         "excess_rms_arcsec": {a: math.sqrt(ex(last[a], a)) / ARCSEC for a in sig_axes}}
        elif not steps:
            remainder = {"axis": worst, "band_hz": lw["band_hz"], "peaks_hz": lw["peaks_hz"], "time_s": lw["time_s"],
                         "excess_rms_arcsec": {a: math.sqrt(excess[a]) / ARCSEC for a in sig_axes}}
    # 6. the verdict
    verdict = give_verdict(fits, sig_axes, candidates, settings, steps, remainder, duration_s=rec.duration_s)
    # a still recording without meta.site: the steady rate the bias nuisance took, the Earth's or a bias
    verdict["steady_rate"] = steady_rate(rec, fits, used, settings.gap_alpha) if drift else None
    # a rate table without meta.site: a scale-factor error there can be the Earth's rate along the table axis
    verdict = table_scale_as_earth(rec, verdict)
    # 7. a close call is said, with the experiment that separates it (discriminate.close_call)
    verdict = close_call(rec, verdict, candidates, floors, settings)
    timing["total"] = time.perf_counter() - t_start
    return Diagnosis(recording=rec, floors=floors, baseline=baseline, gap=gap, candidates=candidates,
                     verdict=verdict, localisation=locs, timing=timing, skipped=skipped, steps=steps or [])
