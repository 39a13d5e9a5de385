"""Calibration of the held-out test that ranks candidates (issue 39, item 2).

The verdict declares one candidate better than another when the held-out Diebold-Mariano test
(:func:`~sins_sim.identification.verdict.dm_pvalue`) rejects "no better" at
:data:`~sins_sim.identification.verdict.AHEAD_ALPHA`.
On a pair of candidates the recording cannot tell apart, that test must not prefer the wrong one more
often than its level says. :func:`false_preference` measures it on the project's own generator: each
recording carries the ``true`` effect, the diagnosis fits both candidates (and only them: the held-out
comparison of two candidates does not depend on the others), and the wrong candidate is *falsely
preferred* when the one-sided test of "the rival predicts the held-out blocks no better than the true
effect" rejects at the level. The same count the other way (the true effect declared better) is the
test's power where the pair is distinguishable.

The near-degenerate pairs (:data:`NEAR_DEGENERATE`), each on a dither-only (``stationary``) recording:

``piezo_lag`` / ``readout_delay``
    a first-order drive lag and a readout delay both delay the narrow-band dither response (issue 24,
    item 5; ``sins_sim.identification.discriminate``);
``readout_delay`` / ``piezo_lag``
    the same pair with the readout delay true;
``viscous_damping`` / ``block_mode`` (rate table)
    a critically damped mount mode far above the table lines is a phase lead of the table motion, which
    a viscous loss gives as well (``verdict``'s "Parsimony"): the mode's three parameters reshape the lines
    as the damping law does with one.

The distinguishable pair (:data:`DISTINGUISHABLE`) is the first on the rate table, whose vibration lines
the readout delay delays and the drive lag does not.

The unit is drawn as ``diagnose-eval --hard`` draws it (:mod:`~sins_sim.identification.blind_hard`: the
nominal resonance log-uniform in 300-450 Hz, the truth off the header by 0.2 % in f0 and 5 % in k1..k5,
integrated at 72 kHz), with white readout noise of 0.05 arcsec.

.. autosummary::

   calibration_case
   pair_pvalues
   false_preference
"""

from __future__ import annotations

import math

import numpy as np
from scipy import stats

from sins_sim.identification.diagnose import DiagnoseSettings, diagnose_recording
from sins_sim.identification.verdict import AHEAD_ALPHA, dm_pvalue
from sins_sim.models.effects import make_effect
from sins_sim.models.suspension import SuspensionParams
from sins_sim.simulation.experiment import (ExperimentInputs, ExperimentSettings, record, stationary_drive,
                                            table_motion)
from sins_sim.units import ARCMIN, ARCSEC, DEG, INTERPOLATED_QUANTUM_RAD

__all__ = ["NEAR_DEGENERATE", "DISTINGUISHABLE", "calibration_case", "pair_pvalues", "false_preference",
           "binomial_margin"]

#: Near-degenerate pairs ``(true effect, rival, experiment)`` (see the module docstring).
NEAR_DEGENERATE = (("piezo_lag", "readout_delay", "stationary"), ("readout_delay", "piezo_lag", "stationary"),
                   ("viscous_damping", "block_mode", "rate_table"))
#: A pair the rate table tells apart: the test's power.
DISTINGUISHABLE = (("piezo_lag", "readout_delay", "rate_table"),)
#: Sample rate of the calibration recordings (Hz), as the blind sets'.
FS = 7200.0
#: The effects' strengths (log-uniform ranges), those of ``diagnose-eval --hard``'s near-degenerate class.
STRENGTH = {"piezo_lag": ("tau_s", 5e-5, 3e-4), "readout_delay": ("delay_s", 2e-5, 1.5e-4),
            "viscous_damping": ("zeta", 4e-4, 3e-3)}


def _log_uniform(rng, lo, hi):
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def calibration_case(true: str, seed: int, duration_s: float = 1.0, experiment: str = "stationary",
                     noise_arcsec: float = 0.05):
    """One recording carrying ``true`` at a drawn strength, and the effect's parameters: ``(Recording, dict)``."""
    from sins_sim.identification.blind import perturbed_unit

    rng = np.random.default_rng([int(seed), 39])
    axes = ["x"]
    nominal = {"x": SuspensionParams(f0_hz=_log_uniform(rng, 300.0, 450.0))}
    truth = perturbed_unit(nominal, axes, rng)
    amp = rng.uniform(2.5, 3.5) * ARCMIN
    n = int(round(duration_s * FS)) + 1
    drive = stationary_drive(nominal, axes, amp, FS, n)
    table = None
    if experiment == "rate_table":
        rate = (1.0 if rng.uniform() < 0.5 else -1.0) * rng.uniform(5.0, 20.0) * DEG
        table = {"x": table_motion(rate, [(30 * ARCMIN, 7.0, rng.uniform(0, 6.3)),
                                          (3 * ARCMIN, 80.0, rng.uniform(0, 6.3)),
                                          (1 * ARCMIN, 230.0, rng.uniform(0, 6.3))])}
    key, lo, hi = STRENGTH[true]
    p = {key: _log_uniform(rng, lo, hi)}
    inputs = ExperimentInputs(axes, FS, n, FS, drive, table)
    rec = record(inputs, truth, nominal, INTERPOLATED_QUANTUM_RAD, [make_effect(true, axes=axes, **p)],
                 ExperimentSettings(plant_rate_hz=72000.0, integrator="exact"), noise_rad=noise_arcsec * ARCSEC,
                 seed=int(rng.integers(2 ** 31)), experiment=experiment, description="held-out test calibration")
    return rec, p


def pair_pvalues(rec, true: str, rival: str, settings: DiagnoseSettings | None = None) -> dict:
    """The held-out test between the pair on one recording.

    Returns ``p_wrong`` (the rival predicts better than the true effect), ``p_right`` (the reverse), both
    candidates' ``gap_reduction`` and the diagnosis' verdict.
    """
    settings = settings or DiagnoseSettings(threads=1)
    from dataclasses import replace

    d = diagnose_recording(rec, replace(settings, effects=(true, rival)))
    c = {x["effect"]: x for x in d.candidates}
    if true not in c or rival not in c:  # no significant gap: neither was fitted, nothing is preferred
        return {"p_wrong": 1.0, "p_right": 1.0, "gap_reduction": {}, "verdict": d.verdict["effect"],
                "d": []}
    d_blocks = np.log(c[true]["_losses"]) - np.log(c[rival]["_losses"])
    return {"p_wrong": dm_pvalue(c[true]["_losses"], c[rival]["_losses"]), "d": d_blocks.tolist(),
            "p_right": dm_pvalue(c[rival]["_losses"], c[true]["_losses"]),
            "gap_reduction": {true: c[true]["gap_reduction"], rival: c[rival]["gap_reduction"]},
            "verdict": d.verdict["effect"]}


def binomial_margin(n: int, level: float, confidence: float = 0.99) -> int:
    """Largest count of false preferences out of ``n`` that a test of exact size ``level`` exceeds with
    probability below ``1 - confidence``: the ``confidence`` quantile of Binomial(n, level)."""
    return int(stats.binom.ppf(confidence, n, level))


def false_preference(true: str, rival: str, seeds, experiment: str = "stationary", duration_s: float = 1.0,
                     level: float = AHEAD_ALPHA, settings: DiagnoseSettings | None = None) -> dict:
    """How often the held-out test prefers ``rival`` over the ``true`` effect at ``level`` (see the module docstring).

    Returns ``n``, ``false`` and ``false_rate`` (the rival declared better), ``right`` and ``power`` (the true
    effect declared better), ``level`` and the per-recording ``p_wrong`` / ``p_right``.
    """
    rows = []
    for s in seeds:
        rec, p = calibration_case(true, s, duration_s, experiment)
        rows.append({"seed": int(s), "params": p, **pair_pvalues(rec, true, rival, settings)})
    n = len(rows)
    wrong = sum(r["p_wrong"] < level for r in rows)
    right = sum(r["p_right"] < level for r in rows)
    return {"true": true, "rival": rival, "experiment": experiment, "duration_s": float(duration_s),
            "level": float(level), "n": n, "false": int(wrong), "false_rate": wrong / n, "right": int(right),
            "power": right / n, "rows": rows}
