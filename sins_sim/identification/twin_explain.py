"""Explain and shrink the gap between a log at rest and its twin, and the verdict, in the channel diagnosis's words.

:mod:`~sins_sim.identification.twin_gap` localises where the log leaves its twin's envelope (the **findings**). This
module tries the SINS-level effects of a catalogue on them, one at a time and then greedily together, and says how
far each shrinks the gap.

Catalogue (at rest; each a rate or specific force added to the twin, :mod:`sins_sim.simulation.twin_effects`)
--------------------------------------------------------------------------------------------------------------
``base_motion_line``
    A sway (below :data:`SWAY_MAX_HZ`) or vibration line, proposed for each spectral-line finding: ``A sin(2 pi f t
    + phi)`` on the finding's sensor axis, its interval mean ``A (cos(w (t - dt) + phi) - cos(w t + phi)) / (w dt)``;
    ``f`` refined over the finding's band, ``A`` and ``phi`` by linear least squares (the sine and cosine
    regressors), the amplitude's sigma the white-noise least-squares one.
``bias_step``
    ``d H(t - t_s)`` on the axis of a bias-step finding: ``t_s`` over every sample boundary (5 % margins), ``d`` the
    difference of the means after and before (least squares, the two means).
``bias_drift``
    A ramp ``r (t - t_mid)`` on the axes whose Allan deviation lies above the twin's band (a trend raises the Allan
    deviation as ``r tau / sqrt(2)``, IEEE Std 952-1997, Annex C), and on the three gyros where the navigation
    leaves its envelope. Its sigma (and the temperature coefficient's) is the white-noise least-squares one, which
    a random walk makes too small: the held-out test, not the sigma, decides whether it is named.
``temperature``
    ``k (T - T_mean)`` on the axes with a significant temperature coefficient, from the log's ``temperature_c``.
``timing_jitter``
    The log's own intervals ``dt_i`` (its time column) against the nominal ``dt``: a unit that integrates over
    ``dt_i`` and is divided by ``dt`` reads its rate and force times ``dt_i / dt``, so ``g (m_c (dt_i - dt) / dt)``
    on every axis (``m_c`` the axis's mean), the gain ``g`` (1 for a real interval error, 0 for a time stamp's
    jitter) fitted by weighted least squares. Gaps (intervals off by more than 0.1 %) are refused before (``invalid
    data``). An ``import-log`` table holds its grid times, so only a plain increments file's own time column can
    show jitter.

Not testable at rest, and said so (``not_testable``): **scale-factor asymmetry** (needs rates of both signs),
**coning and sculling residue** (needs coning or sculling motion), and a **pulse-weight error** or a **rate off its
nominal** (the log's clock): at rest either is a scale on the Earth's rate and gravity, which the rest biases the
twin carries already absorb; the implied scale ``b_D / g`` (accelerometers) and ``b_N / (Omega cos L)`` (gyros) is
given with its sigma, and the two agree for a clock off its nominal.

The gap measure
---------------
Each finding's **excess** (dimensionless, natural log of the log's reading over the envelope's edge, so that an
Allan deviation, a line and a navigation error add in one unit):

* Allan deviation: ``ln(log / hi)`` above the band, ``ln(lo / log)`` below, at the worst tau;
* spectral line: ``ln(snr / threshold)`` (the line's power over its local floor, beyond the detection threshold);
* navigation: ``ln(|log - mean| / halfwidth)`` at the log's end;
* bias step: ``ln(|z| / threshold)``;
* noise level (:func:`noise_level_findings`, a finding of the log alone): ``ln(ratio / hi)`` or ``ln(lo / ratio)``.

The **gap** ``G`` is their sum; zero when the log stays in its envelope. A candidate's **shrink** is ``1 - G_c /
G_0`` (``G_c`` with the candidate added to the twin, the twin's noise terms refitted on the log less the candidate's fitted
part, re-simulated over the twin's seeds and localised again; the candidate enters less its mean, which the twin's
biases hold already); its
uncertainty is the standard deviation over :data:`BOOTSTRAP` resamplings of the twin's seeds with replacement (paired:
the same resampling for the twin with and without the candidate; Efron and Tibshirani 1993, "An Introduction to the
Bootstrap", ch. 6). A bias-step finding is gone when the twin with the candidate has its most likely step (the scan's best boundary,
found or not: a step the log shows just above the threshold is found in only about half of the twin's runs) at the
same time (within two of the scan's resolutions) and with the same sign in at least half its seeds, as a line
finding is; the plain twin's best boundary falls there by chance in about 5 of the scan's ~180 boundaries a seed.

Held-out check
--------------
The log is cut into :data:`HELD_BLOCKS` blocks; every candidate is fitted again on the even blocks alone, and on the
odd blocks the loss of each block is the mean square of ``y - c - p(t)`` over the candidate's axes (each axis
normalised by its variance; ``c`` the even blocks' mean of ``y - p``). The baseline (the twin, ``p = 0``) and the
candidate are compared by the Diebold-Mariano test on the log losses with the Newey-West variance and the
Harvey-Leybourne-Newbold correction (:func:`sins_sim.identification.verdict.dm_test`), at :data:`ALPHA`, as in the
channel diagnosis.

Selection and verdict (:func:`choose_step`, :func:`give_twin_verdict`)
---------------------------------------------------------------------
Greedy forward selection (as the channel diagnosis's): the first effect is the significant candidate (held-out p <
:data:`ALPHA`) that shrinks the gap most, if it removes at least :data:`MIN_PARTIAL` of it; each further one is
fitted on top of those selected (the log less their fitted part), re-simulated with them, and added when it is
significant against the selected model, removes at least one finding, and brings the gap down by at least
:data:`MIN_STEP` of what the findings it removes held (the one that brings it down most is taken); at most
:data:`MAX_EFFECTS`. The further step is judged against its own findings and not against all that remain: the gap
is a sum over findings in different places, so with ``m`` findings of like size left a candidate for one of them
removes ``1 / m`` of the remainder, and a rule of :data:`MIN_STEP` of the remainder (the channel diagnosis's, where
the remainder is one axis's residual) stopped at ``m >= 4`` however clearly each was explained (the bundled log's
still start: 0.38 of the gap named, nine lines on the z gyro of 0.6-1.7 each left, none reaching 0.3 of 8.2). Two candidates **explain it alike** when they remove a finding in common and the held-out test
of the better against the other does not reject at :data:`AHEAD_ALPHA`: the other is named in ``alternatives``; the
first is then named only when it closes the gap or removes at least :data:`DOMINANT` of it (a later step: of what
its findings held).

Statuses (:data:`sins_sim.identification.verdict.STATUSES`): ``none`` (no finding), ``explained`` (the selected
effects leave no finding), ``partly explained`` (at least :data:`MIN_PARTIAL` removed, findings remain: the fraction
and the ``remainder``), ``unknown`` (``band``: the findings that no candidate shrinks, or all of them; ``unconfirmed``:
a candidate that shrinks the gap in-sample but fails the held-out test), ``invalid data`` (:func:`invalid_data`: the
log's refusals, e.g. gaps in its time column or a unit that moves).

.. autosummary::

   explain_twin
   noise_level_findings
   finding_excess
   gap_measure
   choose_step
   give_twin_verdict
   invalid_data
   fit_line
   fit_step
   fit_ramp
   heldout_losses
"""

from __future__ import annotations

import math

import numpy as np

from sins_sim.identification.verdict import AHEAD_ALPHA, ALPHA, DOMINANT, MAX_EFFECTS, MIN_PARTIAL, MIN_STEP, dm_test
from sins_sim.units import DEG_PER_H, MICRO_G

__all__ = ["BOOTSTRAP", "CHANNELS", "HELD_BLOCKS", "NOT_TESTABLE_AT_REST", "SWAY_MAX_HZ", "choose_step",
           "explain_twin", "finding_excess", "finding_key", "finding_place", "select_effects", "verdict_of_steps", "noise_level_findings", "LEVEL_ALPHA", "LEVEL_BLOCKS", "fit_line", "fit_ramp", "fit_step", "gap_measure",
           "give_twin_verdict", "heldout_losses", "invalid_data", "localise_with_steps"]

#: The six axes of a log, in the column order of the added rate and force.
CHANNELS = (("gyro", "x"), ("gyro", "y"), ("gyro", "z"), ("accelerometer", "x"), ("accelerometer", "y"),
            ("accelerometer", "z"))
#: Blocks of the held-out check (even ones fit, odd ones score): 20 held-out blocks for the Diebold-Mariano test; short,
#: so that a step that falls in a held-out block (its time unknown there to the block) spoils few of them.
HELD_BLOCKS = 40
#: Resamplings of the twin's seeds for the shrink's uncertainty.
BOOTSTRAP = 50
#: A base-motion line below this frequency is called sway, above it vibration.
SWAY_MAX_HZ = 2.0
#: Frequencies tried across a line's band: at least this many, a quarter of the log's resolution ``1 / T`` apart, at
#: most :data:`MAX_LINE_GRID`.
LINE_GRID = 41
MAX_LINE_GRID = 2000
#: A sinusoid's Allan deviation peaks at ``tau = 0.371 / f`` (``sigma^2 = Omega^2 (sin^2(pi f tau) / (pi f tau))^2``,
#: IEEE Std 952-1997, Annex C, C.7): a line below the PSD's search band is sought across the band an Allan bump
#: spans, widened by this factor each side.
ALLAN_LINE_TAU = 0.371
ALLAN_LINE_WIDEN = 2.0
#: Fraction of the log at each end where a step is not tried (as the step scan).
STEP_MARGIN = 0.05
#: Blocks of the noise-level scan (:func:`noise_level_findings`) and its chance of a false finding per log.
LEVEL_BLOCKS = 20
LEVEL_ALPHA = 0.01
#: The catalogue's effects that a log at rest cannot test, and why.
NOT_TESTABLE_AT_REST = {
    "scale_factor_asymmetry": "needs rates of both signs well above the Earth's rate; a log at rest has none",
    "coning_sculling_residue": "needs coning or sculling motion; a log at rest has none",
}
_UNIT = {"gyro": ("deg_h", 1.0 / DEG_PER_H), "accelerometer": ("ug", 1.0 / MICRO_G)}


# --- the gap measure -----------------------------------------------------------------------------------------------

def finding_excess(f: dict) -> float:
    """A finding's excess beyond its envelope's edge (module docstring), >= 0.

    Needs the finding's own readings: Allan (``log_*`` and ``band_*``), line (``snr`` and ``threshold``), navigation
    (``log_at_end_*``, ``twin_mean_at_end_*``, ``twin_halfwidth_at_end_*``), bias step (``z`` and ``threshold``).
    """
    q = f["quantity"]
    if q == "allan_deviation":
        log = next(v for k, v in f.items() if k.startswith("log_"))
        lo, hi = next(v for k, v in f.items() if k.startswith("band_"))
        e = math.log(log / hi) if f["side"] == "above" else math.log(lo / log)
    elif q == "psd_line":
        e = math.log(f["snr"] / f["threshold"])
    elif q == "navigation":
        log = next(v for k, v in f.items() if k.startswith("log_at_end_"))
        mean = next(v for k, v in f.items() if k.startswith("twin_mean_at_end_"))
        half = next(v for k, v in f.items() if k.startswith("twin_halfwidth_at_end_"))
        # a twin without spread there (its seeds alike, e.g. a channel quiet within its quantum) has an edge of
        # zero width: read against a billionth of the values instead, so the gap stays finite (about 21 at most)
        edge = max(half, 1e-9 * max(abs(log), abs(mean)), 1e-300)
        e = math.log(abs(log - mean) / edge) if abs(log - mean) > 0.0 else 0.0
    elif q == "bias_step":
        e = math.log(abs(f["z"]) / f["threshold"])
    elif q == "noise_level":
        lo, hi = f["band"]
        e = math.log(f["ratio"] / hi) if f["side"] == "above" else math.log(lo / f["ratio"])
    else:
        raise ValueError(f"finding: unknown quantity {q!r}")
    return max(0.0, float(e))


def gap_measure(findings: list) -> float:
    """The gap ``G``: the sum of the findings' excesses (:func:`finding_excess`)."""
    return float(sum(finding_excess(f) for f in findings))


def finding_key(f: dict) -> tuple:
    """What identifies a finding across twins (its quantity and place, not its readings)."""
    q = f["quantity"]
    if q == "allan_deviation":
        return (q, f["sensor"], f["axis"], f["side"])
    if q == "psd_line":
        return (q, f["sensor"], f["axis"], round(f["frequency_hz"] / max(f["band_hz"][1] - f["frequency_hz"], 1e-12)))
    if q == "navigation":
        return (q, f["what"])
    if q == "noise_level":
        return (q, f["sensor"], f["axis"], f["side"], round(f["time_s"][0], 6))
    return (q, f["sensor"], f["axis"])


def finding_place(f: dict) -> dict:
    """Where a finding sits: quantity, sensor axis, band and time, for the verdict's ``band`` and ``remainder``."""
    out = {k: f[k] for k in ("quantity", "sensor", "axis", "side", "tau_range_s", "band_hz", "what", "leaves_at_s",
                              "time_s") if k in f}
    out["excess"] = finding_excess(f)
    out["statement"] = f["statement"]
    return out


# --- the noise level over time ------------------------------------------------------------------------------------

def noise_level_findings(y6, fs: float, alpha: float = LEVEL_ALPHA, blocks: int = LEVEL_BLOCKS) -> list:
    """Where a log's white-noise level changes over time (a finding kind of the log alone; the twin's noise is
    stationary, so no candidate of the catalogue removes it).

    Per axis, the variance ``s_k^2`` of the first differences of the rate (or specific force) in each of ``blocks``
    blocks, against the median over the blocks. A first difference keeps the white noise (variance ``2 sigma^2``)
    and suppresses what is slow: a line of frequency ``f`` by ``2 sin(pi f / fs)``, a bias step to one sample. The
    differences of white noise are an MA(1) with lag-one correlation -1/2, so a block's sample variance has
    ``(m - 1) / 1.5`` equivalent degrees of freedom (``var s^2 = 2 s^4 (1 + 2 rho_1^2) / m``; Priestley 1981,
    "Spectral Analysis and Time Series", sec. 5.3.2), and the median of ``K`` blocks the share ``2 / pi`` of the
    mean's (its efficiency for a normal scale; Kendall and Stuart, vol. 1, sec. 10.10): the ratio is read against
    ``F(edf, 2 K edf / pi)``, two-sided at ``alpha / (6 K)`` (Bonferroni over the axes and blocks). A run of blocks
    outside on one side is one finding, with its time window.
    """
    from scipy.stats import f as f_dist

    from sins_sim.identification.twin_gap import _runs

    y6 = np.asarray(y6, dtype=np.float64)
    n = y6.shape[0]
    m = n // blocks
    if m < 20:
        return []
    d = np.diff(y6[:m * blocks], axis=0)
    d = np.vstack([d, d[-1:]]).reshape(blocks, m, 6)
    var = d.var(axis=1, ddof=1)                                             # (blocks, 6)
    edf = (m - 1) / 1.5
    a = alpha / (2.0 * 6.0 * blocks)
    lo, hi = f_dist.ppf(a, edf, 2.0 * blocks * edf / math.pi), f_dist.isf(a, edf, 2.0 * blocks * edf / math.pi)
    out = []
    for ch, (sensor, ax) in enumerate(CHANNELS):
        med = float(np.median(var[:, ch]))
        if not med > 0.0:     # a channel quiet within its quantum in most blocks: its level is not testable
            continue
        ratio = np.maximum(var[:, ch] / med, 1e-300)
        flags = np.where(ratio > hi, 1, np.where(ratio < lo, -1, 0))
        for i, j in _runs(flags, bridge=0):
            k = i + int(np.argmax(np.abs(np.log(ratio[i:j + 1]))))
            side = "above" if flags[i] > 0 else "below"
            window = [i * m / fs, (j + 1) * m / fs]
            out.append({"quantity": "noise_level", "sensor": sensor, "axis": ax, "side": side, "time_s": window,
                        "ratio": float(ratio[k]), "band": [float(lo), float(hi)],
                        "statement": (f"{sensor} {ax}: the white noise level lies {side} its median from "
                                      f"{window[0]:.4g} s to {window[1]:.4g} s (variance {ratio[k]:.3g} times the "
                                      f"median; band {lo:.3g} to {hi:.3g})")})
    return out


# --- localisation with the log's bias steps -----------------------------------------------------------------------

def _scan(values, fs: float, ch: int, alpha: float):
    from sins_sim.navigation.temperature_fit import scan_bias_step

    try:
        return scan_bias_step(values[:, ch], fs, sensor="gyro" if ch < 3 else "accel", alpha=alpha)
    except (np.linalg.LinAlgError, ValueError):
        return None


def localise_with_steps(log_run, runs: list, step_findings: list, scans: list, alpha: float = 0.05,
                        level_findings=()) -> list:
    """The findings of :func:`~sins_sim.identification.twin_gap.localise` (with the readings
    :func:`finding_excess` needs) and the log's bias steps that the twin does not show.

    Parameters
    ----------
    log_run : RestRun
    runs : list of RestRun
        The twin's seeds.
    step_findings : list of dict
        The log's bias steps (``sensor``, ``axis``, ``time_s``, ``time_resolution_s``, ``z``, ``threshold``).
    scans : list of dict
        Per seed, ``channel index -> StepScan`` of the twin's record on the steps' axes (None: not scannable).
    alpha : float
        The localisation's false-alarm level.
    level_findings : list of dict
        The log's noise-level findings (:func:`noise_level_findings`): kept whatever the twin (its noise is
        stationary).
    """
    from sins_sim.identification.twin_gap import localise

    gap = localise(log_run, runs, alpha=alpha)
    out = []
    for f in gap["findings"]:
        f = dict(f)
        if f["quantity"] == "psd_line":
            f["threshold"] = float(log_run.lines[(f["sensor"], f["axis"])].threshold)
        f["excess"] = finding_excess(f)
        out.append(f)
    for f in step_findings:
        ch = CHANNELS.index((f["sensor"], f["axis"]))
        hits = 0
        for sc in scans:
            s = sc.get(ch)
            hits += bool(s is not None and abs(s.time_s - f["time_s"]) <= 2.0 * f["time_resolution_s"]
                         and np.sign(s.size) == np.sign(f["z"]))
        if 2 * hits >= len(scans):
            continue
        out.append({**f, "twin_seeds_with_step": hits, "excess": finding_excess(f)})
    out += [{**f, "excess": finding_excess(f)} for f in level_findings]
    return out


# --- fitting the candidates ------------------------------------------------------------------------------------------

def _sin_cos(t, dt: float, f_hz: float) -> tuple:
    """Interval means of ``sin(w t)`` and ``cos(w t)`` over ``(t - dt, t]``."""
    w = 2.0 * math.pi * f_hz
    s = (np.cos(w * (t - dt)) - np.cos(w * t)) / (w * dt)
    c = (np.sin(w * t) - np.sin(w * (t - dt))) / (w * dt)
    return s, c


def fit_line(y, t, dt: float, band_hz, train) -> dict:
    """A sinusoid ``A sin(2 pi f t + phi)`` (interval means) in ``y`` on the ``train`` samples, ``f`` over the band.

    Returns ``frequency_hz`` and ``frequency_sigma_hz``, ``amplitude`` and ``amplitude_sigma`` (SI: the record's
    unit), ``phase_rad`` and ``prediction`` (N,) on every sample.
    """
    y = np.asarray(y, dtype=np.float64)
    tr = np.asarray(train, dtype=bool)
    yt = y[tr] - y[tr].mean()
    best = None
    span = float(t[-1] - t[0]) + dt
    grid = int(min(MAX_LINE_GRID, max(LINE_GRID, math.ceil((band_hz[1] - band_hz[0]) * 4.0 * span))))
    for f in np.linspace(band_hz[0], band_hz[1], grid):
        s, c = _sin_cos(t[tr], dt, f)
        x = np.column_stack([s - s.mean(), c - c.mean()])
        beta, *_ = np.linalg.lstsq(x, yt, rcond=None)
        rss = float(np.sum((yt - x @ beta) ** 2))
        if best is None or rss < best[0]:
            best = (rss, f, beta, x)
    rss, f, (a_s, a_c), x = best
    # y = A sin(wt + phi) = A cos(phi) sin(wt) + A sin(phi) cos(wt)
    amp = math.hypot(a_s, a_c)
    var = rss / max(yt.size - 3, 1) * np.linalg.inv(x.T @ x)
    g = np.array([a_s, a_c]) / amp if amp > 0 else np.zeros(2)
    s, c = _sin_cos(t, dt, f)
    # the frequency's sigma: the Cramer-Rao bound of a sinusoid in white noise, var(w) = 12 s^2 / (A^2 n^3) per
    # sample^2 (Kay 1993, "Fundamentals of Statistical Signal Processing", vol. 1, example 3.14), or the grid's
    # rounding (step / sqrt(12)) where larger
    step = (band_hz[1] - band_hz[0]) / max(grid - 1, 1)
    s2 = rss / max(yt.size - 3, 1)
    crb = math.sqrt(12.0 * s2 / max(amp ** 2 * yt.size ** 3, 1e-300)) / (2.0 * math.pi * dt)
    return {"frequency_hz": float(f), "frequency_sigma_hz": max(crb, step / math.sqrt(12.0)), "amplitude": amp,
            "amplitude_sigma": float(math.sqrt(max(g @ var @ g, 0.0))),
            "phase_rad": math.atan2(a_c, a_s), "prediction": a_s * s + a_c * c}


def fit_step(y, t, train, margin: float = STEP_MARGIN) -> dict:
    """One step ``d H(t - t_s)`` in ``y`` on the ``train`` samples: ``t_s`` over every sample boundary off the ends,
    where the two means (before, after) leave the least sum of squares.

    Returns ``time_s`` (the first sample after the step), ``size`` and ``sigma`` (white-noise sigma of a difference
    of two means) and ``prediction`` (N,).
    """
    y = np.asarray(y, dtype=np.float64)
    tr = np.asarray(train, dtype=bool).astype(np.float64)
    n = y.size
    c_n = np.cumsum(tr)
    c_s = np.cumsum(tr * y)
    lo, hi = int(math.ceil(margin * n)), int(math.floor((1.0 - margin) * n))
    k = np.arange(lo, hi)                     # the step after sample k: samples 0..k before
    n1, s1 = c_n[k], c_s[k]
    n2, s2 = c_n[-1] - n1, c_s[-1] - s1
    ok = (n1 > 0) & (n2 > 0)
    m1 = np.where(ok, s1 / np.maximum(n1, 1), 0.0)
    m2 = np.where(ok, s2 / np.maximum(n2, 1), 0.0)
    red = np.where(ok, n1 * n2 / np.maximum(n1 + n2, 1) * (m2 - m1) ** 2, -1.0)
    j = int(np.argmax(red))
    # between two training samples the sum of squares is flat (the held-out samples do not tell where the step is):
    # the middle of that span, which errs least on them
    j_end = j
    while j_end + 1 < red.size and red[j_end + 1] == red[j]:
        j_end += 1
    j = (j + j_end) // 2
    kk = int(k[j])
    size = float(m2[j] - m1[j])
    after = np.arange(n) > kk
    pred = np.where(after, size, 0.0)
    on = tr > 0
    resid = y[on] - np.where(after, m2[j], m1[j])[on]
    s2w = float(np.sum(resid ** 2)) / max(int(c_n[-1]) - 2, 1)
    return {"time_s": float(t[kk]), "size": size,
            "sigma": float(math.sqrt(s2w * (1.0 / n1[j] + 1.0 / n2[j]))), "prediction": pred}


def fit_ramp(y, t, train) -> dict:
    """A ramp ``r (t - t_mid)`` in ``y`` on the ``train`` samples (least squares with a constant); ``rate`` (SI per
    second), ``sigma`` (white-noise) and ``prediction`` (N,)."""
    return _fit_regressor(y, np.asarray(t, dtype=np.float64) - 0.5 * (t[0] + t[-1]), train)


def _fit_regressor(y, x, train) -> dict:
    y = np.asarray(y, dtype=np.float64)
    tr = np.asarray(train, dtype=bool)
    xc = x - x[tr].mean()
    sxx = float(np.sum(xc[tr] ** 2))
    if sxx <= 0.0:
        return {"rate": 0.0, "sigma": math.inf, "prediction": np.zeros_like(y)}
    k = float(np.sum(xc[tr] * (y[tr] - y[tr].mean()))) / sxx
    r = y[tr] - y[tr].mean() - k * xc[tr]
    s2 = float(np.sum(r ** 2)) / max(int(tr.sum()) - 2, 1)
    return {"rate": k, "sigma": math.sqrt(s2 / sxx), "prediction": k * x}


def _fit(cand: dict, y6, t, dt: float, train, extra: dict) -> tuple:
    """``(prediction (N, 6), params, sigmas)`` of one candidate fitted on the ``train`` samples (params in edge
    units)."""
    pred = np.zeros_like(y6)
    params, sig = {}, {}
    effect = cand["effect"]
    for ch in cand["channels"]:
        sensor, ax = CHANNELS[ch]
        unit, scale = _UNIT[sensor]
        name = f"{sensor}_{ax}"
        if effect == "base_motion_line":
            r = fit_line(y6[:, ch], t, dt, cand["band_hz"], train)
            pred[:, ch] = r["prediction"]
            params[name] = {"frequency_hz": r["frequency_hz"], f"amplitude_{unit}": r["amplitude"] * scale,
                            "phase_deg": math.degrees(r["phase_rad"])}
            sig[name] = {f"amplitude_{unit}": r["amplitude_sigma"] * scale, "frequency_hz": r["frequency_sigma_hz"]}
            if sensor == "gyro":
                from sins_sim.units import ARCSEC

                params[name]["angle_amplitude_arcsec"] = r["amplitude"] / (2 * math.pi * r["frequency_hz"]) / ARCSEC
        elif effect == "bias_step":
            r = fit_step(y6[:, ch], t, train)
            pred[:, ch] = r["prediction"]
            params[name] = {"time_s": r["time_s"], f"size_{unit}": r["size"] * scale}
            # the white-noise sigma of two means understates it under a random walk: at least the step scan's
            # generalised least squares sigma (:func:`sins_sim.navigation.temperature_fit.scan_bias_step`)
            sig[name] = {"time_s": max(dt, cand.get("time_resolution_s", 0.0)), f"size_{unit}": max(r["sigma"], cand.get("gls_sigma", 0.0)) * scale}
        elif effect == "bias_drift":
            r = fit_ramp(y6[:, ch], t, train)
            pred[:, ch] = r["prediction"]
            params[name] = {f"ramp_{unit}_per_h": r["rate"] * scale * 3600.0}
            sig[name] = {f"ramp_{unit}_per_h": r["sigma"] * scale * 3600.0}
        elif effect == "temperature":
            temp = extra["temperature_c"]
            r = _fit_regressor(y6[:, ch], temp - temp.mean(), train)
            pred[:, ch] = r["prediction"]
            params[name] = {f"coefficient_{unit}_per_c": r["rate"] * scale}
            sig[name] = {f"coefficient_{unit}_per_c": r["sigma"] * scale}
    if effect == "timing_jitter":
        tr = np.asarray(train, dtype=bool)
        basis = y6.mean(axis=0)[None, :] * (extra["intervals_s"][:, None] - dt) / dt
        yc = y6 - y6[tr].mean(axis=0)
        bc = basis - basis[tr].mean(axis=0)
        # weighted least squares over the six axes, each weighted by its own noise: the axes' variances first, then
        # (one iteration) the residuals' variances once the fitted part is out
        w = 1.0 / np.maximum(np.var(y6[tr], axis=0), 1e-300)
        for _ in range(2):
            sxx = float(np.sum(w * bc[tr] ** 2))
            g = float(np.sum(w * bc[tr] * yc[tr])) / sxx if sxx > 0 else 0.0
            w = 1.0 / np.maximum(np.var(yc[tr] - g * bc[tr], axis=0), 1e-300)
        sxx = float(np.sum(w * bc[tr] ** 2))
        pred = g * basis
        params["all"] = {"gain": g, "interval_rms_s": float(np.std(extra["intervals_s"] - dt))}
        sig["all"] = {"gain": float(1.0 / math.sqrt(sxx)) if sxx > 0 else math.inf}
    return pred, params, sig


def _candidates(findings: list, extra: dict, temperature: dict | None) -> list:
    """The catalogue's candidates the findings and the log call for (module docstring)."""
    out = []
    for f in findings:
        if f["quantity"] == "psd_line":
            kind = "sway" if f["frequency_hz"] < SWAY_MAX_HZ else "vibration"
            out.append({"effect": "base_motion_line", "label": f"{kind} line {f['sensor']} {f['axis']} "
                                                               f"{f['frequency_hz']:.4g} Hz", "kind": kind,
                        "channels": [CHANNELS.index((f["sensor"], f["axis"]))], "band_hz": f["band_hz"]})
        elif f["quantity"] == "bias_step":
            unit, scale = _UNIT[f["sensor"]]
            out.append({"effect": "bias_step", "label": f"bias step {f['sensor']} {f['axis']}",
                        "channels": [CHANNELS.index((f["sensor"], f["axis"]))],
                        "gls_sigma": f.get(f"sigma_{unit}", 0.0) / scale,
                        "time_resolution_s": f.get("time_resolution_s", 0.0)})
    lined = {(f["sensor"], f["axis"]) for f in findings if f["quantity"] == "psd_line"}
    for f in findings:
        if f["quantity"] == "allan_deviation" and f["side"] == "above" and (f["sensor"], f["axis"]) not in lined:
            lo = max(ALLAN_LINE_TAU / f["tau_range_s"][1] / ALLAN_LINE_WIDEN, 2.0 / (extra["dt_s"] * extra["n"]))
            hi = min(ALLAN_LINE_TAU / f["tau_range_s"][0] * ALLAN_LINE_WIDEN, 0.45 / extra["dt_s"])
            if hi > lo:
                out.append({"effect": "base_motion_line", "label": f"line {f['sensor']} {f['axis']} from the Allan "
                                                                   f"bump ({lo:.3g} to {hi:.3g} Hz)", "kind": "line",
                            "channels": [CHANNELS.index((f["sensor"], f["axis"]))], "band_hz": [lo, hi]})
    drift = sorted({CHANNELS.index((f["sensor"], f["axis"])) for f in findings
                    if f["quantity"] == "allan_deviation" and f["side"] == "above"}
                   | ({0, 1, 2} if any(f["quantity"] == "navigation" for f in findings) else set()))
    if drift:
        out.append({"effect": "bias_drift", "label": "bias drift (ramp) " + ", ".join(
            f"{CHANNELS[c][0]} {CHANNELS[c][1]}" for c in drift), "channels": drift})
    if temperature is not None and extra.get("temperature_c") is not None:
        chans = [CHANNELS.index((s, ax)) for s in ("gyro", "accelerometer") for ax, e in
                 (temperature.get(s) or {}).items() if any("value" in v for v in e.values())]
        if chans:
            out.append({"effect": "temperature", "label": "temperature trend " + ", ".join(
                f"{CHANNELS[c][0]} {CHANNELS[c][1]}" for c in chans), "channels": chans})
    if extra.get("intervals_s") is not None and float(np.std(extra["intervals_s"])) > 1e-9 * extra["dt_s"]:
        out.append({"effect": "timing_jitter", "label": "timing jitter (the log's intervals)",
                    "channels": list(range(6))})
    return out


def heldout_losses(y6, pred, train, blocks) -> np.ndarray:
    """Per held-out block and axis, the mean square of ``y - c - p`` over the block, each axis over its variance
    (``c`` the training samples' mean of ``y - p``); (m, 6)."""
    r = y6 - pred
    tr = np.asarray(train, dtype=bool)
    r = r - r[tr].mean(axis=0)
    var = np.maximum(np.var(y6, axis=0), 1e-300)
    held = np.unique(blocks[~tr])
    return np.array([np.mean(r[blocks == b] ** 2, axis=0) / var for b in held])


def _dm_p(loss_ref, loss_new, channels) -> tuple:
    d = dm_test(loss_ref[:, channels].sum(axis=1), loss_new[:, channels].sum(axis=1))
    return float(d["p"]), d["statistic"], int(d["m"])


# --- the selection and the verdict ----------------------------------------------------------------------------------

def choose_step(evaluated: list, gap_now: float, first: bool, held: dict | None = None) -> dict | None:
    """The next effect of the greedy selection, or None (module docstring, "Selection and verdict").

    Parameters
    ----------
    evaluated : list of dict
        Each candidate fitted on top of those selected: ``label``, ``gap`` (``G`` with it added), ``p_heldout``
        (against the selected model), ``removes`` (keys of the findings it removes) and ``p_vs`` (``label -> p`` of
        the held-out test "this one predicts no better than that one").
    gap_now : float
        ``G`` of the selected model (the twin's for the first step).
    first : bool
        The first step (needs :data:`MIN_PARTIAL` of the gap; later steps :data:`MIN_STEP` of what the findings they
        remove held).
    held : dict, optional
        For a later step: finding key (tuple) -> its excess in the selected model (:func:`finding_excess`).

    Returns
    -------
    dict or None
        The chosen candidate with ``alternatives`` (the labels that explain it alike) and ``tentative`` (it has
        alternatives and neither closes the gap nor removes :data:`DOMINANT` of it: then not named).
    """
    if first:
        ok = [c for c in evaluated if c["p_heldout"] < ALPHA and gap_now > 0.0
              and (gap_now - c["gap"]) / gap_now >= MIN_PARTIAL]
    else:
        # a further effect answers for the findings it removes, not for the others left: it must remove findings and
        # bring the gap down by MIN_STEP of what those findings held (not trade them for new ones elsewhere)
        held = held or {}

        def target(c):
            return sum(held.get(tuple(k), 0.0) for k in c["removes"])

        ok = [c for c in evaluated if c["p_heldout"] < ALPHA and gap_now > 0.0 and target(c) > 0.0
              and gap_now - c["gap"] >= MIN_STEP * target(c)]
    if not ok:
        return None
    best = min(ok, key=lambda c: c["gap"])
    alts = [c["label"] for c in evaluated if c is not best and c["p_heldout"] < ALPHA
            and set(map(tuple, c["removes"])) & set(map(tuple, best["removes"]))
            and best["p_vs"].get(c["label"], 0.0) >= AHEAD_ALPHA]
    # the share it removes: of the whole gap for the first step, of what its findings held for a later one (as above)
    frac = (gap_now - best["gap"]) / (gap_now if first else target(best))
    return {**best, "alternatives": alts,
            "tentative": bool(alts) and not (best["gap"] <= 0.0 or frac >= DOMINANT)}


def give_twin_verdict(findings: list, candidates: list, steps: list, gap0: float) -> dict:
    """The verdict from the findings, the first round's candidates and the selected steps.

    Parameters
    ----------
    findings : list of dict
        The twin's findings (with ``excess``).
    candidates : list of dict
        The first round: ``label``, ``effect``, ``gap``, ``p_heldout``, ``removes``.
    steps : list of dict
        The selected effects in order (:func:`choose_step`'s picks), each with ``findings_left`` (the findings
        with it and those before it added) and ``gap``, ``gap_sd`` (over seeds).
    gap0 : float
        The twin's gap ``G_0``.

    Returns
    -------
    dict
        ``status``, ``effect``, ``explained_fraction`` and ``explained_fraction_sd``, ``effects``,
        ``alternatives``, ``remainder``, ``band`` (for ``unknown``), ``unconfirmed``, ``gap``, ``criterion``.
    """
    criterion = (f"shrink of the gap (sum of the findings' log excess over the envelope) with the effect added to the "
                 f"twin; held-out Diebold-Mariano at {ALPHA:g} on odd blocks (fitted on even ones); first effect "
                 f">= {MIN_PARTIAL:g} of the gap, further ones >= {MIN_STEP:g} of what the findings they remove held; "
                 f"alternatives: a "
                 f"common finding and not worse on held-out data at {AHEAD_ALPHA:g}")
    out = {"criterion": criterion, "gap": gap0, "effects": [], "alternatives": [], "remainder": [], "band": [],
           "unconfirmed": None}
    if not findings:
        out.update(status="none", effect="none", explained_fraction=0.0, explained_fraction_sd=0.0)
        return out
    tied = []
    if steps and steps[0].get("tentative"):
        tied = [steps[0]["label"], *steps[0].get("alternatives", [])]   # explain it alike; none dominant
        steps = []
    if not steps:
        removed = {tuple(k) for c in candidates for k in c["removes"]}
        band = [finding_place(f) for f in findings if finding_key(f) not in removed] or [finding_place(f) for f in findings]
        shown = [c for c in candidates if c["p_heldout"] >= ALPHA and gap0 > 0 and (gap0 - c["gap"]) / gap0
                 >= MIN_PARTIAL]
        unconf = None
        if shown:
            c = min(shown, key=lambda c: c["gap"])
            unconf = {"effect": c["effect"], "label": c["label"], "in_sample_fraction": (gap0 - c["gap"]) / gap0,
                      "p_heldout": c["p_heldout"],
                      "message": (f"{c['label']} shrinks the gap by {(gap0 - c['gap']) / gap0:.2f} in-sample, not "
                                  f"confirmed on held-out data (p = {c['p_heldout']:.2g})")}
        out.update(status="unknown", effect="unknown", explained_fraction=0.0, explained_fraction_sd=0.0, band=band,
                   unconfirmed=unconf, alternatives=tied)
        return out
    last = steps[-1]
    frac = max(0.0, 1.0 - last["gap"] / gap0)
    left = last["findings_left"]
    done = not left
    if not done and frac < MIN_PARTIAL:
        out.update(status="unknown", effect="unknown", explained_fraction=0.0, explained_fraction_sd=0.0,
                   band=[finding_place(f) for f in findings])
        return out
    prev = gap0
    effects = []
    for s in steps:
        effects.append({"effect": s["effect"], "label": s["label"], "explained_fraction": max(0.0, (prev - s["gap"])
                                                                                              / gap0),
                        "params": s.get("params", {}), "uncertainty": s.get("uncertainty", {}),
                        "p_heldout": s["p_heldout"], "removes": [list(k) for k in s["removes"]]})
        prev = s["gap"]
    out.update(status="explained" if done else "partly explained", effect=steps[0]["effect"],
               explained_fraction=1.0 if done else frac, explained_fraction_sd=float(last.get("gap_sd", 0.0) / gap0),
               effects=effects, alternatives=list(steps[0].get("alternatives", [])),
               remainder=[] if done else [finding_place(f) for f in left])
    return out


def invalid_data(reason: str) -> dict:
    """The verdict ``invalid data`` for a log refused before any fit (``reason``: the refusal's one line)."""
    return {"status": "invalid data", "effect": "invalid data", "explained_fraction": 0.0,
            "explained_fraction_sd": 0.0, "effects": [], "alternatives": [], "remainder": [], "band": [],
            "unconfirmed": None, "findings": [reason], "criterion": "the log's checks (evenly spaced, at rest, "
                                                                     "alignable)"}


# --- the whole step ---------------------------------------------------------------------------------------------------

class _Twin:
    """Runs the twin with added effects and localises it (with the bootstrap over seeds)."""

    def __init__(self, sensors, t, site, q_nb, method, seeds, run_kw, log_run, step_findings, step_alpha, alpha,
                 rng, level_findings=()):
        self.level = list(level_findings)
        self.args = (sensors, t, site, q_nb, method, seeds)
        self.run_kw, self.log_run, self.steps = run_kw, log_run, step_findings
        self.step_alpha, self.alpha = step_alpha, alpha
        self.fs = 1.0 / float(t[1] - t[0])
        boot = rng.integers(0, len(seeds), size=(4 * BOOTSTRAP, len(seeds)))
        # a resampling of one seed only has no spread: its envelope is a line, and every excess infinite
        self.boot = boot[[len(set(b.tolist())) >= 2 for b in boot]][:BOOTSTRAP]

    def run(self, added, sensors=None) -> dict:
        """The twin (its noise terms ``sensors`` where refitted) plus ``added`` less its mean (the twin's biases
        are the log's means already), localised against the log."""
        from sins_sim.simulation.twin_effects import twin_runs_with

        args = self.args if sensors is None else (sensors, *self.args[1:])
        if added is not None:
            added = added - added.mean(axis=0)
        pairs = twin_runs_with(*args, added=added, **self.run_kw)
        runs = [r for r, _ in pairs]
        chans = {CHANNELS.index((f["sensor"], f["axis"])) for f in self.steps}
        scans = [{ch: _scan(v, self.fs, ch, self.step_alpha) for ch in chans} for _, v in pairs]
        findings = localise_with_steps(self.log_run, runs, self.steps, scans, self.alpha, self.level)
        boot = []
        for idx in self.boot:
            boot.append(gap_measure(localise_with_steps(self.log_run, [runs[i] for i in idx], self.steps,
                                                        [scans[i] for i in idx], self.alpha, self.level)))
        return {"findings": findings, "gap": gap_measure(findings), "boot": np.asarray(boot)}


def explain_twin(log_run, y6, t, findings: list, step_findings: list, *, sensors, site, q_nb, method: str, seeds,
                 run_kw: dict, temperature_c=None, temperature: dict | None = None, intervals_s=None,
                 step_alpha: float = 0.05 / 6.0, alpha: float = 0.05, bias: dict | None = None,
                 lat_rad: float | None = None, seed: int = 0, refit=None) -> dict:
    """Try the catalogue on the twin's findings and give the verdict (module docstring).

    Parameters
    ----------
    log_run : RestRun
        The log's mission at rest.
    y6 : ndarray
        (N, 6) the log's rate and specific force (``CHANNELS`` order).
    t : ndarray
        Its time axis (evenly spaced, as the twin's).
    findings : list of dict
        The plain twin's findings as listed before (none: the verdict is ``none`` and nothing is run); they are
        localised again here with their readings (:func:`localise_with_steps`, the same seeds).
    step_findings : list of dict
        The log's bias steps as findings (with ``z``, ``threshold``, ``time_resolution_s``).
    sensors, site, q_nb, method, seeds, run_kw
        The twin as it was run (:func:`sins_sim.simulation.twin.twin_runs`).
    temperature_c : ndarray, optional
        The log's temperature column; ``temperature`` its coefficients (``identify``'s ``temperature`` metrics).
    intervals_s : ndarray, optional
        The log's own intervals from its time column (N,).
    step_alpha, alpha : float
        The step scan's level per axis, the localisation's.
    bias : dict, optional
        ``identify``'s rest biases (for the pulse-weight and clock scales implied at rest).
    lat_rad : float, optional
        The site's latitude (with ``bias``).
    seed : int
        Of the bootstrap's resampling.
    refit : callable, optional
        ``refit(residual (N, 6)) -> sensors``: the twin's noise terms fitted again on the log less the candidates'
        fitted part (a strong line or step otherwise inflates the white noise or the random walk the twin was
        fitted with); None keeps the twin's.

    Returns
    -------
    dict
        ``verdict`` (:func:`give_twin_verdict`), ``candidates`` (the first round: label, effect, params,
        uncertainty, shrink and its sd over seeds, p_heldout, removes, findings_left), ``steps``, ``not_testable``,
        ``gap`` (the twin's ``G_0``), ``gap_measure`` (its definition), ``heldout`` (blocks), and ``twins`` (label ->
        the runs' findings; not JSON).
    """
    t = np.asarray(t, dtype=np.float64)
    dt = float(t[1] - t[0])
    n = t.size
    blocks = np.minimum((np.arange(n) * HELD_BLOCKS) // n, HELD_BLOCKS - 1)
    train = blocks % 2 == 0
    every = np.ones(n, dtype=bool)
    extra = {"temperature_c": None if temperature_c is None else np.asarray(temperature_c, dtype=np.float64),
             "intervals_s": None if intervals_s is None else np.asarray(intervals_s, dtype=np.float64), "dt_s": dt,
             "n": n}
    not_testable = dict(NOT_TESTABLE_AT_REST)
    not_testable.update(_implied_scales(bias, lat_rad))
    gap0 = 0.0
    out = {"gap": gap0, "not_testable": not_testable, "candidates": [], "steps": [],
           "gap_measure": "sum over the findings of ln(log / envelope edge) (Allan: deviation over the band's edge; "
                          "line: SNR over the threshold; navigation: |log - mean| over the half-width at the end; "
                          "bias step: |z| over the threshold; noise level: the block variance ratio over the band's "
                          "edge)",
           "heldout": {"blocks": HELD_BLOCKS, "fit": "even blocks", "scored": "odd blocks"}}
    if not findings:
        out["verdict"] = give_twin_verdict(findings, [], [], gap0)
        return out
    twin = _Twin(sensors, t, site, q_nb, method, list(seeds), run_kw, log_run, step_findings, step_alpha, alpha,
                 np.random.default_rng(seed), [f for f in findings if f["quantity"] == "noise_level"])
    base = twin.run(None)
    findings = base["findings"]      # the same seeds as the plain twin's, with each finding's readings
    gap0 = out["gap"] = base["gap"]
    if not findings:
        out["verdict"] = give_twin_verdict(findings, [], [], gap0)
        return out
    cands = _candidates(findings, extra, temperature)

    def fit(c, resid, mask):
        return _fit(c, resid, t, dt, mask, extra)

    def run(added, rest):
        return twin.run(added, None if refit is None else refit(rest))

    select_effects(out, cands, fit, run, lambda c: c["channels"], y6, train, every, blocks, base)
    return out


def select_effects(out: dict, cands: list, fit, run, channels_of, y6, train, every, blocks, base: dict) -> None:
    """The greedy selection (module docstring, "Selection and verdict"), shared by the catalogue at rest and the
    moving one (:mod:`sins_sim.identification.twin_explain_moving`): each round fits every remaining candidate on the
    log less the effects chosen so far (on all samples and on the held-out training blocks), runs the twin with it,
    scores shrink, its sd over the seeds' resamplings and the held-out test, and :func:`choose_step` picks the next;
    fills ``out["candidates"]`` (the first round), ``out["steps"]`` and ``out["verdict"]``.

    ``fit(c, resid, mask) -> (added, params, sigmas)``; ``run(added, rest) -> {"findings", "gap", "boot"}`` (``rest``
    the log less everything added, for a twin that refits its noise); ``channels_of(c)`` the candidate's channels;
    ``base`` the plain twin's ``findings``, ``gap`` and ``boot``."""
    findings, gap0 = base["findings"], base["gap"]
    base_keys = {finding_key(f) for f in findings}
    sel_full = np.zeros_like(y6)
    sel_train = np.zeros_like(y6)
    steps, gap_now, boot_now, left, first_round = [], gap0, base["boot"], findings, []
    base_loss = heldout_losses(y6, sel_train, train, blocks)
    for rnd in range(MAX_EFFECTS):
        if not left or not cands:
            break
        evaluated = []
        for c in cands:
            p_full, params, sig = fit(c, y6 - sel_full, every)
            p_train, _, _ = fit(c, y6 - sel_train, train)
            res = run(sel_full + p_full, y6 - sel_full - p_full)
            loss = heldout_losses(y6, sel_train + p_train, train, blocks)
            chans = sorted(channels_of(c))
            p, stat, m = _dm_p(base_loss, loss, chans)
            keys = {finding_key(f) for f in res["findings"]}
            shrink = (gap_now - res["gap"]) / gap_now if gap_now > 0 else 0.0
            # resamplings of the seeds in which the selected model still leaves a (finite) gap
            ok = (boot_now > 0) & np.isfinite(boot_now) & np.isfinite(res["boot"])
            sd = float(np.std((boot_now[ok] - res["boot"][ok]) / boot_now[ok], ddof=1)) if ok.sum() > 1 else 0.0
            evaluated.append({**{k: c[k] for k in ("effect", "label")}, "params": params, "uncertainty": sig,
                              "gap": res["gap"], "gap_sd": _finite_sd(res["boot"]),
                              "shrink": shrink, "shrink_sd": sd, "p_heldout": p, "t_heldout": stat, "m_heldout": m,
                              "channels": chans,
                              "removes": sorted([list(k) for k in ({finding_key(f) for f in left} - keys)], key=str),
                              "findings_left": res["findings"], "_loss": loss, "_cand": c, "_p_full": p_full,
                              "_p_train": p_train, "_boot": res["boot"]})
        for c in evaluated:
            c["p_vs"] = {o["label"]: _dm_p(o["_loss"], c["_loss"], sorted(set(c["channels"]) | set(o["channels"])))[0]
                         for o in evaluated if o is not c}
        if rnd == 0:
            out["candidates"] = [_public(c, base_keys) for c in sorted(evaluated, key=lambda c: c["gap"])]
            first_round = evaluated
        pick = choose_step(evaluated, gap_now, first=(rnd == 0),
                           held={finding_key(f): finding_excess(f) for f in left})
        if pick is None or pick["tentative"]:
            if pick is not None and rnd == 0:
                steps.append(pick)      # named only with a second effect: give_twin_verdict sets it aside
            break
        steps.append(pick)
        sel_full = sel_full + pick["_p_full"]
        sel_train = sel_train + pick["_p_train"]
        base_loss = pick["_loss"]
        gap_now, boot_now, left = pick["gap"], pick["_boot"], pick["findings_left"]
        cands = [c for c in cands if c is not pick["_cand"]]
    out["steps"] = [_public(s, base_keys) for s in steps]
    out["verdict"] = verdict_of_steps(findings, first_round, steps, gap0, base["boot"])


def verdict_of_steps(findings: list, first_round: list, steps: list, gap0: float, base_boot) -> dict:
    """:func:`give_twin_verdict` of a greedy selection's ``steps``, with the explained fraction's sd over seeds from
    the paired bootstrap of the selected model (the last step's ``_boot``) against the twin's (``base_boot``)."""
    verdict = give_twin_verdict(findings, first_round, steps, gap0)
    if steps and verdict["status"] in ("explained", "partly explained"):
        last = steps[-1]["_boot"]
        ok = (base_boot > 0) & np.isfinite(base_boot) & np.isfinite(last)
        verdict["explained_fraction_sd"] = float(np.std(1.0 - last[ok] / base_boot[ok], ddof=1)) \
            if ok.sum() > 1 else 0.0
    return verdict


def _finite_sd(x) -> float:
    """The sample sd of the finite entries (0 with fewer than two)."""
    x = np.asarray(x, dtype=np.float64)
    x = x[np.isfinite(x)]
    return float(np.std(x, ddof=1)) if x.size > 1 else 0.0


def _public(c: dict, base_keys: set) -> dict:
    """A candidate without its arrays, for the metrics."""
    return {k: v for k, v in c.items() if not k.startswith("_") and k != "findings_left"} | {
        "findings_left": [finding_place(f) for f in c["findings_left"]]}


def _implied_scales(bias: dict | None, lat_rad: float | None) -> dict:
    """The pulse-weight (or clock) scale a log at rest implies: ``b_D / g`` and ``b_N / (Omega cos L)``."""
    why = ("at rest a pulse-weight error or a clock off its nominal scales the Earth's rate and gravity, which the "
           "rest biases the twin carries absorb: not separable from a bias without a rate table or a tilt")
    out = {"pulse_weight_error": why, "timing_rate_off_nominal": why}
    if not bias or lat_rad is None:
        return out
    from sins_sim.earth import EARTH_RATE_RAD_S, gravity_down

    implied = {}
    a = bias.get("accelerometer", {}).get("down_ug", {})
    if "value" in a:
        g = gravity_down(lat_rad, 0.0)
        # the down accelerometer reads -g: a scale s adds -s g along down, so s = -b_D / g
        implied["accelerometer_scale_ppm"] = {"value": -a["value"] * MICRO_G / g * 1e6,
                                              "sigma": (a.get("sigma") or math.nan) * MICRO_G / g * 1e6}
    w = bias.get("gyro", {}).get("north_deg_h", {})
    if "value" in w:
        wn = EARTH_RATE_RAD_S * math.cos(lat_rad)
        implied["gyro_scale_ppm"] = {"value": w["value"] * DEG_PER_H / wn * 1e6,
                                     "sigma": (w.get("sigma") or math.nan) * DEG_PER_H / wn * 1e6}
    out["implied_at_rest"] = implied
    return out
