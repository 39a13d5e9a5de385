"""Sensor errors of the gyro and accelerometer triads, beyond the dither physics.

Parameters are datasheet quantities (units in the field names, per axis or one value for the three
axes); inside, everything is SI with angles in rad. The appliers stream: they take the exact
increments of one sample grid of step ``dt_s`` (angle increments in rad for the gyros, velocity
increments in m/s for the accelerometers), chunk by chunk, and return the measured ones.

.. autosummary::

   GyroErrorParams
   AccelErrorParams
   SensorErrorParams
   GyroErrors
   AccelErrors
   sensor_params_from_dict
   key_ranges
   bias_instability_components
   gauss_markov_adev

Error model (one axis ``i`` of a triad; ``u`` the true rate or specific force, ``u_j`` its body
components, over a sample of length ``h``; the measured increment is the integral of)::

    u_meas,i = u_i (1 + S_i + A_i sgn(u_i) / 2) + NL_i(u_i) + sum_{j != i} M_ij u_j
               + b_i + b_to,i + w_i(t) + r_i(t) + g_i(t)

* **Scale factor and misalignment** (Groves 2013, sec. 4.4.2 and the error model of sec. 4.4.6:
  ``u_meas = b + (I + M) u + w`` with the scale factors on the diagonal of ``M`` and the
  cross-coupling terms ``m_ij`` off it; Titterton & Weston 2004, ch. 4, the gyro error equation with
  scale factor and input-axis misalignment, and ch. 8, their calibration). ``S`` in ppm. ``M_ij``
  (arcsec, small angles): sensor ``i``'s sensitive axis is tilted towards body axis ``j`` by
  ``M_ij``; a general ``M`` holds both a rotation of the triad (antisymmetric part) and the
  non-orthogonality of its axes (symmetric part). Six angles in the order
  ``(xy, xz, yx, yz, zx, zy)`` or a 3x3 list with a zero diagonal.
* **Scale-factor asymmetry** ``A`` (ppm): the difference of the scale factors for positive and for
  negative inputs as a fraction of the mean one (IEEE Std 528-2001, "scale factor asymmetry"), so
  the scale factor is ``1 + S + A/2`` for ``u > 0`` and ``1 + S - A/2`` for ``u < 0``.
* **Gyro scale-factor nonlinearity** ``L`` (ppm of output at full scale ``W_fs``): the scale factor
  grows linearly with the magnitude of the rate, ``NL(u) = L u |u| / W_fs``, so that the deviation
  from the straight line is ``L`` at full scale and falls off towards zero rate; IEEE Std 528-2001
  ("scale factor nonlinearity": the systematic deviation from the least-squares line, quoted as a
  fraction of output) with the quadratic-in-magnitude law used for integrating gyros in
  Titterton & Weston 2004, ch. 4 (scale-factor error terms). An RLG counts fringes and its scale
  factor is linear apart from lock-in near zero rate, which the effects catalogue models
  physically; the presets therefore keep ``L = 0``.
* **Accelerometer nonlinearity** ``K2`` (ug/g^2): the second-order term of the accelerometer model
  equation of IEEE Std 1293-1998 (``E / K1 = K0 + a_i + K2 a_i^2 + K3 a_i^3 + ...``, input in g),
  ``NL(f) = K2 f^2`` with ``f`` in g (Groves 2013, sec. 4.4.4; Titterton & Weston 2004, ch. 4, the accelerometer error equation).
* **Fixed bias** ``b`` and **turn-on bias** ``b_to`` (1 sigma, drawn once per run from the rng at
  construction; the run-to-run "bias repeatability"; Groves 2013, sec. 4.4.1).
* **Angle / velocity random walk** ``w``: white noise of rate / specific force with two-sided power
  spectral density ``N^2``, so that its Allan variance is ``N^2 / tau`` (IEEE Std 952-1997,
  Annex C, "angle random walk"; IEEE Std 1293-1998, Annex, "velocity random walk"). Over a sample
  its increment is Gaussian with standard deviation ``N sqrt(h)``. Units: ``deg/sqrt(h)`` for gyros;
  ``ug/sqrt(Hz)`` for accelerometers, meaning the same coefficient (``1 ug/sqrt(Hz)`` =
  ``9.80665e-6 m/s/sqrt(s)`` = ``5.884e-4 m/s/sqrt(h)``).
* **Rate / acceleration random walk** ``r``: ``dr = K dW``, Allan variance ``K^2 tau / 3`` (IEEE
  Std 952-1997, Annex C, "rate random walk"), the rate starting at 0 at turn-on. Units
  ``deg/h/sqrt(h)`` and ``ug/sqrt(h)``.
* **Bias instability** ``g``: IEEE Std 952-1997, Annex C, "bias instability": flicker noise whose
  Allan deviation is flat at ``sqrt(2 ln 2 / pi) B = 0.664 B``. Modelled as a sum of first-order
  Gauss-Markov processes (correlation times one per decade, from a factor ``10 / 1.89`` below the
  plateau's lower edge to a factor ``10 / 1.89`` above its upper edge; variances fitted by
  non-negative least squares) whose summed Allan deviation is flat to within +-1.3 % over the
  stated range ``bias_instability_tau_s`` and falls off as ``tau^(+1/2)`` below and ``tau^(-1/2)``
  above it (the Allan variance of one process is ``q T^2 (2x - 3 + 4 e^-x - e^-2x) / tau^2``,
  ``x = tau / T``: IEEE Std 952-1997, Annex C, "correlated noise"). The flicker spectrum is itself a
  superposition of such processes with log-uniform correlation times (Keshner, "1/f noise",
  Proc. IEEE 70(3), 1982). The processes start stationary.

Every stochastic term is discretised exactly: the state (rate of the random walk, Gauss-Markov
value) at the end of a sample and its integral over the sample are drawn from their joint Gaussian
law given the state at the start, so the output statistics, and hence the Allan deviation, do not
depend on ``dt_s`` (tested at two sample rates).

Rate-dependent terms (asymmetry, nonlinearity) use the mean rate over the sample, ``increment /
dt_s``: exact for a rate constant over the sample.

Random numbers: the constructor draws four seeds from ``rng`` and gives each random term its own
stream: the turn-on biases (three draws, at construction), the white noise (three per sample), the
random walk (six per sample) and the Gauss-Markov processes (their stationary initial states at
construction, then six per process and sample). A term that is off draws nothing, and switching one
term off leaves the realisations of the others unchanged (what an error budget needs). Draws are
sequential (numba's ``Generator.standard_normal``, NumPy's algorithm on the same state), so the
output does not depend on how the samples are chunked (bit for bit), and a seed reproduces a run.

Quantisation of the accelerometer output stays in :class:`sins_sim.models.accelerometer.Accelerometer`
(its input is the output of :class:`AccelErrors`).

References
----------
IEEE Std 952-1997, *IEEE Standard Specification Format Guide and Test Procedure for Single-Axis
Interferometric Fiber Optic Gyros*, Annex C (Allan variance noise terms: Q, N, B, K, R).
IEEE Std 1293-1998, *IEEE Standard Specification Format Guide and Test Procedure for Linear,
Single-Axis, Nongyroscopic Accelerometers* (model equation, K2; Allan variance).
IEEE Std 528-2001, *IEEE Standard for Inertial Sensor Terminology* (scale factor asymmetry,
nonlinearity).
D. H. Titterton and J. L. Weston, *Strapdown Inertial Navigation Technology*, 2nd ed., IET, 2004,
ch. 4 and ch. 8.
P. D. Groves, *Principles of GNSS, Inertial, and Multisensor Integrated Navigation Systems*, 2nd
ed., Artech House, 2013, ch. 4 (sec. 4.4).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field, fields
from numbers import Real

import numpy as np
from scipy.optimize import nnls

from sins_sim._kernels import sensor_errors as kse
from sins_sim._validate import unknown_key
from sins_sim.units import ARCSEC, DEG, DEG_PER_H, MICRO_G, STANDARD_GRAVITY

__all__ = ["GyroErrorParams", "AccelErrorParams", "SensorErrorParams", "GyroErrors", "AccelErrors",
           "sensor_params_from_dict", "bias_instability_components", "gauss_markov_adev",
           "FLICKER_FLOOR_FACTOR", "MISALIGNMENT_ORDER", "PHYSICAL_RANGES", "key_ranges", "reference_rows"]

#: Allan-deviation floor of flicker (bias-instability) noise per unit of B: sqrt(2 ln 2 / pi) = 0.6643
#: (IEEE Std 952-1997, Annex C).
FLICKER_FLOOR_FACTOR = math.sqrt(2.0 * math.log(2.0) / math.pi)
#: The six off-diagonal misalignment angles, in the order of a six-value ``misalignment_arcsec``.
MISALIGNMENT_ORDER = ("xy", "xz", "yx", "yz", "zx", "zy")
_MIS_INDEX = ((0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1))

#: Scale-factor terms are small errors: at most 1e5 ppm (10 %), 3 x the +-3 % sensitivity tolerance of a consumer
#: MEMS (MPU-6050, see :data:`PHYSICAL_RANGES`).
MAX_PPM = 1.0e5
#: Misalignments are small angles: at most 36000 arcsec (10 deg), 9 x the +-2 % cross-axis sensitivity of a consumer
#: MEMS (1.15 deg = 4125 arcsec, MPU-6050).
MAX_MISALIGNMENT_ARCSEC = 36000.0

#: Where the upper ends of :data:`PHYSICAL_RANGES` come from. The loosest end is a consumer MEMS IMU, the InvenSense
#: MPU-6000/6050 (product specification PS-MPU-6000A-00, rev. 3.4, 2013): gyro initial zero-rate offset +-20 deg/s,
#: rate noise density 0.005 deg/s/sqrt(Hz), sensitivity tolerance +-3 %, nonlinearity 0.2 %, cross-axis sensitivity
#: +-2 %, full scale +-250 to +-2000 deg/s; accelerometer zero-g offset +-50 mg (x, y) and +-80 mg (z), noise density
#: 400 ug/sqrt(Hz), tolerance +-3 %, cross-axis +-2 %. The other end is the navigation grade (the bundled
#: ``configs/nav-grade-rlg.yaml``, an HG9900-class unit: 0.0035 deg/h, 25 ug), and every error may be 0 (off). The
#: grades between (navigation, tactical, automotive / consumer) and their typical biases and noise: Groves 2013,
#: sec. 4.4.1-4.4.3; Titterton & Weston 2004, ch. 4.
RANGE_SOURCE = "navigation grade to beyond the loosest consumer MEMS (MPU-6050 datasheet)"

#: Upper ends of the sensor-error magnitudes (datasheet units; the lower end is 0 for a spread, a noise density or
#: an instability, and ``-max`` for a signed bias), each with its reason; checked on construction, listed by
#: ``sins-sim schema imu``. A bias instability is a wander of the bias about its value: a tenth of the bias range; a
#: rate (acceleration) random walk may carry the bias through its whole range within 100 h (``K sqrt(100 h)``).
PHYSICAL_RANGES = {
    "gyro.bias_deg_h": (1.0e5, "1.4 x the MPU-6050's +-20 deg/s zero-rate offset (7.2e4 deg/h)"),
    "gyro.turn_on_bias_deg_h": (1.0e5, "the bias range: 1.4 x the MPU-6050's +-20 deg/s (7.2e4 deg/h)"),
    "gyro.arw_deg_rt_h": (10.0, "33 x the MPU-6050's 0.005 deg/s/sqrt(Hz) = 0.3 deg/sqrt(h)"),
    "gyro.bias_instability_deg_h": (1.0e4, "a tenth of the bias range (1e5 deg/h)"),
    "gyro.rrw_deg_h_rt_h": (1.0e4, "carries the bias through its range (1e5 deg/h) within 100 h"),
    "accelerometer.bias_ug": (2.0e5, "2.5 x the MPU-6050's +-80 mg zero-g offset"),
    "accelerometer.turn_on_bias_ug": (2.0e5, "the bias range: 2.5 x the MPU-6050's +-80 mg"),
    "accelerometer.vrw_ug_rt_hz": (1.0e4, "25 x the MPU-6050's 400 ug/sqrt(Hz)"),
    "accelerometer.bias_instability_ug": (2.0e4, "a tenth of the bias range (2e5 ug)"),
    "accelerometer.rrw_ug_rt_h": (2.0e4, "carries the bias through its range (2e5 ug) within 100 h"),
}
for _sec in ("gyro", "accelerometer"):
    PHYSICAL_RANGES[f"{_sec}.scale_factor_ppm"] = (MAX_PPM, "3 x the MPU-6050's +-3 % sensitivity tolerance")
    PHYSICAL_RANGES[f"{_sec}.scale_factor_asymmetry_ppm"] = (MAX_PPM, "the scale-factor range (10 %)")
    PHYSICAL_RANGES[f"{_sec}.misalignment_arcsec"] = (MAX_MISALIGNMENT_ARCSEC,
                                                      "9 x the MPU-6050's +-2 % cross-axis sensitivity (4125 arcsec)")
PHYSICAL_RANGES["gyro.scale_factor_nonlinearity_ppm"] = (MAX_PPM, "50 x the MPU-6050's 0.2 % nonlinearity")
PHYSICAL_RANGES["accelerometer.nonlinearity_ug_g2"] = (
    MAX_PPM, "0.1 g at 1 g; the MPU-6050's 0.5 % of +-16 g full scale is 312 ug/g^2")
#: The full-scale rate of the gyro nonlinearity law: rate gyros are specified from tens of deg/s (low-rate
#: navigation FOGs) to +-2000 deg/s (MPU-6050) and +-4000 deg/s (newer consumer MEMS); the range holds them all.
FULL_SCALE_RANGE_DEG_S = (1.0, 1.0e4)
del _sec
#: The bias-instability plateau: edges in (0, 1e7] s, at most 6 decades wide.
MAX_TAU_S = 1.0e7
MAX_PLATEAU_DECADES = 6.0
#: Gauss-Markov correlation times per decade of the plateau fit (ripple +-1.3 %).
GM_PER_DECADE = 1
#: The ADEV peak of one Gauss-Markov process lies at tau = 1.89 T (IEEE Std 952-1997, Annex C).
_GM_PEAK = 1.89


# --- field checks ---------------------------------------------------------------------------------
def _is_number(x) -> bool:
    return isinstance(x, (Real, np.floating, np.integer)) and not isinstance(x, (bool, np.bool_))


def _number(owner, name, x, lo=None, max_abs=None, positive=False, hi=None, why="") -> float:
    """``x`` as a float, checked: finite, ``> 0`` (``positive``), ``>= lo``, ``<= hi``, ``|x| <= max_abs``; a
    refusal states the range and ``why`` (its physical reason, :data:`PHYSICAL_RANGES`)."""
    if not _is_number(x):
        raise ValueError(f"{owner}.{name}: must be a number, got {x!r}")
    if not math.isfinite(float(x)):
        raise ValueError(f"{owner}.{name}: must be finite, got {x!r}")
    reason = f" (the physical range; its bound is {why})" if why else ""
    if positive and not x > 0:
        raise ValueError(f"{owner}.{name}: must be > 0, got {x!r}")
    if lo is not None and x < lo:
        raise ValueError(f"{owner}.{name}: must be >= {lo:g}" + (f" (range [{lo:g}, {hi:g}]{reason})"
                                                               if hi is not None and lo > 0 else "") + f", got {x!r}")
    if hi is not None and x > hi:
        low = f"{lo:g}" if lo is not None else "-inf"
        raise ValueError(f"{owner}.{name}: must lie in [{low}, {hi:g}]{reason}, got {x!r}")
    if max_abs is not None and abs(x) > max_abs:
        raise ValueError(f"{owner}.{name}: must lie in [-{max_abs:g}, {max_abs:g}]{reason}, got {x!r}")
    return float(x)


def _shape(value):
    """The array shape of a list / tuple / array (None for anything else or a ragged list)."""
    if not isinstance(value, (list, tuple, np.ndarray)):
        return None
    try:
        return np.shape(value)
    except ValueError:  # a ragged list
        return None


def _axes(owner, name, value, **limits) -> tuple:
    """One number for the three axes, or three numbers (x, y, z), each checked by :func:`_number` with ``limits``."""
    if _is_number(value):
        x = _number(owner, name, value, **limits)
        return (x, x, x)
    if _shape(value) == (3,):
        return tuple(_number(owner, f"{name}[{k}]", x, **limits) for k, x in enumerate(value))
    raise ValueError(f"{owner}.{name}: must be a number or a list of 3 numbers (x, y, z), got {value!r}")


def _misalignment(owner, name, value) -> tuple:
    """Six angles (xy, xz, yx, yz, zx, zy) or a 3x3 list with a zero diagonal."""
    shape = _shape(value)
    lim = {"max_abs": MAX_MISALIGNMENT_ARCSEC, "why": PHYSICAL_RANGES["gyro.misalignment_arcsec"][1]}
    if shape == (6,):
        return tuple(_number(owner, f"{name}[{k}]", x, **lim) for k, x in enumerate(value))
    if shape == (3, 3):
        rows = [list(r) for r in value]
        for i in range(3):
            if _number(owner, f"{name}[{i}][{i}]", rows[i][i]) != 0.0:
                raise ValueError(f"{owner}.{name}[{i}][{i}]: the diagonal must be 0 (scale factors are separate), "
                                 f"got {rows[i][i]!r}")
        return tuple(_number(owner, f"{name}[{i}][{j}]", rows[i][j], **lim)
                     for i, j in _MIS_INDEX)
    raise ValueError(f"{owner}.{name}: must be 6 angles ({', '.join(MISALIGNMENT_ORDER)}) or a 3x3 list with a zero "
                     f"diagonal, got {value!r}")


def _tau_range(owner, name, value) -> tuple:
    if _shape(value) != (2,):
        raise ValueError(f"{owner}.{name}: must be 2 numbers [lower, upper] (s), got {value!r}")
    lo = _number(owner, f"{name}[0]", value[0])
    hi = _number(owner, f"{name}[1]", value[1])
    if not 0.0 < lo <= hi <= MAX_TAU_S:
        raise ValueError(f"{owner}.{name}: must satisfy 0 < lower <= upper <= {MAX_TAU_S:g} s, got {value!r}")
    if math.log10(hi / lo) > MAX_PLATEAU_DECADES:
        raise ValueError(f"{owner}.{name}: the plateau may span at most {MAX_PLATEAU_DECADES:g} decades, "
                         f"got {value!r}")
    return (lo, hi)


def _check_fields(obj, owner, specs):
    for name, kind, kw in specs:
        value = getattr(obj, name)
        if kind == "axes":
            norm = _axes(owner, name, value, **kw)
        elif kind == "number":
            norm = _number(owner, name, value, **kw)
        elif kind == "tau":
            norm = _tau_range(owner, name, value)
        else:  # misalignment
            norm = _misalignment(owner, name, value)
        object.__setattr__(obj, name, norm)


def _signed(key) -> dict:
    """The limits of a signed error (a bias, a scale factor): ``|x| <= max`` of :data:`PHYSICAL_RANGES`."""
    hi, why = PHYSICAL_RANGES[key]
    return {"max_abs": hi, "why": why}


def _magnitude(key) -> dict:
    """The limits of a spread, noise density or instability: ``0 <= x <= max`` of :data:`PHYSICAL_RANGES`."""
    hi, why = PHYSICAL_RANGES[key]
    return {"lo": 0.0, "hi": hi, "why": why}


def _misalignment_matrix(six_arcsec) -> np.ndarray:
    m = np.zeros((3, 3))
    for (i, j), a in zip(_MIS_INDEX, six_arcsec):
        m[i, j] = a * ARCSEC
    m.setflags(write=False)
    return m


def _zero_axes():
    return (0.0, 0.0, 0.0)


# --- parameters -----------------------------------------------------------------------------------
@dataclass(frozen=True)
class GyroErrorParams:
    """Gyro triad errors in datasheet units (each per axis: one number for x, y, z or a list of three).

    Parameters
    ----------
    bias_deg_h : float or 3 floats
        Fixed bias (deg/h), any sign.
    turn_on_bias_deg_h : float or 3 floats
        Turn-on (run-to-run) bias, 1 sigma (deg/h), >= 0; drawn once per run.
    arw_deg_rt_h : float or 3 floats
        Angle random walk N (deg/sqrt(h)), >= 0: Allan deviation ``N / sqrt(tau)``.
    bias_instability_deg_h : float or 3 floats
        Bias instability B (deg/h), >= 0: Allan deviation floor ``0.664 B``.
    bias_instability_tau_s : 2 floats
        The decade range (s) over which the Allan deviation of the bias instability is flat
        (``0 < lower <= upper <= 1e7``, at most 6 decades); the same for the three axes.
    rrw_deg_h_rt_h : float or 3 floats
        Rate random walk K (deg/h/sqrt(h)), >= 0: Allan deviation ``K sqrt(tau / 3)``.
    scale_factor_ppm : float or 3 floats
        Scale-factor error S (ppm), ``|S| <= 1e5``.
    scale_factor_asymmetry_ppm : float or 3 floats
        Scale-factor asymmetry A (ppm): ``1 + S +- A/2`` for positive / negative rates.
    scale_factor_nonlinearity_ppm : float or 3 floats
        Scale-factor nonlinearity L (ppm at full scale): output error ``L w |w| / w_fs``.
    full_scale_deg_s : float
        Full-scale rate ``w_fs`` (deg/s) of the nonlinearity law, > 0.
    misalignment_arcsec : 6 floats or 3x3 floats
        Off-diagonal misalignment / non-orthogonality ``M_ij`` (arcsec), in the order
        ``(xy, xz, yx, yz, zx, zy)`` or as a 3x3 list with zero diagonal; ``|M_ij| <= 36000``.

    Notes
    -----
    The laws and their sources are given in the module docstring. After construction every per-axis
    field is a tuple of three floats and ``misalignment_arcsec`` a tuple of six.

    Examples
    --------
    >>> p = GyroErrorParams(arw_deg_rt_h=0.002, bias_deg_h=[0.0035, -0.002, 0.001])
    >>> p.arw_deg_rt_h
    (0.002, 0.002, 0.002)
    """

    bias_deg_h: object = 0.0
    turn_on_bias_deg_h: object = 0.0
    arw_deg_rt_h: object = 0.0
    bias_instability_deg_h: object = 0.0
    bias_instability_tau_s: object = (1.0, 1000.0)
    rrw_deg_h_rt_h: object = 0.0
    scale_factor_ppm: object = 0.0
    scale_factor_asymmetry_ppm: object = 0.0
    scale_factor_nonlinearity_ppm: object = 0.0
    full_scale_deg_s: object = 400.0
    misalignment_arcsec: object = (0.0,) * 6

    _OWNER = "gyro_errors"
    #: (field, kind, limits) of every field: checked on construction, listed by :func:`reference_rows`
    _FIELDS = (
        ("bias_deg_h", "axes", _signed("gyro.bias_deg_h")),
        ("turn_on_bias_deg_h", "axes", _magnitude("gyro.turn_on_bias_deg_h")),
        ("arw_deg_rt_h", "axes", _magnitude("gyro.arw_deg_rt_h")),
        ("bias_instability_deg_h", "axes", _magnitude("gyro.bias_instability_deg_h")),
        ("bias_instability_tau_s", "tau", {}),
        ("rrw_deg_h_rt_h", "axes", _magnitude("gyro.rrw_deg_h_rt_h")),
        ("scale_factor_ppm", "axes", _signed("gyro.scale_factor_ppm")),
        ("scale_factor_asymmetry_ppm", "axes", _signed("gyro.scale_factor_asymmetry_ppm")),
        ("scale_factor_nonlinearity_ppm", "axes", _signed("gyro.scale_factor_nonlinearity_ppm")),
        ("full_scale_deg_s", "number", {"positive": True, "lo": FULL_SCALE_RANGE_DEG_S[0],
                                        "hi": FULL_SCALE_RANGE_DEG_S[1],
                                        "why": "rate gyros from low-rate navigation FOGs (tens of deg/s) to "
                                               "consumer MEMS (+-2000 deg/s MPU-6050, +-4000 deg/s newer parts)"}),
        ("misalignment_arcsec", "misalignment", {}),
        )

    def __post_init__(self):
        _check_fields(self, self._OWNER, self._FIELDS)

    @property
    def is_ideal(self) -> bool:
        """True when every error is zero (the applier then returns its input unchanged)."""
        return all(not any(getattr(self, f.name)) for f in fields(self)
                   if f.name not in ("bias_instability_tau_s", "full_scale_deg_s"))

    @property
    def misalignment_matrix_rad(self) -> np.ndarray:
        """The off-diagonal misalignment matrix ``M`` (rad), zero diagonal, read-only (3, 3)."""
        return _misalignment_matrix(self.misalignment_arcsec)


@dataclass(frozen=True)
class AccelErrorParams:
    """Accelerometer triad errors in datasheet units (each per axis: one number or a list of three).

    Parameters
    ----------
    bias_ug : float or 3 floats
        Fixed bias (ug), any sign.
    turn_on_bias_ug : float or 3 floats
        Turn-on (run-to-run) bias, 1 sigma (ug), >= 0; drawn once per run.
    vrw_ug_rt_hz : float or 3 floats
        Velocity random walk N (ug/sqrt(Hz)), >= 0: Allan deviation ``N / sqrt(tau)`` (ug, tau in s);
        ``1 ug/sqrt(Hz) = 5.884e-4 m/s/sqrt(h)``.
    bias_instability_ug : float or 3 floats
        Bias instability B (ug), >= 0: Allan deviation floor ``0.664 B``.
    bias_instability_tau_s : 2 floats
        Decade range (s) of the flat Allan deviation, as for the gyros.
    rrw_ug_rt_h : float or 3 floats
        Acceleration random walk K (ug/sqrt(h)), >= 0: Allan deviation ``K sqrt(tau / 3)`` (tau in h).
    scale_factor_ppm : float or 3 floats
        Scale-factor error S (ppm), ``|S| <= 1e5``.
    scale_factor_asymmetry_ppm : float or 3 floats
        Scale-factor asymmetry A (ppm): ``1 + S +- A/2`` for positive / negative inputs.
    nonlinearity_ug_g2 : float or 3 floats
        Second-order nonlinearity K2 (ug/g^2), ``|K2| <= 1e5``: output error ``K2 f^2`` (f in g).
    misalignment_arcsec : 6 floats or 3x3 floats
        Off-diagonal misalignment / non-orthogonality (arcsec), as for the gyros.
    """

    bias_ug: object = 0.0
    turn_on_bias_ug: object = 0.0
    vrw_ug_rt_hz: object = 0.0
    bias_instability_ug: object = 0.0
    bias_instability_tau_s: object = (1.0, 1000.0)
    rrw_ug_rt_h: object = 0.0
    scale_factor_ppm: object = 0.0
    scale_factor_asymmetry_ppm: object = 0.0
    nonlinearity_ug_g2: object = 0.0
    misalignment_arcsec: object = (0.0,) * 6

    _OWNER = "accel_errors"
    #: (field, kind, limits) of every field: checked on construction, listed by :func:`reference_rows`
    _FIELDS = (
        ("bias_ug", "axes", _signed("accelerometer.bias_ug")),
        ("turn_on_bias_ug", "axes", _magnitude("accelerometer.turn_on_bias_ug")),
        ("vrw_ug_rt_hz", "axes", _magnitude("accelerometer.vrw_ug_rt_hz")),
        ("bias_instability_ug", "axes", _magnitude("accelerometer.bias_instability_ug")),
        ("bias_instability_tau_s", "tau", {}),
        ("rrw_ug_rt_h", "axes", _magnitude("accelerometer.rrw_ug_rt_h")),
        ("scale_factor_ppm", "axes", _signed("accelerometer.scale_factor_ppm")),
        ("scale_factor_asymmetry_ppm", "axes", _signed("accelerometer.scale_factor_asymmetry_ppm")),
        ("nonlinearity_ug_g2", "axes", _signed("accelerometer.nonlinearity_ug_g2")),
        ("misalignment_arcsec", "misalignment", {}),
        )

    def __post_init__(self):
        _check_fields(self, self._OWNER, self._FIELDS)

    @property
    def is_ideal(self) -> bool:
        """True when every error is zero (the applier then returns its input unchanged)."""
        return all(not any(getattr(self, f.name)) for f in fields(self) if f.name != "bias_instability_tau_s")

    @property
    def misalignment_matrix_rad(self) -> np.ndarray:
        """The off-diagonal misalignment matrix ``M`` (rad), zero diagonal, read-only (3, 3)."""
        return _misalignment_matrix(self.misalignment_arcsec)


@dataclass(frozen=True)
class SensorErrorParams:
    """The ``sensors:`` section: gyro and accelerometer triad errors.

    Parameters
    ----------
    gyro : GyroErrorParams
    accelerometer : AccelErrorParams
    """

    gyro: GyroErrorParams = field(default_factory=GyroErrorParams)
    accelerometer: AccelErrorParams = field(default_factory=AccelErrorParams)

    def __post_init__(self):
        if not isinstance(self.gyro, GyroErrorParams):
            raise ValueError(f"sensors.gyro: must be GyroErrorParams, got {type(self.gyro).__name__}")
        if not isinstance(self.accelerometer, AccelErrorParams):
            raise ValueError(f"sensors.accelerometer: must be AccelErrorParams, "
                             f"got {type(self.accelerometer).__name__}")


# --- bias instability as a sum of Gauss-Markov processes ----------------------------------------
def _gm_f(x):
    """``2x - 3 + 4 e^-x - e^-2x`` without cancellation (series below x = 0.5)."""
    x = np.asarray(x, dtype=np.float64)
    out = np.empty_like(x)
    small = x < 0.5
    xs = x[small]
    # sum_{n>=3} (-1)^n (4 - 2^n) x^n / n!: terms fall as (2x)^n / n!, 30 terms reach 1e-17 at x = 0.5
    acc = np.zeros_like(xs)
    term = np.ones_like(xs)
    for n in range(1, 31):
        term = term * xs / n
        if n >= 3:
            acc += (-1) ** n * (4.0 - 2.0 ** n) * term
    out[small] = acc
    xl = x[~small]
    out[~small] = 2.0 * xl - 3.0 + 4.0 * np.exp(-xl) - np.exp(-2.0 * xl)
    return out


def gauss_markov_adev(tau_s, tau_c_s, variance):
    """Allan deviation of a sum of independent first-order Gauss-Markov processes.

    Parameters
    ----------
    tau_s : array_like
        Averaging times (s), > 0.
    tau_c_s : array_like, shape (P,)
        Correlation times T (s), > 0.
    variance : array_like, shape (P,)
        Stationary variances q of the processes (unit^2, e.g. (rad/s)^2).

    Returns
    -------
    ndarray
        ``sqrt(sum_p q_p T_p^2 (2x - 3 + 4 e^-x - e^-2x) / tau^2)``, ``x = tau / T_p`` (unit of
        the process), shaped like ``tau_s`` (IEEE Std 952-1997, Annex C, correlated noise).

    Examples
    --------
    >>> round(float(gauss_markov_adev(1.89, [1.0], [1.0])), 3)  # the peak, near 0.618 sqrt(q)
    0.617
    """
    tau = np.asarray(tau_s, dtype=np.float64)
    tc = np.atleast_1d(np.asarray(tau_c_s, dtype=np.float64))
    q = np.atleast_1d(np.asarray(variance, dtype=np.float64))
    avar = np.zeros_like(tau)
    for t, v in zip(tc, q):
        avar = avar + v * t * t * _gm_f(tau / t) / (tau * tau)
    return np.sqrt(avar)


@functools.lru_cache(maxsize=64)
def _unit_components(lo: float, hi: float):
    r = 10.0 ** (1.0 / GM_PER_DECADE)
    t0 = lo / _GM_PEAK / r
    t1 = hi / _GM_PEAK * r
    n = int(math.ceil(math.log10(t1 / t0) * GM_PER_DECADE - 1e-9)) + 1
    tc = t0 * r ** np.arange(n)
    tau = np.geomspace(lo, hi, 200) if hi > lo else np.array([lo])
    a = np.stack([gauss_markov_adev(tau, [t], [1.0]) ** 2 for t in tc], axis=1)
    q, _ = nnls(a, np.ones(tau.size))
    keep = q > 0.0
    tc, q = tc[keep], q[keep]
    tc.setflags(write=False)
    q.setflags(write=False)
    return tc, q


def bias_instability_components(floor, tau_range_s):
    """Gauss-Markov processes whose summed Allan deviation is flat at ``floor`` over ``tau_range_s``.

    Parameters
    ----------
    floor : float
        The plateau of the Allan deviation, ``0.664 B`` (unit of the rate, e.g. rad/s), >= 0.
    tau_range_s : (float, float)
        Lower and upper edge of the plateau (s).

    Returns
    -------
    tau_c_s : ndarray, shape (P,)
        Correlation times (s), one per decade from ``lower / 1.89 / 10`` to ``upper / 1.89 * 10``.
    variance : ndarray, shape (P,)
        Stationary variances (unit^2), non-negative least squares on the relative Allan variance
        at 200 log-spaced taus over the range (the summed Allan deviation is within +-1.3 % of
        ``floor`` there).

    Examples
    --------
    >>> tc, q = bias_instability_components(1.0, (1.0, 1000.0))
    >>> adev = gauss_markov_adev(np.geomspace(1, 1000, 7), tc, q)
    >>> bool(np.all(np.abs(adev - 1.0) < 0.013))
    True
    """
    lo, hi = _tau_range("bias_instability", "tau_s", tau_range_s)
    floor = float(floor)
    if not (math.isfinite(floor) and floor >= 0.0):
        raise ValueError(f"bias_instability.floor: must be a finite number >= 0, got {floor!r}")
    tc, q = _unit_components(lo, hi)
    return tc.copy(), q * floor * floor


def _gm_coefficients(tc, q, h):
    """Per process ``[phi, mean_gain, l11, l21, l22]`` of the exact (value, integral) transition."""
    x = h / tc
    em1 = np.expm1(-x)                       # phi - 1
    phi = 1.0 + em1
    mean_gain = -tc * em1                    # T (1 - phi)
    var_x = -q * np.expm1(-2.0 * x)          # q (1 - phi^2)
    cov = q * tc * em1 * em1                 # q T (1 - phi)^2
    var_i = q * tc * tc * _gm_f(x)           # q T^2 (2x - 3 + 4 phi - phi^2)
    l11 = np.sqrt(var_x)
    l21 = np.where(l11 > 0.0, cov / np.where(l11 > 0.0, l11, 1.0), 0.0)
    l22 = np.sqrt(np.maximum(var_i - l21 * l21, 0.0))
    return np.stack([phi, mean_gain, l11, l21, l22], axis=-1)


# --- the streaming appliers ---------------------------------------------------------------------
class _TriadErrors:
    """Shared machinery of the gyro and accelerometer appliers (everything in SI here)."""

    _owner = ""

    def _setup(self, rng, dt_s, bias, turn_on_sd, white, floor, tau_range, rw, scale, half_asym, mis):
        if not isinstance(rng, np.random.Generator):
            raise ValueError(f"{self._owner}.rng: must be a numpy.random.Generator, got {type(rng).__name__}")
        dt = _number(self._owner, "dt_s", dt_s, positive=True)
        self.dt_s = dt
        # four independent streams seeded from rng: turn-on biases, white noise, random walk, Gauss-Markov
        seeds = rng.integers(0, 2**63, size=4, dtype=np.uint64)
        s_turn_on, self._g_white, self._g_rw, self._g_gm = (np.random.default_rng(int(x)) for x in seeds)
        self.turn_on_bias = s_turn_on.standard_normal(3) * turn_on_sd
        self.bias = bias + self.turn_on_bias
        tc_unit, q_unit = _unit_components(*tau_range)
        self._gm_tau_c = tc_unit
        self._gm_var = np.outer(floor * floor, q_unit)                  # (3, P)
        if np.any(floor > 0.0):   # stationary start, then the per-sample draws, all from the Gauss-Markov stream
            self._gm_state = self._g_gm.standard_normal((3, tc_unit.size)) * np.sqrt(self._gm_var)
            self._gm_coef = np.stack([_gm_coefficients(tc_unit, self._gm_var[i], dt) for i in range(3)])
        else:
            self._gm_state = np.zeros((3, 0))
            self._gm_coef = np.zeros((3, 0, 5))
        self._white_sd = white * math.sqrt(dt) if np.any(white > 0.0) else np.zeros(0)
        if np.any(rw > 0.0):
            h32 = dt * math.sqrt(dt)
            self._rw_coef = np.stack([rw * math.sqrt(dt), rw * h32 / 2.0, rw * h32 / math.sqrt(12.0),
                                      np.full(3, dt)], axis=1)
        else:
            self._rw_coef = np.zeros((0, 4))
        self._cols = self._white_sd.size + 2 * self._rw_coef.shape[0] + 2 * self._gm_state.size
        self._rw_state = np.zeros(3)
        self._bias_inc = self.bias * dt
        self._scale = scale
        self._half_asym = half_asym
        self._mis = mis
        self._linear_on = bool(np.any(scale) or np.any(half_asym) or np.any(mis))

    @property
    def normals_per_sample(self) -> int:
        """Standard normals drawn per sample: 3 (white) + 6 (random walk) + 6 P (Gauss-Markov), each
        counted only when its term is on for some axis."""
        return self._cols

    @property
    def bias_instability_components(self):
        """``(tau_c_s (P,), variance (3, P))`` of the Gauss-Markov sum per axis (SI units squared)."""
        return self._gm_tau_c.copy(), self._gm_var.copy()

    def _nonlinear(self, inc):
        """The nonlinearity's error increments for ``inc`` (N, 3), or None: the base triad has none."""
        return None

    def _apply(self, x, what):
        inc = np.asarray(x, dtype=np.float64)
        if inc.ndim != 2 or inc.shape[1] != 3:
            raise ValueError(f"{self._owner}.{what}: must have shape (N, 3), got {inc.shape}")
        n = inc.shape[0]
        out = inc.copy()
        if self._linear_on:
            m = self._mis
            err = inc * (self._scale + self._half_asym * np.sign(inc))
            for i in range(3):
                j, k = [a for a in range(3) if a != i]
                err[:, i] += m[i, j] * inc[:, j] + m[i, k] * inc[:, k]
            out += err
        nl = self._nonlinear(inc)
        if nl is not None:
            out += nl
        noise = np.empty((n, 3))
        if self._cols:
            kse.noise_increments(self._g_white, self._g_rw, self._g_gm, self._bias_inc, self._white_sd,
                                 self._rw_coef, self._rw_state, self._gm_coef, self._gm_state, noise)
        else:
            noise[:] = self._bias_inc
        out += noise
        return out


class GyroErrors(_TriadErrors):
    """Streaming gyro-triad errors on angle increments.

    Parameters
    ----------
    params : GyroErrorParams
        The error parameters (datasheet units).
    rng : numpy.random.Generator
        Seeds the four random streams (turn-on biases, white noise, random walk, Gauss-Markov): four
        draws at construction; ``rng`` is not used afterwards.
    dt_s : float
        Length of one sample (s), > 0: the increments passed to :meth:`apply` are integrals over
        consecutive samples of this length.

    Attributes
    ----------
    turn_on_bias : ndarray, shape (3,)
        The turn-on biases drawn for this run (rad/s).
    bias : ndarray, shape (3,)
        Fixed plus turn-on bias (rad/s).

    Examples
    --------
    >>> g = GyroErrors(GyroErrorParams(arw_deg_rt_h=0.002), np.random.default_rng(1), dt_s=0.01)
    >>> g.apply(np.zeros((4, 3))).shape
    (4, 3)
    """

    _owner = "gyro_errors"

    def __init__(self, params: GyroErrorParams, rng: np.random.Generator, dt_s: float):
        if not isinstance(params, GyroErrorParams):
            raise ValueError(f"gyro_errors: must be GyroErrorParams, got {type(params).__name__}")
        self.params = params
        a = lambda name: np.array(getattr(params, name), dtype=np.float64)  # noqa: E731
        self._setup(rng, dt_s,
                    bias=a("bias_deg_h") * DEG_PER_H,
                    turn_on_sd=a("turn_on_bias_deg_h") * DEG_PER_H,
                    white=a("arw_deg_rt_h") * DEG / 60.0,                       # deg/sqrt(h) -> rad/sqrt(s)
                    floor=a("bias_instability_deg_h") * DEG_PER_H * FLICKER_FLOOR_FACTOR,
                    tau_range=params.bias_instability_tau_s,
                    rw=a("rrw_deg_h_rt_h") * DEG_PER_H / 60.0,                  # deg/h/sqrt(h) -> rad/s/sqrt(s)
                    scale=a("scale_factor_ppm") * 1e-6,
                    half_asym=a("scale_factor_asymmetry_ppm") * 0.5e-6,
                    mis=params.misalignment_matrix_rad)
        self._nl = a("scale_factor_nonlinearity_ppm") * 1e-6 / (params.full_scale_deg_s * DEG)  # per (rad/s)

    def _nonlinear(self, inc):
        if not np.any(self._nl):
            return None
        return self._nl * inc * np.abs(inc) / self.dt_s

    def apply(self, dtheta_true) -> np.ndarray:
        """Measured angle increments for a chunk of true ones.

        Parameters
        ----------
        dtheta_true : array_like, shape (N, 3)
            True angle increments (rad) about the body axes x, y, z over N consecutive samples of
            ``dt_s``; the mean rate of a sample, ``dtheta / dt_s``, drives the rate-dependent terms.

        Returns
        -------
        ndarray, shape (N, 3)
            Measured angle increments (rad). Consecutive calls continue the same realisation: any
            chunking of the samples gives the same result bit for bit.
        """
        return self._apply(dtheta_true, "dtheta_true")


class AccelErrors(_TriadErrors):
    """Streaming accelerometer-triad errors on velocity increments.

    Parameters
    ----------
    params : AccelErrorParams
        The error parameters (datasheet units).
    rng : numpy.random.Generator
        Seeds the four random streams, as for :class:`GyroErrors`; use a generator independent of
        the gyros'.
    dt_s : float
        Length of one sample (s), > 0.

    Attributes
    ----------
    turn_on_bias : ndarray, shape (3,)
        The turn-on biases drawn for this run (m/s^2).
    bias : ndarray, shape (3,)
        Fixed plus turn-on bias (m/s^2).

    Notes
    -----
    The output is the input of the pulse quantiser
    (:class:`sins_sim.models.accelerometer.Accelerometer`), which keeps the quantisation.
    """

    _owner = "accel_errors"

    def __init__(self, params: AccelErrorParams, rng: np.random.Generator, dt_s: float):
        if not isinstance(params, AccelErrorParams):
            raise ValueError(f"accel_errors: must be AccelErrorParams, got {type(params).__name__}")
        self.params = params
        a = lambda name: np.array(getattr(params, name), dtype=np.float64)  # noqa: E731
        self._setup(rng, dt_s,
                    bias=a("bias_ug") * MICRO_G,
                    turn_on_sd=a("turn_on_bias_ug") * MICRO_G,
                    white=a("vrw_ug_rt_hz") * MICRO_G,                          # ug/sqrt(Hz) -> m/s/sqrt(s)
                    floor=a("bias_instability_ug") * MICRO_G * FLICKER_FLOOR_FACTOR,
                    tau_range=params.bias_instability_tau_s,
                    rw=a("rrw_ug_rt_h") * MICRO_G / 60.0,                       # ug/sqrt(h) -> m/s^2/sqrt(s)
                    scale=a("scale_factor_ppm") * 1e-6,
                    half_asym=a("scale_factor_asymmetry_ppm") * 0.5e-6,
                    mis=params.misalignment_matrix_rad)
        self._k2 = a("nonlinearity_ug_g2") * 1e-6 / STANDARD_GRAVITY          # per (m/s^2)

    def _nonlinear(self, inc):
        if not np.any(self._k2):
            return None
        return self._k2 * inc * inc / self.dt_s

    def apply(self, dv_true) -> np.ndarray:
        """Measured velocity increments (before pulse quantisation) for a chunk of true ones.

        Parameters
        ----------
        dv_true : array_like, shape (N, 3)
            True velocity increments (m/s) along the body axes over N consecutive samples of
            ``dt_s``; the mean specific force ``dv / dt_s`` drives the rate-dependent terms.

        Returns
        -------
        ndarray, shape (N, 3)
            Measured velocity increments (m/s), chunking-independent bit for bit.
        """
        return self._apply(dv_true, "dv_true")


# --- the `sensors:` section of a YAML file ------------------------------------------------------
_GYRO_KEYS = {
    "bias_deg_h": "bias", "turn_on_bias_deg_h": "turn_on_bias", "arw_deg_rt_h": "arw",
    "bias_instability_deg_h": "bias_instability", "bias_instability_tau_s": "bias_instability_tau",
    "rrw_deg_h_rt_h": "rrw", "scale_factor_ppm": "scale_factor",
    "scale_factor_asymmetry_ppm": "scale_factor_asymmetry",
    "scale_factor_nonlinearity_ppm": "scale_factor_nonlinearity", "full_scale_deg_s": "full_scale",
    "misalignment_arcsec": "misalignment",
}
_ACCEL_KEYS = {
    "bias_ug": "bias", "turn_on_bias_ug": "turn_on_bias", "vrw_ug_rt_hz": "vrw",
    "bias_instability_ug": "bias_instability", "bias_instability_tau_s": "bias_instability_tau",
    "rrw_ug_rt_h": "rrw", "scale_factor_ppm": "scale_factor",
    "scale_factor_asymmetry_ppm": "scale_factor_asymmetry", "nonlinearity_ug_g2": "nonlinearity",
    "misalignment_arcsec": "misalignment",
}
_UNIT_WORDS = {"deg", "rad", "mrad", "urad", "arcsec", "arcmin", "h", "s", "ms", "hz", "rt", "per", "ppm", "ppb",
               "percent", "ug", "mg", "g", "g2", "m", "s2", "rps", "dph"}


def _unknown_key_rule(key, known: dict) -> str:
    bases = sorted(((b, k) for k, b in known.items() if key == b or key.startswith(b + "_")),
                   key=lambda bk: len(bk[0]), reverse=True)
    if bases:
        base, right = bases[0]
        if key == base:
            return f"needs a unit: write {right}"
        if all(w in _UNIT_WORDS for w in key[len(base) + 1:].split("_")):
            return f"unknown unit in {key!r}: write {right}"
    return unknown_key(key, known, {b: k for k, b in known.items()})


def _section(doc, cls, known, ctx, where):
    if doc is None:
        return cls()
    if not isinstance(doc, dict):
        raise ValueError(f"{ctx}: {where}: must be a mapping, got {type(doc).__name__} {doc!r}")
    for key in doc:
        if not isinstance(key, str):
            raise ValueError(f"{ctx}: {where}.{key}: keys must be strings")
        if key not in known:
            raise ValueError(f"{ctx}: {where}.{key}: {_unknown_key_rule(key, known)}")
    try:
        return cls(**doc)
    except ValueError as exc:
        msg = str(exc)
        prefix = cls._OWNER + "."
        if msg.startswith(prefix):
            msg = msg[len(prefix):]
        raise ValueError(f"{ctx}: {where}.{msg}") from None


def sensor_params_from_dict(doc, ctx: str, path: str = "sensors") -> SensorErrorParams:
    """Build the sensor error parameters from the ``sensors:`` mapping of a YAML file.

    Parameters
    ----------
    doc : dict or None
        The parsed mapping under ``sensors:``: ``{"gyro": {...}, "accelerometer": {...}}``, both
        optional (missing or null: no errors). Keys carry their units, values are a number for the
        three axes or a list of three (``misalignment_arcsec``: 6 angles or a 3x3 list,
        ``bias_instability_tau_s``: [lower, upper]); see :class:`GyroErrorParams` and
        :class:`AccelErrorParams` for the keys and their ranges.
    ctx : str
        Where the mapping comes from (the file name), first in every error message.
    path : str
        Key path of the mapping in the file (``sensors``).

    Returns
    -------
    SensorErrorParams

    Raises
    ------
    ValueError
        One line naming ``ctx``, the key path and the rule, e.g.
        ``imu.yaml: sensors.gyro.arw_deg_rt_h: must be >= 0, got -1``.

    Examples
    --------
    >>> p = sensor_params_from_dict({"gyro": {"arw_deg_rt_h": 0.002}}, "imu.yaml")
    >>> p.gyro.arw_deg_rt_h, p.accelerometer.bias_ug
    ((0.002, 0.002, 0.002), (0.0, 0.0, 0.0))
    """
    if doc is None:
        return SensorErrorParams()
    if not isinstance(doc, dict):
        raise ValueError(f"{ctx}: {path}: must be a mapping, got {type(doc).__name__} {doc!r}")
    for key in doc:
        if key not in ("gyro", "accelerometer"):
            raise ValueError(f"{ctx}: {path}.{key}: {unknown_key(str(key), ('accelerometer', 'gyro'))}")
    return SensorErrorParams(
        gyro=_section(doc.get("gyro"), GyroErrorParams, _GYRO_KEYS, ctx, f"{path}.gyro"),
        accelerometer=_section(doc.get("accelerometer"), AccelErrorParams, _ACCEL_KEYS, ctx,
                               f"{path}.accelerometer"))


def key_ranges() -> list:
    """Every bounded key of the ``sensors:`` section with its range, for the reference, tests and the fuzz.

    Returns
    -------
    list of (section, key, lower, upper, values)
        ``section`` is ``"gyro"`` or ``"accelerometer"``; ``values`` the numbers the key takes per entry (3 per
        axis, 6 misalignment angles, or 0 for one number for the triad, ``full_scale_deg_s``). The lower end of a
        signed key is ``-upper``. ``bias_instability_tau_s`` (a pair with its own rule) is not listed.
    """
    out = []
    for section, cls in (("gyro", GyroErrorParams), ("accelerometer", AccelErrorParams)):
        for name, kind, kw in cls._FIELDS:
            if kind == "axes":
                hi = kw.get("hi", kw.get("max_abs"))
                out.append((section, name, kw.get("lo", -hi), hi, 3))
            elif kind == "misalignment":
                out.append((section, name, -MAX_MISALIGNMENT_ARCSEC, MAX_MISALIGNMENT_ARCSEC, 6))
            elif kind == "number":
                out.append((section, name, kw["lo"], kw["hi"], 0))
    return out


def _param_docs(cls) -> dict:
    """First sentence of each parameter's description in the class docstring (numpydoc)."""
    import inspect
    import re

    doc = inspect.getdoc(cls) or ""
    body = doc.split("Parameters\n----------\n", 1)[-1].split("\n\n", 1)[0]
    out, name = {}, None
    for line in body.splitlines():
        m = re.match(r"^(\w+) : ", line)
        if m:
            name = m.group(1)
            out[name] = ""
        elif name is not None and line.startswith("    "):
            out[name] = (out[name] + " " + line.strip()).strip()
    return {k: v.split(". ")[0].rstrip(".") for k, v in out.items()}


def reference_rows(path: str = "sensors") -> list:
    """The ``sensors:`` keys as rows of the input reference (``sins-sim schema imu``): key, kind, unit, range,
    default and description, from the field specs the constructors check and the classes' docstrings."""
    unit_of = (("_deg_h_rt_h", "deg/h/sqrt(h)"), ("_deg_rt_h", "deg/sqrt(h)"), ("_ug_rt_hz", "ug/sqrt(Hz)"),
               ("_ug_rt_h", "ug/sqrt(h)"), ("_ug_g2", "ug/g^2"), ("_deg_h", "deg/h"), ("_deg_s", "deg/s"),
               ("_ppm", "ppm"), ("_arcsec", "arcsec"), ("_ug", "ug"), ("_s", "s"))
    rows = [{"key": path, "kind": "mapping", "unit": "", "range": "gyro, accelerometer", "default": "(none: ideal)",
             "doc": "sensor errors beyond the dither physics (sins_sim.models.sensor_errors); per-axis keys take one "
                    "number for x, y, z or a list of three"}]
    for section, cls in (("gyro", GyroErrorParams), ("accelerometer", AccelErrorParams)):
        docs = _param_docs(cls)
        defaults = {f.name: f.default for f in fields(cls)}
        rows.append({"key": f"{path}.{section}", "kind": "mapping", "unit": "", "range": "", "default": "(none)",
                     "doc": ""})
        for name, kind, kw in cls._FIELDS:
            unit = next((label for suffix, label in unit_of if name.endswith(suffix)), "")
            why = kw.get("why", "")
            if kind == "axes":
                rng = (f"[{kw['lo']:g}, {kw['hi']:g}]" if "hi" in kw else f"|x| <= {kw['max_abs']:g}") + ", per axis"
                knd = "number or 3 numbers"
            elif kind == "number":
                rng, knd = f"[{kw['lo']:g}, {kw['hi']:g}]", "number for all axes"
            elif kind == "tau":
                rng = f"0 < lower <= upper <= {MAX_TAU_S:g}, at most {MAX_PLATEAU_DECADES:g} decades"
                knd = "2 numbers"
            else:
                rng = f"|x| <= {MAX_MISALIGNMENT_ARCSEC:g}; order {', '.join(MISALIGNMENT_ORDER)}"
                knd = "6 numbers or 3x3"
                why = PHYSICAL_RANGES[f"{section}.{name}"][1]
            d = defaults[name]
            default = f"{d:g}" if isinstance(d, float) else ", ".join(f"{x:g}" for x in d)
            doc = docs.get(name, "")
            if why and kind == "number":
                doc = f"{doc}; range: {why}"
            elif why:
                doc = f"{doc}; range: {RANGE_SOURCE}; the bound is {why}"
            rows.append({"key": f"{path}.{section}.{name}", "kind": knd, "unit": unit, "range": rng,
                         "default": default, "doc": doc})
    return rows
