"""The ring laser readout: fringe counting, anti-alias filter and decimation.

docs/theory/suspension.md, "Readout": the ring laser counts fringes, its output is
the accumulated count ``floor(phi_rlg / q)`` with quantum ``q`` (2.42 arcsec
per fringe for a 28 cm triangular He-Ne cavity; the paper's comparator plus
12-bit ADC interpolate to 1/16 fringe, so ``q`` is a setting). The paper's
chain samples the readout at 72 kHz, low-pass filters it (9 kHz band) and
decimates it to 7.2 kHz, the rate at which the filters run.

Conventions chosen here (the paper gives the band, not the filter):

- optional white readout noise of standard deviation ``noise_rad`` is added
  to the angle before quantisation (it dithers the quantiser);
- the anti-alias filter is a linear-phase FIR from ``scipy.signal.firwin``
  (Hamming window, unity DC gain); 21 taps at 72 kHz delay the signal by
  exactly 10 input samples = one 7.2 kHz output sample, so the decimated
  angle at output index ``k`` describes the RLG at ``t = (k - 1) / 7200``;
- decimation keeps the filter outputs at input indices ``0, R, 2R, ...``
  (``scipy.signal.lfilter(taps, 1, x)[::R]``).

Because of ``floor``, ``counts * q`` lies in ``(phi - q, phi]``: without
noise it is ``q / 2`` low on average; a consumer that wants an unbiased
angle adds ``q / 2``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from numbers import Integral

import numpy as np
from scipy import signal

from sins_sim import _validate as v
from sins_sim._kernels.fir import fir_decimate
from sins_sim.units import INTERPOLATED_QUANTUM_RAD

__all__ = ["AntiAliasParams", "ReadoutParams", "quantise", "Decimator", "Readout", "QUANTUM_RANGE_RAD",
           "QUANTUM_REAL_RANGE_RAD", "NOISE_MAX_RAD", "RATE_MAX_HZ", "MAX_NUMTAPS"]

# --- physical ranges (issue 12, point 4): declared in sins_sim.models.ranges, re-exported here
from sins_sim.models.ranges import (MAX_NUMTAPS, NOISE_MAX_RAD, QUANTUM_RANGE_RAD,  # noqa: E402
                                    QUANTUM_REAL_RANGE_RAD, RATE_MAX_HZ)


@dataclass(frozen=True)
class AntiAliasParams:
    """Anti-alias FIR applied before decimation (docs/theory/suspension.md, "Readout").

    Parameters
    ----------
    cutoff_hz : float
        Cut-off (-6 dB point of ``scipy.signal.firwin``) in Hz, > 0; must be
        below half the input rate (checked by :class:`ReadoutParams`).
        Default 9 kHz, the paper's band.
    numtaps : int
        Number of taps, odd and >= 1 (odd keeps the delay a whole number of
        input samples, ``(numtaps - 1) / 2``).
    window : str or tuple
        Window for ``scipy.signal.firwin`` (``scipy.signal.get_window``
        syntax), default ``"hamming"``.
    """

    cutoff_hz: float = 9000.0
    numtaps: int = 21
    window: str | tuple = "hamming"

    def __post_init__(self):
        o = "readout.anti_alias"
        object.__setattr__(self, "cutoff_hz", v.positive(o, "cutoff_hz", self.cutoff_hz))
        n = self.numtaps
        if isinstance(n, bool) or not isinstance(n, Integral) or n < 1 or n % 2 == 0 or n > MAX_NUMTAPS:
            raise ValueError(f"{o}.numtaps: must be an odd integer in [1, {MAX_NUMTAPS}], got {n!r}")
        object.__setattr__(self, "numtaps", int(n))
        try:
            w = signal.get_window(self.window, 3, fftbins=False)
        except (ValueError, TypeError) as exc:
            raise ValueError(
                f"{o}.window: must be a window scipy.signal.get_window knows, "
                f"got {self.window!r} ({exc})"
            ) from None
        if not np.all(np.isfinite(w)):
            raise ValueError(f"{o}.window: gives non-finite weights, got {self.window!r}")

    def taps(self, input_rate_hz: float) -> np.ndarray:
        """FIR coefficients at the given input rate (unity DC gain).

        Parameters
        ----------
        input_rate_hz : float
            Sampling rate of the filtered signal (Hz); ``cutoff_hz`` must be
            below its half.

        Returns
        -------
        ndarray of float64, shape (numtaps,)
        """
        fs = v.positive("readout", "input_rate_hz", input_rate_hz)
        if not self.cutoff_hz < fs / 2.0:
            raise ValueError(
                f"readout.anti_alias.cutoff_hz: must be < input_rate_hz / 2 = {fs / 2.0!r}, "
                f"got {self.cutoff_hz!r}"
            )
        return np.asarray(
            signal.firwin(self.numtaps, self.cutoff_hz, window=self.window, fs=fs),
            dtype=np.float64,
        )


@dataclass(frozen=True)
class ReadoutParams:
    """Immutable parameters of the readout chain (docs/theory/suspension.md, "Readout").

    Parameters
    ----------
    quantum_rad : float
        Angle per count ``q`` (rad), > 0. Default: the paper's interpolated
        1/16 fringe; :data:`sins_sim.units.FRINGE_RAD` is the raw fringe.
    noise_rad : float
        Standard deviation of white noise added to the angle before
        quantisation (rad), >= 0.
    input_rate_hz : float
        Rate at which the fringe counter is sampled (Hz), > 0; 72 kHz in the
        paper.
    output_rate_hz : float
        Rate after decimation (Hz), > 0, with ``input_rate_hz /
        output_rate_hz`` an integer within 1e-9 relative; 7.2 kHz in the
        paper.
    anti_alias : AntiAliasParams or None
        The anti-alias FIR; ``None`` switches it off (plain decimation,
        every R-th sample).

    Examples
    --------
    >>> p = ReadoutParams()
    >>> p.decimation, p.delay_s * 7200.0
    (10, 1.0)
    """

    quantum_rad: float = INTERPOLATED_QUANTUM_RAD
    noise_rad: float = 0.0
    input_rate_hz: float = 72000.0
    output_rate_hz: float = 7200.0
    anti_alias: AntiAliasParams | None = field(default_factory=AntiAliasParams)

    def __post_init__(self):
        o = "readout"
        q = v.positive(o, "quantum_rad", self.quantum_rad)
        if not QUANTUM_RANGE_RAD[0] <= q <= QUANTUM_RANGE_RAD[1]:
            lo, hi = QUANTUM_RANGE_RAD
            raise ValueError(f"{o}.quantum_rad: must be in [{lo:.3g}, {hi:.3g}] rad (real readouts: 0.001 to 60 "
                             f"arcsec), got {q!r}")
        object.__setattr__(self, "quantum_rad", q)
        noise = v.non_negative(o, "noise_rad", self.noise_rad)
        if noise > NOISE_MAX_RAD:
            raise ValueError(f"{o}.noise_rad: must be <= {NOISE_MAX_RAD:.3g} rad (60 arcsec), got {noise!r}")
        object.__setattr__(self, "noise_rad", noise)
        fin = v.positive(o, "input_rate_hz", self.input_rate_hz)
        fout = v.positive(o, "output_rate_hz", self.output_rate_hz)
        for name, rate in (("input_rate_hz", fin), ("output_rate_hz", fout)):
            if rate > RATE_MAX_HZ:
                raise ValueError(f"{o}.{name}: must be <= {RATE_MAX_HZ:g} Hz, got {rate!r}")
        object.__setattr__(self, "input_rate_hz", fin)
        object.__setattr__(self, "output_rate_hz", fout)
        v.integer_ratio(o, "output_rate_hz", fin, fout, "input_rate_hz / output_rate_hz")
        aa = self.anti_alias
        if aa is not None:
            if not isinstance(aa, AntiAliasParams):
                raise ValueError(
                    f"{o}.anti_alias: must be AntiAliasParams or None, got {type(aa).__name__}"
                )
            if not aa.cutoff_hz < fin / 2.0:
                raise ValueError(
                    f"{o}.anti_alias.cutoff_hz: must be < input_rate_hz / 2 = {fin / 2.0!r}, "
                    f"got {aa.cutoff_hz!r}"
                )

    @property
    def decimation(self) -> int:
        """Decimation factor ``R = input_rate_hz / output_rate_hz``."""
        return int(round(self.input_rate_hz / self.output_rate_hz))

    @property
    def delay_s(self) -> float:
        """Group delay of the anti-alias FIR, ``(numtaps - 1) / 2 / input_rate_hz`` (0 when off)."""
        if self.anti_alias is None:
            return 0.0
        return (self.anti_alias.numtaps - 1) / 2.0 / self.input_rate_hz

    def taps(self) -> np.ndarray:
        """Anti-alias FIR coefficients at ``input_rate_hz`` (``[1.0]`` when off)."""
        if self.anti_alias is None:
            return np.ones(1, dtype=np.float64)
        return self.anti_alias.taps(self.input_rate_hz)


def quantise(phi_rad, quantum_rad: float, noise_rad: float = 0.0, rng=None) -> np.ndarray:
    """Accumulated fringe count ``floor((phi + noise) / q)`` (docs/theory/suspension.md, "Readout").

    Parameters
    ----------
    phi_rad : array_like
        RLG angle ``phi_rlg`` (rad), finite.
    quantum_rad : float
        Angle per count ``q`` (rad), > 0.
    noise_rad : float
        Standard deviation of white noise added before quantisation (rad),
        >= 0.
    rng : numpy.random.Generator, optional
        Source of the noise, required when ``noise_rad > 0``. One standard
        normal is drawn per sample, in order, so splitting a signal into
        chunks does not change the noise sequence.

    Returns
    -------
    ndarray of int64
        Counts, same shape as ``phi_rad``.

    Examples
    --------
    >>> quantise([-0.5, 0.0, 0.99, 1.0], 1.0).tolist()
    [-1, 0, 0, 1]
    """
    q = v.positive("readout", "quantum_rad", quantum_rad)
    sigma = v.non_negative("readout", "noise_rad", noise_rad)
    phi = np.asarray(phi_rad, dtype=np.float64)
    if not np.all(np.isfinite(phi)):
        raise ValueError("readout.phi_rad: must be finite everywhere (NaN or inf found)")
    if sigma > 0.0:
        if not isinstance(rng, np.random.Generator):
            raise ValueError(
                "readout.rng: a numpy.random.Generator is required when noise_rad > 0, "
                f"got {type(rng).__name__}"
            )
        phi = phi + sigma * rng.standard_normal(phi.shape)
    return np.floor(phi / q).astype(np.int64)


class Decimator:
    """Streaming linear-phase FIR low-pass followed by keeping every R-th sample.

    Output ``k`` of the whole stream is ``sum_j taps[j] * x[k R - j]``
    (``scipy.signal.lfilter(taps, 1, x)[::R]``); chunks of any length give
    output bit-identical to one call on the whole stream. Any signal sampled
    at the input rate can go through it: passing the drive voltage through a
    Decimator built from the same parameters keeps it time-aligned with the
    decimated readout.

    Parameters
    ----------
    taps : array_like, 1-D
        FIR coefficients, finite, symmetric (linear phase), at least one.
    decimation : int
        Decimation factor ``R >= 1``.
    input_rate_hz : float
        Input sampling rate (Hz), > 0.

    Attributes
    ----------
    taps : ndarray
        The FIR coefficients (read-only).
    decimation : int
        ``R``.
    input_rate_hz, output_rate_hz : float
        Rates before and after decimation.
    delay_s : float
        Group delay of the FIR, ``(len(taps) - 1) / 2 / input_rate_hz``.
    """

    def __init__(self, taps, decimation: int, input_rate_hz: float):
        o = "decimator"
        t = np.array(v.finite_array(o, "taps", taps, ndim=1), dtype=np.float64, order="C")
        if t.size < 1:
            raise ValueError(f"{o}.taps: must hold at least one coefficient, got 0")
        scale = max(float(np.max(np.abs(t))), np.finfo(np.float64).tiny)
        if np.max(np.abs(t - t[::-1])) > 1e-12 * scale:
            raise ValueError(f"{o}.taps: must be symmetric (linear phase)")
        if isinstance(decimation, bool) or not isinstance(decimation, Integral) or decimation < 1:
            raise ValueError(f"{o}.decimation: must be an integer >= 1, got {decimation!r}")
        fs = v.positive(o, "input_rate_hz", input_rate_hz)
        t.setflags(write=False)
        self.taps = t
        self.decimation = int(decimation)
        self.input_rate_hz = fs
        self.output_rate_hz = fs / self.decimation
        self.delay_s = (t.size - 1) / 2.0 / fs
        self._taps = np.array(t)  # writable copy for the kernel
        self._hist = np.zeros(t.size - 1, dtype=np.float64)
        self._phase = 0

    @classmethod
    def from_readout(cls, params: ReadoutParams) -> "Decimator":
        """The decimator of a readout chain (anti-alias FIR, or plain ``x[::R]`` when off)."""
        if not isinstance(params, ReadoutParams):
            raise ValueError(
                f"readout: must be ReadoutParams, got {type(params).__name__}"
            )
        return cls(params.taps(), params.decimation, params.input_rate_hz)

    def reset(self) -> None:
        """Return to rest: zero history, next input is sample 0 of a new stream."""
        self._hist[:] = 0.0
        self._phase = 0

    def process(self, x) -> np.ndarray:
        """Filter and decimate the next chunk.

        Parameters
        ----------
        x : array_like, 1-D
            Next input samples, finite.

        Returns
        -------
        ndarray of float64
            The outputs this chunk completes (possibly none).
        """
        xa = np.ascontiguousarray(v.finite_array("decimator", "x", x, ndim=1))
        r = self.decimation
        first = (r - self._phase) % r
        n_out = (xa.size - first + r - 1) // r if first < xa.size else 0
        y = np.empty(n_out, dtype=np.float64)
        _, self._phase = fir_decimate(self._taps, xa, self._hist, self._phase, y, r)
        return y


class Readout:
    """Streaming readout chain: fringe counter at the input rate, decimated angle.

    ``process`` turns a chunk of ``phi_rlg`` sampled at ``input_rate_hz``
    into the counts at that rate and the decimated angle
    ``Decimator(counts * q)`` at ``output_rate_hz``. With the same seed,
    chunked use equals whole-array use bit for bit.

    Parameters
    ----------
    params : ReadoutParams
        The chain.
    rng : numpy.random.Generator, optional
        Noise source, required when ``params.noise_rad > 0``.

    Attributes
    ----------
    params : ReadoutParams
    decimator : Decimator
    """

    def __init__(self, params: ReadoutParams, rng: np.random.Generator | None = None):
        if not isinstance(params, ReadoutParams):
            raise ValueError(f"readout: must be ReadoutParams, got {type(params).__name__}")
        if params.noise_rad > 0.0 and not isinstance(rng, np.random.Generator):
            raise ValueError(
                "readout.rng: a numpy.random.Generator is required when noise_rad > 0, "
                f"got {type(rng).__name__}"
            )
        self.params = params
        self.rng = rng
        self.decimator = Decimator.from_readout(params)

    @property
    def delay_s(self) -> float:
        """Group delay of the decimated angle relative to ``phi_rlg`` (s)."""
        return self.decimator.delay_s

    def reset(self) -> None:
        """Return the decimator to rest (the noise generator is not rewound)."""
        self.decimator.reset()

    def process(self, phi_rlg) -> tuple[np.ndarray, np.ndarray]:
        """Read the next chunk of the RLG angle.

        Parameters
        ----------
        phi_rlg : array_like, 1-D
            RLG angle (rad) at ``input_rate_hz``, finite.

        Returns
        -------
        counts : ndarray of int64
            Accumulated fringe count at the input rate, same length.
        angle : ndarray of float64
            ``counts * q`` through the anti-alias FIR, decimated to
            ``output_rate_hz``.
        """
        phi = v.finite_array("readout", "phi_rlg", phi_rlg, ndim=1)
        p = self.params
        counts = quantise(phi, p.quantum_rad, p.noise_rad, self.rng)
        angle = self.decimator.process(counts.astype(np.float64) * p.quantum_rad)
        return counts, angle
