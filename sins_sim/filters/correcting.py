"""The correcting digital filter of the paper, eq. 5, in both forms of the spec.

- ``form="paper"``: eq. 5 as printed; DC gain ``B = 2 (1 - cos w)/w^2``
  (0.99058 at 386 Hz, 7.2 kHz), a -0.94 % scale error on steady rotation.
- ``form="unity"`` (default): ``1/w^2`` replaced by ``1/(2 (1 - cos w))`` and
  ``B`` by 1; same notch at omega0, unit DC gain.

The output ``Y_n`` describes the block at ``t_{n-1}``: it is one sample late
(``delay_samples = 1``); align before comparing with truth.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from sins_sim import _validate as v
from sins_sim._kernels import correcting as kcor
from sins_sim._kernels import physics as kphys
from sins_sim.errors import warn_regime

__all__ = ["FORMS", "CorrectingFilterDesign", "CorrectingFilter", "correct"]

FORMS = ("unity", "paper")
#: A deflection estimate beyond this (rad, ~172 arcmin, 50 x the paper's dither) is unphysical.
D_LIMIT_RAD = 0.05

# Physical ranges of what the filter believes (issue 12, point 4): the same numbers, and the same reasons,
# as sins_sim.models.suspension (the layers keep filters and models apart, so they are repeated here).
#: f0 (Hz): dither suspensions resonate at 100-1500 Hz; 20-5000 Hz is refused outside.
F0_RANGE_HZ = (20.0, 5000.0)
#: k1 <= 0.1 and k1 < 2 k2 (the spring keeps its stiffness); k2 in [1e-6, 0.1] rad; k3 <= 0.2 (Q >= 5);
#: k4 in [-20, 1e4] /rad; |k5| <= 1e-2 rad/V (0: a drive-free filter); and the loss k3 (1 + k4 a) below 1 for
#: every deflection a up to D_LIMIT_RAD (eq. 5 inverts eq. 10 on its own D and runs away otherwise).
K1_MAX, K2_RANGE_RAD, K3_MAX, K4_RANGE_PER_RAD, K5_MAX_RAD_PER_V = 0.1, (1e-6, 0.1), 0.2, (-20.0, 1.0e4), 1.0e-2
#: Filter rate (Hz): at most 1 MHz (the readout's limit).
FS_MAX_HZ = 1.0e6


def _within(field: str, value: float, lo: float, hi: float, unit: str = "") -> None:
    if not lo <= value <= hi:
        raise ValueError(f"correcting.{field}: must be in [{lo:g}, {hi:g}]{' ' + unit if unit else ''}, got {value!r}")


@dataclass(frozen=True)
class CorrectingFilterDesign:
    """Parameters of the correcting filter (the paper's equation 5) for one channel.

    Parameters
    ----------
    f0_hz : float
        The filter's omega0 / 2 pi (Hz). The paper offsets it from the drive
        frequency by the "relative mismatch" (Fig. 6).
    k1, k2, k3, k4, k5 : float
        Suspension model parameters (eq. 9, 10, 14) as the filter believes them.
    fs_hz : float
        Filter rate (Hz), default 7.2 kHz; must exceed 2 f0 (w = omega0 dT < pi).
    form : {"unity", "paper"}
    hysteresis : {"paper", "masing"}
        Rule tracking the half-cycle amplitude of D for eq. 10.
    """

    f0_hz: float = 386.0
    k1: float = 1.75e-4
    k2: float = 1.05e-3
    k3: float = 4.4e-3
    k4: float = 250.0
    k5: float = -1.2e-5
    fs_hz: float = 7200.0
    form: str = "unity"
    hysteresis: str = "paper"

    def __post_init__(self):
        o = "correcting"
        f0 = v.positive(o, "f0_hz", self.f0_hz)
        _within("f0_hz", f0, *F0_RANGE_HZ, "Hz")
        k1 = v.non_negative(o, "k1", self.k1)
        _within("k1", k1, 0.0, K1_MAX)
        k2 = v.positive(o, "k2", self.k2)
        _within("k2", k2, *K2_RANGE_RAD, "rad")
        if not k1 < 2.0 * k2:
            raise ValueError(f"correcting.k1: must be < 2 k2 = {2.0 * k2:g} (eq. 9 keeps the spring's stiffness), "
                             f"got {k1!r}")
        k3 = v.non_negative(o, "k3", self.k3)
        _within("k3", k3, 0.0, K3_MAX)
        k4 = v.finite(o, "k4", self.k4)
        _within("k4", k4, *K4_RANGE_PER_RAD, "1/rad")
        if not k3 * (1.0 + k4 * D_LIMIT_RAD) < 1.0:
            raise ValueError(f"correcting.k3: the loss k3 (1 + k4 a) must stay < 1 for every deflection up to "
                             f"{D_LIMIT_RAD:g} rad, got {k3 * (1.0 + k4 * D_LIMIT_RAD):.4g} (k3 = {k3!r}, k4 = {k4!r})")
        _within("k5", v.finite(o, "k5", self.k5), -K5_MAX_RAD_PER_V, K5_MAX_RAD_PER_V, "rad/V")
        fs = v.positive(o, "fs_hz", self.fs_hz)
        _within("fs_hz", fs, 0.0, FS_MAX_HZ, "Hz")
        if fs <= 2.0 * f0:
            raise ValueError(
                f"correcting.fs_hz: must be > 2 x f0 = {2 * f0:.6g} Hz (w = omega0 dT < pi), got {fs!r}"
            )
        v.choice(o, "form", self.form, FORMS)
        v.choice(o, "hysteresis", self.hysteresis, kphys.RULES)

    @property
    def w(self) -> float:
        """w = omega0 dT (rad per sample)."""
        return 2.0 * math.pi * self.f0_hz / self.fs_hz

    @property
    def dc_gain_paper(self) -> float:
        """B = 2 (1 - cos w) / w^2, the paper form's DC gain (eq. 4, 5)."""
        w = self.w
        return 2.0 * (1.0 - math.cos(w)) / (w * w)

    @property
    def coefficients(self) -> tuple[float, float]:
        """(a2, g): weight of the second difference and of the bracket in eq. 5."""
        w = self.w
        if self.form == "paper":
            return 1.0 / (w * w), self.dc_gain_paper
        return 1.0 / (2.0 * (1.0 - math.cos(w))), 1.0

    @property
    def dc_gain(self) -> float:
        """Gain at zero frequency of the linear part: B (paper) or 1 (unity)."""
        return self.coefficients[1]

    @property
    def nyquist_gain(self) -> float:
        """|H| at fs/2: ``(2 + 2 cos w)/w^2`` for the paper form, ``(1 + cos w)/(1 - cos w)`` for unity."""
        a2, g = self.coefficients
        return abs(g - 4.0 * a2)

    delay_samples = 1
    """Y_n estimates the block at t_{n-1} (the second difference is centred there)."""

    def frequency_response(self, f_hz) -> np.ndarray:
        """Linear part of eq. 5 (k1 = k3 = k5 = 0), analytically.

        ``H(z) = a2 (1 - 2 z^-1 + z^-2) + g z^-1 = z^-1 (g - 2 a2 (1 - cos theta))``
        on the unit circle ``z = exp(j theta)``, ``theta = 2 pi f / fs``: a zero at
        omega0 and a pure one-sample delay.
        """
        a2, g = self.coefficients
        theta = 2.0 * math.pi * np.asarray(f_hz, dtype=np.float64) / self.fs_hz
        return np.exp(-1j * theta) * (g - 2.0 * a2 * (1.0 - np.cos(theta)))


class CorrectingFilter:
    """Streaming correcting filter (the paper's equation 5), chunk by chunk.

    Chunked output equals one call on the whole array, bit for bit.

    Parameters
    ----------
    design : CorrectingFilterDesign
    x0 : float
        The angle the RLG rests at before the first sample (X_{-1} = X_{-2} = x0, D = 0).
    """

    def __init__(self, design: CorrectingFilterDesign, x0: float = 0.0):
        self.design = design
        self._a2, self._g = design.coefficients
        self._rule = kphys.RULES[design.hysteresis]
        self._fast_dt = 0.25 / design.f0_hz
        self.state = np.zeros(kcor.STATE_SIZE)
        self.hyst = np.zeros(kphys.HYST_SIZE)
        self.stack = np.zeros(kphys.STACK_SIZE)
        self.reset(x0)

    def reset(self, x0: float = 0.0) -> None:
        """Back to rest at angle ``x0``."""
        self.state[:] = 0.0
        self.state[kcor.F_X1] = v.finite("correcting", "x0", x0)
        kphys.hyst_reset(self.hyst, self.stack)
        self._warned = False
        self._warned_d = False

    @property
    def fast_half_cycles(self) -> int:
        """Half-cycles of D shorter than a quarter dither period so far."""
        return int(self.hyst[5])

    def process(self, x, volts=None) -> np.ndarray:
        """Filter a chunk of RLG angles ``x`` (rad) with the drive ``volts`` (V) aligned to them."""
        x = v.finite_array("correcting", "x", x)
        if volts is None:
            volts = np.zeros_like(x)
        else:
            volts = v.finite_array("correcting", "volts", volts)
            if volts.shape != x.shape:
                raise ValueError(f"correcting.volts: must match x in shape {x.shape}, got {volts.shape}")
        out = np.empty_like(x)
        d = self.design
        kcor.correcting_run(x, volts, self._a2, self._g, d.k1, d.k2, d.k3, d.k4, d.k5, 1.0 / d.fs_hz,
                            self._rule, self._fast_dt, self.state, self.hyst, self.stack, out)
        self.check_output(x, out, stacklevel=3)
        return out

    def check_output(self, x, out, stacklevel: int = 2) -> None:
        """Warn (once per run) when a chunk's output leaves the filter's domain.

        The paper form's ``D = X - Y`` beyond any physical deflection (eq. 5's DC gain B), and
        the hysteresis regime of eq. 10 inside the filter. Called by :meth:`process` and by
        the engine's fused kernel path after each chunk.
        """
        if self.design.form == "paper" and not self._warned_d:
            d_max = float(np.max(np.abs(x - out))) if x.size else 0.0
            if not d_max <= D_LIMIT_RAD:
                self._warned_d = True
                warnings.warn(
                    f"correcting filter (paper form): |D| = |X - Y| reached {d_max:.3g} rad, beyond any physical "
                    f"deflection ({D_LIMIT_RAD} rad): eq. 5's DC gain B feeds (1 - B) X into D, so Nonl(D) and "
                    "Diss(D) leave their domain under sustained rotation (and diverge after ~0.3 rad); use "
                    "form='unity'",
                    RuntimeWarning,
                    stacklevel=stacklevel,
                )
        if self.design.k3 > 0.0 and self._rule == kphys.RULE_PAPER and self.hyst[5] > 0 and not self._warned:
            self._warned = True
            warn_regime(f"correcting filter ({self.design.form} form)", int(self.hyst[5]), float(self.hyst[6]), "D", stacklevel=stacklevel)


def correct(x, design: CorrectingFilterDesign, volts, x0: float = 0.0, *, drive_free: bool = False) -> np.ndarray:
    """Eq. 5 over a whole record (see :class:`CorrectingFilter`).

    Parameters
    ----------
    x : array_like
        RLG angles (rad) at the filter rate.
    design : CorrectingFilterDesign
    volts : array_like or None
        The piezo drive (V) aligned with ``x``; eq. 5 subtracts its ``k5 V``
        term. Required: ``None`` means "no drive term" and is accepted only
        when ``design.k5 == 0`` or ``drive_free=True``.
    x0 : float
        The angle the RLG rests at before the first sample.
    drive_free : bool
        Filter without the drive term although ``design.k5 != 0`` (the
        caller states that the suspension was not driven).

    Raises
    ------
    ValueError
        ``volts`` is None while ``design.k5 != 0`` and ``drive_free`` is not set.

    Examples
    --------
    >>> d = CorrectingFilterDesign(k5=0.0)
    >>> correct(np.zeros(4), d, None).shape
    (4,)
    """
    if volts is None and design.k5 != 0.0 and not drive_free:
        raise ValueError(
            f"correcting.volts: is required when the design's k5 = {design.k5!r} != 0 (eq. 5 subtracts the "
            "k5 V drive term); pass the drive voltage aligned with x, or volts=None with drive_free=True"
        )
    return CorrectingFilter(design, x0).process(x, volts)
