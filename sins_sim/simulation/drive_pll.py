"""Three dither drives on one block, each held on its resonance by a live phase-locked loop (issue 38, item 5).

The engine's drives on a block run at fixed frequencies (a tracking PLL there is ideal: locked at each update to
the resonance the plant has, no loop dynamics). Here each drive is a PLL with its own loop, on the coupled plant
of :class:`~sins_sim.models.block.CoupledPlant` (the three nonlinear suspensions, eq. 9/10/14, on the block on its
isolators), so that the drives can pull each other through the block, follow each other's beat, or lock together.

Loop (per axis, updated every ``1 / update_hz``)
-------------------------------------------------
- drive ``V = V_m cos(phi)``, ``phi' = w`` (the DAC sine at the PLL's frequency);
- phase detector: at each update, ``I = <delta sin phi>``, ``Q = <delta cos phi>`` over the last ``cycles``
  periods of the drive (exactly: the 2 w product terms cancel); at resonance the deflection
  lags the drive by 90 deg (eq. 15-17: ``V_m cos`` gives ``a_m sin``), so ``e = atan2(Q, I)`` is 0 there and
  positive below resonance (the response then in phase with the drive);
- frequency: ``w = w_c + K_p e + K_i int e``. The resonator's phase follows a frequency offset ``x`` as
  ``e = -tau x / (1 + s tau)`` with ``tau = 2 Q / w`` (the envelope time constant of a resonator of quality
  ``Q``; Gardner, *Phaselock Techniques*, 3rd ed., ch. 2 for the loop algebra). The closed loop is then
  ``tau s^2 + (1 + tau K_p) s + tau K_i = 0``; ``K_i = w_n^2`` and ``K_p = (2 zeta w_n tau - 1) / tau`` place it at
  ``w_n = 2 pi B`` with damping ``zeta`` (:func:`pll_gains`).

The voltage is held at the resonance value on the block (eq. 17 times
:func:`~sins_sim.models.block.dither_voltage_factor`): no amplitude loop, so that a frequency shift is the PLL's
alone.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["PllSettings", "pll_gains", "simulate_pll_drives"]


@dataclass(frozen=True)
class PllSettings:
    """One PLL per drive.

    Parameters
    ----------
    bandwidth_hz : float
        Natural frequency of the closed loop (Hz), > 0; below a tenth of the update rate.
    damping : float
        Damping ratio of the closed loop, in (0.2, 2].
    update_hz : float
        Phase-detector and frequency update rate (Hz): a whole divisor of the plant rate.
    cycles : int
        The detector averages over this many periods of its drive (>= 1).
    """

    bandwidth_hz: float = 5.0
    damping: float = 0.7
    update_hz: float = 1000.0
    cycles: int = 2

    def __post_init__(self):
        if not (math.isfinite(self.update_hz) and self.update_hz > 0):
            raise ValueError(f"pll.update_hz: must be a finite number > 0 Hz, got {self.update_hz!r}")
        if not (math.isfinite(self.bandwidth_hz) and 0 < self.bandwidth_hz <= 0.1 * self.update_hz):
            raise ValueError(f"pll.bandwidth_hz: must be > 0 and at most a tenth of the update rate "
                             f"({0.1 * self.update_hz:g} Hz), got {self.bandwidth_hz!r}")
        if isinstance(self.cycles, bool) or int(self.cycles) != self.cycles or self.cycles < 1:
            raise ValueError(f"pll.cycles: must be an integer >= 1, got {self.cycles!r}")
        if not (0.2 < self.damping <= 2.0):
            raise ValueError(f"pll.damping: must lie in (0.2, 2], got {self.damping!r}")


def pll_gains(settings: PllSettings, tau_s: float) -> tuple:
    """``(K_p, K_i)`` placing the loop (module docstring) at ``2 pi B`` with damping ``zeta``, for a resonator of
    envelope time constant ``tau_s`` (s). ``K_p`` is clipped at 0 when the resonator alone is faster."""
    wn = 2.0 * math.pi * settings.bandwidth_hz
    return max(0.0, (2.0 * settings.damping * wn * tau_s - 1.0) / tau_s), wn * wn


def simulate_pll_drives(imu, duration_s: float, settings: PllSettings = PllSettings()) -> dict:
    """The three drives of ``imu`` (with a ``block``) each on its own PLL, started at the coupled resonances.

    Parameters
    ----------
    imu : ImuConfig
        A unit with a block; its channels' suspensions, drive amplitudes and plant rate are used.
    duration_s : float
        Length (s).
    settings : PllSettings

    Returns
    -------
    dict
        ``t_s`` (K,) the update times, ``frequency_hz`` (3, K) each PLL's frequency, ``phase_error_rad`` (3, K),
        ``start_hz`` (3,) the coupled resonances it started from, ``amplitude_rad`` (3,) each deflection's
        amplitude over the last update, ``tau_s`` (3,) and ``gains`` [(K_p, K_i)] per axis.
    """
    from sins_sim.models.block import CoupledPlant, coupled_dither_frequencies, dither_voltage_factor

    chs = imu.channels
    rate = chs[0].plant.rate_hz
    m = int(round(rate / settings.update_hz))
    if m < 1 or abs(m * settings.update_hz - rate) > 1e-9 * rate:
        raise ValueError(f"pll.update_hz: must divide the plant rate {rate:g} Hz, got {settings.update_hz:g}")
    if not (math.isfinite(duration_s) and duration_s > 0):
        raise ValueError(f"duration_s: must be a finite number > 0 s, got {duration_s!r}")
    sus = [c.suspension for c in chs]
    amp = np.array([c.drive.amplitude_rad for c in chs])
    om = np.array([2.0 * math.pi * s.resonance_hz(a) for s, a in zip(sus, amp)])
    q = np.array([s.q_factor(a) for s, a in zip(sus, amp)])
    f_start = coupled_dither_frequencies(imu.block, om)
    v_m = np.array([s.drive_voltage(a) for s, a in zip(sus, amp)]) * dither_voltage_factor(imu.block, om, q)
    w = 2.0 * math.pi * f_start
    tau = 2.0 * q / w
    gains = [pll_gains(settings, t) for t in tau]
    kp = np.array([g[0] for g in gains])
    ki = np.array([g[1] for g in gains])
    plant = CoupledPlant(sus, imu.block, chs[0].plant)
    h = 1.0 / rate
    n_up = int(math.floor(duration_s * settings.update_hz))
    phi0 = np.zeros(3)
    integ = np.zeros(3)
    f_out = np.empty((3, n_up))
    e_out = np.empty((3, n_up))
    steps = np.arange(1, m + 1, dtype=float) * h
    amp_last = np.zeros(3)
    zeros = np.zeros((3, m))  # the chassis at rest
    w_cmd = w.copy()
    span = int(math.ceil(settings.cycles * rate / f_start.min() * 1.2)) + m + 2
    ps = np.zeros((3, span))  # delta sin(phi) and delta cos(phi) over the last ``span`` plant steps
    pc = np.zeros((3, span))
    for k in range(n_up):
        wk = w_cmd
        # the drive is held over each plant step at its value at the step's start (zero-order hold)
        volts = v_m[:, None] * np.cos(phi0[:, None] + wk[:, None] * (steps - h)[None, :])
        delta, _ = plant.step(zeros, zeros, volts)
        ph_end = phi0[:, None] + wk[:, None] * steps[None, :]  # the deflection at the step's end
        ps = np.concatenate([ps[:, m:], delta * np.sin(ph_end)], axis=1)
        pc = np.concatenate([pc[:, m:], delta * np.cos(ph_end)], axis=1)
        # the detector's mean over exactly ``cycles`` periods of each drive (the last sample weighted by the
        # fraction that completes them): the 2 w product term cancels, only the slow phase remains
        length = settings.cycles * 2.0 * math.pi / (wk * h)
        i_c, q_c = np.empty(3), np.empty(3)
        for ax in range(3):
            n_full = int(length[ax])
            frac = length[ax] - n_full
            i_c[ax] = (ps[ax, span - n_full:].sum() + frac * ps[ax, span - n_full - 1]) / length[ax]
            q_c[ax] = (pc[ax, span - n_full:].sum() + frac * pc[ax, span - n_full - 1]) / length[ax]
        e = np.arctan2(q_c, i_c)
        amp_last = 2.0 * np.hypot(i_c, q_c)
        integ += e / settings.update_hz
        w_cmd = w + kp * e + ki * integ
        phi0 = np.mod(phi0 + wk * m * h, 2.0 * math.pi)
        f_out[:, k] = w_cmd / (2.0 * math.pi)
        e_out[:, k] = e
    return {"t_s": (np.arange(n_up) + 1) / settings.update_hz, "frequency_hz": f_out, "phase_error_rad": e_out,
            "start_hz": f_start, "amplitude_rad": amp_last, "tau_s": tau, "gains": gains}
