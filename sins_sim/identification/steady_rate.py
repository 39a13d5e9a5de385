"""A steady rate across the axes of a still recording without ``meta.site``: the Earth's, a gyro bias, or unknown.

On a still bench every gyro reads the Earth's rate projected on its axis (``sins_sim.simulation.site``). A
recording that does not say where the bench stands leaves that rate to the bias-drift nuisance of the fits
(``DiagnoseSettings.bias_drift``: ``b t + c t^2`` profiled out of each axis' residual), whose ``b`` is the
steady rate of the axis. :func:`steady_rate` reads those rates and their one-sigma errors, and says what
the vector is:

- **detected** when ``chi2 = sum_i (b_i / sigma_i)^2`` exceeds the ``1 - alpha`` quantile of chi-square with
  ``A`` degrees of freedom (``alpha`` the diagnosis' ``gap_alpha``);
- ``earth_rate`` when the three axes ``x, y, z`` are recorded and the vector's magnitude lies within
  :data:`MATCH_SIGMAS` of its sigma of the Earth's rate ``Omega = 15.04 deg/h`` (the magnitude does not
  depend on the latitude or the orientation): the finding asks for the site and gives the Earth's axis
  ``u = b / |b|`` in the unit's axes, and, for a unit standing level (pitch = roll = 0), the latitude
  ``asin(-u_z)`` and heading ``atan2(-u_y, u_x)`` (from ``u = (cos lat cos psi, -cos lat sin psi, -sin lat)``,
  the gyrocompassing relation, Titterton & Weston, "Strapdown Inertial Navigation Technology", 2nd ed., 2004,
  ch. 10);
- ``gyro_bias`` when every ``|b_i| <= MAX_PLAUSIBLE_BIAS_DEG_H``;
- ``unknown`` otherwise.

On a **rate table without ``meta.site``** (:func:`table_scale_as_earth`) there is no bias nuisance, and the
Earth's rate along the table axis ``u``, ``Omega_u``, adds to each gyro ``i`` the steady rate ``Omega_u t_i``
where ``t = C_nb0^T u`` also maps the table's angle onto the axes (``sins_angle_i = theta t_i``): a readout
scale-factor error ``e_i = Omega_u / theta'`` gives the same ramp ``e_i theta' t_i t``. A ``scale_factor`` the
verdict names there is a steady rate ``r_i = e_i theta'_i`` (``theta'_i`` the table's mean rate on axis ``i``);
when ``|r|`` is at most the Earth's rate plus :data:`MATCH_SIGMAS` of its sigma, the recording cannot tell
the two apart (a ppm scale error on a table turning at 10 deg/s is a fraction of a deg/h): ``earth_rate``
joins the verdict's ``alternatives`` and ``steady_rate`` asks for the site.

Sigmas: ``b_i``'s from the linear least squares of the nuisance on the used samples,
``var(b) = s^2 [(X'X)^-1]_bb L`` with ``s^2`` the residual's mean square and ``L`` its integrated
correlation length (the inflation the refit uses, ``refit._correlation_length``); those of ``|b|``, ``u``,
latitude and heading by first-order propagation (the axes' errors independent).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import stats

from sins_sim.earth import EARTH_RATE_RAD_S
from sins_sim.identification.refit import _correlation_length
from sins_sim.units import DEG, DEG_PER_H

__all__ = ["MATCH_SIGMAS", "MAX_PLAUSIBLE_BIAS_DEG_H", "steady_rate", "table_scale_as_earth"]

#: The magnitude matches the Earth's rate when within this many of its sigmas (a two-sided 99.7 % band).
MATCH_SIGMAS = 3.0
#: Largest steady gyro bias (deg/h) taken as plausible: the bias of small tactical-grade dithered RLGs and the
#: top of the blind evaluation's ``bias_drift`` class (``sins_sim.identification.blind_hard``: 0.5-10 deg/h); a
#: navigation-grade RLG's bias is about 0.01 deg/h.
MAX_PLAUSIBLE_BIAS_DEG_H = 10.0


def _rate_sigma(residual: np.ndarray, used: np.ndarray, fs_hz: float, offset: bool) -> float:
    """One-sigma error of the steady rate ``b`` of the nuisance ``[1,] t, t^2`` fitted on ``used`` (rad/s)."""
    n = residual.size
    t = np.arange(n) / fs_hz
    cols = ([np.ones(n)] if offset else []) + [t, t * t]
    x = np.column_stack(cols)[used]
    r = residual[used]
    r = r[np.isfinite(r)]
    if r.size <= x.shape[1]:
        return math.inf
    s2 = float(np.mean(r * r))
    cov = np.linalg.inv(x.T @ x)
    return math.sqrt(s2 * cov[len(cols) - 2, len(cols) - 2] * _correlation_length(r))


def steady_rate(rec, fits: dict, used: np.ndarray, alpha: float) -> dict | None:
    """The steady rate vector the bias nuisance found, classified (module docstring); None when not detected.

    Parameters
    ----------
    rec : Recording
        A still recording without ``meta.site``.
    fits : dict axis -> AxisFit
        The baseline fits, with their ``drift`` nuisance.
    used : ndarray of bool
        The samples the fits used.
    alpha : float
        False-alarm level of the detection.

    Returns
    -------
    dict or None
        ``finding`` (``earth_rate``, ``gyro_bias`` or ``unknown``), ``rate_deg_h`` and ``sigma_deg_h`` per axis,
        ``magnitude_deg_h`` and its ``magnitude_sigma_deg_h``, ``chi2``, ``chi2_critical``, ``message``; for
        ``earth_rate`` also ``earth_axis`` and ``earth_axis_sigma`` (unit vector per axis) and ``if_level``
        (``latitude_deg``, ``heading_deg`` and their sigmas).
    """
    if rec.site is not None or any(fits[a].drift is None for a in rec.axes):
        return None
    offset = rec.initial_state == "unknown"
    b = np.array([fits[a].drift[0] for a in rec.axes])
    sd = np.array([_rate_sigma(fits[a].residual, used, rec.fs_hz, offset) for a in rec.axes])
    chi2 = float(np.sum((b / sd) ** 2))
    crit = float(stats.chi2.ppf(1.0 - alpha, len(b)))
    if not chi2 > crit:
        return None
    mag = float(np.linalg.norm(b))
    mag_sd = float(math.sqrt(np.sum((b * sd) ** 2)) / mag)
    out = {"rate_deg_h": {a: float(x / DEG_PER_H) for a, x in zip(rec.axes, b)},
           "sigma_deg_h": {a: float(x / DEG_PER_H) for a, x in zip(rec.axes, sd)},
           "magnitude_deg_h": mag / DEG_PER_H, "magnitude_sigma_deg_h": mag_sd / DEG_PER_H,
           "chi2": chi2, "chi2_critical": crit}
    rates = ", ".join(f"{a} {x / DEG_PER_H:+.4g} +- {s / DEG_PER_H:.2g}" for a, x, s in zip(rec.axes, b, sd))
    triad = tuple(rec.axes) == ("x", "y", "z")
    if triad and abs(mag - EARTH_RATE_RAD_S) <= MATCH_SIGMAS * mag_sd:
        u = b / mag
        # d u / d b = (I - u u^T) / |b|
        jac = (np.eye(3) - np.outer(u, u)) / mag
        u_sd = np.sqrt((jac ** 2) @ (sd ** 2))
        lat = math.asin(max(-1.0, min(1.0, -u[2])))
        head = math.atan2(-u[1], u[0]) % (2.0 * math.pi)
        # lat = asin(-u_z): d lat = -d u_z / cos lat; psi = atan2(-u_y, u_x): d psi = (u_y du_x - u_x du_y) / h^2;
        # through d u = jac d b, so that the correlation of u's components is kept
        h2 = max(u[0] ** 2 + u[1] ** 2, 1e-24)
        g_lat = np.array([0.0, 0.0, -1.0 / max(math.cos(lat), 1e-12)]) @ jac
        g_head = np.array([u[1] / h2, -u[0] / h2, 0.0]) @ jac
        lat_sd = float(math.sqrt(np.sum((g_lat * sd) ** 2)))
        head_sd = float(math.sqrt(np.sum((g_head * sd) ** 2)))
        out.update(finding="earth_rate",
                   earth_axis={a: float(x) for a, x in zip(rec.axes, u)},
                   earth_axis_sigma={a: float(x) for a, x in zip(rec.axes, u_sd)},
                   if_level={"latitude_deg": lat / DEG, "latitude_sigma_deg": lat_sd / DEG,
                             "heading_deg": head / DEG, "heading_sigma_deg": head_sd / DEG})
        out["message"] = (f"the Earth's rate: give the site and orientation (meta.site). A steady rate ({rates} deg/h) "
                          f"of magnitude {mag / DEG_PER_H:.4g} +- {mag_sd / DEG_PER_H:.2g} deg/h, the Earth's "
                          f"{EARTH_RATE_RAD_S / DEG_PER_H:.4g} deg/h; the Earth's axis in the unit's axes "
                          + ", ".join(f"{a} {x:+.4f} +- {s:.2g}" for a, x, s in zip(rec.axes, u, u_sd))
                          + f"; if the unit stands level: latitude {lat / DEG:.3f} +- {lat_sd / DEG:.2g} deg, heading "
                          f"{head / DEG:.2f} +- {head_sd / DEG:.2g} deg")
    elif float(np.max(np.abs(b))) <= MAX_PLAUSIBLE_BIAS_DEG_H * DEG_PER_H:
        out["finding"] = "gyro_bias"
        out["message"] = (f"a steady rate ({rates} deg/h) of magnitude {mag / DEG_PER_H:.4g} +- "
                          f"{mag_sd / DEG_PER_H:.2g} deg/h, not the Earth's {EARTH_RATE_RAD_S / DEG_PER_H:.4g} deg/h"
                          + ("" if triad else " (not all of x, y, z recorded)")
                          + f": a gyro bias (within the {MAX_PLAUSIBLE_BIAS_DEG_H:g} deg/h a unit may have)")
    else:
        out["finding"] = "unknown"
        out["message"] = (f"a steady rate ({rates} deg/h) of magnitude {mag / DEG_PER_H:.4g} +- "
                          f"{mag_sd / DEG_PER_H:.2g} deg/h: neither the Earth's {EARTH_RATE_RAD_S / DEG_PER_H:.4g} "
                          f"deg/h" + ("" if triad else " (not all of x, y, z recorded)")
                          + f" nor a plausible gyro bias (at most {MAX_PLAUSIBLE_BIAS_DEG_H:g} deg/h): unknown")
    return out


def table_scale_as_earth(rec, verdict: dict) -> dict:
    """The verdict (a copy) with the Earth's rate named beside a ``scale_factor`` it cannot be told from.

    Only for a recording with table motion and without ``meta.site`` whose verdict names ``scale_factor``
    (module docstring); otherwise ``verdict`` unchanged. Adds ``earth_rate`` to ``alternatives`` and
    ``steady_rate`` (``finding`` ``earth_rate``, the implied steady ``rate_deg_h`` per axis with
    ``sigma_deg_h``, ``magnitude_deg_h`` and ``message``).
    """
    if rec.site is not None or rec.sins_angle is None:
        return verdict
    sf = next((e for e in verdict.get("effects") or [] if e["effect"] == "scale_factor"), None)
    if sf is None:
        return verdict
    axes = [a for a in rec.axes if "error" in sf["params"].get(a, {})]
    if not axes:
        return verdict
    r, sd = [], []
    for a in axes:
        th = np.asarray(rec.sins_angle[:, rec.axis_index(a)], dtype=np.float64)
        rate = float(th[-1] - th[0]) / rec.duration_s
        r.append(sf["params"][a]["error"] * rate)
        sd.append(abs(sf["uncertainty"].get(a, {}).get("error", 0.0) * rate))
    r, sd = np.array(r), np.array(sd)
    mag = float(np.linalg.norm(r))
    mag_sd = float(math.sqrt(np.sum((r * sd) ** 2)) / mag) if mag > 0.0 else float(np.linalg.norm(sd))
    if mag - MATCH_SIGMAS * mag_sd > EARTH_RATE_RAD_S:
        return verdict
    rates = ", ".join(f"{a} {x / DEG_PER_H:+.4g} +- {s / DEG_PER_H:.2g}" for a, x, s in zip(axes, r, sd))
    out = dict(verdict)
    out["alternatives"] = list(verdict.get("alternatives") or []) + ["earth_rate"]
    out["steady_rate"] = {
        "finding": "earth_rate", "rate_deg_h": {a: float(x / DEG_PER_H) for a, x in zip(axes, r)},
        "sigma_deg_h": {a: float(x / DEG_PER_H) for a, x in zip(axes, sd)},
        "magnitude_deg_h": mag / DEG_PER_H, "magnitude_sigma_deg_h": mag_sd / DEG_PER_H,
        "message": (f"the Earth's rate: give the site and orientation (meta.site). On this turning table the scale-"
                    f"factor error is a steady rate ({rates} deg/h) of magnitude {mag / DEG_PER_H:.4g} +- "
                    f"{mag_sd / DEG_PER_H:.2g} deg/h, at most the Earth's {EARTH_RATE_RAD_S / DEG_PER_H:.4g} deg/h: "
                    "without the site the recording cannot tell the Earth's rate along the table axis from it")}
    return out
