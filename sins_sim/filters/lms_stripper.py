"""The production dither stripper: three pickoffs, two 3x3 gain matrices adapted by NLMS (after US 7,440,109).

A production unit strips the dither by subtracting from each gyro's counts an estimate of its dither angle built
from the dither pickoffs of all three axes (US 7,440,109, Honeywell, 2008). With ``x_n`` the three gyros' counts as
angle (rad) and ``alpha_n`` the three pickoff signals, the estimate and the stripped output are::

    d_n = E alpha_n + F alpha_{n-1}        y_n = x_n - d_n

``E`` and ``F`` are 3x3 matrices (rad per V s): the off-diagonal terms absorb the coupling between the axes (a
coil that also sees the other axes' motion), and ``F`` next to ``E`` lets each entry fit a gain *and* a phase (a
lagging coil, a fraction of a sample between counts and pickoff). Our pickoffs are electrodynamic (they read the
deflection rate, :mod:`sins_sim.models.pickoff`), so ``alpha`` is the leaky integral of the voltage,
``alpha_n = u_n = lambda u_{n-1} + h v_n`` (V s), as in the single-axis baseline :mod:`sins_sim.filters.pickoff`;
a piezo pickoff, as in the patent, would give the deflection directly.

Adaptation. The gains are adapted on filtered signals, ``HP``: by default (``adapt_band="highpass"``, the patent's
high-pass-filtered counts) a second-order Butterworth high-pass with corner ``highpass_hz`` below the dither band,
so that vehicle motion and the integrators' slow wander do not reach them; or (``adapt_band="dither"``) the sum of
three second-order band-passes (``scipy.signal.iirpeak``, width ``band_hz``) centred on the three dither frequencies,
which also keeps block vibration above the high-pass corner out of the gains (see below):
with ``r_n = [HP(u)_n; HP(u)_{n-1}]`` (the regressor, 6 values) and the a priori error
``e_n = HP(x)_n - E HP(u)_n - F HP(u)_{n-1}`` (3 values), the normalised LMS update is::

    E += mu e_n HP(u)_n^T / (|r_n|^2 + reg P_n)      F += mu e_n HP(u)_{n-1}^T / (|r_n|^2 + reg P_n)

with ``P_n`` a running mean of ``|r_n|^2`` (over ``power_time_s``) and ``reg`` a small regularisation (1e-3)
that keeps the step finite when the three dithers pass zero together. The patent's plain LMS update is
``E += 2 mu' e alpha^T``; the normalised form is that update with ``2 mu' = mu / |r|^2``.

Why normalised LMS. Plain LMS is stable in the mean square for ``0 < mu' < 2 / tr R`` (Widrow and Stearns,
*Adaptive Signal Processing*, 1985, ch. 6; Haykin, *Adaptive Filter Theory*, 4th ed., 2002, ch. 5), ``R`` the
regressor's correlation matrix, whose trace is the pickoff signal power: the bound moves with the pickoff scale, the
dither amplitudes and the high-pass, none of which a configuration file can check at load. Normalising by the
instantaneous power ``|r_n|^2`` (an estimate of ``tr R``) gives the bound in a number that a file can check:

**Stability bound** ``0 < mu < 2``. Derivation (Haykin 2002, ch. 6, normalised LMS): with ``reg = 0`` the
a posteriori error after an update is ``e_n^+ = HP(x)_n - E^+ HP(u)_n - F^+ HP(u)_{n-1}
= (1 - mu) e_n`` (substitute the update: ``r^T r / |r|^2 = 1``); the error contracts at every step iff
``|1 - mu| < 1``, i.e. ``0 < mu < 2``, and for ``mu > 2`` it grows by ``|1 - mu| > 1`` in the direction of each
regressor, so the gains diverge. With ``reg > 0`` the factor is ``1 - mu |r|^2 / (|r|^2 + reg P)``, inside
``(-1, 1)`` for the same ``mu``: the bound is unchanged. ``mu = 1`` removes the whole a priori error each sample
(fastest, noisiest); the misadjustment grows as ``mu / (2 - mu)`` (Haykin ch. 6), so small steps trade speed for
steadier gains. The loader refuses ``mu`` outside ``(0, 2)``; the Python API builds it with
``allow_unstable=True`` to show the divergence.

Convergence time. The regressor of the three dithers has three pairs of eigen-directions: ``u_n + u_{n-1}``
(eigenvalue ``~ 1 + cos(w h)`` of the pair) and ``u_n - u_{n-1}`` (``~ 1 - cos(w h)``, 0.056 at 386 Hz and 7.2 kHz):
the phase (``E - F``) converges ``(1 + cos wh) / (1 - cos wh)`` (35) times slower than the gain (``E + F``), with
time constant about ``1 / (mu (1 - cos w h) / (2 * 3))`` samples for three dithers of equal amplitude. The
reported convergence time is measured: the last time the gain matrices were farther than 1 % (Frobenius) from their
final values (:meth:`LmsStripper.report`).

What it measures: the part of the counts that is a linear, two-tap function of the three pickoffs at the three
dither frequencies. It does not remove what the pickoffs do not see (their noise, their nonlinearity's harmonics),
and it injects the pickoff noise, integrated, into the output. Block motion inside the adaptation band biases the
gains, as in the single-axis baseline: the suspension turns block motion into deflection, which the pickoffs see and
which is correlated with the block motion in the counts, so the least-squares gains also cancel part of the block
motion. With the high-pass that band is everything above ``highpass_hz`` (vibration, coning); with
``adapt_band="dither"`` it is ``band_hz`` around each dither.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import signal

from sins_sim import _validate as v
from sins_sim._kernels import lms_stripper as _k
from sins_sim.filters.registry import ThreeAxisContext

__all__ = ["MU_MAX", "LmsStripperDesign", "LmsStripper", "build_lms_stripper"]

#: Upper stability bound of the normalised LMS step (module docstring).
MU_MAX = 2.0
#: The gains are "converged" once they stay within this fraction (Frobenius) of their final values.
CONVERGED_FRACTION = 0.01


@dataclass(frozen=True)
class LmsStripperDesign:
    """Settings of the three-axis LMS stripper.

    Parameters
    ----------
    fs_hz : float
        Rate of the counts and pickoff samples (Hz), > 0.
    scale_v_per_rad_s : tuple of three float
        Nominal pickoff sensitivities (V per rad/s), != 0: ``E_0 = diag(1 / scale)``, ``F_0 = 0``.
    mu : float
        NLMS step; stable for ``0 < mu < 2`` (:data:`MU_MAX`, module docstring).
    highpass_hz : float
        Corner of the second-order Butterworth high-pass of the adaptation (Hz), in (0, fs/2); below the dither band.
    adapt_band : {"highpass", "dither"}
        The adaptation filter: the high-pass, or band-passes around ``dither_hz``.
    band_hz : float
        Width of each dither band-pass (Hz), > 0 (``adapt_band="dither"``).
    dither_hz : tuple of float
        The three dither frequencies (Hz), in (band_hz, fs/2); required for ``adapt_band="dither"``.
    leak_hz : float
        Corner of the leaky integrators of the pickoff voltages (Hz), >= 0.
    power_time_s : float
        Averaging time of the regressor power (s), > 0.
    regularisation : float
        Fraction of the mean regressor power added to the NLMS normaliser, >= 0.
    hold_s : float
        Adaptation starts this long after a reset (s), >= 0: the high-passes settle first.
    gain_limit : float
        The stripper has diverged once a gain exceeds ``gain_limit`` times the largest starting gain, > 1.
    history_hz : float
        Rate of the stored gain snapshots (Hz), > 0 (the convergence time is read from them).
    allow_unstable : bool
        Accept ``mu >= 2`` (to demonstrate the bound); the loader never sets it.
    """

    fs_hz: float = 7200.0
    scale_v_per_rad_s: tuple = (1.0, 1.0, 1.0)
    mu: float = 0.05
    highpass_hz: float = 50.0
    adapt_band: str = "highpass"
    band_hz: float = 2.0
    dither_hz: tuple = ()
    leak_hz: float = 0.1
    power_time_s: float = 0.01
    regularisation: float = 1e-3
    hold_s: float = 0.1
    gain_limit: float = 1e3
    history_hz: float = 20.0
    allow_unstable: bool = False

    def __post_init__(self):
        o = "lms_stripper"
        fs = v.positive(o, "fs_hz", self.fs_hz)
        if len(self.scale_v_per_rad_s) != 3:
            raise ValueError(f"{o}.scale_v_per_rad_s: must be three numbers, got {self.scale_v_per_rad_s!r}")
        for s in self.scale_v_per_rad_s:
            if v.finite(o, "scale_v_per_rad_s", s) == 0.0:
                raise ValueError(f"{o}.scale_v_per_rad_s: must be != 0, got 0.0")
        mu = v.positive(o, "mu", self.mu)
        if mu >= MU_MAX and not self.allow_unstable:
            raise ValueError(f"{o}.mu: must be in (0, {MU_MAX:g}) (normalised LMS stability bound: the a posteriori "
                             f"error is (1 - mu) times the a priori one), got {mu!r}")
        hp = v.positive(o, "highpass_hz", self.highpass_hz)
        if hp >= fs / 2.0:
            raise ValueError(f"{o}.highpass_hz: must be < fs_hz / 2 = {fs / 2.0!r}, got {hp!r}")
        v.choice(o, "adapt_band", self.adapt_band, ("highpass", "dither"))
        bw = v.positive(o, "band_hz", self.band_hz)
        if self.adapt_band == "dither":
            if len(self.dither_hz) != 3:
                raise ValueError(f"{o}.dither_hz: adapt_band 'dither' needs the three dither frequencies, got "
                                 f"{self.dither_hz!r}")
            for f in self.dither_hz:
                if not bw < v.positive(o, "dither_hz", f) < fs / 2.0:
                    raise ValueError(f"{o}.dither_hz: must lie in (band_hz, fs_hz / 2) = ({bw!r}, {fs / 2.0!r}), "
                                     f"got {f!r}")
        lk = v.non_negative(o, "leak_hz", self.leak_hz)
        if lk >= hp:
            raise ValueError(f"{o}.leak_hz: must be < highpass_hz = {hp!r}, got {lk!r}")
        v.positive(o, "power_time_s", self.power_time_s)
        v.non_negative(o, "regularisation", self.regularisation)
        v.non_negative(o, "hold_s", self.hold_s)
        if not v.finite(o, "gain_limit", self.gain_limit) > 1.0:
            raise ValueError(f"{o}.gain_limit: must be > 1, got {self.gain_limit!r}")
        v.positive(o, "history_hz", self.history_hz)

    @property
    def gains0(self) -> np.ndarray:
        """Starting ``E`` and ``F``, shape (2, 3, 3): the nominal calibration ``diag(1 / scale)`` and 0."""
        g = np.zeros((2, 3, 3))
        g[0] = np.diag([1.0 / s for s in self.scale_v_per_rad_s])
        return g

    def bank(self) -> np.ndarray:
        """Rows ``[b0, b1, b2, a1, a2]`` of the adaptation filter, summed in parallel: the high-pass
        (``scipy.signal.butter``, order 2) or one band-pass per dither (``scipy.signal.iirpeak``, unit peak gain)."""
        if self.adapt_band == "highpass":
            ba = [signal.butter(2, self.highpass_hz, btype="highpass", fs=self.fs_hz)]
        else:
            ba = [signal.iirpeak(f, f / self.band_hz, fs=self.fs_hz) for f in self.dither_hz]
        return np.array([[b[0], b[1], b[2], a[1], a[2]] / a[0] for b, a in ba])

    def integrator_response(self, f_hz) -> np.ndarray:
        """Complex response of the leaky integrator ``h / (1 - lambda z^-1)`` (s) at ``f_hz``."""
        h = 1.0 / self.fs_hz
        lam = math.exp(-2.0 * math.pi * self.leak_hz * h)
        return h / (1.0 - lam * np.exp(-2j * math.pi * np.asarray(f_hz, dtype=np.float64) * h))


class LmsStripper:
    """Streaming three-axis stripper: chunked output equals one call, bit for bit.

    The plug-in protocol of a three-axis filter (:mod:`sins_sim.filters.registry`): ``process(x, volts)`` with
    ``x`` the counts (rad) and ``volts`` the pickoff voltages (V), both (3, m); ``delay_samples`` (0: the
    output describes the counts' own instant); ``reset()``; and ``failure`` (None, or why the output stopped being
    finite) and ``report()`` for ``metrics.json``.

    Parameters
    ----------
    design : LmsStripperDesign
    """

    delay_samples = 0.0

    def __init__(self, design: LmsStripperDesign):
        if not isinstance(design, LmsStripperDesign):
            raise ValueError(f"lms_stripper.design: must be an LmsStripperDesign, got {type(design).__name__}")
        self.design = design
        fs = design.fs_hz
        self._h = 1.0 / fs
        self._lam = math.exp(-2.0 * math.pi * design.leak_hz * self._h)
        self._bank = design.bank()
        self._zx = np.zeros((3, self._bank.shape[0], 2))
        self._zu = np.zeros((3, self._bank.shape[0], 2))
        self._kappa = min(1.0, 1.0 / (design.power_time_s * fs))
        self._limit = design.gain_limit * float(np.max(np.abs(design.gains0)))
        self._stride = max(1, int(round(fs / design.history_hz)))
        self.state = np.zeros(_k.STATE_SIZE)
        self.gains = np.zeros((2, 3, 3))
        self.reset()

    def reset(self) -> None:
        """Integrators and high-passes at rest, gains back to the nominal calibration, history cleared."""
        self.state[:] = 0.0
        self._zx[:] = 0.0
        self._zu[:] = 0.0
        self.gains[:] = self.design.gains0
        self._hist = []

    @property
    def E(self) -> np.ndarray:
        """Current ``E`` (rad per V s), a copy."""
        return self.gains[0].copy()

    @property
    def F(self) -> np.ndarray:
        """Current ``F`` (rad per V s), a copy."""
        return self.gains[1].copy()

    @property
    def failure(self) -> str | None:
        """Why the output stopped being finite, or None."""
        k = self.state[_k.DIV]
        if k <= 0.0:
            return None
        return (f"LMS gains beyond {self.design.gain_limit:g} x the nominal calibration at "
                f"{(k - 1.0) / self.design.fs_hz:.4g} s (mu = {self.design.mu:g}; stable for 0 < mu < {MU_MAX:g})")

    def process(self, x, volts) -> np.ndarray:
        """Strip the next chunk: counts ``x`` (rad) and pickoff voltages ``volts`` (V), both (3, m)."""
        xa = np.ascontiguousarray(v.finite_array("lms_stripper", "x", x, ndim=2))
        va = np.ascontiguousarray(v.finite_array("lms_stripper", "volts", volts, ndim=2))
        if xa.shape[0] != 3 or xa.shape != va.shape:
            raise ValueError(f"lms_stripper.volts: x and volts must both have shape (3, m), got {xa.shape} and "
                             f"{va.shape}")
        out = np.empty_like(xa)
        hist = np.empty((xa.shape[1] // self._stride + 1, 18))
        d = self.design
        n = _k.lms3_run(xa, va, self._h, self._lam, self._bank, float(d.mu), self._kappa, float(d.regularisation),
                        d.hold_s * d.fs_hz, self._limit, self._stride, self.state, self._zx, self._zu, self.gains,
                        out, hist)
        if n:
            self._hist.append(hist[:n].copy())
        return out

    def history(self) -> tuple[np.ndarray, np.ndarray]:
        """``(t_s, gains)``: the gain snapshots (``gains``: (k, 2, 3, 3)) and their times from the reset (s)."""
        g = np.concatenate(self._hist) if self._hist else np.zeros((0, 18))
        t = (np.arange(1, g.shape[0] + 1) * self._stride) / self.design.fs_hz
        return t, g.reshape(-1, 2, 3, 3)

    def convergence_time_s(self, fraction: float = CONVERGED_FRACTION) -> float | None:
        """Last time the gains were farther than ``fraction`` (Frobenius) from their final values (s).

        None when diverged or before any snapshot; 0 when they never left that neighbourhood.
        """
        t, g = self.history()
        if self.failure is not None or g.shape[0] == 0:
            return None
        final = g[-1]
        err = np.sqrt(np.sum((g - final) ** 2, axis=(1, 2, 3)))
        away = np.nonzero(err > fraction * np.sqrt(np.sum(final ** 2)))[0]
        return float(t[away[-1]]) if away.size else 0.0

    def report(self) -> dict:
        """The adaptation for ``metrics.json``: final gains, convergence time, divergence."""
        return {"algorithm": "normalised LMS (US 7,440,109 estimate E alpha_n + F alpha_{n-1})",
                "mu": float(self.design.mu), "mu_bound": f"0 < mu < {MU_MAX:g}",
                "E_rad_per_v_s": self.gains[0].tolist(), "F_rad_per_v_s": self.gains[1].tolist(),
                "convergence_time_s": self.convergence_time_s(),
                "converged_definition": f"last time the gains were farther than {CONVERGED_FRACTION:g} (Frobenius, "
                                        "relative) from their final values",
                "failure": self.failure}


#: Settings a context may carry (the IMU file's ``lms_stripper`` section gives all but ``allow_unstable``, which
#: only the Python API sets, to show the divergence beyond the bound).
SETTINGS_KEYS = ("mu", "highpass_hz", "adapt_band", "band_hz", "leak_hz", "power_time_s", "regularisation", "hold_s",
                 "allow_unstable")


def build_lms_stripper(ctx: ThreeAxisContext) -> LmsStripper:
    """The registry's builder: a stripper at the filter rate with the pickoffs' nominal scales and the settings."""
    settings = dict(ctx.settings or {})
    unknown = sorted(set(settings) - set(SETTINGS_KEYS))
    if unknown:
        raise ValueError(f"lms_stripper.{unknown[0]}: unknown setting; known: {', '.join(SETTINGS_KEYS)}")
    return LmsStripper(LmsStripperDesign(fs_hz=ctx.fs_hz, scale_v_per_rad_s=tuple(ctx.pickoff_scale_v_per_rad_s),
                                         dither_hz=tuple(float(a.dither_hz) for a in ctx.axes), **settings))
