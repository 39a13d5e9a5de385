"""The result every alignment method returns (``navigation.alignment``: coarse, inertial, kalman, truth).

One type for all methods, so that a mission, ``sins-sim navigate`` and a sweep read any alignment the same
way. Inside: SI and rad. :meth:`AlignmentResult.to_dict` is the edge: degrees, arcsec and deg/h appear
there only, with the unit in each key.

Attitude uncertainty convention: ``sigma_rad = (sigma_north, sigma_east, sigma_down)``, the 1-sigma of the
attitude error ``psi`` resolved in NED, with ``C_nb_est = (I + [psi x]) C_nb_true`` (the project's psi
convention); ``sigma_north`` and ``sigma_east`` are the tilts, ``sigma_down`` the heading.

.. autosummary::

   AlignmentResult
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from sins_sim.units import ARCSEC, DEG, DEG_PER_H, MICRO_G

__all__ = ["AlignmentResult", "ALIGNMENT_METHODS"]

#: The alignment methods, by the name ``navigation.alignment.method`` takes.
ALIGNMENT_METHODS = ("truth", "coarse", "inertial", "kalman")


def _euler_321(q) -> np.ndarray:
    """Roll, pitch, yaw (rad) of ``q_nb`` (3-2-1; Titterton & Weston 2004, sec. 3.6)."""
    q0, q1, q2, q3 = (float(x) for x in q)
    c11 = q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3
    c21 = 2.0 * (q1 * q2 + q0 * q3)
    c31 = 2.0 * (q1 * q3 - q0 * q2)
    c32 = 2.0 * (q2 * q3 + q0 * q1)
    c33 = q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3
    return np.array([math.atan2(c32, c33), -math.asin(min(1.0, max(-1.0, c31))), math.atan2(c21, c11)])


@dataclass(frozen=True)
class AlignmentResult:
    """What an alignment found, how sure it is, and how long it took.

    Parameters
    ----------
    method : str
        One of :data:`ALIGNMENT_METHODS`.
    q_nb : array_like, shape (4,)
        The attitude found at the end of the alignment window, body to NED (Hamilton, scalar first).
    sigma_rad : array_like, shape (3,)
        1-sigma of the attitude error about north, east and down (rad; module docstring): from the
        filter's covariance (``kalman``) or from the observability bounds and the data's own scatter
        (``coarse``, ``inertial``); zeros for ``truth``.
    duration_s : float
        The time the alignment used (s).
    convergence : dict of str -> ndarray, optional
        The estimate's history: ``t_s`` and ``roll_rad``, ``pitch_rad``, ``heading_rad`` (each the
        estimate from the data up to ``t_s``), and for a filter ``sigma_heading_rad``.
    settling_rad : float, optional
        The convergence figure: how far the heading moved over the last fifth of the window (rad). Small
        against ``sigma_rad[2]`` means the window was long enough; NaN where no history was kept.
    gyro_bias_rad_s, gyro_bias_sigma_rad_s, accel_bias_m_s2, accel_bias_sigma_m_s2 : array_like (3,), optional
        Bias estimates (body axes) and their 1-sigma, where the method estimates them (``kalman``).
    observable : dict of str -> bool, optional
        Per estimated quantity (e.g. ``gyro_bias_x``), whether this window makes it observable; an
        unobservable quantity is reported as such, never as a number.
    notes : tuple of str
        What the user should know (e.g. the base moved more than the method tolerates).
    """

    method: str
    q_nb: np.ndarray
    sigma_rad: np.ndarray
    duration_s: float
    convergence: dict = field(default_factory=dict)
    settling_rad: float = math.nan
    gyro_bias_rad_s: np.ndarray | None = None
    gyro_bias_sigma_rad_s: np.ndarray | None = None
    accel_bias_m_s2: np.ndarray | None = None
    accel_bias_sigma_m_s2: np.ndarray | None = None
    observable: dict = field(default_factory=dict)
    notes: tuple = ()

    def __post_init__(self):
        if self.method not in ALIGNMENT_METHODS:
            raise ValueError(f"method: must be one of {', '.join(ALIGNMENT_METHODS)}, got {self.method!r}")
        q = np.asarray(self.q_nb, dtype=np.float64).reshape(-1)
        if q.size != 4 or not np.all(np.isfinite(q)) or abs(float(q @ q) - 1.0) > 1e-6:
            raise ValueError(f"q_nb: must be a finite unit quaternion of 4 components, got {self.q_nb!r}")
        s = np.asarray(self.sigma_rad, dtype=np.float64).reshape(-1)
        if s.size != 3 or not np.all(s >= 0.0):
            raise ValueError(f"sigma_rad: must be 3 values >= 0 (north, east, down), got {self.sigma_rad!r}")
        object.__setattr__(self, "q_nb", q / math.sqrt(float(q @ q)))
        object.__setattr__(self, "sigma_rad", s)
        for name in ("gyro_bias_rad_s", "gyro_bias_sigma_rad_s", "accel_bias_m_s2", "accel_bias_sigma_m_s2"):
            val = getattr(self, name)
            if val is not None:
                arr = np.asarray(val, dtype=np.float64).reshape(-1)
                if arr.size != 3:
                    raise ValueError(f"{name}: must have 3 components (body x, y, z), got {val!r}")
                object.__setattr__(self, name, arr)
        object.__setattr__(self, "convergence", {k: np.asarray(x) for k, x in self.convergence.items()})
        object.__setattr__(self, "notes", tuple(self.notes))

    @property
    def euler_rad(self) -> np.ndarray:
        """Roll, pitch, heading (rad, 3-2-1) of :attr:`q_nb`."""
        return _euler_321(self.q_nb)

    def to_dict(self) -> dict:
        """JSON-ready summary with the units in the keys (deg for angles, arcsec for the tilt sigmas,
        deg/h and ug for the biases); unobservable biases are reported as ``"not observable"``."""
        roll, pitch, yaw = self.euler_rad
        out = {"method": self.method, "duration_s": float(self.duration_s),
               "roll_deg": float(roll / DEG), "pitch_deg": float(pitch / DEG), "heading_deg": float((yaw / DEG) % 360.0),
               "sigma_tilt_north_arcsec": float(self.sigma_rad[0] / ARCSEC),
               "sigma_tilt_east_arcsec": float(self.sigma_rad[1] / ARCSEC),
               "sigma_heading_deg": float(self.sigma_rad[2] / DEG),
               "settling_heading_deg": (None if math.isnan(self.settling_rad) else self.settling_rad / DEG)}
        g_unit, a_unit = DEG_PER_H, MICRO_G
        for key, val, sig, unit, label in (("gyro_bias", self.gyro_bias_rad_s, self.gyro_bias_sigma_rad_s, g_unit,
                                            "deg_h"),
                                           ("accel_bias", self.accel_bias_m_s2, self.accel_bias_sigma_m_s2, a_unit,
                                            "ug")):
            if val is None:
                continue
            for i, ax in enumerate("xyz"):
                name = f"{key}_{ax}"
                if self.observable.get(name, True):
                    out[f"{name}_{label}"] = float(val[i] / unit)
                    if sig is not None:
                        out[f"{name}_sigma_{label}"] = float(sig[i] / unit)
                else:
                    out[f"{name}_{label}"] = "not observable"
        if self.notes:
            out["notes"] = list(self.notes)
        return out

    def to_pandas(self):
        """The convergence history as a DataFrame indexed by ``t_s`` (empty where none was kept)."""
        import pandas as pd

        hist = dict(self.convergence)
        t = hist.pop("t_s", np.empty(0))
        return pd.DataFrame(hist, index=pd.Index(t, name="t_s"))
