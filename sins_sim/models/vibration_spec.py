"""Sine-on-random vibration specifications, as test standards write them, resolved to the vibration models.

A specification is, per body axis, a random background given as a breakpoint table of its acceleration PSD in
g^2/Hz (log-log interpolated between breakpoints, as MIL-STD-810H Method 514.8 [1]_ and its Annex D helicopter
schedules define their spectra), plus sine lines (frequency in Hz, amplitude in g peak). A rotor's lines follow
from its speed and blade count: the blade-passage frequency ``f_b = blades * rotor rate`` and its harmonics
``n f_b``, ``n = 1 .. N``, each with its own amplitude [1]_ [2]_.

The specification resolves to the existing translational models: the background to
:class:`~sins_sim.models.motion.LinearRandomVibration` (independent noise per axis) and each line to
:class:`~sins_sim.models.motion.LinearSines`. Its RMS acceleration is closed-form:

* the background, ``integral_{f_1}^{f_k} G(f) df`` of the piecewise power law ``G(f) = G_i (f / f_i)^b_i``,
  ``b_i = ln(G_{i+1} / G_i) / ln(f_{i+1} / f_i)``, segment by segment
  ``G_i f_i / (b_i + 1) ((f_{i+1} / f_i)^(b_i + 1) - 1)`` (``G_i f_i ln(f_{i+1} / f_i)`` when ``b_i = -1``), the
  integral of a power law (:func:`sins_sim.models.motion.base._loglog_segment_integral`);
* a line of peak ``a`` adds ``a^2 / 2`` (its RMS is ``a / sqrt 2``);
* ``g_rms = sqrt(background + sum a^2 / 2)``.

References
----------
.. [1] MIL-STD-810H, *Environmental Engineering Considerations and Laboratory Tests*, Method 514.8 "Vibration",
   2019, Annex D (operational tailoring guidance; its helicopter category: sinusoids at the rotor's
   blade-passage harmonics over a broadband background). The form is taken from it, no level.
.. [2] W. Johnson, *Helicopter Theory*, Princeton University Press, 1980 (Dover 1994), the chapter on
   helicopter vibration: an N-bladed rotor transmits to the fuselage at ``N Omega`` and its harmonics.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sins_sim import _validate as v
from sins_sim.models.motion import STANDARD_GRAVITY, LinearRandomVibration, LinearSines
from sins_sim.models.motion.base import _loglog_segment_integral, _psd_table

__all__ = ["AxisSpec", "SineOnRandomSpec", "rotor_lines", "loglog_power_g2"]

_AXES = ("x", "y", "z")


def loglog_power_g2(table) -> float:
    """``integral G(f) df`` (g^2) of a breakpoint table ``[(f_hz, G_g2_per_hz), ...]`` interpolated log-log,
    from its first to its last breakpoint (the module's closed form)."""
    t, f_lo, f_hi = _psd_table("psd_g2_per_hz", table, None, None)
    fr, ps = t[:, 0], t[:, 1]
    n_exp = np.log(ps[1:] / ps[:-1]) / np.log(fr[1:] / fr[:-1])
    return float(np.sum(_loglog_segment_integral(fr[:-1], fr[1:], fr[:-1], ps[:-1], n_exp)))


def rotor_lines(rev_s: float, blades: int, amplitudes_g) -> tuple:
    """The lines ``(n blades rev_s, A_n)`` (Hz, g peak) of a rotor turning at ``rev_s`` (rev/s), ``n = 1 .. N``
    for the ``N`` amplitudes given (the blade-passage frequency and its harmonics, [2]_)."""
    v.positive("rotor", "speed_rev_s", rev_s)
    if int(blades) != blades or blades < 1:
        raise ValueError(f"rotor.blades: must be a whole number >= 1, got {blades!r}")
    return tuple((n * int(blades) * float(rev_s), float(a)) for n, a in enumerate(amplitudes_g, start=1))


@dataclass(frozen=True)
class AxisSpec:
    """One axis of a specification: a random background (or None) and sine lines.

    Parameters
    ----------
    psd_g2_per_hz : tuple of (f_hz, g^2/Hz) or None
        The background's breakpoints, frequencies strictly increasing, values > 0.
    lines : tuple of (f_hz, amplitude_g)
        Sine lines, frequency > 0, amplitude (g peak) >= 0.
    """

    psd_g2_per_hz: tuple | None = None
    lines: tuple = ()

    def __post_init__(self):
        if self.psd_g2_per_hz is not None:
            t, _, _ = _psd_table("AxisSpec.psd_g2_per_hz", self.psd_g2_per_hz, None, None)
            object.__setattr__(self, "psd_g2_per_hz", tuple((float(a), float(b)) for a, b in t))
        for i, (f, a) in enumerate(self.lines):
            v.positive("AxisSpec", f"lines[{i}].frequency_hz", f)
            v.non_negative("AxisSpec", f"lines[{i}].amplitude_g", a)
        lines = tuple((float(f), float(a)) for f, a in self.lines)
        seen = [f for f, _ in lines]
        twice = sorted({f for f in seen if seen.count(f) > 1})
        if twice:
            raise ValueError(f"AxisSpec.lines: one line per frequency (a line given twice would be one vibration "
                             f"of summed amplitude, not two), got {twice[0]:g} Hz twice")
        object.__setattr__(self, "lines", lines)

    @property
    def random_power_g2(self) -> float:
        """The background's mean square (g^2), closed form."""
        return 0.0 if self.psd_g2_per_hz is None else loglog_power_g2(self.psd_g2_per_hz)

    @property
    def sine_power_g2(self) -> float:
        """The lines' mean square (g^2): ``sum a^2 / 2``."""
        return float(sum(0.5 * a * a for _, a in self.lines))

    @property
    def grms_g(self) -> float:
        """``sqrt(background + lines)`` (g)."""
        return math.sqrt(self.random_power_g2 + self.sine_power_g2)


@dataclass(frozen=True)
class SineOnRandomSpec:
    """A sine-on-random specification on the three body axes (None: that axis is still).

    Parameters
    ----------
    axes : tuple of 3 (AxisSpec or None)
        x, y, z.
    source : str
        Where the levels come from (reported with the run).
    """

    axes: tuple = (None, None, None)
    source: str = ""

    def __post_init__(self):
        if len(self.axes) != 3 or not any(a is not None for a in self.axes):
            raise ValueError("SineOnRandomSpec.axes: must be three AxisSpec or None, at least one given")

    @property
    def grms_g(self) -> np.ndarray:
        """RMS acceleration per axis (g), closed form (random background plus lines)."""
        return np.array([0.0 if a is None else a.grms_g for a in self.axes])

    def translation(self, seed: int):
        """The specification as a :class:`~sins_sim.models.motion.Translation` (a sum of the existing models).

        One :class:`LinearRandomVibration` for the axes that share a background table (independent noise per
        axis), one per distinct table otherwise; one :class:`LinearSines` per line frequency, each axis's phase
        drawn uniformly from ``seed`` (the specification gives none: a test controller's lines are unphased).
        """
        parts = []
        tables = {}
        for i, a in enumerate(self.axes):
            if a is not None and a.psd_g2_per_hz is not None:
                tables.setdefault(a.psd_g2_per_hz, []).append(i)
        for k, (table, idx) in enumerate(tables.items()):
            w = tuple(1.0 if i in idx else 0.0 for i in range(3))
            parts.append(LinearRandomVibration(psd_table=table, axis_weights=w, seed=(seed + 7919 * (k + 1)) % 2**32))
        freqs = sorted({f for a in self.axes if a is not None for f, _ in a.lines})
        rng = np.random.default_rng([seed, 514])
        for f in freqs:
            amp = [0.0, 0.0, 0.0]
            for i, a in enumerate(self.axes):
                if a is not None:
                    amp[i] = dict(a.lines).get(f, 0.0) * STANDARD_GRAVITY
            parts.append(LinearSines(tuple(amp), (f, f, f), tuple(rng.uniform(-math.pi, math.pi, 3))))
        total = parts[0]
        for p in parts[1:]:
            total = total + p
        return total

    def summary(self) -> dict:
        """What the run reports: the source, per axis the closed-form g_rms and its random and sine parts."""
        out = {"source": self.source, "axes": {}}
        for name, a in zip(_AXES, self.axes):
            if a is None:
                continue
            out["axes"][name] = {"grms_g": a.grms_g, "random_grms_g": math.sqrt(a.random_power_g2),
                                 "sine_grms_g": math.sqrt(a.sine_power_g2),
                                 "band_hz": None if a.psd_g2_per_hz is None else [a.psd_g2_per_hz[0][0],
                                                                                 a.psd_g2_per_hz[-1][0]],
                                 "lines_hz_g": [[f, amp] for f, amp in a.lines]}
        return out

