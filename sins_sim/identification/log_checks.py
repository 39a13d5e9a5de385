"""Checks of a unit's increments log before it is fitted (``sins-sim identify``'s step 0).

The fits of ``identify`` (the Allan deviation, the PSD, the alignment, the twin on the log's time axis) all take
the log as evenly sampled at one rate, every channel a live sensor. A log that is not gets the verdict
``invalid data`` instead of a fit: each failed check is a **finding** naming the check, the channel, the time and
the row, and what the user can do about it (as the channel diagnosis's checks,
:mod:`sins_sim.identification.checks`, do for a recording).

==================== ===================================================================================
check                rule (and why the threshold holds)
==================== ===================================================================================
``time order``       a time that does not advance (a step ``<= 0``): the rows are out of order, or a row
                     repeats (``sins-sim import-log`` drops exact duplicates and names the rest)
``time gap``         a step of two or more periods (``round(step / dt) >= 2``, the period ``dt`` the median
                     step): ``k - 1`` intervals missing. The increments of the missing intervals are lost:
                     the Allan deviation and the navigation would run on a wrong time axis
``time step``        a step that is one period but off by more than :data:`DT_TOL` of it: the log's clock
                     jitters more than the even time axis the fits assume allows
``rate``             the log's rate ``1 / dt`` off its nominal (the description's ``time.rate_hz``) by more
                     than :data:`DT_TOL`: every rate and force is then scaled by the ratio of the two
``stuck``            a run of ``L >= MIN_RUN`` identical values in one channel that its noise cannot give.
                     A pulse counter reports ``c`` pulses ``L`` times in a row only if the sensed increment
                     summed over the run lies within one pulse ``q`` of ``c L q`` (the counter carries its
                     remainder, within ``[0, q)`` at either end). That sum has a spread ``sigma_L``, so at one
                     start the chance is at most ``2 q phi(z) / sigma_L`` (the Gaussian density's largest
                     value within ``q`` of the run's sum, ``z = max(0, L |c q - mean| - q) / sigma_L`` with the
                     channel's mean), and over the ``n - L + 1`` starts at most that many times as much (the
                     union bound); refused below :data:`STUCK_ALPHA` over the six channels (Bonferroni). ``q``
                     is the smallest step between the channel's values (a float channel's is tiny: any long
                     run is stuck); ``sigma_L = sigma_1 sqrt(L)`` with ``sigma_1`` the noise per sample read
                     off the sums over :data:`SIGMA_WINDOWS` windows (their variance less the quantisation's
                     ``q^2 / 6``) as white noise: a random walk or flicker spreads those windows' sums more
                     than white noise would, so ``sigma_1`` errs large and the bound towards passing. Every
                     run is judged and the least likely one reported. A quiet quantised channel (the
                     horizontal accelerometers at rest, a few pulses a minute) has ``sigma_L`` below ``q`` on
                     its runs and passes. A run at the channel's largest or smallest value is named
                     saturated. A channel constant over the whole log has nothing to judge it by and is left
                     to the Allan fit ("not determinable")
==================== ===================================================================================

.. autosummary::

   check_log
   invalid_data_summary
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["CHANNEL_NAMES", "DT_TOL", "MIN_RUN", "SIGMA_WINDOWS", "STUCK_ALPHA", "check_log", "invalid_data_summary"]

#: How far a sample interval may be off the median one, and the log's rate off its nominal (relative).
DT_TOL = 1e-3
#: Shortest run of identical values the stuck check judges.
MIN_RUN = 3
#: Chance of a false stuck finding in a log (its six channels together).
STUCK_ALPHA = 1e-3
#: Windows whose sums give a channel's noise per sample for the stuck check.
SIGMA_WINDOWS = 64
#: The channels, in the column order of ``(dtheta, dv)``.
CHANNEL_NAMES = ("gyro x", "gyro y", "gyro z", "accelerometer x", "accelerometer y", "accelerometer z")


def _finding(check: str, channel: str, t_s: float, sample: int, message: str, remedy: str) -> dict:
    return {"check": check, "channel": channel, "time_s": float(t_s), "sample": int(sample), "message": message,
            "remedy": remedy}


def _time_findings(t: np.ndarray, nominal_rate_hz) -> list:
    out = []
    d = np.diff(t)
    back = np.flatnonzero(d <= 0.0)
    if back.size:
        i = int(back[0])
        out.append(_finding(
            "time order", "time", t[i + 1], i + 1,
            f"row {i + 2}: the time does not advance ({t[i + 1]:.9g} s after {t[i]:.9g} s on row {i + 1}; "
            f"{back.size} such step(s))",
            "sort the log by time and drop repeated rows, or import the unit's own log with sins-sim import-log "
            "(it drops exact duplicate rows and names the others)"))
    pos = d[d > 0.0]
    if pos.size == 0:
        return out
    dt = float(np.median(pos))
    k = np.rint(d / dt)
    gap = np.flatnonzero(k >= 2.0)
    if gap.size:
        i = int(gap[0])
        missing = int(np.sum(k[gap] - 1.0))
        until = float(t[i] - t[0] + dt)
        out.append(_finding(
            "time gap", "time", t[i], i,
            f"rows {i + 1}-{i + 2}: a gap from {t[i]:.9g} to {t[i + 1]:.9g} s, {int(k[i]) - 1} interval(s) of "
            f"{dt:.6g} s missing ({gap.size} gap(s), {missing} interval(s) in all)",
            "import the unit's log with time.gaps: fill_mean in its description (each filled interval is listed), "
            f"or fit the part before the gap with --until-s {until:.6g}"))
    odd = np.flatnonzero((k == 1.0) & (np.abs(d - dt) > DT_TOL * dt))
    if odd.size:
        i = int(odd[0])
        out.append(_finding(
            "time step", "time", t[i + 1], i + 1,
            f"row {i + 2}: a step of {d[i]:.9g} s against the period {dt:.9g} s (off by {abs(d[i] / dt - 1.0):.3g} "
            f"of it, tolerance {DT_TOL:g}; {odd.size} such step(s))",
            "the fits need an even time axis: import the unit's log with sins-sim import-log, which fits the grid "
            "to its time column (time.jitter)"))
    if nominal_rate_hz is not None and not out:
        rate = 1.0 / dt
        if abs(rate / float(nominal_rate_hz) - 1.0) > DT_TOL:
            out.append(_finding(
                "rate", "time", t[0], 0,
                f"the log runs at {rate:.9g} Hz, its nominal rate {float(nominal_rate_hz):.9g} Hz is "
                f"{abs(rate / float(nominal_rate_hz) - 1.0):.3g} off (tolerance {DT_TOL:g})",
                "check time.rate_hz in the log's description against the logger's rate: a clock off its nominal "
                "scales every rate and force by the ratio"))
    return out


def _runs(x: np.ndarray) -> tuple:
    """``(starts, lengths)`` of the runs of equal consecutive values."""
    change = np.flatnonzero(x[1:] != x[:-1]) + 1
    starts = np.concatenate([[0], change])
    return starts, np.diff(np.concatenate([starts, [x.size]]))


def _stuck_chances(x: np.ndarray, starts: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """The bound on the chance of each run (module docstring, ``stuck``); 1 where the channel cannot judge it."""
    n = x.size
    values = np.unique(x)
    q = float(np.min(np.diff(values))) if values.size > 1 else 0.0
    m = n // SIGMA_WINDOWS
    out = np.ones(starts.size)
    if q <= 0.0 or m < 1:
        return out
    sums = x[:SIGMA_WINDOWS * m].reshape(SIGMA_WINDOWS, m).sum(axis=1)
    var_1 = (float(np.var(sums, ddof=1)) - q * q / 6.0) / m          # per sample, as white noise
    if var_1 <= 0.0:
        return out
    sigma_l = np.sqrt(var_1 * lengths)
    z = np.maximum(0.0, np.abs(lengths * (x[starts] - float(np.mean(x)))) - q) / sigma_l
    return np.minimum(1.0, (n - lengths + 1) * 2.0 * q / (math.sqrt(2.0 * math.pi) * sigma_l) * np.exp(-0.5 * z * z))


def _stuck_findings(t: np.ndarray, columns: np.ndarray) -> list:
    out = []
    n = columns.shape[0]
    per_channel = STUCK_ALPHA / columns.shape[1]
    for c in range(columns.shape[1]):
        x = columns[:, c]
        starts, lengths = _runs(x)
        judged = (lengths >= MIN_RUN) & (lengths < n)
        if not np.any(judged):
            continue
        starts, lengths = starts[judged], lengths[judged]
        chance = _stuck_chances(x, starts, lengths)
        j = int(np.argmin(chance))
        if chance[j] >= per_channel:
            continue
        i0, length = int(starts[j]), int(lengths[j])
        v = x[i0]
        extreme = v >= x.max() or v <= x.min()
        what = "saturated (its largest or smallest value)" if extreme else "stuck"
        end = i0 + length - 1
        until = float(t[i0] - t[0])
        out.append(_finding(
            "stuck", CHANNEL_NAMES[c], t[i0], i0,
            f"{CHANNEL_NAMES[c]}: {what} at {v:.9g} for {length} samples from {t[i0]:.9g} to {t[end]:.9g} s "
            f"(rows {i0 + 1}-{end + 1}; a chance of at most {chance[j]:.2g} that its noise gives such a run)",
            "check that channel's sensor and readout"
            + (f"; fit the part before the run with --until-s {until:.6g}" if until > 0.0 else "")))
    return out


def check_log(t_s, dtheta, dv, *, nominal_rate_hz: float | None = None) -> list:
    """The findings of the log's checks (module docstring), empty for a log that passes.

    Parameters
    ----------
    t_s : array_like
        (N,) the end time of each interval (s).
    dtheta, dv : array_like
        (N, 3) the angle (rad) and velocity (m/s) increments.
    nominal_rate_hz : float, optional
        The rate the log's description gives (``time.rate_hz``); None: not checked.

    Returns
    -------
    list of dict
        ``check``, ``channel`` (``time`` or a sensor axis), ``time_s``, ``sample`` (0-based row), ``message``
        (one line) and ``remedy`` (what the user can do), in the order of the table above.
    """
    t = np.asarray(t_s, dtype=np.float64)
    if t.ndim != 1 or t.size < 2:
        raise ValueError(f"t_s: needs at least two times, got shape {t.shape}")
    columns = np.column_stack([np.asarray(dtheta, dtype=np.float64), np.asarray(dv, dtype=np.float64)])
    if columns.shape != (t.size, 6):
        raise ValueError(f"dtheta, dv: must be ({t.size}, 3) each, got {columns.shape[0]} rows of "
                         f"{columns.shape[1]} columns in all")
    return _time_findings(t, nominal_rate_hz) + _stuck_findings(t, columns)


def invalid_data_summary(findings: list) -> str:
    """The one line a refused log prints: the first finding, how many more, and its remedy."""
    first = findings[0]
    more = f" (and {len(findings) - 1} more finding(s))" if len(findings) > 1 else ""
    return f"invalid data: {first['check']}: {first['message']}{more}; {first['remedy']}"
