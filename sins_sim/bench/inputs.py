"""Fixed, deterministic inputs of the benchmarks (no random numbers)."""

from __future__ import annotations

import math

import numpy as np

from sins_sim.models.drive import DriveParams
from sins_sim.models.suspension import PAPER_SUSPENSION, SuspensionParams
from sins_sim.units import ARCMIN, INTERPOLATED_QUANTUM_RAD

__all__ = ["filter_input", "plant_input"]


def filter_input(n: int, fs_hz: float = 7200.0, suspension: SuspensionParams = PAPER_SUSPENSION):
    """A decimated readout record for the filters: ``(x, volts)`` at ``fs_hz``, length ``n``.

    A 3 arcmin dither at the amplitude's resonance, a 1 arcmin 100 Hz block
    vibration and a 10 deg/h rotation, quantised to 1/16 fringe; the drive
    ``V_m cos`` of eq. 17 (phase 90 deg ahead of the deflection, as at
    resonance). Deterministic (no random numbers).
    """
    drive = DriveParams().resolve(suspension)
    k = np.arange(n, dtype=np.float64)
    ph = 2.0 * math.pi * np.mod(drive.frequency_hz * k / fs_hz, 1.0)
    angle = (3.0 * ARCMIN * np.sin(ph) + ARCMIN * np.sin(2.0 * math.pi * 100.0 * k / fs_hz)
             + (10.0 * math.pi / 180.0 / 3600.0) * k / fs_hz)
    x = np.floor(angle / INTERPOLATED_QUANTUM_RAD) * INTERPOLATED_QUANTUM_RAD
    volts = drive.v_m * np.cos(ph)
    return x, volts


def plant_input(n: int, rate_hz: float = 72000.0, suspension: SuspensionParams = PAPER_SUSPENSION):
    """Plant inputs ``(sins_angle, sins_rate, volts)`` for ``n`` steps at ``rate_hz``.

    Block angle and rate of a 1 arcmin 100 Hz vibration at the ends of the
    steps ``t_1 .. t_n``; the drive at the 3 arcmin resonance held over each
    step (DAC at the plant rate). Deterministic.
    """
    t = np.arange(1, n + 1) / rate_hz
    w = 2.0 * math.pi * 100.0
    volts = DriveParams(dac_rate_hz=rate_hz).resolve(suspension).samples(0, n)
    return ARCMIN * np.sin(w * t), ARCMIN * w * np.cos(w * t), volts
