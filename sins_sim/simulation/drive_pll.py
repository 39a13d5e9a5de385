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

Under vibration
---------------
``motion`` (a rotation profile: the chassis angle and rate about the block axes) and ``translation`` (the chassis'
linear acceleration) enter at the chassis and reach the block through its isolators, as in the engine
(:meth:`~sins_sim.models.block.CoupledPlant.step`). A line at ``f_v`` puts a forced response ``d_v`` into a
gyro's deflection beside its dither ``a`` at ``f_d``; the detector's ``atan2`` reads it as a phase disturbance
``n = (d_v / a) sin(2 pi (f_v - f_d) t + ...)`` (to first order in ``d_v / a``), seen through its own ``cycles``
-period mean ``D(s) = e^{-s T/2} sin(w T/2) / (w T/2)``, ``T = cycles / f_d``. With the loop's filter
``C(s) = K_p + K_i / s``, the held command ``H(s) = e^{-s T_u / 2}`` (``T_u = 1 / update_hz``) and the resonator's
phase ``-tau / (1 + s tau)`` per unit frequency offset, the commanded frequency follows the disturbance the open
detector reads, ``e_o = D n``, as

    ``W(s) = C H / (1 + C H D tau / (1 + s tau))``   (rad/s per rad; :func:`fm_per_phase_disturbance`),

so the FM amplitude at the offset is ``|W(j 2 pi |f_v - f_d|)| e_o / (2 pi)`` Hz (Gardner, ch. 2, the loop's
response to a phase disturbance at the detector). Capture: when the line's response reaches the dither
(``d_v / a >= 1``) the detector's ``atan2`` follows the line instead, and the loop runs at ``f_v``; as an oscillator
the resonator would lock within Adler's range ``(f_d / 2 Q) (d_v / a)`` (Adler, Proc. IRE 34, 1946, eq. 9).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["PllSettings", "pll_gains", "simulate_pll_drives", "fm_per_phase_disturbance", "adler_range_hz",
           "pll_line_response"]


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


def fm_per_phase_disturbance(settings: PllSettings, tau_s: float, drive_hz: float, offset_hz: float) -> float:
    """``|W(j 2 pi f)| / (2 pi)``: the commanded frequency's amplitude (Hz) per rad of the phase disturbance the
    open detector reads at ``offset_hz`` (module docstring, "Under vibration"), for a drive at ``drive_hz`` on a
    resonator of envelope time constant ``tau_s``."""
    if not (offset_hz > 0 and math.isfinite(offset_hz)):
        raise ValueError(f"offset_hz: must be a finite number > 0 Hz, got {offset_hz!r}")
    kp, ki = pll_gains(settings, tau_s)
    w = 2.0 * math.pi * offset_hz
    s = 1j * w
    t_det = settings.cycles / drive_hz
    x = 0.5 * w * t_det
    d = np.exp(-s * t_det / 2.0) * math.sin(x) / x
    c = kp + ki / s
    h = np.exp(-s / (2.0 * settings.update_hz))
    return float(abs(c * h / (1.0 + c * h * d * tau_s / (1.0 + s * tau_s))) / (2.0 * math.pi))


def adler_range_hz(drive_hz: float, q: float, ratio: float) -> float:
    """Adler's lock range ``(f / 2 Q) (injected / driven)`` (Hz) of an oscillator at ``drive_hz`` of quality ``q``
    under an injection ``ratio`` of its own amplitude (Adler, Proc. IRE 34, 1946, eq. 9)."""
    return drive_hz / (2.0 * q) * ratio


def simulate_pll_drives(imu, duration_s: float, settings: PllSettings = PllSettings(), *, motion=None,
                        translation=None, hold: bool = False) -> dict:
    """The three drives of ``imu`` (with a ``block``) each on its own PLL, started at the coupled resonances.

    Parameters
    ----------
    imu : ImuConfig
        A unit with a block; its channels' suspensions, drive amplitudes and plant rate are used.
    duration_s : float
        Length (s).
    settings : PllSettings
    motion : Motion3D or None
        Chassis rotation (its ``grid_angle_rate`` about the block axes), entering at the chassis; None: at rest.
    translation : object with ``accel(t)`` ((n, 3), m/s^2) or None
        Chassis linear acceleration, entering at the chassis (through the isolators); None: none.
    hold : bool
        Hold each drive at its start frequency (the loop open; the detector still reads): the phase disturbance
        the open detector sees, ``e_o`` of the module docstring.

    Returns
    -------
    dict
        ``t_s`` (K,) the update times, ``frequency_hz`` (3, K) each PLL's frequency, ``phase_error_rad`` (3, K),
        ``start_hz`` (3,) the coupled resonances it started from, ``amplitude_rad`` (3,) each deflection's
        amplitude over the last update, ``q`` (3,) the suspensions' quality at their amplitude, ``tau_s`` (3,)
        and ``gains`` [(K_p, K_i)] per axis.
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
    if motion is not None:  # the chassis' angle and rate at t = 0: no start step of the profile
        a0, r0 = motion.grid_angle_rate(-1, 1, 1.0 / rate)
        plant.reset(a0[0], r0[0])
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
        if motion is None:
            ang = rat = zeros
        else:  # the chassis at the step ends (the plant's convention)
            ang, rat = (np.ascontiguousarray(x.T) for x in motion.grid_angle_rate(k * m, m, h))
        if translation is None:
            lin0 = lin1 = None
        else:  # the acceleration at each step's start and its chord slope over the step (as the engine takes it)
            acc = np.asarray(translation.accel((k * m + np.arange(m + 1)) * h), dtype=float)
            lin0, lin1 = np.ascontiguousarray(acc[:-1].T), np.ascontiguousarray(np.diff(acc, axis=0).T / h)
        delta, _ = plant.step(ang, rat, volts, lin0, lin1)
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
        if not hold:
            w_cmd = w + kp * e + ki * integ
        phi0 = np.mod(phi0 + wk * m * h, 2.0 * math.pi)
        f_out[:, k] = w_cmd / (2.0 * math.pi)
        e_out[:, k] = e
    return {"t_s": (np.arange(n_up) + 1) / settings.update_hz, "frequency_hz": f_out, "phase_error_rad": e_out,
            "start_hz": f_start, "amplitude_rad": amp_last, "q": q, "tau_s": tau, "gains": gains}


#: A PLL counts as locked to a vibration line when its mean frequency lies within this fraction of the line's
#: offset from the line (a PLL that holds its drive stays at a shift of order FM^2 / offset, far below).
LOCKED_FRACTION = 0.1


def pll_line_response(imu, duration_s: float, settle_s: float, lines_hz, settings: PllSettings = PllSettings(), *,
                      motion=None, translation=None) -> dict:
    """Each drive's PLL under the chassis vibration ``motion`` / ``translation``, against the same PLLs at rest.

    Four runs of :func:`simulate_pll_drives` of ``duration_s``: the loop open (``hold``) and closed, each at rest
    and under the vibration. The plant is linear in the small line, so the differences (vibration less rest) hold
    the vibration's part alone, free of the start transient and of the drives' pulling of each other. Over the
    record after ``settle_s``, for each axis and each vibration line ``f_v`` of ``lines_hz``, at the offset
    ``|f_v - f_d|``: the phase disturbance the open detector reads (``e_o``), the closed loop's FM and its closed
    form ``|W| e_o / (2 pi)`` (:func:`fm_per_phase_disturbance`), the line's response relative to the dither
    (``d_v / a = e_o / |D|``), Adler's range for it, and the mean frequency's shift under the vibration.

    Returns
    -------
    dict
        ``mean_hz`` (3,) and ``rest_mean_hz`` (3,) the closed loop's mean frequencies under vibration and at
        rest, ``start_hz`` (3,), ``q`` (3,), and ``lines``: a list of dicts per (axis, line) with ``axis``,
        ``line_hz``, ``drive_hz``, ``offset_hz``, ``phase_disturbance_rad``, ``line_to_dither``, ``fm_hz``,
        ``fm_closed_form_hz``, ``adler_range_hz``, ``captured`` (``d_v / a >= 1``: the detector follows the
        line), ``within_adler`` (the offset inside Adler's range), ``mean_shift_hz`` (closed loop, vibration less
        rest) and ``locked_to_line`` (measured: the mean within :data:`LOCKED_FRACTION` of the offset from the
        line); offsets the record does not resolve
        (fewer than two periods after ``settle_s``) are left out.
    """
    if not (0 <= settle_s < duration_s):
        raise ValueError(f"settle_s: must lie in [0, duration_s), got {settle_s!r}")
    runs = {(vib, hold): simulate_pll_drives(imu, duration_s, settings, hold=hold,
                                             motion=motion if vib else None,
                                             translation=translation if vib else None)
            for vib in (False, True) for hold in (True, False)}
    from sins_sim.simulation.responses import line_amplitudes

    t = runs[(True, True)]["t_s"]
    keep = t > settle_s
    span = t[keep][-1] - t[keep][0]
    ref = runs[(True, True)]
    out = []
    for ax in range(3):
        fd = float(ref["start_hz"][ax])
        for fv in lines_hz:
            off = abs(float(fv) - fd)
            if off * span < 2.0:
                continue
            e_o = line_amplitudes(t[keep], (runs[(True, True)]["phase_error_rad"][ax]
                                            - runs[(False, True)]["phase_error_rad"][ax])[keep], (off,), trend=True)[0]
            fm = line_amplitudes(t[keep], (runs[(True, False)]["frequency_hz"][ax]
                                           - runs[(False, False)]["frequency_hz"][ax])[keep], (off,), trend=True)[0]
            x = math.pi * off * settings.cycles / fd
            ratio = e_o / abs(math.sin(x) / x)
            adler = adler_range_hz(fd, float(ref["q"][ax]), ratio)
            mean = float(runs[(True, False)]["frequency_hz"][ax, keep].mean())
            out.append({"axis": "xyz"[ax], "line_hz": float(fv), "drive_hz": fd, "offset_hz": off,
                        "phase_disturbance_rad": e_o, "line_to_dither": ratio, "fm_hz": fm,
                        "fm_closed_form_hz": fm_per_phase_disturbance(settings, float(ref["tau_s"][ax]), fd, off) * e_o,
                        "adler_range_hz": adler, "captured": bool(ratio >= 1.0), "within_adler": bool(off < adler),
                        "mean_shift_hz": mean - float(runs[(False, False)]["frequency_hz"][ax, keep].mean()),
                        "locked_to_line": bool(abs(mean - fv) < LOCKED_FRACTION * off)})
    return {"mean_hz": runs[(True, False)]["frequency_hz"][:, keep].mean(axis=1),
            "rest_mean_hz": runs[(False, False)]["frequency_hz"][:, keep].mean(axis=1),
            "start_hz": ref["start_hz"], "q": ref["q"], "lines": out}
