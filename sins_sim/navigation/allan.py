"""Allan deviation of gyro and accelerometer records and the noise terms read off it.

Arrays in, numbers out. The overlapping Allan deviation is computed by ``allantools.oadev``
(NIST SP 1065, Riley 2008, eq. 11) from a record of rates (rad/s, m/s^2), of increments per sample
(rad, m/s) or of the running integral (angle in rad, velocity in m/s).

.. autosummary::

   allan_deviation
   fit_allan
   screen_noise
   not_determinable
   term_interval
   term_rel
   gyro_allan
   accel_allan
   allan_axes
   AllanCurve
   AllanTerm
   AllanAnalysis

Reading the curve (IEEE Std 952-1997, Annex C; IEEE Std 1293-1998 for accelerometers): the Allan
variance of independent noise terms adds up, each with its own power of tau::

    sigma^2(tau) = 3 Q^2 / tau^2 + N^2 / tau + (0.664 B)^2 + K^2 tau / 3 + R^2 tau^2 / 2

quantisation ``Q`` (slope -1 of the deviation), angle / velocity random walk ``N`` (slope -1/2:
the value of the -1/2 line at tau = 1 s), bias instability ``B`` (slope 0: the flat floor is
``sqrt(2 ln 2 / pi) B = 0.664 B``, so B is the floor divided by 0.664), rate / acceleration random
walk ``K`` (slope +1/2: the value of the +1/2 line at tau = 3 s) and rate ramp ``R`` (slope +1).
IEEE Std 952-1997, Annex C, suggests the least-squares fit of the Allan variance as such a sum of
powers of tau; here:

1. the points used are those averaged over at least ``min_clusters`` independent clusters
   (``record / tau >= 10`` by default): the relative standard deviation of an Allan-deviation point
   is about ``1 / sqrt(2 (clusters - 1))`` (IEEE Std 952-1997, Annex C, the percentage error of the
   estimate; Riley 2008 on confidence intervals), that of the variance twice as much, so longer taus
   carry little information and much scatter;
2. the five non-negative coefficients are fitted by weighted non-negative least squares
   (``scipy.optimize.nnls``) with weights ``1 / (model rel)``, ``rel = max(sqrt(2 / clusters),
   0.05)`` (the floor allows for a curve that departs from the power laws by a few per cent),
   iterated on the model so that points that happen to lie low are not favoured; the point worst
   described (beyond three ``rel``) is dropped and the fit repeated until every point left is
   described (robust against a curve that is not a sum of power laws somewhere, such as the rising
   side of a Gauss-Markov bias plateau);
3. the region of a term is the longest run of consecutive points where that term makes up at least
   ``share`` (one half by default) of the fitted variance and the point is described by the fit
   (within three ``rel``); it is returned as ``tau_range_s``;
4. the term is read from the points of its region alone: the fixed-slope line through them after
   the other fitted terms are subtracted (weighted least squares), and the slope measured there by
   a free log-log fit is reported beside it;
5. each term's 95 % confidence interval (:attr:`AllanTerm.ci`, :func:`term_interval`): the chi-square
   interval of the overlapping estimator with the simple equivalent degrees of freedom of the term's
   noise type (Riley 2008, Table 7), combined at each point with the error of the other terms subtracted
   there (their part times their own relative error, read first from their own regions: first-order error
   propagation, :func:`term_rel`), bounded over the region's correlated points (conservative). The fit's
   weights in step 2 use the simpler non-overlapping count ``clusters - 1`` instead.

A term absent from the record (zero coefficient, or no point where it dominates) reads NaN.

Units of the readings: gyros ``arw_deg_rt_h`` (deg/sqrt(h)), ``bias_instability_deg_h`` (deg/h),
``rrw_deg_h_rt_h`` (deg/h/sqrt(h)), ``quantization_arcsec``; accelerometers ``vrw_ug_rt_hz``
(ug/sqrt(Hz), the coefficient N with sigma^2 = N^2 / tau: ``1 ug/sqrt(Hz) = 9.80665e-6 m/s/sqrt(s)
= 5.884e-4 m/s/sqrt(h)``; ``vrw_m_s_rt_h`` gives the same in m/s/sqrt(h)), ``bias_instability_ug``,
``rrw_ug_rt_h`` (ug/sqrt(h)), ``quantization_m_s``.

References
----------
IEEE Std 952-1997, Annex C. IEEE Std 1293-1998. W. J. Riley, *Handbook of Frequency Stability
Analysis*, NIST Special Publication 1065, 2008. A. Wallin et al., allantools
(https://github.com/aewallin/allantools).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from numbers import Real

import numpy as np
from scipy.optimize import nnls

from sins_sim.units import ARCSEC, DEG, DEG_PER_H, MICRO_G

__all__ = [
    "ALPHA",
    "CI_LEVEL",
    "FLICKER_FLOOR_FACTOR",
    "TERMS",
    "AllanAnalysis",
    "AllanCurve",
    "AllanTerm",
    "accel_allan",
    "allan_axes",
    "allan_deviation",
    "fit_allan",
    "gyro_allan",
    "not_determinable",
    "screen_noise",
    "term_interval",
    "term_rel",
]

#: Allan-deviation floor of bias instability per unit of B, sqrt(2 ln 2 / pi) (IEEE Std 952-1997, Annex C).
FLICKER_FLOOR_FACTOR = math.sqrt(2.0 * math.log(2.0) / math.pi)
#: The noise terms: name -> (power of tau in the Allan variance, slope of the deviation).
TERMS = {
    "quantization": (-2, -1.0),
    "white": (-1, -0.5),
    "flicker": (0, 0.0),
    "random_walk": (1, 0.5),
    "ramp": (2, 1.0),
}
#: Smallest relative uncertainty given to an Allan-variance point in the fit: a real curve departs from the
#: power-law sum by a few per cent (e.g. a Gauss-Markov bias plateau outside its decade range), so the
#: short-tau points, estimated to 0.1 %, must not pin the fit alone.
REL_FLOOR = 0.05
#: :func:`screen_noise`: points a term's region must hold, the largest departure of its measured slope from the
#: nominal one (half the spacing of neighbouring power laws), the smallest goodness-of-fit p-value, and the
#: largest fraction of the reliable points the robust fit may leave out.
MIN_REGION_POINTS = 3
SLOPE_TOLERANCE = 0.25
GOF_P_MIN = 1e-3
MAX_DROPPED_FRACTION = 0.1
_DATA = {"gyro": ("rate", "increment", "angle"), "accel": ("specific_force", "increment", "velocity")}


@dataclass(frozen=True)
class AllanCurve:
    """Overlapping Allan deviation of one record.

    Parameters
    ----------
    tau_s : ndarray
        Averaging times (s), increasing.
    adev : ndarray
        Allan deviation of the rate (rad/s) or specific force (m/s^2) at ``tau_s``.
    n_terms : ndarray
        Number of overlapping second differences averaged at each tau.
    n_samples : int
        Samples in the record.
    rate_hz : float
        Sample rate (Hz).
    """

    tau_s: np.ndarray
    adev: np.ndarray
    n_terms: np.ndarray
    n_samples: int
    rate_hz: float

    @property
    def duration_s(self) -> float:
        """Length of the record (s)."""
        return self.n_samples / self.rate_hz

    @property
    def clusters(self) -> np.ndarray:
        """Independent (non-overlapping) clusters at each tau, ``floor(record / tau)``."""
        return np.floor(self.n_samples / np.round(self.tau_s * self.rate_hz))

    @property
    def adev_err(self) -> np.ndarray:
        """1-sigma uncertainty of ``adev`` (same unit): ``adev / sqrt(2 (clusters - 1))``, the
        non-overlapping chi-square estimate (conservative for the overlapping estimator)."""
        return self.adev / np.sqrt(2.0 * np.maximum(self.clusters - 1.0, 1.0))


@dataclass(frozen=True)
class AllanTerm:
    """One noise term read off an Allan curve (SI).

    Parameters
    ----------
    name : str
        ``quantization``, ``white``, ``flicker``, ``random_walk`` or ``ramp``.
    slope : float
        Nominal log-log slope of the deviation (-1, -1/2, 0, +1/2, +1).
    coefficient : float
        Q (rad or m/s), N (rad/sqrt(s) or m/s/sqrt(s)), B (rad/s or m/s^2), K (rad/s/sqrt(s) or
        m/s^2/sqrt(s)) or R (rad/s^2 or m/s^3); NaN when not found.
    tau_range_s : tuple of float or None
        First and last tau (s) of the region the reading comes from; None when not found.
    n_points : int
        Points in the region.
    slope_measured : float
        Free log-log slope over the region (NaN with fewer than 3 points).
    ci : tuple of float or None
        95 % confidence interval ``(low, high)`` of ``coefficient`` (same unit), from the chi-square
        scatter of the region's points and the error of the other terms subtracted there
        (:func:`term_interval`); None when not found.
    """

    name: str
    slope: float
    coefficient: float
    tau_range_s: tuple | None
    n_points: int
    slope_measured: float
    ci: tuple | None = None

    @property
    def found(self) -> bool:
        """True when the term was read (finite coefficient)."""
        return bool(np.isfinite(self.coefficient))


def _empty_terms() -> dict:
    """Every term, not found (NaN coefficient, no region)."""
    return {n: AllanTerm(n, TERMS[n][1], math.nan, None, 0, math.nan) for n in TERMS}


def _coefficient_from_c(name, c):
    if not (np.isfinite(c) and c > 0.0):
        return math.nan
    return {"quantization": math.sqrt(c / 3.0), "white": math.sqrt(c),
            "flicker": math.sqrt(c) / FLICKER_FLOOR_FACTOR, "random_walk": math.sqrt(3.0 * c),
            "ramp": math.sqrt(2.0 * c)}[name]


def _c_from_coefficient(name, x):
    return {"quantization": 3.0 * x * x, "white": x * x, "flicker": (FLICKER_FLOOR_FACTOR * x) ** 2,
            "random_walk": x * x / 3.0, "ramp": x * x / 2.0}[name]


@dataclass(frozen=True)
class AllanAnalysis:
    """An Allan curve, its power-law fit and the noise terms read off it.

    Parameters
    ----------
    curve : AllanCurve
    sensor : str
        ``gyro`` or ``accel`` (selects the datasheet units of :meth:`readings`).
    coefficients : dict
        Fitted Allan-variance coefficient ``C_k`` of each term (SI unit^2 s^-k).
    terms : dict
        Name -> :class:`AllanTerm`.
    min_clusters : float
        The reliability threshold used.
    goodness_of_fit : dict or None
        How well the power-law sum describes the reliable points (:func:`fit_allan`): ``points``,
        ``dropped`` (points the robust fit had to leave out), ``chi2``, ``dof``, ``p_value``.
    determinable : bool
        False when the record cannot support noise terms at all (:func:`screen_noise`): then every
        term reads NaN and ``reason`` says why.
    reason : str
        Why the record supports no noise term (empty when it does).
    rejected : dict
        Term name -> why a term that the fit found was not accepted (:func:`screen_noise`).
    """

    curve: AllanCurve
    sensor: str
    coefficients: dict
    terms: dict
    min_clusters: float
    goodness_of_fit: dict | None = None
    determinable: bool = True
    reason: str = ""
    rejected: dict = field(default_factory=dict)

    @property
    def display_unit(self) -> str:
        """Unit of the deviation in plots: ``deg/h`` (gyro) or ``ug`` (accel)."""
        return "deg/h" if self.sensor == "gyro" else "ug"

    @property
    def display_scale(self) -> float:
        """Factor from the SI deviation to :attr:`display_unit`."""
        return 1.0 / DEG_PER_H if self.sensor == "gyro" else 1.0 / MICRO_G

    def model_adev(self, tau_s) -> np.ndarray:
        """The fitted power-law Allan deviation at ``tau_s`` (s) (SI)."""
        tau = np.asarray(tau_s, dtype=np.float64)
        return np.sqrt(sum(c * tau ** TERMS[n][0] for n, c in self.coefficients.items()))

    def line(self, name: str, tau_s) -> np.ndarray:
        """The line of term ``name`` (its reading alone) at ``tau_s`` (s) (SI deviation; NaN if not found)."""
        tau = np.asarray(tau_s, dtype=np.float64)
        term = self.terms[name]
        return np.sqrt(_c_from_coefficient(name, term.coefficient) * tau ** TERMS[name][0])

    def readings(self) -> dict:
        """The readings in datasheet units (NaN where a term was not found).

        Returns
        -------
        dict
            Gyro: ``arw_deg_rt_h``, ``bias_instability_deg_h``, ``rrw_deg_h_rt_h``,
            ``quantization_arcsec``. Accelerometer: ``vrw_ug_rt_hz``, ``vrw_m_s_rt_h``,
            ``bias_instability_ug``, ``rrw_ug_rt_h``, ``quantization_m_s``.
        """
        c = {n: t.coefficient for n, t in self.terms.items()}
        if self.sensor == "gyro":
            return {"arw_deg_rt_h": c["white"] * 60.0 / DEG,
                    "bias_instability_deg_h": c["flicker"] / DEG_PER_H,
                    "rrw_deg_h_rt_h": c["random_walk"] * 60.0 / DEG_PER_H,
                    "quantization_arcsec": c["quantization"] / ARCSEC}
        return {"vrw_ug_rt_hz": c["white"] / MICRO_G,
                "vrw_m_s_rt_h": c["white"] * 60.0,
                "bias_instability_ug": c["flicker"] / MICRO_G,
                "rrw_ug_rt_h": c["random_walk"] * 60.0 / MICRO_G,
                "quantization_m_s": c["quantization"]}

    def to_dict(self) -> dict:
        """JSON-ready readings with the tau range of each (None where not found).

        Returns
        -------
        dict
            :meth:`readings` (NaN as None) plus ``tau_range_s`` = {reading key: [first, last] or None}.
        """
        r = self.readings()
        key_of = ({"white": "arw_deg_rt_h", "flicker": "bias_instability_deg_h", "random_walk": "rrw_deg_h_rt_h",
                   "quantization": "quantization_arcsec"} if self.sensor == "gyro" else
                  {"white": "vrw_ug_rt_hz", "flicker": "bias_instability_ug", "random_walk": "rrw_ug_rt_h",
                   "quantization": "quantization_m_s"})
        out = {k: (float(v) if np.isfinite(v) else None) for k, v in r.items()}
        out["tau_range_s"] = {key_of[n]: (list(self.terms[n].tau_range_s) if self.terms[n].tau_range_s else None)
                              for n in key_of}
        out["determinable"] = self.determinable
        if self.reason:
            out["reason"] = self.reason
        if self.rejected:
            out["rejected"] = {key_of.get(n, n): why for n, why in self.rejected.items()}
        if self.goodness_of_fit is not None:
            out["goodness_of_fit"] = dict(self.goodness_of_fit)
        return out


def _check_record(x, rate_hz, what):
    arr = np.asarray(x, dtype=np.float64)
    if arr.ndim != 1:
        raise ValueError(f"allan.{what}: must be a 1-D record, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"allan.{what}: must be finite everywhere")
    rate = float(rate_hz)
    if not (math.isfinite(rate) and rate > 0.0):
        raise ValueError(f"allan.rate_hz: must be > 0, got {rate_hz!r}")
    return arr, rate


def allan_deviation(x, rate_hz: float, data: str = "rate", per_decade: int = 10) -> AllanCurve:
    """Overlapping Allan deviation of a rate, increment or integral record (``allantools.oadev``).

    Parameters
    ----------
    x : array_like, 1-D
        The record: with ``data="rate"`` the mean rate (or specific force) over each sample
        (unit/s, e.g. rad/s); ``"increment"`` its integral over each sample (unit, e.g. rad);
        ``"angle"`` the running integral at the sample instants (unit, e.g. rad). Aliases:
        ``"specific_force"`` = ``"rate"``, ``"velocity"`` = ``"angle"``.
    rate_hz : float
        Sample rate (Hz), > 0.
    data : str
        What ``x`` holds (above).
    per_decade : int
        Averaging times per decade, log-spaced multiples of the sample interval from 1 up to half
        the record (duplicates after rounding removed).

    Returns
    -------
    AllanCurve
        Deviation of the rate (unit/s).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> c = allan_deviation(rng.standard_normal(100000) * 10.0, 100.0)  # white, 1 unit/sqrt(s)
    >>> bool(abs(c.adev[np.argmin(abs(c.tau_s - 1.0))] - 1.0) < 0.05)
    True
    """
    import allantools

    kind = {"rate": "rate", "specific_force": "rate", "increment": "increment", "angle": "angle",
            "velocity": "angle"}.get(data)
    if kind is None:
        raise ValueError(f"allan.data: must be one of ['angle', 'increment', 'rate', 'specific_force', 'velocity'], "
                         f"got {data!r}")
    arr, rate = _check_record(x, rate_hz, "x")
    if not (isinstance(per_decade, (int, np.integer)) and 1 <= per_decade <= 100):
        raise ValueError(f"allan.per_decade: must be an integer in [1, 100], got {per_decade!r}")
    n = arr.size - 1 if kind == "angle" else arr.size
    if n < 4:
        raise ValueError(f"allan.x: needs at least 4 samples, got {n}")
    m_max = n // 2
    m = np.unique(np.round(np.logspace(0.0, math.log10(m_max), int(per_decade * math.log10(m_max)) + 1)))
    taus = m / rate
    if kind == "rate":
        t, ad, _, ns = allantools.oadev(arr, rate=rate, data_type="freq", taus=taus)
    elif kind == "increment":
        t, ad, _, ns = allantools.oadev(arr * rate, rate=rate, data_type="freq", taus=taus)
    else:
        t, ad, _, ns = allantools.oadev(arr, rate=rate, data_type="phase", taus=taus)
    keep = np.isfinite(ad) & (ad > 0.0)
    return AllanCurve(tau_s=np.asarray(t)[keep], adev=np.asarray(ad)[keep], n_terms=np.asarray(ns)[keep],
                      n_samples=int(n), rate_hz=rate)


def _runs(mask):
    """(start, stop) of the longest run of True in ``mask`` (None if none)."""
    best, start = None, None
    for i, flag in enumerate(list(mask) + [False]):
        if flag and start is None:
            start = i
        elif not flag and start is not None:
            if best is None or i - start > best[1] - best[0]:
                best = (start, i)
            start = None
    return best


def _weighted_nnls(basis, s2, rel):
    """Non-negative power-law coefficients; weights 1 / (model rel), iterated from 1 / (data rel)."""
    err = s2 * rel
    coef = np.zeros(basis.shape[1])
    for _ in range(4):
        a = basis / err[:, None]
        norm = np.linalg.norm(a, axis=0)
        sol, _ = nnls(a / norm, s2 / err)
        coef = sol / norm
        err = np.maximum(basis @ coef, 0.25 * s2) * rel   # model-based weights, floored against a poor early fit
    return coef


def fit_allan(curve: AllanCurve, sensor: str = "gyro", min_clusters: float = 10.0,
              share: float = 0.5) -> AllanAnalysis:
    """Fit the IEEE power-law model to an Allan curve and read each term from its own region.

    Parameters
    ----------
    curve : AllanCurve
        From :func:`allan_deviation` (SI).
    sensor : str
        ``gyro`` or ``accel``: the units of :meth:`AllanAnalysis.readings`.
    min_clusters : float
        Use only taus averaged over at least this many independent clusters (>= 2).
    share : float
        A term's region: where it makes up at least this fraction of the fitted variance, in (0, 1].

    Returns
    -------
    AllanAnalysis

    Notes
    -----
    The method (fit, regions, per-region reading) is described in the module docstring.
    """
    if sensor not in _DATA:
        raise ValueError(f"allan.sensor: must be one of ['accel', 'gyro'], got {sensor!r}")
    if not (isinstance(min_clusters, Real) and not isinstance(min_clusters, bool) and min_clusters >= 2.0):
        raise ValueError(f"allan.min_clusters: must be >= 2, got {min_clusters!r}")
    if not (isinstance(share, Real) and not isinstance(share, bool) and 0.0 < share <= 1.0):
        raise ValueError(f"allan.share: must lie in (0, 1], got {share!r}")
    names = list(TERMS)
    powers = np.array([TERMS[n][0] for n in names], dtype=np.float64)
    ok = curve.clusters >= min_clusters
    tau, s2, cl = curve.tau_s[ok], curve.adev[ok] ** 2, curve.clusters[ok]
    empty = _empty_terms()
    if tau.size < 2:
        return AllanAnalysis(curve, sensor, {n: 0.0 for n in names}, empty, float(min_clusters))
    rel = np.maximum(np.sqrt(2.0 / np.maximum(cl - 1.0, 1.0)), REL_FLOOR)
    basis = tau[:, None] ** powers[None, :]
    # robust fit: drop the worst point the power-law sum does not describe (beyond three floored standard
    # deviations), one at a time, and refit, until every point left is described
    use = np.ones(tau.size, dtype=bool)
    while True:
        coef = _weighted_nnls(basis[use], s2[use], rel[use])
        model = np.maximum(basis @ coef, np.finfo(np.float64).tiny)
        dev = np.abs(s2 / model - 1.0) / (3.0 * rel)
        dev[~use] = 0.0
        if dev.max() <= 1.0 or use.sum() <= 3:
            break
        use[int(np.argmax(dev))] = False
    consistent = np.abs(s2 / model - 1.0) <= 3.0 * rel
    gof = _goodness_of_fit(s2, model, rel, coef, use)
    w = 1.0 / (np.maximum(model, 0.25 * s2) * rel) ** 2
    # pass 1: each term's reading and the relative standard deviation of its Allan-variance coefficient from its
    # own region's chi-square scatter alone (term_rel without others_err)
    reading = {}
    for k, name in enumerate(names):
        part = basis[:, k] * coef[k]
        run = _runs((part >= share * model) & consistent) if coef[k] > 0.0 else None
        if run is None:
            continue
        sel = slice(*run)
        resid = s2[sel] - (model[sel] - part[sel])
        bk = basis[sel, k]
        c_k = float(np.sum(w[sel] * resid * bk) / np.sum(w[sel] * bk * bk))
        own = term_rel(name, tau[sel], s2[sel], part[sel] / coef[k] * c_k, w[sel] * bk * bk, curve)
        reading[name] = (run, c_k, own)
    # pass 2: the interval with the other terms' coefficient errors carried into each point (term_interval); a
    # fitted term without a region of its own is known only to within itself (relative error 1); a region's own
    # bound above 1 says no more than that (a non-negative coefficient is known to within itself), so it is capped
    # there, which also keeps a nearly empty region's huge bound from swamping the others' intervals
    own_rel = {n: (min(reading[n][2], 1.0) if n in reading and np.isfinite(reading[n][2]) else 1.0) for n in names}
    terms = {}
    for k, name in enumerate(names):
        if name not in reading:
            terms[name] = empty[name]
            continue
        (a, b), c_k, _ = reading[name]
        sel = slice(a, b)
        bk = basis[sel, k]
        others_err = sum(basis[sel, j] * coef[j] * own_rel[nj] for j, nj in enumerate(names) if j != k)
        slope = math.nan
        if b - a >= 3:
            slope = float(np.polyfit(np.log(tau[sel]), 0.5 * np.log(s2[sel]), 1)[0])
        ci = term_interval(name, c_k, tau[sel], s2[sel], basis[sel, k] * c_k, w[sel] * bk * bk, curve,
                           others_err=others_err)
        terms[name] = AllanTerm(name, TERMS[name][1], _coefficient_from_c(name, c_k),
                                (float(tau[a]), float(tau[b - 1])), b - a, slope, ci)
    return AllanAnalysis(curve, sensor, {n: float(c) for n, c in zip(names, coef)}, terms, float(min_clusters),
                         goodness_of_fit=gof)


#: Power-law exponent ``alpha`` of the rate's spectral density ``S(f) ~ f^alpha`` for each term (the frequency-
#: stability convention of NIST SP 1065, Riley 2008, sec. 5.2: white rate = white FM 0, bias instability = flicker
#: FM -1, rate random walk = random-walk FM -2, quantisation = white PM +2; the ramp is deterministic: no alpha).
ALPHA = {"quantization": 2, "white": 0, "flicker": -1, "random_walk": -2}
#: Confidence level of :attr:`AllanTerm.ci`.
CI_LEVEL = 0.95


def term_rel(name: str, tau, s2, part, weight, curve: AllanCurve, others_err=None) -> float:
    """Relative standard deviation of a term's Allan-variance coefficient read off its region.

    Each Allan-variance point is chi-square distributed with ``edf`` equivalent degrees of freedom,
    ``edf * s2_hat / s2 ~ chi2(edf)`` (NIST SP 1065, Riley 2008, sec. 5.3), a relative standard deviation
    ``sqrt(2 / edf)``; ``edf`` is the simple approximation for the overlapping Allan variance of the term's
    noise type (Riley 2008, Table 7, after Howe, Allan and Barnes 1981; ``allantools.edf_simple``). The
    term's variance at a point is ``c_i tau_i^k = s2_i - others_i``, so (first-order error propagation):

    * the point's own scatter enters ``gain_i = s2_i / part_i`` times: ``u_i = gain_i sqrt(2 / edf_i)``;
    * the other terms' part ``others_i`` is itself an estimate; its 1-sigma error ``others_err_i`` (the sum,
      over the other terms, of their part times their own coefficient's relative error: added linearly, since
      the fit's coefficients are correlated with unknown sign) enters as ``v_i = others_err_i / part_i``.

    The two are read off different points (the other terms' regions), so they add in quadrature,
    ``r_i = sqrt(u_i^2 + v_i^2)``. The reading is a weighted mean of the region's points (normalised
    weights ``a_i``); the points of an overlapping curve are correlated in an unknown way, and the other
    terms' errors are the same at every point, so the reading's relative standard deviation is bounded by
    the weighted mean ``rel = sum(a_i r_i)`` (Minkowski's inequality: equality for fully correlated points).

    Parameters
    ----------
    name : str
        The term (one of :data:`ALPHA`).
    tau, s2, part, weight : ndarray
        The region's taus (s), Allan variances, the term's part of them and each point's weight in the
        reading (the weight of ``c_i = (s2_i - others_i) / tau_i^k``).
    curve : AllanCurve
        The curve (for the record length and sample rate).
    others_err : ndarray or None
        1-sigma error of the other terms' part subtracted at each point (unit^2); None: the point's scatter
        alone.

    Returns
    -------
    float
        ``rel`` (NaN for a term without a noise type, the ramp).
    """
    import allantools

    if name not in ALPHA:
        return math.nan
    m = np.round(np.asarray(tau) * curve.rate_hz)
    edf = np.array([allantools.edf_simple(curve.n_samples, float(mi), ALPHA[name]) for mi in m])
    edf = np.maximum(edf, 1.0)
    part = np.maximum(np.asarray(part, dtype=np.float64), np.finfo(np.float64).tiny)
    u = np.asarray(s2, dtype=np.float64) / part * np.sqrt(2.0 / edf)
    v = np.zeros_like(u) if others_err is None else np.asarray(others_err, dtype=np.float64) / part
    a = np.asarray(weight, dtype=np.float64) / np.sum(weight)
    return float(np.sum(a * np.hypot(u, v)))


def term_interval(name: str, c_k: float, tau, s2, part, weight, curve: AllanCurve, level: float = CI_LEVEL,
                  others_err=None):
    """Confidence interval of a term's coefficient read off its region.

    The relative standard deviation ``rel`` of the Allan-variance coefficient is :func:`term_rel` (each
    point's chi-square scatter, NIST SP 1065 sec. 5.3, and the error of the other terms subtracted there,
    first-order propagation), bounded over the region's correlated points; the interval is the chi-square
    one for ``edf_eff = 2 / rel^2`` (Riley 2008, sec. 5.3, eq. 35 form). The bound makes the interval
    conservative (coverage at least ``level`` under the noise model).

    Parameters
    ----------
    name : str
        The term.
    c_k : float
        Its Allan-variance coefficient read off the region (unit^2 s^-k).
    tau, s2, part, weight : ndarray
        See :func:`term_rel`.
    curve : AllanCurve
        The curve (for the record length and sample rate).
    level : float
        Confidence level.
    others_err : ndarray or None
        See :func:`term_rel`.

    Returns
    -------
    tuple of float or None
        ``(low, high)`` of the coefficient (Q, N, B, K or R in SI), None for the ramp, a non-positive
        ``c_k`` or a relative error beyond 1e6 (or not finite, or so large that the chi-square lower quantile is 0),
        for which no chi-square interval with a finite upper end exists.
    """
    from scipy.stats import chi2 as chi2_dist

    if name not in ALPHA or not (np.isfinite(c_k) and c_k > 0.0):
        return None
    rel = term_rel(name, tau, s2, part, weight, curve, others_err)
    if not (math.isfinite(rel) and 0.0 < rel < 1e6):  # no interval the chi-square form can state
        return None
    edf_eff = 2.0 / rel ** 2
    lo_q, hi_q = chi2_dist.ppf([(1.0 - level) / 2.0, (1.0 + level) / 2.0], edf_eff)
    if not lo_q > 0.0:     # so few degrees of freedom that the lower quantile underflows: no finite upper end
        return None
    return (_coefficient_from_c(name, c_k * edf_eff / hi_q), _coefficient_from_c(name, c_k * edf_eff / lo_q))


def _goodness_of_fit(s2, model, rel, coef, use) -> dict:
    """Chi-square of the reliable points against the fitted power-law sum (every point, dropped ones too).

    Each point's relative standard deviation is ``rel`` (see :func:`fit_allan`). The overlapping
    estimator's points are correlated, so the statistic is not exactly chi-square distributed: its
    p-value is a screen (used with a small threshold, :data:`GOF_P_MIN`), not an exact probability.
    """
    from scipy.stats import chi2 as chi2_dist

    z = (s2 / model - 1.0) / rel
    stat = float(np.sum(z * z))
    dof = max(int(s2.size) - int(np.count_nonzero(coef > 0.0)), 1)
    return {"points": int(s2.size), "dropped": int(s2.size - int(np.count_nonzero(use))), "chi2": stat,
            "dof": dof, "p_value": float(chi2_dist.sf(stat, dof))}


def screen_noise(analysis: AllanAnalysis, min_region_points: int = MIN_REGION_POINTS,
                 slope_tolerance: float = SLOPE_TOLERANCE, p_min: float = GOF_P_MIN,
                 max_dropped_fraction: float = MAX_DROPPED_FRACTION) -> AllanAnalysis:
    """Keep only the noise terms the curve supports; say why the others are not determinable.

    The IEEE model (Std 952-1997, Annex C) describes a record made of independent noise processes. A
    curve it does not describe, or a term read off one or two points, is not a noise term and must not
    be reported as one (a manoeuvre's or a vibration's deterministic error read as an ARW or a rate
    random walk). The rules, in order:

    1. the fit must describe the curve: at least 4 reliable points, at most ``max_dropped_fraction``
       of them left out by the robust fit, and the goodness-of-fit p-value (:func:`_goodness_of_fit`)
       at least ``p_min``; otherwise nothing is determinable;
    2. a term is kept only when its region holds at least ``min_region_points`` points (two points
       make a line of any slope) and the slope measured there lies within ``slope_tolerance`` of its
       nominal slope: 0.25 is half the spacing of neighbouring power laws, so a region kept is closer to
       its own law than to any other;
    3. the rate ramp (slope +1) is deterministic, never a noise term.

    Parameters
    ----------
    analysis : AllanAnalysis
        From :func:`fit_allan`.
    min_region_points, slope_tolerance, p_min, max_dropped_fraction
        The rules above.

    Returns
    -------
    AllanAnalysis
        The same analysis with the terms that fail set to NaN, and ``determinable``, ``reason`` and
        ``rejected`` filled in.
    """
    gof = analysis.goodness_of_fit
    empty = _empty_terms()
    if gof is None or gof["points"] < 4:
        n = 0 if gof is None else gof["points"]
        return replace(analysis, terms=empty, determinable=False,
                       reason=f"too few reliable points on the curve ({n}, need 4): the record is too short")
    dropped_ok = gof["dropped"] <= max_dropped_fraction * gof["points"]
    if gof["p_value"] < p_min or not dropped_ok:
        return replace(analysis, terms=empty, determinable=False,
                       reason=(f"the noise model does not describe the curve (chi2/dof {gof['chi2'] / gof['dof']:.3g}, "
                               f"p {gof['p_value']:.2g}; {gof['dropped']} of {gof['points']} points left out): "
                               "the record holds deterministic errors (a periodic residual, a quantiser's pattern) "
                               "or noise outside the power-law model"))
    terms, rejected = dict(analysis.terms), {}
    for name, term in analysis.terms.items():
        if not term.found:
            continue
        why = None
        if name == "ramp":
            why = "a rate ramp is deterministic, not noise"
        elif term.n_points < min_region_points:
            why = f"read off {term.n_points} point(s) (need {min_region_points})"
        elif not abs(term.slope_measured - term.slope) <= slope_tolerance:
            why = (f"slope {term.slope_measured:.2f} where it dominates, not {term.slope:+.1f} "
                   f"(tolerance {slope_tolerance})")
        if why is not None:
            terms[name] = empty[name]
            rejected[name] = why
    return replace(analysis, terms=terms, rejected=rejected)


def gyro_allan(x, rate_hz: float, data: str = "rate", min_clusters: float = 10.0, share: float = 0.5,
               per_decade: int = 10) -> AllanAnalysis:
    """Allan analysis of one gyro record: ARW, bias instability, rate random walk, quantisation.

    Parameters
    ----------
    x : array_like, 1-D
        Rate (rad/s, ``data="rate"``), angle increments per sample (rad, ``"increment"``) or the
        angle (rad, ``"angle"``; e.g. a filter's output on a stationary segment).
    rate_hz : float
        Sample rate (Hz).
    data : str
        ``rate``, ``increment`` or ``angle``.
    min_clusters, share, per_decade
        See :func:`fit_allan` and :func:`allan_deviation`.

    Returns
    -------
    AllanAnalysis
        ``readings()``: ``arw_deg_rt_h`` (deg/sqrt(h)), ``bias_instability_deg_h`` (deg/h),
        ``rrw_deg_h_rt_h`` (deg/h/sqrt(h)), ``quantization_arcsec`` (arcsec).

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> n_si = 0.1 * DEG / 60.0                               # 0.1 deg/sqrt(h) in rad/sqrt(s)
    >>> rate = rng.standard_normal(200000) * n_si * np.sqrt(100.0)
    >>> a = gyro_allan(rate, 100.0)
    >>> bool(abs(a.readings()["arw_deg_rt_h"] / 0.1 - 1.0) < 0.05)
    True
    """
    if data not in _DATA["gyro"]:
        raise ValueError(f"allan.data: must be one of {list(_DATA['gyro'])} for a gyro, got {data!r}")
    return fit_allan(allan_deviation(x, rate_hz, data, per_decade), "gyro", min_clusters, share)


def accel_allan(x, rate_hz: float, data: str = "specific_force", min_clusters: float = 10.0, share: float = 0.5,
                per_decade: int = 10) -> AllanAnalysis:
    """Allan analysis of one accelerometer record: VRW, bias instability, acceleration random walk.

    Parameters
    ----------
    x : array_like, 1-D
        Specific force (m/s^2, ``data="specific_force"``), velocity increments per sample (m/s,
        ``"increment"``) or the velocity (m/s, ``"velocity"``).
    rate_hz : float
        Sample rate (Hz).
    data : str
        ``specific_force``, ``increment`` or ``velocity``.
    min_clusters, share, per_decade
        See :func:`fit_allan` and :func:`allan_deviation`.

    Returns
    -------
    AllanAnalysis
        ``readings()``: ``vrw_ug_rt_hz`` (ug/sqrt(Hz)), ``vrw_m_s_rt_h`` (m/s/sqrt(h)),
        ``bias_instability_ug`` (ug), ``rrw_ug_rt_h`` (ug/sqrt(h)), ``quantization_m_s`` (m/s).
    """
    if data not in _DATA["accel"]:
        raise ValueError(f"allan.data: must be one of {list(_DATA['accel'])} for an accelerometer, got {data!r}")
    return fit_allan(allan_deviation(x, rate_hz, data, per_decade), "accel", min_clusters, share)


def allan_axes(x, rate_hz: float, sensor: str = "gyro", data: str | None = None, **kwargs) -> dict:
    """Allan analysis of each axis of a triad record.

    Parameters
    ----------
    x : array_like, shape (N, 3)
        Columns x, y, z, in the units of :func:`gyro_allan` / :func:`accel_allan`.
    rate_hz : float
        Sample rate (Hz).
    sensor : str
        ``gyro`` or ``accel``.
    data : str or None
        What ``x`` holds (default: ``rate`` / ``specific_force``).
    **kwargs
        ``min_clusters``, ``share``, ``per_decade``.

    Returns
    -------
    dict
        ``{"x": AllanAnalysis, "y": ..., "z": ...}``.
    """
    arr = np.asarray(x, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"allan.x: must have shape (N, 3), got {arr.shape}")
    unknown = set(kwargs) - {"min_clusters", "share", "per_decade"}
    if unknown:
        raise ValueError(f"allan: unknown keyword(s) {sorted(unknown)} (allowed: min_clusters, per_decade, share)")
    if sensor == "gyro":
        fn, default = gyro_allan, "rate"
    elif sensor == "accel":
        fn, default = accel_allan, "specific_force"
    else:
        raise ValueError(f"allan.sensor: must be one of ['accel', 'gyro'], got {sensor!r}")
    return {ax: fn(arr[:, i], rate_hz, data or default, **kwargs) for i, ax in enumerate("xyz")}


def not_determinable(sensor: str, reason: str, rate_hz: float = math.nan) -> AllanAnalysis:
    """An analysis that reads no term, with the reason (e.g. no stationary span in a record)."""
    if sensor not in _DATA:
        raise ValueError(f"allan.sensor: must be one of ['accel', 'gyro'], got {sensor!r}")
    curve = AllanCurve(np.zeros(0), np.zeros(0), np.zeros(0), 0, float(rate_hz))
    empty = _empty_terms()
    return AllanAnalysis(curve, sensor, {n: 0.0 for n in TERMS}, empty, 10.0, determinable=False, reason=reason)
