"""The electrodynamic dither pickoff: the industry's sensor for dither stripping.

The paper's introduction: a permanent magnet on the RLG body and a coil on
the SINS block give a voltage proportional to the RLG's rate of rotation
relative to the block, ``d delta / dt``. Its drawbacks are the time and
temperature dependence of that analog signal; here they are three numbers:

- a scale error: the actual sensitivity is ``scale_v_per_rad_s * (1 + gain_error)``;
- a phase error: a first-order lag of time constant ``lag_s`` between the
  rate and the voltage (phase ``atan(2 pi f lag_s)`` at frequency f);
- white noise of standard deviation ``noise_v`` per output sample (seeded rng);
- a nonlinearity: the sensitivity depends on the deflection,
  ``S (1 + nonlinearity_per_rad2 * delta^2)`` (the magnet leaves the coil's
  uniform field), so that the integral of the voltage is
  ``S (w + nonlinearity_per_rad2 * w^3 / 3)`` with ``w`` the lagged deflection:
  a third harmonic and a gain change of ``nonlinearity_per_rad2 * a^2 / 4``
  at amplitude ``a`` (0 by default: the linear sensor).

Sampling convention: the voltage is read by an integrating converter (a
voltage-to-frequency counter or integrating ADC), so output sample ``n`` is
the *average* over ``[t_{n-1}, t_n]`` of the lagged rate signal. With ``w``
the first-order lag of the deflection (``lag_s w' + w = delta``) that
average is ``(w_n - w_{n-1}) / h`` (the lagged rate is ``w'``). ``w`` is
advanced exactly for a deflection that is linear between samples
(first-order-hold discretisation)::

    w_n = alpha w_{n-1} + (1 - beta) delta_n + (beta - alpha) delta_{n-1},
    alpha = exp(-h / lag_s),  beta = (1 - alpha) lag_s / h

(``lag_s = 0``: ``w = delta``, the voltage is the backward difference of
delta over the step.) Summing the samples times ``h`` therefore gives the
lagged deflection exactly: the ideal pickoff integrates back to delta.

The model reads the suspension deflection ``delta`` (the plant's output) and
nothing else; it is streaming (``process`` in chunks equals one call, bit
for bit, with the same seed).

Three coils (:class:`PickoffTriad`): in a three-axis unit each coil also sees
the other axes' motion (stray field, mounting): coil ``i`` reads the
deflection ``sum_j C_ij delta_j`` through its own lag, gain, nonlinearity
and noise, with ``C`` the 3x3 cross-coupling matrix (identity: no coupling).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy import signal

from sins_sim import _validate as v

__all__ = ["PickoffParams", "PickoffSensor", "PickoffTriadParams", "PickoffTriad"]


@dataclass(frozen=True)
class PickoffParams:
    """Immutable parameters of one pickoff coil and its converter.

    Parameters
    ----------
    scale_v_per_rad_s : float
        Nominal sensitivity (V per rad/s of relative rate), != 0. What the
        stripper believes (its starting gain is the inverse).
    gain_error : float
        Relative error of the actual sensitivity, > -1 (temperature, ageing).
    lag_s : float
        Time constant of the first-order lag (s), >= 0 (coil inductance,
        amplifier); the phase error at 384 Hz is ``atan(2 pi 384 lag_s)``.
    noise_v : float
        White noise standard deviation per output sample (V), >= 0.
    rate_hz : float
        Sampling rate (Hz), > 0; in the project the plant/readout rate (72 kHz).
    nonlinearity_per_rad2 : float
        Relative change of the sensitivity per rad^2 of deflection (1/rad^2), finite, with
        ``1 + nonlinearity_per_rad2 * delta^2 > 0`` over the deflections met; 0: linear.

    Notes
    -----
    The defaults are illustrative, not from the paper: 3 % scale error,
    2 us lag (0.28 deg at the dither), noise of 5e-4 V per sample at
    1 V/(rad/s), i.e. 0.025 % of the 2.1 rad/s dither rate at 3 arcmin.
    """

    scale_v_per_rad_s: float = 1.0
    gain_error: float = 0.03
    lag_s: float = 2e-6
    noise_v: float = 5e-4
    rate_hz: float = 72000.0
    nonlinearity_per_rad2: float = 0.0

    def __post_init__(self):
        o = "pickoff"
        s = v.finite(o, "scale_v_per_rad_s", self.scale_v_per_rad_s)
        if s == 0.0:
            raise ValueError("pickoff.scale_v_per_rad_s: must be != 0, got 0.0")
        ge = v.finite(o, "gain_error", self.gain_error)
        if ge <= -1.0:
            raise ValueError(f"pickoff.gain_error: must be > -1 (sensitivity keeps its sign), got {ge!r}")
        v.non_negative(o, "lag_s", self.lag_s)
        v.non_negative(o, "noise_v", self.noise_v)
        v.positive(o, "rate_hz", self.rate_hz)
        v.finite(o, "nonlinearity_per_rad2", self.nonlinearity_per_rad2)

    @property
    def sensitivity(self) -> float:
        """Actual sensitivity ``scale * (1 + gain_error)`` (V per rad/s)."""
        return self.scale_v_per_rad_s * (1.0 + self.gain_error)

    def lag_coefficients(self) -> tuple[np.ndarray, np.ndarray]:
        """``(b, a)`` of the lagged deflection ``w`` from ``delta`` (first-order hold, exact)."""
        h = 1.0 / self.rate_hz
        if self.lag_s > 0.0:
            alpha = math.exp(-h / self.lag_s)
            beta = (1.0 - alpha) * self.lag_s / h
        else:
            alpha = beta = 0.0
        return np.array([1.0 - beta, beta - alpha]), np.array([1.0, -alpha])

    def coefficients(self) -> tuple[np.ndarray, np.ndarray]:
        """``(b, a)`` of the linear map delta -> voltage (noise excluded): the lag, differenced over the step."""
        bw, a = self.lag_coefficients()
        b = self.sensitivity / (1.0 / self.rate_hz) * np.convolve(bw, [1.0, -1.0])  # as S / h, bit for bit
        return b, a

    def frequency_response(self, f_hz) -> np.ndarray:
        """Complex gain from the deflection ``delta`` to the voltage, per rad (V/rad).

        Compare with the ideal ``j 2 pi f * scale`` to read the scale and phase
        errors; the interval average adds a half-sample delay
        (``exp(-j pi f / rate_hz)``), which summing the samples undoes.
        """
        b, a = self.coefficients()
        f = np.asarray(f_hz, dtype=np.float64)
        _, h = signal.freqz(b, a, worN=np.atleast_1d(f).ravel(), fs=self.rate_hz)
        return h.reshape(f.shape)


class PickoffSensor:
    """Streaming pickoff: deflection samples in, voltage samples out.

    Parameters
    ----------
    params : PickoffParams
    rng : numpy.random.Generator, optional
        Noise source; required when ``noise_v > 0``. One standard normal is
        drawn per sample, in order.
    delta0 : float
        Deflection the sensor rests at before the first sample (rad).

    Examples
    --------
    >>> s = PickoffSensor(PickoffParams(gain_error=0.0, lag_s=0.0, noise_v=0.0))
    >>> volts = s.process(np.array([0.0, 1e-5, 3e-5]))  # rad, at 72 kHz
    >>> np.round(volts, 6).tolist()  # V = rad/s: the backward difference over each step
    [0.0, 0.72, 1.44]
    """

    def __init__(self, params: PickoffParams, rng: np.random.Generator | None = None, delta0: float = 0.0):
        if not isinstance(params, PickoffParams):
            raise ValueError(f"pickoff: must be PickoffParams, got {type(params).__name__}")
        if params.noise_v > 0.0 and not isinstance(rng, np.random.Generator):
            raise ValueError(
                f"pickoff.rng: a numpy.random.Generator is required when noise_v > 0, got {type(rng).__name__}"
            )
        self.params = params
        self.rng = rng
        self._b, self._a = params.coefficients()
        self._bw, self._aw = params.lag_coefficients()
        self.reset(delta0)

    def reset(self, delta0: float = 0.0) -> None:
        """At rest at deflection ``delta0`` (the noise generator is not rewound)."""
        d0 = v.finite("pickoff", "delta0", delta0)
        self._zi = signal.lfilter_zi(self._b, self._a) * d0
        self._ziw = signal.lfilter_zi(self._bw, self._aw) * d0  # the lagged deflection (nonlinear term)
        self._w_last = d0

    def process(self, delta) -> np.ndarray:
        """Voltage samples (V) for the next chunk of deflection samples (rad)."""
        d = v.finite_array("pickoff", "delta", delta)
        if d.size == 0:  # scipy's lfilter returns a wrong final state for an empty input
            return np.empty(0)
        out, self._zi = signal.lfilter(self._b, self._a, d, zi=self._zi)
        nl = self.params.nonlinearity_per_rad2
        if nl != 0.0:  # the voltage's integral gains S nl (w^3 - w_prev^3) / 3 over each step
            w, self._ziw = signal.lfilter(self._bw, self._aw, d, zi=self._ziw)
            w3 = w * w * w
            prev = np.concatenate(([self._w_last ** 3], w3[:-1]))
            out = out + (self.params.sensitivity * nl * self.params.rate_hz / 3.0) * (w3 - prev)
            self._w_last = float(w[-1])
        if self.params.noise_v > 0.0:
            out = out + self.params.noise_v * self.rng.standard_normal(d.shape)
        return out


def _identity3() -> tuple:
    return ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


#: Largest condition number of the cross-coupling matrix: beyond it the three coils do not tell the axes apart
#: (a stripper inverting ``C`` would amplify the pickoff noise by more than this).
MAX_COUPLING_CONDITION = 1.0e3


@dataclass(frozen=True)
class PickoffTriadParams:
    """The three pickoff coils of a three-axis unit and their cross-coupling.

    Parameters
    ----------
    coils : tuple of three PickoffParams
        Coils x, y, z (their own scale, gain, lag, noise and nonlinearity errors).
    coupling : tuple of three 3-tuples
        Cross-coupling matrix ``C`` (dimensionless): coil ``i`` reads ``sum_j C_ij delta_j``.
        Finite, condition number <= :data:`MAX_COUPLING_CONDITION`; default identity.
    """

    coils: tuple = (PickoffParams(), PickoffParams(), PickoffParams())
    coupling: tuple = field(default_factory=_identity3)

    def __post_init__(self):
        if len(self.coils) != 3 or not all(isinstance(c, PickoffParams) for c in self.coils):
            raise ValueError("pickoff.coils: must be three PickoffParams (x, y, z)")
        c = np.asarray(self.coupling, dtype=np.float64) if _is_matrix(self.coupling) else None
        if c is None or c.shape != (3, 3) or not np.all(np.isfinite(c)):
            raise ValueError(f"pickoff.cross_coupling: must be a 3x3 matrix of finite numbers, got {self.coupling!r}")
        cond = float(np.linalg.cond(c))
        if not cond <= MAX_COUPLING_CONDITION:
            raise ValueError(f"pickoff.cross_coupling: condition number must be <= {MAX_COUPLING_CONDITION:g} (the "
                             f"coils must tell the three axes apart), got {cond:.3g}")
        object.__setattr__(self, "coupling", tuple(tuple(float(x) for x in row) for row in c))

    @property
    def matrix(self) -> np.ndarray:
        """``C`` as a (3, 3) array."""
        return np.array(self.coupling)


def _is_matrix(x) -> bool:
    try:
        np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError):
        return False
    return True


class PickoffTriad:
    """Three streaming pickoffs: deflections (3, n) in, voltages (3, n) out.

    Parameters
    ----------
    params : PickoffTriadParams
    rngs : sequence of three numpy.random.Generator, optional
        One noise source per coil (required for a coil with ``noise_v > 0``), so that each coil's
        draws are in sample order whatever the chunking: chunked equals one call, bit for bit.
    """

    def __init__(self, params: PickoffTriadParams, rngs=(None, None, None)):
        if not isinstance(params, PickoffTriadParams):
            raise ValueError(f"pickoff: must be PickoffTriadParams, got {type(params).__name__}")
        if len(rngs) != 3:
            raise ValueError(f"pickoff.rngs: must be three generators (one per coil), got {len(rngs)}")
        self.params = params
        self._c = params.matrix
        self.sensors = [PickoffSensor(p, r) for p, r in zip(params.coils, rngs)]

    def reset(self) -> None:
        for s in self.sensors:
            s.reset(0.0)

    def process(self, delta) -> np.ndarray:
        """Voltages (V), shape (3, n), for the deflections ``delta`` (rad), shape (3, n)."""
        d = np.asarray(delta, dtype=np.float64)
        if d.ndim != 2 or d.shape[0] != 3:
            raise ValueError(f"pickoff.delta: must have shape (3, n), got {d.shape}")
        mixed = self._c @ d
        return np.stack([s.process(mixed[i]) for i, s in enumerate(self.sensors)]) if d.shape[1] else np.zeros((3, 0))
