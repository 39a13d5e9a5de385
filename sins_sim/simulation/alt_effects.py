"""Alternative physical forms of the catalogue effects, for the blind evaluation only.

The diagnosis fits the catalogue (``sins_sim.models.effects``). A real unit never has exactly
that form: the same physics shows up with another law, time profile or symmetry. This module
writes recordings with such forms, so that ``diagnose-eval`` does not test the catalogue against
itself. Nothing here is imported by the diagnosis, and no physics is shared with the catalogue:
only the hook protocol of :class:`~sins_sim.models.effects.Effect` (the stages at which the
experiment simulator, ``sins_sim.simulation.experiment``, lets an effect act), which the
simulator requires.

================================ =========== ==================================================================
form (catalogue effect it mimics) stage       law
================================ =========== ==================================================================
``two_pole_drive`` (piezo_lag)    voltage     two cascaded first-order lags ``tau1``, ``tau2`` (an amplifier
                                              with a second-order output filter), not one
``lowpass_coupling``              block       the other axis' deflection reaches the mount through a first-order
(axis_coupling)                               low-pass ``fc_hz`` (a compliant, damped mount): a phase lag, not
                                              an in-phase fraction
``structural_mode`` (block_mode)  block       structural (hysteretic) damping: ``H(f) = w^2 (1 + i eta) /
                                              (w^2 (1 + i eta) - (2 pi f)^2)`` per table sine, steady state;
                                              a loss factor independent of frequency, not viscous
``quadratic_damping``             voltage     aerodynamic damping ``c |d'| d'`` (loss per cycle ~ a^3, not
(viscous_damping)                             a^2), applied as an equivalent drive and iterated to a fixed point
``thermal_drift``                 voltage     ``f0(t) = f0 + df (1 - exp(-t / tau))`` (a unit warming up
(resonance_drift)                             towards equilibrium, not a linear ramp), as the stiffness change
                                              ``2 df(t) / f0 delta`` fed to the drive, iterated to a fixed point
``readout_lowpass``               sense       a first-order low-pass ``tau_s`` in the readout (an
(readout_delay)                               anti-alias stage): delay with a droop, not a pure delay
``warming_scale`` (scale_factor)  sense       the scale error grows over the recording: ``eps(t) = error (0.5
                                              + t / T)``, applied to each increment
``turnaround_kicks`` (lock_in)    sense       a phase error at each turnaround of the dither, from the
                                              stationary-phase evaluation of the lock-in term (Killpatrick 1967),
                                              nothing between turnarounds: not the continuous Adler law
================================ =========== ==================================================================

The fixed-point forms (``quadratic_damping``, ``thermal_drift``) need the deflection they act on:
:func:`record_alternative` simulates the axis, feeds its deflection to the form, and repeats
(:data:`FIXED_POINT_PASSES`, relaxed by :data:`RELAXATION`), like the simulator's own coupling passes.
"""

from __future__ import annotations

import abc

import math
import warnings

import numpy as np
from scipy import signal

from sins_sim.models.effects import Effect, Param
from sins_sim.simulation.experiment import record, simulate_axis
from sins_sim.units import FRINGE_RAD

__all__ = ["ALT_FORMS", "FIXED_POINT_PASSES", "record_alternative", "TwoPoleDrive", "LowpassCoupling",
           "StructuralMode", "QuadraticDamping", "ThermalDrift", "ReadoutLowpass", "WarmingScale", "TurnaroundKicks"]

#: Passes of the fixed-point forms, and the relaxation of each pass (the new deflection is this mix of the
#: simulated one and the previous one). The plain iteration alternates about the fixed point and contracts
#: by about 0.3-0.5 per pass for a damping change of 0.4-1 resonance half widths; relaxed by 1/2 it contracts
#: by about 0.4 steadily, and 10 passes leave about 1e-4 of the first change (measured at zeta_eq = 1e-3 and
#: 3e-3 on the default unit).
FIXED_POINT_PASSES = 10
RELAXATION = 0.5


def _zoh_lowpass(x: np.ndarray, tau: float, h: float) -> np.ndarray:
    """First-order low-pass ``tau y' = x - y`` of a signal held over each step, ``y(0) = x[0]``."""
    a = math.exp(-h / tau)
    y, _ = signal.lfilter([1.0 - a], [1.0, -a], x, zi=[a * x[0]])
    return y


class TwoPoleDrive(Effect):
    name = "two_pole_drive"
    stage = "voltage"
    summary = "two cascaded first-order lags of the piezo voltage"
    PARAMS = (Param("tau1_s", "first time constant (s)", 1e-7, 0.01, 1e-4),
              Param("tau2_s", "second time constant (s)", 1e-7, 0.01, 1e-4))

    def voltage(self, axis, volts, h):
        if not self.acts_on(axis):
            return volts
        v1 = np.concatenate(([0.0], volts))  # from rest: V_eff(0) = 0
        y = _zoh_lowpass(_zoh_lowpass(v1, self.params["tau1_s"], h), self.params["tau2_s"], h)
        return 0.5 * (y[:-1] + y[1:])


class LowpassCoupling(Effect):
    """``source``'s deflection through a first-order low-pass, times ``c``, added to the target's block angle."""

    name = "lowpass_coupling"
    stage = "block"
    summary = "coupling of another axis' deflection through a low-pass mount"
    PARAMS = (Param("c", "coupling coefficient", -0.2, 0.2, 1e-2), Param("fc_hz", "corner (Hz)", 1.0, 1e5, 1e3))

    def __init__(self, axes, source: str, **params):
        super().__init__(axes=axes, **params)
        self.source = source
        self.delta = None  # the source's deflection on the plant grid (record_alternative)

    def block(self, axis, angle, rate, h):
        if not self.acts_on(axis) or self.delta is None:
            return angle, rate
        y = _zoh_lowpass(self.delta, 1.0 / (2.0 * math.pi * self.params["fc_hz"]), h)
        c = self.params["c"]
        return angle + c * y, rate + c * np.gradient(y, h)


class StructuralMode(Effect):
    """Steady-state response of the table's sines through a mode with a structural loss factor ``eta``."""

    name = "structural_mode"
    stage = "block"
    summary = "block mode with structural (hysteretic) damping"
    PARAMS = (Param("frequency_hz", "mode frequency (Hz)", 1.0, 20000.0, 100.0),
              Param("eta", "loss factor", 1e-4, 2.0, 0.1),
              Param("gain", "participation of the gyros' block", -2.0, 2.0, 0.3))

    def __init__(self, axes, sines, **params):
        super().__init__(axes=axes, **params)
        self.sines = tuple(sines)  # [(amplitude rad, frequency Hz, phase rad)] of the table motion

    def block(self, axis, angle, rate, h):
        if not self.acts_on(axis):
            return angle, rate
        w2 = (2.0 * math.pi * self.params["frequency_hz"]) ** 2 * (1.0 + 1j * self.params["eta"])
        g = self.params["gain"]
        t = np.arange(angle.size) * h
        da = np.zeros_like(angle)
        dr = np.zeros_like(angle)
        for amp, f, ph in self.sines:
            w = 2.0 * math.pi * f
            dh = g * (w2 / (w2 - w * w) - 1.0)  # the change of the sine's complex gain
            z = amp * dh * np.exp(1j * (w * t + ph))
            da += z.imag  # the table's sine is amp sin(w t + ph) = Im(amp e^{i(w t + ph)})
            dr += (1j * w * z).imag
        return angle + da, rate + dr


class _FixedPoint(Effect, abc.ABC):
    """A form that acts through the drive on the axis' own deflection (``delta`` from the previous pass).

    Subclasses give the law as :meth:`_extra`: the drive voltage (V) that adds their force at the
    mid-points of the plant steps.
    """

    stage = "voltage"

    def __init__(self, axes, suspension, **params):
        super().__init__(axes=axes, **params)
        self.sus = suspension
        self.delta = None

    @abc.abstractmethod
    def _extra(self, d_mid, r_mid, t_mid):
        """Extra drive (V) at the step mid-points from the deflection ``d_mid`` (rad), its rate ``r_mid`` (rad/s)
        and the time ``t_mid`` (s)."""

    def voltage(self, axis, volts, h):
        if not self.acts_on(axis) or self.delta is None:
            return volts
        d = self.delta
        d_mid = 0.5 * (d[:-1] + d[1:])
        r_mid = np.diff(d) / h
        t_mid = (np.arange(volts.size) + 0.5) * h
        return volts + self._extra(d_mid, r_mid, t_mid)


class QuadraticDamping(_FixedPoint):
    """``c |d'| d'`` with ``c`` giving the loss per cycle of ``zeta_eq`` at ``amplitude_rad``."""

    name = "quadratic_damping"
    summary = "aerodynamic (quadratic) damping of the suspension"
    PARAMS = (Param("zeta_eq", "equivalent damping ratio at the dither amplitude", 0.0, 0.1, 5e-4),
              Param("amplitude_rad", "dither amplitude (rad)", 1e-6, 0.1, 1e-3))

    def _extra(self, d_mid, r_mid, t_mid):
        s = self.sus
        w0 = s.omega0
        # equal loss per cycle: 2 zeta w0 * pi a^2 w = c * (8/3) a^3 w^2 at w = w0 (harmonic balance)
        c = 2.0 * self.params["zeta_eq"] * w0 * 3.0 * math.pi / (8.0 * self.params["amplitude_rad"] * w0)
        # eq. 2: d2phi/dt2 = -w0^2 (... + k5 V); a force -c |d'| d' is k5 dV = c |d'| d' / w0^2
        return c * np.abs(r_mid) * r_mid / (w0 * w0 * s.k5)


class ThermalDrift(_FixedPoint):
    name = "thermal_drift"
    summary = "small-amplitude resonance approaching a new value exponentially"
    PARAMS = (Param("df_hz", "final change of f0 (Hz)", -100.0, 100.0, 0.2),
              Param("tau_s", "thermal time constant (s)", 1e-3, 1e4, 1.0))

    def _extra(self, d_mid, r_mid, t_mid):
        s = self.sus
        df = self.params["df_hz"] * (1.0 - np.exp(-t_mid / self.params["tau_s"]))
        # (w0 + dw)^2 delta = w0^2 (1 + 2 dw / w0) delta: the extra stiffness as k5 dV = 2 df / f0 delta
        return 2.0 * df / s.f0_hz * d_mid / s.k5


class ReadoutLowpass(Effect):
    name = "readout_lowpass"
    stage = "sense"
    summary = "first-order low-pass in the readout"
    PARAMS = (Param("tau_s", "time constant (s)", 1e-7, 0.01, 2e-5),)

    def sense(self, axis, phi, rate, h):
        if not self.acts_on(axis):
            return phi
        return _zoh_lowpass(phi, self.params["tau_s"], h)


class WarmingScale(Effect):
    name = "warming_scale"
    stage = "sense"
    summary = "a readout scale error that grows over the recording"
    PARAMS = (Param("error", "scale error in the middle of the recording", -0.5, 0.5, 1e-3),
              Param("duration_s", "recording length T (s)", 1e-3, 1e5, 1.0))

    def sense(self, axis, phi, rate, h):
        if not self.acts_on(axis):
            return phi
        t = np.arange(phi.size) * h
        eps = self.params["error"] * (0.5 + t / self.params["duration_s"])
        inc = np.diff(phi)
        return phi + np.concatenate(([0.0], np.cumsum(0.5 * (eps[:-1] + eps[1:]) * inc)))


class TurnaroundKicks(Effect):
    """Lock-in as discrete phase errors at the dither's turnarounds, nothing in between.

    At each zero crossing of the RLG's rate ``r`` (slope ``r'``), the stationary-phase evaluation of
    the lock-in term gives an angle error ``-Omega_L sqrt(2 pi / (K |r'|)) sin(psi0 + sign(r') pi / 4)``
    with ``K = 2 pi / fringe`` and ``psi0 = K phi + phase`` the Sagnac phase at the crossing
    (Killpatrick 1967, "The laser gyro", IEEE Spectrum 4(10); Aronowitz 1971): the classic random walk of a
    dithered gyro. It has no phase pulling away from the turnarounds, unlike the continuous Adler law.
    """

    name = "turnaround_kicks"
    stage = "sense"
    summary = "lock-in as phase kicks at the dither turnarounds (stationary phase)"
    PARAMS = (Param("threshold_rad_s", "lock-in rate Omega_L (rad/s)", 0.0, 1.0, 2e-3),
              Param("phase_rad", "backscatter phase (rad)", -4.0 * math.pi, 4.0 * math.pi, 1.0, default=0.0),
              Param("fringe_rad", "rotation angle per Sagnac fringe (rad)", 1e-7, 1e-3, FRINGE_RAD,
                    default=FRINGE_RAD))

    def sense(self, axis, phi, rate, h):
        if not self.acts_on(axis):
            return phi
        om = self.params["threshold_rad_s"]
        k = 2.0 * math.pi / self.params["fringe_rad"]
        cross = np.flatnonzero(np.signbit(rate[:-1]) != np.signbit(rate[1:]))
        kicks = np.zeros_like(phi)
        err = 0.0
        for j in cross:
            slope = (rate[j + 1] - rate[j]) / h
            if slope == 0.0:
                continue
            frac = rate[j] / (rate[j] - rate[j + 1])
            psi0 = k * (phi[j] + frac * (phi[j + 1] - phi[j]) + err) + self.params["phase_rad"]
            kick = -om * math.sqrt(2.0 * math.pi / (k * abs(slope))) * math.sin(psi0 + math.copysign(0.25 * math.pi,
                                                                                                 slope))
            err += kick
            kicks[j + 1] += kick
        return phi + np.cumsum(kicks)


#: Alternative forms by the catalogue effect they mimic.
ALT_FORMS = {"piezo_lag": ("two_pole_drive",), "axis_coupling": ("lowpass_coupling",),
             "block_mode": ("structural_mode",), "viscous_damping": ("quadratic_damping",),
             "resonance_drift": ("thermal_drift",), "readout_delay": ("readout_lowpass",),
             "scale_factor": ("warming_scale",), "lock_in": ("turnaround_kicks",)}


def record_alternative(inputs, truth, nominal, quantum_rad, effects, settings, noise_rad, seed, experiment,
                       description="", preroll_samples=0):
    """:func:`~sins_sim.simulation.experiment.record` with the deflections the forms here need.

    ``LowpassCoupling`` gets its source axis' deflection (one simulation of that axis); the fixed-point
    forms get their own axis' deflection, :data:`FIXED_POINT_PASSES` times.
    """
    effects = list(effects)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for e in effects:
            if isinstance(e, LowpassCoupling):
                others = [o for o in effects if o is not e and o.acts_on(e.source)]
                _, e.delta = simulate_axis(inputs, e.source, truth[e.source], others, settings, return_delta=True)
        fixed = [e for e in effects if isinstance(e, _FixedPoint)]
        for _ in range(FIXED_POINT_PASSES if fixed else 0):
            for e in fixed:
                ax = e.axes[0]
                _, d = simulate_axis(inputs, ax, truth[ax], effects, settings, return_delta=True)
                e.delta = d if e.delta is None else RELAXATION * d + (1.0 - RELAXATION) * e.delta
    return record(inputs, truth, nominal, quantum_rad, effects, settings, noise_rad=noise_rad, seed=seed,
                  experiment=experiment, description=description, preroll_samples=preroll_samples)
