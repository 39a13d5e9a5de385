"""Analytic responses of the paper reproduction and Fig. 1 (AFC of the mechanical and correcting filters).

:func:`mechanical_response` is eq. 3 with hysteretic damping (the kinematic
AFC ``phi_sins -> phi_rlg``), :func:`fir_response` the anti-alias FIR; Fig. 1
sets the mechanical filter beside the analog (eq. 3 inverted) and digital
(eq. 4, both DC forms) correcting filters at dT = 0.139 ms.
"""

from __future__ import annotations


import numpy as np

from sins_sim.filters.correcting import CorrectingFilterDesign
from sins_sim.jobs.reproduce.common import PAPER
from sins_sim.models.suspension import SuspensionParams
from sins_sim.simulation.responses import fir_response, mechanical_response
from sins_sim.units import ARCMIN

__all__ = ["mechanical_response", "fir_response"]


def _fig1(s: SuspensionParams):
    dt = PAPER["fig1_dt_s"]
    fs = 1.0 / dt
    f = np.linspace(0.5, fs - 0.5, 4000)
    q = s.q_factor(3.0 * ARCMIN)
    mech = mechanical_response(f, s.f0_hz, q)
    analog = np.abs(1.0 - (f / s.f0_hz) ** 2)
    paper = CorrectingFilterDesign(f0_hz=s.f0_hz, fs_hz=fs, form="paper")
    unity = CorrectingFilterDesign(f0_hz=s.f0_hz, fs_hz=fs, form="unity")
    return {"f": f, "fs": fs, "q": q, "mech": np.abs(mech), "analog": analog,
            "digital_paper": np.abs(paper.frequency_response(f)), "digital_unity": np.abs(unity.frequency_response(f)),
            "f0": s.f0_hz, "dc_gain_paper_0139": paper.dc_gain, "nyquist_gain_paper_0139": paper.nyquist_gain}
