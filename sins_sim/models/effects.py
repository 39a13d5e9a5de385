"""Unmodelled effects: named, parameterised extensions of the nominal channel model.

docs/theory/index.md ("What is modelled"): the nominal model is a rigid block with
three independent suspensions, each obeying eq. 2 with eq. 9, 10 and 14,
and an ideal fringe counter. Everything beyond it is an effect that a
configuration switches on. Each effect here is a small frozen object with
SI parameters, validated on construction, that acts at one stage of the
experiment simulator (``sins_sim.simulation.experiment``):

============== ============ ==========================================================
name           stage        what it does
============== ============ ==========================================================
piezo_lag      voltage      first-order lag of the effective piezo voltage, ``tau_s``
axis_coupling  coupling     a channel's block angle picks up the other channels'
                            dither deflections, ``coefficients[target][source]``
block_mode     block        structural mode of the block/mount between table and gyros:
                            the block angle is the table angle through a second-order
                            resonance (``frequency_hz``, ``zeta``, ``gain``)
viscous_damping suspension  velocity-proportional damping ``zeta`` beside eq. 10
resonance_drift plant       ``f0`` changing linearly, ``rate_hz_per_s``
readout_delay  readout      the readout samples the RLG ``delay_s`` late
scale_factor   readout      readout scale error, angle x ``(1 + error)``
lock_in        sense        backscatter lock-in: Adler equation on the Sagnac phase,
                            ``threshold_rad_s``, ``phase_rad``, ``fringe_rad``
============== ============ ==========================================================

Four more disturbances live in :data:`DISTURBANCES`, outside the catalogue:
they exist so that the blind evaluation can test that the diagnosis says
``unknown`` for what it does not know (``mains_pickup``: a sine added to the
readout; ``drive_harmonic``: a quadratic piezo, ``V + c2 V^2``; ``mount_mode``: a structural mode of the
mount at 1-3 kHz rung by ambient vibration, a resonant peak in the readout that is physics, not a defect;
``bias_drift``: a slow ramp and random walk of the readout bias, a nuisance of every gyro).

Registries: :data:`EFFECTS` (the catalogue, by name), :data:`DISTURBANCES`;
:func:`make_effect` builds either from a name and parameters, as a scenario
file gives them.

Definitions
-----------
piezo_lag
    ``tau dV_eff/dt = V - V_eff``, ``V_eff(0) = 0``; the plant receives the
    exact average of ``V_eff`` over each plant step (the drive is held
    between DAC updates, so this is exact).
block_mode
    With ``u'' + 2 zeta w u' + w^2 u = 2 zeta w phi' + w^2 phi`` (``w = 2 pi
    frequency_hz``, ``phi`` the table angle; the block on a flexible mount,
    whose relative motion ``u - phi`` is excited by the table's
    acceleration), the gyros' block angle is ``(1 - gain) phi + gain u``
    (``gain = 1``: the whole block rides on the mode). ``u(0) = phi(0)``,
    ``u'(0) = phi'(0)``; ``phi`` between grid points is the cubic Hermite
    interpolant of angle and rate (as for the plant), integrated exactly.
    Invisible while the table does not move.
axis_coupling
    ``phi_block_i = phi_table_i + sum_j c_ij delta_j`` (and the same for
    the rates): the mount transmits a fraction of the other gyros' dither
    deflection to gyro ``i``.
resonance_drift
    ``f0(t) = f0 + rate_hz_per_s * t`` (e.g. temperature).
readout_delay
    Sample ``n`` of the readout holds the RLG angle at ``n / fs - delay_s``
    (the angle before ``t = 0`` is the rest angle).
scale_factor
    The readout angle is ``(1 + error)`` times the RLG angle (in a recording
    without table motion this is indistinguishable from a rescaling of
    ``k1, k2, k4, k5``, so it is identifiable only with table motion).
lock_in
    ``psi = 2 pi phi_meas / fringe_rad + phase_rad``,
    ``dpsi/dt = 2 pi/fringe_rad (dphi_rlg/dt - threshold_rad_s sin psi)``
    (Adler), integrated at the plant rate with sub-steps that resolve the
    Sagnac beat; the readout counts ``phi_meas``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from types import MappingProxyType
from typing import ClassVar

import numpy as np
from scipy import linalg, signal

from sins_sim._kernels.effects import lock_in_run, mode_run
from sins_sim.models.suspension import SuspensionParams
from sins_sim.units import FRINGE_RAD

__all__ = ["Param", "Effect", "PiezoLag", "AxisCoupling", "BlockMode", "ViscousDamping", "ResonanceDrift",
           "ReadoutDelay", "ScaleFactor", "LockIn", "MainsPickup", "DriveHarmonic", "MountMode", "BiasDrift", "EFFECTS", "DISTURBANCES",
           "make_effect", "effect_names", "rate_from_grid"]


@dataclass(frozen=True)
class Param:
    """One scalar parameter of an effect.

    Parameters
    ----------
    name : str
        Key (SI unit in the name where it has one).
    doc : str
    lo, hi : float
        Valid range (inclusive).
    scale : float
        Typical size: the unit in which a fit moves it.
    default : float or None
        Value when not given (``None``: required).
    fit : bool
        Whether the diagnosis fits it.
    """

    name: str
    doc: str
    lo: float
    hi: float
    scale: float
    default: float | None = None
    fit: bool = True


def _check_param(effect: str, p: Param, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise ValueError(f"effects.{effect}.{p.name}: must be a finite number, got {value!r}")
    value = float(value)
    if not math.isfinite(value) or not p.lo <= value <= p.hi:
        raise ValueError(f"effects.{effect}.{p.name}: must be in [{p.lo:g}, {p.hi:g}], got {value!r}")
    return value


def rate_from_grid(x: np.ndarray, h: float) -> np.ndarray:
    """Derivative of a signal on a uniform grid: 4th-order central differences, 2nd-order at the ends."""
    x = np.asarray(x, dtype=np.float64)
    d = np.empty_like(x)
    n = x.size
    if n < 5:
        return np.gradient(x, h) if n > 1 else np.zeros_like(x)
    d[2:-2] = (x[:-4] - 8.0 * x[1:-3] + 8.0 * x[3:-1] - x[4:]) / (12.0 * h)
    d[0] = (-3.0 * x[0] + 4.0 * x[1] - x[2]) / (2.0 * h)
    d[1] = (x[2] - x[0]) / (2.0 * h)
    d[-2] = (x[-1] - x[-3]) / (2.0 * h)
    d[-1] = (3.0 * x[-1] - 4.0 * x[-2] + x[-3]) / (2.0 * h)
    return d


def _unknown_parameter(effect: str, key, allowed) -> None:
    """Refuse parameter ``key`` of ``effect``: the key path, the allowed keys and the closest one (difflib)."""
    import difflib

    names = sorted(set(allowed) | {"axes"})
    close = difflib.get_close_matches(str(key), names, n=1)
    hint = f"; did you mean {close[0]!r}?" if close else ""
    raise ValueError(f"effects.{effect}.{key}: unknown parameter (allowed: {', '.join(names)}){hint}")


class Effect:
    """Base class: a named model extension with validated SI parameters.

    Parameters
    ----------
    axes : list of str or None
        Axes the effect acts on (``None``: every axis).
    **params
        The parameters of :attr:`PARAMS` (unknown names are errors).

    Hooks (identity here; each effect overrides the one of its stage) are
    called by the experiment simulator with per-axis arrays on the plant
    grid (``n + 1`` points including ``t = 0``, step ``h``).
    """

    name: ClassVar[str] = ""
    stage: ClassVar[str] = ""
    summary: ClassVar[str] = ""
    PARAMS: ClassVar[tuple] = ()
    #: True when the effect is invisible while the block does not move.
    needs_motion: ClassVar[bool] = False
    #: Fewest axes the effect needs to exist.
    min_axes: ClassVar[int] = 1

    def __init__(self, axes=None, **params):
        if axes is not None:
            if isinstance(axes, str) or not all(isinstance(a, str) and a for a in axes) or not len(axes):
                raise ValueError(f"effects.{self.name}.axes: must be a non-empty list of axis names, got {axes!r}")
            axes = tuple(axes)
        self.axes = axes
        known = {p.name: p for p in self.PARAMS}
        for key in params:
            if key not in known:
                _unknown_parameter(self.name, key, known)
        values = {}
        for p in self.PARAMS:
            if p.name in params:
                values[p.name] = _check_param(self.name, p, params[p.name])
            elif p.default is not None:
                values[p.name] = float(p.default)
            else:
                raise ValueError(f"effects.{self.name}.{p.name}: is required")
        self.params = MappingProxyType(values)
        self._check()

    def _check(self) -> None:
        """Cross-parameter checks (subclasses)."""

    def __repr__(self):
        args = ", ".join(f"{k}={v!r}" for k, v in self.params.items())
        ax = f", axes={list(self.axes)!r}" if self.axes is not None else ""
        return f"{type(self).__name__}({args}{ax})"

    def __eq__(self, other):
        return type(self) is type(other) and self.to_dict() == other.to_dict()

    def __hash__(self):
        return hash(repr(self))

    @classmethod
    def unresolved(cls, axis: str, values: dict) -> str | None:
        """Why a fit with parameter ``values`` on ``axis`` lacks the feature that defines this effect
        (the diagnosis then ranks it after fits that show theirs), or ``None``: by default every fit
        shows it."""
        return None

    def to_dict(self) -> dict:
        """``{"name": ..., "axes": [...], <params>}`` (what a scenario file holds)."""
        out = {"name": self.name, **dict(self.params)}
        if self.axes is not None:
            out["axes"] = list(self.axes)
        return out

    def acts_on(self, axis: str) -> bool:
        return self.axes is None or axis in self.axes

    def check_axes(self, axes) -> None:
        """Raise if the effect names an axis the unit or experiment does not have."""
        for a in self.axes or ():
            if a not in axes:
                raise ValueError(f"effects.{self.name}.axes: {a!r} is not one of the axes {list(axes)}")
        if len(axes) < self.min_axes:
            raise ValueError(f"effects.{self.name}: needs at least {self.min_axes} axes, there are {len(axes)}")

    # --- fitting protocol -------------------------------------------------------------------
    @classmethod
    def fit_space(cls, axis: str, axes) -> list:
        """The fitted parameters for one axis: list of ``Param`` (keys of :meth:`build`)."""
        return [p for p in cls.PARAMS if p.fit]

    @classmethod
    def build(cls, axis: str, axes, values: dict) -> "Effect":
        """The effect acting on ``axis`` only with the fitted ``values``."""
        return cls(axes=[axis], **values)

    def values(self, axis: str) -> dict:
        """The fitted parameters' values for ``axis`` (inverse of :meth:`build`)."""
        return {p.name: self.params[p.name] for p in self.fit_space(axis, ()) if p.name in self.params}

    # --- hooks --------------------------------------------------------------------------------
    def suspension(self, axis: str, s: SuspensionParams) -> SuspensionParams:
        return s

    def f0_rate_hz_per_s(self, axis: str) -> float:
        return 0.0

    def voltage(self, axis: str, volts: np.ndarray, h: float) -> np.ndarray:
        return volts

    def block(self, axis: str, angle: np.ndarray, rate: np.ndarray, h: float):
        return angle, rate

    def coupling(self, axis: str) -> dict:
        return {}

    def sense(self, axis: str, phi: np.ndarray, rate: np.ndarray, h: float) -> np.ndarray:
        return phi

    def delay_s(self, axis: str) -> float:
        return 0.0

    def scale(self, axis: str) -> float:
        return 1.0

    def additive(self, axis: str, t: np.ndarray):
        return None


class PiezoLag(Effect):
    name = "piezo_lag"
    stage = "voltage"
    summary = "first-order lag of the effective piezo voltage (drive electronics)"
    PARAMS = (Param("tau_s", "time constant of the lag (s)", 0.0, 0.01, 1e-4),)

    def voltage(self, axis, volts, h):
        tau = self.params["tau_s"]
        if not self.acts_on(axis) or tau <= 0.0:
            return volts
        a = math.exp(-h / tau)
        y_end = signal.lfilter([1.0 - a], [1.0, -a], volts)
        y_start = np.concatenate(([0.0], y_end[:-1]))
        # exact mean of V_eff over each step with V held: V + (V_eff(start) - V) tau/h (1 - a)
        return volts + (y_start - volts) * (tau / h) * (1.0 - a)

    def voltage_stream(self, axis, volts, h, state):
        """:meth:`voltage` chunk by chunk: ``state[0]`` is ``V_eff`` at the chunk's start (0 at rest), updated.

        Same recursion (``lfilter`` with its initial condition ``a V_eff(start)``), so a chunked run
        equals the whole-array :meth:`voltage` to rounding.
        """
        tau = self.params["tau_s"]
        if not self.acts_on(axis) or tau <= 0.0 or volts.shape[0] == 0:
            return volts
        a = math.exp(-h / tau)
        y_end, _ = signal.lfilter([1.0 - a], [1.0, -a], volts, zi=[a * float(state[0])])
        y_start = np.concatenate(([float(state[0])], y_end[:-1]))
        state[0] = float(y_end[-1])
        return volts + (y_start - volts) * (tau / h) * (1.0 - a)


class AxisCoupling(Effect):
    """``coefficients = {target: {source: c}}``: gyro ``target``'s block angle gains ``c delta_source``."""

    name = "axis_coupling"
    stage = "coupling"
    summary = "a channel's block angle picks up the other channels' dither deflections"
    PARAMS = ()
    min_axes = 2
    LIMIT = 0.2

    def __init__(self, coefficients=None, axes=None):
        super().__init__(axes=None)
        if not isinstance(coefficients, dict) or not coefficients:
            raise ValueError(f"effects.axis_coupling.coefficients: must be a mapping target -> {{source: c}}, "
                             f"got {coefficients!r}")
        clean = {}
        for tgt, row in coefficients.items():
            if not isinstance(tgt, str) or not isinstance(row, dict):
                raise ValueError(f"effects.axis_coupling.coefficients.{tgt}: must be a mapping source -> c, "
                                 f"got {row!r}")
            clean[tgt] = {}
            for src, c in row.items():
                p = Param(f"coefficients.{tgt}.{src}", "", -self.LIMIT, self.LIMIT, 1e-2)
                val = _check_param("axis_coupling", p, c)
                if src == tgt:
                    raise ValueError(f"effects.axis_coupling.coefficients.{tgt}.{src}: an axis does not couple "
                                     "to itself")
                clean[tgt][src] = val
        self.coefficients = MappingProxyType({k: MappingProxyType(v) for k, v in clean.items()})
        self.axes = tuple(clean)

    def __repr__(self):
        return f"AxisCoupling(coefficients={self.to_dict()['coefficients']!r})"

    def to_dict(self):
        return {"name": self.name, "coefficients": {t: dict(r) for t, r in self.coefficients.items()}}

    def check_axes(self, axes):
        if len(axes) < self.min_axes:
            raise ValueError(f"effects.{self.name}: needs at least {self.min_axes} axes, there are {len(axes)}")
        for target, row in self.coefficients.items():  # named by the key the user wrote
            if target not in axes:
                raise ValueError(f"effects.axis_coupling.coefficients.{target}: {target!r} is not one of the axes "
                                 f"{list(axes)}")
            for src in row:
                if src not in axes:
                    raise ValueError(f"effects.axis_coupling.coefficients.{target}.{src}: {src!r} is not one of the "
                                     f"axes {list(axes)}")

    @classmethod
    def fit_space(cls, axis, axes):
        return [Param(f"c_{src}", f"coupling of {src}'s deflection into {axis}", -cls.LIMIT, cls.LIMIT, 1e-2)
                for src in axes if src != axis]

    @classmethod
    def build(cls, axis, axes, values):
        return cls(coefficients={axis: {k[2:]: v for k, v in values.items()}})

    def values(self, axis):
        return {f"c_{src}": c for src, c in self.coefficients.get(axis, {}).items()}

    def coupling(self, axis):
        return dict(self.coefficients.get(axis, {}))


class BlockMode(Effect):
    name = "block_mode"
    stage = "block"
    summary = "structural mode of the block/mount between table and gyros (second-order resonance)"
    PARAMS = (Param("frequency_hz", "mode frequency (Hz)", 1.0, 20000.0, 100.0),
              Param("zeta", "mode damping ratio", 1e-4, 1.0, 0.05),
              Param("gain", "participation of the gyros' block in the mode", -2.0, 2.0, 0.3))
    needs_motion = True
    #: Largest damping ratio at which a second-order mode has a resonant peak: ``|H(j w)|`` of
    #: ``w_n^2 / (s^2 + 2 zeta w_n s + w_n^2)`` peaks, at ``w_n sqrt(1 - 2 zeta^2)``, only for
    #: ``zeta < 1/sqrt(2)`` (Ogata, "Modern Control Engineering", 5th ed., sec. 8-2, the resonant peak).
    ZETA_RESONANT_MAX = 1.0 / math.sqrt(2.0)

    @classmethod
    def unresolved(cls, axis, values):
        """A mode fitted at a damping ratio of at least 1/sqrt(2) has no resonance: its three parameters
        only reshape the table motion smoothly (a phase lead far above the table lines)."""
        zeta = values.get("zeta")
        if zeta is not None and zeta >= cls.ZETA_RESONANT_MAX:
            return (f"the block mode on axis {axis} has damping ratio {zeta:.3g} >= 1/sqrt(2): no resonance, "
                    f"a smooth reshaping of the table motion rather than a mode")
        return None

    def block(self, axis, angle, rate, h):
        if not self.acts_on(axis):
            return angle, rate
        w = 2.0 * math.pi * self.params["frequency_hz"]
        z = self.params["zeta"]
        g = self.params["gain"]
        # augmented state (u, u', f and its three derivatives): exact for a cubic forcing over the step
        m = np.zeros((6, 6))
        m[0, 1] = 1.0
        m[1, 0] = -w * w
        m[1, 1] = -2.0 * z * w
        m[1, 2] = 1.0
        m[2, 3] = m[3, 4] = m[4, 5] = 1.0
        e = linalg.expm(m * h)
        u = np.empty_like(angle)
        du = np.empty_like(angle)
        mode_run(np.ascontiguousarray(angle), np.ascontiguousarray(rate), h, w, z, np.ascontiguousarray(e[:2, :2]),
                 np.ascontiguousarray(e[:2, 2:6]), float(angle[0]), float(rate[0]), u, du)
        return (1.0 - g) * angle + g * u, (1.0 - g) * rate + g * du

    def block_stream(self, axis, angle, rate, h, state):
        """:meth:`block` chunk by chunk.

        ``angle, rate``: the table at the grid points after the chunk's start; ``state`` =
        ``[table angle, table rate, u, u']`` at the chunk's start (at rest: ``[phi0, rate0, phi0, rate0]``,
        the mode's start of :meth:`block`), updated. The exact step of :func:`mode_run` does not depend
        on where the chunks end.
        """
        if not self.acts_on(axis) or angle.shape[0] == 0:
            return angle, rate
        w = 2.0 * math.pi * self.params["frequency_hz"]
        z = self.params["zeta"]
        g = self.params["gain"]
        key = (h,)
        cache = self.__dict__.setdefault("_stream_cache", {})
        if key not in cache:
            m = np.zeros((6, 6))
            m[0, 1] = 1.0
            m[1, 0] = -w * w
            m[1, 1] = -2.0 * z * w
            m[1, 2] = 1.0
            m[2, 3] = m[3, 4] = m[4, 5] = 1.0
            e = linalg.expm(m * h)
            cache[key] = (np.ascontiguousarray(e[:2, :2]), np.ascontiguousarray(e[:2, 2:6]))
        phi_m, gam = cache[key]
        a_ext = np.concatenate(([float(state[0])], angle))
        r_ext = np.concatenate(([float(state[1])], rate))
        u = np.empty_like(a_ext)
        du = np.empty_like(a_ext)
        mode_run(a_ext, r_ext, h, w, z, phi_m, gam, float(state[2]), float(state[3]), u, du)
        state[:] = (a_ext[-1], r_ext[-1], u[-1], du[-1])
        return (1.0 - g) * angle + g * u[1:], (1.0 - g) * rate + g * du[1:]


class ViscousDamping(Effect):
    name = "viscous_damping"
    stage = "suspension"
    summary = "velocity-proportional damping beside the hysteretic loss"
    PARAMS = (Param("zeta", "viscous damping ratio added to the suspension", 0.0, 0.1, 5e-4),)

    def suspension(self, axis, s):
        if not self.acts_on(axis) or self.params["zeta"] == 0.0:
            return s
        return s.replace(zeta=s.zeta + self.params["zeta"])


class ResonanceDrift(Effect):
    name = "resonance_drift"
    stage = "plant"
    summary = "small-amplitude resonance f0 changing linearly over the recording (temperature)"
    PARAMS = (Param("rate_hz_per_s", "df0/dt (Hz/s)", -100.0, 100.0, 0.2),)

    def f0_rate_hz_per_s(self, axis):
        return self.params["rate_hz_per_s"] if self.acts_on(axis) else 0.0


class ReadoutDelay(Effect):
    name = "readout_delay"
    stage = "readout"
    summary = "a delay between the drive and the readout"
    PARAMS = (Param("delay_s", "the readout samples the RLG this late (s)", 0.0, 0.01, 2e-5),)

    def delay_s(self, axis):
        return self.params["delay_s"] if self.acts_on(axis) else 0.0


class ScaleFactor(Effect):
    name = "scale_factor"
    stage = "readout"
    summary = "readout scale-factor error"
    PARAMS = (Param("error", "relative scale error of the readout", -0.5, 0.5, 1e-3),)
    needs_motion = True

    def scale(self, axis):
        return 1.0 + self.params["error"] if self.acts_on(axis) else 1.0


class LockIn(Effect):
    name = "lock_in"
    stage = "sense"
    summary = "backscatter lock-in of the counter-propagating modes (Adler equation)"
    PARAMS = (Param("threshold_rad_s", "lock-in rate Omega_L (rad/s)", 0.0, 1.0, 2e-3),
              Param("phase_rad", "backscatter phase (rad)", -4.0 * math.pi, 4.0 * math.pi, 1.0, default=0.0),
              Param("fringe_rad", "rotation angle per Sagnac fringe (rad)", 1e-7, 1e-3, FRINGE_RAD,
                    default=FRINGE_RAD, fit=False))
    #: Sub-interval control of the lock-in kernel (``_kernels.effects.lock_in_run``): the largest change of the
    #: lock-in error's phase per piece (rad); the integrals are accurate to about ``MAX_DPSI**2 / 4`` per plant step.
    MAX_DPSI = 0.05

    def sense(self, axis, phi, rate, h):
        if not self.acts_on(axis) or self.params["threshold_rad_s"] == 0.0:
            return phi
        e = np.empty_like(phi)
        k = 2.0 * math.pi / self.params["fringe_rad"]
        lock_in_run(np.ascontiguousarray(phi), np.ascontiguousarray(rate), h, self.params["threshold_rad_s"], k,
                    self.params["phase_rad"], self.MAX_DPSI, 0.0, e)
        return phi + e

    def sense_stream(self, axis, phi, rate, h, state):
        """:meth:`sense` chunk by chunk; also the measured angle's rate.

        ``phi, rate``: RLG angle and rate at the grid points after the chunk's start; ``state`` =
        ``[phi, rate, e]`` at the chunk's start (at rest: ``[phi0, rate0, 0]``), updated. Returns
        ``(phi_meas, e, de/dt)`` at those grid points, ``de/dt = -threshold sin(psi)`` (Adler). The
        kernel steps each plant step on its own, so chunking does not change the result.
        """
        if not self.acts_on(axis) or self.params["threshold_rad_s"] == 0.0 or phi.shape[0] == 0:
            z = np.zeros_like(phi)
            return phi, z, z
        p = self.params
        k = 2.0 * math.pi / p["fringe_rad"]
        p_ext = np.concatenate(([float(state[0])], phi))
        r_ext = np.concatenate(([float(state[1])], rate))
        e = np.empty_like(p_ext)
        lock_in_run(p_ext, r_ext, h, p["threshold_rad_s"], k, p["phase_rad"], self.MAX_DPSI, float(state[2]), e)
        state[:] = (p_ext[-1], r_ext[-1], e[-1])
        meas = phi + e[1:]
        de = -p["threshold_rad_s"] * np.sin(k * meas + p["phase_rad"])
        return meas, e[1:], de


class MainsPickup(Effect):
    """Off-catalogue: a sine added to the readout angle (electrical pickup)."""

    name = "mains_pickup"
    stage = "readout"
    summary = "sine added to the readout angle (not in the catalogue)"
    PARAMS = (Param("amplitude_rad", "amplitude (rad)", 0.0, 1e-3, 1e-6),
              Param("frequency_hz", "frequency (Hz)", 0.1, 1e5, 50.0, default=50.0),
              Param("phase_rad", "phase (rad)", -10.0, 10.0, 1.0, default=0.0))

    def additive(self, axis, t):
        if not self.acts_on(axis):
            return None
        p = self.params
        return p["amplitude_rad"] * np.sin(2.0 * math.pi * p["frequency_hz"] * t + p["phase_rad"])


class DriveHarmonic(Effect):
    """Off-catalogue: a quadratic piezo, ``V_eff = V + c2 V^2``."""

    name = "drive_harmonic"
    stage = "voltage"
    summary = "quadratic piezo response (not in the catalogue)"
    PARAMS = (Param("c2_per_v", "quadratic coefficient (1/V)", -10.0, 10.0, 0.05),)

    def voltage(self, axis, volts, h):
        if not self.acts_on(axis):
            return volts
        return volts + self.params["c2_per_v"] * volts * volts


class MountMode(Effect):
    """Off-catalogue: a structural mode of the gyro's mount rung by broadband ambient vibration.

    A lightly damped mode of the mount or of the gyro on its dither spring (a mount mode at 1-2 kHz, a
    rocking mode) driven by broadband vibration turns the ring laser by a narrow-band random angle that
    the readout sees beside the dither: white noise through the resonant band-pass ``2 zeta w s / (s^2 +
    2 zeta w s + w^2)`` (``w = 2 pi frequency_hz``; unit gain at ``w``, 20 dB per decade below and above:
    the mode's peak without a broadband floor of its own, a clean mode), discretised on the plant grid by the bilinear transform prewarped at ``w``
    (Oppenheim & Schafer, "Discrete-Time Signal Processing", 3rd ed., sec. 7.2.2), started ``10 / (zeta
    w)`` before ``t = 0`` so that it is stationary from the start, and scaled to an RMS angle of
    ``rms_rad`` at the ring laser over the record. The same ``seed`` gives the same angle on every axis it
    acts on (one rocking mode seen by several gyros). It acts at the sense stage: the dither plant does
    not feel it.
    """

    name = "mount_mode"
    stage = "sense"
    summary = "structural mode of the mount rung by ambient vibration (not in the catalogue)"
    PARAMS = (Param("frequency_hz", "mode frequency (Hz)", 1.0, 20000.0, 100.0),
              Param("zeta", "mode damping ratio", 1e-3, 0.5, 0.01, default=0.02),
              Param("rms_rad", "RMS angle at the ring laser (rad)", 0.0, 1e-3, 1e-6),
              Param("seed", "seed of the ambient vibration", 0.0, 2.0 ** 31, 1.0, default=0.0))

    def sense(self, axis, phi, rate, h):
        if not self.acts_on(axis) or self.params["rms_rad"] == 0.0:
            return phi
        p = self.params
        w = 2.0 * math.pi * p["frequency_hz"]
        n_pre = int(math.ceil(10.0 / (p["zeta"] * w) / h))
        fs = 1.0 / h
        if not w < math.pi * fs:
            return phi  # above the plant grid's Nyquist frequency: nothing the grid can hold
        # prewarped: the continuous filter at w' = 2 fs tan(w h / 2) maps its resonance onto w
        wp = 2.0 * fs * math.tan(w * h / 2.0)
        b, a = signal.bilinear([2.0 * p["zeta"] * wp, 0.0], [1.0, 2.0 * p["zeta"] * wp, wp * wp], fs=fs)
        e = np.random.default_rng([int(p["seed"]), 11]).standard_normal(n_pre + phi.size)
        u = signal.lfilter(b, a, e)[n_pre:]
        rms = float(np.sqrt(np.mean(u * u)))
        if not rms > 0.0:
            return phi
        return phi + u * (p["rms_rad"] / rms)


class BiasDrift(Effect):
    """Off-catalogue: a slow drift of the readout's bias, a nuisance of every ring-laser gyro.

    The readout angle gains ``integral of bias(t) dt`` with ``bias(t) = bias_rad_s + bias_rate_rad_s2 t +
    walk(t)``, ``walk`` a random walk of the bias (``walk_rad_s_rt_s`` times a Wiener process, seeded; the
    rate random walk of IEEE Std 952-1997, annex C), integrated on the readout's sample times by the
    trapezoidal rule.
    """

    name = "bias_drift"
    stage = "readout"
    summary = "slow drift of the readout bias: a ramp and a random walk (not in the catalogue)"
    PARAMS = (Param("bias_rad_s", "bias at t = 0 (rad/s)", -1e-3, 1e-3, 1e-7),
              Param("bias_rate_rad_s2", "change of the bias (rad/s^2)", -1e-4, 1e-4, 1e-9, default=0.0),
              Param("walk_rad_s_rt_s", "random walk of the bias (rad/s/sqrt(s))", 0.0, 1e-4, 1e-9, default=0.0),
              Param("seed", "seed of the random walk", 0.0, 2.0 ** 31, 1.0, default=0.0))

    def additive(self, axis, t):
        if not self.acts_on(axis):
            return None
        p = self.params
        bias = p["bias_rad_s"] + p["bias_rate_rad_s2"] * t
        if p["walk_rad_s_rt_s"] > 0.0 and t.size > 1:
            dt = np.diff(t)
            steps = np.random.default_rng([int(p["seed"]), 13]).standard_normal(dt.size) * np.sqrt(dt)
            bias = bias + p["walk_rad_s_rt_s"] * np.concatenate(([0.0], np.cumsum(steps)))
        out = np.zeros_like(t)
        if t.size > 1:
            out[1:] = np.cumsum(0.5 * (bias[1:] + bias[:-1]) * np.diff(t))
        return out


#: The catalogue of unmodelled effects the diagnosis knows, by name.
EFFECTS = MappingProxyType({cls.name: cls for cls in (PiezoLag, AxisCoupling, BlockMode, ViscousDamping,
                                                       ResonanceDrift, ReadoutDelay, ScaleFactor, LockIn)})
#: Disturbances outside the catalogue (for the blind evaluation).
DISTURBANCES = MappingProxyType({cls.name: cls for cls in (MainsPickup, DriveHarmonic, MountMode, BiasDrift)})


def effect_names() -> list:
    """Names of the catalogue's effects."""
    return list(EFFECTS)


def make_effect(name: str, **params) -> Effect:
    """Build a catalogue effect (or an off-catalogue disturbance) by name.

    Examples
    --------
    >>> make_effect("piezo_lag", tau_s=1e-4)
    PiezoLag(tau_s=0.0001)
    >>> make_effect("axis_coupling", coefficients={"x": {"y": 0.01}}).coupling("x")
    {'y': 0.01}
    """
    cls = EFFECTS.get(name) or DISTURBANCES.get(name)
    if cls is None:
        raise ValueError(f"effects: name: must be one of {sorted(EFFECTS) + sorted(DISTURBANCES)}, got {name!r}")
    if cls.__init__ is not Effect.__init__:  # an effect with its own parameters (axis_coupling): its signature
        import inspect

        allowed = [n for n, p in inspect.signature(cls.__init__).parameters.items()
                   if n != "self" and p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)]
        for key in params:
            if key not in allowed:
                _unknown_parameter(name, key, allowed)
    return cls(**params)
