"""Fig. 5 of the paper reproduction: the end-to-end AFC (flatness) of every filter.

The gain from a 1 arcmin SINS sine (80 to 3600 Hz) to each filter's output,
simulated on the nonlinear plant (:func:`_fig5`), beside the linear analytic
curves (:func:`_fig5_analytic`); the largest deviation per band and the
eliminator's roll-off slope.
"""

from __future__ import annotations

import math

import numpy as np

from sins_sim.filters.correcting import CorrectingFilterDesign
from sins_sim.filters.eliminator import EliminatorDesign
from sins_sim.jobs.reproduce.channel import PICKOFF_TRACK_TIME_S, paper_drive, simulate_paper_channel
from sins_sim.jobs.reproduce.common import BANDS, FILTERS, ReproduceSettings
from sins_sim.jobs.reproduce.responses import fir_response, mechanical_response
from sins_sim.models.motion import SineMotion
from sins_sim.models.pickoff import PickoffParams
from sins_sim.models.readout import ReadoutParams
from sins_sim.models.suspension import SuspensionParams
from sins_sim.units import ARCMIN


def _sine_amplitude(y, t, f_hz, extra_hz=()):
    """Amplitude at ``f_hz`` from a least-squares fit with a constant, a ramp and sines at ``extra_hz``."""
    cols = [np.ones_like(t), t - t.mean()]
    for f in (f_hz, *extra_hz):
        w = 2.0 * math.pi * f
        cols += [np.sin(w * t), np.cos(w * t)]
    m = np.column_stack(cols)
    coef, *_ = np.linalg.lstsq(m, y, rcond=None)
    return float(math.hypot(coef[2], coef[3]))


def _band_max_dev(freqs, gains_db):
    out = {}
    for key, (lo, hi) in BANDS.items():
        m = (freqs >= lo) & (freqs <= hi)
        out[key] = float(np.max(np.abs(gains_db[m]))) if np.any(m) else math.nan
    return out


def _fig5(s: SuspensionParams, st: ReproduceSettings, progress=None, hysteresis: str = "paper",
          pickoff_gain: float | None = None):
    # log-spaced, plus the band edges of afc_max_dev_db so that each band is measured to its end
    freqs = np.unique(np.concatenate((np.geomspace(80.0, st.fig5_top_hz, st.n_fig5), [1000.0, 2000.0, 3000.0])))
    drive, _, _ = paper_drive(s)
    fd = drive.frequency_hz
    amp = 1.0 * ARCMIN
    gains = {name: np.empty(freqs.size) for name in FILTERS}
    fast = []
    dur = st.fig5_settle_s + st.fig5_measure_s
    for i, f in enumerate(freqs):
        run = simulate_paper_channel(dur, SineMotion(amp, float(f)), s, hysteresis=hysteresis, align_hz=float(f),
                                     pickoff_gain0=pickoff_gain, pickoff_adapt_time_s=PICKOFF_TRACK_TIME_S)
        m = run.t >= st.fig5_settle_s
        extra = [k * fd for k in (1, 2, 3) if abs(k * fd - f) > 0.5 and k * fd < 3600.0]
        for name in FILTERS:
            gains[name][i] = _sine_amplitude(run.outputs[name][m], run.t[m], float(f), extra) / amp
        fast.append(run.fast_half_cycles)
        if progress is not None:
            progress((i + 1) / freqs.size)
    gains_db = {k: 20.0 * np.log10(g) for k, g in gains.items()}
    return {"freqs": freqs, "gains": gains, "gains_db": gains_db, "fd": fd, "fast": fast,
            "max_dev": {k: _band_max_dev(freqs, gains_db[k]) for k in ("correcting", "correcting_paper",
                                                                       "eliminator", "pickoff", "raw")}}


def _fig5_analytic(s: SuspensionParams, fd: float):
    readout = ReadoutParams()
    f = np.geomspace(60.0, 3600.0, 1500)
    q = s.q_factor(3.0 * ARCMIN)
    mech = mechanical_response(f, s.f0_hz, q)
    fir = fir_response(readout, f)
    elim = EliminatorDesign.paper().frequency_response(f)
    out = {"f": f, "mech": mech * fir, "eliminator": mech * fir * elim}
    for form, key in (("unity", "correcting"), ("paper", "correcting_paper")):
        d = CorrectingFilterDesign(f0_hz=s.f0_hz, fs_hz=7200.0, form=form)
        out[key] = mech * fir * d.frequency_response(f) * np.exp(2j * math.pi * f / 7200.0)
    pk = PickoffParams()
    # deflection estimate / deflection: the lag and scale error, the LMS gain scaling it back at the dither
    lag = 1.0 / (1.0 + 2j * math.pi * f * pk.lag_s)
    g = 1.0 / (pk.sensitivity * np.real(1.0 / (1.0 + 2j * math.pi * fd * pk.lag_s)))
    est = g * pk.sensitivity * lag
    out["pickoff"] = fir * (mech - (mech - 1.0) * est)
    out["fir"] = fir
    return out


def _slope_db_per_octave(freqs, gains_db, lo, hi):
    m = (freqs >= lo) & (freqs <= hi)
    if np.count_nonzero(m) < 2:
        return math.nan
    c = np.polyfit(np.log2(freqs[m]), gains_db[m], 1)
    return float(c[0])
