"""Accelerometer scale factors, misalignments and biases, and the gyros' g-sensitivity, from a multi-position log.

Arrays in, numbers out (SI inside; ppm, arcsec, ug and deg/h/g at :meth:`MultiPositionFit.to_dict`).

A multi-position (tumble) test holds the unit still in several orientations, each with one body axis up or down
(the faces of a cube or a dividing head; Titterton and Weston 2004, sec. 8.5, the multi-position static test;
Groves 2013, sec. 4.4.6, the error model). In a still position ``k`` with the unit vector ``u_k`` up (body axes) the
true specific force is ``f_k = g u_k`` and the true rate the Earth's, ``C_bn w_ie``. The error models are

    accelerometer:  m_f = b_a + (I + E_a) f + n        (E_a: scale factors S_i on the diagonal, misalignments off it)
    gyro:           m_w = b_g + w + G f + n            (G: the g-sensitivity, rad/s per m/s^2)

**Accelerometers.** Each sensor row ``i`` is fitted by weighted least squares over the positions,
``m_f,ik - f_ik = b_i + sum_j E_ij f_jk``: four unknowns per row, each position one equation with the sigma of its
mean. A column ``j`` of ``E`` is excited only where axis ``j`` was vertical in at least one position, and told from
the bias only where it was up in one and down in another (the classic six-position pairs: ``b_i = (m_up + m_down)/2``,
``S_i = (m_up - m_down) / (2 g) - 1``); an entry not excited is "not excited", never a number. The true ``f_k`` is
the fixture's nominal face (the axis nearest the measured force): the fixture's own tilt and face errors alias into
``E``'s off-diagonal entries (the misalignments are relative to the fixture's faces), and ``g`` is normal gravity at
the site: a gravity anomaly ``dg`` enters the scale factors as ``dg / g`` (10 ug: 10 ppm), outside the sigma.

**Gyros.** With axis ``i`` vertical the Earth's rate along it is its vertical part alone, ``+-Omega sin(lat)``
(known from the latitude; the horizontal part lies across the axis), and the force along it ``+-g``: so an up and a
down position of axis ``i`` give ``b_g,i = (m_up + m_down) / 2`` and
``G_ii = ((m_up - m_down) / 2 - Omega sin(lat)) / g``. The cross terms ``G_ij`` need the horizontal Earth rate along a
horizontal gyro, which depends on each position's heading, unknown here: "not observable".

Sigmas: each position's mean has the standard error of its one-second block means (``std / sqrt(K)``, white noise
and anything correlated over less than a second; Flyvbjerg and Petersen 1989), propagated through the least squares
(the covariance ``(A^T W A)^-1``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sins_sim.earth import EARTH_RATE_RAD_S, gravity_down
from sins_sim.units import ARCSEC, DEG_PER_H, MICRO_G

__all__ = ["FACE_COS", "MIN_POSITION_S", "MultiPositionFit", "Position", "find_positions", "fit_multiposition",
           "position_means"]

#: The shortest still position fitted (s): ten one-second blocks for its standard error.
MIN_POSITION_S = 10.0
#: A position counts as a face when the measured force lies within 25 deg of a body axis (cos 25 deg): a dividing
#: head's intermediate angles and a unit on its edge are refused, not guessed.
FACE_COS = math.cos(math.radians(25.0))
#: A block belongs to the still run of its neighbours while its mean force stays within this of the run's median
#: (m/s^2: 5 mg, as the log's own rest check) and its mean rate within this many Earth rates (5: 75 deg/h).
_FORCE_TOL_M_S2 = 0.05
_RATE_TOL_EARTH = 5.0


@dataclass(frozen=True)
class Position:
    """One still position: its window (s), the body axis up (0..2) and its sign, and its means with their standard
    errors (SI: rad/s and m/s^2, body axes)."""

    start_s: float
    end_s: float
    axis: int
    sign: int
    rate: np.ndarray
    rate_se: np.ndarray
    force: np.ndarray
    force_se: np.ndarray

    @property
    def label(self) -> str:
        return ("+" if self.sign > 0 else "-") + "xyz"[self.axis]


def position_means(t_s, dtheta, dv, start_s: float, end_s: float) -> Position:
    """A still window's means and standard errors (one-second block means) and its face.

    Raises
    ------
    ValueError
        A window shorter than :data:`MIN_POSITION_S` or whose force is not near a body axis (:data:`FACE_COS`).
    """
    t = np.asarray(t_s, dtype=np.float64)
    dt = float(t[1] - t[0])
    sel = np.flatnonzero((t > start_s) & (t <= end_s))
    per = max(1, int(round(1.0 / dt)))
    k = sel.size // per
    if k * per * dt < MIN_POSITION_S - 1e-9:
        raise ValueError(f"positions: the window {start_s:g} to {end_s:g} s holds {sel.size * dt:.3g} s, fewer than "
                         f"{MIN_POSITION_S:g} s")
    idx = sel[:k * per]
    w = np.asarray(dtheta, dtype=np.float64)[idx].reshape(k, per, 3).sum(axis=1) / (per * dt)
    f = np.asarray(dv, dtype=np.float64)[idx].reshape(k, per, 3).sum(axis=1) / (per * dt)
    fm = f.mean(axis=0)
    axis = int(np.argmax(np.abs(fm)))
    cos = abs(fm[axis]) / float(np.linalg.norm(fm))
    if cos < FACE_COS:
        raise ValueError(f"positions: the window {start_s:g} to {end_s:g} s is not a face position (its force lies "
                         f"{math.degrees(math.acos(min(cos, 1.0))):.3g} deg from the nearest body axis, more than "
                         f"{math.degrees(math.acos(FACE_COS)):.3g} deg)")
    return Position(float(t[idx[0]] - dt), float(t[idx[-1]]), axis, 1 if fm[axis] > 0 else -1, w.mean(axis=0),
                    w.std(axis=0, ddof=1) / math.sqrt(k), fm, f.std(axis=0, ddof=1) / math.sqrt(k))


def find_positions(t_s, dtheta, dv) -> list:
    """The still windows of a log (module docstring): runs of one-second blocks between changes of the mean force
    (more than 0.05 m/s^2) or rate (5 Earth rates), each run less its first and last block (which may hold the end of
    a turn), kept where at least :data:`MIN_POSITION_S` long; returns ``[(start_s, end_s)]``."""
    t = np.asarray(t_s, dtype=np.float64)
    dt = float(t[1] - t[0])
    per = max(1, int(round(1.0 / dt)))
    nb = t.size // per
    if nb < 3:
        return []
    w = np.asarray(dtheta)[:nb * per].reshape(nb, per, 3).sum(axis=1) / (per * dt)
    f = np.asarray(dv)[:nb * per].reshape(nb, per, 3).sum(axis=1) / (per * dt)
    jump = ((np.linalg.norm(np.diff(f, axis=0), axis=1) >= _FORCE_TOL_M_S2)
            | (np.linalg.norm(np.diff(w, axis=0), axis=1) >= _RATE_TOL_EARTH * EARTH_RATE_RAD_S))
    edges = np.concatenate([[0], np.flatnonzero(jump) + 1, [nb]])
    out = []
    for a, b in zip(edges[:-1], edges[1:]):
        a, b = a + 1, b - 1                                     # less the blocks at each end
        if b - a < MIN_POSITION_S / (per * dt) - 1e-9:
            continue
        fm, wm = np.median(f[a:b], axis=0), np.median(w[a:b], axis=0)
        still = ((np.linalg.norm(f[a:b] - fm, axis=1) < _FORCE_TOL_M_S2)
                 & (np.linalg.norm(w[a:b] - wm, axis=1) < _RATE_TOL_EARTH * EARTH_RATE_RAD_S))
        if still.all():
            out.append((float(t[0] - dt + a * per * dt), float(t[0] - dt + b * per * dt)))
    return out


@dataclass(frozen=True)
class MultiPositionFit:
    """What a multi-position log gives (module docstring).

    Attributes
    ----------
    accel_bias, accel_bias_sigma : ndarray (3,)
        m/s^2; NaN where the row is not determined.
    accel_e, accel_e_sigma : ndarray (3, 3)
        ``E_a``; NaN where not excited.
    gyro_bias, gyro_bias_sigma : ndarray (3,)
        rad/s; NaN where axis ``i`` was not both up and down.
    gyro_g, gyro_g_sigma : ndarray (3,)
        The diagonal ``G_ii`` (rad/s per m/s^2); NaN as the gyro bias.
    positions : tuple of Position
    g : float
        The normal gravity used (m/s^2).
    """

    accel_bias: np.ndarray
    accel_bias_sigma: np.ndarray
    accel_e: np.ndarray
    accel_e_sigma: np.ndarray
    gyro_bias: np.ndarray
    gyro_bias_sigma: np.ndarray
    gyro_g: np.ndarray
    gyro_g_sigma: np.ndarray
    positions: tuple
    g: float

    def to_dict(self) -> dict:
        """Edge units: accelerometer bias (ug), scale factors (ppm), misalignments (arcsec, ``xy``: sensor x towards
        body y); gyro bias (deg/h) and g-sensitivity (deg/h/g); each ``{value, sigma}`` or a status."""
        def entry(val, sig, scale, status="not excited"):
            return ({"status": status} if not math.isfinite(val) else
                    {"value": float(val * scale), "sigma": float(sig * scale)})

        out = {"positions": [{"start_s": p.start_s, "end_s": p.end_s, "up": p.label} for p in self.positions],
               "gravity_m_s2": self.g, "accelerometer": {"bias_ug": {}, "scale_factor_ppm": {},
                                                         "misalignment_arcsec": {}},
               "gyro": {"bias_deg_h": {}, "g_sensitivity_deg_h_per_g": {}}}
        acc, gy = out["accelerometer"], out["gyro"]
        per_g = 1.0 / DEG_PER_H * self.g
        for i, si in enumerate("xyz"):
            acc["bias_ug"][si] = entry(self.accel_bias[i], self.accel_bias_sigma[i], 1.0 / MICRO_G,
                                       "not determined (no position with this axis vertical)")
            gy["bias_deg_h"][si] = entry(self.gyro_bias[i], self.gyro_bias_sigma[i], 1.0 / DEG_PER_H,
                                         "not determined (needs this axis both up and down)")
            for j, sj in enumerate("xyz"):
                if i == j:
                    acc["scale_factor_ppm"][si] = entry(self.accel_e[i, i], self.accel_e_sigma[i, i], 1e6)
                    gy["g_sensitivity_deg_h_per_g"][si + sj] = entry(
                        self.gyro_g[i], self.gyro_g_sigma[i], per_g, "not determined (needs this axis both up and down)")
                else:
                    acc["misalignment_arcsec"][si + sj] = entry(self.accel_e[i, j], self.accel_e_sigma[i, j],
                                                                1.0 / ARCSEC)
                    gy["g_sensitivity_deg_h_per_g"][si + sj] = {
                        "status": "not observable (the Earth's horizontal rate along a horizontal gyro depends on "
                                  "each position's heading, unknown here)"}
        return out


def fit_multiposition(t_s, dtheta, dv, windows, lat_rad: float, h_m: float = 0.0) -> MultiPositionFit:
    """Fit the terms of a multi-position log (module docstring).

    Parameters
    ----------
    t_s, dtheta, dv : array_like
        End times (s), angle (rad) and velocity (m/s) increments (N, 3), evenly spaced.
    windows : sequence of (float, float)
        The still positions' ``(start_s, end_s)`` (:func:`find_positions`, or given).
    lat_rad, h_m : float
        The site (normal gravity and the Earth rate's vertical part).

    Raises
    ------
    ValueError
        Fewer than two positions, a window too short or off a face (:func:`position_means`).
    """
    pos = [position_means(t_s, dtheta, dv, a, b) for a, b in windows]
    if len(pos) < 2:
        raise ValueError(f"positions: needs at least two still positions, got {len(pos)}")
    g = float(gravity_down(lat_rad, h_m))
    f_true = np.array([p.sign * g * np.eye(3)[p.axis] for p in pos])
    m_f = np.array([p.force for p in pos])
    se_f = np.array([p.force_se for p in pos])
    bias_a, bias_a_sig = np.full(3, np.nan), np.full(3, np.nan)
    e_a, e_a_sig = np.full((3, 3), np.nan), np.full((3, 3), np.nan)
    vertical = {(p.axis, p.sign) for p in pos}
    # a column j is excited (told from the bias) only where axis j was both up and down
    cols = [j for j in range(3) if (j, 1) in vertical and (j, -1) in vertical]
    for i in range(3):
        a_mat = np.column_stack([np.ones(len(pos))] + [f_true[:, j] for j in cols])
        if np.linalg.matrix_rank(a_mat) < a_mat.shape[1]:
            continue
        wts = 1.0 / np.maximum(se_f[:, i], 1e-12) ** 2
        cov = np.linalg.inv(a_mat.T @ (a_mat * wts[:, None]))
        x = cov @ (a_mat.T @ (wts * (m_f[:, i] - f_true[:, i])))
        bias_a[i], bias_a_sig[i] = x[0], math.sqrt(cov[0, 0])
        for c, j in enumerate(cols, start=1):
            e_a[i, j], e_a_sig[i, j] = x[c], math.sqrt(cov[c, c])
    # gyros: an up and a down position of axis i (the first of each)
    bias_g, bias_g_sig = np.full(3, np.nan), np.full(3, np.nan)
    g_sens, g_sens_sig = np.full(3, np.nan), np.full(3, np.nan)
    omega_up = EARTH_RATE_RAD_S * math.sin(lat_rad)
    for i in range(3):
        up = next((p for p in pos if p.axis == i and p.sign > 0), None)
        down = next((p for p in pos if p.axis == i and p.sign < 0), None)
        if up is None or down is None:
            continue
        bias_g[i] = 0.5 * (up.rate[i] + down.rate[i])
        half = 0.5 * math.hypot(up.rate_se[i], down.rate_se[i])
        bias_g_sig[i] = half
        # m_up = b + Omega sin(lat) + G g, m_down = b - Omega sin(lat) - G g (the up axis sees the Earth's rate's
        # vertical part +Omega sin(lat): NED down component -Omega sin(lat))
        g_sens[i] = (0.5 * (up.rate[i] - down.rate[i]) - omega_up) / g
        g_sens_sig[i] = half / g
    return MultiPositionFit(bias_a, bias_a_sig, e_a, e_a_sig, bias_g, bias_g_sig, g_sens, g_sens_sig, tuple(pos), g)
