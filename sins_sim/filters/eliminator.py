"""The elliptic dither eliminator: the paper's baseline band-stop filter.

docs/theory/suspension.md, "The elliptic eliminator": a 10th-order elliptic IIR
band-stop at 7.2 kHz with a 370 to 410 Hz band for a 386 Hz dither (the
paper's refs [3, 9, 19]); for other channels the band is centred on the
channel's dither frequency with the same width. The paper states neither
ripple nor attenuation, so both are settings (default 0.1 dB pass-band
ripple, 60 dB stop-band attenuation). The design is
``scipy.signal.ellip(order, rp, rs, band, btype="bandstop", fs=fs,
output="sos")`` with ``order = 5`` (a band-stop doubles the prototype order:
10 poles), run as second-order sections in transposed direct form II
(``sins_sim._kernels.sos``, identical to ``scipy.signal.sosfilt``).

``band_hz`` are the edges handed to scipy: for an elliptic design they are
where the gain first leaves the pass-band ripple (``-rp_db``); the stop band
(at least ``rs_db`` down) is narrower and lies inside them.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property, lru_cache
from numbers import Integral

import numpy as np
from scipy import signal

from sins_sim import _validate as v
from sins_sim._kernels.sos import sos_filter

__all__ = ["EliminatorDesign", "Eliminator", "eliminate"]

_OWNER = "eliminator"

# Ranges (issue 12, point 4).
#: Sampling rate (Hz): at most 1 MHz (the readout's limit).
FS_MAX_HZ = 1.0e6
#: Prototype order: the paper's band-stop has order 5 (10 poles); beyond 20 (40 poles) the sections' poles
#: crowd the unit circle and the design says more about rounding than about a filter.
MAX_ORDER = 20
# the ripple limits: declared in sins_sim.filters.ranges (no heavy import: a configuration file is checked against
# them before scipy and numba load), re-exported here
from sins_sim.filters.ranges import MAX_RP_DB, MAX_RS_DB  # noqa: E402

# scipy >= 1.15 names it freqz_sos; sosfreqz is the older name (same function).
_freqz_sos = getattr(signal, "freqz_sos", None) or signal.sosfreqz


@lru_cache(maxsize=256)
def _ellip_sos(order: int, rp_db: float, rs_db: float, band_hz: tuple, fs_hz: float) -> np.ndarray:
    """The sections of :attr:`EliminatorDesign.sos`, designed once per parameter set and process.

    A run builds one eliminator per channel and a sweep thousands of identical ones: the elliptic design
    (``scipy.signal.ellip``, about 2 ms) depends only on these validated, hashable parameters, and its result is
    read-only, so every design of the same parameters shares one array (the same bits as designing it again). An
    unstable design raises every time (``lru_cache`` does not keep exceptions).
    """
    sos = signal.ellip(
        order,
        rp_db,
        rs_db,
        list(band_hz),
        btype="bandstop",
        fs=fs_hz,
        output="sos",
    )
    sos = np.ascontiguousarray(sos, dtype=np.float64)
    # each section's poles are the roots of z^2 + a1 z + a2: inside the unit circle, or the filter grows
    radius = max((float(np.max(np.abs(np.roots(row[3:])))) for row in sos), default=0.0)
    if not (np.all(np.isfinite(sos)) and radius < 1.0):
        raise ValueError(
            f"{_OWNER}.band_hz: the elliptic design {band_hz} Hz at {fs_hz:g} Hz, order {order}, "
            f"is not stable in float64 (largest pole radius {radius:.12g}); widen the band or lower the order"
        )
    sos.setflags(write=False)
    return sos


@dataclass(frozen=True)
class EliminatorDesign:
    """Immutable design of one elliptic band-stop eliminator.

    Parameters
    ----------
    fs_hz : float
        Sampling rate (Hz), > 0. The paper's filters run at 7.2 kHz
        (docs/theory/suspension.md, "Readout").
    band_hz : tuple of float
        ``(lo, hi)`` pass-band edges (Hz) handed to ``scipy.signal.ellip``,
        with ``0 < lo < hi < fs_hz / 2``.
    order : int
        Prototype order, >= 1; the band-stop has ``2 * order`` poles
        (docs/theory/suspension.md: order 5, 10 poles).
    rp_db : float
        Maximum pass-band ripple (dB), > 0.
    rs_db : float
        Minimum stop-band attenuation (dB), > ``rp_db``.

    Examples
    --------
    >>> d = EliminatorDesign.paper()
    >>> d.band_hz, d.n_poles
    ((370.0, 410.0), 10)
    """

    fs_hz: float = 7200.0
    band_hz: tuple[float, float] = (370.0, 410.0)
    order: int = 5
    rp_db: float = 0.1
    rs_db: float = 60.0

    def __post_init__(self):
        fs = v.positive(_OWNER, "fs_hz", self.fs_hz)
        if fs > FS_MAX_HZ:
            raise ValueError(f"{_OWNER}.fs_hz: must be <= {FS_MAX_HZ:g} Hz, got {fs!r}")
        band = self.band_hz
        try:
            n_edges = len(band)
        except TypeError:
            n_edges = -1
        if n_edges != 2:
            raise ValueError(f"{_OWNER}.band_hz: must be a pair (lo, hi) in Hz, got {band!r}")
        lo = v.finite(_OWNER, "band_hz", band[0])
        hi = v.finite(_OWNER, "band_hz", band[1])
        if not 0.0 < lo < hi:
            raise ValueError(f"{_OWNER}.band_hz: must satisfy 0 < lo < hi, got ({lo!r}, {hi!r})")
        if not hi < fs / 2.0:
            raise ValueError(
                f"{_OWNER}.band_hz: hi must be < fs_hz / 2 = {fs / 2.0!r}, got {hi!r}"
            )
        order = self.order
        if isinstance(order, bool) or not isinstance(order, Integral) or not 1 <= order <= MAX_ORDER:
            raise ValueError(f"{_OWNER}.order: must be an integer in [1, {MAX_ORDER}], got {order!r}")
        rp = v.positive(_OWNER, "rp_db", self.rp_db)
        if rp > MAX_RP_DB:
            raise ValueError(f"{_OWNER}.rp_db: must be in (0, {MAX_RP_DB:g}] dB, got {rp!r}")
        rs = v.positive(_OWNER, "rs_db", self.rs_db)
        if not rs > rp:
            raise ValueError(f"{_OWNER}.rs_db: must be > rp_db = {rp!r}, got {rs!r}")
        if rs > MAX_RS_DB:
            raise ValueError(f"{_OWNER}.rs_db: must be <= {MAX_RS_DB:g} dB, got {rs!r}")
        object.__setattr__(self, "fs_hz", fs)
        object.__setattr__(self, "band_hz", (lo, hi))
        object.__setattr__(self, "order", int(order))
        object.__setattr__(self, "rp_db", rp)
        object.__setattr__(self, "rs_db", rs)

    @classmethod
    def centred(
        cls,
        dither_hz: float,
        width_hz: float = 40.0,
        fs_hz: float = 7200.0,
        order: int = 5,
        rp_db: float = 0.1,
        rs_db: float = 60.0,
    ) -> "EliminatorDesign":
        """Band ``(dither - width/2, dither + width/2)`` centred on a channel's dither.

        docs/theory/suspension.md, "The elliptic eliminator": other channels use the
        paper's 40 Hz width centred on their own dither frequency.

        Parameters
        ----------
        dither_hz : float
            Dither frequency of the channel (Hz), > 0.
        width_hz : float
            Distance between the pass-band edges (Hz), > 0.
        fs_hz, order, rp_db, rs_db
            As in the class.
        """
        f = v.positive(_OWNER, "dither_hz", dither_hz)
        w = v.positive(_OWNER, "width_hz", width_hz)
        return cls(
            fs_hz=fs_hz,
            band_hz=(f - w / 2.0, f + w / 2.0),
            order=order,
            rp_db=rp_db,
            rs_db=rs_db,
        )

    @classmethod
    def paper(cls) -> "EliminatorDesign":
        """The paper's eliminator: 370 to 410 Hz at 7.2 kHz, 10 poles, 0.1 dB / 60 dB."""
        return cls(fs_hz=7200.0, band_hz=(370.0, 410.0), order=5, rp_db=0.1, rs_db=60.0)

    @cached_property
    def sos(self) -> np.ndarray:
        """Second-order sections, shape ``(order, 6)``, read-only (one design per parameter set and process:
        :func:`_ellip_sos`)."""
        return _ellip_sos(self.order, self.rp_db, self.rs_db, self.band_hz, self.fs_hz)

    @property
    def n_poles(self) -> int:
        """Number of poles, ``2 * order``."""
        return 2 * self.order

    def poles(self) -> np.ndarray:
        """Poles in the z plane (complex, length ``n_poles``)."""
        return signal.sos2zpk(self.sos)[1]

    def _frequencies(self, f_hz) -> np.ndarray:
        f = np.asarray(f_hz, dtype=np.float64)
        if not np.all(np.isfinite(f)):
            raise ValueError(f"{_OWNER}.f_hz: must be finite everywhere, got {f_hz!r}")
        return f

    def frequency_response(self, f_hz) -> np.ndarray:
        """Complex gain ``H(exp(j 2 pi f / fs))`` at frequencies ``f_hz`` (Hz).

        Parameters
        ----------
        f_hz : float or array_like
            Frequencies (Hz), finite.

        Returns
        -------
        ndarray of complex
            Same shape as ``f_hz`` (``scipy.signal.sosfreqz``).
        """
        f = self._frequencies(f_hz)
        _, h = _freqz_sos(self.sos, worN=np.atleast_1d(f).ravel(), fs=self.fs_hz)
        return h.reshape(f.shape)

    def group_delay_s(self, f_hz) -> np.ndarray:
        """Group delay ``-d(arg H)/d(omega)`` (s) at frequencies ``f_hz`` (Hz).

        The sum over sections of ``scipy.signal.group_delay`` on each
        section's ``(b, a)`` (the group delay of a cascade is the sum of the
        sections'), which avoids the ill-conditioned 10th-order polynomial.
        At a transmission zero on the unit circle the delay is undefined;
        scipy then returns 0 for that section and warns.

        Parameters
        ----------
        f_hz : float or array_like
            Frequencies (Hz), finite.

        Returns
        -------
        ndarray of float
            Same shape as ``f_hz``.
        """
        f = self._frequencies(f_hz)
        w = np.atleast_1d(f).ravel()
        total = np.zeros(w.shape, dtype=np.float64)
        for row in self.sos:
            _, gd = signal.group_delay((row[:3], row[3:]), w=w, fs=self.fs_hz)
            total += gd
        return (total / self.fs_hz).reshape(f.shape)


class Eliminator:
    """Streaming elliptic band-stop: feed chunks, get the filtered chunks.

    The state is zero at construction and after :meth:`reset` (system at
    rest). Feeding a signal in chunks of any length gives output
    bit-identical to one call on the whole signal.

    Parameters
    ----------
    design : EliminatorDesign
        The filter to run.

    Examples
    --------
    >>> import numpy as np
    >>> e = Eliminator(EliminatorDesign.paper())
    >>> y = e.process(np.ones(8))
    >>> y.shape
    (8,)
    """

    def __init__(self, design: EliminatorDesign):
        if not isinstance(design, EliminatorDesign):
            raise ValueError(
                f"{_OWNER}.design: must be an EliminatorDesign, got {type(design).__name__}"
            )
        self.design = design
        self._sos = np.array(design.sos, dtype=np.float64, order="C")
        self._zi = np.zeros((self._sos.shape[0], 2), dtype=np.float64)

    def reset(self) -> None:
        """Return to rest (zero state)."""
        self._zi[:] = 0.0

    @property
    def state(self) -> np.ndarray:
        """Copy of the filter state, shape ``(n_sections, 2)`` (sosfilt's ``zi``)."""
        return self._zi.copy()

    def process(self, x) -> np.ndarray:
        """Filter the next chunk.

        Parameters
        ----------
        x : array_like, 1-D
            Next input samples at ``design.fs_hz``, finite.

        Returns
        -------
        ndarray of float64
            Filtered samples, a new array of the same length.
        """
        xa = np.ascontiguousarray(v.finite_array(_OWNER, "x", x, ndim=1))
        y = np.empty_like(xa)
        sos_filter(self._sos, xa, self._zi, y)
        return y


def eliminate(x, design: EliminatorDesign) -> np.ndarray:
    """Run a whole signal through a fresh (at rest) eliminator.

    Parameters
    ----------
    x : array_like, 1-D
        Samples at ``design.fs_hz``, finite.
    design : EliminatorDesign
        The filter.

    Returns
    -------
    ndarray of float64
        Filtered signal.
    """
    return Eliminator(design).process(x)
