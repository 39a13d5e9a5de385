"""Identification: fitting model parameters to measured (or simulated) suspension behaviour.

- :mod:`sins_sim.identification.abel`: eq. 6-9, elastic nonlinearity from the
  resonance-vs-amplitude curve (Abel inversion) and the eq. 9 fit.
- :mod:`sins_sim.identification.afc`: steady dither amplitude vs drive
  frequency and voltage (the paper's Fig. 2/4), the fit of omega0, k1..k5 to
  such a set and the sensitivity table.
- :mod:`sins_sim.identification.diagnose`: the sim-to-real diagnosis of a
  recording, one module per step: :mod:`~sins_sim.identification.checks` (the data checks),
  :mod:`~sins_sim.identification.refit`,
  :mod:`~sins_sim.identification.recording_inputs`,
  :mod:`~sins_sim.identification.localise`,
  :mod:`~sins_sim.identification.explain`,
  :mod:`~sins_sim.identification.verdict`,
  :mod:`~sins_sim.identification.report`.
"""
