"""Smoothing fit of sampled positions and measured velocities (a recorded trajectory's truth).

A recorded flight log carries its positions rounded (7 decimals of a degree: 1 cm) and its velocity as a
measurement (GNSS grade: 0.01-0.1 m/s of noise). Interpolating the positions and checking the velocity against
the interpolant's derivative refuses such a file: the derivative of 1 cm of rounding at 10 Hz is already ~0.1
m/s. Here both are measurements of one smooth motion and the truth is the fit of both.

Model. Each axis (north, east: latitude and longitude offsets scaled to metres at the first sample; up: the
height) is a constant-acceleration motion driven by white jerk of power spectral density ``q`` (m^2/s^5), the
continuous Wiener-process-acceleration model of [1] sec. 6.2.3: state ``(p, v, a)``, transition
``F = [[1, h, h^2/2], [0, 1, h], [0, 0, 1]]`` and process noise
``Q = q [[h^5/20, h^4/8, h^3/6], [h^4/8, h^3/3, h^2/2], [h^3/6, h^2/2, h]]`` over a step ``h``. The samples
measure ``p`` with noise ``sigma_p`` and ``v`` with noise ``sigma_v``. The fixed-interval Rauch-Tung-Striebel
smoother [2] gives ``(p, v, a)`` at every sample given the whole file; between samples the quintic Hermite
polynomial through the smoothed ``(p, v, a)`` at both ends is the same estimate: the smoothed mean of an
integrated-Wiener model is the polynomial smoothing spline (here quintic, penalty ``int (p''')^2``; [3], [4]),
so position, velocity and acceleration of the truth are one C2 function and its derivatives.

Parameters from the file itself:

* ``sigma_p``, ``sigma_v``: difference-based noise estimates ([5]): the normalised divided differences of
  order 4 over 5 consecutive samples annihilate cubics, so on a smooth motion they hold the noise alone
  (unit gain for white noise of any spacing); the scale is their median absolute value / 0.6745 (robust to
  manoeuvres). Floors 1e-6 m and 1e-6 m/s keep the filter well conditioned (a file written to 1e-8 m is then
  fitted within micrometres).
* ``q``: the larger of the maximum-likelihood values ([1] sec. 5.5, the innovations' likelihood) fitted to the
  positions alone and to the velocities alone, per axis. Each describes a motion the file could be; neither
  lets the joint fit bend to reconcile a velocity that contradicts the positions (a fitted ``q`` from both
  together would grow until the fit matched both, with absurd accelerations in between), so a contradiction
  remains in the residuals, which the caller checks.

References
----------
.. [1] Y. Bar-Shalom, X. R. Li, T. Kirubarajan, *Estimation with Applications to Tracking and Navigation*,
   Wiley 2001, sec. 6.2.3 (continuous Wiener process acceleration model) and 5.5 (likelihood of a filter).
.. [2] H. E. Rauch, F. Tung, C. T. Striebel, "Maximum likelihood estimates of linear dynamic systems",
   AIAA J. 3(8), 1445-1450, 1965.
.. [3] G. Wahba, "Improper priors, spline smoothing and the problem of guarding against model errors in
   regression", J. R. Stat. Soc. B 40, 364-372, 1978.
.. [4] W. E. Wecker, C. F. Ansley, "The signal extraction approach to nonlinear regression and spline
   smoothing", J. Am. Stat. Assoc. 78, 81-89, 1983.
.. [5] P. Hall, J. W. Kay, D. M. Titterington, "Asymptotically optimal difference-based estimation of variance
   in nonparametric regression", Biometrika 77(3), 521-528, 1990.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.interpolate import PPoly
from scipy.optimize import minimize_scalar

from sins_sim._kernels._config import jit

__all__ = ["SmoothFit", "noise_scale", "quantisation_sigma", "smooth_axis", "fit_positions_velocities",
           "quintic_hermite"]

#: Floors of the noise estimates (m, m/s): conditioning of the filter, far below any file's resolution that matters.
SIGMA_P_FLOOR_M = 1e-8
SIGMA_V_FLOOR_M_S = 1e-6
#: Prior standard deviation of the acceleration at the first sample (m/s^2).
A0_SIGMA_M_S2 = 100.0
#: Search range of log10 q (q in m^2/s^5): 1e-8 (a ship) .. 1e10 (far beyond any vehicle's jerk).
LOG10_Q_RANGE = (-8.0, 10.0)


def noise_scale(t, x) -> float:
    """Robust scale of the noise on samples ``x`` at times ``t``: median |normalised 4th divided difference| / 0.6745.

    The weights of the divided difference over 5 consecutive samples, ``w_j = 1 / prod_{i != j} (t_j - t_i)``,
    annihilate polynomials of degree <= 3 at any spacing; normalised to unit length they pass white noise of
    standard deviation ``sigma`` with standard deviation ``sigma`` ([5]). Fewer than 5 samples: 0.
    """
    t = np.asarray(t, dtype=np.float64)
    x = np.asarray(x, dtype=np.float64)
    n = t.size
    if n < 5:
        return 0.0
    idx = np.arange(n - 4)[:, None] + np.arange(5)[None, :]
    tt = t[idx] - t[idx[:, 2:3]]  # centred, for conditioning
    diff = tt[:, :, None] - tt[:, None, :]
    diff[:, np.arange(5), np.arange(5)] = 1.0
    w = 1.0 / np.prod(diff, axis=2)
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    d = np.einsum("ij,ij->i", w, x[idx])
    return float(np.median(np.abs(d)) / 0.6744897501960817)


@jit
def _ca_smoother(t, zp, rp, zv, rv, q, use_p, use_v, a0_var, out, var_v, smooth):
    """Kalman filter and RTS smoother of the constant-acceleration model ([1] 6.2.3, [2]) on one axis.

    ``zp, rp``: position measurements and their variances; ``zv, rv``: velocities and variances; ``use_p``,
    ``use_v``: which to use. With ``smooth``, ``out`` (n, 3) receives the smoothed (p, v, a) and ``var_v`` (n,)
    the smoothed variance of v (the RTS covariance recursion [2]); without, only the likelihood is formed.
    Returns the negative log-likelihood of the innovations after the first sample ([1] 5.5; constants dropped).
    The forward pass works on preallocated 3 x 3 buffers (no array per step).
    """
    n = t.size
    nstore = n if smooth else 1
    xf = np.empty((nstore, 3))
    pf = np.empty((nstore, 3, 3))
    xp = np.empty((nstore, 3))
    pp = np.empty((nstore, 3, 3))
    x = np.zeros(3)
    p = np.zeros((3, 3))
    fp = np.empty((3, 3))
    ap = np.empty((3, 3))
    kg = np.empty(3)
    x[0] = zp[0] if use_p else 0.0
    x[1] = zv[0] if use_v else 0.0
    p[0, 0] = rp[0] if use_p else 1e12
    p[1, 1] = rv[0] if use_v else 1e8
    p[2, 2] = a0_var
    nll = 0.0
    for k in range(n):
        if k > 0:
            h = t[k] - t[k - 1]
            h2 = h * h
            h3 = h2 * h
            hh = 0.5 * h2
            x[0] = x[0] + h * x[1] + hh * x[2]
            x[1] = x[1] + h * x[2]
            # F P (rows of F: (1, h, h^2/2), (0, 1, h), (0, 0, 1))
            for j in range(3):
                fp[0, j] = p[0, j] + h * p[1, j] + hh * p[2, j]
                fp[1, j] = p[1, j] + h * p[2, j]
                fp[2, j] = p[2, j]
            # (F P) F' + Q
            for i in range(3):
                p[i, 0] = fp[i, 0] + h * fp[i, 1] + hh * fp[i, 2]
                p[i, 1] = fp[i, 1] + h * fp[i, 2]
                p[i, 2] = fp[i, 2]
            p[0, 0] += q * h3 * h2 / 20.0
            p[0, 1] += q * h2 * h2 / 8.0
            p[1, 0] += q * h2 * h2 / 8.0
            p[0, 2] += q * h3 / 6.0
            p[2, 0] += q * h3 / 6.0
            p[1, 1] += q * h3 / 3.0
            p[1, 2] += q * h2 / 2.0
            p[2, 1] += q * h2 / 2.0
            p[2, 2] += q * h
            for i in range(3):
                for j in range(i + 1, 3):
                    sym = 0.5 * (p[i, j] + p[j, i])
                    p[i, j] = sym
                    p[j, i] = sym
        if smooth:
            xp[k] = x
            pp[k] = p
        for m in range(2):
            if (m == 0 and not use_p) or (m == 1 and not use_v) or k == 0:
                continue  # unused, or the first sample (it initialised the state)
            z = zp[k] if m == 0 else zv[k]
            r = rp[k] if m == 0 else rv[k]
            sv = p[m, m] + r
            nu = z - x[m]
            nll += 0.5 * (math.log(sv) + nu * nu / sv)
            for i in range(3):
                kg[i] = p[i, m] / sv
                x[i] += kg[i] * nu
            # Joseph form (I - K e_m') P (I - K e_m')' + r K K', symmetric and positive
            for i in range(3):
                for j in range(3):
                    ap[i, j] = p[i, j] - kg[i] * p[m, j]
            for i in range(3):
                for j in range(3):
                    p[i, j] = ap[i, j] - ap[i, m] * kg[j] + r * kg[i] * kg[j]
        if smooth:
            xf[k] = x
            pf[k] = p
    if not smooth:
        return nll
    out[n - 1] = xf[n - 1]
    ps = pf[n - 1].copy()
    var_v[n - 1] = ps[1, 1]
    f = np.eye(3)
    for k in range(n - 2, -1, -1):
        h = t[k + 1] - t[k]
        f[0, 1] = h
        f[0, 2] = 0.5 * h * h
        f[1, 2] = h
        # G = P_f F' P_p^-1, i.e. G' = solve(P_p, F P_f) (P_p symmetric)
        g = np.linalg.solve(pp[k + 1], f @ pf[k]).T
        out[k] = xf[k] + g @ (out[k + 1] - xp[k + 1])
        ps = pf[k] + g @ (ps - pp[k + 1]) @ g.T
        var_v[k] = ps[1, 1]
    return nll


def smooth_axis(t, zp, sigma_p, zv, sigma_v, q, use_p=True, use_v=True, var_v=None, smooth=True):
    """Smoothed ``(p, v, a)`` (n, 3) and the negative log-likelihood on one axis (see :func:`_ca_smoother`).

    ``sigma_p`` and ``sigma_v`` are scalars or per-sample arrays (standard deviations); ``var_v`` (n,), if given,
    receives the smoothed variance of the velocity. ``smooth=False``: the forward filter's likelihood alone
    (the first value is then not filled).
    """
    n = len(t)
    out = np.empty((n, 3))
    var_v = np.empty(n) if var_v is None else var_v
    rp = np.broadcast_to(np.asarray(sigma_p, dtype=np.float64) ** 2, (n,)).copy()
    rv = np.broadcast_to(np.asarray(sigma_v, dtype=np.float64) ** 2, (n,)).copy()
    nll = _ca_smoother(np.ascontiguousarray(t, dtype=np.float64), np.ascontiguousarray(zp, dtype=np.float64), rp,
                       np.ascontiguousarray(zv, dtype=np.float64), rv, float(q), bool(use_p), bool(use_v),
                       A0_SIGMA_M_S2 ** 2, out, var_v, bool(smooth))
    return out, nll


#: Longest stretch of samples the likelihood of ``q`` is evaluated on; longer files use ML_BLOCKS evenly spaced
#: blocks of ML_SAMPLES / ML_BLOCKS contiguous samples (the likelihood is a sum over samples; a one-hour log at
#: 10 Hz would otherwise cost ~100 smoother passes of 36000 samples).
ML_SAMPLES = 20000
ML_BLOCKS = 10


def _ml_q(t, zp, rp, zv, rv, use_p, use_v) -> float:
    """Maximum-likelihood ``q`` (m^2/s^5) of one axis from the positions or the velocities alone ([1] 5.5)."""
    n = len(t)
    rp = np.broadcast_to(np.asarray(rp, dtype=np.float64), (n,))
    rv = np.broadcast_to(np.asarray(rv, dtype=np.float64), (n,))
    if n > ML_SAMPLES:
        m = ML_SAMPLES // ML_BLOCKS
        starts = np.linspace(0, n - m, ML_BLOCKS).astype(np.int64)
        blocks = [slice(int(a), int(a) + m) for a in starts]
    else:
        blocks = [slice(0, n)]

    def nll(lq):
        return sum(smooth_axis(t[b], zp[b], rp[b], zv[b], rv[b], 10.0 ** lq, use_p, use_v, smooth=False)[1]
                   for b in blocks)

    lo, hi = LOG10_Q_RANGE
    res = minimize_scalar(nll, bounds=(lo, hi), method="bounded", options={"xatol": 0.05})
    return float(10.0 ** res.x)


class SmoothFit:
    """The result of :func:`fit_positions_velocities` on three axes (arrays (n, 3) unless said).

    Attributes
    ----------
    p, v, a : ndarray (n, 3)
        Smoothed position, velocity, acceleration (the fit's units: m, m/s, m/s^2) from positions and velocities.
    v_positions : ndarray (n, 3)
        The velocity of the smoothing fit of the positions alone (the check of the measured velocity).
    sigma_check : ndarray (n, 3)
        Standard deviation of ``measured velocity - v_positions`` if both describe the same motion: the velocity
        noise and the fit's own uncertainty (from the smoother's covariance), in the fit's units.
    sigma_p, sigma_v, q : ndarray (3,)
        Noise standard deviations and the jerk spectral densities used (m, m/s, m^2/s^5).
    """

    def __init__(self, p, v, a, v_positions, sigma_check, sigma_p, sigma_v, q):
        self.p, self.v, self.a, self.v_positions, self.sigma_check = p, v, a, v_positions, sigma_check
        self.sigma_p, self.sigma_v, self.q = sigma_p, sigma_v, q


def quantisation_sigma(x, unit: float, max_decimals: int = 12) -> float:
    """Standard deviation of the rounding of values written to a fixed number of decimals (in units of ``x``).

    ``x`` is taken as written with ``k`` decimals of ``unit`` for the smallest ``k <= max_decimals`` at which
    every value is a whole number of ``10^-k unit`` (to 1e-3 of a step, float64's representation of a
    decimal); the rounding error is then uniform over one step: ``10^-k unit / sqrt(12)`` (Widrow & Kollar,
    *Quantization Noise*, Cambridge 2008, ch. 4). No such ``k``: 0 (a file at full float resolution); a constant
    column (a level flight's height of 1500.0) shows no step either: 0.
    """
    x = np.asarray(x, dtype=np.float64) / unit
    if x.size == 0 or np.ptp(x) == 0.0:
        return 0.0
    for k in range(max_decimals + 1):
        y = x * 10.0 ** k
        if np.all(np.abs(y - np.round(y)) < 1e-3):
            return 10.0 ** -k * unit / math.sqrt(12.0)
    return 0.0


def fit_positions_velocities(t, pos, vel, vel_scale=None, sigma_p_min=None, sigma_v_min=None) -> SmoothFit:
    """Smoothing fit of positions ``pos`` (n, 3, m) and velocities ``vel`` (n, 3, m/s) measured at times ``t``.

    Parameters
    ----------
    t : ndarray (n,)
        Strictly increasing times (s), n >= 4.
    pos, vel : ndarray (n, 3)
        Per axis, the position and its measured rate (same axes and units per second).
    vel_scale : ndarray (n, 3), optional
        Per-sample factor by which the velocity noise of the file maps into ``vel`` (the metres of the fit's
        axes per metre of the local axes); 1 when omitted.
    sigma_p_min, sigma_v_min : array_like (3,), optional
        Lower bounds of the noise estimates (m, m/s of the file), e.g. the rounding of its decimals
        (:func:`quantisation_sigma`): a rounded value that stays constant has no difference to estimate from.

    Returns
    -------
    SmoothFit
        The jerk density ``q`` of each axis is the maximum-likelihood value of the positions alone ([1] 5.5):
        the motion the positions describe, so that a velocity contradicting them cannot bend the fit without
        showing in ``v - v_positions``.
    """
    t = np.asarray(t, dtype=np.float64)
    scale = np.ones_like(vel) if vel_scale is None else np.asarray(vel_scale, dtype=np.float64)
    p_min = np.zeros(3) if sigma_p_min is None else np.asarray(sigma_p_min, dtype=np.float64)
    v_min = np.zeros(3) if sigma_v_min is None else np.asarray(sigma_v_min, dtype=np.float64)
    n = t.size
    p, v, a, vp, sc = np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3))
    var = np.empty(n)
    sp, sv, qs = np.empty(3), np.empty(3), np.empty(3)
    for i in range(3):
        sp[i] = max(noise_scale(t, pos[:, i]), p_min[i], SIGMA_P_FLOOR_M)
        sv[i] = max(noise_scale(t, vel[:, i] / scale[:, i]), v_min[i], SIGMA_V_FLOOR_M_S)
        rv = sv[i] * scale[:, i]
        qs[i] = _ml_q(t, pos[:, i], sp[i], vel[:, i], rv, True, False)
        # the check's fit of the positions alone bends as much as either source says the motion does (a short file
        # of coarse positions under-states it), so its uncertainty covers the motion the velocities show
        q_check = max(qs[i], _ml_q(t, pos[:, i], sp[i], vel[:, i], rv, False, True))
        vp[:, i] = smooth_axis(t, pos[:, i], sp[i], vel[:, i], rv, q_check, True, False, var)[0][:, 1]
        sc[:, i] = np.sqrt(np.maximum(var, 0.0) + rv ** 2)
        out, _ = smooth_axis(t, pos[:, i], sp[i], vel[:, i], rv, qs[i])
        p[:, i], v[:, i], a[:, i] = out[:, 0], out[:, 1], out[:, 2]
    return SmoothFit(p, v, a, vp, sc, sp, sv, qs)


def quintic_hermite(t, p, v, a) -> PPoly:
    """The piecewise quintic through values ``p``, first derivatives ``v`` and second derivatives ``a`` (n, ...)
    at the knots ``t`` (C2; the smoothing spline of the fit between its samples, module docstring)."""
    t = np.asarray(t, dtype=np.float64)
    h = np.diff(t).reshape((-1,) + (1,) * (np.ndim(p) - 1))
    p0, p1, v0, v1, a0, a1 = p[:-1], p[1:], v[:-1], v[1:], a[:-1], a[1:]
    d = p1 - p0 - v0 * h - 0.5 * a0 * h * h
    e = v1 - v0 - a0 * h
    f = a1 - a0
    c3 = (10.0 * d - 4.0 * e * h + 0.5 * f * h * h) / h ** 3
    c4 = (-15.0 * d + 7.0 * e * h - f * h * h) / h ** 4
    c5 = (6.0 * d - 3.0 * e * h + 0.5 * f * h * h) / h ** 5
    return PPoly(np.stack([c5, c4, c3, 0.5 * a0, v0, p0]), t)
