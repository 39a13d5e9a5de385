"""The dither suspension as a streaming simulation (eq. 2, RK4 at a fixed plant rate).

Public wrapper around ``sins_sim._kernels.plant``: validates, owns the state,
and turns the kernel's regime counter into a :class:`HysteresisRegimeWarning`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sins_sim import _validate as v
from sins_sim._kernels import physics as kphys
from sins_sim._kernels import plant as kplant
from sins_sim.errors import warn_regime
from sins_sim.models.suspension import SuspensionParams

__all__ = ["HYSTERESIS_RULES", "PlantSettings", "Plant", "simulate_plant"]

#: Hysteresis rules by name (reference-model.md): the paper's turning-point rule and Masing's.
HYSTERESIS_RULES = kphys.RULES


@dataclass(frozen=True)
class PlantSettings:
    """Numerical settings of the plant integrator.

    Parameters
    ----------
    rate_hz : float
        Internal integration rate (Hz); default 72 kHz, the paper's readout rate.
    hysteresis : {"paper", "masing"}
        Rule that tracks eq. 10's half-cycle amplitude.
    """

    rate_hz: float = 72000.0
    hysteresis: str = "paper"

    def __post_init__(self):
        v.positive("plant", "rate_hz", self.rate_hz)
        v.choice("plant", "hysteresis", self.hysteresis, HYSTERESIS_RULES)


class Plant:
    """One suspension integrated chunk by chunk; chunked == whole-array, bit for bit.

    Parameters
    ----------
    suspension : SuspensionParams
    settings : PlantSettings
    initial_rate : float
        Initial RLG rate relative to the block (rad/s); 0 = rest (delta = 0,
        d delta/dt = 0 at t = 0, recording-format.md ``initial_state: rest``).
    """

    def __init__(self, suspension: SuspensionParams, settings: PlantSettings = PlantSettings()):
        if suspension.f0_hz >= settings.rate_hz / 8.0:
            raise ValueError(
                f"plant.rate_hz: must be >= 8 x f0 = {8 * suspension.f0_hz:.6g} Hz for RK4 to resolve the "
                f"resonance, got {settings.rate_hz!r}"
            )
        self.suspension = suspension
        self.settings = settings
        self.h = 1.0 / settings.rate_hz
        self._rule = HYSTERESIS_RULES[settings.hysteresis]
        self._fast_dt = 0.25 / suspension.f0_hz
        self._warned = False
        self.state = np.zeros(kplant.STATE_SIZE)
        self.hyst = np.zeros(kphys.HYST_SIZE)
        self.stack = np.zeros(kphys.STACK_SIZE)
        self.reset()

    def reset(self, sins_angle0: float = 0.0, sins_rate0: float = 0.0) -> None:
        """Back to rest at t = 0 with the block at the given angle and rate."""
        self.state[:] = 0.0
        self.state[kplant.S_PHI] = v.finite("plant", "sins_angle0", sins_angle0)
        self.state[kplant.S_RATE] = v.finite("plant", "sins_rate0", sins_rate0)
        self.state[kplant.S_OMEGA] = sins_rate0
        kphys.hyst_reset(self.hyst, self.stack)
        self._warned = False

    @property
    def time(self) -> float:
        """Time of the last grid point reached (s)."""
        return float(self.state[kplant.S_TIME])

    @property
    def fast_half_cycles(self) -> int:
        """Half-cycles shorter than a quarter dither period so far (the paper's rule breaks there)."""
        return int(self.hyst[5])

    def step(self, sins_angle, sins_rate, volts) -> np.ndarray:
        """Advance ``len(volts)`` steps; return delta at the new grid points (rad).

        ``sins_angle`` and ``sins_rate`` are the block's angle and rate at the
        ends of the steps; ``volts`` the drive held over each step.
        """
        volts = v.finite_array("plant", "volts", volts)
        n = volts.shape[0]
        sins_angle = v.finite_array("plant", "sins_angle", sins_angle)
        sins_rate = v.finite_array("plant", "sins_rate", sins_rate)
        if sins_angle.shape[0] != n or sins_rate.shape[0] != n:
            raise ValueError(
                f"plant.sins_angle: angle, rate and volts must have the same length, got "
                f"{sins_angle.shape[0]}, {sins_rate.shape[0]}, {n}"
            )
        out = np.empty(n)
        s = self.suspension
        w0 = s.omega0
        kplant.plant_run(sins_angle, sins_rate, volts, self.h, w0 * w0, s.k1, s.k2, s.k3, s.k4, s.k5,
                         2.0 * s.zeta / w0, self._rule, self._fast_dt, self.state, self.hyst, self.stack, out)
        self._check_regime()
        return out

    def _check_regime(self) -> None:
        if self._rule == kphys.RULE_PAPER and self.hyst[5] > 0 and not self._warned:
            self._warned = True
            warn_regime("plant", int(self.hyst[5]), float(self.hyst[6]), "the deflection")


def simulate_plant(suspension: SuspensionParams, volts, motion=None, settings: PlantSettings = PlantSettings(),
                   chunk: int | None = None):
    """Simulate the suspension from rest over ``len(volts)`` plant steps.

    Parameters
    ----------
    volts : array
        Drive voltage held over each plant step (V).
    motion : None or motion object (``sins_sim.models.motion``)
        Block angle about the sensitive axis; ``None`` = at rest.
    chunk : int, optional
        Process in chunks of this many steps (results are identical).

    Returns
    -------
    t, delta, phi_rlg, phi_sins : arrays of length ``len(volts) + 1``
        Grid times (s), deflection, RLG angle and SINS angle (rad), from t = 0.
    """
    from sins_sim.models.motion import as_motion

    volts = v.finite_array("plant", "volts", volts)
    motion = as_motion(motion)
    plant = Plant(suspension, settings)
    n = volts.shape[0]
    t = np.arange(n + 1) * plant.h
    phi, rate = motion.angle_rate(t)
    plant.reset(phi[0], rate[0])
    step = n if chunk is None else int(chunk)
    delta = np.empty(n + 1)
    delta[0] = 0.0
    for i0 in range(0, n, max(step, 1)):
        i1 = min(i0 + step, n)
        delta[i0 + 1:i1 + 1] = plant.step(phi[i0 + 1:i1 + 1], rate[i0 + 1:i1 + 1], volts[i0:i1])
    return t, delta, phi + delta, phi
