"""The piezo drive of one suspension: a DAC sine at the amplitude-dependent resonance.

The drive is produced by a DAC and held constant between updates
(zero-order hold, docs/theory/suspension.md "Readout"). With ``V = V_m cos(omega t)``
at resonance the steady deflection is ``a_m sin(omega t)`` (eq. 15-17).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from sins_sim import _validate as v
from sins_sim.models.suspension import Q_RANGE, SuspensionParams
from sins_sim.units import ARCMIN

__all__ = ["DriveParams", "DriveSignal", "AMPLITUDE_RANGE_ARCMIN", "AMPLITUDE_TYPICAL_ARCMIN", "V_MAX",
           "V_TYPICAL_MAX", "RATE_MAX_HZ"]

# --- physical ranges (issue 12, point 4): declared in sins_sim.models.ranges, re-exported here
from sins_sim.models.ranges import (AMPLITUDE_RANGE_ARCMIN, AMPLITUDE_TYPICAL_ARCMIN, RATE_MAX_HZ,  # noqa: E402
                                    V_MAX, V_TYPICAL_MAX)


@dataclass(frozen=True)
class DriveParams:
    """Drive settings of one channel.

    Parameters
    ----------
    amplitude_rad : float
        Target dither amplitude a_m (rad), > 0. Default 3 arcmin (paper).
    frequency_hz : float or None
        Drive frequency; ``None`` = the amplitude-dependent resonance F(a_m)
        by harmonic balance of eq. 9 (what the paper's PLL tracks).
    v_m : float or None
        Drive amplitude (V); ``None`` = eq. 17 solved for V_m, the voltage that
        holds a_m at resonance.
    dac_rate_hz : float
        DAC update rate (Hz); the plant rate must be an integer multiple.
    phase_rad : float
        Phase of the drive cosine at t = 0.
    """

    amplitude_rad: float = 3.0 * ARCMIN
    frequency_hz: float | None = None
    v_m: float | None = None
    dac_rate_hz: float = 72000.0
    phase_rad: float = 0.0

    def __post_init__(self):
        o = "drive"
        a = v.positive(o, "amplitude_rad", self.amplitude_rad) / ARCMIN
        lo, hi = AMPLITUDE_RANGE_ARCMIN
        if not lo <= a <= hi:
            raise ValueError(f"drive.amplitude_rad: must be in [{lo:g}, {hi:g}] arcmin ({lo * ARCMIN:.3g} to "
                             f"{hi * ARCMIN:.3g} rad; RLG dithers run at 0.1-30 arcmin), got {self.amplitude_rad!r} "
                             f"({a:.4g} arcmin)")
        if self.frequency_hz is not None:
            v.positive(o, "frequency_hz", self.frequency_hz)
        if self.v_m is not None:
            vm = v.non_negative(o, "v_m", self.v_m)
            if vm > V_MAX:
                raise ValueError(f"drive.v_m: must be <= {V_MAX:g} V (what a piezo stack takes), got {vm!r}")
        rate = v.positive(o, "dac_rate_hz", self.dac_rate_hz)
        if rate > RATE_MAX_HZ:
            raise ValueError(f"drive.dac_rate_hz: must be <= {RATE_MAX_HZ:g} Hz, got {rate!r}")
        if abs(v.finite(o, "phase_rad", self.phase_rad)) > 1.0e3:
            raise ValueError(f"drive.phase_rad: must be in [-1000, 1000] rad, got {self.phase_rad!r}")
        tlo, thi = AMPLITUDE_TYPICAL_ARCMIN
        if not tlo <= a <= thi:
            warnings.warn(f"drive.amplitude: {a:.4g} arcmin is outside the usual RLG dither amplitudes "
                          f"({tlo:g}-{thi:g} arcmin)", UserWarning, stacklevel=3)

    def resolve(self, suspension: SuspensionParams) -> "DriveSignal":
        """Fix frequency and voltage for a given suspension."""
        a = self.amplitude_rad
        q = suspension.q_factor(a)
        if not Q_RANGE[0] <= q <= Q_RANGE[1]:
            raise ValueError(
                f"suspension.k3: Q = 1/(k3 (1 + k4 a) + 2 zeta) at the dither amplitude {a / ARCMIN:.4g} arcmin "
                f"must be in [{Q_RANGE[0]:g}, {Q_RANGE[1]:g}] (dither suspensions: 50-1000), got {q:.4g}")
        f = self.frequency_hz if self.frequency_hz is not None else suspension.resonance_hz(a)
        vm = self.v_m if self.v_m is not None else suspension.drive_voltage(a)
        if abs(vm) > V_MAX:
            raise ValueError(
                f"suspension.k5: holding {a / ARCMIN:.4g} arcmin at Q = {q:.4g} takes a drive of {abs(vm):.3g} V, "
                f"beyond what a piezo stack takes ({V_MAX:g} V): |k5| = {abs(suspension.k5):.3g} rad/V is too small "
                "or the amplitude too large")
        if abs(vm) > V_TYPICAL_MAX:
            warnings.warn(f"drive: {abs(vm):.4g} V is beyond what most piezo stacks take continuously "
                          f"({V_TYPICAL_MAX:g} V; high-voltage stacks up to {V_MAX:g} V)", UserWarning, stacklevel=2)
        if f >= 0.5 * self.dac_rate_hz:
            raise ValueError(
                f"drive.dac_rate_hz: must exceed twice the drive frequency {f:.6g} Hz, got {self.dac_rate_hz!r}"
            )
        return DriveSignal(frequency_hz=float(f), v_m=float(vm), dac_rate_hz=self.dac_rate_hz, phase_rad=self.phase_rad)


@dataclass(frozen=True)
class DriveSignal:
    """A resolved drive: ``V_k = V_m cos(2 pi f k / dac_rate + phase)``, held for one DAC period."""

    frequency_hz: float
    v_m: float
    dac_rate_hz: float
    phase_rad: float = 0.0

    def samples(self, k0: int, n: int) -> np.ndarray:
        """DAC samples k0 .. k0 + n - 1 (V). Phase is computed from the integer index (no drift)."""
        k = np.arange(k0, k0 + n, dtype=np.float64)
        # reduce the phase per sample exactly: (f k / rate) mod 1 keeps long runs accurate
        cycles = np.mod(self.frequency_hz * k / self.dac_rate_hz, 1.0)
        return self.v_m * np.cos(2.0 * math.pi * cycles + self.phase_rad)


# --- the amplitude loop under a vibration line ---------------------------------------------------------------------
def detector_leakage(block_steps: int, rate_hz: float, offset_hz: float) -> float:
    """What the amplitude loop's detector reads of a line ``offset_hz`` from the drive, per unit of that line.

    The detector (``sins_sim._kernels.drive.demod_accumulate``, ``chain.end_block``) reads
    ``2 |sum_n w_n delta_n e^{-i w_d t_n}| / sum_n w_n`` over a control block of ``block_steps`` plant steps with a
    Hann window ``w_n``. A line ``d_v cos(w_v t)`` adds ``d_v |W(w_v - w_d)| / W(0)`` to that phasor's modulus,
    ``W`` the window's transform (Harris 1978, "On the use of windows for harmonic analysis with the discrete
    Fourier transform", Proc. IEEE 66(1), sec. IV.C: the Hann window's main lobe spans ``+- 2 / T``); the image at
    ``w_v + w_d`` is left out (below 1e-3 for lines near the dither). Here ``W`` is summed exactly over the block.
    """
    n = np.arange(int(block_steps)) + 0.5
    w = np.sin(math.pi * n / int(block_steps)) ** 2
    return float(abs(np.sum(w * np.exp(2j * math.pi * float(offset_hz) * n / float(rate_hz)))) / np.sum(w))


def held_dither_amplitude(target_rad: float, leak_rad: float) -> float:
    """The dither the closed amplitude loop holds when its detector also reads a line's leak ``leak_rad``.

    At a beat the control blocks do not resolve, the line's phasor turns against the dither's from block to block, and
    the detector reads ``|a + c e^{i phi}|`` with ``phi`` spread evenly over the turn; the loop's integral drives the
    mean of that to the target: ``M(a, c) = (2 / pi) (a + c) E(4 a c / (a + c)^2) = a_t`` (``E`` the complete
    elliptic integral of the second kind, parameter ``m``: the mean distance from a point of a circle of radius
    ``c`` to a point at ``a`` from its centre; Abramowitz and Stegun 1964, 17.3.3). ``M >= max(a, c)``: a leak
    ``c >= a_t`` leaves no dither at all (the loop winds the drive down, returned as 0), and a small one takes
    ``c^2 / (4 a_t)`` from it.
    """
    from scipy import optimize, special

    at, c = float(target_rad), float(leak_rad)
    if c <= 0.0:
        return at
    if c >= at:
        return 0.0

    def mean(a):
        s = a + c
        return 2.0 / math.pi * s * special.ellipe(4.0 * a * c / (s * s)) - at

    return float(optimize.brentq(mean, 0.0, at, xtol=1e-15 * at, rtol=1e-13))
