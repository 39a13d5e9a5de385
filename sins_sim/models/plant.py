"""The dither suspension as a streaming simulation (eq. 2 at a fixed plant rate).

Public wrapper around the plant kernels: validates, owns the state, and
turns the kernel's regime counter into a :class:`HysteresisRegimeWarning`.
Two integrators (``PlantSettings.integrator``):

- ``"exact"`` (default): ``sins_sim._kernels.plant_exact``, the undamped
  oscillator and the kinematic and drive inputs propagated exactly over each
  step, the small terms (eq. 9, eq. 10, viscous) by a third-order
  predictor-corrector; one or two evaluations of eq. 9/10 per step, about
  0.4x the cost of RK4.
- ``"rk4"``: ``sins_sim._kernels.plant``, classical RK4 (the reference).

Both locate turning points and Masing loop closures inside the step. At
72 kHz the exact integrator agrees with RK4 at 288 kHz within 0.003 arcsec
RMS for a 3 arcmin dither from rest under 1 arcmin of 100 Hz or 1.5 kHz
vibration, both hysteresis rules (``tests/test_plant_exact.py``); RK4 at
72 kHz itself is within 0.002 arcsec except where a Masing loop closes in
the same step as a turning point (0.036 arcsec RMS at 1.5 kHz, see
``_kernels.plant_exact._find_event``).
"""

from __future__ import annotations

from dataclasses import dataclass

import math

import numpy as np

from sins_sim import _validate as v
from sins_sim._kernels import physics as kphys
from sins_sim._kernels import plant as kplant
from sins_sim._kernels import plant_exact as kexact
from sins_sim.errors import warn_regime
from sins_sim.models.suspension import SuspensionParams

__all__ = ["HYSTERESIS_RULES", "INTEGRATORS", "PlantSettings", "Plant", "simulate_plant", "RATE_RANGE_HZ",
           "MIN_STEPS_PER_PERIOD", "check_resolution"]

# the plant's ranges: declared in sins_sim.models.ranges, re-exported here
from sins_sim.models.ranges import MIN_STEPS_PER_PERIOD, PLANT_RATE_RANGE_HZ as RATE_RANGE_HZ  # noqa: E402


def check_resolution(suspension: SuspensionParams, rate_hz: float) -> None:
    """The plant must resolve the dither: ``rate_hz >= MIN_STEPS_PER_PERIOD * f0`` (ValueError naming plant.rate_hz)."""
    need = MIN_STEPS_PER_PERIOD * suspension.f0_hz
    if not rate_hz >= need:
        raise ValueError(
            f"plant.rate_hz: must be >= {MIN_STEPS_PER_PERIOD} x f0 = {need:.6g} Hz ({MIN_STEPS_PER_PERIOD} steps per "
            f"dither period, f0 = {suspension.f0_hz:g} Hz), got {rate_hz!r}"
        )

#: Hysteresis rules by name (docs/theory/suspension.md): the paper's turning-point rule and Masing's.
HYSTERESIS_RULES = kphys.RULES
#: Plant integrators by name: (kernel, state size). Both kernels keep the block's angle, rate
#: and the time at the same indices (kplant.S_PHI, S_RATE, S_TIME == kexact.X_PHI, X_RATE, X_TIME).
INTEGRATORS = {
    "exact": (kexact.plant_run_exact, kexact.STATE_SIZE),
    "rk4": (kplant.plant_run, kplant.STATE_SIZE),
}


@dataclass(frozen=True)
class PlantSettings:
    """Numerical settings of the plant integrator.

    Parameters
    ----------
    rate_hz : float
        Internal integration rate (Hz); default 72 kHz, the paper's readout rate.
    hysteresis : {"paper", "masing"}
        Rule that tracks eq. 10's half-cycle amplitude.
    integrator : {"exact", "rk4"}
        ``"exact"`` (default): exact oscillator plus a third-order
        predictor-corrector for the small terms (``_kernels.plant_exact``);
        ``"rk4"``: classical RK4 (``_kernels.plant``), the reference.
    """

    rate_hz: float = 72000.0
    hysteresis: str = "paper"
    integrator: str = "exact"

    def __post_init__(self):
        rate = v.positive("plant", "rate_hz", self.rate_hz)
        if not RATE_RANGE_HZ[0] <= rate <= RATE_RANGE_HZ[1]:
            raise ValueError(f"plant.rate_hz: must be in [{RATE_RANGE_HZ[0]:g}, {RATE_RANGE_HZ[1]:g}] Hz, got {rate!r}")
        v.choice("plant", "hysteresis", self.hysteresis, HYSTERESIS_RULES)
        v.choice("plant", "integrator", self.integrator, INTEGRATORS)


class Plant:
    """One suspension integrated chunk by chunk; chunked == whole-array, bit for bit.

    Parameters
    ----------
    suspension : SuspensionParams
    settings : PlantSettings

    Attributes
    ----------
    state : ndarray
        The kernel's state (``_kernels.plant`` or ``_kernels.plant_exact``
        layout: delta, then the RLG rate (rk4) or d delta/dt (exact), the
        block's angle, rate and the time at the last grid point, then the
        exact integrator's history). :meth:`reset` starts from rest: delta = 0,
        d delta/dt = 0 at t = 0 (a recording's ``initial_state: rest``, sins_sim.io.recording).
    hyst, stack : ndarray
        Eq. 10's branch and reversal stack (``_kernels.physics``).
    """

    def __init__(self, suspension: SuspensionParams, settings: PlantSettings = PlantSettings()):
        check_resolution(suspension, settings.rate_hz)
        self.suspension = suspension
        self.settings = settings
        self.h = 1.0 / settings.rate_hz
        self._rule = HYSTERESIS_RULES[settings.hysteresis]
        self._fast_dt = 0.25 / suspension.f0_hz
        self._warned = False
        self._kernel, size = INTEGRATORS[settings.integrator]
        self._exact = settings.integrator == "exact"
        self.state = np.zeros(size)  # indices S_PHI, S_RATE, S_TIME are common to both layouts
        self.hyst = np.zeros(kphys.HYST_SIZE)
        self.stack = np.zeros(kphys.STACK_SIZE)
        self.reset()

    def reset(self, sins_angle0: float = 0.0, sins_rate0: float = 0.0) -> None:
        """Back to rest at t = 0 with the block at the given angle and rate."""
        self.state[:] = 0.0
        self.state[kplant.S_PHI] = v.finite("plant", "sins_angle0", sins_angle0)
        self.state[kplant.S_RATE] = v.finite("plant", "sins_rate0", sins_rate0)
        if not self._exact:
            self.state[kplant.S_OMEGA] = sins_rate0  # RLG rate; the exact kernel keeps d delta/dt = 0
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

    def step(self, sins_angle, sins_rate, volts, check: bool = True, f0_hz: float | None = None) -> np.ndarray:
        """Advance ``len(volts)`` steps; return delta at the new grid points (rad).

        ``sins_angle`` and ``sins_rate`` are the block's angle and rate at the
        ends of the steps; ``volts`` the drive held over each step. ``check=False``
        skips the input checks for callers (the engine) that pass contiguous,
        finite float64 arrays of equal length they made themselves. ``f0_hz``
        (checked by the caller) replaces the suspension's resonance for these
        steps only: a resonance that drifts, stepped in short blocks, without a
        new suspension object per block.
        """
        if check:
            volts = np.ascontiguousarray(v.finite_array("plant", "volts", volts))
            sins_angle = np.ascontiguousarray(v.finite_array("plant", "sins_angle", sins_angle))
            sins_rate = np.ascontiguousarray(v.finite_array("plant", "sins_rate", sins_rate))
        n = volts.shape[0]
        if sins_angle.shape[0] != n or sins_rate.shape[0] != n:
            raise ValueError(
                f"plant.sins_angle: angle, rate and volts must have the same length, got "
                f"{sins_angle.shape[0]}, {sins_rate.shape[0]}, {n}"
            )
        out = np.empty(n)
        s = self.suspension
        w0 = s.omega0 if f0_hz is None else 2.0 * math.pi * f0_hz  # SuspensionParams.omega0
        self._kernel(sins_angle, sins_rate, volts, self.h, w0 * w0, s.k1, s.k2, s.k3, s.k4, s.k5,
                     2.0 * s.zeta / w0, self._rule, self._fast_dt, self.state, self.hyst, self.stack, out)
        self._check_regime()
        return out

    def _check_regime(self) -> None:
        # eq. 10 is absent when k3 = 0: no rule to break
        if self.suspension.k3 > 0.0 and self._rule == kphys.RULE_PAPER and self.hyst[5] > 0 and not self._warned:
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
