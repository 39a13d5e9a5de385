"""Fig. 6 of the paper reproduction: residual dither after the correcting filter vs the mismatch of its omega0.

On a stationary SINS, quantisation on and off, for both DC forms of eq. 5
and a filter without Nonl; :func:`_quantisation_floor` is the floor that the
readout quantum amplified by eq. 5 leaves.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import optimize

from sins_sim.filters.correcting import CorrectingFilter, CorrectingFilterDesign
from sins_sim.jobs.reproduce.channel import PICKOFF_TRACK_TIME_S, paper_drive, simulate_paper_channel
from sins_sim.jobs.reproduce.common import ReproduceSettings
from sins_sim.models.motion import StaticMotion
from sins_sim.models.readout import ReadoutParams
from sins_sim.models.suspension import SuspensionParams
from sins_sim.units import INTERPOLATED_QUANTUM_RAD


def _fig6(s: SuspensionParams, st: ReproduceSettings, pickoff_gain: float | None = None):
    drive, _, _ = paper_drive(s)
    fd = drive.frequency_hz
    dur = st.fig6_settle_s + st.fig6_measure_s
    ms = np.linspace(st.mismatch_min, st.mismatch_max, st.n_mismatch)
    out = {"m": ms, "fd": fd}
    for label, q in (("quantised", INTERPOLATED_QUANTUM_RAD), ("unquantised", 1e-13)):
        run = simulate_paper_channel(dur, StaticMotion(), s, readout=ReadoutParams(quantum_rad=q),
                                     pickoff_gain0=pickoff_gain, pickoff_adapt_time_s=PICKOFF_TRACK_TIME_S)
        sel = run.t >= st.fig6_settle_s
        x0 = float(run.x[0])

        def rms(m, form, k1=s.k1, run=run, sel=sel, x0=x0):
            d = CorrectingFilterDesign(f0_hz=fd * (1.0 + m), k1=k1, k2=s.k2, k3=s.k3, k4=s.k4, k5=s.k5,
                                       fs_hz=7200.0, form=form)
            y = CorrectingFilter(d, x0=x0).process(run.x, run.volts)[sel]
            return float(np.std(y))

        for form in ("paper", "unity"):
            curve = np.array([rms(m, form) for m in ms])
            k = int(np.argmin(curve))
            lo, hi = ms[max(k - 1, 0)], ms[min(k + 1, ms.size - 1)]
            best = optimize.minimize_scalar(lambda m: rms(m, form), bounds=(lo, hi), method="bounded",
                                            options={"xatol": 2e-6})
            out[(label, form)] = {"rms": curve, "m_opt": float(best.x), "rms_opt": float(best.fun)}
        lin = np.array([rms(m, "paper", k1=0.0) for m in ms])
        k = int(np.argmin(lin))
        best = optimize.minimize_scalar(lambda m: rms(m, "paper", k1=0.0),
                                        bounds=(ms[max(k - 1, 0)], ms[min(k + 1, ms.size - 1)]), method="bounded",
                                        options={"xatol": 2e-6})
        out[(label, "linear")] = {"rms": lin, "m_opt": float(best.x), "rms_opt": float(best.fun)}
        out[(label, "others")] = {name: float(np.std(run.outputs[name][sel])) for name in ("eliminator", "pickoff")}
    return out


def _quantisation_floor(design: CorrectingFilterDesign, readout: ReadoutParams | None = None) -> float:
    """RMS (rad) that white quantisation noise q^2/12 at the input rate leaves after FIR, decimation, eq. 5.

    Noise variance after the FIR and decimation: ``q^2/12 * sum(taps^2)``; eq. 5's
    linear part has taps ``(a2, g - 2 a2, a2)``.
    """
    readout = readout or ReadoutParams()
    taps = readout.taps()
    a2, g = design.coefficients
    gain2 = a2 * a2 + (g - 2.0 * a2) ** 2 + a2 * a2
    return readout.quantum_rad / math.sqrt(12.0) * math.sqrt(float(np.sum(taps * taps)) * gain2)
