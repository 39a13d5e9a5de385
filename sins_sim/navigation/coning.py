"""Coning algorithms: names, coefficients, the classical cone and its error formulas.

The classical cone (Miller 1983; Ignagni 1990; Savage 1998): the body x axis
sweeps a cone of half-angle ``alpha`` (rad) about the navigation x axis at
``Omega`` (rad/s). With ``s = sin(alpha/2)``, ``c = cos(alpha/2)``::

    q_nb(t)  = [c, 0, s cos(Omega t), s sin(Omega t)]
    omega(t) = [-2 Omega s^2, -Omega sin(alpha) sin(Omega t), Omega sin(alpha) cos(Omega t)]

``omega = 2 q* (x) dq/dt`` (Titterton & Weston 2004, ch. 3) links the two
exactly (the same pair as G. Yan's PSINS ``conesimu.m``); ``q_nb`` is periodic,
so the true attitude has no drift. The gyro angle increment over
``[t_{k-1}, t_{k-1} + h]`` is, with ``tm = t_{k-1} + h/2``::

    dtheta_k = [-2 Omega s^2 h,
                -2 sin(alpha) sin(Omega h / 2) sin(Omega tm),
                 2 sin(alpha) sin(Omega h / 2) cos(Omega tm)]

Its constant x component integrates to the **classical coning rate**
``-Omega (1 - cos(alpha)) = -2 Omega sin^2(alpha/2) ~ -Omega alpha^2 / 2``
(:func:`coning_drift_closed_form`): the body-axis rate that the
non-commutativity of the cross-axis rotations must cancel. An algorithm that
cannot see the cross-axis motion at all (``Omega h = 2 pi``: every increment's
cross-axis part is zero) drifts at exactly that rate.

Algorithm residual (leading order in ``alpha``). Per step the cross products
of increments ``j`` steps apart are constant along body x,
``(dtheta_{k-j} x dtheta_k)_x = 2 sin^2(alpha) (1 - cos x) sin(j x)``
(``x = Omega h``), and the exact rotation vector exceeds ``dtheta_k`` along x by
the Bortz coning term ``(1/2) int (theta x omega) dt = (sin^2(alpha)/2)(x - sin x)``
(Bortz 1971; PSINS ``conedrift.m``). The algorithm's drift along the cone
axis is therefore, to ``O(alpha^2)`` (``sin^2(alpha) = alpha^2 + O(alpha^4)``)::

    eps = (sin^2(alpha) / h) [2 (1 - cos x) sum_j c_j sin(j x) - (x - sin x) / 2]

(:func:`algorithm_residual_drift` with ``leading_order=False``). Expanding in
``x``, the coefficients of this module cancel the ``x^3`` (two-sample) and
``x^3, x^5`` (three-sample) terms and leave the published leading terms
(``N`` = samples the algorithm spans; ``N = 1`` is no correction)::

    eps_N = -Omega alpha^2 (Omega h)^(2N) * N! / (2^(N+1) (2N+1)!!)
          = -Omega alpha^2 (Omega h)^2 / 12     N = 1 ("none")
          = -Omega alpha^2 (Omega h)^4 / 60     N = 2 ("two_sample")
          = -Omega alpha^2 (Omega h)^6 / 280    N = 3 ("three_sample")
          = -Omega alpha^2 (Omega h)^8 / 1260   N = 4 ("four_sample")

This is the N-sample optimal-algorithm error of Miller (1983) and Ignagni
(1990) written per sample period ``h``: with the update interval
``T = N h`` it reads ``Omega alpha^2 (Omega T)^4 / 960`` for the two-sample
algorithm (Miller 1983) and ``Omega alpha^2 (Omega T)^6 / 204120`` for
Ignagni's three-sample Algorithm E (``280 * 3^6 = 204120``) and
``Omega alpha^2 (Omega T)^8 / 82575360`` for the four-sample algorithm
(``1260 * 4^8``), the form of the
general expression in G. Yan's PSINS toolbox (``conedrift.m``:
``eps = alpha^2 (Omega h)^(2N+1) N N! / (2^(N+1) (2N+1)!!) / (N h)``). The
previous-sample forms have the same error per sample as the N-sample forms
(Ignagni 1996; Savage 1998 for the 1/12 algorithm) because composing the
per-sample updates adds exactly the missing adjacent cross products:
``3 c1 + 1/2 = 9/20``, ``3 c2 + 1 = 27/20`` (Algorithm E) and
``2 (1/12) + 1/2 = 2/3`` (Miller's two-sample coefficient).

Filtered increments (Mark & Tazartes 2001). When the increments of axis
``j`` pass through a filter of response ``H_j`` (at ``x``; ``H_j(0)`` on the
constant axial rate), the same phase averages give, per step and to
``O(alpha^2)`` (the cross products of two sinusoids of phases ``psi_j``,
``psi_k`` average to ``|H_j H_k| cos(psi_j - psi_k) = Re(H_j conj(H_k))``
times the flat value; the composition of the per-step rotations adds
``(1/2) sum_{j>=1} dtheta_{k-j} x dtheta_k``, Abel-summed ``(1/2) sin(x)``)::

    eps_i h / sin^2(alpha) = Re(H_j conj H_k) [sin(x)/2 + 2 (1 - cos x) sum_l c[i,l] sin(l x)]
                             - H_i(0) x / 2                                       (T1)

for the cone about body axis ``i`` (``(i, j, k)`` cyclic). With ``H = 1`` it
is the flat residual above. :func:`tuned_coefficients` chooses ``c[i, :]``
(lags 1..3) to minimise the band mean of ``(T1 / (x/2))^2`` (the fraction of
the classical coning rate left uncompensated) for the given responses; with
the identity filter it is the flat band design (:func:`flat_coefficients`).

Pseudo-coning. An in-phase planar vibration ``theta_j = a sin(w t)``,
``theta_k = b sin(w t)`` has no coning. Its filtered increments
``|H_j| a``, ``|H_k| b`` at phases ``phi_j``, ``phi_k`` are those of a true
elliptical cone of rate ``(1/2) a b w |H_j| |H_k| sin(phi_j - phi_k)`` about
axis ``i`` (the Bortz term ``(1/2) theta x omega`` of the filtered rate).
The navigation integrates it as real: per step, by the same averages as (T1)
(``Im`` in place of ``Re`` and no axial term)::

    eps_i = (1/2) a b w |H_j H_k| sin(phi_j - phi_k)
            * [sin x + 4 (1 - cos x) sum_l c[i,l] sin(l x)] / x                  (P1)

whose last factor is ``1 + O(x^(2N))`` for an ``N``-sample algorithm
(:func:`pseudo_coning_drift`).

Sign: for ``Omega > 0`` every residual is negative along the cone axis (the
computed attitude lags the cone); all formulas are odd in ``Omega``.

References
----------
.. [1] R. B. Miller, "A new strapdown attitude algorithm", J. Guidance,
   Control, and Dynamics 6(4), 287-291, 1983.
.. [2] M. B. Ignagni, "Optimal strapdown attitude integration algorithms",
   J. Guidance, Control, and Dynamics 13(2), 363-369, 1990.
.. [3] M. B. Ignagni, "Efficient class of optimized coning compensation
   algorithms", J. Guidance, Control, and Dynamics 19(2), 424-429, 1996.
.. [4] P. G. Savage, "Strapdown inertial navigation integration algorithm
   design, Part 1: Attitude algorithms", J. Guidance, Control, and Dynamics
   21(1), 19-28, 1998.
.. [5] J. W. Bortz, "A new mathematical formulation for strapdown inertial
   navigation", IEEE Trans. Aerosp. Electron. Syst. AES-7(1), 61-66, 1971.
.. [7] W. Mark, D. Tazartes, "Tuning of coning algorithms to gyro data
   frequency response characteristics", J. Guidance, Control, and Dynamics
   24(4), 641-647, 2001.
.. [6] G. Yan, PSINS toolbox (Northwestern Polytechnical University),
   ``conesimu.m``, ``conedrift.m``, ``conecoef.m``.
"""

from __future__ import annotations

import enum
import math

import numpy as np

from sins_sim import _validate as v
from sins_sim._kernels import nav as knav

__all__ = [
    "ConingAlgorithm",
    "CONING_ALGORITHMS",
    "CONING_COEFFICIENTS",
    "RESIDUAL_COEFFICIENTS",
    "parse_algorithm",
    "cone_body_rate",
    "cone_quaternion",
    "cone_increments",
    "coning_drift_closed_form",
    "algorithm_residual_drift",
    "coefficient_matrix",
    "flat_coefficients",
    "tuned_coefficients",
    "tuned_residual",
    "pseudo_coning_drift",
]


class ConingAlgorithm(str, enum.Enum):
    """Coning correction of the attitude update (one gyro increment per update).

    - ``NONE`` ("none"): ``phi_k = dtheta_k``.
    - ``TWO_SAMPLE`` ("two_sample"): ``phi_k = dtheta_k + (1/12) dtheta_{k-1} x dtheta_k``
      (Savage 1998; Savage, *Strapdown Analytics*, eq. 7.1.1.1.1-18).
    - ``THREE_SAMPLE`` ("three_sample"): ``phi_k = dtheta_k - (1/60) dtheta_{k-2} x dtheta_k
      + (7/60) dtheta_{k-1} x dtheta_k`` (Ignagni 1990 Algorithm E, one increment
      per update; module docstring).
    - ``FOUR_SAMPLE`` ("four_sample"): ``phi_k = dtheta_k + (1/280) dtheta_{k-3} x dtheta_k
      - (13/420) dtheta_{k-2} x dtheta_k + (113/840) dtheta_{k-1} x dtheta_k``
      (the N = 4 member of the same family, matched through ``(Omega h)^7``).
    """

    NONE = "none"
    TWO_SAMPLE = "two_sample"
    THREE_SAMPLE = "three_sample"
    FOUR_SAMPLE = "four_sample"

    @property
    def n_samples(self) -> int:
        """Increments the correction spans (``N`` of the residual formula)."""
        return _CODES[self] + 1


_CODES = {
    ConingAlgorithm.NONE: knav.ALGO_NONE,
    ConingAlgorithm.TWO_SAMPLE: knav.ALGO_TWO_SAMPLE,
    ConingAlgorithm.THREE_SAMPLE: knav.ALGO_THREE_SAMPLE,
    ConingAlgorithm.FOUR_SAMPLE: knav.ALGO_FOUR_SAMPLE,
}

#: The algorithm names accepted everywhere.
CONING_ALGORITHMS = tuple(a.value for a in ConingAlgorithm)

#: ``(c_1, c_2, c_3)``: coefficients of ``dtheta_{k-j} x dtheta_k``, ``j = 1, 2, 3`` (lag order).
CONING_COEFFICIENTS = {
    ConingAlgorithm.NONE: (0.0, 0.0, 0.0),
    ConingAlgorithm.TWO_SAMPLE: (knav.C_TWO_PREV1, 0.0, 0.0),
    ConingAlgorithm.THREE_SAMPLE: (knav.C_THREE_PREV1, knav.C_THREE_PREV2, 0.0),
    ConingAlgorithm.FOUR_SAMPLE: (knav.C_FOUR_PREV1, knav.C_FOUR_PREV2, knav.C_FOUR_PREV3),
}

#: ``N! / (2^(N+1) (2N+1)!!)``: leading residual coefficient per sample period
#: (1/12, 1/60, 1/280; Miller 1983's 1/960 and Ignagni 1990's 1/204120 per update).
RESIDUAL_COEFFICIENTS = {
    ConingAlgorithm.NONE: 1.0 / 12.0,
    ConingAlgorithm.TWO_SAMPLE: 1.0 / 60.0,
    ConingAlgorithm.THREE_SAMPLE: 1.0 / 280.0,
    ConingAlgorithm.FOUR_SAMPLE: 1.0 / 1260.0,
}


def parse_algorithm(algorithm, field: str = "algorithm") -> ConingAlgorithm:
    """Return the :class:`ConingAlgorithm` named by ``algorithm``.

    Parameters
    ----------
    algorithm : str or ConingAlgorithm
        One of :data:`CONING_ALGORITHMS`.
    field : str
        Argument name used in the error message.

    Raises
    ------
    ValueError
        If the name is unknown (the message names ``field``).
    """
    if isinstance(algorithm, ConingAlgorithm):
        return algorithm
    if not isinstance(algorithm, str):
        raise ValueError(f"{field}: must be one of {sorted(CONING_ALGORITHMS)}, got {algorithm!r}")
    v.choice("", field, algorithm, CONING_ALGORITHMS)
    return ConingAlgorithm(algorithm)


def _cone_args(alpha_rad, omega_rad_s):
    alpha = v.finite("", "alpha_rad", alpha_rad)
    omega = v.finite("", "omega_rad_s", omega_rad_s)
    return alpha, omega


def cone_body_rate(t_s, alpha_rad, omega_rad_s) -> np.ndarray:
    """Body angular rate of the classical cone (rad/s).

    ``omega = [-2 Omega sin^2(alpha/2), -Omega sin(alpha) sin(Omega t),
    Omega sin(alpha) cos(Omega t)]`` (module docstring; PSINS ``conesimu.m``).

    Parameters
    ----------
    t_s : array_like, shape (N,)
        Times (s).
    alpha_rad : float
        Cone half-angle (rad).
    omega_rad_s : float
        Coning frequency ``Omega`` (rad/s).

    Returns
    -------
    ndarray, shape (N, 3)
        ``omega_ib^b`` (rad/s).
    """
    alpha, omega = _cone_args(alpha_rad, omega_rad_s)
    t = v.finite_array("", "t_s", t_s)
    out = np.empty((t.size, 3))
    out[:, 0] = -2.0 * omega * math.sin(0.5 * alpha) ** 2
    out[:, 1] = -omega * math.sin(alpha) * np.sin(omega * t)
    out[:, 2] = omega * math.sin(alpha) * np.cos(omega * t)
    return out


def cone_quaternion(t_s, alpha_rad, omega_rad_s) -> np.ndarray:
    """Exact attitude ``q_nb(t)`` of the classical cone.

    ``q_nb = [cos(alpha/2), 0, sin(alpha/2) cos(Omega t), sin(alpha/2) sin(Omega t)]``:
    a rotation by ``alpha`` about the axis ``[0, cos(Omega t), sin(Omega t)]``.

    Parameters
    ----------
    t_s : array_like, shape (N,)
        Times (s).
    alpha_rad : float
        Cone half-angle (rad).
    omega_rad_s : float
        Coning frequency (rad/s).

    Returns
    -------
    ndarray, shape (N, 4)
        Unit quaternions, scalar first.
    """
    alpha, omega = _cone_args(alpha_rad, omega_rad_s)
    t = v.finite_array("", "t_s", t_s)
    out = np.empty((t.size, 4))
    out[:, 0] = math.cos(0.5 * alpha)
    out[:, 1] = 0.0
    out[:, 2] = math.sin(0.5 * alpha) * np.cos(omega * t)
    out[:, 3] = math.sin(0.5 * alpha) * np.sin(omega * t)
    return out


def cone_increments(alpha_rad, omega_rad_s, period_s, n: int, start: int = 0) -> np.ndarray:
    """Exact gyro angle increments of the classical cone (rad).

    Increment ``k`` (``k = start .. start + n - 1``) integrates
    :func:`cone_body_rate` over ``[k h, (k + 1) h]`` in closed form (module
    docstring), so the increments carry no quadrature error. ``start < 0``
    gives the increments before ``t = 0`` (the ``dtheta_prev`` state).

    Parameters
    ----------
    alpha_rad : float
        Cone half-angle (rad).
    omega_rad_s : float
        Coning frequency (rad/s).
    period_s : float
        Sample period ``h`` (s), > 0.
    n : int
        Number of increments, >= 0.
    start : int
        Index of the first increment.

    Returns
    -------
    ndarray, shape (n, 3)
    """
    alpha, omega = _cone_args(alpha_rad, omega_rad_s)
    h = v.positive("", "period_s", period_s)
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0:
        raise ValueError(f"n: must be an integer >= 0, got {n!r}")
    if isinstance(start, bool) or not isinstance(start, (int, np.integer)):
        raise ValueError(f"start: must be an integer, got {start!r}")
    tm = (np.arange(int(start), int(start) + int(n)) + 0.5) * h
    amp = 2.0 * math.sin(alpha) * math.sin(0.5 * omega * h)
    out = np.empty((int(n), 3))
    out[:, 0] = -2.0 * omega * math.sin(0.5 * alpha) ** 2 * h
    out[:, 1] = -amp * np.sin(omega * tm)
    out[:, 2] = amp * np.cos(omega * tm)
    return out


def coning_drift_closed_form(alpha_rad, omega_rad_s) -> float:
    """Classical coning rate of a cone (rad/s), exact.

    ``-Omega (1 - cos(alpha)) = -2 Omega sin^2(alpha/2) ~ -Omega alpha^2 / 2``:
    the constant body-axis rate of the cone (the x component of
    :func:`cone_body_rate`), i.e. the drift of an attitude computation that
    sees none of the cross-axis motion. Sampling once per cone period
    (``Omega h = 2 pi``) the uncorrected and the corrected algorithms all drift
    at exactly this rate about the body cone axis. For ``Omega h -> 0`` the
    algorithms' residuals (:func:`algorithm_residual_drift`) vanish instead.

    Parameters
    ----------
    alpha_rad : float
        Cone half-angle (rad).
    omega_rad_s : float
        Coning frequency (rad/s); the sign gives the sense of the cone.

    Returns
    -------
    float
        Signed rate about the cone axis (rad/s); its magnitude is
        ``|Omega| (1 - cos(alpha))``.

    Examples
    --------
    >>> round(coning_drift_closed_form(0.01, 100.0), 9)
    -0.004999958
    """
    alpha, omega = _cone_args(alpha_rad, omega_rad_s)
    return -2.0 * omega * math.sin(0.5 * alpha) ** 2


def algorithm_residual_drift(algorithm, alpha_rad, omega_rad_s, period_s, *, leading_order: bool = True) -> float:
    """Drift of a coning algorithm under the classical cone (rad/s).

    Leading order (default), Miller 1983 / Ignagni 1990 (module docstring)::

        eps = -Omega alpha^2 (Omega h)^(2N) N! / (2^(N+1) (2N+1)!!)

    i.e. the coefficients 1/12, 1/60, 1/280, 1/1260 for ``"none"``,
    ``"two_sample"``, ``"three_sample"``, ``"four_sample"``. With ``leading_order=False``: the same error to
    ``O(alpha^2)`` but exact in ``x = Omega h`` (the sum over the algorithm's
    cross-product coefficients ``c_j`` of increments ``j`` steps apart)::

        eps = (sin^2(alpha) / h) [2 (1 - cos x) sum_j c_j sin(j x) - (x - sin x) / 2]

    (``sin^2(alpha)`` is the exact amplitude of the cross products; its
    difference from ``alpha^2`` is below the neglected ``O(alpha^4)`` terms.)

    Parameters
    ----------
    algorithm : str or ConingAlgorithm
        One of :data:`CONING_ALGORITHMS`.
    alpha_rad : float
        Cone half-angle (rad); the formulas hold for ``alpha << 1``.
    omega_rad_s : float
        Coning frequency (rad/s).
    period_s : float
        Sample (= update) period ``h`` (s).
    leading_order : bool
        Leading term in ``Omega h`` (published form) or the closed form in ``Omega h``.

    Returns
    -------
    float
        Drift rate about the cone axis (rad/s), negative for ``Omega > 0``.

    Examples
    --------
    >>> eps = algorithm_residual_drift("two_sample", 0.01, 100.0, 1e-3)
    >>> round(eps / (-100.0 * 0.01**2 * 0.1**4 / 60), 12)
    1.0
    """
    algo = parse_algorithm(algorithm)
    alpha, omega = _cone_args(alpha_rad, omega_rad_s)
    h = v.positive("", "period_s", period_s)
    x = omega * h
    if leading_order:
        return -omega * alpha * alpha * x ** (2 * algo.n_samples) * RESIDUAL_COEFFICIENTS[algo]
    cross = 2.0 * (1.0 - math.cos(x)) * _lag_sum(CONING_COEFFICIENTS[algo], x)
    return math.sin(alpha) ** 2 * (cross - 0.5 * (x - math.sin(x))) / h


def _lag_sum(coef, x):
    """``sum_l c_l sin(l x)`` over lags ``l = 1..3`` (``x`` scalar or array)."""
    return sum(c * np.sin((l + 1) * x) for l, c in enumerate(coef))


def coefficient_matrix(spec, field: str = "coning") -> np.ndarray:
    """The kernels' ``(3, 3)`` coefficient array ``[component, lag - 1]`` of an algorithm.

    Parameters
    ----------
    spec : str, ConingAlgorithm or array_like
        An algorithm name (every row its :data:`CONING_COEFFICIENTS`), one row
        of three lag coefficients for all components, or a ``(3, 3)`` array
        (a filter-tuned design, :func:`tuned_coefficients`).
    field : str
        Argument name used in the error message.

    Returns
    -------
    ndarray, shape (3, 3)
        A new array.

    Raises
    ------
    ValueError
        For an unknown name, a wrong shape or a non-finite coefficient.

    Examples
    --------
    >>> coefficient_matrix("three_sample")[2].tolist() == [7 / 60, -1 / 60, 0.0]
    True
    """
    if isinstance(spec, (str, ConingAlgorithm)):
        row = CONING_COEFFICIENTS[parse_algorithm(spec, field)]
        return np.tile(np.asarray(row, dtype=np.float64), (3, 1))
    arr = np.asarray(spec, dtype=np.float64)
    if arr.shape == (3,):
        arr = np.tile(arr, (3, 1))
    if arr.shape != (3, 3) or not np.all(np.isfinite(arr)):
        raise ValueError(f"{field}: must be one of {sorted(CONING_ALGORITHMS)} or finite coefficients of shape "
                         f"(3,) or (3, 3), got {spec!r}")
    return arr.copy()


def _band_x(band_hz, rate_hz, n_points):
    lo, hi = float(band_hz[0]), float(band_hz[1])
    fs = v.positive("", "rate_hz", rate_hz)
    if not (0.0 < lo < hi < 0.5 * fs):
        raise ValueError(f"band_hz: must satisfy 0 < low < high < rate_hz / 2 = {0.5 * fs:g}, got {band_hz!r}")
    f = np.linspace(lo, hi, int(n_points))
    return f, 2.0 * math.pi * f / fs


def _cone_parts(responses, dc_gains, x):
    """Per component ``i``: ``R_i = Re(H_j conj H_k)`` and ``H_i(0)``, ``(i, j, k)`` cyclic."""
    h = np.asarray(responses, dtype=np.complex128)
    if h.shape != (3, x.size):
        raise ValueError(f"responses: must have shape (3, {x.size}) (one row per axis, one column per band "
                         f"frequency), got {h.shape}")
    g0 = np.ones(3) if dc_gains is None else np.asarray(dc_gains, dtype=np.float64)
    r = np.array([np.real(h[(i + 1) % 3] * np.conj(h[(i + 2) % 3])) for i in range(3)])
    return r, g0


def tuned_residual(coef, responses, band_hz, rate_hz, dc_gains=None, n_points: int = 201) -> np.ndarray:
    """Fraction of the classical coning rate left uncompensated, over a band (module docstring, T1).

    ``E_i(f) = T1_i / (x/2)``: the drift of the cone about body axis ``i``
    divided by its classical coning rate ``Omega alpha^2 / 2``, to
    ``O(alpha^2)``, for increments filtered by ``responses``.

    Parameters
    ----------
    coef : str or array_like
        Algorithm (:func:`coefficient_matrix`).
    responses : array_like of complex, shape (3, n_points)
        Per-axis frequency response of the increments at the band
        frequencies ``linspace(band_hz[0], band_hz[1], n_points)``.
    band_hz : (float, float)
        Band (Hz), inside ``(0, rate_hz / 2)``.
    rate_hz : float
        Increment (filter output) rate (Hz).
    dc_gains : array_like, shape (3,), optional
        Per-axis gain at zero frequency (ones by default).
    n_points : int
        Band frequencies.

    Returns
    -------
    ndarray, shape (3, n_points)
        Signed fraction (negative: the computed attitude lags the cone).
    """
    c = coefficient_matrix(coef)
    _, x = _band_x(band_hz, rate_hz, n_points)
    r, g0 = _cone_parts(responses, dc_gains, x)
    out = np.empty((3, x.size))
    for i in range(3):
        alg = 0.5 * np.sin(x) + 2.0 * (1.0 - np.cos(x)) * _lag_sum(c[i], x)
        out[i] = (r[i] * alg - g0[i] * 0.5 * x) / (0.5 * x)
    return out


def tuned_coefficients(responses, band_hz, rate_hz, dc_gains=None, n_points: int = 201) -> np.ndarray:
    """Filter-tuned coning coefficients (Mark & Tazartes 2001; module docstring, T1).

    For each component ``i`` the lag coefficients ``c[i, 0..2]`` minimise the
    band mean of ``E_i(f)^2`` (:func:`tuned_residual`), a linear least-squares
    problem: ``E_i`` is affine in ``c[i]`` with columns
    ``R_i 4 (1 - cos x) sin(l x) / x``. The band frequencies are uniform in
    Hz, so every part of the band weighs the same.

    Parameters
    ----------
    responses, band_hz, rate_hz, dc_gains, n_points
        As :func:`tuned_residual`.

    Returns
    -------
    ndarray, shape (3, 3)
        ``[component, lag - 1]``, for the kernels.
    """
    _, x = _band_x(band_hz, rate_hz, n_points)
    r, g0 = _cone_parts(responses, dc_gains, x)
    out = np.empty((3, 3))
    for i in range(3):
        cols = np.stack([r[i] * 4.0 * (1.0 - np.cos(x)) * np.sin(l * x) / x for l in (1, 2, 3)], axis=1)
        rhs = -(r[i] * np.sin(x) - g0[i] * x) / x
        # column scaling keeps the normal equations of this near-collinear basis well conditioned
        scale = np.linalg.norm(cols, axis=0)
        sol, *_ = np.linalg.lstsq(cols / scale, rhs, rcond=None)
        out[i] = sol / scale
    return out


def flat_coefficients(band_hz, rate_hz, n_points: int = 201) -> np.ndarray:
    """:func:`tuned_coefficients` for a flat, zero-phase response (every ``H = 1``).

    Parameters
    ----------
    band_hz, rate_hz, n_points
        As :func:`tuned_residual`.

    Returns
    -------
    ndarray, shape (3, 3)
    """
    return tuned_coefficients(np.ones((3, int(n_points)), dtype=np.complex128), band_hz, rate_hz,
                              n_points=n_points)


def pseudo_coning_drift(a_rad, b_rad, omega_rad_s, h_j, h_k, period_s, coef="two_sample", component: int = 2):
    """False coning rate of an in-phase planar vibration seen through two filters (rad/s; P1).

    ``(1/2) a b w |H_j| |H_k| sin(phi_j - phi_k) [sin x + 4 (1 - cos x) sum_l c_l sin(l x)] / x``
    for ``theta_j = a sin(w t)``, ``theta_k = b sin(w t)`` about the two body
    axes before axis ``component`` in cyclic order (``component = 2``: ``j = x``,
    ``k = y``, the drift about z; the issue's ``(1/2) a b w |H_x||H_y| sin(phi_x - phi_y)``).

    Parameters
    ----------
    a_rad, b_rad : float
        Angular amplitudes about axes ``j`` and ``k`` (rad).
    omega_rad_s : float
        Vibration frequency (rad/s).
    h_j, h_k : complex
        The filters' responses at ``omega`` (the increments of axis ``j``, ``k``).
    period_s : float
        Increment period ``h`` (s).
    coef : str or array_like
        The navigation's coning algorithm (:func:`coefficient_matrix`).
    component : int
        Body axis of the drift (0, 1, 2).

    Returns
    -------
    float
        Drift rate about body axis ``component`` (rad/s).

    Examples
    --------
    >>> import cmath
    >>> eps = pseudo_coning_drift(1e-3, 1e-3, 1000.0, 1.0, cmath.exp(-0.1j), 1e-5, coef="four_sample")
    >>> round(eps / (0.5e-6 * 1000.0 * math.sin(0.1)), 9)
    1.0
    """
    a = v.finite("", "a_rad", a_rad)
    b = v.finite("", "b_rad", b_rad)
    w = v.finite("", "omega_rad_s", omega_rad_s)
    h = v.positive("", "period_s", period_s)
    c = coefficient_matrix(coef)[int(component)]
    x = w * h
    hj, hk = complex(h_j), complex(h_k)
    factor = (math.sin(x) + 4.0 * (1.0 - math.cos(x)) * float(_lag_sum(c, x))) / x
    return 0.5 * a * b * w * (hj * hk.conjugate()).imag * factor
