"""Fig. 7 of the paper reproduction: the response of every filter to an impact on the SINS.

:func:`impact_motion` is a half-sine rate pulse (a 3 arcmin step in 0.3 ms)
followed by a decaying 1.6 kHz block vibration; :func:`impact_error` the
RMS error it leaves; the eliminator's ringing period is measured from the
error's zero crossings.
"""

from __future__ import annotations

import math

import numpy as np

from sins_sim.jobs.reproduce.channel import PICKOFF_TRACK_TIME_S, PaperChannelRun, simulate_paper_channel
from sins_sim.jobs.reproduce.common import ReproduceSettings
from sins_sim.models.motion import CallableMotion
from sins_sim.models.suspension import SuspensionParams
from sins_sim.units import ARCMIN

__all__ = ["impact_motion", "impact_error"]


def impact_motion(t_imp: float, step_rad: float = 3.0 * ARCMIN, pulse_s: float = 0.3e-3,
                  vib_rad: float = 0.5 * ARCMIN, vib_hz: float = 1600.0, vib_decay_s: float = 4e-3):
    """Impact on the SINS at ``t_imp``: a half-sine rate pulse (angle step ``step_rad`` in ``pulse_s``)
    followed by a decaying block vibration ``vib_rad e^{-t/tau} sin(2 pi f t)`` starting at the pulse's end."""
    r_peak = step_rad * math.pi / (2.0 * pulse_s)
    wv = 2.0 * math.pi * vib_hz

    def f(t):
        tau = t - t_imp
        inside = (tau > 0.0) & (tau < pulse_s)
        after = tau >= pulse_s
        ang = np.where(inside, step_rad * 0.5 * (1.0 - np.cos(math.pi * tau / pulse_s)), 0.0)
        ang = np.where(after, step_rad, ang)
        rate = np.where(inside, r_peak * np.sin(math.pi * tau / pulse_s), 0.0)
        tv = np.maximum(tau - pulse_s, 0.0)
        env = np.exp(-tv / vib_decay_s)
        ang = ang + np.where(after, vib_rad * env * np.sin(wv * tv), 0.0)
        rate = rate + np.where(after, vib_rad * env * (wv * np.cos(wv * tv) - np.sin(wv * tv) / vib_decay_s), 0.0)
        return ang, rate

    return CallableMotion(f)


def _ring_period_ms(t, err, t0, t1):
    """Mean period (ms) of ``err`` over [t0, t1] from its zero crossings (about its mean); and the frequency."""
    m = (t >= t0) & (t <= t1)
    tt = t[m]
    e = err[m] - err[m].mean()
    k = np.flatnonzero(np.sign(e[:-1]) * np.sign(e[1:]) < 0)
    if k.size < 3:
        return math.nan, math.nan
    tz = tt[k] - e[k] * (tt[k + 1] - tt[k]) / (e[k + 1] - e[k])
    period = 2.0 * (tz[-1] - tz[0]) / (tz.size - 1)
    return 1e3 * period, 1.0 / period


def impact_error(run: PaperChannelRun, name: str, t_imp: float, before_s: float = 0.005,
                 after_s: float = 0.03) -> float:
    """RMS (rad) over ``[t_imp, t_imp + after_s]`` of output minus truth, less its mean over the ``before_s`` before.

    Removing the pre-impact error leaves the response to the impact itself
    (for the paper form: its scale error ``B - 1`` times the step, not times
    whatever angle the block had before).
    """
    ts = run.t - run.delays_s[name]
    err = run.outputs[name] - run.truth(name)
    pre = (ts >= t_imp - before_s) & (ts < t_imp)
    post = (ts >= t_imp) & (ts <= t_imp + after_s)
    e = err[post] - (err[pre].mean() if np.any(pre) else 0.0)
    return float(np.sqrt(np.mean(e * e)))


def _fig7(s: SuspensionParams, st: ReproduceSettings, pickoff_gain: float | None = None):
    t_imp = st.impact_settle_s
    motion = impact_motion(t_imp)
    out = {}
    for rule in ("paper", "masing"):
        run = simulate_paper_channel(t_imp + 0.06, motion, s, hysteresis=rule, align_hz=0.0,
                                     pickoff_gain0=pickoff_gain, pickoff_adapt_time_s=PICKOFF_TRACK_TIME_S)
        out[rule] = run
    run = out["paper"]
    err = run.outputs["eliminator"] - run.truth("eliminator")
    # after the first 5 ms (the step itself and the 1.6 kHz vibration) the error is the eliminator's ringing
    period_ms, ring_hz = _ring_period_ms(run.t - run.delays_s["eliminator"], err, t_imp + 0.005, t_imp + 0.055)
    win = (run.t >= t_imp - 0.005) & (run.t <= t_imp + 0.03)
    names = ("eliminator", "correcting", "correcting_paper", "pickoff")
    errs = {name: impact_error(out["paper"], name, t_imp) for name in names}
    errs_masing = {name: impact_error(out["masing"], name, t_imp) for name in names}
    return {"runs": out, "t_imp": t_imp, "win": win, "ring_period_ms": period_ms, "ring_hz": ring_hz,
            "err_rms": errs, "err_rms_masing": errs_masing}
