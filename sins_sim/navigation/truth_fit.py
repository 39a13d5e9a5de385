"""Biases, scale factors and misalignments of a moving log against its known trajectory (least squares).

Arrays in, numbers out (SI inside; deg/h, ug, ppm and arcsec at :meth:`TruthFit.to_dict`).

The truth gives each interval's ideal increments ``x_true`` (:func:`sins_sim.simulation.external.ideal_increments`:
the exact integrals of the body rate and specific force). The error model of each triad (Groves 2013, sec. 4.4.6;
Titterton and Weston 2004, ch. 4; the convention of :mod:`sins_sim.models.sensor_errors`) is

    x_meas = x_true + b dt + E x_true + n

with ``b`` the bias, ``E`` the scale factors ``S_i`` on its diagonal and the misalignments ``M_ij`` (sensor ``i``
towards body axis ``j``) off it. Being linear per interval, it holds for sums over blocks of intervals:
row ``i`` of the errors ``y = x_meas - x_true`` summed over block ``k`` of length ``T_k`` is
``Y_ik = b_i T_k + sum_j E_ij X_jk``. Each row's ``(b_i, E_i1, E_i2, E_i3)`` is fitted on the sums over one-second
blocks (:data:`BLOCK_S`):

1. **ordinary least squares** on the block sums gives first values of the terms (and ``ols_sigma``);
2. **the noise of the residual**: each interval's residual ``y - b dt - E x_true`` (the log less the truth's exact
   increments less the fitted terms), as a rate, has its overlapping Allan deviation fitted with the IEEE Std
   952-1997 (Annex C) power laws (:func:`sins_sim.navigation.allan.fit_allan`, screened by
   :func:`~sins_sim.navigation.allan.screen_noise` for what is reported as determined): quantisation ``Q``, white
   noise ``N`` (ARW / VRW), bias instability ``B``, random walk ``K`` (RRW). These are the twin's noise terms;
3. **the terms and their covariance under correlated noise**: generalised least squares (Kariya and Kurata 2004,
   ch. 2) on the block sums with the covariance ``C = s^2 (I + rho R)``: a white part (the white noise and the
   quantisation over a block) and a rate random walk of ``K^2 = s^2 rho`` started at the log's start (its start
   value is the bias), whose block sums, for blocks of length ``T`` and centres ``c_k``, have the covariance
   ``R_kl = T^2 min(c_k, c_l)`` apart and ``T^2 (c_k - T / 6)`` within one (the double integral of ``min(s, u)``,
   :func:`walk_covariance`). ``s^2`` and ``rho`` are fitted to the block sums themselves by restricted maximum
   likelihood (Harville 1977), ``s^2`` profiled out, ``rho`` on a grid refined between its neighbours, in the
   eigenbasis of ``R`` (computed once per triad) where ``C`` is diagonal. The bias instability has no
   finite-dimensional covariance; over a log of minutes to hours its block sums wander as a random walk does, and
   the likelihood takes it as one. ``rho`` from one log is uncertain (a walk crossing the white noise at 20 s is
   read to tens of per cent in 600 s), and where the log shows none a walk too weak to see still moves the bias; so
   the terms' covariance is that of the estimate under ``C(rho_up)``, ``rho_up`` the upper end of the profile
   likelihood's interval (``-2 ln L`` up by :data:`RHO_LEVEL`). The terms reported are the ordinary least-squares
   ones, with their covariance under ``C(rho_up)``, the sandwich ``(A^T A)^-1 A^T D_up A (A^T A)^-1`` (``D_up =
   s_up^2 (I + rho_up Lambda)`` in the eigenbasis): the twin's candidate effects on a moving log are projected off
   the fitted terms with that same estimator (:mod:`sins_sim.identification.twin_explain_moving`), and a GLS
   estimate there left the twin's heading apart from a log with a scale-factor asymmetry (the two estimators absorb
   the asymmetry's rectified part differently). The price is efficiency, not honesty: the sandwich is the OLS
   estimate's covariance under that noise. The Allan fit of item 2 gives the twin its terms; the likelihood, which
   uses every block, the covariance.

Why generalised least squares with the fitted covariance rather than a block bootstrap or a Newey-West correction:
a rate random walk is not stationary (its block sums' variance grows with time) and correlates the whole log, so
neither a stationary bootstrap nor a HAC estimator with a finite lag window holds its covariance; the random walk's
covariance is known in closed form up to its level, which the likelihood fits. The white-noise sigma ``s^2 (A^T
A)^-1`` (Draper and Smith 1998, ch. 5) that this fit gave before (``ols_sigma``) holds the walk only through the
residuals' scatter about the fit, not through its share in the bias (``K^2 T_log / 3`` against ``N^2 / T_log``):
on the test's logs (a walk crossing the white noise at 20 s, 600 s long) the bias's z had an RMS of 6.0 with it,
0.96 now. The price under white noise alone: the walk that a 600 s log cannot exclude makes the bias's sigma about
2.5 times the white-noise one (z RMS 0.39); the scale factors and misalignments, which the motion excites apart
from a slow drift, keep theirs.

Long logs: the blocks are lengthened so that there are at most :data:`MAX_BLOCKS` (the covariance is dense).

Observability: a term is observable only where the motion excites its column ``X_j`` apart from the others and from
the constant (the bias's column ``T_k``). A column whose part outside the span of the others is less than
:data:`EXCITATION_MIN` of its own size (``1 - R^2`` of its regression on the others, the variance inflation's
inverse) is "not observable" and is dropped from the fit (so that it does not spoil the others): the gyro scale
factors of a unit at rest (its rate the Earth's, constant), the accelerometers' of a vehicle that stays level (its
horizontal force near zero, its vertical force constant). A bias is always observable against a truth (the truth
holds the attitude).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sins_sim.units import ARCSEC, DEG, DEG_PER_H, MICRO_G

__all__ = ["BLOCK_S", "EXCITATION_MIN", "MAX_BLOCKS", "TruthFit", "fit_against_truth", "walk_covariance"]

#: The blocks the increments are summed over (s): long enough to average the quantisation and white noise, short
#: enough to follow the motion (a manoeuvre of seconds).
BLOCK_S = 1.0
#: Least ``1 - R^2`` of a column's regression on the others for it to be fitted: 1e-6, a variance inflation of 1e6
#: (a term then still gets a sigma a thousand times that of an orthogonal design; below it the term is not told from
#: the others at all).
EXCITATION_MIN = 1e-6
#: Most blocks in the covariance (a dense matrix of that size).
MAX_BLOCKS = 1200
#: The rise of the restricted log-likelihood (``-2 ln L``) that ends the random walk's interval: 1, the chi-square
#: quantile of one degree of freedom at 68 %, so that its upper end is a one-sided 84 % bound (Wilks 1938): on the
#: simulated logs of the test (a walk crossing the white noise at 20 s in 600 s) the bias's z then has an RMS of 0.96
#: (0.89 at the one-sided 95 % bound, 2.71; 1.07 at the estimate itself, with 91 % inside +-1.96)
RHO_LEVEL = 1.0
#: The noise terms the twin carries, per triad: (Allan term, metrics key, factor from SI).
NOISE_KEYS = {"gyro": (("white", "arw_deg_rt_h", 60.0 / DEG), ("flicker", "bias_instability_deg_h", 1.0 / DEG_PER_H),
                       ("random_walk", "rrw_deg_h_rt_h", 60.0 / DEG_PER_H)),
              "accelerometer": (("white", "vrw_ug_rt_hz", 1.0 / MICRO_G), ("flicker", "bias_instability_ug",
                                                                         1.0 / MICRO_G),
                                ("random_walk", "rrw_ug_rt_h", 60.0 / MICRO_G))}
NOT_OBSERVABLE = "not observable (the motion does not excite it apart from the other terms)"


@dataclass(frozen=True)
class TruthFit:
    """Per triad (``gyro``, ``accelerometer``): ``bias`` (3,) and ``e`` (3, 3) in SI with their 1-sigma
    ``bias_sigma``, ``e_sigma``; NaN where not observable. ``blocks``: the blocks fitted, ``block_s`` their length;
    ``rms_residual``: per triad and axis the residual's RMS per block (rad, m/s). ``noise``: per triad a list of three
    (one per axis) :class:`~sins_sim.navigation.allan.AllanAnalysis` of the residual (screened); ``noise_used``: per
    triad and axis the residual's Allan coefficients (SI) and the likelihood's block variance ``s^2``
    (``block_white_variance``), random walk ``K^2`` and its upper end (``block_random_walk``,
    ``block_random_walk_upper``); ``ols_sigma``: the ordinary least squares sigmas (``bias`` (3,), ``e`` (3, 3)) for
    comparison; ``variance_ratio``: per triad and axis the likelihood's ``s^2`` over the ordinary residual variance
    (below 1 where a random walk takes part of the scatter)."""

    bias: dict
    bias_sigma: dict
    e: dict
    e_sigma: dict
    blocks: int
    rms_residual: dict
    block_s: float = BLOCK_S
    noise: dict | None = None
    noise_used: dict | None = None
    ols_sigma: dict | None = None
    variance_ratio: dict | None = None

    def to_dict(self) -> dict:
        """Edge units: gyro bias deg/h, accelerometer bias ug, scale factors ppm, misalignments arcsec (``xy``:
        sensor x towards body y); each ``{value, sigma}`` or ``{status: not observable ...}``."""
        out = {"blocks": self.blocks, "block_s": self.block_s}
        for s, (bkey, bscale) in (("gyro", ("bias_deg_h", 1.0 / DEG_PER_H)),
                                  ("accelerometer", ("bias_ug", 1.0 / MICRO_G))):
            sec = {bkey: {}, "scale_factor_ppm": {}, "misalignment_arcsec": {},
                   "rms_residual_per_block": [float(x) for x in self.rms_residual[s]]}
            for i, si in enumerate("xyz"):
                sec[bkey][si] = _entry(self.bias[s][i], self.bias_sigma[s][i], bscale)
                for j, sj in enumerate("xyz"):
                    if i == j:
                        sec["scale_factor_ppm"][si] = _entry(self.e[s][i, i], self.e_sigma[s][i, i], 1e6)
                    else:
                        sec["misalignment_arcsec"][si + sj] = _entry(self.e[s][i, j], self.e_sigma[s][i, j],
                                                                     1.0 / ARCSEC)
            if self.noise is not None:
                sec["noise"] = {ax: _noise_entries(s, self.noise[s][i], self.noise_used[s][i])
                                for i, ax in enumerate("xyz")}
                sec["variance_ratio"] = [float(x) for x in self.variance_ratio[s]]
                # the likelihood's random walk and the upper end the sigmas were taken at (the RRW key's unit)
                _, rkey, rscale = NOISE_KEYS[s][2]
                sec["random_walk_likelihood"] = {
                    ax: {rkey: float(math.sqrt(max(self.noise_used[s][i]["block_random_walk"], 0.0)) * rscale),
                         "upper": float(math.sqrt(max(self.noise_used[s][i]["block_random_walk_upper"], 0.0)) * rscale)}
                    for i, ax in enumerate("xyz")}
                bs = self.ols_sigma[s]
                sec["ols_sigma"] = {bkey: [float(x * bscale) for x in bs["bias"]],
                                    "scale_factor_ppm": [float(bs["e"][i, i] * 1e6) for i in range(3)]}
            out[s] = sec
        return out


def _noise_entries(sensor: str, analysis, used: dict) -> dict:
    """Each noise term of the twin: the value used (edge units), ``determined`` where the curve shows its slope
    region (with its 95 % interval), else the fit's value all the same (a term too weak to show still moves the
    block sums: the twin carries it)."""
    from sins_sim.navigation.allan import FLICKER_FLOOR_FACTOR

    out = {}
    for name, key, scale in NOISE_KEYS[sensor]:
        # the Allan fit's coefficient -> term (IEEE Std 952-1997, Annex C)
        c = max(float(used.get(name, 0.0)), 0.0)
        x = {"white": math.sqrt(c), "flicker": math.sqrt(c) / FLICKER_FLOOR_FACTOR,
             "random_walk": math.sqrt(3.0 * c)}[name]
        term = analysis.terms[name]
        e = {"value": float(x * scale) if math.isfinite(x) else 0.0, "determined": bool(term.found)}
        if term.found:
            e["tau_range_s"] = [float(x) for x in term.tau_range_s]
            if term.ci is not None:
                e["ci95"] = [float(term.ci[0] * scale), float(term.ci[1] * scale)]
        out[key] = e
    return out


def residual_noise_entries(resid: np.ndarray, dt_s: float, sensor: str) -> dict:
    """The twin's noise terms (``noise`` of :meth:`TruthFit.to_dict`, per axis) read off a residual ``(N, 3)`` of
    per-interval increments: the Allan fit of each axis, as the fit itself does. Used to refit the twin's noise on
    the residual less a candidate effect (a strong effect otherwise reads as bias instability or random walk)."""
    r = np.asarray(resid, dtype=np.float64)
    return {ax: _noise_entries(sensor, *_residual_noise(r[:, i], dt_s, sensor)) for i, ax in enumerate("xyz")}


def _entry(val, sig, scale) -> dict:
    return {"status": NOT_OBSERVABLE} if not math.isfinite(val) else {"value": float(val * scale),
                                                                     "sigma": float(sig * scale)}


def _excited(a_mat: np.ndarray) -> list:
    """Columns (after the first, the bias's) kept: drop the least excited one while any falls below
    :data:`EXCITATION_MIN` (``1 - R^2`` on the others kept)."""
    keep = list(range(a_mat.shape[1]))
    while len(keep) > 1:
        worst, worst_val = None, math.inf
        for c in keep[1:]:
            col = a_mat[:, c]
            norm2 = float(col @ col)
            if norm2 == 0.0:
                worst, worst_val = c, 0.0
                break
            others = a_mat[:, [k for k in keep if k != c]]
            coef, *_ = np.linalg.lstsq(others, col, rcond=None)
            resid = col - others @ coef
            frac = float(resid @ resid) / norm2
            if frac < worst_val:
                worst, worst_val = c, frac
        if worst_val >= EXCITATION_MIN:
            break
        keep.remove(worst)
    return keep


def walk_covariance(n_blocks: int, block_s: float) -> np.ndarray:
    """The covariance of ``n_blocks`` consecutive block sums (each ``block_s`` long) of a rate random walk of unit
    density started at the first block's start: ``T^2 min(c_k, c_l)`` apart, ``T^2 (c - T / 6)`` within one block
    (the double integral of ``min(s, u)``; module docstring, item 3)."""
    t_b = float(block_s)
    centres = (np.arange(n_blocks) + 0.5) * t_b
    cov = t_b * t_b * np.minimum.outer(centres, centres)
    cov[np.diag_indices(n_blocks)] -= t_b ** 3 / 6.0
    return cov


def _reml(a_t: np.ndarray, y_t: np.ndarray, lam: np.ndarray) -> tuple:
    """Generalised least squares with ``C = s^2 (I + rho R)`` in the eigenbasis of ``R`` (``a_t = V^T A``, ``y_t =
    V^T y``, ``lam`` the eigenvalues), ``rho`` by restricted maximum likelihood (Harville 1977; ``s^2`` profiled
    out), and the coefficients' covariance at ``rho_up``, the upper end of ``rho``'s profile-likelihood interval
    (:data:`RHO_LEVEL`): ``(GLS coefficients, their covariance, the OLS coefficients' covariance, s^2, rho,
    rho_up)`` (module docstring, item 3)."""
    from scipy.optimize import brentq, minimize_scalar

    k, p = a_t.shape

    def solve(rho):
        d = 1.0 + rho * lam
        w = 1.0 / d
        m = a_t.T @ (w[:, None] * a_t)
        m_inv = np.linalg.inv(m)
        beta = m_inv @ (a_t.T @ (w * y_t))
        r = y_t - a_t @ beta
        s2 = float(np.sum(w * r * r)) / (k - p)
        nll = (k - p) * math.log(max(s2, 1e-300)) + float(np.sum(np.log(d))) + float(np.linalg.slogdet(m)[1])
        return nll, beta, m_inv, s2, w

    top = float(np.max(lam))
    grid = np.concatenate([[0.0], np.logspace(-8, 8, 65) / top])
    nll = np.array([solve(r)[0] for r in grid])
    j = int(np.argmin(nll))
    rho, best = float(grid[j]), float(nll[j])
    if 0 < j < grid.size - 1:                     # refine between the neighbours, on log rho
        lo = math.log(grid[j - 1]) if j > 1 else math.log(grid[1]) - math.log(10.0)
        res = minimize_scalar(lambda x: solve(math.exp(x))[0], bounds=(lo, math.log(grid[j + 1])), method="bounded",
                              options={"xatol": 1e-4})
        if res.fun < best:
            rho, best = math.exp(float(res.x)), float(res.fun)
    _, beta, m_inv, _, w = solve(rho)
    limit = best + RHO_LEVEL
    above = np.flatnonzero((grid > rho) & (nll > limit))
    if above.size == 0:
        rho_up = float(grid[-1])
    else:
        hi = float(grid[above[0]])
        lo = max(rho, float(grid[above[0] - 1]))
        f = lambda x: solve(math.exp(x))[0] - limit            # noqa: E731
        lo_x = math.log(lo) if lo > 0.0 else math.log(hi) - 20.0
        rho_up = math.exp(brentq(f, lo_x, math.log(hi), xtol=1e-4)) if f(lo_x) < 0.0 else lo
    _, _, _, s2_up, _ = solve(rho_up)
    # the estimate's covariance where the noise is C(rho_up): M^-1 A^T W D_up W A M^-1 (W, M at the estimate's rho)
    d_up = 1.0 + rho_up * lam
    cov = s2_up * m_inv @ (a_t.T @ ((w * w * d_up)[:, None] * a_t)) @ m_inv
    # the ordinary least-squares estimate's covariance there too (the sandwich (A^T A)^-1 A^T D_up A (A^T A)^-1)
    m0_inv = np.linalg.inv(a_t.T @ a_t)
    cov_ols = s2_up * m0_inv @ (a_t.T @ (d_up[:, None] * a_t)) @ m0_inv
    return beta, cov, cov_ols, solve(rho)[3], rho, rho_up


def _residual_noise(resid: np.ndarray, dt_s: float, sensor: str):
    """The Allan fit of one axis's per-interval residual (as a rate): ``(screened analysis, coefficients used)``."""
    from sins_sim.navigation.allan import allan_deviation, fit_allan, screen_noise

    curve = allan_deviation(resid / dt_s, 1.0 / dt_s)
    fit = fit_allan(curve, "gyro" if sensor == "gyro" else "accel")
    used = {k: float(v) for k, v in fit.coefficients.items() if k in ("quantization", "white", "flicker",
                                                                       "random_walk") and math.isfinite(v)}
    return screen_noise(fit), used


def fit_against_truth(dt_s: float, meas: dict, ideal: dict) -> TruthFit:
    """Fit each triad's bias, scale factors and misalignments (module docstring).

    Parameters
    ----------
    dt_s : float
        The increments' interval (s).
    meas, ideal : dict
        ``gyro`` and ``accelerometer``: the log's increments and the truth's ideal ones, (N, 3) each (rad, m/s).

    Raises
    ------
    ValueError
        Shapes that differ, or fewer blocks than twice the unknowns.
    """
    per = max(1, int(round(BLOCK_S / dt_s)))
    out = {k: {} for k in ("bias", "bias_sigma", "e", "e_sigma", "rms", "noise", "used", "ols", "ratio")}
    blocks = None
    for s in ("gyro", "accelerometer"):
        xm, xt = np.asarray(meas[s], dtype=np.float64), np.asarray(ideal[s], dtype=np.float64)
        if xm.shape != xt.shape or xm.ndim != 2 or xm.shape[1] != 3:
            raise ValueError(f"{s}: the log's and the truth's increments must both have shape (N, 3), got "
                             f"{xm.shape} and {xt.shape}")
        per = max(per, -(-xm.shape[0] // MAX_BLOCKS))
        k = xm.shape[0] // per
        if k < 8:
            raise ValueError(f"{s}: {k} blocks of {per * dt_s:g} s, fewer than 8 (twice the four unknowns of a row)")
        blocks = k
        err = (xm - xt)[:k * per]
        y = err.reshape(k, per, 3).sum(axis=1)
        x = xt[:k * per].reshape(k, per, 3).sum(axis=1)
        a_full = np.column_stack([np.full(k, per * dt_s), x])
        # scale the columns to unit size before the excitation test and the solve (rad vs s)
        scale = np.linalg.norm(a_full, axis=0)
        scale[scale == 0.0] = 1.0
        a_n = a_full / scale
        bias, bias_sig = np.full(3, np.nan), np.full(3, np.nan)
        e, e_sig = np.full((3, 3), np.nan), np.full((3, 3), np.nan)
        ols_b, ols_e = np.full(3, np.nan), np.full((3, 3), np.nan)
        rms, ratio = np.zeros(3), np.zeros(3)
        analyses, used_all = [], []
        keep = _excited(a_n)
        a_k = a_n[:, keep]
        cov_unit = np.linalg.inv(a_k.T @ a_k)
        dof = k - len(keep)
        # the per-interval regressors of the kept columns (the bias's is dt), in the same scaling
        per_interval = np.column_stack([np.full(k * per, dt_s), xt[:k * per]])[:, keep] / scale[keep]
        lam, vec = np.linalg.eigh(walk_covariance(k, per * dt_s))
        lam = np.maximum(lam, 0.0)
        a_t = vec.T @ a_k
        for i in range(3):
            coef = cov_unit @ (a_k.T @ y[:, i])
            resid = y[:, i] - a_k @ coef
            rms[i] = math.sqrt(float(resid @ resid) / k)
            ols_sig = np.sqrt(np.diag(cov_unit) * float(resid @ resid) / dof)
            analysis, used = _residual_noise(err[:, i] - per_interval @ coef, dt_s, s)
            # the terms are the ordinary least-squares ones (the estimator the twin's candidates are projected with,
            # twin_explain_moving._perp), their covariance the one the walk's likelihood bound gives them
            _, _, cov_beta, s2, rho, rho_up = _reml(a_t, vec.T @ y[:, i], lam)
            beta = coef
            # SI: a block's white variance (unit^2), the walk's K^2 (unit^2 / s^3) and its upper end used for the sigmas
            used.update(block_white_variance=s2, block_random_walk=s2 * rho, block_random_walk_upper=s2 * rho_up)
            analyses.append(analysis)
            used_all.append(used)
            ratio[i] = s2 * dof / float(resid @ resid)      # the white part against the white-noise fit's
            sig = np.sqrt(np.diag(cov_beta))
            for c, col in enumerate(keep):
                val, sd, so = beta[c] / scale[col], sig[c] / scale[col], ols_sig[c] / scale[col]
                if col == 0:
                    bias[i], bias_sig[i], ols_b[i] = val, sd, so
                else:
                    e[i, col - 1], e_sig[i, col - 1], ols_e[i, col - 1] = val, sd, so
        out["bias"][s], out["bias_sigma"][s], out["e"][s], out["e_sigma"][s], out["rms"][s] = bias, bias_sig, e, e_sig, rms
        out["noise"][s], out["used"][s], out["ratio"][s] = analyses, used_all, ratio
        out["ols"][s] = {"bias": ols_b, "e": ols_e}
    return TruthFit(out["bias"], out["bias_sigma"], out["e"], out["e_sigma"], blocks, out["rms"], per * dt_s,
                    out["noise"], out["used"], out["ols"], out["ratio"])
