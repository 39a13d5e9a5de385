"""Wideband correcting filters beyond eq. 5 (issue 15; derivations in ``docs/wideband-filters.md``).

Eq. 5 inverts the suspension (eq. 2) with two approximations: the second derivative of the RLG
angle is the second difference ``X_n - 2 X_{n-1} + X_{n-2}`` (a ``sinc^2``-shaped error: 0.6 dB
short at 1 kHz, 5.6 dB at 3 kHz on 7.2 kHz samples), and its nonlinear terms read the deflection
of the previous sample (``D = X_{n-1} - Y_{n-1}``). The designs here keep eq. 2 and change those:

``correcting_aligned``
    Eq. 5's second difference (unity DC form), with ``Nonl`` and ``Diss`` solved on the deflection
    of the output's own instant (implicit eq. 2, fixed-point iteration). Delay 1 sample, like eq. 5.
``correcting_wideband``
    The second difference followed by a symmetric FIR equaliser (``scipy.signal.firls``) that makes
    the linear cascade (suspension, filter) flat to 2.6 kHz and rolls the estimate off above 3.2 kHz
    (the band edge bounds the noise gain below eq. 5's); nonlinear terms as ``correcting_aligned``.
    Delay 16 samples (2.2 ms at 7.2 kHz).
``correcting_lownoise``
    The same structure flat to 1.5 kHz with the band edge at 2.2 kHz: about a quarter of eq. 5's
    quantisation noise. Delay 20 samples (2.8 ms).

All three are plug-ins (:mod:`sins_sim.filters.registry`); band edges scale with the filter rate
(the numbers above are at 7.2 kHz). Every design has unit DC gain exactly (the second difference
annihilates constants and ramps) and its notch exactly at the believed omega0 (the scale ``c``).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from sins_sim import _validate as v
from sins_sim._kernels import physics as kphys
from sins_sim._kernels import wideband as kwb
from sins_sim.errors import warn_regime
from sins_sim.filters.correcting import CorrectingFilterDesign

__all__ = ["KINDS", "WidebandDesign", "WidebandFilter", "design_equaliser", "build_aligned", "build_wideband",
           "build_lownoise", "REFERENCE_FS_HZ"]

KINDS = ("aligned", "equalised")
#: Band edges of the shipped designs are given at this filter rate and scale with the actual one.
REFERENCE_FS_HZ = 7200.0
#: Sub-bands per Hz range in the least-squares target (firls takes piecewise-linear targets): the
#: smooth targets are sampled on 60 pass-band and 30 stop-band pieces; the linear interpolation error of
#: theta^2 / (2 (1 - cos theta)) over a 45 Hz piece is below 1e-6, far under any design's ripple.
N_PASS_BANDS, N_STOP_BANDS = 60, 30
#: Samples per internal block of :meth:`WidebandFilter.process` (its work arrays stay in the L2 cache).
BLOCK = 8192
#: Longest equaliser (half length K): 2.8 ms at 7.2 kHz for K = 20; 64 bounds the delay at 9 ms.
K_MAX = 64


def _fp_weight(theta, w):
    """Least-squares weight of the equaliser error in the pass band (docs/wideband-filters.md, eq. W1).

    The end-to-end relative error is ``2 (1 - cos theta) dE / (w^2 - theta^2)`` (to first order); the
    floor ``w^2 / 20`` keeps the notch itself (pinned exactly by the scale ``c``) from dominating the fit
    while weighting its neighbourhood, where an equaliser error is amplified most (with a floor of
    ``w^2 / 4`` the gain on the nonlinear plant erred by 1.18 % at 3.5 % above the 419 Hz resonance; with
    ``w^2 / 20`` the worst point from 80 Hz to 1.5 kHz is 0.98 %, measured by ``sins-sim compare-filters``).
    """
    return (2.0 * (1.0 - math.cos(theta))) ** 2 / max(abs(w * w - theta * theta), 0.05 * w * w) ** 2


@functools.lru_cache(maxsize=64)
def _firls_taps(f0_hz, fs_hz, half_length, pass_hz, stop_hz, stop_weight):
    from scipy import signal

    w = 2.0 * math.pi * f0_hz / fs_hz
    edges, desired, weights = [], [], []
    pb = np.linspace(0.0, pass_hz, N_PASS_BANDS + 1)
    for lo, hi in zip(pb[:-1], pb[1:]):
        for f in (lo, hi):
            th = 2.0 * math.pi * f / fs_hz
            desired.append(1.0 if th == 0.0 else th * th / (2.0 * (1.0 - math.cos(th))))
        edges += [lo, hi]
        weights.append(_fp_weight(math.pi * (lo + hi) / fs_hz, w))
    sb = np.linspace(stop_hz, 0.5 * fs_hz, N_STOP_BANDS + 1)
    for lo, hi in zip(sb[:-1], sb[1:]):
        for f in (lo, hi):
            th = 2.0 * math.pi * f / fs_hz
            desired.append(w * w / (2.0 * (1.0 - math.cos(th))))
        edges += [lo, hi]
        tc = math.pi * (lo + hi) / fs_hz
        weights.append(stop_weight * (2.0 * (1.0 - math.cos(tc))) ** 2 / w ** 4)
    taps = signal.firls(2 * half_length - 1, edges, desired, weight=weights, fs=fs_hz)
    taps = 0.5 * (taps + taps[::-1])  # exactly symmetric (linear phase, delay K)
    taps.setflags(write=False)
    return taps


def design_equaliser(f0_hz: float, fs_hz: float, half_length: int, pass_hz: float, stop_hz: float,
                     stop_weight: float = 1.0) -> np.ndarray:
    """FIR equaliser ``e`` (length ``2 K - 1``) of the second difference, by weighted least squares.

    With ``theta = 2 pi f / fs`` and ``w = omega0 / fs``, the targets (docs/wideband-filters.md, eq. W2) are

    - pass band ``[0, pass_hz]``: ``E(theta) = theta^2 / (2 (1 - cos theta))``, so that
      ``2 (1 - cos theta) E / w^2 = (f / f0)^2``: the linear cascade inverts the suspension exactly;
    - stop band ``[stop_hz, fs/2]``: ``E(theta) = w^2 / (2 (1 - cos theta))``, so that the filter's
      gain ``1 - 2 (1 - cos theta) E / w^2`` is 0: the estimate is band-limited and the noise bounded,

    solved by ``scipy.signal.firls`` on piecewise-linear samples of the targets.

    Examples
    --------
    >>> e = design_equaliser(386.0, 7200.0, 16, 2600.0, 3200.0)
    >>> e.size, bool(np.allclose(e, e[::-1]))
    (31, True)
    """
    half_length = int(half_length)
    if not 2 <= half_length <= K_MAX:
        raise ValueError(f"wideband.half_length: must be in [2, {K_MAX}], got {half_length!r}")
    if not 0.0 < pass_hz < stop_hz < 0.5 * fs_hz:
        raise ValueError(f"wideband.pass_hz, stop_hz: must satisfy 0 < pass_hz < stop_hz < fs/2 = {0.5 * fs_hz:g} Hz, "
                         f"got {pass_hz!r}, {stop_hz!r}")
    if not stop_weight > 0.0:
        raise ValueError(f"wideband.stop_weight: must be > 0, got {stop_weight!r}")
    return _firls_taps(float(f0_hz), float(fs_hz), half_length, float(pass_hz), float(stop_hz), float(stop_weight))


@dataclass(frozen=True)
class WidebandDesign:
    """One wideband correcting filter for one channel (SI units, rad).

    Parameters
    ----------
    f0_hz, k1, k2, k3, k4, k5, fs_hz, hysteresis
        What the filter believes, as for eq. 5 (:class:`~sins_sim.filters.correcting.CorrectingFilterDesign`,
        whose ranges apply).
    kind : {"aligned", "equalised"}
        ``aligned``: eq. 5's second difference (``e = [1]``, ``K = 1``); ``equalised``: the FIR equaliser
        of :func:`design_equaliser`.
    half_length : int
        ``K``: the equaliser has ``2 K - 1`` taps, the output describes ``t_{n-K}`` (delay ``K`` samples).
    pass_hz, stop_hz : float
        Band edges of the equaliser (``equalised`` only).
    stop_weight : float
        Weight of the stop band against the pass band in the least squares.
    n_iter : int
        Fixed-point corrections of the implicit eq. 2 after the predictor (1-8).
    """

    f0_hz: float = 386.0
    k1: float = 1.75e-4
    k2: float = 1.05e-3
    k3: float = 4.4e-3
    k4: float = 250.0
    k5: float = -1.2e-5
    fs_hz: float = 7200.0
    hysteresis: str = "paper"
    kind: str = "equalised"
    half_length: int = 16
    pass_hz: float = 2600.0
    stop_hz: float = 3200.0
    stop_weight: float = 1.0
    n_iter: int = 1

    def __post_init__(self):
        # the ranges of eq. 5's parameters, checked by its design
        CorrectingFilterDesign(f0_hz=self.f0_hz, k1=self.k1, k2=self.k2, k3=self.k3, k4=self.k4, k5=self.k5,
                               fs_hz=self.fs_hz, hysteresis=self.hysteresis)
        v.choice("wideband", "kind", self.kind, KINDS)
        if not isinstance(self.n_iter, (int, np.integer)) or not 1 <= self.n_iter <= 8:
            raise ValueError(f"wideband.n_iter: must be an integer in [1, 8], got {self.n_iter!r}")
        if self.kind == "aligned" and self.half_length != 1:
            raise ValueError(f"wideband.half_length: must be 1 for kind 'aligned', got {self.half_length!r}")
        if self.kind == "equalised":
            design_equaliser(self.f0_hz, self.fs_hz, self.half_length, self.pass_hz, self.stop_hz,
                             self.stop_weight)

    @property
    def w(self) -> float:
        """w = omega0 dT (rad per sample)."""
        return 2.0 * math.pi * self.f0_hz / self.fs_hz

    @property
    def equaliser(self) -> np.ndarray:
        """Taps ``e`` (read-only), ``[1]`` for ``aligned``."""
        if self.kind == "aligned":
            return np.ones(1)
        return design_equaliser(self.f0_hz, self.fs_hz, self.half_length, self.pass_hz, self.stop_hz,
                                self.stop_weight)

    def equaliser_response(self, f_hz) -> np.ndarray:
        """Zero-phase response ``E(theta) = sum_m e_m cos((m - K + 1) theta)`` (real)."""
        e = self.equaliser
        theta = 2.0 * math.pi * np.asarray(f_hz, dtype=np.float64) / self.fs_hz
        m = np.arange(e.size) - (e.size - 1) / 2.0
        return np.cos(np.multiply.outer(theta, m)) @ e

    @property
    def scale(self) -> float:
        """``c = 1 / (2 (1 - cos w) E(w))``: the notch exactly at the believed omega0 (eq. W3)."""
        return 1.0 / (2.0 * (1.0 - math.cos(self.w)) * float(self.equaliser_response(self.f0_hz)))

    @property
    def delay_samples(self) -> float:
        """The output describes the block at ``t_{n-K}``: ``K`` filter samples late at every frequency."""
        return float(self.half_length)

    @property
    def taps(self) -> np.ndarray:
        """The linear part as one FIR on ``X`` (length ``2 K + 1``): ``delta_K + c (1, -2, 1) * e``."""
        g = self.scale * np.convolve([1.0, -2.0, 1.0], self.equaliser)
        g[self.half_length] += 1.0
        return g

    def frequency_response(self, f_hz) -> np.ndarray:
        """Linear part (k1 = k3 = k5 = 0), analytically (eq. W4)::

            H(theta) = exp(-j K theta) (1 - 2 c (1 - cos theta) E(theta))

        For ``aligned`` this is eq. 5's unity-DC response.
        """
        theta = 2.0 * math.pi * np.asarray(f_hz, dtype=np.float64) / self.fs_hz
        zero_phase = 1.0 - 2.0 * self.scale * (1.0 - np.cos(theta)) * self.equaliser_response(f_hz)
        return np.exp(-1j * self.half_length * theta) * zero_phase

    @property
    def noise_gain_white(self) -> float:
        """RMS gain on white input noise: ``||g||_2`` of :attr:`taps` (eq. 5, unity form: 21.0 at 386 Hz)."""
        return float(np.sqrt(np.sum(self.taps ** 2)))

    @classmethod
    def from_context(cls, ctx, **kw) -> "WidebandDesign":
        """A design from a registry :class:`~sins_sim.filters.registry.FilterContext` (what the axis believes)."""
        return cls(f0_hz=ctx.f0_hz, k1=ctx.k1, k2=ctx.k2, k3=ctx.k3, k4=ctx.k4, k5=ctx.k5, fs_hz=ctx.fs_hz,
                   hysteresis=ctx.hysteresis, **kw)


class WidebandFilter:
    """Streaming wideband correcting filter: chunked output equals one call on the whole array, bit for bit.

    The filter rests at its first sample (the history before it is that angle, the drive 0): unlike
    eq. 5's ``x0 = 0`` start, a run that starts at a block angle far from 0 has no start transient.

    Parameters
    ----------
    design : WidebandDesign
    """

    def __init__(self, design: WidebandDesign):
        self.design = design
        self._e = np.ascontiguousarray(design.equaliser, dtype=np.float64)
        self._c = design.scale
        self._k = int(design.half_length)
        self._rule = kphys.RULES[design.hysteresis]
        self._fast_dt = 0.25 / design.f0_hz
        self.state = np.zeros(kwb.STATE_SIZE)
        self.hyst = np.zeros(kphys.HYST_SIZE)
        self.stack = np.zeros(kphys.STACK_SIZE)
        self.reset()

    @property
    def delay_samples(self) -> float:
        return self.design.delay_samples

    def reset(self) -> None:
        """Back to the state before the first chunk."""
        self.state[:] = 0.0
        kphys.hyst_reset(self.hyst, self.stack)
        self._xhist = None
        self._vhist = np.zeros(self._k)
        self._warned = False

    @property
    def fast_half_cycles(self) -> int:
        """Half-cycles of D shorter than a quarter dither period so far (regime counter of eq. 10)."""
        return int(self.hyst[5])

    def process(self, x, volts=None) -> np.ndarray:
        """Filter a chunk of RLG angles ``x`` (rad) with the drive ``volts`` (V) aligned to them.

        Returns the block angle ``K`` samples before each input sample (rad).
        """
        x = v.finite_array("wideband", "x", x)
        if volts is None:
            volts = np.zeros_like(x)
        else:
            volts = v.finite_array("wideband", "volts", volts)
            if volts.shape != x.shape:
                raise ValueError(f"wideband.volts: must match x in shape {x.shape}, got {volts.shape}")
        out = np.empty(x.size)
        # blocks that stay in cache (the result does not depend on the split: streaming is bit-exact)
        for i0 in range(0, x.size, BLOCK):
            i1 = min(i0 + BLOCK, x.size)
            self._block(x[i0:i1], volts[i0:i1], out[i0:i1])
        return out

    def _block(self, x, volts, out) -> None:
        n = x.size
        lh = self._e.size + 1
        if self._xhist is None:
            self._xhist = np.full(lh, x[0])
        xx = np.concatenate((self._xhist, x))
        vv = np.concatenate((self._vhist, volts))
        acc = np.empty(n)
        kwb.equalised_second_difference(xx, self._e, self._c, acc)
        xk = xx[lh - self._k: lh - self._k + n]
        vk = vv[:n]
        d = self.design
        kwb.wideband_run(acc, xk, vk, d.k1, d.k2, d.k3, d.k4, d.k5, 1.0 / d.fs_hz, self._rule, self._fast_dt,
                         int(d.n_iter), self.state, self.hyst, self.stack, out)
        self._xhist = xx[-lh:].copy()
        self._vhist = vv[-self._k:].copy()

    def set_design(self, design: WidebandDesign) -> None:
        """Run on ``design`` from the next sample on (its parameters changed in operation, e.g. by an online
        estimator); the state and the input history stay, so the output stays continuous."""
        if design.kind != self.design.kind or design.half_length != self.design.half_length:
            raise ValueError("wideband.set_design: the kind and half_length cannot change in operation")
        self.design = design
        self._e = np.ascontiguousarray(design.equaliser, dtype=np.float64)
        self._c = design.scale
        self._fast_dt = 0.25 / design.f0_hz

    def check_output(self, x=None, y=None, stacklevel: int = 2) -> None:
        """Warn once per run when eq. 10's turning-point rule leaves its domain on the filter's own D."""
        if self.design.k3 > 0.0 and self._rule == kphys.RULE_PAPER and self.hyst[5] > 0 and not self._warned:
            self._warned = True
            warn_regime(f"wideband correcting filter ({self.design.kind})", int(self.hyst[5]), float(self.hyst[6]),
                        "D", stacklevel=stacklevel)


def _scaled(hz: float, fs_hz: float) -> float:
    return hz * fs_hz / REFERENCE_FS_HZ


def build_aligned(ctx) -> WidebandFilter:
    """``correcting_aligned``: eq. 5 (unity DC) with Nonl and Diss on the current deflection."""
    return WidebandFilter(WidebandDesign.from_context(ctx, kind="aligned", half_length=1))


def build_wideband(ctx) -> WidebandFilter:
    """``correcting_wideband``: equalised second difference, flat to 2.6 kHz, band edge 3.2 kHz (at 7.2 kHz)."""
    return WidebandFilter(WidebandDesign.from_context(ctx, kind="equalised", half_length=16,
                                                      pass_hz=_scaled(2600.0, ctx.fs_hz),
                                                      stop_hz=_scaled(3200.0, ctx.fs_hz), stop_weight=1.0))


def build_lownoise(ctx) -> WidebandFilter:
    """``correcting_lownoise``: equalised second difference, flat to 1.5 kHz, band edge 2.2 kHz (at 7.2 kHz)."""
    return WidebandFilter(WidebandDesign.from_context(ctx, kind="equalised", half_length=20,
                                                      pass_hz=_scaled(1500.0, ctx.fs_hz),
                                                      stop_hz=_scaled(2200.0, ctx.fs_hz), stop_weight=0.1))

