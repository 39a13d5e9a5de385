"""Dither stripping from a pickoff signal, with an adaptive LMS gain: the industry baseline.

The electrodynamic pickoff (``sins_sim.models.pickoff``) measures the RLG's
rate relative to the block. Integrated and scaled it estimates the
deflection ``delta``; subtracting that from the RLG angle leaves the block
angle::

    u_n     = lambda u_{n-1} + h v_n          (integral of the pickoff voltage, V s)
    y_n     = x_n - g_n u_n                   (x: RLG angle, y: SINS angle estimate)

``lambda = exp(-2 pi leak_hz h)`` makes the integrator leak very slowly so
that integrated noise and start-up offsets do not wander (0.1 Hz by default:
a phase lead of ``leak_hz / f`` on the estimate, 2.6e-4 rad at the dither).

The sensitivity of the coil drifts, so the gain ``g`` (rad per V s) is
adapted by a normalised LMS that minimises the dither-frequency content of
the output: with ``BP`` a second-order band-pass (``scipy.signal.iirpeak``)
centred on the dither, ``r = BP(u)``, ``e = BP(x) - g_n r`` (the band-passed
output with the current gain) and ``P`` a running mean of ``r^2``::

    g_{n+1} = g_n + mu e_n r_n / P_n,     mu = 1 / (adapt_time_s * fs)

Band-passing ``x`` and ``u`` separately keeps the band-pass's delay (about
``1 / (pi band_hz)``) out of the adaptation loop; band-passing the output
``y`` instead puts it inside and, with a narrow band, makes ``g`` ring.

so ``g`` approaches the projection of the dither in ``x`` on ``u`` with time
constant ``adapt_time_s``. The band-pass keeps the block motion away from
the adaptation; it has to be narrow (2 Hz by default): block motion that
falls inside it is correlated between ``y`` and ``u`` (the suspension
turns block motion into deflection) and biases ``g``, by about
``|BP(f)|^2 * (motion * deflection it causes) / dither^2``. With a 20 Hz
band a 1 arcmin block sine at 433 Hz biased the gain by 8 %; with 2 Hz the
bias there is below 0.1 %, but motion within a few Hz of the dither still
biases it (no gain-only stripper can tell the two apart). What one gain cannot remove is the part of the dither in
quadrature with ``u`` (the pickoff's phase error): about ``a * 2 pi f lag``.

``g_0 = 1 / scale_v_per_rad_s``, the nominal calibration. The filter runs at
any rate; in the project it runs at the readout's input rate (72 kHz) on
``counts * q`` and the pickoff samples, and its output is decimated with the
readout's anti-alias chain (delay: that of the chain).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import signal

from sins_sim import _validate as v
from sins_sim._kernels.pickoff import G_INDEX as _G
from sins_sim._kernels.pickoff import STATE_SIZE as _STATE
from sins_sim._kernels.pickoff import strip_run

__all__ = ["PickoffStripperDesign", "PickoffStripper", "strip"]




@dataclass(frozen=True)
class PickoffStripperDesign:
    """Settings of the pickoff dither stripper.

    Parameters
    ----------
    fs_hz : float
        Rate of the angle and pickoff samples (Hz), > 0.
    dither_hz : float
        Dither frequency (Hz): centre of the adaptation band-pass, < fs/2.
    scale_v_per_rad_s : float
        Nominal pickoff sensitivity (V per rad/s), != 0; ``g_0`` is its inverse.
    adapt_time_s : float
        Time constant of the LMS gain (s), > 0; ``inf`` freezes the gain at ``g_0``.
    band_hz : float
        Bandwidth of the adaptation band-pass (Hz), > 0.
    power_time_s : float
        Averaging time of the band-passed reference power (s), > 0.
    leak_hz : float
        Corner of the leaky integrator (Hz), >= 0 (0: pure integrator).
    hold_s : float or None
        The gain stays at ``g_0`` for this long after a reset while the
        band-passes fill (s), >= 0; ``None`` = ``3 / (pi band_hz)``, three
        time constants of the band-pass envelope (0.48 s at 2 Hz).
    """

    fs_hz: float = 72000.0
    dither_hz: float = 384.0
    scale_v_per_rad_s: float = 1.0
    adapt_time_s: float = 0.2
    band_hz: float = 2.0
    power_time_s: float = 0.01
    leak_hz: float = 0.1
    hold_s: float | None = None

    def __post_init__(self):
        o = "pickoff_stripper"
        fs = v.positive(o, "fs_hz", self.fs_hz)
        fd = v.positive(o, "dither_hz", self.dither_hz)
        if fd >= fs / 2.0:
            raise ValueError(f"{o}.dither_hz: must be < fs_hz / 2 = {fs / 2.0!r}, got {fd!r}")
        s = v.finite(o, "scale_v_per_rad_s", self.scale_v_per_rad_s)
        if s == 0.0:
            raise ValueError(f"{o}.scale_v_per_rad_s: must be != 0, got 0.0")
        at = self.adapt_time_s
        if isinstance(at, bool) or not isinstance(at, (int, float, np.floating)) or not at > 0.0:
            raise ValueError(f"{o}.adapt_time_s: must be > 0 (inf freezes the gain), got {self.adapt_time_s!r}")
        bw = v.positive(o, "band_hz", self.band_hz)
        if bw >= fd:
            raise ValueError(f"{o}.band_hz: must be < dither_hz = {fd!r}, got {bw!r}")
        v.positive(o, "power_time_s", self.power_time_s)
        lk = v.non_negative(o, "leak_hz", self.leak_hz)
        if lk >= fd:
            raise ValueError(f"{o}.leak_hz: must be < dither_hz = {fd!r}, got {lk!r}")
        if self.hold_s is not None:
            v.non_negative(o, "hold_s", self.hold_s)

    @property
    def gain0(self) -> float:
        """Starting gain ``1 / scale`` (rad per V s)."""
        return 1.0 / self.scale_v_per_rad_s

    @property
    def hold(self) -> float:
        """Hold time before adaptation starts (s)."""
        return 3.0 / (math.pi * self.band_hz) if self.hold_s is None else float(self.hold_s)

    @property
    def adaptive(self) -> bool:
        return math.isfinite(self.adapt_time_s)

    def bandpass(self) -> tuple[np.ndarray, np.ndarray]:
        """``(b, a)`` of the adaptation band-pass (``scipy.signal.iirpeak``, unit peak gain)."""
        return signal.iirpeak(self.dither_hz, self.dither_hz / self.band_hz, fs=self.fs_hz)

    def estimate_response(self, f_hz, gain: float | None = None) -> np.ndarray:
        """Complex response of ``g u`` to a pickoff voltage ``v`` at frequencies ``f_hz``, per V.

        ``g h / (1 - lambda z^-1)`` with ``gain`` (default ``g_0``).
        """
        h = 1.0 / self.fs_hz
        lam = math.exp(-2.0 * math.pi * self.leak_hz * h)
        z1 = np.exp(-2j * math.pi * np.asarray(f_hz, dtype=np.float64) * h)
        g = self.gain0 if gain is None else gain
        return g * h / (1.0 - lam * z1)


class PickoffStripper:
    """Streaming pickoff dither stripper (chunked output equals one call, bit for bit).

    Parameters
    ----------
    design : PickoffStripperDesign
    """

    def __init__(self, design: PickoffStripperDesign):
        if not isinstance(design, PickoffStripperDesign):
            raise ValueError(f"pickoff_stripper.design: must be a PickoffStripperDesign, got {type(design).__name__}")
        self.design = design
        fs = design.fs_hz
        self._h = 1.0 / fs
        self._lam = math.exp(-2.0 * math.pi * design.leak_hz * self._h)
        b, a = design.bandpass()
        self._bp = (float(b[0] / a[0]), float(b[1] / a[0]), float(b[2] / a[0]), float(a[1] / a[0]),
                    float(a[2] / a[0]))
        self._mu = 1.0 / (design.adapt_time_s * fs) if design.adaptive else 0.0
        self._kappa = min(1.0, 1.0 / (design.power_time_s * fs))
        self.state = np.zeros(_STATE)
        self.reset()

    def reset(self) -> None:
        """Integrator at 0, gain back to ``g_0``, band-passes at rest, hold time restarted."""
        self.state[:] = 0.0
        self.state[_G] = self.design.gain0

    @property
    def gain(self) -> float:
        """Current gain ``g`` (rad per V s)."""
        return float(self.state[_G])

    def process(self, x, volts, return_gain: bool = False):
        """Strip the dither from the next chunk.

        Parameters
        ----------
        x : array_like, 1-D
            RLG angle samples (rad) at ``fs_hz``.
        volts : array_like, 1-D
            Pickoff voltage samples (V), aligned with ``x`` (sample n averages ``[t_{n-1}, t_n]``).
        return_gain : bool
            Also return the gain used at each sample.

        Returns
        -------
        y : ndarray
            SINS angle estimate (rad); with ``return_gain``, ``(y, gains)``.
        """
        xa = np.ascontiguousarray(v.finite_array("pickoff_stripper", "x", x))
        va = np.ascontiguousarray(v.finite_array("pickoff_stripper", "volts", volts))
        if xa.shape != va.shape:
            raise ValueError(f"pickoff_stripper.volts: must match x in shape {xa.shape}, got {va.shape}")
        y = np.empty_like(xa)
        gains = np.empty_like(xa)
        b0, b1, b2, a1, a2 = self._bp
        hold = self.design.hold * self.design.fs_hz
        strip_run(xa, va, self._h, self._lam, b0, b1, b2, a1, a2, self._mu, self._kappa, hold,
                   self.design.adaptive, self.state, y, gains)
        return (y, gains) if return_gain else y


def strip(x, volts, design: PickoffStripperDesign) -> np.ndarray:
    """Run a whole record through a fresh stripper (see :class:`PickoffStripper`)."""
    return PickoffStripper(design).process(x, volts)
