"""The unit's temperature over a mission, and what it does to each dither suspension.

A scenario's ``temperature:`` section (``sins_sim.config.scenario``) gives a profile ``T(t)`` and the
suspension's temperature coefficients; the engine (:class:`~sins_sim.simulation.channel.ChannelChain`)
updates the plant's ``omega0`` (and optionally k1..k5) in blocks of ``update_s`` counted from t = 0,
with the temperature at each block's middle, so results do not depend on chunking.

Model (a linear temperature coefficient: the definition of the coefficient, first order in
``T - T_ref``)::

    p(T) = p_ref * (1 + c_p * (T - T_ref))        for p in f0, k1 .. k5, c_p in 1/K (ppm/K at the edges)

Physics of ``c_f0``: the dither spring's stiffness is proportional to Young's (or the shear)
modulus E and the RLG's inertia is fixed, so ``f0 ~ sqrt(E)`` times a geometric factor; with the
spring's thermal expansion alpha, ``d ln f0 / dT ~ TCE / 2 + alpha / 2`` for a flexure (thickness up,
length up, the inertia's radius up). The temperature coefficient of the modulus (TCE) is:

* carbon and spring steels: about -2.4e-4 to -3e-4 1/K (Keulegan and Houseman, "Temperature
  coefficient of the moduli of metals and alloys used as elastic elements", J. Res. NBS 10, RP531,
  1933, -50 to +50 C), so with alpha ~ 1.2e-5 1/K: ``c_f0`` about -110 to -145 ppm/K;
* constant-modulus alloys (Elinvar, Ni-Span-C 902): the TCE is set by the heat treatment to within
  about +-2e-5 1/K of zero (a linear positive TCE of about +20 ppm/degF, 36 ppm/K, after a heat
  treatment for maximum strength; near zero after the recommended one), so ``|c_f0|`` <= about
  10-20 ppm/K.

The bundled scenario takes -30 ppm/K: a compensated spring between the two. The other coefficients
(k1, k2 of eq. 9; k3, k4 of eq. 10's internal friction; k5 of the piezo, whose d31 rises by
roughly 0.1-0.3 %/K in PZT) default to 0: the project has no measurement of them.

A sensor block on elastomeric isolators (an IMU ``block:`` section) has two more, on the same linear model:
``c_k`` for the isolators' stiffness (translational and rotational) and ``c_c`` for their damping
(:meth:`ThermalModel.block_at`). Their sign and size depend on the compound and the frequency, and both
default to 0 (isolators held at their file values):

* an unfilled rubber far above its glass transition is an entropy spring, ``G = n k T`` (Treloar, *The
  Physics of Rubber Elasticity*, 3rd ed., 1975, ch. 4), so ``d ln k / dT = 1 / T``: +3400 ppm/K at 293 K;
* the filled, damped compounds of isolators are viscoelastic: by time-temperature superposition (Williams,
  Landel and Ferry, J. Am. Chem. Soc. 77, 3701, 1955) warming shifts their relaxation to higher frequencies,
  so the storage modulus at a fixed frequency falls with temperature, and their makers publish stiffness
  against temperature curves that fall on warming; take the mount's own curve, linearised about
  ``reference_k``.

The gyros' dither resonances on the block move with their suspensions (``c_f0``); the coupled modes the
drives lock to follow from both (:func:`sins_sim.models.block.coupled_dither_frequencies`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from sins_sim import _validate as v
from sins_sim.models.suspension import SuspensionParams

__all__ = ["TemperatureProfile", "ThermalModel", "PROFILES", "K_NAMES", "DEFAULT_UPDATE_S"]

PROFILES = ("constant", "ramp", "step", "table")
K_NAMES = ("k1", "k2", "k3", "k4", "k5")
#: Default update interval of the plant's parameters (s): the resonance-drift effect's block (0.02 s).
#: A 30 K ramp over 600 s at -30 ppm/K moves f0 by 3e-5 ppm per block: far below anything the filters see.
DEFAULT_UPDATE_S = 0.02
#: Temperatures the model accepts (K): -100 C to +200 C, beyond the military range (-55 C to +125 C).
TEMPERATURE_RANGE_K = (173.15, 473.15)


@dataclass(frozen=True)
class TemperatureProfile:
    """The unit's temperature ``T(t)`` (K) over the mission.

    ``constant``: ``start_k``; ``ramp``: ``start_k`` until ``start_s``, linear to ``end_k`` over
    ``duration_s``, then ``end_k``; ``step``: ``start_k`` before ``start_s``, ``start_k + step_k``
    from then on; ``table``: linear interpolation of ``(t_s, temp_k)`` rows, held at the ends.
    """

    kind: str = "constant"
    start_k: float = 293.15
    end_k: float = 293.15
    step_k: float = 0.0
    start_s: float = 0.0
    duration_s: float = 0.0
    table: tuple = ()

    def __post_init__(self):
        v.choice("temperature", "profile", self.kind, PROFILES)
        v.non_negative("temperature", "start_s", self.start_s)
        if self.kind == "ramp":
            v.positive("temperature", "duration_s", self.duration_s)
        if self.kind == "table":
            rows = tuple((float(t), float(k)) for t, k in self.table)
            if len(rows) < 2:
                raise ValueError(f"temperature.table_s_k: needs at least 2 rows, got {len(rows)}")
            ts = [t for t, _ in rows]
            if any(b <= a for a, b in zip(ts, ts[1:])):
                raise ValueError("temperature.table_s_k: times must increase strictly")
            object.__setattr__(self, "table", rows)
        lo, hi = TEMPERATURE_RANGE_K
        for name, value in (("start_k", self.start_k), ("end_k", self.end_k),
                            ("start_k + step_k", self.start_k + self.step_k)):
            if not lo <= value <= hi:
                raise ValueError(f"temperature.{name}: must lie in [{lo:g}, {hi:g}] K, got {value!r}")
        for i, (_, k) in enumerate(self.table):
            if not lo <= k <= hi:
                raise ValueError(f"temperature.table_s_k[{i}][1]: must lie in [{lo:g}, {hi:g}] K, got {k!r}")

    def at(self, t_s):
        """Temperature (K) at times ``t_s`` (s; scalar or array)."""
        t = np.asarray(t_s, dtype=np.float64)
        if self.kind == "constant":
            out = np.full_like(t, self.start_k)
        elif self.kind == "ramp":
            u = np.clip((t - self.start_s) / self.duration_s, 0.0, 1.0)
            out = self.start_k + (self.end_k - self.start_k) * u
        elif self.kind == "step":
            out = np.where(t < self.start_s, self.start_k, self.start_k + self.step_k)
        else:
            ts, ks = zip(*self.table)
            out = np.interp(t, ts, ks)
        return float(out) if out.ndim == 0 else out

    def extremes(self, duration_s: float) -> tuple:
        """(lowest, highest) temperature over ``0 .. duration_s`` (K): the profile is piecewise linear."""
        pts = [0.0, float(duration_s)]
        if self.kind in ("ramp", "step"):
            pts += [self.start_s, self.start_s + self.duration_s]
        elif self.kind == "table":
            pts += [t for t, _ in self.table]
        temps = [self.at(min(max(p, 0.0), duration_s)) for p in pts]
        if self.kind == "step" and self.start_s <= duration_s:
            temps.append(self.start_k + self.step_k)
        return min(temps), max(temps)


@dataclass(frozen=True)
class ThermalModel:
    """A temperature profile and the suspension's linear temperature coefficients (module docstring).

    Parameters
    ----------
    profile : TemperatureProfile
    f0_per_k : float
        Relative change of f0 per kelvin (1/K; -30e-6 is -30 ppm/K).
    k_per_k : tuple of 5 float
        Relative change of k1 .. k5 per kelvin (1/K).
    reference_k : float or None
        The temperature at which the IMU file's f0 and k's hold (None: the profile's at t = 0).
    update_s : float
        Interval of the parameter updates (s), rounded to whole filter samples by the engine.
    isolator_stiffness_per_k, isolator_damping_per_k : float
        Relative change per kelvin (1/K) of a block's isolator stiffness (translational and rotational) and
        damping (module docstring); 0: held. Only a unit with a block on isolators has them.
    """

    profile: TemperatureProfile = TemperatureProfile()
    f0_per_k: float = 0.0
    k_per_k: tuple = (0.0, 0.0, 0.0, 0.0, 0.0)
    reference_k: float | None = None
    update_s: float = DEFAULT_UPDATE_S
    isolator_stiffness_per_k: float = 0.0
    isolator_damping_per_k: float = 0.0

    def __post_init__(self):
        if not isinstance(self.profile, TemperatureProfile):
            raise ValueError(f"temperature.profile: must be a TemperatureProfile, got {self.profile!r}")
        v.finite("temperature", "f0_ppm_per_k", self.f0_per_k)
        ks = tuple(float(v.finite("temperature", f"k_ppm_per_k.{n}", c)) for n, c in zip(K_NAMES, self.k_per_k))
        if len(ks) != 5:
            raise ValueError(f"temperature.k_ppm_per_k: needs 5 coefficients (k1 .. k5), got {self.k_per_k!r}")
        object.__setattr__(self, "k_per_k", ks)
        if self.reference_k is None:
            object.__setattr__(self, "reference_k", float(self.profile.at(0.0)))
        v.positive("temperature", "reference_k", self.reference_k)
        v.positive("temperature", "update_s", self.update_s)
        v.finite("temperature", "isolators.stiffness_ppm_per_k", self.isolator_stiffness_per_k)
        v.finite("temperature", "isolators.damping_ppm_per_k", self.isolator_damping_per_k)

    @property
    def moves_isolators(self) -> bool:
        """True when the isolators' stiffness or damping changes with temperature."""
        return self.isolator_stiffness_per_k != 0.0 or self.isolator_damping_per_k != 0.0

    def block_at(self, block, temp_k: float):
        """``block`` (a :class:`~sins_sim.models.block.BlockParams` valid at ``reference_k``) at ``temp_k``: its
        isolators' stiffness times ``1 + c_k (T - T_ref)`` and damping times ``1 + c_c (T - T_ref)``; the same
        block when neither coefficient is set."""
        if not self.moves_isolators:
            return block
        dt = float(temp_k) - self.reference_k
        fk, fc = 1.0 + self.isolator_stiffness_per_k * dt, 1.0 + self.isolator_damping_per_k * dt
        return replace(block, k_trans_n_per_m=block.k_trans_n_per_m * fk,
                       k_rot_n_m_per_rad=block.k_rot_n_m_per_rad * fk,
                       c_trans_n_s_per_m=block.c_trans_n_s_per_m * fc,
                       c_rot_n_m_s_per_rad=block.c_rot_n_m_s_per_rad * fc)

    def check_block(self, block, duration_s: float, where: str = "temperature") -> tuple:
        """The block at the profile's extremes over the mission (its linear model kept within
        ``1 + c (T - T_ref) > 0.5``, as for the suspension); one line naming the key otherwise."""
        out = []
        for temp in self.profile.extremes(duration_s):
            dt = temp - self.reference_k
            for name, c in (("isolators.stiffness_ppm_per_k", self.isolator_stiffness_per_k),
                            ("isolators.damping_ppm_per_k", self.isolator_damping_per_k)):
                if not 1.0 + c * dt > 0.5:
                    raise ValueError(f"{where}.{name}: the linear model leaves its range at {temp:.6g} K "
                                     f"(1 + c (T - T_ref) = {1.0 + c * dt:.4g}, must stay > 0.5)")
            out.append(self.block_at(block, temp))
        return tuple(out)

    @property
    def is_null(self) -> bool:
        """True when every coefficient is zero (the suspension does not change)."""
        return self.f0_per_k == 0.0 and not any(self.k_per_k)

    def suspension_at(self, base: SuspensionParams, temp_k: float) -> SuspensionParams:
        """``base`` (valid at ``reference_k``) at temperature ``temp_k``: ``p (1 + c_p (T - T_ref))``."""
        dt = float(temp_k) - self.reference_k
        ch = {"f0_hz": base.f0_hz * (1.0 + self.f0_per_k * dt)}
        for name, c in zip(K_NAMES, self.k_per_k):
            ch[name] = getattr(base, name) * (1.0 + c * dt)
        return base.replace(**ch)

    def check(self, base: SuspensionParams, duration_s: float, where: str = "temperature") -> tuple:
        """The suspension at the profile's extremes over the mission; one line naming the key otherwise."""
        out = []
        for temp in self.profile.extremes(duration_s):
            dt = temp - self.reference_k
            for name, c in (("f0_ppm_per_k", self.f0_per_k),) + tuple(
                    (f"k_ppm_per_k.{n}", c) for n, c in zip(K_NAMES, self.k_per_k)):
                if not 1.0 + c * dt > 0.5:
                    raise ValueError(f"{where}.{name}: the linear model leaves its range at {temp:.6g} K "
                                     f"(1 + c (T - T_ref) = {1.0 + c * dt:.4g}, must stay > 0.5)")
            try:
                out.append(self.suspension_at(base, temp))
            except ValueError as exc:
                raise ValueError(f"{where}: at {temp:.6g} K: {exc}") from None
        return tuple(out)

