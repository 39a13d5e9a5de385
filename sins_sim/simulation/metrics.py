"""Navigation-error bookkeeping of a run: full-rate statistics and anti-aliased stored series.

Every metric comes from the full-rate solution (one value per navigation update), streamed
chunk by chunk; storage settings change only what is stored. Stored series are block
averages over ``1 / timeseries_rate_hz`` (a boxcar anti-alias filter before the
decimation) with the minimum and maximum of each block beside them, so a plot shows the
envelope of what happened between stored samples instead of an aliased sample of it. With a
navigation rate below the filter rate the average is over every filter sample, not over the
updates: each update brings its interval mean (:mod:`sins_sim._kernels.series`), without which
content above the navigation Nyquist (dither lines, vibration) would fold into the block means.

Derived figures (:func:`ramp_fit`, :func:`event_steps`) report what the data supports: a
drift only when a ramp explains the attitude error (with its 95 % confidence interval), a
step across a shock as a step, a scale-factor error from a turn in ppm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from sins_sim import earth
from sins_sim._kernels import truth as ktruth
from sins_sim.units import ARCSEC, DEG_PER_H

__all__ = ["ErrorSeries", "NavErrorStats", "ramp_fit", "drift_metrics", "gyro_drift", "psi_angle",
           "attitude_drift_angle", "track_on_series", "drift_angle_of_series", "event_steps", "SERIES_FIELDS", "N_COLS", "DRIFT_RESOLUTION_RAD_S",
           "stored_line"]

#: Smallest drift reported as a drift (rad/s): 1e-4 deg/h, a tenth of the bias stability of the best
#: navigation-grade gyros (0.001 deg/h). Below it a ramp is the simulation's own numerical floor (the ideal
#: increments through the strapdown algorithm drift by about 1e-6 deg/h), reported as "below resolution".
DRIFT_RESOLUTION_RAD_S = 1e-4 * DEG_PER_H

#: Stored channels (columns of the error rows of :func:`sins_sim._kernels.truth.nav_errors` plus
#: the solution's position): name -> columns.
SERIES_FIELDS = {
    "north_m": slice(0, 1),
    "east_m": slice(1, 2),
    "horizontal_m": slice(2, 3),
    "vertical_m": slice(3, 4),
    "velocity_ned_m_s": slice(4, 7),
    "attitude_ned_rad": slice(7, 10),
    "lat_rad": slice(10, 11),
    "lon_rad": slice(11, 12),
    "attitude_free_ned_rad": slice(12, 15),
}
N_COLS = 15


class ErrorSeries:
    """Block means, minima and maxima of the error rows over ``every`` consecutive updates.

    Rows arrive in chunks; a block is stored when complete, so chunking does not change the
    stored series. The block's time is its centre.

    With a multi-rate navigation (``n_sub > 1``) each update also brings its interval mean (the error averaged
    over the update's filter samples, :func:`sins_sim._kernels.series.interval_fast_means`): the block means are
    then those of the interval means, i.e. of the error at every filter sample, and the envelope spans both the
    errors at the updates and the interval means (so that it holds the mean).
    """

    def __init__(self, every: int, dt_s: float, t0_s: float, samples_per_update: int = 1):
        self.every = max(1, int(every))
        self.n_sub = max(1, int(samples_per_update))
        self.dt = float(dt_s)
        self.t0 = float(t0_s)
        self._acc = np.zeros(1 + 3 * N_COLS)
        self._acc_epochs = np.zeros(1 + 3 * N_COLS)
        self._n_blocks = 0
        self._mean, self._lo, self._hi = [], [], []

    def add(self, rows: np.ndarray, interval_means: np.ndarray | None = None):
        """Add error rows ``(n, N_COLS)`` at the updates and, optionally, their interval means (same shape)."""
        nb_max = (rows.shape[0] + int(self._acc[0])) // self.every
        out = [np.empty((nb_max, N_COLS)) for _ in range(3)]
        src = rows if interval_means is None else interval_means
        m = ktruth.block_stats(np.ascontiguousarray(src), self.every, self._acc, *out)
        if interval_means is not None:  # the envelope of the errors at the updates joins that of the means
            ep = [np.empty((nb_max, N_COLS)) for _ in range(3)]
            ktruth.block_stats(np.ascontiguousarray(rows), self.every, self._acc_epochs, *ep)
            np.minimum(out[1], ep[1], out=out[1])
            np.maximum(out[2], ep[2], out=out[2])
        if m:
            self._mean.append(out[0][:m])
            self._lo.append(out[1][:m])
            self._hi.append(out[2][:m])
            self._n_blocks += m

    def arrays(self) -> dict:
        """``t_s`` and, per channel, ``NAME``, ``NAME_min``, ``NAME_max`` as arrays."""
        nb = self._n_blocks
        if self.n_sub == 1:  # the centre of the block's updates
            t = self.t0 + (self.every * np.arange(nb) + 0.5 * (self.every - 1) + 1) * self.dt
        else:  # the centre of the block's filter samples (the means are over them)
            t = self.t0 + (self.every * np.arange(nb) + 0.5 * self.every + 0.5 / self.n_sub) * self.dt
        out = {"t_s": t}
        for suffix, src in (("", self._mean), ("_min", self._lo), ("_max", self._hi)):
            a = np.concatenate(src) if src else np.zeros((0, N_COLS))
            for k, sl in SERIES_FIELDS.items():
                col = a[:, sl]
                out[k + suffix] = col[:, 0] if col.shape[1] == 1 else col
        return out


@dataclass
class NavErrorStats:
    """Full-rate statistics of one filter's navigation error."""

    n: int = 0
    horizontal_max_m: float = 0.0
    velocity_max_m_s: float = 0.0
    att_sum2: np.ndarray = field(default_factory=lambda: np.zeros(3))
    last: dict = field(default_factory=dict)

    def add(self, rows: np.ndarray, t_s: np.ndarray):
        """Add error rows ``(n, N_COLS)`` at times ``t_s``."""
        if rows.shape[0] == 0:
            return
        self.n += rows.shape[0]
        st = np.empty(6)
        ktruth.error_stats(rows, st)  # one pass: maxima, attitude sums of squares, the last velocity norm
        self.horizontal_max_m = max(self.horizontal_max_m, float(st[0]))
        self.velocity_max_m_s = max(self.velocity_max_m_s, float(st[1]))
        self.att_sum2 += st[2:5]
        r = rows[-1]
        self.last = {"t_s": float(t_s[-1]), "north_m": float(r[0]), "east_m": float(r[1]),
                     "horizontal_m": float(r[2]), "vertical_m": float(r[3]), "velocity_ned_m_s": r[4:7].copy(),
                     "velocity_m_s": float(st[5]), "attitude_ned_rad": r[7:10].copy()}

    @property
    def attitude_rms_rad(self) -> np.ndarray:
        return np.sqrt(self.att_sum2 / max(self.n, 1))


def _dot(a, b) -> float:
    """``sum a b`` by numpy's pairwise summation: the same bits whatever the cores (a BLAS dot product splits long
    vectors over threads, and the drift fits of one run then differed in their last digit between 1 and 2 cores)."""
    return float(np.sum(a * b))


def ramp_fit(t_s, y, r2_min: float = 0.9):
    """Least-squares ramp ``a + b t`` with a 95 % confidence interval on ``b`` for correlated residuals.

    The residuals' lag-one autocorrelation ``rho`` reduces the effective number of samples to
    ``n (1 - rho) / (1 + rho)`` (the AR(1) adjustment; Bartlett 1946, Bayley & Hammersley 1946),
    which widens the ordinary-least-squares interval by ``sqrt(n / n_eff)``.

    Returns
    -------
    dict
        ``slope`` and ``ci95`` (units of ``y`` per s), ``r2``, ``n_eff``, and ``explains``:
        True when the ramp explains at least ``r2_min`` of the variance and its slope is
        distinguishable from zero (``|slope| > ci95``).
    """
    t = np.asarray(t_s, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    n = t.size
    if n < 8:
        return {"slope": math.nan, "ci95": math.nan, "r2": math.nan, "n_eff": float(n), "explains": False}
    tc = t - t.mean()
    yc = y - y.mean()
    stt = _dot(tc, tc)
    b = _dot(tc, yc) / stt
    res = yc - b * tc
    ss_res = _dot(res, res)
    ss_tot = _dot(yc, yc)
    r2 = 1.0 - ss_res / ss_tot if ss_tot > 0 else 0.0
    rho = _dot(res[1:], res[:-1]) / ss_res if ss_res > 0 else 0.0
    rho = min(max(rho, 0.0), 0.999)
    n_eff = max(3.0, n * (1.0 - rho) / (1.0 + rho))
    se = math.sqrt(ss_res / max(n - 2, 1) / stt) * math.sqrt(n / n_eff)
    ci = 1.96 * se
    return {"slope": b, "ci95": ci, "r2": r2, "n_eff": n_eff, "explains": bool(r2 >= r2_min and abs(b) > ci)}


def drift_metrics(t_s, angle, axes, resolution_rad_s: float = DRIFT_RESOLUTION_RAD_S) -> dict:
    """Drift per axis of an accumulated angle error, reported as a drift only where a ramp explains it.

    Parameters
    ----------
    t_s : array (N,)
        Times (s).
    angle : array (N, 3)
        An accumulated angle error (rad) whose slope is a drift: a filter's gyro-angle error in body
        axes (:func:`gyro_drift`), or the navigation's accumulated attitude drift angle
        (:func:`attitude_drift_angle`). Never the tilt phi, which the Schuler loop bounds.
    axes : sequence of 3 str
        Axis names.
    resolution_rad_s : float
        Slopes below this are "below resolution" (:data:`DRIFT_RESOLUTION_RAD_S`).

    Returns
    -------
    dict
        Per axis ``{"value", "ci95"}`` (deg/h; None unless a drift), ``"r2"``, ``"status"`` (``drift``: a
        ramp explains at least 90 % of the variance, its slope exceeds its 95 % interval (:func:`ramp_fit`)
        and the resolution; ``no ramp``: the error is bounded, a step or noise; ``below resolution``) and
        ``"bound_95"`` (deg/h): the largest ramp the record allows at 95 %, ``|slope| + ci95``, where
        no drift is reported. Plus ``"rule"``.
    """
    out = {}
    for i, ax in enumerate(axes):
        f = ramp_fit(t_s, angle[:, i])
        r2 = None if math.isnan(f["r2"]) else round(f["r2"], 4)
        slope, ci = f["slope"] / DEG_PER_H, f["ci95"] / DEG_PER_H
        if not math.isfinite(slope):
            out[ax] = {"value": None, "ci95": None, "r2": r2, "status": "too short", "bound_95": None}
        elif f["explains"] and abs(f["slope"]) >= resolution_rad_s:
            out[ax] = {"value": slope, "ci95": ci, "r2": r2, "status": "drift", "bound_95": None}
        else:
            status = "below resolution" if f["explains"] else "no ramp"
            out[ax] = {"value": None, "ci95": None, "r2": r2, "status": status, "bound_95": abs(slope) + ci}
    out["rule"] = (f"a drift where a ramp a + b t explains >= 90 % of the variance, |b| > its 95 % interval and "
                   f"|b| >= {resolution_rad_s / DEG_PER_H:g} deg/h (the resolution); otherwise bound_95 = |b| + ci95")
    return out


def gyro_drift(records: dict, name: str) -> dict | None:
    """``gyro_drift_deg_h``: the drift of a filter's output per body axis, from its gyro-angle error.

    The record is the filter's output minus the true gyro angle, sensor errors included, accumulated in
    body axes and sampled over the navigated period (:attr:`SinsResult.records`). Its slope is what the
    filter's increments add to the true rotation per second on that axis: a gyro bias, or a filter's
    gain error against the Earth rate at rest. Coning losses do not appear here (they live in the
    attitude integration: :func:`attitude_drift_angle`).
    """
    x = records.get(name) if records else None
    if x is None:
        return None
    return drift_metrics(records["t_s"], x, ("x", "y", "z"))


def psi_angle(ser: dict) -> np.ndarray:
    """The psi attitude error (rad, NED) from the stored series: ``psi = phi + dtheta``.

    ``phi`` (``attitude_ned_rad``) is the rotation vector of ``q_est (x) q_true*``: the computed body
    attitude against the true NED frame at the true position. ``dtheta = (dlon cos L, -dlat, -dlon sin
    L)`` is the rotation from the true NED frame to the NED frame at the computed position (position
    error angle; Titterton & Weston 2004, sec. 12.3.3, with ``dlat = north / (R_N + h)``, ``dlon cos L =
    east / (R_E + h)``); with phi's sign convention (phi = psi - dtheta in Titterton & Weston's), psi
    is the attitude error against the computed position's frame. Its dynamics carry no velocity or
    position error (``psi' = -w_in x psi - eps``: the psi-angle equations, Benson 1975), so an
    accelerometer error leaves it at zero while phi follows the Schuler loop. Block means in, block
    means out (the relation is linear).
    """
    lat = ser["lat_rad"]
    r_n, r_e = earth.radii(lat)
    h = ser.get("h_m")
    h = 0.0 if h is None else h
    dth = np.stack([ser["east_m"] / (r_e + h), -ser["north_m"] / (r_n + h),
                    -ser["east_m"] * np.tan(lat) / (r_e + h)], axis=1)
    return ser["attitude_ned_rad"] + dth


def track_on_series(truth_series: dict, t_s) -> dict:
    """The truth's latitude, height and transport rate at the stored error series' times ``t_s``.

    The velocity comes from the truth's stored positions (central differences of latitude, longitude
    and height; ``v_N = lat' (R_N + h)``, ``v_E = lon' cos L (R_E + h)``), the transport rate from
    :func:`sins_sim.earth.transport_rate_ned`. Used for the psi angle's radii and the drift angle's
    coupling term, where metre-level detail does not matter.
    """
    tt = np.asarray(truth_series.get("t_s", ()), dtype=np.float64)
    t_s = np.asarray(t_s, dtype=np.float64)
    if tt.size < 3:
        return {"h_m": np.zeros_like(t_s), "w_en_ned": None}
    lat, lon, h = truth_series["lat_rad"], np.unwrap(truth_series["lon_rad"]), truth_series["h_m"]
    r_n, r_e = earth.radii(lat)
    v = np.stack([np.gradient(lat, tt) * (r_n + h), np.gradient(lon, tt) * np.cos(lat) * (r_e + h),
                  -np.gradient(h, tt)], axis=1)
    w = earth.transport_rate_ned(lat, h, v)
    return {"h_m": np.interp(t_s, tt, h),
            "w_en_ned": np.stack([np.interp(t_s, tt, w[:, i]) for i in range(3)], axis=1)}


def drift_angle_of_series(ser: dict, truth_series: dict) -> tuple:
    """``(psi, D)`` of one filter's stored series: :func:`psi_angle` and :func:`attitude_drift_angle` along the
    truth's track (:func:`track_on_series`), both (N, 3) rad in NED at ``ser["t_s"]``."""
    t = ser["t_s"]
    track = track_on_series(truth_series, t)
    psi = psi_angle({**ser, "h_m": track["h_m"]})
    return psi, attitude_drift_angle(t, psi, ser["lat_rad"], track["w_en_ned"])


def attitude_drift_angle(t_s, psi, lat_rad, w_en_ned=None) -> np.ndarray:
    """The navigation's accumulated attitude drift angle (rad, NED): ``psi(t) - psi(t0) + int w_in x psi dt``.

    From the psi-angle equation ``psi' = -w_in x psi + eps`` (phi's sign convention): integrating gives
    ``int eps dt``, the attitude the navigation has gained or lost, without the Earth-rate and
    transport-rate coupling between axes (which turns a north tilt into an east one over an hour).
    ``w_in = Omega_ie + w_en`` (NED); trapezoidal integration over the stored series.

    Parameters
    ----------
    t_s : array (N,)
    psi : array (N, 3)
        :func:`psi_angle`.
    lat_rad : array (N,)
    w_en_ned : array (N, 3) or None
        Transport rate (rad/s); None: the vehicle at rest.
    """
    w = earth.earth_rate_ned(lat_rad)
    if w_en_ned is not None:
        w = w + w_en_ned
    c = np.cross(w, psi)
    integral = np.concatenate([np.zeros((1, 3)), np.cumsum(0.5 * (c[1:] + c[:-1]) * np.diff(t_s)[:, None], axis=0)])
    return psi - psi[0] + integral


def event_steps(t_s, att_ned, events, window_s: float = 0.5, settle_s: float = 0.2):
    """Attitude-error steps across events (shocks, turns), from the stored block means.

    For each event ``{"kind", "start_s", "end_s", "angle_rad" (turns), "axis_ned" (turns)}``:
    the mean error over ``[end + settle, end + settle + window]`` minus the mean over
    ``[start - window, start)``, in arcsec per NED axis; for a turn also the scale-factor
    error ``step . axis / angle`` in ppm.
    """
    t = np.asarray(t_s)
    out = []
    for ev in events:
        before = (t >= ev["start_s"] - window_s) & (t < ev["start_s"])
        after = (t >= ev["end_s"] + settle_s) & (t < ev["end_s"] + settle_s + window_s)
        if not before.any() or not after.any():
            continue
        step = att_ned[after].mean(axis=0) - att_ned[before].mean(axis=0)
        rec = {"kind": ev["kind"], "start_s": ev["start_s"], "end_s": ev["end_s"],
               "step_arcsec": [float(x / ARCSEC) for x in step]}
        if ev.get("angle_rad"):
            axis = np.asarray(ev["axis_ned"], dtype=float)
            rec["scale_factor_error_ppm"] = float(step @ axis / ev["angle_rad"] * 1e6)
        out.append(rec)
    return out


def stored_line(t_s, y, f_hz: float, series_rate_hz: float) -> float:
    """Amplitude of a line at ``f_hz`` in a stored series (block means over ``1 / series_rate_hz``, module
    docstring): the least-squares lock-in (:func:`sins_sim.simulation.responses.line_amplitudes`, with an offset
    and a linear trend: an attitude error that drifts) divided by the block mean's gain at that frequency,
    ``|sinc(f / rate)|`` (a boxcar's transfer function). Meaningful below a quarter of the series rate, where that
    gain is above 0.9 and the line is not aliased."""
    from sins_sim.simulation.responses import line_amplitudes

    return line_amplitudes(t_s, y, (f_hz,), trend=True)[0] / abs(float(np.sinc(f_hz / series_rate_hz)))
