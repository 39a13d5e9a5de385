"""Navigation-error bookkeeping of a run: full-rate statistics and anti-aliased stored series.

Every metric comes from the full-rate solution (one value per navigation update), streamed
chunk by chunk; storage settings change only what is stored. Stored series are block
averages over ``1 / timeseries_rate_hz`` (a boxcar anti-alias filter before the
decimation) with the minimum and maximum of each block beside them, so a plot shows the
envelope of what happened between stored samples instead of an aliased sample of it.

Derived figures (:func:`ramp_fit`, :func:`event_steps`) report what the data supports: a
drift only when a ramp explains the attitude error (with its 95 % confidence interval), a
step across a shock as a step, a scale-factor error from a turn in ppm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from sins_sim._kernels import truth as ktruth
from sins_sim.units import ARCSEC, DEG

__all__ = ["ErrorSeries", "NavErrorStats", "ramp_fit", "drift_metrics", "event_steps", "SERIES_FIELDS", "N_COLS"]

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
    """

    def __init__(self, every: int, dt_s: float, t0_s: float):
        self.every = max(1, int(every))
        self.dt = float(dt_s)
        self.t0 = float(t0_s)
        self._acc = np.zeros(1 + 3 * N_COLS)
        self._n_blocks = 0
        self._mean, self._lo, self._hi = [], [], []

    def add(self, rows: np.ndarray):
        """Add error rows ``(n, N_COLS)``."""
        nb_max = (rows.shape[0] + int(self._acc[0])) // self.every
        out = [np.empty((nb_max, N_COLS)) for _ in range(3)]
        m = ktruth.block_stats(np.ascontiguousarray(rows), self.every, self._acc, *out)
        if m:
            self._mean.append(out[0][:m])
            self._lo.append(out[1][:m])
            self._hi.append(out[2][:m])
            self._n_blocks += m

    def arrays(self) -> dict:
        """``t_s`` and, per channel, ``NAME``, ``NAME_min``, ``NAME_max`` as arrays."""
        nb = self._n_blocks
        t = self.t0 + (self.every * np.arange(nb) + 0.5 * (self.every - 1) + 1) * self.dt
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
    stt = float(tc @ tc)
    b = float(tc @ yc) / stt
    res = yc - b * tc
    ss_res = float(res @ res)
    ss_tot = float(yc @ yc)
    r2 = 1.0 - ss_res / ss_tot if ss_tot > 0 else 0.0
    rho = float(res[1:] @ res[:-1]) / ss_res if ss_res > 0 else 0.0
    rho = min(max(rho, 0.0), 0.999)
    n_eff = max(3.0, n * (1.0 - rho) / (1.0 + rho))
    se = math.sqrt(ss_res / max(n - 2, 1) / stt) * math.sqrt(n / n_eff)
    ci = 1.96 * se
    return {"slope": b, "ci95": ci, "r2": r2, "n_eff": n_eff, "explains": bool(r2 >= r2_min and abs(b) > ci)}


def drift_metrics(t_s, att_ned):
    """``drift_deg_per_h`` per NED axis: the ramp's slope and 95 % interval where a ramp explains the
    attitude error, else None (with the R^2 that was found)."""
    out = {"value": [], "ci95": [], "r2": []}
    for i in range(3):
        f = ramp_fit(t_s, att_ned[:, i])
        ok = f["explains"]
        out["value"].append(f["slope"] / DEG * 3600.0 if ok else None)
        out["ci95"].append(f["ci95"] / DEG * 3600.0 if ok else None)
        out["r2"].append(None if math.isnan(f["r2"]) else round(f["r2"], 4))
    out["axes"] = ["north", "east", "down"]
    out["rule"] = "reported where a ramp a + b t explains >= 90 % of the variance and |b| > its 95 % interval"
    return out


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
