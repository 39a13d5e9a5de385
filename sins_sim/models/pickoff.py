"""The electrodynamic dither pickoff: the industry's sensor for dither stripping.

The paper's introduction: a permanent magnet on the RLG body and a coil on
the SINS block give a voltage proportional to the RLG's rate of rotation
relative to the block, ``d delta / dt``. Its drawbacks are the time and
temperature dependence of that analog signal; here they are three numbers:

- a scale error: the actual sensitivity is ``scale_v_per_rad_s * (1 + gain_error)``;
- a phase error: a first-order lag of time constant ``lag_s`` between the
  rate and the voltage (phase ``atan(2 pi f lag_s)`` at frequency f);
- white noise of standard deviation ``noise_v`` per output sample (seeded rng).

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
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import signal

from sins_sim import _validate as v

__all__ = ["PickoffParams", "PickoffSensor"]


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

    @property
    def sensitivity(self) -> float:
        """Actual sensitivity ``scale * (1 + gain_error)`` (V per rad/s)."""
        return self.scale_v_per_rad_s * (1.0 + self.gain_error)

    def coefficients(self) -> tuple[np.ndarray, np.ndarray]:
        """``(b, a)`` of the linear map delta -> voltage (noise excluded)."""
        h = 1.0 / self.rate_hz
        if self.lag_s > 0.0:
            alpha = math.exp(-h / self.lag_s)
            beta = (1.0 - alpha) * self.lag_s / h
        else:
            alpha = beta = 0.0
        b = self.sensitivity / h * np.convolve([1.0 - beta, beta - alpha], [1.0, -1.0])
        a = np.array([1.0, -alpha])
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
        self.reset(delta0)

    def reset(self, delta0: float = 0.0) -> None:
        """At rest at deflection ``delta0`` (the noise generator is not rewound)."""
        d0 = v.finite("pickoff", "delta0", delta0)
        self._zi = signal.lfilter_zi(self._b, self._a) * d0

    def process(self, delta) -> np.ndarray:
        """Voltage samples (V) for the next chunk of deflection samples (rad)."""
        d = v.finite_array("pickoff", "delta", delta)
        if d.size == 0:  # scipy's lfilter returns a wrong final state for an empty input
            return np.empty(0)
        out, self._zi = signal.lfilter(self._b, self._a, d, zi=self._zi)
        if self.params.noise_v > 0.0:
            out = out + self.params.noise_v * self.rng.standard_normal(d.shape)
        return out
