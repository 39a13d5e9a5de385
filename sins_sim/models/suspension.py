"""Parameters of one dither suspension and the closed forms derived from them.

Equation numbers refer to the paper; conventions to docs/theory/suspension.md
("Equation of motion (eq. 2)"). Angles in rad, frequencies in Hz.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, replace
from functools import lru_cache

import numpy as np
from scipy import integrate, optimize

from sins_sim import _validate as v
from sins_sim._kernels.physics import dnonl, nonl
from sins_sim.units import ARCMIN

__all__ = ["SuspensionParams", "PAPER_SUSPENSION", "nonl_array", "F0_RANGE_HZ", "F0_TYPICAL_HZ", "K1_MAX",
           "K2_RANGE_RAD", "K3_MAX", "K4_MAX_PER_RAD", "K4_MIN_PER_RAD", "LOSS_AMPLITUDE_RAD", "K5_RANGE_RAD_PER_V",
           "ZETA_MAX", "Q_RANGE", "check_range"]

# --- physical ranges (issue 12, point 4): declared in sins_sim.models.ranges (no heavy import there, so a
# configuration file is checked against them before numba and scipy load) and re-exported here
from sins_sim.models.ranges import (F0_RANGE_HZ, F0_TYPICAL_HZ, K1_MAX, K2_RANGE_RAD, K3_MAX,  # noqa: E402
                                    K4_MAX_PER_RAD, K4_MIN_PER_RAD, K5_RANGE_RAD_PER_V, LOSS_AMPLITUDE_RAD,
                                    Q_RANGE, ZETA_MAX)


def check_range(owner: str, field: str, value: float, lo: float, hi: float, unit: str = "", why: str = "") -> float:
    """``lo <= value <= hi`` or a ValueError naming ``owner.field``, the range and why."""
    if not lo <= value <= hi:
        u = f" {unit}" if unit else ""
        raise ValueError(f"{owner}.{field}: must be in [{lo:g}, {hi:g}]{u}{' (' + why + ')' if why else ''}, "
                         f"got {value!r}")
    return value


def nonl_array(d, k1, k2):
    """Eq. 9 on an array (same cancellation-free form as the kernels)."""
    d = np.asarray(d, dtype=np.float64)
    x = np.abs(d) / k2
    r = 1.0 + np.sqrt(1.0 + x)
    return -np.sign(d) * k1 * x * x / (2.0 * r * r)


@dataclass(frozen=True)
class SuspensionParams:
    """Immutable parameters of one dithered RLG suspension (the paper's equations 2, 9, 10 and 14).

    Parameters
    ----------
    f0_hz : float
        Small-amplitude resonance f0 = omega0 / 2 pi (Hz), > 0.
    k1 : float
        Eq. 9 nonlinearity scale (dimensionless), >= 0 (softening spring).
    k2 : float
        Eq. 9 nonlinearity angle (rad), > 0.
    k3 : float
        Eq. 10 dissipation (dimensionless), >= 0.
    k4 : float
        Eq. 10 amplitude dependence of dissipation (1/rad), with 1 + k4 a > 0.
    k5 : float
        Eq. 14 piezo gain (rad/V), != 0.
    zeta : float
        Optional viscous damping ratio beside the hysteretic one (0 in the
        paper's model), >= 0.

    Examples
    --------
    >>> from sins_sim.units import ARCMIN
    >>> round(PAPER_SUSPENSION.q_factor(3 * ARCMIN), 1)
    186.6
    """

    f0_hz: float = 386.0
    k1: float = 1.75e-4
    k2: float = 1.05e-3
    k3: float = 4.4e-3
    k4: float = 250.0
    k5: float = -1.2e-5
    zeta: float = 0.0

    def __post_init__(self):
        o = "suspension"
        f0 = v.positive(o, "f0_hz", self.f0_hz)
        check_range(o, "f0_hz", f0, *F0_RANGE_HZ, "Hz", "dither suspensions resonate at 100-1500 Hz")
        k1 = v.non_negative(o, "k1", self.k1)
        check_range(o, "k1", k1, 0.0, K1_MAX)
        k2 = v.positive(o, "k2", self.k2)
        check_range(o, "k2", k2, *K2_RANGE_RAD, "rad")
        if not k1 < 2.0 * k2:
            raise ValueError(f"suspension.k1: must be < 2 k2 = {2.0 * k2:g} (eq. 9's slope tends to -k1/(2 k2): "
                             f"the spring would lose its stiffness), got {k1!r}")
        k3 = v.non_negative(o, "k3", self.k3)
        check_range(o, "k3", k3, 0.0, K3_MAX, "", "Q >= 5")
        k4 = v.finite(o, "k4", self.k4)
        check_range(o, "k4", k4, K4_MIN_PER_RAD, K4_MAX_PER_RAD, "1/rad")
        k5 = v.finite(o, "k5", self.k5)
        if k5 == 0.0:
            raise ValueError("suspension.k5: must be != 0 (eq. 14: no drive otherwise), got 0.0")
        if not K5_RANGE_RAD_PER_V[0] <= abs(k5) <= K5_RANGE_RAD_PER_V[1]:
            raise ValueError(f"suspension.k5: |k5| must be in [{K5_RANGE_RAD_PER_V[0]:g}, {K5_RANGE_RAD_PER_V[1]:g}] "
                             f"rad/V (a piezo stack's gain; the paper: 1.2e-5), got {k5!r}")
        zeta = v.non_negative(o, "zeta", self.zeta)
        check_range(o, "zeta", zeta, 0.0, ZETA_MAX, "", "Q >= 5")
        if self.k3 == 0.0 and self.zeta == 0.0:
            raise ValueError("suspension.k3: k3 and zeta are both 0: Q would be infinite (Q <= 0 or inf is unphysical)")
        a = LOSS_AMPLITUDE_RAD
        worst = k3 * (1.0 + k4 * a) + 2.0 * zeta  # the loss is linear in a: its extremes are at 0 and at a
        if not worst < 1.0:
            raise ValueError(f"suspension.k3: the loss 1/Q = k3 (1 + k4 a) + 2 zeta must stay < 1 for every deflection "
                             f"up to {a:g} rad (a resonance), got {worst:.4g} at {a:g} rad (k3 = {k3!r}, k4 = {k4!r}, "
                             f"zeta = {zeta!r})")
        if not F0_TYPICAL_HZ[0] <= f0 <= F0_TYPICAL_HZ[1]:
            warnings.warn(f"suspension.f0_hz: {f0:g} Hz is outside the usual band of RLG dither suspensions "
                          f"({F0_TYPICAL_HZ[0]:g}-{F0_TYPICAL_HZ[1]:g} Hz)", UserWarning, stacklevel=3)

    # --- alternative constructors -------------------------------------------------
    @classmethod
    def from_q(cls, q: float, amplitude_rad: float, v_m: float, **kwargs) -> "SuspensionParams":
        """Parameters whose k3 and k5 give quality ``q`` at ``amplitude_rad`` driven by ``v_m``.

        Eq. 16: ``k3 = 1 / (Q (1 + k4 a_m))``; eq. 17: ``k5 = -a_m / (Q V_m)``.
        """
        q = v.positive("suspension", "Q", q)
        a = v.positive("drive", "amplitude_rad", amplitude_rad)
        v_m = v.positive("drive", "v_m", v_m)
        k4 = kwargs.get("k4", cls.k4)
        if 1.0 + k4 * a <= 0.0:
            raise ValueError(f"suspension.k4: 1 + k4 * a_m must be > 0, got {1.0 + k4 * a!r}")
        kwargs["k3"] = 1.0 / (q * (1.0 + k4 * a))
        kwargs["k5"] = -a / (q * v_m)
        return cls(**kwargs)

    def replace(self, **changes) -> "SuspensionParams":
        """A copy with some fields changed (validated again)."""
        return replace(self, **changes)

    # --- derived quantities ------------------------------------------------------
    @property
    def omega0(self) -> float:
        """Small-amplitude circular resonance omega0 = 2 pi f0 (rad/s)."""
        return 2.0 * math.pi * self.f0_hz

    def nonl(self, d):
        """Eq. 9 Nonl(delta) (works on arrays)."""
        return nonl_array(d, self.k1, self.k2)

    def inverse_q(self, amplitude_rad: float) -> float:
        """1/Q at amplitude a: eq. 16 ``k3 (1 + k4 a)`` plus the viscous ``2 zeta``."""
        return self.k3 * (1.0 + self.k4 * amplitude_rad) + 2.0 * self.zeta

    def q_factor(self, amplitude_rad: float) -> float:
        """Mechanical quality factor at amplitude a (eq. 16); error if not > 0."""
        a = v.positive("drive", "amplitude_rad", amplitude_rad)
        inv = self.inverse_q(a)
        if not inv > 0.0:
            raise ValueError(
                f"suspension.k4: Q = 1/(k3 (1 + k4 a) + 2 zeta) must be > 0 at a = {a!r} rad, got 1/Q = {inv!r}"
            )
        return 1.0 / inv

    def drive_voltage(self, amplitude_rad: float) -> float:
        """Drive amplitude V_m that holds dither amplitude a at resonance (eq. 17 solved for V_m)."""
        return -amplitude_rad / (self.q_factor(amplitude_rad) * self.k5)

    def k5_for(self, amplitude_rad: float, v_m: float) -> float:
        """Eq. 17: ``k5 = -a_m / (Q V_m)``."""
        return -amplitude_rad / (self.q_factor(amplitude_rad) * v.positive("drive", "v_m", v_m))

    def stiffness_ratio_hb(self, amplitude_rad: float) -> float:
        """(omega(a)/omega0)^2 by first-harmonic balance of eq. 9.

        For ``delta = a cos(theta)`` the restoring term ``delta + Nonl(delta)``
        has first harmonic ``(1 + N1(a)/a) a cos(theta)`` with
        ``N1(a) = (2/pi) int_0^pi Nonl(a cos theta) cos theta dtheta``.
        """
        return _stiffness_ratio_hb(float(amplitude_rad), self.k1, self.k2)

    def resonance_hz(self, amplitude_rad: float) -> float:
        """Amplitude-dependent resonance F(a) by harmonic balance (the drive's operating point)."""
        return self.f0_hz * math.sqrt(self.stiffness_ratio_hb(amplitude_rad))

    def resonance_hz_exact(self, amplitude_rad: float) -> float:
        """F(a) = 1/T(a) of the conservative oscillator ``d'' = -omega0^2 (d + Nonl(d))``.

        Exact period from energy conservation (the relation eq. 6-7 invert):
        ``T = 4 int_0^a dd / sqrt(2 (U(a) - U(d)))`` with
        ``U(d) = omega0^2 int_0^d (x + Nonl(x)) dx``; the substitution
        ``d = a sin(u)`` removes the end-point singularity.
        """
        return _resonance_exact(float(amplitude_rad), self.f0_hz, self.k1, self.k2)

    def line_resonance_hz(self, amplitude_rad: float) -> float:
        """The resonance a small line superposed on a dither of amplitude ``a`` meets (Hz).

        A small deflection ``e`` at a frequency unrelated to the dither's sees the spring's slope along the
        dither, ``1 + Nonl'(a cos theta)``, and its first harmonic keeps that slope's mean over the cycle: the
        two-sinusoid describing function in the limit of a small second input (Gelb and Vander Velde,
        *Multiple-Input Describing Functions and Nonlinear System Design*, 1968, ch. 5), so
        ``(omega_l / omega0)^2 = 1 + (1/pi) int_0^pi Nonl'(a cos theta) dtheta``. The softening spring (eq. 9,
        ``Nonl ~ -k1 d |d| / (8 k2^2)``) softens for the line 3/2 times as much as for the dither itself
        (:meth:`resonance_hz`): 416.3 Hz against 417.9 Hz for a 421 Hz suspension at 3 arcmin.
        """
        return self.f0_hz * math.sqrt(_line_stiffness_ratio(float(amplitude_rad), self.k1, self.k2))

    def relative_mismatch(self, amplitude_rad: float) -> float:
        """f0 / F(a) - 1: how far above the operating frequency omega0 sits (paper, Fig. 6)."""
        return self.f0_hz / self.resonance_hz(amplitude_rad) - 1.0


@lru_cache(maxsize=256)
def _stiffness_ratio_hb(a: float, k1: float, k2: float) -> float:
    if a <= 0.0:
        return 1.0 + dnonl(0.0, k1, k2)
    val, _ = integrate.quad(lambda th: nonl(a * math.cos(th), k1, k2) * math.cos(th), 0.0, math.pi,
                            epsabs=1e-16, epsrel=1e-12, limit=200)
    return 1.0 + (2.0 / math.pi) * val / a


@lru_cache(maxsize=256)
def _line_stiffness_ratio(a: float, k1: float, k2: float) -> float:
    if a <= 0.0:
        return 1.0 + dnonl(0.0, k1, k2)
    val, _ = integrate.quad(lambda th: dnonl(a * math.cos(th), k1, k2), 0.0, math.pi, points=(math.pi / 2,),
                            epsabs=1e-16, epsrel=1e-12, limit=200)
    return 1.0 + val / math.pi


#: Taylor coefficients of G(y) = (2/3)((1+y)^{3/2} - 1) - y - y^2/4 from y^3 on (binomial series).
_G_SERIES = (-1.0 / 24.0, 1.0 / 64.0, -1.0 / 128.0, 7.0 / 1536.0, -3.0 / 1024.0, 33.0 / 16384.0)


def _g(y: float) -> float:
    """G(y) = (2/3)((1+y)^{3/2} - 1) - y - y^2/4 without cancellation (series below y = 0.05)."""
    if y < 0.05:
        acc = 0.0
        for c in reversed(_G_SERIES):
            acc = acc * y + c
        return acc * y * y * y
    return (2.0 / 3.0) * ((1.0 + y) ** 1.5 - 1.0) - y - 0.25 * y * y


def _potential(d: float, k1: float, k2: float) -> float:
    """int_0^d (x + Nonl(x)) dx for eq. 9, in closed form (d >= 0).

    ``d^2/2 + k1 k2 G(d/k2)``: the eq. 9 part integrates to ``k1 k2 G``, which is
    evaluated by its series at small ``d`` where the closed form cancels.
    """
    return 0.5 * d * d + k1 * k2 * _g(d / k2)


@lru_cache(maxsize=256)
def _resonance_exact(a: float, f0: float, k1: float, k2: float) -> float:
    if a <= 0.0:
        return f0
    w0 = 2.0 * math.pi * f0
    ua = _potential(a, k1, k2)

    def integrand(u):
        d = a * math.sin(u)
        du = ua - _potential(d, k1, k2)
        return a * math.cos(u) / math.sqrt(2.0 * w0 * w0 * du) if du > 0 else 0.0

    # near u = pi/2 the ratio tends to a finite limit; quad copes
    quarter, _ = integrate.quad(integrand, 0.0, math.pi / 2, epsabs=0.0, epsrel=1e-12, limit=200)
    return 1.0 / (4.0 * quarter)


#: The paper's 28 cm RLG (docs/user-guide/paper.md).
PAPER_SUSPENSION = SuspensionParams()
PAPER_DITHER_AMPLITUDE_RAD = 3.0 * ARCMIN
