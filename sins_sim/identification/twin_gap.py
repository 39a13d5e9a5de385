"""Where a log at rest leaves its twin's envelope: which quantity, axis, band and time.

Takes the mission at rest run on the log and on ``S`` seeds of its twin
(:class:`sins_sim.simulation.twin.RestRun`) and lists findings, each a place where the log is outside what the
twin does, with the test and the level it was made at. The false-alarm rate is controlled per log and per kind
of quantity (``alpha``, Bonferroni over the points tested):

* **Allan deviation** (per sensor axis, at each tau with at least ``MIN_CLUSTERS`` independent clusters): the
  log's Allan variance over the mean of the twin's. Both are chi-square with (conservatively) the
  non-overlapping ``clusters - 1`` degrees of freedom (IEEE Std 952-1997, Annex C; Riley 2008, sec. 5.3), the
  twin's mean with ``S`` times as many, so under "the log is a run of the twin" the ratio is
  ``F(edf, S edf)`` distributed. The twin's terms are themselves fitted from the log, to a few per cent (the Allan
  fit's model tolerance, :data:`MODEL_TOLERANCE` on the deviation, as in :mod:`sins_sim.navigation.allan`), so the
  F interval is widened by that factor each side. A tau is outside where the ratio leaves the central
  ``1 - alpha / (6 n_tau)`` interval so widened; a finding is a run of consecutive taus outside on one side (gaps
  of up to :data:`BRIDGE` taus bridged).
* **Spectral lines**: a line of the log (found at the log's false-alarm level) with no line of the twin within
  two bins in at least half its seeds.
* **Navigation** (north and east position, north and east velocity, attitude drift about north, east and down; on a
  known trajectory the errors against the truth, :data:`NAV_QUANTITIES_TRUTH`):
  at each time the twin's 95 % prediction interval for one more run, ``mean +- t_{S-1} s sqrt(1 + 1/S)`` (the
  normal prediction interval with unknown mean and variance), at level ``1 - alpha / 7``. The log leaves it at
  the start of the last run of times it is outside, when that run reaches the end of the log (it does not come
  back); a log that steps out and back in is not a finding.

The alignment is not a finding: the log's true attitude is unknown. Its stated sigma is set beside the twin's
actual alignment errors (the twin's truth is the log's aligned attitude) in :func:`alignment_side_by_side`.
"""

from __future__ import annotations

import math

import numpy as np

from sins_sim.units import ARCSEC, DEG_PER_H, MICRO_G

__all__ = ["MIN_CLUSTERS", "MODEL_TOLERANCE", "NAV_QUANTITIES", "NAV_QUANTITIES_TRUTH", "alignment_side_by_side", "allan_band", "localise", "localise_nav", "nav_band"]

#: Independent clusters a tau needs to be tested.
MIN_CLUSTERS = 10
#: Relative tolerance of the twin's Allan deviation for its terms' own fit (the 5 % floor of the Allan fit's
#: weights, :func:`sins_sim.navigation.allan.fit_allan`).
MODEL_TOLERANCE = 0.05
#: Taus inside the band that may separate two runs outside on the same side and still make one finding.
BRIDGE = 2
#: (key in RestRun.nav, column, label, factor from SI to the edge unit, edge unit)
NAV_QUANTITIES = (
    ("position_m", 0, "north position", 1.0, "m"),
    ("position_m", 1, "east position", 1.0, "m"),
    ("velocity_m_s", 0, "north velocity", 1.0, "m/s"),
    ("velocity_m_s", 1, "east velocity", 1.0, "m/s"),
    ("attitude_rad", 0, "attitude drift about north", 1.0 / ARCSEC, "arcsec"),
    ("attitude_rad", 1, "attitude drift about east", 1.0 / ARCSEC, "arcsec"),
    ("attitude_rad", 2, "attitude drift about down", 1.0 / ARCSEC, "arcsec"),
)
#: The same on a known trajectory (:mod:`sins_sim.simulation.twin_moving`): position and velocity are errors against
#: the truth, and the attitude is the error ``psi`` against the truth's attitude, not a drift from an aligned start.
NAV_QUANTITIES_TRUTH = tuple((key, col, label.replace("drift", "error") if key == "attitude_rad" else label + " error",
                              scale, unit) for key, col, label, scale, unit in NAV_QUANTITIES)
_ALLAN_UNIT = {"gyro": ("deg_h", 1.0 / DEG_PER_H), "accelerometer": ("ug", 1.0 / MICRO_G)}


def allan_band(log_curve, twin_curves, alpha_point: float) -> dict:
    """The twin's band for the log's Allan deviation at each tau the log and every twin seed share.

    Returns
    -------
    dict
        ``tau_s``, ``log`` and ``twin_mean`` (deviations, SI), ``lo`` and ``hi`` (the band on the deviation),
        ``tested`` (bool per tau: enough clusters), ``outside`` (-1 below, +1 above, 0 inside or untested).
    """
    from scipy.stats import f as f_dist

    tau = np.asarray(log_curve.tau_s)
    s = len(twin_curves)
    var = np.full((s, tau.size), np.nan)
    for j, c in enumerate(twin_curves):
        idx = np.searchsorted(c.tau_s, tau)
        ok = (idx < c.tau_s.size)
        ok[ok] = np.isclose(c.tau_s[idx[ok]], tau[ok], rtol=1e-9)
        var[j, ok] = c.adev[idx[ok]] ** 2
    mean = np.mean(var, axis=0)
    edf = np.maximum(np.asarray(log_curve.clusters, dtype=np.float64) - 1.0, 1.0)
    tested = (np.asarray(log_curve.clusters) >= MIN_CLUSTERS) & np.all(np.isfinite(var), axis=0)
    lo_q = f_dist.ppf(alpha_point / 2.0, edf, s * edf) / (1.0 + MODEL_TOLERANCE) ** 2
    hi_q = f_dist.isf(alpha_point / 2.0, edf, s * edf) * (1.0 + MODEL_TOLERANCE) ** 2
    ratio = log_curve.adev ** 2 / mean
    outside = np.where(tested & (ratio > hi_q), 1, np.where(tested & (ratio < lo_q), -1, 0))
    return {"tau_s": tau, "log": np.asarray(log_curve.adev), "twin_mean": np.sqrt(mean),
            "lo": np.sqrt(mean * lo_q), "hi": np.sqrt(mean * hi_q), "tested": tested, "outside": outside}


def nav_band(log_values, twin_values, level: float) -> dict:
    """The twin's prediction interval for one more run, per time (``twin_values`` (S, M)).

    Returns
    -------
    dict
        ``mean``, ``lo``, ``hi``, ``min``, ``max`` over the seeds and ``outside`` (bool per time).
    """
    from scipy.stats import t as t_dist

    x = np.asarray(twin_values, dtype=np.float64)
    s = x.shape[0]
    mean = x.mean(axis=0)
    sd = x.std(axis=0, ddof=1) if s > 1 else np.zeros_like(mean)
    half = float(t_dist.isf((1.0 - level) / 2.0, max(s - 1, 1))) * sd * math.sqrt(1.0 + 1.0 / s)
    y = np.asarray(log_values, dtype=np.float64)
    return {"mean": mean, "lo": mean - half, "hi": mean + half, "min": x.min(axis=0), "max": x.max(axis=0),
            "outside": np.abs(y - mean) > half}


def _runs(flags: np.ndarray, bridge: int = BRIDGE) -> list:
    """``(start, stop)`` index pairs of the runs of equal non-zero values, gaps of up to ``bridge`` points between
    two runs of the same sign bridged (one effect's ripple crossing the band edge stays one finding)."""
    out, i, n = [], 0, flags.size
    while i < n:
        if flags[i] == 0:
            i += 1
            continue
        j = i
        while j + 1 < n and flags[j + 1] == flags[i]:
            j += 1
        if out and flags[out[-1][0]] == flags[i] and i - out[-1][1] - 1 <= bridge:
            out[-1] = (out[-1][0], j)
        else:
            out.append((i, j))
        i = j + 1
    return out


def _allan_findings(log_run, twins, alpha: float) -> tuple:
    findings, bands = [], {}
    for key, curve in log_run.allan.items():
        sensor, ax = key
        n_tau = max(int(np.sum(curve.clusters >= MIN_CLUSTERS)), 1)
        band = allan_band(curve, [t.allan[key] for t in twins], alpha / (6.0 * n_tau))
        bands[key] = band
        unit, scale = _ALLAN_UNIT[sensor]
        for i, j in _runs(band["outside"]):
            k = i + int(np.argmax(np.abs(np.log(band["log"][i:j + 1] / band["twin_mean"][i:j + 1]))))
            side = "above" if band["outside"][i] > 0 else "below"
            findings.append({
                "quantity": "allan_deviation", "sensor": sensor, "axis": ax, "side": side,
                "tau_range_s": [float(band["tau_s"][i]), float(band["tau_s"][j])],
                "worst_tau_s": float(band["tau_s"][k]), f"log_{unit}": float(band["log"][k] * scale),
                f"twin_{unit}": float(band["twin_mean"][k] * scale),
                f"band_{unit}": [float(band["lo"][k] * scale), float(band["hi"][k] * scale)],
                "ratio": float(band["log"][k] / band["twin_mean"][k]),
                "statement": (f"{sensor} {ax}: the Allan deviation lies {side} the twin's band from tau "
                              f"{band['tau_s'][i]:.3g} s to {band['tau_s'][j]:.3g} s (at {band['tau_s'][k]:.3g} s "
                              f"{band['log'][k] / band['twin_mean'][k]:.3g} times the twin's)")})
    return findings, bands


def _line_findings(log_run, twins) -> list:
    findings = []
    for key, search in log_run.lines.items():
        sensor, ax = key
        df = search.psd.resolution_hz
        for line in search.lines:
            hits = sum(any(abs(tl.frequency_hz - line.frequency_hz) <= 2.0 * df for tl in t.lines[key].lines)
                       for t in twins)
            if hits * 2 >= len(twins):
                continue
            findings.append({
                "quantity": "psd_line", "sensor": sensor, "axis": ax, "frequency_hz": float(line.frequency_hz),
                "band_hz": [float(line.frequency_hz - df), float(line.frequency_hz + df)],
                "snr": float(line.snr), "twin_seeds_with_line": int(hits),
                "statement": (f"{sensor} {ax}: a line at {line.frequency_hz:.4g} Hz (SNR {line.snr:.3g}) that the "
                              f"twin has in {hits} of {len(twins)} seeds")})
    return findings


def _nav_findings(log_run, twins, alpha: float, quantities=NAV_QUANTITIES) -> tuple:
    findings, bands = [], {}
    level = 1.0 - alpha / len(quantities)
    t = log_run.nav_t_s
    m = min([t.size] + [tw.nav_t_s.size for tw in twins])
    for key, col, label, scale, unit in quantities:
        y = log_run.nav[key][:m, col]
        x = np.array([tw.nav[key][:m, col] for tw in twins])
        band = nav_band(y, x, level)
        bands[(key, col)] = band
        out = band["outside"]
        if not out[-1]:
            continue
        inside = np.flatnonzero(~out)
        start = int(inside[-1] + 1) if inside.size else 0
        half_end = float(band["hi"][-1] - band["mean"][-1])
        findings.append({
            "quantity": "navigation", "what": label, "leaves_at_s": float(t[start]),
            f"log_at_end_{unit}": float(y[-1] * scale), f"twin_mean_at_end_{unit}": float(band["mean"][-1] * scale),
            f"twin_halfwidth_at_end_{unit}": float(half_end * scale), "level": level,
            "statement": (f"{label}: leaves the twin's {100 * level:.3g} % envelope at {t[start]:.4g} s and stays out; "
                          f"at the end {y[-1] * scale:.4g} {unit} against {band['mean'][-1] * scale:.4g} "
                          f"+- {half_end * scale:.3g} {unit}")})
    return findings, bands


def localise(log_run, twins, *, alpha: float = 0.05, quantities=NAV_QUANTITIES) -> dict:
    """The findings (module docstring) and the bands they were read against (the navigation's ``quantities``:
    :data:`NAV_QUANTITIES` at rest, :data:`NAV_QUANTITIES_TRUTH` on a known trajectory).

    Returns
    -------
    dict
        ``findings`` (list of dicts, each with ``quantity`` and a ``statement``), ``allan_bands``
        (``(sensor, axis) -> band``), ``nav_bands`` (``(key, column) -> band``), ``alpha``.
    """
    if len(twins) < 2:
        raise ValueError(f"twin_seeds: the envelope needs at least 2 seeds of the twin, got {len(twins)}")
    allan_f, allan_b = _allan_findings(log_run, twins, alpha)
    nav_f, nav_b = _nav_findings(log_run, twins, alpha, quantities)
    return {"findings": allan_f + _line_findings(log_run, twins) + nav_f, "allan_bands": allan_b,
            "nav_bands": nav_b, "alpha": alpha}


def localise_nav(log_run, twins, *, alpha: float = 0.05, quantities=NAV_QUANTITIES_TRUTH) -> dict:
    """The navigation findings alone (module docstring, **Navigation**), for a mission with no Allan or line test
    beside it: a moving log navigated on its known trajectory and its twin's seeds
    (:class:`sins_sim.simulation.twin_moving.MovingRun`; anything with ``nav_t_s`` and ``nav`` as
    :class:`~sins_sim.simulation.twin.RestRun`).

    Returns
    -------
    dict
        ``findings``, ``nav_bands`` (``(key, column) -> band``), ``alpha``.
    """
    if len(twins) < 2:
        raise ValueError(f"twin_seeds: the envelope needs at least 2 seeds of the twin, got {len(twins)}")
    nav_f, nav_b = _nav_findings(log_run, twins, alpha, quantities)
    return {"findings": nav_f, "nav_bands": nav_b, "alpha": alpha}


def alignment_side_by_side(log_run, twins, q_true) -> dict:
    """The log's alignment (its attitude and stated sigma) beside the twin's alignment errors (its truth
    ``q_true``, the log's aligned attitude): per seed, their RMS and the sigma the twin's alignment states (arcsec
    about north and east, deg about down)."""
    from sins_sim.navigation.attitude import attitude_error, euler_from_quat

    scale = np.array([1.0 / ARCSEC, 1.0 / ARCSEC, 180.0 / math.pi])
    errs = np.array([attitude_error(np.asarray(t.alignment.q_nb), np.asarray(q_true)) for t in twins]) * scale
    sig = np.array([np.asarray(t.alignment.sigma_rad) for t in twins]) * scale
    rpy = np.degrees(euler_from_quat(np.asarray(log_run.alignment.q_nb)))
    keys = ("north_arcsec", "east_arcsec", "down_deg")
    return {
        "log": {"roll_deg": float(rpy[0]), "pitch_deg": float(rpy[1]), "heading_deg": float(rpy[2]),
                "sigma": dict(zip(keys, (np.asarray(log_run.alignment.sigma_rad) * scale).tolist()))},
        "twin_errors": [dict(zip(keys, e.tolist())) for e in errs],
        "twin_error_rms": dict(zip(keys, np.sqrt(np.mean(errs ** 2, axis=0)).tolist())),
        "twin_sigma_mean": dict(zip(keys, sig.mean(axis=0).tolist())),
    }
