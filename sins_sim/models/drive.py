"""The piezo drive of one suspension: a DAC sine at the amplitude-dependent resonance.

The drive is produced by a DAC and held constant between updates
(zero-order hold, reference-model.md "Readout"). With ``V = V_m cos(omega t)``
at resonance the steady deflection is ``a_m sin(omega t)`` (eq. 15-17).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sins_sim import _validate as v
from sins_sim.models.suspension import SuspensionParams
from sins_sim.units import ARCMIN

__all__ = ["DriveParams", "DriveSignal"]


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
        v.positive(o, "amplitude_rad", self.amplitude_rad)
        if self.frequency_hz is not None:
            v.positive(o, "frequency_hz", self.frequency_hz)
        if self.v_m is not None:
            v.non_negative(o, "v_m", self.v_m)
        v.positive(o, "dac_rate_hz", self.dac_rate_hz)
        v.finite(o, "phase_rad", self.phase_rad)

    def resolve(self, suspension: SuspensionParams) -> "DriveSignal":
        """Fix frequency and voltage for a given suspension."""
        f = self.frequency_hz if self.frequency_hz is not None else suspension.resonance_hz(self.amplitude_rad)
        vm = self.v_m if self.v_m is not None else suspension.drive_voltage(self.amplitude_rad)
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
