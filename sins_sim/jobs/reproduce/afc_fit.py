"""Fig. 4 of the paper reproduction: the AFC fit of omega0, k1..k5 and the sensitivity table.

Steady dither amplitude at 4 voltages x 10 frequencies (:func:`afc_design`)
of a stand-in measurement (parameters slightly off, plus reading noise),
fitted with ``sins_sim.identification.afc``, and the sensitivity of the fit
to each parameter.
"""

from __future__ import annotations

import time

import numpy as np

from sins_sim.identification.afc import (AfcSettings, fit_afc, hb_amplitudes, params_vector, sensitivity, simulate_afc,
                                         with_params)
from sins_sim.jobs.reproduce.common import ReproduceSettings
from sins_sim.models.suspension import PAPER_SUSPENSION, SuspensionParams
from sins_sim.units import ARCMIN, ARCSEC

__all__ = ["afc_design"]


def afc_design(s: SuspensionParams = PAPER_SUSPENSION):
    """The AFC set: voltages for 1.5, 2.25, 3 and 3.75 arcmin at resonance, 10 frequencies 381.5-387 Hz."""
    peaks = np.array([1.5, 2.25, 3.0, 3.75]) * ARCMIN
    volts = np.array([s.drive_voltage(a) for a in peaks])
    freqs = np.linspace(381.5, 387.0, 10)
    return volts, freqs, peaks


def _fig4(s: SuspensionParams, st: ReproduceSettings, seed: int = 1):
    volts, freqs, peaks = afc_design(s)
    rng = np.random.default_rng(seed)
    # the stand-in for the measurement: slightly different parameters, plus reading noise
    rel = np.array([0.001, 0.02, 0.02, 0.02, 0.02, 0.02]) * rng.standard_normal(6)
    truth = with_params(s, params_vector(s) * (1.0 + rel))
    clean = simulate_afc(truth, volts, freqs, AfcSettings(settle_s=st.afc_truth_settle_s))
    measured = clean + st.afc_noise_arcsec * ARCSEC * rng.standard_normal(clean.shape)
    settings = AfcSettings(settle_s=st.afc_settle_s)
    t0 = time.perf_counter()
    fit = fit_afc(measured, volts, freqs, s, settings, max_nfev=st.afc_max_nfev)
    t_fit = time.perf_counter() - t0
    sens = sensitivity(fit.params, measured, volts, freqs, settings, pct=1.0)
    fdense = np.linspace(freqs[0] - 0.5, freqs[-1] + 0.5, 200)
    hb = np.array([[hb_amplitudes(fit.params, vm, f)[-1] for f in fdense] for vm in volts])
    return {"volts": volts, "freqs": freqs, "peaks": peaks, "truth": truth, "rel": rel, "measured": measured,
            "clean": clean, "fit": fit, "sens": sens, "fdense": fdense, "hb": hb, "t_fit": t_fit,
            "start_model": simulate_afc(s, volts, freqs, settings)}
