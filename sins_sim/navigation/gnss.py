"""Simulated GNSS position and velocity fixes from a navigation truth (issue 37).

A receiver at the antenna, ``lever_arm_b_m`` from the IMU in body axes, reports fixes at ``rate_hz``. Each
fix describes the truth at its time of validity ``t_valid`` and reaches the navigation computer
``latency_s`` later, at ``t_deliver = t_valid + latency_s``; the record carries both times, so the filter
can apply it against its own solution at ``t_valid`` (:func:`sins_sim.navigation.aided.navigate_aided`).
No fix is valid inside an outage window ``[start, end)`` (the signal is lost at the antenna, so the
windows are on the time of validity).

Errors of a fix, per NED axis (Groves 2013, sec. 9.4 and 14.3.1 for the loosely coupled model)::

    position:  dr = e_k + w_k,   w_k ~ N(0, sigma_p^2)
               e_k = exp(-dt/tau) e_(k-1) + sqrt(1 - exp(-2 dt/tau)) sigma_gm u_k,   e_0 ~ N(0, sigma_gm^2)
    velocity:  dv = w'_k,        w'_k ~ N(0, sigma_v^2)

``e`` is a first-order Gauss-Markov process sampled exactly at the fix interval ``dt`` (the discrete
recursion of ``de/dt = -e/tau + w``, stationary from the start; Gelb 1974, table 3.1-1; Brown & Hwang
2012, sec. 2.9): the slowly varying error of the atmosphere and multipath. It runs through the outages,
so a fix after an outage carries the correlation the gap leaves (``exp(-gap/tau)``).

Lever arm (Groves 2013, eq. 14.110 and 14.114): the antenna's position is ``r + C_nb l`` and its velocity
with respect to the Earth ``v + C_nb (omega_ib^b x l) - omega_ie^n x (C_nb l)``.

.. autosummary::

   GnssSettings
   GnssFixes
   simulate_gnss
   gnss_errors
   fixes_from_truth
   concat_fixes

References
----------
.. [1] P. D. Groves, *Principles of GNSS, Inertial, and Multisensor Integrated Navigation Systems*, 2nd
   ed., Artech House, 2013, ch. 9 (GNSS errors), ch. 14 (loosely coupled integration, lever arms).
.. [2] A. Gelb (ed.), *Applied Optimal Estimation*, MIT Press, 1974, sec. 3.1.
.. [3] R. G. Brown, P. Y. C. Hwang, *Introduction to Random Signals and Applied Kalman Filtering*, 4th ed.,
   Wiley, 2012, sec. 2.9 (Gauss-Markov processes).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from numbers import Integral

import numpy as np

from sins_sim import _validate as v
from sins_sim import earth
from sins_sim.navigation.attitude import dcm_from_quat

__all__ = ["GnssSettings", "GnssFixes", "simulate_gnss", "gnss_errors", "fixes_from_truth", "concat_fixes"]

#: Relative tolerance of a fix's time of validity on the truth's time grid.
_TIME_RTOL = 1e-9


def _sigma3(owner, name, value, positive):
    try:
        arr = np.broadcast_to(np.asarray(value, dtype=np.float64), (3,))
    except (TypeError, ValueError):
        arr = None
    rule = "> 0" if positive else ">= 0"
    if arr is None or not np.all(np.isfinite(arr)) or np.any(arr <= 0.0 if positive else arr < 0.0):
        raise ValueError(f"{owner}.{name}: must be one value or 3 (north, east, down), each finite and {rule}, "
                         f"got {value!r}")
    return tuple(float(x) for x in arr)


@dataclass(frozen=True)
class GnssSettings:
    """A GNSS receiver's fixes: rate, noise, latency, lever arm and outages (SI units in every name).

    Parameters
    ----------
    rate_hz : float
        Fix rate (Hz), > 0; the times of validity are the whole multiples of ``1 / rate_hz``.
    position_sigma_m : float or sequence of 3
        White position noise 1-sigma north, east, down (m), > 0.
    velocity_sigma_m_s : float or sequence of 3
        White velocity noise 1-sigma NED (m/s), > 0.
    markov_sigma_m : float or sequence of 3
        Stationary 1-sigma of the Gauss-Markov position error NED (m), >= 0 (0: none).
    markov_tau_s : float
        Its correlation time (s), > 0.
    latency_s : float
        Delay from a fix's time of validity to its delivery (s), >= 0.
    lever_arm_b_m : sequence of 3
        Antenna position from the IMU, body axes (m).
    outages_s : sequence of (start, end)
        Windows ``[start, end)`` of the time of validity with no fix (s), ``start < end``.
    """

    rate_hz: float = 1.0
    position_sigma_m: tuple = (1.0, 1.0, 2.0)
    velocity_sigma_m_s: tuple = (0.05, 0.05, 0.1)
    markov_sigma_m: tuple = (0.0, 0.0, 0.0)
    markov_tau_s: float = 300.0
    latency_s: float = 0.0
    lever_arm_b_m: tuple = (0.0, 0.0, 0.0)
    outages_s: tuple = ()

    def __post_init__(self):
        o = "GnssSettings"
        object.__setattr__(self, "rate_hz", v.positive(o, "rate_hz", self.rate_hz))
        object.__setattr__(self, "position_sigma_m", _sigma3(o, "position_sigma_m", self.position_sigma_m, True))
        object.__setattr__(self, "velocity_sigma_m_s",
                           _sigma3(o, "velocity_sigma_m_s", self.velocity_sigma_m_s, True))
        object.__setattr__(self, "markov_sigma_m", _sigma3(o, "markov_sigma_m", self.markov_sigma_m, False))
        object.__setattr__(self, "markov_tau_s", v.positive(o, "markov_tau_s", self.markov_tau_s))
        object.__setattr__(self, "latency_s", v.non_negative(o, "latency_s", self.latency_s))
        lever = v.finite_array(o, "lever_arm_b_m", self.lever_arm_b_m, ndim=1)
        if lever.shape != (3,):
            raise ValueError(f"{o}.lever_arm_b_m: must have 3 values (body x, y, z), got shape {lever.shape}")
        object.__setattr__(self, "lever_arm_b_m", tuple(float(x) for x in lever))
        windows = []
        for i, w in enumerate(self.outages_s):
            pair = np.asarray(w, dtype=np.float64) if np.ndim(w) == 1 else np.zeros(0)
            if pair.shape != (2,) or not np.all(np.isfinite(pair)) or not pair[0] < pair[1]:
                raise ValueError(f"{o}.outages_s[{i}]: must be a (start, end) pair of finite times with "
                                 f"start < end (s), got {w!r}")
            windows.append((float(pair[0]), float(pair[1])))
        object.__setattr__(self, "outages_s", tuple(sorted(windows)))

    @property
    def interval_s(self) -> float:
        """Fix interval ``1 / rate_hz`` (s)."""
        return 1.0 / self.rate_hz

    def in_outage(self, t_s) -> np.ndarray:
        """Whether each time of validity lies in an outage window."""
        t = np.asarray(t_s, dtype=np.float64)
        out = np.zeros(t.shape, dtype=bool)
        for a, b in self.outages_s:
            out |= (t >= a) & (t < b)
        return out


@dataclass(frozen=True)
class GnssFixes:
    """GNSS fixes at the antenna, one row per fix, with the truth's errors they carry.

    Attributes
    ----------
    t_valid_s : ndarray, shape (K,)
        Time each fix describes (s).
    t_deliver_s : ndarray, shape (K,)
        Time it is delivered, ``t_valid_s + latency_s`` (s).
    lat_rad, lon_rad, h_m : ndarray, shape (K,)
        Measured antenna position.
    v_ned_m_s : ndarray, shape (K, 3)
        Measured antenna velocity (m/s).
    position_error_ned_m : ndarray, shape (K, 3)
        The error added to the true antenna position (white plus Gauss-Markov; m, NED).
    velocity_error_ned_m_s : ndarray, shape (K, 3)
        The error added to the true antenna velocity (m/s).
    position_sigma_m, velocity_sigma_m_s : ndarray, shape (3,)
        The white noise 1-sigmas (the filter's ``R``).
    lever_arm_b_m : ndarray, shape (3,)
        The antenna's lever arm (body axes, m).
    """

    t_valid_s: np.ndarray
    t_deliver_s: np.ndarray
    lat_rad: np.ndarray
    lon_rad: np.ndarray
    h_m: np.ndarray
    v_ned_m_s: np.ndarray
    position_error_ned_m: np.ndarray
    velocity_error_ned_m_s: np.ndarray
    position_sigma_m: np.ndarray
    velocity_sigma_m_s: np.ndarray
    lever_arm_b_m: np.ndarray

    def __len__(self) -> int:
        return int(self.t_valid_s.shape[0])

    def to_pandas(self):
        """The fixes as a DataFrame indexed by ``t_valid_s`` (units in the column names)."""
        import pandas as pd

        cols = {"t_deliver_s": self.t_deliver_s, "lat_rad": self.lat_rad, "lon_rad": self.lon_rad, "h_m": self.h_m}
        for i, ax in enumerate("ned"):
            cols[f"v_{ax}_m_s"] = self.v_ned_m_s[:, i]
        for i, ax in enumerate("ned"):
            cols[f"position_error_{ax}_m"] = self.position_error_ned_m[:, i]
        for i, ax in enumerate("ned"):
            cols[f"velocity_error_{ax}_m_s"] = self.velocity_error_ned_m_s[:, i]
        return pd.DataFrame(cols, index=pd.Index(self.t_valid_s, name="t_valid_s"))


def _rng(seed):
    if isinstance(seed, np.random.Generator):
        return seed
    if isinstance(seed, bool) or not isinstance(seed, Integral) or seed < 0:
        raise ValueError(f"seed: must be an integer >= 0 or a numpy Generator, got {seed!r}")
    return np.random.default_rng(int(seed))


def simulate_gnss(t_s, lat_rad, lon_rad, h_m, v_ned_m_s, settings: GnssSettings, seed, *, q_nb=None,
                  omega_ib_b_rad_s=None) -> GnssFixes:
    """GNSS fixes of a truth (module docstring): the antenna's position and velocity plus the error models.

    Parameters
    ----------
    t_s : array_like, shape (N,)
        The truth's times (s), increasing. Every time of validity ``k / rate_hz`` inside ``[t_s[0],
        t_s[-1]]`` (outside the outages) must be one of them.
    lat_rad, lon_rad, h_m : array_like, shape (N,)
        True IMU position (rad, rad, m up).
    v_ned_m_s : array_like, shape (N, 3)
        True IMU velocity NED (m/s).
    settings : GnssSettings
        The receiver.
    seed : int or numpy.random.Generator
        Seed of ``np.random.default_rng`` (or the generator): the same seed gives the same fixes.
    q_nb : array_like, shape (N, 4), optional
        True attitude body to NED; required with a lever arm.
    omega_ib_b_rad_s : array_like, shape (N, 3), optional
        True angular rate of the body w.r.t. inertial space, body axes (rad/s); required with a lever arm.

    Returns
    -------
    GnssFixes

    Raises
    ------
    ValueError
        For a bad argument (the message names it).
    """
    if not isinstance(settings, GnssSettings):
        raise ValueError(f"settings: must be a GnssSettings, got {type(settings).__name__}")
    rng = _rng(seed)
    t = v.finite_array("", "t_s", t_s, ndim=1)
    n = t.shape[0]
    if n < 1 or np.any(np.diff(t) <= 0.0):
        raise ValueError("t_s: must hold at least one time, strictly increasing")
    lat, lon, h = (v.finite_array("", name, a, ndim=1) for name, a in
                   (("lat_rad", lat_rad), ("lon_rad", lon_rad), ("h_m", h_m)))
    vel = v.finite_array("", "v_ned_m_s", v_ned_m_s, ndim=2)
    for name, arr, shape in (("lat_rad", lat, (n,)), ("lon_rad", lon, (n,)), ("h_m", h, (n,)),
                             ("v_ned_m_s", vel, (n, 3))):
        if arr.shape != shape:
            raise ValueError(f"{name}: must have shape {shape} (one per truth time), got {arr.shape}")
    lever = np.asarray(settings.lever_arm_b_m)
    has_lever = bool(np.any(lever != 0.0))
    if has_lever:
        for name, arr, m in (("q_nb", q_nb, 4), ("omega_ib_b_rad_s", omega_ib_b_rad_s, 3)):
            if arr is None or np.shape(arr) != (n, m):
                raise ValueError(f"{name}: required with a lever arm, shape ({n}, {m}), got "
                                 f"{None if arr is None else np.shape(arr)}")
    # times of validity: the fix grid inside the truth's span
    dt = settings.interval_s
    tol = _TIME_RTOL * max(1.0, abs(t[0]), abs(t[-1]))
    grid = np.arange(math.ceil((t[0] - tol) / dt), math.floor((t[-1] + tol) / dt) + 1) * dt
    keep = ~settings.in_outage(grid)
    idx = np.minimum(np.searchsorted(t, grid - tol), n - 1)
    off = np.abs(t[idx] - grid) > tol
    if np.any(off & keep):
        bad = grid[off & keep][0]
        raise ValueError(f"t_s: must contain every time of validity k / rate_hz of the fixes; {bad!r} s is missing")
    # errors on the whole grid (the Gauss-Markov process runs through the outages), exact recursion
    dr, dv = gnss_errors(settings, grid.shape[0], rng)
    i = idx[keep]
    return fixes_from_truth(grid[keep], lat[i], lon[i], h[i], vel[i], dr[keep], dv[keep], settings,
                            q_nb=None if not has_lever else np.asarray(q_nb, dtype=np.float64)[i],
                            omega_ib_b_rad_s=None if not has_lever else np.asarray(omega_ib_b_rad_s, np.float64)[i])


def gnss_errors(settings: GnssSettings, m: int, rng) -> tuple:
    """The errors of ``m`` consecutive fixes on the fix grid (outages included; module docstring).

    Parameters
    ----------
    settings : GnssSettings
        The receiver.
    m : int
        Grid points, >= 0.
    rng : int or numpy.random.Generator
        Seed or generator; the draws are, in this order, the Gauss-Markov driving noise, the white position
        noise and the white velocity noise, each ``(m, 3)``.

    Returns
    -------
    (ndarray, ndarray), shapes (m, 3)
        Position error NED (m; white plus Gauss-Markov) and velocity error NED (m/s).
    """
    rng = _rng(rng)
    dt = settings.interval_s
    sig_gm = np.asarray(settings.markov_sigma_m)
    a = math.exp(-dt / settings.markov_tau_s)
    b = math.sqrt(-math.expm1(-2.0 * dt / settings.markov_tau_s))
    u = rng.standard_normal((m, 3))
    gm = np.empty((m, 3))
    if m:
        gm[0] = sig_gm * u[0]
    for k in range(1, m):
        gm[k] = a * gm[k - 1] + b * sig_gm * u[k]
    dr = gm + rng.standard_normal((m, 3)) * np.asarray(settings.position_sigma_m)
    dv = rng.standard_normal((m, 3)) * np.asarray(settings.velocity_sigma_m_s)
    return dr, dv


def fixes_from_truth(t_valid_s, lat, lon, h, vel, dr, dv, settings: GnssSettings, *, q_nb=None,
                     omega_ib_b_rad_s=None) -> GnssFixes:
    """Fixes from the true IMU state at their times of validity plus the errors of :func:`gnss_errors`: the
    antenna's position and velocity (lever arm, Groves 2013, eq. 14.110 and 14.114) with the errors added.

    ``q_nb`` (K, 4) and ``omega_ib_b_rad_s`` (K, 3) are required with a lever arm; every other argument has one
    row per fix (K).
    """
    lever = np.asarray(settings.lever_arm_b_m)
    la, lo, hh = (np.asarray(x, dtype=np.float64) for x in (lat, lon, h))
    vv = np.array(vel, dtype=np.float64).reshape(-1, 3)
    tv = np.asarray(t_valid_s, dtype=np.float64)
    pos_ned = np.array(dr, dtype=np.float64).reshape(-1, 3)
    if np.any(lever != 0.0):
        c = dcm_from_quat(np.asarray(q_nb, dtype=np.float64).reshape(-1, 4))
        cl = c @ lever
        w = np.asarray(omega_ib_b_rad_s, dtype=np.float64).reshape(-1, 3)
        # Groves 2013, eq. 14.114: v_a = v + C (omega_ib x l) - omega_ie x (C l)
        vv += np.einsum("kij,kj->ki", c, np.cross(w, lever)) - np.cross(earth.earth_rate_ned(la), cl)
        pos_ned += cl
    r_n, r_e = earth.radii(la)
    return GnssFixes(
        t_valid_s=tv, t_deliver_s=tv + settings.latency_s,
        lat_rad=la + pos_ned[:, 0] / (r_n + hh),
        lon_rad=(lo + pos_ned[:, 1] / ((r_e + hh) * np.cos(la)) + math.pi) % (2.0 * math.pi) - math.pi,
        h_m=hh - pos_ned[:, 2], v_ned_m_s=vv + dv, position_error_ned_m=np.asarray(dr, dtype=np.float64).reshape(-1, 3),
        velocity_error_ned_m_s=np.asarray(dv, dtype=np.float64).reshape(-1, 3),
        position_sigma_m=np.asarray(settings.position_sigma_m),
        velocity_sigma_m_s=np.asarray(settings.velocity_sigma_m_s), lever_arm_b_m=lever.copy())


def concat_fixes(parts) -> GnssFixes:
    """Fixes of several :class:`GnssFixes` (same receiver) one after the other."""
    parts = list(parts)
    if not parts:
        raise ValueError("parts: must hold at least one GnssFixes")
    first = parts[0]
    cat = {f: np.concatenate([getattr(p, f) for p in parts]) for f in
           ("t_valid_s", "t_deliver_s", "lat_rad", "lon_rad", "h_m")}
    cat.update({f: np.concatenate([getattr(p, f) for p in parts]).reshape(-1, 3) for f in
                ("v_ned_m_s", "position_error_ned_m", "velocity_error_ned_m_s")})
    return GnssFixes(**cat, position_sigma_m=first.position_sigma_m, velocity_sigma_m_s=first.velocity_sigma_m_s,
                     lever_arm_b_m=first.lever_arm_b_m)
