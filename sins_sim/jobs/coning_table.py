"""The coning table: each filter's heading drift error under coning with several coning algorithms.

One run navigates each filter with one coning algorithm. The other algorithms are compared on
the same increments by an attitude replay: the filter's increments are the motion's true gyro
angle plus the run's recorded gyro-angle error (``SinsResult.spectra``, output minus truth at the
filter rate), differenced; they are integrated with each algorithm
(:func:`sins_sim.navigation.attitude.integrate_attitude`) from the true attitude at the record's
start, and the drift of the attitude error (:func:`sins_sim.navigation.attitude.drift_rate`) about
the cone axis is the heading drift error. The replay leaves out the Earth rate and the
navigation frame (which commute with the cone to far below the coning terms): its two-sample
result equals the full navigation's within 2e-4 relative on ``coning-600hz`` (measured), and the
table states both.

The filter-tuned design (:func:`sins_sim.simulation.responses.tuned_design`) is made for each
filter over the scenario's ``navigation.tuned_band_hz`` or, without one, over
:data:`DEFAULT_BAND` times the coning frequency.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["ALGORITHMS", "DEFAULT_BAND", "coning_frequency_hz", "algorithm_drifts", "band_for", "coning_algorithm_table"]

#: The algorithms of the table.
ALGORITHMS = ("two_sample", "three_sample", "filter_tuned")
#: Default design band of the tuned algorithm, as fractions of the coning frequency.
DEFAULT_BAND = (0.8, 1.2)
#: Increments before the replay's first step (the algorithms' history).
_N_PREV = 3


def coning_frequency_hz(scenario) -> float | None:
    """The coning frequency (Hz) when the scenario's only motion is one ``coning`` part, else None."""
    spec = scenario.motion_spec
    if len(spec) != 1 or spec[0].get("type") != "coning":
        return None
    return float(spec[0]["frequency_hz"])


def band_for(scenario, f_hz: float, fs_hz: float) -> tuple:
    """The tuned design band (Hz): the scenario's ``tuned_band_hz`` or :data:`DEFAULT_BAND` x ``f_hz``."""
    if scenario.nav is not None and scenario.nav.tuned_band_hz is not None:
        return tuple(float(b) for b in scenario.nav.tuned_band_hz)
    return DEFAULT_BAND[0] * f_hz, min(DEFAULT_BAND[1] * f_hz, 0.49 * fs_hz)


def algorithm_drifts(scenario, res, band_hz) -> dict:
    """Heading drift error (deg/h) of each filter with each algorithm of :data:`ALGORITHMS` (replay).

    Parameters
    ----------
    scenario : Scenario
        A scenario whose motion is one ``coning`` part (the cone axis is body z).
    res : SinsResult
        Its run, with the gyro-angle error records (``spectra``).
    band_hz : (float, float)
        The tuned design band (Hz).

    Returns
    -------
    dict
        ``{filter: {algorithm: deg/h}}`` (``filter_tuned`` None for a plug-in without a frequency
        response); empty when the record is too short.
    """
    from sins_sim.navigation.attitude import attitude_error, drift_rate, integrate_attitude
    from sins_sim.simulation.sins import tuned_designs

    t = res.spectra.get("t") if res.spectra else None
    if t is None or len(t) < 4 * _N_PREV:
        return {}
    names = [n for n in res.filters if n in res.spectra and len(res.spectra[n]) == len(t)]
    designs = {}
    for name in names:  # a plug-in without a frequency response has no tuned design: None in the table
        try:
            designs.update(tuned_designs(scenario.imu, [name], band_hz))
        except ValueError:
            designs[name] = None
    angle = scenario.motion.gyro_angle(t)
    q_true = scenario.motion.attitude(t)
    k = _N_PREV
    out = {}
    for name in names:
        dth = np.diff(angle + res.spectra[name], axis=0)
        row = {}
        for alg in ALGORITHMS:
            if alg == "filter_tuned" and designs[name] is None:
                row[alg] = None
                continue
            coef = designs[name]["coefficients"] if alg == "filter_tuned" else alg
            q = integrate_attitude(dth[k:], q_true[k], coef, dtheta_prev=dth[:k])
            slope = drift_rate(attitude_error(q, q_true[k:]), t[k:] - t[k])
            row[alg] = math.degrees(float(slope[2])) * 3600.0
        out[name] = row
    return out


def coning_algorithm_table(by_filter: dict) -> str:
    """Markdown table: per filter and coning frequency, ``two-sample / three-sample / filter-tuned`` (deg/h).

    Parameters
    ----------
    by_filter : dict
        ``{filter: {frequency label: {algorithm: deg/h} or None}}``.
    """
    freqs = list(next(iter(by_filter.values())))
    lines = ["Heading drift error (deg/h) by coning algorithm, `two-sample / three-sample / filter-tuned` "
             "(attitude replay of each filter's increments; the tuned design over 0.8-1.2 x the coning "
             "frequency unless the scenario sets `navigation.tuned_band_hz`):", "",
             "| filter | " + " | ".join(f"{k} Hz" for k in freqs) + " |", "|---|" + "---|" * len(freqs)]
    for name, row in by_filter.items():
        cells = []
        for k in freqs:
            r = row.get(k)
            cells.append("n/a" if not r else " / ".join("n/a" if r[a] is None else f"{r[a]:.3g}" for a in ALGORITHMS))
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"
