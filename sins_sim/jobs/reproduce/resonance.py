"""Fig. 3 of the paper reproduction: the resonance F(a) vs amplitude and Nonl(phi) by Abel inversion.

F(a) as eq. 9 implies it (harmonic balance and exact period) and as a
free-decay simulation of the plant gives it (:func:`free_decay`); Nonl(phi)
recovered from ten samples of F(a) by eq. 7-8 and the eq. 9 fit
(``sins_sim.identification.abel``).
"""

from __future__ import annotations

import numpy as np

from sins_sim.identification.abel import identify_nonl
from sins_sim.identification.afc import kick_motion
from sins_sim.jobs.reproduce.common import ReproduceSettings
from sins_sim.models.plant import Plant, PlantSettings
from sins_sim.models.suspension import SuspensionParams
from sins_sim.units import ARCMIN

__all__ = ["free_decay"]


def free_decay(s: SuspensionParams, a0: float, duration_s: float, rate_hz: float = 72000.0):
    """Free oscillation of the plant started at amplitude ``a0`` by the block kick (no drive).

    Returns per-cycle ``(amplitude, frequency)``: frequency = 1 / time between
    successive upward zero crossings (cubic interpolation of the samples),
    amplitude = half the peak-to-peak over that cycle.
    """
    plant = Plant(s, PlantSettings(rate_hz=rate_hz))
    plant.reset(0.0, 0.0)
    n = int(round(duration_s * rate_hz))
    t = np.arange(n + 1) / rate_hz
    kick, _ = kick_motion(a0, rate_hz)
    ang, rate = kick.angle_rate(t[1:])
    d = np.concatenate(([0.0], plant.step(ang, rate, np.zeros(n))))
    idx = np.flatnonzero((d[:-1] < 0.0) & (d[1:] >= 0.0))
    idx = idx[(idx >= 1) & (idx + 2 < d.size)]
    tz = []
    for k in idx:
        c = np.polyfit(t[k - 1:k + 3] - t[k], d[k - 1:k + 3], 3)
        roots = np.roots(c)
        roots = roots[np.abs(roots.imag) < 1e-12].real
        roots = roots[(roots >= -1e-12) & (roots <= 1.0 / rate_hz + 1e-12)]
        if roots.size:
            tz.append(t[k] + roots[0])
    tz = np.array(tz)
    amp, freq = [], []
    for t0, t1 in zip(tz[:-1], tz[1:]):
        m = (t >= t0) & (t < t1)
        amp.append(0.5 * (d[m].max() - d[m].min()))
        freq.append(1.0 / (t1 - t0))
    return np.array(amp), np.array(freq)


def _fig3(s: SuspensionParams, st: ReproduceSettings):
    amp, freq = free_decay(s, 6.0 * ARCMIN, st.decay_s)
    grid = np.linspace(0.1, 6.0, 60) * ARCMIN
    hb = np.array([s.resonance_hz(a) for a in grid])
    exact = np.array([s.resonance_hz_exact(a) for a in grid])
    order = np.argsort(amp)
    samples_a = np.linspace(0.5, 5.0, st.abel_samples) * ARCMIN
    samples_f = np.interp(samples_a, amp[order], freq[order])
    exact_f = np.array([s.resonance_hz_exact(a) for a in samples_a])
    res_sim, fit_sim = identify_nonl(samples_a, samples_f, passes=1)
    res_exact, fit_exact = identify_nonl(samples_a, exact_f, passes=1)
    res_paper, fit_paper = identify_nonl(samples_a, samples_f, refine_f0=False, amplitude="energy")
    a3 = 3.0 * ARCMIN
    f_sim_3 = float(np.interp(a3, amp[order], freq[order]))
    return {
        "decay_amp": amp, "decay_freq": freq, "grid": grid, "hb": hb, "exact": exact,
        "samples_a": samples_a, "samples_f": samples_f,
        "abel_sim": res_sim, "fit_sim": fit_sim, "abel_exact": res_exact, "fit_exact": fit_exact,
        "abel_paper": res_paper, "fit_paper": fit_paper, "f_sim_3": f_sim_3,
        "k1": s.k1, "k2": s.k2, "f0": s.f0_hz,
    }
