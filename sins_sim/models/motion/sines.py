"""Block motions made of sinusoids: per-axis sines, pure coning, random vibration as a sum of tones.

Rates and angle increments of every sum of sinusoids are evaluated by
``sins_sim._kernels.motion`` (``_SineBank``); :class:`Coning` adds its
closed-form attitude. Random vibration as filtered noise (never repeating)
is :class:`~sins_sim.models.motion.vibration.FilteredNoiseVibration`.

.. autosummary::

   AxisSines
   Coning
   RandomVibration

References
----------
Numbered as in the library overview (:mod:`sins_sim.models.motion.body`).

.. [2] P. G. Savage, "Strapdown inertial navigation integration algorithm
   design, Part 1: attitude algorithms", J. Guid. Control Dyn. 21(1), 19-28,
   1998 (coning motion and the two-sample coning algorithm).
.. [3] L. E. Goodman, A. R. Robinson, "Effect of finite rotations on
   gyroscopic sensing devices", J. Appl. Mech. 25, 210-213, 1958 (coning drift).
.. [5] M. Shinozuka, C.-M. Jan, "Digital simulation of random processes and
   its applications", J. Sound Vib. 25(1), 111-128, 1972 (spectral
   representation of a random process by a sum of cosines).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from sins_sim import _validate as v
from sins_sim._kernels.motion import comb_increment, comb_rate, sines_grid, sines_increment, sines_rate
from sins_sim.models.motion.base import (_STATIC, Motion3D, _axis_index, _loglog_segment_integral, _psd_table, _qconj,
                                         _qexp, _qmul, _set, _vec3)

__all__ = ["AxisSines", "Coning", "RandomVibration"]

_MAX_TONES = 1_000_000


class _SineBank(Motion3D):
    """Motions that are sums of sinusoids per axis (rate ``sum amp cos(omega t + phase)``).

    Subclasses set ``_amp``, ``_omega``, ``_phase`` (float64[3, K]) in
    ``__post_init__``; rate and angle increments are evaluated by
    ``sins_sim._kernels.motion``.
    """

    def _rate(self, t):
        out = np.empty((t.size, 3))
        sines_rate(np.ascontiguousarray(t), self._amp, self._omega, self._phase, out)
        return out

    def _increment(self, ta, tb):
        out = np.empty((ta.size, 3))
        sines_increment(np.ascontiguousarray(ta), np.ascontiguousarray(tb), self._amp, self._omega, self._phase, out)
        return out

    def grid_angle_rate(self, i0: int, n: int, h: float):
        # axis-major (Fortran order): the kernel fills each axis's column contiguously, and the engine adds
        # the Earth and vehicle terms in place and hands each column to its channel without a copy
        angle = np.empty((n, 3), order="F")
        rate = np.empty((n, 3), order="F")
        sines_grid(int(i0), int(n), float(h), self._amp, self._omega, self._phase, angle, rate)
        return angle, rate

    def _fixed_axis(self):
        live = [i for i in range(3) if np.any(self._amp[i] != 0.0)]
        if not live:
            return _STATIC
        if len(live) == 1:
            return np.eye(3)[live[0]]
        return None


@dataclass(frozen=True)
class AxisSines(_SineBank):
    """Per-axis sinusoidal gyro angles ``A_i sin(2 pi f_i t + p_i)``.

    ``omega_b,i(t) = A_i 2 pi f_i cos(2 pi f_i t + p_i)`` and, integrating from
    0, ``phi_i(t) = A_i (sin(2 pi f_i t + p_i) - sin p_i)``: the gyro angle is
    the requested sine less its value at ``t = 0`` (so ``phi(0) = 0``, the
    package's definition of the SINS angle); rates are unaffected.

    Parameters
    ----------
    amplitude_rad : float or array_like (3,)
        Angle amplitude ``A_i`` (rad), >= 0.
    frequency_hz : float or array_like (3,)
        Frequency ``f_i`` (Hz), >= 0 (0 gives no motion on that axis).
    phase_rad : float or array_like (3,)
        Phase ``p_i`` (rad).

    Notes
    -----
    Two axes with equal amplitudes and frequencies and phases 90 deg apart
    are the body rates of pure coning; :class:`Coning` gives them together
    with the closed-form attitude. Any other combination on two or more axes
    has its attitude integrated numerically.
    """

    amplitude_rad: tuple = (0.0, 0.0, 0.0)
    frequency_hz: tuple = (1.0, 1.0, 1.0)
    phase_rad: tuple = (0.0, 0.0, 0.0)

    def __post_init__(self):
        amp = _vec3("AxisSines", "amplitude_rad", self.amplitude_rad)
        freq = _vec3("AxisSines", "frequency_hz", self.frequency_hz)
        phase = _vec3("AxisSines", "phase_rad", self.phase_rad)
        for i in range(3):
            v.non_negative("AxisSines", f"amplitude_rad[{i}]", amp[i])
            v.non_negative("AxisSines", f"frequency_hz[{i}]", freq[i])
        _set(self, "amplitude_rad", amp)
        _set(self, "frequency_hz", freq)
        _set(self, "phase_rad", phase)
        w = 2.0 * math.pi * np.array(freq)
        a = np.array(amp) * w
        _set(self, "_amp", a.reshape(3, 1).copy())
        _set(self, "_omega", w.reshape(3, 1).copy())
        _set(self, "_phase", np.array(phase).reshape(3, 1).copy())


@dataclass(frozen=True)
class Coning(_SineBank):
    """Pure (circular) coning with the exact closed-form attitude.

    The two axes orthogonal to ``cone_axis`` (cyclic order: for ``z`` they are
    ``x, y``; for ``x``: ``y, z``; for ``y``: ``z, x``) carry the gyro angles

        phi_1 = A (sin(psi) - sin(psi_0)),  phi_2 = A (sin(psi + p) - sin(psi_0 + p)),

    ``psi = 2 pi f t + psi_0``, ``p = phase_rad = +-pi/2``; the cone axis's
    rate is zero. These are exactly the rates of
    ``AxisSines(amplitude_rad=(A, A, 0), frequency_hz=f, phase_rad=(psi_0, psi_0 + p, 0))``
    for ``cone_axis = 'z'``.

    Parameters
    ----------
    amplitude_rad : float
        Gyro angle amplitude ``A`` on each of the two coned axes (rad), >= 0.
    frequency_hz : float
        Coning frequency ``f`` seen by the gyros (Hz), > 0.
    phase_rad : float
        Phase of the second coned axis relative to the first: ``+pi/2`` or
        ``-pi/2`` (a circular cone; other phases give elliptic coning, which
        has no closed form: use :class:`AxisSines`).
    start_phase_rad : float
        ``psi_0``, the phase of the first coned axis at ``t = 0`` (rad).
    cone_axis : {'x', 'y', 'z', 0, 1, 2}
        The body axis about which the cone is described.

    Notes
    -----
    Closed form (derived here from the classic coning attitude [2]_, [3]_,
    and checked in the tests: it satisfies ``q' = 0.5 q (x) omega`` to the
    accuracy of a 5-point finite difference, ~1e-10 relative, and the
    numerical integrator reproduces it to 1e-16 .. 6e-13 rad over 1 s).
    In cone coordinates (1, 2, 3 = the two coned axes and the cone axis),
    with ``sigma = sign(p)`` and ``eps = -sigma``,

        a      = arctan(A)                       (cone half-angle)
        Omega  = eps 2 pi f sqrt(1 + A^2)        (precession rate of the cone)
        beta   = Omega (1 - cos a) = eps 2 pi f (sqrt(1 + A^2) - 1)
        chi    = eps (psi_0 - pi/2)
        Q(t)   = [cos(a/2), sin(a/2) cos(Omega t + chi), sin(a/2) sin(Omega t + chi), 0]
        R(t)   = [cos(beta t / 2), 0, 0, sin(beta t / 2)]
        q(t)   = q0 (x) Q(0)* (x) Q(t) (x) R(t).

    ``Q(t)`` alone (a tilt by ``a`` about an axis that precesses at
    ``Omega`` in the 1-2 plane) is the classic coning attitude of [2]_; its
    body rate is ``Omega (-sin a sin(Omega t + chi), sin a cos(Omega t + chi),
    -(1 - cos a))``. The right factor ``R(t)`` cancels the constant rate
    ``-Omega (1 - cos a)`` about the cone axis, so that the gyro on that axis
    reads nothing, and rotates the quadrature rates down to the frequency
    ``Omega cos a = eps 2 pi f``: the body rate becomes
    ``A 2 pi f (cos psi, -sigma sin psi, 0)`` (rate amplitude
    ``Omega sin a = 2 pi f A``), exactly the rates above.

    Mapping from the user's "amplitude per axis and phase" to the cone: the
    body's cone axis sweeps a cone of half-angle ``a = arctan(A)`` (``a = A``
    to 1e-8 relative for 1 arcmin) about its initial direction, once per
    ``2 pi / |Omega|``; with ``p = -pi/2`` (second axis lags) the cone turns
    positively about the cone axis, with ``p = +pi/2`` negatively. After
    every full precession ``Q(t) = Q(0)``, so the attitude is a pure rotation
    by ``beta t`` about the cone axis: the net rotation rate the gyros never
    see, :meth:`coning_drift_rate` (``~ -sigma pi f A^2`` for small ``A``, the
    classic ``1/2 Omega A^2`` coning drift [3]_).
    """

    amplitude_rad: float = 0.0
    frequency_hz: float = 1.0
    phase_rad: float = math.pi / 2.0
    start_phase_rad: float = 0.0
    cone_axis: object = "z"

    def __post_init__(self):
        A = v.non_negative("Coning", "amplitude_rad", self.amplitude_rad)
        f = v.positive("Coning", "frequency_hz", self.frequency_hz)
        p = v.finite("Coning", "phase_rad", self.phase_rad)
        psi0 = v.finite("Coning", "start_phase_rad", self.start_phase_rad)
        axis = _axis_index("Coning", "cone_axis", self.cone_axis)
        wrapped = math.remainder(p, 2.0 * math.pi)
        if abs(abs(wrapped) - math.pi / 2.0) > 1e-9:
            raise ValueError(
                f"Coning.phase_rad: must be +pi/2 or -pi/2 (circular cone), got {p!r}; "
                "use AxisSines for elliptic coning"
            )
        sigma = 1.0 if wrapped > 0.0 else -1.0
        for name, val in (("amplitude_rad", A), ("frequency_hz", f), ("phase_rad", p), ("start_phase_rad", psi0)):
            _set(self, name, val)
        _set(self, "cone_axis", "xyz"[axis])
        perm = ((axis + 1) % 3, (axis + 2) % 3, axis)
        w = 2.0 * math.pi * f
        amp = np.zeros((3, 1))
        omega = np.zeros((3, 1))
        phase = np.zeros((3, 1))
        amp[perm[0], 0] = amp[perm[1], 0] = A * w
        omega[perm[0], 0] = omega[perm[1], 0] = w
        phase[perm[0], 0] = psi0
        phase[perm[1], 0] = psi0 + sigma * math.pi / 2.0
        _set(self, "_amp", amp)
        _set(self, "_omega", omega)
        _set(self, "_phase", phase)
        _set(self, "_perm", perm)
        eps = -sigma
        root = math.sqrt(1.0 + A * A)
        _set(self, "_sigma", sigma)
        _set(self, "_half_angle", math.atan(A))
        _set(self, "_precession", eps * w * root)
        _set(self, "_beta", eps * w * A * A / (root + 1.0))  # = eps w (root - 1) without cancellation
        _set(self, "_chi", eps * (psi0 - math.pi / 2.0))

    @property
    def half_angle_rad(self) -> float:
        """Cone half-angle ``a = arctan(amplitude_rad)`` (rad)."""
        return self._half_angle

    @property
    def precession_rate_rad_s(self) -> float:
        """Signed precession rate ``Omega`` of the cone about the cone axis (rad/s)."""
        return self._precession

    def coning_drift_rate(self) -> float:
        """Net rotation rate about the cone axis (rad/s), signed, exact.

        Returns
        -------
        float
            ``beta = Omega (1 - cos a) = -sign(phase) 2 pi f (sqrt(1 + A^2) - 1)``:
            the attitude turns about the cone axis at this mean rate although
            the cone-axis gyro reads zero.
        """
        return self._beta

    def _fixed_axis(self):
        return _STATIC if self.amplitude_rad == 0.0 else None

    def _cone_quat(self, t):
        """``Q(t) (x) R(t)`` in body axes, (N, 4)."""
        a2 = 0.5 * self._half_angle
        u = self._precession * t + self._chi
        s = math.sin(a2)
        qq = np.zeros((t.size, 4))
        qq[:, 0] = math.cos(a2)
        qq[:, 1] = s * np.cos(u)
        qq[:, 2] = s * np.sin(u)
        b = 0.5 * self._beta * t
        rr = np.zeros((t.size, 4))
        rr[:, 0] = np.cos(b)
        rr[:, 3] = np.sin(b)
        local = _qmul(qq, rr)
        body = np.empty_like(local)
        body[:, 0] = local[:, 0]
        for k in range(3):
            body[:, 1 + self._perm[k]] = local[:, 1 + k]
        return body

    def _transition(self, ta, tb):
        if self.amplitude_rad == 0.0:
            return _qexp(np.zeros((ta.size, 3)))
        return _qmul(_qconj(self._cone_quat(ta)), self._cone_quat(tb))


@dataclass(frozen=True)
class RandomVibration(_SineBank):
    """Band-limited angular random vibration realised as a sum of sinusoids.

    The rate on axis ``i`` is ``w_i sum_k sqrt(2 P_k) cos(2 pi f_k t + theta_ik)``
    with tone frequencies ``f_k`` at the centres of ``K`` equal cells of width
    ``df`` covering ``[f_lo_hz, f_hi_hz]``, ``P_k`` the exact integral of the
    log-log interpolated rate PSD over cell ``k``, and independent phases
    ``theta_ik`` uniform on ``[0, 2 pi)`` from ``np.random.default_rng(seed)``
    (the spectral representation of Shinozuka and Jan [5]_). The angle is the
    exact integral of each cosine, so rate and gyro angle are closed forms at
    any ``t``.

    Parameters
    ----------
    psd_table : sequence of (f_hz, psd) pairs
        One-sided PSD of the angular RATE, ``(rad/s)^2 / Hz``, at strictly
        increasing frequencies > 0 (at least two rows); values must be > 0
        (use a tiny value rather than 0). Interpolated linearly in
        log(f)-log(psd).
    f_lo_hz, f_hi_hz : float, optional
        Band (Hz); default the first and last table frequency; must lie inside
        the table.
    axis_weights : float or array_like (3,)
        Amplitude weight per body axis (the PSD on axis ``i`` is
        ``w_i^2 psd``), >= 0.
    seed : int
        Seed of the phases (>= 0). Same seed, same motion.
    df_hz : float
        Tone spacing (Hz), rounded so that a whole number ``K`` of cells fills
        the band. Take ``df_hz <= 1 / record length``: the realisation repeats
        with period ``1/df`` (``2/df`` unless ``f_lo/df`` is a whole number).

    Notes
    -----
    Over a whole period ``1/df`` (``f_lo/df`` whole) the tones are orthogonal,
    so the RMS rate on axis ``i`` is exactly ``w_i sqrt(integral PSD df)``
    (:attr:`rms_rate_rad_s`); over shorter windows it fluctuates by the
    window's statistical scatter. Evaluation costs ``3 K`` cosines per time:
    keep ``K = (f_hi - f_lo)/df`` to what the record needs.
    """

    psd_table: tuple = ()
    f_lo_hz: float | None = None
    f_hi_hz: float | None = None
    axis_weights: tuple = (1.0, 1.0, 1.0)
    seed: int = 0
    df_hz: float = 1.0
    _amp: np.ndarray = field(init=False, repr=False, compare=False, default=None)
    _omega: np.ndarray = field(init=False, repr=False, compare=False, default=None)
    _phase: np.ndarray = field(init=False, repr=False, compare=False, default=None)

    def __post_init__(self):
        owner = "RandomVibration"
        table, f_lo, f_hi = _psd_table(owner, self.psd_table, self.f_lo_hz, self.f_hi_hz)
        weights = _vec3(owner, "axis_weights", self.axis_weights)
        for i in range(3):
            v.non_negative(owner, f"axis_weights[{i}]", weights[i])
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) or self.seed < 0:
            raise ValueError(f"{owner}.seed: must be an integer >= 0, got {self.seed!r}")
        df = v.positive(owner, "df_hz", self.df_hz)
        n_tones = max(1, int(round((f_hi - f_lo) / df)))
        if n_tones > _MAX_TONES:
            raise ValueError(f"{owner}.df_hz: gives {n_tones} tones (> {_MAX_TONES}); increase df_hz")
        df_eff = (f_hi - f_lo) / n_tones
        _set(self, "psd_table", tuple((float(a), float(b)) for a, b in table))
        _set(self, "f_lo_hz", float(f_lo))
        _set(self, "f_hi_hz", float(f_hi))
        _set(self, "axis_weights", weights)
        _set(self, "seed", int(self.seed))
        _set(self, "df_hz", float(df))
        _set(self, "_table", table.copy())
        edges = f_lo + df_eff * np.arange(n_tones + 1)
        edges[-1] = f_hi
        centres = 0.5 * (edges[:-1] + edges[1:])
        power = self._cell_power(edges)
        rng = np.random.default_rng(self.seed)
        phases = rng.uniform(0.0, 2.0 * math.pi, size=(3, n_tones))
        amp = np.sqrt(2.0 * power)[None, :] * np.array(weights)[:, None]
        w0 = 2.0 * math.pi * (f_lo + 0.5 * df_eff)
        dw = 2.0 * math.pi * df_eff
        _set(self, "_amp", np.ascontiguousarray(amp))
        _set(self, "_omega", np.ascontiguousarray(np.broadcast_to(w0 + dw * np.arange(n_tones), (3, n_tones))))
        _set(self, "_phase", phases)
        _set(self, "_w0", w0)
        _set(self, "_dw", dw)
        _set(self, "_cre", np.ascontiguousarray(amp * np.cos(phases)))
        _set(self, "_cim", np.ascontiguousarray(amp * np.sin(phases)))
        _set(self, "_freqs", centres)
        _set(self, "_power", power)

    def _rate(self, t):
        out = np.empty((t.size, 3))
        comb_rate(np.ascontiguousarray(t), self._w0, self._dw, self._cre, self._cim, out)
        return out

    def _increment(self, ta, tb):
        out = np.empty((ta.size, 3))
        comb_increment(np.ascontiguousarray(ta), np.ascontiguousarray(tb), self._w0, self._dw,
                       self._cre, self._cim, out)
        return out

    def _cell_power(self, edges):
        """Exact integral of the log-log PSD over each cell ``[edges[k], edges[k+1]]``."""
        fr, ps = self._table[:, 0], self._table[:, 1]
        inner = fr[(fr > edges[0]) & (fr < edges[-1])]
        pts = np.union1d(edges, inner)
        x0, x1 = pts[:-1], pts[1:]
        seg = np.clip(np.searchsorted(fr, x0, side="right") - 1, 0, fr.size - 2)
        n_exp = np.log(ps[seg + 1] / ps[seg]) / np.log(fr[seg + 1] / fr[seg])
        vals = _loglog_segment_integral(x0, x1, fr[seg], ps[seg], n_exp)
        cell = np.clip(np.searchsorted(edges, x0, side="right") - 1, 0, edges.size - 2)
        return np.bincount(cell, weights=vals, minlength=edges.size - 1)

    def psd(self, f_hz):
        """The log-log interpolated table at ``f_hz`` ((rad/s)^2/Hz; 0 outside the band).

        Parameters
        ----------
        f_hz : array_like
            Frequencies (Hz).

        Returns
        -------
        ndarray
        """
        f = np.asarray(f_hz, dtype=np.float64)
        fr, ps = self._table[:, 0], self._table[:, 1]
        inside = (f >= self.f_lo_hz) & (f <= self.f_hi_hz)
        fc = np.clip(f, fr[0], fr[-1])
        out = np.exp(np.interp(np.log(fc), np.log(fr), np.log(ps)))
        return np.where(inside, out, 0.0)

    @property
    def frequencies_hz(self):
        """Tone frequencies (Hz), read-only."""
        return self._freqs

    @property
    def rms_rate_rad_s(self):
        """RMS rate per axis (rad/s): ``w_i sqrt(integral_{f_lo}^{f_hi} PSD df)``."""
        return np.sqrt(np.sum(self._power)) * np.array(self.axis_weights)
