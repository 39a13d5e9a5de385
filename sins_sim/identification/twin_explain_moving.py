"""Explain and shrink the gap between a moving log and its twin on the known trajectory: the motion-excited part of
the catalogue, in the words of :mod:`sins_sim.identification.twin_explain`.

On a log with its truth (``identify --truth``) the twin carries the terms fitted against the truth's exact
increments (bias, scale factors, misalignments; :mod:`sins_sim.navigation.truth_fit`) and flies the truth beside the
log (:mod:`sins_sim.simulation.twin_moving`). The findings (:func:`sins_sim.identification.twin_gap.localise` with
:data:`~sins_sim.identification.twin_gap.NAV_QUANTITIES_TRUTH`) are read on the **residual** ``r = (x_meas - x_true -
b dt - E x_true) / dt`` (Allan deviation and spectral lines, log against the twin's seeds) and on the navigation
error against the truth.

Catalogue (each an added rate or specific force ``p = beta z_perp``)
---------------------------------------------------------------------
A candidate is a regressor ``z`` per channel (built from the truth's exact increments, so the motion decides whether
it is testable) and one coefficient ``beta`` per group of channels. The twin's fitted terms have already taken the
part of ``z`` that lies in the span of the bias and the triad's three increments ``[1, x_1, x_2, x_3]`` (its
scale factors and misalignments), so what the candidate adds to the twin is ``beta z_perp``, ``z_perp`` the part of
``z`` outside that span, and ``beta`` is the least-squares coefficient of ``r`` on ``z_perp``, the same as a joint
fit of the terms and the candidate gives (Frisch-Waugh-Lovell; Davidson and MacKinnon 2004, "Econometric Theory and
Methods", sec. 2.4). A group of channels shares ``beta``, weighted by each channel's residual variance; ``beta``'s
sigma is the white-noise least-squares one, ``(sum_ch z_perp . z_perp / s_ch^2)^-1/2``.

``scale_factor_asymmetry`` (per axis of each triad)
    Scale factor ``S + A/2`` for positive rates (forces) and ``S - A/2`` for negative ones: ``x_meas = x (1 + S) +
    (A / 2) |x|`` (the asymmetry ``A`` of IEEE Std 952-1997, sec. 3, "scale factor asymmetry"; Titterton and Weston
    2004, sec. 4.2.3), so ``z = |x| / (2 dt)``. Testable only where the axis turns both ways: with rates of one
    sign ``|x| = +-x`` is in the span and ``z_perp`` vanishes (the asymmetry is then a scale factor). The rule is the
    truth fit's (:data:`~sins_sim.navigation.truth_fit.EXCITATION_MIN` on ``1 - R^2`` of ``z`` on the span).
``timing_rate_off_nominal`` (clock; one ``kappa`` for the six channels)
    A unit whose interval is ``dt (1 + kappa)`` but stamped ``dt``: its k-th increment is the truth's over
    ``((k-1) dt (1 + kappa), k dt (1 + kappa)]``, to first order ``x_k (1 + kappa) + kappa t_k dx_k/dt``, so ``z =
    (x + t dx/dt) / dt`` (``t`` from the log's start, the derivative by central differences). Its scale part is in
    the span; the growing time offset ``kappa t`` is not, wherever the rate or force changes.
``coning_sculling_residue`` (one gain on the gyros, one on the accelerometers)
    The unit's increments carry its own algorithm's coning and sculling terms (or part of them, the gain ``g``),
    where the truth's are the exact integrals of rate and force: the gyros ``(1/12) a_{k-1} x a_k`` (the two-sample
    coning term) and the accelerometers ``(1/2) a_k x v_k + (1/12) (a_{k-1} x v_k + v_{k-1} x a_k)`` (rotation and
    sculling; Savage 1998, "Strapdown inertial navigation integration algorithm design", parts 1 and 2; Titterton
    and Weston 2004, sec. 11.2.2 and 11.2.3). Testable where a full term (``g = 1``) would be found at
    :data:`~sins_sim.identification.verdict.ALPHA` with power :data:`TEST_POWER`: ``sigma_g <= 1 / (z_{1 - ALPHA/2} +
    z_{TEST_POWER})``.

A **pulse-weight error** of a channel scales its increments, ``x_meas = (w_true / w_nominal) x``: on a known
trajectory it is the channel's scale factor, fitted against the truth and carried by the twin, so it leaves no gap;
it is named (``in_the_fit``) where the fitted scale factor differs from zero beyond its sigma (two-sided,
:data:`~sins_sim.identification.verdict.ALPHA` over the channels, Bonferroni), with its value in ppm.

Shrink, held-out check, selection and verdict are :mod:`sins_sim.identification.twin_explain`'s: the candidate is
added to every seed of the twin (the same seeds), localised again, ``shrink = 1 - G_c / G_0`` with its sd from the
paired bootstrap over seeds; fitted again on the even blocks and scored on the odd ones (Diebold-Mariano);
:func:`~sins_sim.identification.twin_explain.choose_step` and
:func:`~sins_sim.identification.twin_explain.give_twin_verdict` name it.

.. autosummary::

   explain_moving
   motion_candidates
   fit_motion_candidate
   localise_moving
"""

from __future__ import annotations

import math

import numpy as np

from sins_sim.identification.twin_explain import (BOOTSTRAP, CHANNELS, HELD_BLOCKS, finding_excess, gap_measure,
                                                  give_twin_verdict, select_effects)
from sins_sim.identification.verdict import ALPHA

__all__ = ["TEST_POWER", "explain_moving", "fit_motion_candidate", "localise_moving", "motion_candidates",
           "pulse_weight_in_fit"]

#: The power a testable coning or sculling term (gain 1) has of being found at ``ALPHA``.
TEST_POWER = 0.9


# --- the regressors ----------------------------------------------------------------------------------------------------

def _span(x3: np.ndarray) -> np.ndarray:
    """The twin's fitted columns of a triad, per interval: ``[1, x_1, x_2, x_3]``."""
    return np.column_stack([np.ones(x3.shape[0]), x3])


def _perp(z: np.ndarray, span: np.ndarray, train, per: int) -> tuple:
    """``(z_perp, 1 - R^2)``: ``z`` less its regression on ``span``, the coefficients fitted as the twin's terms
    were (:func:`~sins_sim.navigation.truth_fit.fit_against_truth`: on sums over blocks of ``per`` intervals, here
    the blocks wholly in ``train``), and the share of ``z``'s block sums of squares outside the span."""
    n = z.shape[0]
    k = n // per
    tr = np.asarray(train, dtype=bool)[:k * per].reshape(k, per).all(axis=1)
    zb = z[:k * per].reshape(k, per).sum(axis=1)[tr]
    sb = span[:k * per].reshape(k, per, span.shape[1]).sum(axis=1)[tr]
    scale = np.linalg.norm(sb, axis=0)
    scale[scale == 0.0] = 1.0
    coef, *_ = np.linalg.lstsq(sb / scale, zb, rcond=None)
    zz = float(zb @ zb)
    rb = zb - (sb / scale) @ coef
    return z - (span / scale) @ coef, (float(rb @ rb) / zz if zz > 0.0 else 0.0)


def _clock_regressor(x: np.ndarray, t: np.ndarray, dt: float) -> np.ndarray:
    """``(x + t dx/dt) / dt`` per column (module docstring, clock)."""
    return (x + (t - t[0] + dt)[:, None] * np.gradient(x, dt, axis=0)) / dt


def _coning_sculling(a: np.ndarray, v: np.ndarray, dt: float) -> tuple:
    """The two-sample coning term of the angles ``a`` and the rotation and sculling terms of ``v`` (module
    docstring), as rate and specific force (the first interval has no predecessor: zero)."""
    a0 = np.vstack([np.zeros((1, 3)), a[:-1]])
    v0 = np.vstack([np.zeros((1, 3)), v[:-1]])
    con = np.cross(a0, a) / 12.0
    scul = 0.5 * np.cross(a, v) + (np.cross(a0, v) + np.cross(v0, a)) / 12.0
    con[0] = 0.0
    scul[0] = 0.5 * np.cross(a[0], v[0])
    return con / dt, scul / dt


def motion_candidates(ideal_dth, ideal_dv, t, resid6) -> tuple:
    """The motion-excited candidates this log's trajectory can test, and why the others cannot.

    Parameters
    ----------
    ideal_dth, ideal_dv : ndarray (N, 3)
        The truth's exact increments.
    t : ndarray (N,)
        End times of the intervals (s), evenly spaced.
    resid6 : ndarray (N, 6)
        The log's residual (rate and specific force) against the truth and the twin's fitted terms (its channel
        variances weight a shared coefficient and state the coning test's sigma).

    Returns
    -------
    (list of dict, dict)
        The candidates (``effect``, ``label``, ``groups``: list of ``(channels, z (N, len))``, ``coefficient``,
        ``unit``) and ``not_testable`` (effect -> reason).
    """
    from scipy.stats import norm

    from sins_sim.navigation.truth_fit import BLOCK_S, EXCITATION_MIN

    a = np.asarray(ideal_dth, dtype=np.float64)
    v = np.asarray(ideal_dv, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)
    dt = float(t[1] - t[0])
    every = np.ones(t.size, dtype=bool)
    per = max(1, int(round(BLOCK_S / dt)))
    spans = (_span(a), _span(v))
    var = np.maximum(np.var(np.asarray(resid6, dtype=np.float64), axis=0), 1e-300)
    cands, why = [], {}
    out_of = []
    for tri, (sensor, x, what) in enumerate((("gyro", a, "rates"), ("accelerometer", v, "specific forces"))):
        for i, ax in enumerate("xyz"):
            z = np.abs(x[:, i]) / (2.0 * dt)
            zp, share = _perp(z, spans[tri], every, per)
            if share >= EXCITATION_MIN:
                cands.append({"effect": "scale_factor_asymmetry", "label": f"scale-factor asymmetry {sensor} {ax}",
                              "groups": [([3 * tri + i], zp[:, None])], "coefficient": "asymmetry", "unit": "ppm",
                              "factor": 1e6})
                continue
            pos, neg = float(np.sum(x[x[:, i] > 0, i])), abs(float(np.sum(x[x[:, i] < 0, i])))
            sign = "negative" if neg <= pos else "positive"
            out_of.append(f"{sensor} {ax}: no {sign} {what} about {ax} (their share of the axis's increments: "
                          f"{min(pos, neg) / max(pos + neg, 1e-300):.2g}), so |x| is +-x and the asymmetry a scale "
                          "factor")
    if out_of:
        why["scale_factor_asymmetry"] = "; ".join(out_of)
    groups = []
    for tri, x in enumerate((a, v)):
        z = _clock_regressor(x, t, dt)
        for i in range(3):
            zp, share = _perp(z[:, i], spans[tri], every, per)
            if share >= EXCITATION_MIN:
                groups.append([3 * tri + i, zp])
    if groups:
        cands.append({"effect": "timing_rate_off_nominal", "label": "clock rate off its nominal (all channels)",
                      "groups": [([c for c, _ in groups], np.column_stack([z for _, z in groups]))],
                      "coefficient": "rate_error", "unit": "ppm", "factor": 1e6})
    else:
        why["timing_rate_off_nominal"] = ("the rates and forces do not change (a clock's time offset t kappa then "
                                          "reads as a scale factor)")
    con, scul = _coning_sculling(a, v, dt)
    need = 1.0 / (norm.isf(ALPHA / 2.0) + norm.ppf(TEST_POWER))
    groups, low = [], []
    for tri, (z3, name) in enumerate(((con, "coning"), (scul, "sculling"))):
        cols = [_perp(z3[:, i], spans[tri], every, per)[0] for i in range(3)]
        info = sum(float(c @ c) / var[3 * tri + i] for i, c in enumerate(cols))
        sigma = 1.0 / math.sqrt(info) if info > 0.0 else math.inf
        if sigma <= need:
            groups.append(([3 * tri, 3 * tri + 1, 3 * tri + 2], np.column_stack(cols)))
        else:
            low.append(f"{name}: a full term would have sigma {sigma:.3g} on its gain (testable at <= {need:.3g})")
    if groups:
        cands.append({"effect": "coning_sculling_residue", "label": "coning/sculling residue"
                      + ("" if len(groups) == 2 else f" ({'coning' if groups[0][0][0] == 0 else 'sculling'} only)"),
                      "groups": groups, "coefficient": "gain", "unit": "", "factor": 1.0})
    if low:
        why["coning_sculling_residue"] = "the motion's coning and sculling are too weak against the noise: " + \
                                         "; ".join(low)
    return cands, why


def fit_motion_candidate(cand: dict, resid6, train) -> tuple:
    """``(prediction (N, 6), params, sigmas)`` of one candidate fitted on the ``train`` samples of the residual
    (module docstring; params per group in the candidate's edge unit)."""
    r = np.asarray(resid6, dtype=np.float64)
    tr = np.asarray(train, dtype=bool)
    pred = np.zeros_like(r)
    params, sig = {}, {}
    for chans, z in cand["groups"]:
        zc = z - z[tr].mean(axis=0)
        rc = r[:, chans] - r[tr][:, chans].mean(axis=0)
        w = 1.0 / np.maximum(np.var(rc[tr], axis=0), 1e-300)
        for _ in range(2):   # weights from the residual once the fitted part is out (one iteration)
            info = float(np.sum(w * np.sum(zc[tr] ** 2, axis=0)))
            beta = float(np.sum(w * np.sum(zc[tr] * rc[tr], axis=0))) / info if info > 0.0 else 0.0
            w = 1.0 / np.maximum(np.var(rc[tr] - beta * zc[tr], axis=0), 1e-300)
        info = float(np.sum(w * np.sum(zc[tr] ** 2, axis=0)))
        pred[:, chans] = beta * zc
        name = ", ".join(f"{CHANNELS[c][0]} {CHANNELS[c][1]}" for c in chans)
        key = f"{cand['coefficient']}_{cand['unit']}" if cand["unit"] else cand["coefficient"]
        params[name] = {key: beta * cand["factor"]}
        sig[name] = {key: (1.0 / math.sqrt(info) if info > 0.0 else math.inf) * cand["factor"]}
    return pred, params, sig


def pulse_weight_in_fit(truth_fit: dict, alpha: float = ALPHA) -> dict:
    """The scale factors of the fit against the truth (:meth:`~sins_sim.navigation.truth_fit.TruthFit.to_dict`) that
    differ from zero, read as pulse-weight errors (module docstring): ``channel -> {value_ppm, sigma_ppm}``."""
    from scipy.stats import norm

    found = {}
    chans = [(s, a) for s in ("gyro", "accelerometer") for a in "xyz"]
    crit = float(norm.isf(alpha / (2.0 * len(chans))))
    for s, a in chans:
        e = truth_fit[s]["scale_factor_ppm"][a]
        if "value" in e and e["sigma"] > 0.0 and abs(e["value"]) > crit * e["sigma"]:
            found[f"{s} {a}"] = {"value_ppm": e["value"], "sigma_ppm": e["sigma"]}
    return {"effect": "pulse_weight_error", "channels": found,
            "statement": ("a pulse-weight error is its channel's scale factor, not told apart from it on a known "
                          "trajectory: it is in the fitted scale factor and in the twin, and leaves no gap; scale "
                          "factors that differ from zero (a pulse-weight error among them): " + ("; ".join(
                              f"{k} {e['value_ppm']:.4g} +- {e['sigma_ppm']:.2g} ppm" for k, e in found.items())
                              or f"no scale factor differs from zero (|S| / sigma < {crit:.3g})"))}


# --- localisation and the twin with a candidate ---------------------------------------------------------------------

def localise_moving(log_run, runs: list, alpha: float = 0.05) -> list:
    """The findings of :func:`~sins_sim.identification.twin_gap.localise` on the residual and the navigation
    against the truth (``quantities`` :data:`~sins_sim.identification.twin_gap.NAV_QUANTITIES_TRUTH`), each with
    its ``excess`` (:func:`~sins_sim.identification.twin_explain.finding_excess`)."""
    from sins_sim.identification.twin_gap import NAV_QUANTITIES_TRUTH, localise

    out = []
    for f in localise(log_run, runs, alpha=alpha, quantities=NAV_QUANTITIES_TRUTH)["findings"]:
        f = dict(f)
        if f["quantity"] == "psd_line":
            f["threshold"] = float(log_run.lines[(f["sensor"], f["axis"])].threshold)
        f["excess"] = finding_excess(f)
        out.append(f)
    return out


class _MovingTwin:
    """Runs the twin on the truth with added effects and localises it (with the bootstrap over seeds)."""

    def __init__(self, run_twin, log_run, n_seeds: int, alpha: float, rng):
        self.run_twin, self.log_run, self.alpha = run_twin, log_run, alpha
        boot = rng.integers(0, n_seeds, size=(4 * BOOTSTRAP, n_seeds))
        self.boot = boot[[len(set(b.tolist())) >= 2 for b in boot]][:BOOTSTRAP]

    def run(self, added) -> dict:
        runs = self.run_twin(None if added is None else added - added.mean(axis=0))
        findings = localise_moving(self.log_run, runs, self.alpha)
        boot = np.asarray([gap_measure(localise_moving(self.log_run, [runs[i] for i in idx], self.alpha))
                           for idx in self.boot])
        return {"findings": findings, "gap": gap_measure(findings), "boot": boot, "runs": runs}


def explain_moving(log_run, resid6, t, ideal_dth, ideal_dv, run_twin, n_seeds: int, *, truth_fit: dict | None = None,
                   alpha: float = 0.05, seed: int = 0, base_runs=None) -> dict:
    """Try the motion-excited catalogue on a moving log's twin and give the verdict (module docstring).

    Parameters
    ----------
    log_run : MovingRun
        The log on its truth, with its residual's analyses.
    resid6 : ndarray (N, 6)
        The log's residual (rate, specific force) against the truth and the twin's fitted terms.
    t : ndarray (N,)
        The truth's time axis of the intervals.
    ideal_dth, ideal_dv : ndarray (N, 3)
        The truth's exact increments.
    run_twin : callable
        ``run_twin(added (N, 6) or None) -> list of MovingRun``: the twin's seeds (always the same) with the rate
        and specific force ``added``.
    n_seeds : int
        The twin's seeds.
    truth_fit : dict, optional
        The fit against the truth (``to_dict``), for :func:`pulse_weight_in_fit`.
    alpha : float
        The localisation's false-alarm level.
    seed : int
        Of the bootstrap's resampling.
    base_runs : list of MovingRun, optional
        The plain twin's runs, if already made (``run_twin(None)``).

    Returns
    -------
    dict
        As :func:`~sins_sim.identification.twin_explain.explain_twin`'s: ``verdict``, ``candidates``, ``steps``,
        ``not_testable``, ``in_the_fit``, ``gap``, ``gap_measure``, ``heldout``, and ``findings`` (the plain twin's).
    """
    r6 = np.asarray(resid6, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64)
    n = t.size
    blocks = np.minimum((np.arange(n) * HELD_BLOCKS) // n, HELD_BLOCKS - 1)
    train = blocks % 2 == 0
    every = np.ones(n, dtype=bool)
    cands, not_testable = motion_candidates(ideal_dth, ideal_dv, t, r6)
    twin = _MovingTwin(run_twin, log_run, n_seeds, alpha, np.random.default_rng(seed))
    if base_runs is None:
        base = twin.run(None)
    else:
        findings = localise_moving(log_run, base_runs, alpha)
        base = {"findings": findings, "gap": gap_measure(findings), "runs": base_runs,
                "boot": np.asarray([gap_measure(localise_moving(log_run, [base_runs[i] for i in idx], alpha))
                                    for idx in twin.boot])}
    findings, gap0 = base["findings"], base["gap"]
    out = {"gap": gap0, "findings": findings, "not_testable": not_testable, "candidates": [], "steps": [],
           "in_the_fit": {} if truth_fit is None else {"pulse_weight_error": pulse_weight_in_fit(truth_fit)},
           "gap_measure": "sum over the findings of ln(log / envelope edge) (Allan deviation and lines of the "
                          "residual against the truth and the fitted terms; navigation: |log - mean| over the "
                          "half-width at the end)",
           "heldout": {"blocks": HELD_BLOCKS, "fit": "even blocks", "scored": "odd blocks"}}
    if not findings:
        out["verdict"] = give_twin_verdict(findings, [], [], gap0)
        return out
    select_effects(out, cands, fit_motion_candidate,
                   lambda added, rest: twin.run(added), lambda c: {ch for chs, _ in c["groups"] for ch in chs},
                   r6, train, every, blocks, base)
    return out


