"""Reproduce the paper: every figure and headline number with the project's own models and filters.

``run_reproduce(out_dir, quick=False)`` writes into ``out_dir``:

- ``fig1_correcting_afc.png``: AFC of the mechanical filter (kinematic input,
  curve 1), of the analog correcting filter (eq. 3 inverted, curve 2) and of
  the digital one (eq. 4, both DC forms, curve 3) at dT = 0.139 ms;
- ``fig3_resonance_vs_amplitude.png``: F(a) implied by eq. 9, by free-decay
  simulation of the plant and by harmonic balance / exact period;
- ``fig3_abel_nonl.png``: Nonl(phi) recovered from ten samples of F(a) by
  eq. 7-8 and the eq. 9 fit;
- ``fig4_afc_fit.png``: steady dither amplitude at 4 voltages x 10
  frequencies, the fit of omega0, k1..k5, and the sensitivity table;
- ``fig5_end_to_end_afc.png``: gain from a 1 arcmin SINS sine (80 to 3600 Hz)
  to each filter's output, simulated on the nonlinear plant, beside the
  linear analytic curves;
- ``fig6_mismatch.png``: residual dither RMS after the correcting filter vs
  the relative mismatch of its omega0, quantisation on and off;
- ``fig7_impact.png``: response to an impact on the SINS;
- ``numbers.json`` and ``report.md`` (paper vs sins-sim, with explanations).

Nothing is tuned to a printed number: the paper's parameters go in, what the
equations give comes out, and the report explains each disagreement.

Common set-up (docs/user-guide/paper.md): the paper's suspension (f0 = 386 Hz,
k1..k4 as printed, Q = 187 at 3 arcmin), driven at the amplitude-dependent
resonance F(3 arcmin) = 383.88 Hz by the eq. 17 voltage; plant at 72 kHz,
fringe counter with the paper's 1/16-fringe quantum, 21-tap anti-alias FIR,
decimation to 7.2 kHz; the eliminator is the paper's 370-410 Hz 10th-order
elliptic band-stop; the correcting filter knows the true parameters unless a
mismatch is the point. Runs start on the steady dither (the harmonic-balance
state, reached by a two-step rotation of the block at t = 0, see
``sins_sim.identification.afc.kick_motion``) so that only the filters' own
transients have to settle.

The job is split by figure and finding, re-exported here:

- :mod:`~sins_sim.jobs.reproduce.common`: the paper's printed numbers
  (``PAPER``) and the run's resolution (``ReproduceSettings``);
- :mod:`~sins_sim.jobs.reproduce.channel`: one channel started on the steady
  dither, with every filter and the pickoff baseline;
- :mod:`~sins_sim.jobs.reproduce.responses`: analytic responses and Fig. 1;
- :mod:`~sins_sim.jobs.reproduce.resonance`: free decay, F(a) and the Abel
  inversion (Fig. 3);
- :mod:`~sins_sim.jobs.reproduce.afc_fit`: the AFC fit and its sensitivity
  table (Fig. 4);
- :mod:`~sins_sim.jobs.reproduce.flatness`: end-to-end AFC of every filter
  (Fig. 5);
- :mod:`~sins_sim.jobs.reproduce.mismatch`: residual dither vs the correcting
  filter's mismatch (Fig. 6);
- :mod:`~sins_sim.jobs.reproduce.impact`: response to an impact (Fig. 7);
- :mod:`~sins_sim.jobs.reproduce.job`: :func:`run_reproduce`, the numbers;
- :mod:`~sins_sim.jobs.reproduce.report`: ``report.md``.
"""

from __future__ import annotations

from sins_sim.jobs.reproduce.afc_fit import afc_design
from sins_sim.jobs.reproduce.channel import (PICKOFF_TRACK_TIME_S, PaperChannelRun, calibrate_pickoff, paper_drive,
                                             simulate_paper_channel)
from sins_sim.jobs.reproduce.common import BANDS, FILTERS, PAPER, ReproduceSettings  # noqa: F401 (re-exported)
from sins_sim.jobs.reproduce.impact import impact_error, impact_motion
from sins_sim.jobs.reproduce.job import run_reproduce
from sins_sim.jobs.reproduce.resonance import free_decay
from sins_sim.jobs.reproduce.responses import fir_response, mechanical_response

__all__ = ["ReproduceSettings", "run_reproduce", "simulate_paper_channel", "PaperChannelRun", "PAPER", "paper_drive",
           "calibrate_pickoff", "free_decay", "impact_motion", "impact_error", "mechanical_response", "fir_response",
           "afc_design", "PICKOFF_TRACK_TIME_S"]
