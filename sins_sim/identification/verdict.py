"""The verdict of the diagnosis (step 5): how much of the gap which effects explain.

Statuses
--------
``none``
    No axis has a significant gap: the refit nominal model sits at the noise floor (the test of
    :mod:`~sins_sim.identification.detection`).
``explained``
    The selected effects bring the residual to the floor: the excess RMS they leave on every axis
    with a gap is within the significance tolerance, or below ``close_fraction`` of the excess the
    baseline left, and they remove at least ``min_gap_reduction`` of the excess power.
``partly explained``
    The best effect is significant (below) and clearly ahead of the others, and closes at least
    :data:`MIN_PARTIAL` of the gap (or, not clearly ahead, at least :data:`DOMINANT`), but not all of it: ``explained_fraction`` says how much, and
    ``remainder`` where the rest sits (axis, band, time window).
``unknown``
    No effect passes: the localisation is the answer.
    When a candidate closes at least :data:`MIN_PARTIAL` of the gap in-sample but fails the held-out test,
    ``unconfirmed`` names it: "closes 0.89 in-sample, not confirmed on held-out data (p = 0.09)", with the
    recording length that would confirm it at :data:`CONFIRM_POWER` (:func:`unconfirmed`,
    :func:`confirm_duration`).
``invalid data``
    The data checks (:mod:`sins_sim.identification.checks`) found the recording unfit to judge;
    no verdict, the ``findings`` say what is wrong, on which axis and when.

Model selection
---------------
An effect is **significant** against the model it extends (the baseline refit, or the effects
selected so far) when both tests reject "no improvement" at level :data:`ALPHA`:

1. **held-out error** (Diebold & Mariano 1995, "Comparing predictive accuracy", J. Bus. Econ.
   Stat. 13(3); with the small-sample Student-t reference of Harvey, Leybourne & Newbold 1997):
   the recording is cut into blocks, even blocks fit and odd blocks score. The loss differential
   ``d_k = ln MSE_ref,k - ln MSE_new,k`` over the ``m`` held-out blocks gives ``DM = mean(d) /
   sqrt(S / m)``, ``S`` the Newey-West long-run variance of ``d`` (Newey & West 1987; lag truncation
   ``floor(4 (m / 100)^(2/9))``, Newey & West 1994), with the Harvey-Leybourne-Newbold correction for
   that many lags, one-sided against ``t_{m-1}`` (:func:`dm_test`). The blocks are neighbours in time,
   interleaved with the blocks the models were fitted on, so their differentials may be correlated; before
   issue 39 the variance was the plain ``sd(d)^2``. On the project's generator
   (:mod:`~sins_sim.identification.calibration`) the differentials of a near-degenerate pair showed
   little correlation (lag-1 about 0.06); the false preferences there came from a candidate fit that its
   budget stopped short of its optimum, which the diagnosis now finishes before ranking. The loss is the
   logarithm of each block's mean square residual, so that the blocks count alike: a residual's envelope
   changes by orders of magnitude over a recording (a start transient, a drift), and the plain difference
   would be decided by its largest block alone. An effect that only fits noise on the training blocks
   does not lower the held-out error consistently and fails.
2. **extra sum of squares F-test on the nested models** (Bates & Watts 1988, "Nonlinear Regression
   Analysis and Its Applications", sec. 3.5; Seber & Wild 1989, sec. 5.3): every catalogue effect
   reduces to the model it extends at a parameter value (``tau_s = 0``, ``gain = 0``, ...), so
   ``F = ((RSS_ref - RSS_new) / k) / (RSS_new / (n_eff - p))`` on the training samples, with ``k``
   the effect's parameters, ``p`` all fitted parameters and ``n_eff = n / L`` the number of
   independent samples (``L`` the residual's integrated correlation length, the same inflation as
   the parameter uncertainties), against ``F(k, n_eff - p)``.

**Resolved**: a candidate whose fit lacks the feature that defines its effect (:func:`unresolved`) comes
after those whose fits show theirs. A block mode is a resonance of the mount; fitted with a damping ratio
at or above ``1/sqrt(2)`` (:data:`MODE_ZETA_MAX`) its response has no resonant peak, and its three
parameters only reshape the table motion smoothly (far above the table lines, a phase lead proportional
to frequency), which damping laws and delays do as well. Such a fit is named only when the others give no
verdict (:func:`first_step`, and :func:`resolved_first` in the greedy steps), and is no rival of one that
does.

**Parsimony** (the one-standard-error rule of Breiman, Friedman, Olshen & Stone 1984, "Classification
and Regression Trees", sec. 3.4.3; Hastie, Tibshirani & Friedman 2009, "The Elements of Statistical
Learning", sec. 7.10): the effect named first is the best-scoring candidate, unless a significant
candidate with fewer parameters predicts the held-out blocks as well, i.e. the held-out test of the best
against it does not reject at :data:`AHEAD_ALPHA`; then the one with the fewest parameters among those
(:func:`parsimonious`). Extra parameters that do not predict better are not evidence for the effect that
has them: on the rate table, a block mode's three parameters (a critically damped mode far above the
table lines is a phase lead of the table motion) can reshape the table lines as well as a damping law
does with one.

**Clearly ahead** (for ``partly explained``): the held-out test of the named candidate against the
runner-up rejects at :data:`AHEAD_ALPHA` (the runner-up: the best-scoring other candidate, leaving out
those with more parameters that parsimony set aside). Without that, two effects explain the data about as
well: the best one is kept if the greedy selection (below) adds a second effect to it (two effects
present at once each explain much of the gap alone), or alone when it is **dominant**, closing at least
:data:`DOMINANT` of the gap (:func:`keep_dominant`): then ``partly explained`` with the runner-up in
``alternatives`` and the remainder localised (issue 24: a piezo lag plus a weak axis coupling was
``unknown``); else the verdict stays ``unknown`` (the ranking is in the report).

**Plausible** (:mod:`~sins_sim.identification.plausibility`): a candidate whose fit needs values no unit
has (an effect switched on where it explains no gap, a parameter at the end of its declared range, a nominal
refit bent to a limit) comes after the plausible ones, like an unresolved one, in the first step and in
every greedy round; ``verdict.plausibility`` gives the reasons.

**Several effects** (greedy forward selection, Efroymson 1960 / Hocking 1976, "The analysis and
selection of variables in linear regression", Biometrics 32), per axis: a selected effect is kept
on the axes where it removes at least :data:`MIN_STEP` of the excess the model before it left there
(a unit can carry one effect on its x gyro and another on its y gyro); every remaining candidate is
then fitted on top of what each axis holds (on an axis that holds nothing yet that is the first
round's fit, not repeated; an axis at the floor is left alone), and the next effect is added when it
is significant against the selected model and removes at least :data:`MIN_STEP` of the excess power
that remains. At most :data:`MAX_EFFECTS` effects are selected; ``verdict.effects[i].axes`` names
the axes each is kept on.

.. autosummary::

   give_verdict
   heldout_block_losses
   dm_test
   dm_pvalue
   hac_variance
   nw_bandwidth
   f_pvalue
   assess
   unconfirmed
   confirm_duration
"""

from __future__ import annotations

import math

import numpy as np
from scipy import stats

from sins_sim.identification.refit import DiagnoseSettings, _correlation_length
from sins_sim.models.effects import EFFECTS, BlockMode
from sins_sim.units import ARCSEC

__all__ = ["ALTERNATIVE_MARGIN", "ALPHA", "AHEAD_ALPHA", "MIN_PARTIAL", "MIN_STEP", "MAX_EFFECTS", "STATUSES",
           "give_verdict", "heldout_block_losses", "dm_test", "dm_pvalue", "dm_pvalue_iid", "hac_variance",
           "nw_bandwidth", "f_pvalue", "assess", "closes", "excess_power",
           "parsimonious", "first_step", "unresolved", "resolved_first", "MODE_ZETA_MAX", "DOMINANT", "keep_dominant",
           "CONFIRM_POWER", "confirm_duration", "unconfirmed"]

#: Candidates scoring within this fraction of the best one are named as alternatives of the verdict.
ALTERNATIVE_MARGIN = 0.05
#: Level of both significance tests (held-out and nested F). 1 %: eight candidates are tried per round, so
#: the chance that one of them passes on noise alone stays below about 8 % (Bonferroni).
ALPHA = 0.01
#: Level of the held-out test of the best candidate against the runner-up (``partly explained``).
AHEAD_ALPHA = 0.05
#: Smallest fraction of the gap the best effect must close to be named when it does not close it all. A
#: quarter: the issue's two misses closed 37 % and 85 %; off-catalogue disturbances in the blind evaluation
#: get at most about 15 % from the best catalogue effect.
MIN_PARTIAL = 0.25
#: Smallest fraction of the remaining excess power a further effect of the greedy selection must remove.
MIN_STEP = 0.3
#: Smallest fraction of the gap a first effect that is not clearly ahead of its runner-up must close to be
#: named alone (``partly explained``, :func:`keep_dominant`). Four fifths: the issue's piezo lag beside a weak
#: coupling closed 0.89; an off-catalogue drive harmonic (``diagnose-eval --seed 1``) got 0.71 from
#: ``scale_factor``, tied with ``lock_in`` (at one half it was named, wrongly; before, ``unknown``).
DOMINANT = 0.8
#: Power at which :func:`unconfirmed` estimates the recording length that would confirm an in-sample candidate.
CONFIRM_POWER = 0.8
#: Most effects the greedy selection names.
MAX_EFFECTS = 3
#: The block mode's damping ratio beyond which it has no resonant peak (``BlockMode.ZETA_RESONANT_MAX``).
MODE_ZETA_MAX = BlockMode.ZETA_RESONANT_MAX
#: The statuses of a verdict.
STATUSES = ("none", "explained", "partly explained", "unknown", "invalid data")


def heldout_block_losses(fits: dict, axes, train: np.ndarray, used: np.ndarray) -> np.ndarray:
    """Mean square residual of every held-out block, summed over ``axes`` (rad^2), one entry per block."""
    held = used & ~train
    # label the contiguous held-out runs
    start = held & ~np.concatenate(([False], held[:-1]))
    label = np.cumsum(start) * held
    m = int(label.max()) if label.size else 0
    out = np.zeros(m)
    if m == 0:
        return out
    for a in axes:
        r = fits[a].residual
        ok = held & np.isfinite(r)
        sums = np.bincount(label[ok], weights=r[ok] ** 2, minlength=m + 1)[1:]
        cnt = np.bincount(label[ok], minlength=m + 1)[1:]
        out += np.where(cnt > 0, sums / np.maximum(cnt, 1), 0.0)
    return out


def nw_bandwidth(m: int) -> int:
    """Newey-West lag truncation for ``m`` loss differentials: ``floor(4 (m / 100)^(2/9))`` (Newey & West 1994,
    "Automatic lag selection in covariance matrix estimation", Rev. Econ. Stud. 61(4), the Bartlett kernel's
    rule), at least 1 and at most ``m - 2``: 2 lags for the 10 held-out blocks of a recording up to 10 s, 2 for
    20 and 3 for 43."""
    return int(max(1, min(m - 2, math.floor(4.0 * (m / 100.0) ** (2.0 / 9.0)))))


def hac_variance(d: np.ndarray, lags: int) -> float:
    """Newey-West (Bartlett-kernel) long-run variance of ``d``: ``g_0 + 2 sum_{j=1}^{L} (1 - j / (L + 1)) g_j``.

    ``g_j = (1/m) sum_{k>j} (d_k - mean)(d_{k-j} - mean)`` (Newey & West 1987, "A simple, positive semi-definite,
    heteroskedasticity and autocorrelation consistent covariance matrix", Econometrica 55(3), eq. 2); the
    Bartlett weights keep it non-negative. ``var(mean(d)) = hac_variance(d) / m``.
    """
    d = np.asarray(d, dtype=np.float64)
    m = d.size
    e = d - d.mean()
    s = float(e @ e) / m
    for j in range(1, min(lags, m - 1) + 1):
        s += 2.0 * (1.0 - j / (lags + 1.0)) * float(e[j:] @ e[:-j]) / m
    return max(s, 0.0)


def _log_differential(loss_ref, loss_new) -> np.ndarray:
    """``ln loss_ref - ln loss_new`` per block (losses floored at 1e-300, so an exact fit stays finite)."""
    tiny = 1e-300
    return (np.log(np.maximum(np.asarray(loss_ref, dtype=np.float64), tiny))
            - np.log(np.maximum(np.asarray(loss_new, dtype=np.float64), tiny)))


def dm_test(loss_ref: np.ndarray, loss_new: np.ndarray) -> dict:
    """Diebold-Mariano test of "the new model predicts the held-out blocks no better", one-sided.

    ``d_k = ln loss_ref,k - ln loss_new,k`` over the ``m`` held-out blocks. The blocks are neighbours in
    time, interleaved with the training blocks the models were fitted on, and a residual's envelope drifts
    over a recording, so the ``d_k`` are correlated; their mean's variance is the Newey-West long-run
    variance (:func:`hac_variance`) over ``m``, with the lag truncation ``L`` of :func:`nw_bandwidth`
    (Diebold & Mariano 1995, "Comparing predictive accuracy", J. Bus. Econ. Stat. 13(3), sec. 1.1, whose
    statistic uses this long-run variance). ``DM = mean(d) / sqrt(S / m)``; the small-sample correction
    of Harvey, Leybourne & Newbold 1997 ("Testing the equality of prediction mean squared errors",
    Int. J. Forecasting 13(2), eq. 9) for a differential correlated over ``h - 1 = L`` lags,
    ``DM* = DM sqrt((m + 1 - 2h + h (h - 1) / m) / m)``, against Student's t with ``m - 1`` degrees of freedom.

    Returns ``statistic`` (DM*), ``p`` (one-sided), ``m``, ``lags``. Fewer than 3 blocks: ``p = 1``.
    """
    d = _log_differential(loss_ref, loss_new)
    m = d.size
    if m < 3:
        return {"statistic": math.nan, "p": 1.0, "m": m, "lags": 0}
    lags = nw_bandwidth(m)
    mean = float(np.mean(d))
    var = hac_variance(d, lags)
    if var <= 0.0:
        return {"statistic": math.copysign(math.inf, mean) if mean else 0.0, "p": 0.0 if mean > 0.0 else 1.0,
                "m": m, "lags": lags}
    h = lags + 1
    t = mean / math.sqrt(var / m) * math.sqrt(max(m + 1.0 - 2.0 * h + h * (h - 1.0) / m, 1.0) / m)
    return {"statistic": t, "p": float(stats.t.sf(t, m - 1)), "m": m, "lags": lags}


def dm_pvalue(loss_ref: np.ndarray, loss_new: np.ndarray) -> float:
    """One-sided p-value of "the new model predicts the held-out blocks no better" (:func:`dm_test`)."""
    return dm_test(loss_ref, loss_new)["p"]


def dm_pvalue_iid(loss_ref: np.ndarray, loss_new: np.ndarray) -> float:
    """The held-out test before issue 39: ``t = mean(d) / (sd(d) / sqrt(m))`` against ``t_{m-1}``, the blocks
    taken as independent. Kept to measure its calibration against :func:`dm_pvalue`
    (:mod:`~sins_sim.identification.calibration`). Fewer than 3 blocks: 1.
    """
    d = _log_differential(loss_ref, loss_new)
    m = d.size
    if m < 3:
        return 1.0
    sd = float(np.std(d, ddof=1))
    mean = float(np.mean(d))
    if sd == 0.0:
        return 0.0 if mean > 0.0 else 1.0
    return float(stats.t.sf(mean / (sd / math.sqrt(m)), m - 1))


def _train_rss(fits: dict, axes, train: np.ndarray):
    """Training residual sum of squares and effective sample count over ``axes``."""
    rss, n_eff = 0.0, 0.0
    for a in axes:
        r = fits[a].residual[train]
        r = r[np.isfinite(r)]
        rss += float(np.sum(r * r))
        n_eff += r.size / _correlation_length(r)
    return rss, n_eff


def f_pvalue(rss_ref: float, rss_new: float, k: int, p: int, n_eff: float) -> float:
    """p-value of the extra-sum-of-squares F-test of nested models (Bates & Watts 1988, sec. 3.5)."""
    dof = n_eff - p
    if k < 1 or dof < 1 or rss_new <= 0.0:
        return 1.0 if rss_new >= rss_ref else 0.0
    f = ((rss_ref - rss_new) / k) / (rss_new / dof)
    return float(stats.f.sf(f, k, dof)) if f > 0 else 1.0


def assess(candidates: list, ref_fits: dict, sig_axes: list, train: np.ndarray, used: np.ndarray,
           n_ref_params) -> None:
    """Add the held-out and F-test p-values and ``significant`` to every candidate (in place).

    ``ref_fits`` is the model the candidates extend; ``n_ref_params`` its fitted parameters per axis
    (a number, or axis -> number). A candidate adds ``n_params`` on each of its ``n_axes`` axes
    (default: every axis of ``sig_axes``).
    """
    ref_loss = heldout_block_losses(ref_fits, sig_axes, train, used)
    ref_rss, _ = _train_rss(ref_fits, sig_axes, train)
    n_ref = n_ref_params if isinstance(n_ref_params, dict) else {a: n_ref_params for a in sig_axes}
    for c in candidates:
        loss = heldout_block_losses(c["fits"], sig_axes, train, used)
        rss, n_eff = _train_rss(c["fits"], sig_axes, train)
        k = c.get("n_params", 1) * c.get("n_axes", len(sig_axes))
        p = sum(n_ref[a] for a in sig_axes) + k
        c["_losses"] = loss
        dm = dm_test(ref_loss, loss)
        c["p_heldout"], c["t_heldout"], c["m_heldout"] = dm["p"], dm["statistic"], dm["m"]
        c["p_f"] = f_pvalue(ref_rss, rss, k, p, n_eff)
        c["unresolved"] = unresolved(c, ref_fits, sig_axes)
        c["significant"] = bool(c["p_heldout"] < ALPHA and c["p_f"] < ALPHA and c["gap_reduction"] > 0.0)


def resolved_first(candidates: list) -> list:
    """``candidates`` (best first) with those lacking their effect's defining feature after the others."""
    return [c for c in candidates if not c.get("unresolved")] + [c for c in candidates if c.get("unresolved")]


def unresolved(c: dict, ref_fits: dict, axes) -> str | None:
    """Why a candidate's fit lacks the feature that defines its effect, or ``None`` (see "Resolved").

    Asked of the effect class (``Effect.unresolved``) on the axis where the candidate removes the most
    residual power.
    """
    effect_cls = EFFECTS.get(c["effect"])
    if effect_cls is None or not axes:
        return None
    main = max(axes, key=lambda a: ref_fits[a].rms ** 2 - c["fits"][a].rms ** 2)
    return effect_cls.unresolved(main, c["params"].get(main, {}))


def excess_power(fit, floor: dict) -> float:
    """A fit's residual power above the noise floor (rad^2, at least 0); ``floor`` from ``noise_floor``."""
    return max(0.0, fit.rms ** 2 - floor["floor_rad"] ** 2)


def closes(remaining: dict, excess0: dict, tol: dict, settings: DiagnoseSettings) -> bool:
    """Whether the excess left on every axis (rad RMS) is within the tolerance or ``close_fraction`` of the start."""
    return all(remaining[a] <= max(tol[a], settings.close_fraction * math.sqrt(excess0[a])) for a in remaining)


def give_verdict(fits: dict, sig_axes: list, candidates: list, settings: DiagnoseSettings,
                 steps: list | None = None, remainder: dict | None = None, duration_s: float | None = None) -> dict:
    """The verdict from the baseline refit, the ranked first-round candidates and the greedy steps.

    Parameters
    ----------
    fits : dict
        The baseline refit per axis (``AxisFit``).
    sig_axes : list of str
        The axes with a significant gap (none: the verdict is ``none``).
    candidates : list of dict
        The first-round candidates (:func:`sins_sim.identification.explain.explain`, with
        :func:`assess`), best first.
    settings : DiagnoseSettings
    steps : list of dict or None
        The effects the greedy selection added, in order: ``effect``, ``explained_fraction`` (of the
        baseline's excess power, this step's share), ``params``, ``uncertainty``, ``closes_gap``
        (the selected model closes the gap), ``p_heldout``, ``p_f``. ``None``: decided from
        ``candidates`` alone (first round).
    remainder : dict or None
        Where the excess left by the selected model sits (axis, band, time window).
    duration_s : float or None
        The recording's length: with it, a verdict ``unknown`` names the candidate that closes the gap
        in-sample but fails the held-out test, with the length that would confirm it (:func:`unconfirmed`).

    Returns
    -------
    dict
        ``effect`` (``none``, the first selected effect or ``unknown``), ``status`` (:data:`STATUSES`),
        ``explained_fraction`` (of the baseline's excess power, all selected effects), ``gap_reduction``
        (the same, kept for older readers), ``effects`` (the selected effects in order),
        ``alternatives``, ``remainder``, ``baseline_score`` (held-out RMS of the baseline, arcsec),
        ``criterion`` (the selection rule in words); for ``unknown``, ``unconfirmed`` (:func:`unconfirmed`,
        or ``None``).
    """
    base_held = math.sqrt(np.mean([fits[a].heldout_rms ** 2 for a in sig_axes])) if sig_axes else math.nan
    criterion = (f"held-out Diebold-Mariano and nested F-test at {ALPHA:g}; partly explained when >= {MIN_PARTIAL:g} "
                 f"of the gap is closed and the runner-up is worse on held-out data at {AHEAD_ALPHA:g}; greedy "
                 f"steps remove >= {MIN_STEP:g} of what remains")
    out = {"criterion": criterion, "remainder": None, "effects": [], "alternatives": []}
    if not sig_axes:
        out.update(effect="none", status="none", explained_fraction=0.0, gap_reduction=0.0, baseline_score=None)
        return out
    out["baseline_score"] = base_held / ARCSEC
    if steps is None:
        steps = first_step(candidates, base_held, settings)
    steps = keep_dominant(steps)  # a lone tentative first effect is named only when dominant
    if not steps:
        best = candidates[0] if candidates else None
        out.update(effect="unknown", status="unknown", explained_fraction=0.0,
                   gap_reduction=best["gap_reduction"] if best else 0.0, remainder=remainder,
                   plausibility=_plausibility([], candidates),
                   unconfirmed=unconfirmed(candidates, duration_s) if duration_s else None)
        return out
    total = float(sum(s["explained_fraction"] for s in steps))
    done = steps[-1]["closes_gap"] and total >= settings.min_gap_reduction
    best = next((c for c in candidates if c["effect"] == steps[0]["effect"]), candidates[0])
    alts = []
    if len(steps) == 1 and steps[0].get("tentative") and steps[0].get("rival"):
        alts = [steps[0]["rival"]]  # dominant, but the held-out data do not put it clearly ahead of this one
    elif done and len(steps) == 1:
        # effects the data cannot tell from the best one: they close the gap as well and score
        # within ALTERNATIVE_MARGIN of it
        alts = [c["effect"] for c in candidates if c is not best and c["closes_gap"]
                and (best.get("unresolved") or not c.get("unresolved"))
                and c["score"] <= best["score"] * (1.0 + ALTERNATIVE_MARGIN)]
    out.update(effect=steps[0]["effect"], status="explained" if done else "partly explained",
               explained_fraction=min(1.0, total), gap_reduction=min(1.0, total), alternatives=alts,
               effects=[{**{k: s[k] for k in ("effect", "explained_fraction", "params", "uncertainty", "p_heldout",
                                              "p_f")}, "axes": list(s.get("axes") or s["params"])} for s in steps],
               remainder=None if done else remainder,
               plausibility=_plausibility(steps, candidates))
    return out


def confirm_duration(t_observed: float, m: int, duration_s: float, alpha: float = ALPHA,
                     power: float = CONFIRM_POWER) -> float | None:
    """The recording length (s) at which the held-out test would reject at ``alpha`` with probability ``power``.

    For an effect of fixed size the loss differential's mean is fixed and its standard error falls as
    ``1 / sqrt(n)`` (more held-out blocks, or longer ones averaging more samples), so the statistic grows as
    ``sqrt(n)``: ``E[DM](n') = t_obs sqrt(n' / n)``. The test rejects when ``DM > c``, ``c`` the one-sided
    ``t_{m-1}`` critical value at ``alpha`` (kept at this recording's ``m``: a longer recording has at least
    as many blocks, so ``c`` only falls, and the length is an upper estimate); with ``DM`` about normal with
    unit variance around its mean, ``P(DM > c) = power`` when ``E[DM] = c + z_power``:

    ``n' = n ((c + z_power) / t_obs)^2`` (the usual sample-size rule, e.g. Chow, Shao & Wang 2008, "Sample
    Size Calculations in Clinical Research", sec. 3.1, with the observed standardised effect in place of the
    assumed one). ``t_obs`` is itself estimated from the fit, so the length is an estimate of the same
    precision. ``None`` when ``t_obs <= 0``: the held-out blocks show no improvement, and no length follows.
    """
    if not (math.isfinite(t_observed) and t_observed > 0.0) or m < 3:
        return None
    c = float(stats.t.isf(alpha, m - 1))
    return float(duration_s * ((c + float(stats.norm.ppf(power))) / t_observed) ** 2)


def unconfirmed(candidates: list, duration_s: float) -> dict | None:
    """The candidate a verdict ``unknown`` names as shown in-sample but not confirmed on held-out data.

    The first candidate (in the ranking: plausible and resolved before the others, then by held-out score)
    that closes at least :data:`MIN_PARTIAL` of the gap in-sample (``gap_reduction``, the training and held-out
    samples together) and fails the held-out test at :data:`ALPHA`. Returns ``effect``,
    ``in_sample_fraction``, ``p_heldout``, ``alpha``, ``params``, ``uncertainty``, ``duration_s`` (the
    recording's), ``confirm_duration_s`` (:func:`confirm_duration` at :data:`CONFIRM_POWER`, or ``None``),
    ``power`` and ``message``; ``None`` when no candidate qualifies.
    """
    ranked = sorted(candidates, key=lambda c: (bool(c.get("unresolved")),
                                               not c.get("plausibility", {}).get("plausible", True), c["score"]))
    c = next((c for c in ranked if c["gap_reduction"] >= MIN_PARTIAL and c.get("p_heldout", 1.0) >= ALPHA), None)
    if c is None:
        return None
    need = confirm_duration(c.get("t_heldout", math.nan), int(c.get("m_heldout", 0)), duration_s)
    msg = (f"{c['effect']} closes {c['gap_reduction']:.2f} in-sample, not confirmed on held-out data "
           f"(p = {c['p_heldout']:.2g})")
    if need is None:
        msg += "; its held-out blocks show no improvement, so no longer recording is predicted to confirm it"
    else:
        msg += (f"; a recording of about {need:.3g} s would confirm it at power {CONFIRM_POWER:g} (level "
                f"{ALPHA:g}), were the effect as large as this fit says")
    return {"effect": c["effect"], "in_sample_fraction": float(c["gap_reduction"]), "p_heldout": float(c["p_heldout"]),
            "alpha": ALPHA, "params": c["params"], "uncertainty": c["uncertainty"], "duration_s": float(duration_s),
            "confirm_duration_s": need, "power": CONFIRM_POWER, "message": msg}


def _plausibility(steps: list, candidates: list) -> dict:
    """The verdict's ``plausibility``: the named effects' (``plausible``, ``reasons``) and the candidates
    ranked after the plausible ones, with their reasons."""
    named = {s["effect"]: s.get("plausibility") or {"plausible": True, "reasons": []} for s in steps}
    aside = [{"effect": c["effect"], "reasons": c["plausibility"]["reasons"]} for c in candidates
             if not c.get("plausibility", {}).get("plausible", True)]
    return {"named": named, "ranked_after": aside}


def parsimonious(candidates: list) -> dict | None:
    """The candidate the verdict names first (see "Parsimony" in the module docstring).

    ``candidates`` best-scoring first, with ``n_params``, ``significant`` and the held-out block losses
    ``_losses`` (:func:`assess`). The best-scoring one, unless significant candidates with fewer parameters
    are within reach of it (``dm_pvalue(theirs, best) >= AHEAD_ALPHA``): then the one among those with the
    fewest parameters (then the best score).
    """
    if not candidates:
        return None
    best = candidates[0]
    equal = [c for c in candidates[1:] if c.get("significant") and c.get("n_params", 1) < best.get("n_params", 1)
             and dm_pvalue(c["_losses"], best["_losses"]) >= AHEAD_ALPHA]
    if not equal:
        return best
    return min(equal, key=lambda c: (c.get("n_params", 1), c["score"]))


def first_step(candidates: list, base_held: float, settings: DiagnoseSettings) -> list:
    """The first effect of the selection (a one-element list) or ``[]`` (see the module docstring).

    Candidates whose fit lacks the feature defining their effect, and implausible ones
    (:mod:`~sins_sim.identification.plausibility`), are left out (they are no rivals either); only when
    the others give no first step are they considered too: first the plausible resolved ones, then all
    resolved ones, then all.
    """
    candidates = sorted(candidates, key=lambda c: c["score"])  # best-scoring first (the list may be re-ranked)
    resolved = [c for c in candidates if not c.get("unresolved")]
    tiers = [[c for c in resolved if c.get("plausibility", {}).get("plausible", True)], resolved]
    for tier in tiers:
        if len(tier) < len(candidates):
            step = _first_step(tier, base_held, settings)
            if step:
                return step
    return _first_step(candidates, base_held, settings)


def keep_dominant(steps: list) -> list:
    """The greedy selection's steps, less a lone tentative first step that is not dominant.

    A first effect that is not clearly ahead of its runner-up (tentative) and that no second effect
    joined is still named (``partly explained``) when it closes at least :data:`DOMINANT` of the gap: it
    then explains nearly all of it, and its runner-up is named beside it as an
    alternative (issue 24: a piezo lag plus a weak axis coupling ended as ``unknown`` with 0.89 of the gap
    closed by the lag). Below that the verdict stays ``unknown``.
    """
    if len(steps) == 1 and steps[0].get("tentative") and steps[0]["explained_fraction"] < DOMINANT:
        return []
    return steps


def _first_step(candidates: list, base_held: float, settings: DiagnoseSettings) -> list:
    if not candidates:
        return []
    best = parsimonious(candidates)
    if not best.get("significant") or best["score"] >= base_held / ARCSEC:
        return []
    frac = max(0.0, best["gap_reduction"])
    full = best["closes_gap"] and frac >= settings.min_gap_reduction
    if not full:
        if frac < MIN_PARTIAL:
            return []
        i = next(j for j, c in enumerate(candidates) if c is best)
        # the runner-up: the best-scoring other candidate, without those ahead of ``best`` that parsimony
        # sets aside (more parameters and not clearly better)
        rivals = [c for c in candidates[:i] if c.get("n_params", 1) <= best.get("n_params", 1)
                  or dm_pvalue(best["_losses"], c["_losses"]) < AHEAD_ALPHA] + candidates[i + 1:]
        runner = rivals[0] if rivals else None
        if runner is not None and dm_pvalue(runner["_losses"], best["_losses"]) >= AHEAD_ALPHA:
            # not clearly ahead: named only if the greedy selection then adds a second effect (a pair
            # whose members each explain much of the gap), or if it is dominant (keep_dominant)
            return [_step(best, frac, full, tentative=True, rival=runner["effect"])]
    return [_step(best, frac, full)]


def _step(c: dict, frac: float, closes_gap: bool, tentative: bool = False, rival: str | None = None) -> dict:
    return {"tentative": tentative, "effect": c["effect"], "explained_fraction": float(frac), "params": c["params"],
            "uncertainty": c["uncertainty"], "p_heldout": c.get("p_heldout"), "p_f": c.get("p_f"),
            "closes_gap": bool(closes_gap), "fits": c["fits"], "rival": rival,
            "plausibility": c.get("plausibility")}
