"""Biases, scale factors and misalignments of a moving log against its known trajectory (least squares).

Arrays in, numbers out (SI inside; deg/h, ug, ppm and arcsec at :meth:`TruthFit.to_dict`).

The truth gives each interval's ideal increments ``x_true`` (:func:`sins_sim.simulation.external.ideal_increments`:
the exact integrals of the body rate and specific force). The error model of each triad (Groves 2013, sec. 4.4.6;
Titterton and Weston 2004, ch. 4; the convention of :mod:`sins_sim.models.sensor_errors`) is

    x_meas = x_true + b dt + E x_true + n

with ``b`` the bias, ``E`` the scale factors ``S_i`` on its diagonal and the misalignments ``M_ij`` (sensor ``i``
towards body axis ``j``) off it. Being linear per interval, it holds for sums over blocks of intervals:
row ``i`` of the errors ``y = x_meas - x_true`` summed over block ``k`` of length ``T_k`` is
``Y_ik = b_i T_k + sum_j E_ij X_jk``. Each row is an ordinary least-squares fit of ``(b_i, E_i1, E_i2, E_i3)`` on
one-second blocks (:data:`BLOCK_S`); the noise of a block sum is white for white noise and for anything correlated
over less than a block, and its variance is read off the residuals, ``s^2 = RSS / (K - p)``, the covariance
``s^2 (A^T A)^-1`` (Draper and Smith 1998, ch. 5).

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

from sins_sim.units import ARCSEC, DEG_PER_H, MICRO_G

__all__ = ["BLOCK_S", "EXCITATION_MIN", "TruthFit", "fit_against_truth"]

#: The blocks the increments are summed over (s): long enough to average the quantisation and white noise, short
#: enough to follow the motion (a manoeuvre of seconds).
BLOCK_S = 1.0
#: Least ``1 - R^2`` of a column's regression on the others for it to be fitted: 1e-6, a variance inflation of 1e6
#: (a term then still gets a sigma a thousand times that of an orthogonal design; below it the term is not told from
#: the others at all).
EXCITATION_MIN = 1e-6
NOT_OBSERVABLE = "not observable (the motion does not excite it apart from the other terms)"


@dataclass(frozen=True)
class TruthFit:
    """Per triad (``gyro``, ``accelerometer``): ``bias`` (3,) and ``e`` (3, 3) in SI with their 1-sigma
    ``bias_sigma``, ``e_sigma``; NaN where not observable. ``blocks``: the blocks fitted; ``rms_residual``: per triad
    and axis the residual's RMS per block (rad, m/s)."""

    bias: dict
    bias_sigma: dict
    e: dict
    e_sigma: dict
    blocks: int
    rms_residual: dict

    def to_dict(self) -> dict:
        """Edge units: gyro bias deg/h, accelerometer bias ug, scale factors ppm, misalignments arcsec (``xy``:
        sensor x towards body y); each ``{value, sigma}`` or ``{status: not observable ...}``."""
        out = {"blocks": self.blocks, "block_s": BLOCK_S}
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
            out[s] = sec
        return out


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
    out = {k: {} for k in ("bias", "bias_sigma", "e", "e_sigma", "rms")}
    blocks = None
    for s in ("gyro", "accelerometer"):
        xm, xt = np.asarray(meas[s], dtype=np.float64), np.asarray(ideal[s], dtype=np.float64)
        if xm.shape != xt.shape or xm.ndim != 2 or xm.shape[1] != 3:
            raise ValueError(f"{s}: the log's and the truth's increments must both have shape (N, 3), got "
                             f"{xm.shape} and {xt.shape}")
        k = xm.shape[0] // per
        if k < 8:
            raise ValueError(f"{s}: {k} blocks of {BLOCK_S:g} s, fewer than 8 (twice the four unknowns of a row)")
        blocks = k
        y = (xm - xt)[:k * per].reshape(k, per, 3).sum(axis=1)
        x = xt[:k * per].reshape(k, per, 3).sum(axis=1)
        a_full = np.column_stack([np.full(k, per * dt_s), x])
        # scale the columns to unit size before the excitation test and the solve (rad vs s)
        scale = np.linalg.norm(a_full, axis=0)
        scale[scale == 0.0] = 1.0
        a_n = a_full / scale
        bias, bias_sig = np.full(3, np.nan), np.full(3, np.nan)
        e, e_sig = np.full((3, 3), np.nan), np.full((3, 3), np.nan)
        rms = np.zeros(3)
        keep = _excited(a_n)
        a_k = a_n[:, keep]
        cov_unit = np.linalg.inv(a_k.T @ a_k)
        for i in range(3):
            coef = cov_unit @ (a_k.T @ y[:, i])
            resid = y[:, i] - a_k @ coef
            dof = k - len(keep)
            s2 = float(resid @ resid) / dof
            rms[i] = math.sqrt(float(resid @ resid) / k)
            sig = np.sqrt(np.diag(cov_unit) * s2)
            for c, col in enumerate(keep):
                val, sd = coef[c] / scale[col], sig[c] / scale[col]
                if col == 0:
                    bias[i], bias_sig[i] = val, sd
                else:
                    e[i, col - 1], e_sig[i, col - 1] = val, sd
        out["bias"][s], out["bias_sigma"][s], out["e"][s], out["e_sigma"][s], out["rms"][s] = bias, bias_sig, e, e_sig, rms
    return TruthFit(out["bias"], out["bias_sigma"], out["e"], out["e_sigma"], blocks, out["rms"])
