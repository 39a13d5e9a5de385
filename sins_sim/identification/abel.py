"""Elastic nonlinearity from the resonance-vs-amplitude curve: the paper's eq. 6-9.

The period of a conservative oscillator fixes the shape of its potential
well (Landau and Lifshitz, Mechanics, eq. 12.2, the paper's eq. 6). With the
energy written through an "energy amplitude" ``a`` (``U = c a^2 / 2``) and the
resonance frequency ``F(v)`` measured at energy amplitude ``v``, the turning
point reached at energy ``U(a)`` is (eq. 7)::

    phi(a) = F0 * int_0^a v dv / (F(v) sqrt(a^2 - v^2))

and the restoring torque ``-c (phi + Nonl(phi))`` follows from
``U(phi) = c a(phi)^2 / 2`` (eq. 8)::

    Nonl(phi) = a(phi) da/dphi - phi = a / phi'(a) - phi(a).

Numerics
--------
``F`` is interpolated linearly between the samples and extrapolated linearly
to zero amplitude from the first two samples, as the paper did. The
integrable singularity ``1/sqrt(a^2 - v^2)`` is removed by ``v = a sin(u)``::

    phi(a)  = F0 int_0^{pi/2} a sin(u) / F(a sin u) du
    phi'(a) = F0 int_0^{pi/2} sin(u) [1/F(v) - v F'(v)/F(v)^2] du,   v = a sin u

Both integrands are smooth between the breakpoints ``u_k = arcsin(v_k/a)``
of the interpolant (``F'`` is piecewise constant), so each piece is
integrated by 24-point Gauss-Legendre: exact to round-off for the
interpolant. ``F(0)`` of the extrapolation is ``F0`` unless given.

Amplitudes: eq. 7 wants ``F`` as a function of the *energy* amplitude; a
measurement gives it at the *true* amplitude (the turning point), which for
the softening spring of eq. 9 is about 0.4 % larger at 3 arcmin. With
``amplitude="true"`` the samples are relabelled self-consistently (the
inversion itself says which energy amplitude reaches a given turning point;
a fixed-point iteration converges in a few steps). ``amplitude="energy"`` is
the paper's shortcut (samples taken as energy amplitudes).

Functions
---------
.. autosummary::

   FrequencyCurve
   phi_of_a
   abel_invert
   fit_nonl
   identify_nonl
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import optimize

from sins_sim import _validate as v
from sins_sim.models.suspension import nonl_array

__all__ = ["FrequencyCurve", "AbelResult", "NonlFit", "phi_of_a", "abel_invert", "fit_nonl", "identify_nonl"]

_GL_X, _GL_W = np.polynomial.legendre.leggauss(24)


@dataclass(frozen=True)
class FrequencyCurve:
    """Piecewise-linear ``F(v)`` through samples, linearly extrapolated to ``v = 0``.

    Parameters
    ----------
    amplitudes : array_like
        Sample amplitudes (rad), > 0, strictly increasing after sorting, at least 2.
    freqs : array_like
        Resonance frequency at each amplitude (Hz), > 0.
    f0_hz : float or None
        ``F(0)``; ``None`` = extrapolate the first two samples linearly to zero.
    """

    amplitudes: np.ndarray
    freqs: np.ndarray
    f0_hz: float | None = None

    def __post_init__(self):
        a = v.finite_array("abel", "amplitudes", self.amplitudes)
        f = v.finite_array("abel", "freqs", self.freqs)
        if a.size < 2 or a.size != f.size:
            raise ValueError(f"abel.amplitudes: need >= 2 samples, as many as freqs, got {a.size} and {f.size}")
        order = np.argsort(a)
        a, f = a[order], f[order]
        if a[0] <= 0.0 or np.any(np.diff(a) <= 0.0):
            raise ValueError("abel.amplitudes: must be > 0 and distinct")
        if np.any(f <= 0.0):
            raise ValueError("abel.freqs: must be > 0")
        f0 = self.f0_hz
        if f0 is None:
            f0 = f[0] - a[0] * (f[1] - f[0]) / (a[1] - a[0])
        f0 = v.positive("abel", "f0_hz", f0)
        knots = np.concatenate(([0.0], a))
        values = np.concatenate(([f0], f))
        knots.setflags(write=False)
        values.setflags(write=False)
        object.__setattr__(self, "amplitudes", a)
        object.__setattr__(self, "freqs", f)
        object.__setattr__(self, "f0_hz", float(f0))
        object.__setattr__(self, "_knots", knots)
        object.__setattr__(self, "_values", values)

    @property
    def a_max(self) -> float:
        """Largest sample amplitude (rad): eq. 7 is evaluated up to it."""
        return float(self.amplitudes[-1])

    def _segment(self, x):
        k = np.clip(np.searchsorted(self._knots, x, side="right") - 1, 0, self._knots.size - 2)
        return k

    def __call__(self, x):
        """F at amplitudes ``x`` (rad); linear beyond the last sample too."""
        x = np.asarray(x, dtype=np.float64)
        k = self._segment(x)
        x0, x1 = self._knots[k], self._knots[k + 1]
        y0, y1 = self._values[k], self._values[k + 1]
        return y0 + (y1 - y0) * (x - x0) / (x1 - x0)

    def slope(self, x):
        """dF/dv (Hz/rad), piecewise constant."""
        x = np.asarray(x, dtype=np.float64)
        k = self._segment(x)
        return (self._values[k + 1] - self._values[k]) / (self._knots[k + 1] - self._knots[k])


def _pieces(curve: FrequencyCurve, a: float) -> np.ndarray:
    """Breakpoints in u = arcsin(v / a) of the interpolant on [0, pi/2]."""
    inner = curve._knots[(curve._knots > 0.0) & (curve._knots < a)]
    return np.concatenate(([0.0], np.arcsin(inner / a), [0.5 * math.pi]))


def _phi_and_slope(curve: FrequencyCurve, a: float) -> tuple[float, float]:
    """eq. 7 phi(a) and its derivative, piecewise Gauss-Legendre in u."""
    if a <= 0.0:
        return 0.0, 1.0
    edges = _pieces(curve, a)
    lo, hi = edges[:-1, None], edges[1:, None]
    u = 0.5 * (hi - lo) * _GL_X[None, :] + 0.5 * (hi + lo)
    w = 0.5 * (hi - lo) * _GL_W[None, :]
    s = np.sin(u)
    vv = a * s
    # evaluate the slope on the piece it belongs to (midpoints stay off the breakpoints)
    fv = curve(vv)
    dfv = curve.slope(vv)
    f0 = curve.f0_hz
    phi = f0 * float(np.sum(w * a * s / fv))
    dphi = f0 * float(np.sum(w * s * (1.0 / fv - vv * dfv / (fv * fv))))
    return phi, dphi


def phi_of_a(a, curve: FrequencyCurve) -> np.ndarray:
    """Eq. 7: turning point ``phi`` (rad) reached at energy amplitude ``a`` (rad).

    Parameters
    ----------
    a : array_like
        Energy amplitudes (rad), >= 0.
    curve : FrequencyCurve
        ``F(v)`` samples with their interpolation and extrapolation.

    Returns
    -------
    ndarray, same shape as ``a``

    Examples
    --------
    A linear spring (constant F) has phi(a) = a:

    >>> c = FrequencyCurve(np.array([1e-4, 2e-4]), np.array([386.0, 386.0]))
    >>> round(float(phi_of_a(1.5e-4, c)) / 1.5e-4, 12)
    1.0
    """
    arr = np.asarray(a, dtype=np.float64)
    out = np.array([_phi_and_slope(curve, float(x))[0] for x in arr.ravel()])
    return out.reshape(arr.shape)


@dataclass(frozen=True)
class AbelResult:
    """Eq. 7-8 on a grid of energy amplitudes.

    Attributes
    ----------
    a : ndarray
        Energy amplitudes (rad).
    phi : ndarray
        Eq. 7 turning points phi(a) (rad), increasing.
    nonl : ndarray
        Eq. 8 Nonl(phi) at those turning points (rad).
    curve : FrequencyCurve
        The (relabelled, for ``amplitude="true"``) frequency curve used.
    iterations : int
        Fixed-point relabelling steps taken (0 for ``amplitude="energy"``).
    """

    a: np.ndarray
    phi: np.ndarray
    nonl: np.ndarray
    curve: FrequencyCurve
    iterations: int


def _invert_on_grid(curve: FrequencyCurve, n_grid: int):
    a = np.linspace(0.0, curve.a_max, n_grid + 1)[1:]
    vals = np.array([_phi_and_slope(curve, float(x)) for x in a])
    phi, dphi = vals[:, 0], vals[:, 1]
    if np.any(dphi <= 0.0):
        raise ValueError("abel.freqs: phi(a) is not increasing: the samples do not describe a potential well")
    return a, phi, a / dphi - phi


def _energy_label(curve: FrequencyCurve, target: float) -> float:
    """The energy amplitude a with phi(a) = target (phi is increasing)."""

    def g(x):
        return _phi_and_slope(curve, x)[0] - target

    lo = hi = target
    if g(target) > 0.0:
        while g(lo) > 0.0:
            lo *= 0.9
    else:
        while g(hi) < 0.0:
            hi *= 1.1
    if lo == hi:
        return target
    return optimize.brentq(g, lo, hi, xtol=1e-16 * target, rtol=4 * np.finfo(float).eps)


def abel_invert(amplitudes, freqs, f0_hz: float | None = None, amplitude: str = "true", n_grid: int = 200,
                max_iter: int = 20, tol: float = 1e-12) -> AbelResult:
    """Invert a resonance-vs-amplitude curve to the elastic nonlinearity, eq. 7-8.

    Parameters
    ----------
    amplitudes : array_like
        Amplitudes (rad) at which the resonance was measured.
    freqs : array_like
        Resonance frequencies there (Hz).
    f0_hz : float or None
        Small-amplitude resonance F0; ``None`` = linear extrapolation to zero (the paper).
    amplitude : {"true", "energy"}
        What ``amplitudes`` are: measured turning points (relabelled to energy
        amplitudes self-consistently) or already energy amplitudes (the paper's shortcut).
    n_grid : int
        Energy amplitudes in the output grid (uniform on (0, a_max]).
    max_iter, tol : int, float
        Fixed-point iteration limits (relative change of the labels).

    Returns
    -------
    AbelResult
    """
    v.choice("abel", "amplitude", amplitude, ("true", "energy"))
    curve = FrequencyCurve(np.asarray(amplitudes, dtype=np.float64), np.asarray(freqs, dtype=np.float64), f0_hz)
    if amplitude == "energy":
        a, phi, nl = _invert_on_grid(curve, n_grid)
        return AbelResult(a, phi, nl, curve, 0)
    measured = curve.amplitudes
    labels = measured.copy()
    it = 0
    for it in range(1, max_iter + 1):
        cur = FrequencyCurve(labels, curve.freqs, f0_hz)
        # the energy amplitude whose turning point is each measured amplitude: phi(a) = A
        new = np.array([_energy_label(cur, t) for t in measured])
        change = float(np.max(np.abs(new - labels) / measured))
        labels = new
        if change < tol:
            break
    cur = FrequencyCurve(labels, curve.freqs, f0_hz)
    a, phi, nl = _invert_on_grid(cur, n_grid)
    return AbelResult(a, phi, nl, cur, it)


@dataclass(frozen=True)
class NonlFit:
    """Least-squares fit of eq. 9 (plus an optional linear term) to Nonl(phi) samples.

    Attributes
    ----------
    k1, k2 : float
        Eq. 9 parameters (k2 in rad).
    linear : float
        Coefficient ``c`` of the extra term ``c * phi`` (0 when not fitted). A
        relative error ``eps`` of the F0 used in eq. 7 scales phi(a) by
        ``1 + eps`` and shows up, to first order, as ``c = -2 eps``.
    rms : float
        RMS of the fit residual (rad).
    success : bool
        ``scipy.optimize.least_squares`` status.
    """

    k1: float
    k2: float
    linear: float
    rms: float
    success: bool

    def nonl(self, phi):
        """The fitted curve (eq. 9 plus the linear term) at ``phi`` (rad)."""
        phi = np.asarray(phi, dtype=np.float64)
        return nonl_array(phi, self.k1, self.k2) + self.linear * phi


def fit_nonl(phi, nonl, k0=(1e-4, 1e-3), free_linear: bool = True) -> NonlFit:
    """Fit eq. 9's k1, k2 to samples ``nonl`` at angles ``phi`` (rad).

    The unknowns are ``log(k1/k1_0)``, ``log(k2/k2_0)`` (scaled and kept
    positive) and, with ``free_linear``, the coefficient of a term linear in
    ``phi`` that absorbs an error of F0 (eq. 9 itself has ``Nonl'(0) = 0``).
    The residual is scaled by the largest ``|Nonl|``.
    """
    phi = v.finite_array("abel", "phi", phi)
    nonl = v.finite_array("abel", "nonl", nonl)
    k10, k20 = (v.positive("abel", "k1", k0[0]), v.positive("abel", "k2", k0[1]))
    scale = max(float(np.max(np.abs(nonl))), 1e-300)
    lin_scale = scale / max(float(np.max(np.abs(phi))), 1e-300)

    def model(x):
        out = nonl_array(phi, k10 * math.exp(x[0]), k20 * math.exp(x[1]))
        if free_linear:
            out = out + x[2] * lin_scale * phi
        return out

    def resid(x):
        return (model(x) - nonl) / scale

    x0 = np.zeros(3 if free_linear else 2)
    sol = optimize.least_squares(resid, x0, method="lm", xtol=1e-14, ftol=1e-14, gtol=1e-14)
    k1, k2 = k10 * math.exp(sol.x[0]), k20 * math.exp(sol.x[1])
    lin = float(sol.x[2] * lin_scale) if free_linear else 0.0
    rms = float(np.sqrt(np.mean((resid(sol.x) * scale) ** 2)))
    return NonlFit(k1=k1, k2=k2, linear=lin, rms=rms, success=bool(sol.success))


def identify_nonl(amplitudes, freqs, f0_hz: float | None = None, amplitude: str = "true", n_grid: int = 200,
                  k0=(1e-4, 1e-3), refine_f0: bool = True, passes: int = 3) -> tuple[AbelResult, NonlFit]:
    """Eq. 7-8 inversion followed by the eq. 9 fit: samples of F(a) -> (k1, k2).

    Parameters
    ----------
    amplitudes, freqs, f0_hz, amplitude, n_grid
        As :func:`abel_invert`.
    k0 : (float, float)
        Scales (and start) of k1, k2.
    refine_f0 : bool
        ``False``: the paper's procedure (F0 from the linear extrapolation or
        ``f0_hz``, eq. 9 fitted alone). ``True``: also fit a linear term and
        read it as an F0 error (``F0 <- F0 / (1 - c/2)``), then invert again
        (``passes`` times). The linear extrapolation misses F0 because F(a)
        of eq. 9 is curved near zero; a relative F0 error ``eps`` adds
        ``-2 eps phi`` to Nonl, as large as Nonl itself for eps ~ 1e-4 at
        small phi.

    Returns
    -------
    (AbelResult, NonlFit)
        The last inversion (its ``curve.f0_hz`` is the F0 used) and its fit.

    Examples
    --------
    >>> from sins_sim.models.suspension import PAPER_SUSPENSION as s
    >>> amps = np.linspace(0.5, 5.0, 10) * math.pi / 10800
    >>> freqs = [s.resonance_hz_exact(x) for x in amps]
    >>> _, fit = identify_nonl(amps, freqs)
    >>> abs(fit.k1 / s.k1 - 1) < 0.03 and abs(fit.k2 / s.k2 - 1) < 0.03
    True
    """
    res = abel_invert(amplitudes, freqs, f0_hz=f0_hz, amplitude=amplitude, n_grid=n_grid)
    fit = fit_nonl(res.phi, res.nonl, k0, free_linear=refine_f0)
    if not refine_f0:
        return res, fit
    for _ in range(max(int(passes), 0)):
        f0 = res.curve.f0_hz / (1.0 - 0.5 * fit.linear)
        res = abel_invert(amplitudes, freqs, f0_hz=f0, amplitude=amplitude, n_grid=n_grid)
        fit = fit_nonl(res.phi, res.nonl, k0, free_linear=True)
    return res, fit
