"""Online estimation of the suspension's parameters from what a unit has: readout and drive.

The paper (section "Piezoceramic drive", after eq. 17, and the experiment of Fig. 6) says its DSP
estimated k1..k3 and Q during operation from the amplitude modulation of the dither, k5 from the
amplitude stabilisation (eq. 17), held k4 constant, and took omega0 from the dither PLL "taking into
account a relative mismatch at known coefficients k1, k2 and a_m"; the algorithm "depends on the
specific amplitude modulation algorithm" and is left out. This module is one such algorithm.

Model: the slow flow of eq. 2 (harmonic balance, as eq. 15). With the deflection
``delta = Re(A exp(i w t))`` at the drive frequency ``w`` and the drive ``V = Re(Vc exp(i w t))``,
``Nonl`` moves the resonance to the backbone ``Omega_F(a)`` (eq. 6-9 by harmonic balance) and eq. 10
is exactly in quadrature with the fundamental (``Diss = (1/Q) delta' / w``, ``1/Q = k3 (1 + k4 a)``,
eq. 16); dropping ``A''``::

    dA/dt = p(a) A + b Vc,   p(a) = -w0^2 / (2 w Q(a)) + i (Omega_F(a)^2 - w^2) / (2 w),
                             b = i w0^2 k5 / (2 w)

Keeping ``A''`` the envelope's pole ``p`` of ``A'' + 2 i w A' + c A = -w0^2 k5 Vc`` with
``c = Omega_F^2 - w^2 + i w0^2 / Q`` gives exactly ``c = -(p^2 + 2 i w p)`` and ``k5 = -b (p + 2 i w) / w0^2``;
the estimator uses these (the first-order forms above differ by ``|p| / w``, about 0.3 %).
At a steady amplitude at resonance this is eq. 17, ``k5 = -a_m / (Q V_m)``; with the amplitude
modulated, ``Re p`` is eq. 15's decay rate ``w / (2 Q)`` and ``Im p`` is the PLL's frequency error
``Omega_F(a) - w`` (to first order): the locked frequency at each amplitude, i.e. the backbone.

Algorithm (per filter sample: :func:`sins_sim._kernels.online.envelope_normal_equations`):
complex envelopes ``A`` of the readout and ``Vc`` of the drive by demodulation at the drive
frequency and a Hann low-pass of ``window_cycles`` periods; ``p(a)`` as a quadratic in
``u = a / a_ref - 1``, ``p = p0 + c1 u + c2 u^2``; the integral form of the equation over
intervals of ``interval_cycles`` periods gives linear equations in ``(p0, c1, c2, b)``, accumulated
with exponential forgetting of time constant ``forgetting_s`` (a weight ``exp(-age / forgetting_s)``
per interval: the estimate of a parameter drifting at a steady rate lags by ``forgetting_s``).
Timing offsets between readout and drive (sampling instants, pipeline delays) rotate ``b`` only,
so ``p`` and ``|b|`` are immune to them.

At each update (:meth:`OnlineEstimator.solve`): the least-squares ``(p0, c1, c2, b)`` and their
covariance (residual variance times the inverse normal matrix, for exponential weights
``s^2 R^{-1} / (1 + lam)``); the locked frequency ``F(a)`` on three amplitudes around the mean
``a_ref (1 + u_mean +- 2 sigma_u)``; ``f0, k1, k2`` by Gauss-Newton on ``ln F(a) = ln f0 +
(1/2) ln r(a; k1, k2)`` (``r`` the harmonic-balance stiffness ratio, :func:`backbone_ratio`) with a
log-normal prior on k1, k2 around the datasheet (``k_prior``: a small modulation leaves the
curvature of the backbone, hence k2, to the prior; the stated standard deviations say how much);
``Q`` at ``a_ref`` from ``Re p``; ``k3 = 1 / (Q (1 + k4 a_ref))`` with k4 held at the datasheet
(the paper's choice); ``k5 = sign(k5_datasheet) 2 w |b| / w0^2``.

Guards: an interval with the amplitude outside ``a_ref (1 +- band)`` (a dead or frozen readout, a
start-up), the drive at saturation or a non-finite input is left out; an estimate outside its
physical range (:data:`RANGES`), or before the modulation has excited the amplitude
(``sigma_u < min_spread``), is not applied: the last good value stays and an event is recorded.
No estimate is ever NaN: before the first good one the datasheet values stand.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from sins_sim._kernels import online as kon

__all__ = ["OnlineSettings", "OnlineEstimate", "OnlineEstimator", "backbone_ratio", "RANGES", "PARAMS"]

#: Parameters the estimator reports, in this order.
PARAMS = ("f0_hz", "k1", "k2", "k3", "k4", "k5", "q")

#: Physical ranges (the ranges the IMU file accepts for k1..k5, sins_sim.config.filter_params; Q as
#: the drive accepts it); f0 within +-20 % of the datasheet (a 30 K ramp at -145 ppm/K, the steepest
#: steel of sins_sim.simulation.temperature, moves f0 by 0.4 %).
RANGES = {"f0_rel": (0.8, 1.2), "k1": (1e-9, 0.1), "k2": (1e-6, 0.1), "k3": (1e-6, 0.2), "q": (10.0, 1e5),
          "k5_abs": (1e-12, 1e-2)}

_GL_X, _GL_W = np.polynomial.legendre.leggauss(48)
_TH = 0.25 * math.pi * (_GL_X + 1.0)  # Gauss-Legendre nodes on [0, pi/2]
_COS = np.cos(_TH)
_WQ = 0.25 * math.pi * _GL_W


def _re_c(p, w):
    """``Omega_F^2 - w^2`` from the pole ``p`` of the envelope (module docstring, keeping ``A''``)."""
    return 2.0 * w * np.imag(p) + np.imag(p) ** 2 - np.real(p) ** 2


def _im_c(p, w):
    """``w0^2 / Q`` from the pole ``p`` of the envelope (module docstring, keeping ``A''``)."""
    return -2.0 * np.real(p) * (w + np.imag(p))


def backbone_ratio(a, k1: float, k2: float):
    """``(F(a) / f0)^2`` by harmonic balance of eq. 9: ``1 + (4 / (pi a)) int_0^{pi/2} Nonl(a cos t) cos t dt``.

    Nonl is odd, so the integral over ``[0, pi]`` of the fundamental's coefficient is twice the one over
    ``[0, pi/2]``; its integrand is analytic there (``Nonl(d) ~ -d^2 / (8 k2^2)`` near 0), so 48-point
    Gauss-Legendre is exact to rounding (``tests/test_online_estimator.py`` compares with
    ``SuspensionParams.resonance_hz``, an adaptive quadrature).
    """
    a = np.atleast_1d(np.asarray(a, dtype=np.float64))
    d = a[:, None] * _COS[None, :]
    y = d / k2
    # sqrt(1 + y) - 1 - y/2 without cancellation: -y^2 / (2 (sqrt(1+y) + 1)^2) ... exactly:
    s = np.sqrt(1.0 + y)
    nonl = k1 * (-(y * y) / (2.0 * (s + 1.0) ** 2))
    integral = (nonl * _COS[None, :]) @ _WQ
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.where(a > 0.0, 1.0 + 4.0 / math.pi * integral / np.where(a > 0.0, a, 1.0), 1.0)
    return out


@dataclass(frozen=True)
class OnlineSettings:
    """How the online estimator works (all times in s).

    Parameters
    ----------
    forgetting_s : float
        Time constant of the exponential forgetting (s): data of age ``t`` weigh ``exp(-t / forgetting_s)``.
    interval_cycles, window_cycles : int
        Integration interval and Hann envelope window, in dither periods. With the loop's random modulation (a new
        target every 10 cycles) an interval of 4 cycles biased the backbone's curvature (k1, k2 30 % low on the
        paper's unit, 10 % depth), 2 cycles by 10 %; a 1-cycle window leaves the demodulation's image at twice
        the drive frequency in the envelope, which biased the locked frequency of a linear unit by 80 ppm
        (docs/user-guide/online-estimation.md).
    band : float
        Intervals whose amplitude leaves ``a_ref (1 +- band)`` are left out.
    k_prior : float
        Standard deviation of the log-normal prior of k1 and k2 around the datasheet (0.5: a factor 1.65).
    min_spread : float
        RMS amplitude modulation ``sigma_u`` (relative) below which nothing is applied (no excitation).
    v_sat_factor : float
        The drive counts as saturated at ``v_sat_factor`` times the drive's limit ``v_max`` (a margin
        for the envelope's ripple).
    """

    forgetting_s: float = 5.0
    interval_cycles: int = 2
    window_cycles: int = 2
    band: float = 0.5
    k_prior: float = 0.5
    min_spread: float = 0.005
    v_sat_factor: float = 0.995

    def __post_init__(self):
        for name in ("forgetting_s", "band", "k_prior", "min_spread", "v_sat_factor"):
            val = getattr(self, name)
            if not (isinstance(val, (int, float)) and math.isfinite(val) and val > 0.0):
                raise ValueError(f"online.{name}: must be a positive number, got {val!r}")
        for name in ("interval_cycles", "window_cycles"):
            val = getattr(self, name)
            if not (isinstance(val, int) and val >= 1):
                raise ValueError(f"online.{name}: must be an integer >= 1, got {val!r}")
        if self.window_cycles > self.interval_cycles:
            raise ValueError(f"online.window_cycles: must be <= interval_cycles = {self.interval_cycles} (a fault "
                             f"reaches back one window; the guard drops one interval), got {self.window_cycles!r}")
        if self.band >= 1.0:
            raise ValueError(f"online.band: must be < 1, got {self.band!r}")


@dataclass
class OnlineEstimate:
    """The estimator's current values (SI; ``q`` at ``a_ref``) and their standard deviations.

    ``applied``: per parameter group (``backbone``: f0, k1, k2; ``damping``: Q, k3; ``k5``) whether the
    last update passed the guards (otherwise the values are the last good ones, or the datasheet).
    ``locked_hz``: the PLL's locked frequency at ``a_ref`` (drive frequency plus the phase detector).
    """

    t_s: float
    values: dict
    std: dict
    applied: dict
    locked_hz: float
    spread: float
    good_intervals: int


class OnlineEstimator:
    """Streams one channel's readout and drive, and estimates f0, k1..k5 and Q on request.

    Parameters
    ----------
    settings : OnlineSettings
    fs_hz : float
        Filter rate (Hz).
    drive_hz : float
        The drive's frequency at start (Hz; :meth:`process` takes the current one).
    a_ref_rad, v_ref : float
        The amplitude loop's target amplitude (rad) and the datasheet drive amplitude (V), the units of
        the envelopes.
    v_max : float
        The drive's limit (V).
    datasheet : dict
        ``f0_hz, k1, k2, k3, k4, k5``: the prior and the values before the first good estimate.
    """

    def __init__(self, settings: OnlineSettings, fs_hz: float, drive_hz: float, a_ref_rad: float, v_ref: float,
                 v_max: float, datasheet: dict):
        self.settings = settings
        self.fs = float(fs_hz)
        self.a_ref = float(a_ref_rad)
        self.v_ref = float(v_ref)
        self.datasheet = {k: float(datasheet[k]) for k in ("f0_hz", "k1", "k2", "k3", "k4", "k5")}
        if not (self.a_ref > 0.0 and self.v_ref > 0.0 and self.fs > 2.0 * drive_hz > 0.0):
            raise ValueError("online: needs a_ref_rad > 0, v_ref > 0 and 0 < drive_hz < fs_hz / 2")
        self.m_int = max(4, int(round(settings.interval_cycles * self.fs / drive_hz)))
        self.w = min(self.m_int, max(4, int(round(settings.window_cycles * self.fs / drive_hz))))
        self.taps = np.empty(self.w)
        kon.hann_taps(self.w, self.taps)
        interval_s = self.m_int / self.fs
        self.lam = math.exp(-interval_s / settings.forgetting_s)
        self.par = np.zeros(kon.N_PAR)
        self.par[kon.P_AREF] = self.a_ref
        self.par[kon.P_VREF] = self.v_ref
        self.par[kon.P_DT] = 1.0 / self.fs
        self.par[kon.P_BAND] = settings.band
        self.par[kon.P_VSAT] = settings.v_sat_factor * float(v_max)
        self.par[kon.P_LAM] = self.lam
        self.drive_hz = float(drive_hz)
        self.reset()

    def reset(self):
        """Forget everything: the datasheet values stand again."""
        self.fstate = np.zeros(kon.N_FSTATE)
        self.cstate = np.zeros(kon.N_CSTATE, dtype=np.complex128)
        self.hx = np.zeros(self.w, dtype=np.complex128)
        self.hv = np.zeros(self.w, dtype=np.complex128)
        self.big_r = np.zeros((4, 4), dtype=np.complex128)
        self.small_r = np.zeros(4, dtype=np.complex128)
        self.mom = np.zeros(6)
        ds = self.datasheet
        q0 = 1.0 / (ds["k3"] * (1.0 + ds["k4"] * self.a_ref))
        self.current = dict(ds, q=q0)
        self.std = {k: math.nan for k in PARAMS}
        self.applied = {"backbone": False, "damping": False, "k5": False}
        self.events = []
        self._counts = (0, 0, 0)
        self._q_log = np.array([math.log(ds["f0_hz"]), math.log(ds["k1"]), math.log(ds["k2"])])
        self.locked_hz = math.nan
        self.spread = 0.0
        self.n = 0

    # -- streaming ------------------------------------------------------------------------------
    def process(self, x: np.ndarray, v: np.ndarray, drive_hz: float | None = None) -> None:
        """Feed readout angles ``x`` (rad) and drive ``v`` (V) at the filter rate, at ``drive_hz`` (Hz)."""
        if drive_hz is not None:
            self.drive_hz = float(drive_hz)
        x = np.ascontiguousarray(x, dtype=np.float64)
        v = np.ascontiguousarray(v, dtype=np.float64)
        if x.shape != v.shape or x.ndim != 1:
            raise ValueError("online.process: x and v must be 1-D arrays of one length")
        kon.envelope_normal_equations(x, v, self.drive_hz / self.fs, self.m_int, self.par, self.taps, self.fstate,
                                      self.cstate, self.hx, self.hv, self.big_r, self.small_r, self.mom)
        self.n += x.shape[0]

    @property
    def t_s(self) -> float:
        return self.n / self.fs

    def _event(self, kind: str, message: str):
        self.events.append((self.t_s, kind, message))

    def _count_events(self):
        fs = self.fstate
        counts = (int(fs[kon.F_BAD_BAND]), int(fs[kon.F_BAD_SAT]), int(fs[kon.F_BAD_NAN]))
        for (old, new, kind, what) in zip(self._counts, counts, ("band", "saturation", "nonfinite"),
                                          ("amplitude outside a_ref (1 +- band) (dead or frozen readout?)",
                                           "drive at saturation", "non-finite readout or drive")):
            if new > old:
                self._event(kind, f"{new - old} interval(s) left out: {what}")
        self._counts = counts

    # -- the update ---------------------------------------------------------------------------
    def solve(self) -> OnlineEstimate:
        """Solve the current normal equations; apply what passes the guards; return the estimate."""
        self._count_events()
        st = self.settings
        mom = self.mom
        if mom[0] <= 0.0:
            return self._estimate()
        u_mean = mom[1] / mom[0]
        spread = math.sqrt(max(mom[2] / mom[0] - u_mean * u_mean, 0.0))
        self.spread = spread
        if spread < st.min_spread:
            self._event("excitation", f"amplitude modulation {spread:.3g} < min_spread {st.min_spread:.3g}: "
                                      f"nothing applied")
            return self._estimate()
        big_r = self.big_r
        scale = np.sqrt(np.real(np.diag(big_r)))
        if not np.all(scale > 0.0):
            return self._estimate()
        rn = big_r / np.outer(scale, scale)
        try:
            cond = np.linalg.cond(rn)
            if not math.isfinite(cond) or cond > 1e12:
                raise np.linalg.LinAlgError
            inv = np.linalg.inv(rn) / np.outer(scale, scale)
        except np.linalg.LinAlgError:
            self._event("excitation", "normal equations singular: nothing applied")
            return self._estimate()
        theta = inv @ self.small_r
        n_w = mom[0] * self.fs / self.m_int  # sum of interval weights
        n_eff = n_w * n_w / mom[5] if mom[5] > 0 else 0.0
        rss = max(float(mom[4] - np.real(np.vdot(theta, self.small_r))), 0.0)
        s2 = rss / max(n_w - 4.0, 1.0)
        cov = s2 * inv / (1.0 + self.lam)
        if not np.all(np.isfinite(theta)) or n_eff < 8.0:
            return self._estimate()
        w = 2.0 * math.pi * self.drive_hz
        p0, c1, c2, b = theta
        # the backbone on three amplitudes around the mean: Omega_F^2 = w^2 + 2 w Im p(u)
        us = u_mean + np.array([-2.0, 0.0, 2.0]) * spread
        g = np.stack([np.ones(3), us, us * us], axis=1)
        pj = g @ np.array([p0, c1, c2])
        om2 = w * w + _re_c(pj, w)
        cov_p = 0.5 * np.real(g @ cov[:3, :3] @ g.T)
        ok_backbone = bool(np.all(om2 > 0.0))
        # Gauss-Newton from the datasheet (so that one set of normal equations gives one answer)
        ds = self.datasheet
        q_log = np.array([math.log(ds["f0_hz"]), math.log(ds["k1"]), math.log(ds["k2"])])
        p_cov = None
        if ok_backbone:
            d = 0.5 * np.log(om2) - math.log(2.0 * math.pi)
            dd = (w + pj.imag) / om2  # d ln F / d Im p
            cov_d = cov_p * np.outer(dd, dd) + np.eye(3) * 1e-24
            try:
                wmat = np.linalg.inv(cov_d)
            except np.linalg.LinAlgError:
                wmat = None
            ok_backbone = wmat is not None
        if ok_backbone:
            ds = self.datasheet
            prior_mu = np.array([math.log(ds["k1"]), math.log(ds["k2"])])
            prior_w = 1.0 / st.k_prior ** 2
            a_j = self.a_ref * (1.0 + us)
            for _ in range(40):
                m, jac = self._model(q_log, a_j)
                res = d - m
                h = jac.T @ wmat @ jac
                grad = jac.T @ wmat @ res
                h[1:, 1:] += prior_w * np.eye(2)
                grad[1:] += prior_w * (prior_mu - q_log[1:])
                try:
                    step = np.linalg.solve(h, grad)
                except np.linalg.LinAlgError:
                    ok_backbone = False
                    break
                step = np.clip(step, -0.5, 0.5)
                q_log = q_log + step
                if np.max(np.abs(step)) < 1e-10:
                    break
            if ok_backbone:
                try:
                    p_cov = np.linalg.inv(h)
                except np.linalg.LinAlgError:
                    ok_backbone = False
        new = {}
        if ok_backbone and np.all(np.isfinite(q_log)):
            f0, k1, k2 = (float(x) for x in np.exp(q_log))
            lo, hi = RANGES["f0_rel"]
            bad = []
            if not lo * self.datasheet["f0_hz"] <= f0 <= hi * self.datasheet["f0_hz"]:
                bad.append(f"f0_hz = {f0:.6g}")
            if not RANGES["k1"][0] <= k1 <= RANGES["k1"][1]:
                bad.append(f"k1 = {k1:.3g}")
            if not RANGES["k2"][0] <= k2 <= RANGES["k2"][1]:
                bad.append(f"k2 = {k2:.3g}")
            if bad:
                self._event("range", "backbone not applied: " + ", ".join(bad) + " outside the physical range")
            else:
                new.update(f0_hz=f0, k1=k1, k2=k2)
                self._q_log = q_log
                sd = np.sqrt(np.maximum(np.diag(p_cov), 0.0))
                self.std.update(f0_hz=f0 * sd[0], k1=k1 * sd[1], k2=k2 * sd[2])
        elif not ok_backbone:
            self._event("range", "backbone not applied: locked frequency not positive or fit singular")
        self.applied["backbone"] = "f0_hz" in new
        f0 = new.get("f0_hz", self.current["f0_hz"])
        w0sq = (2.0 * math.pi * f0) ** 2
        # Q at a_ref (u = 0) from the decay rate; k3 with k4 held (eq. 16)
        inv_q = _im_c(p0, w) / w0sq
        k4 = self.datasheet["k4"]
        q = 1.0 / inv_q if inv_q > 0.0 else math.inf
        if RANGES["q"][0] <= q <= RANGES["q"][1]:
            k3 = inv_q / (1.0 + k4 * self.a_ref)
            if RANGES["k3"][0] <= k3 <= RANGES["k3"][1]:
                new.update(q=q, k3=k3)
                sd_inv_q = 2.0 * w * math.sqrt(max(0.5 * cov[0, 0].real, 0.0)) / w0sq
                self.std.update(q=q * q * sd_inv_q, k3=sd_inv_q / (1.0 + k4 * self.a_ref))
        if "q" not in new:
            self._event("range", f"damping not applied: Q = {q:.4g} outside [{RANGES['q'][0]:g}, {RANGES['q'][1]:g}]")
        self.applied["damping"] = "q" in new
        k5 = math.copysign(abs(b) * abs(p0 + 2j * w) * (self.a_ref / self.v_ref) / w0sq, self.datasheet["k5"])
        if RANGES["k5_abs"][0] <= abs(k5) <= RANGES["k5_abs"][1]:
            new["k5"] = k5
            self.std["k5"] = 2.0 * w * math.sqrt(max(0.5 * cov[3, 3].real, 0.0)) * (self.a_ref / self.v_ref) / w0sq
        else:
            self._event("range", f"k5 not applied: |k5| = {abs(k5):.3g} outside the physical range")
        self.applied["k5"] = "k5" in new
        self.current.update(new)
        self.locked_hz = math.sqrt(max(w * w + _re_c(p0, w), 0.0)) / (2.0 * math.pi)
        return self._estimate()

    def _model(self, q_log, a_j):
        """``ln F(a_j)`` for ``(ln f0, ln k1, ln k2)`` and its Jacobian (central differences in k1, k2)."""
        k1, k2 = math.exp(q_log[1]), math.exp(q_log[2])
        m = q_log[0] + 0.5 * np.log(backbone_ratio(a_j, k1, k2))
        jac = np.empty((a_j.shape[0], 3))
        jac[:, 0] = 1.0
        h = 1e-5
        for i in (1, 2):
            qp = q_log.copy()
            qm = q_log.copy()
            qp[i] += h
            qm[i] -= h
            mp = 0.5 * np.log(backbone_ratio(a_j, math.exp(qp[1]), math.exp(qp[2])))
            mm = 0.5 * np.log(backbone_ratio(a_j, math.exp(qm[1]), math.exp(qm[2])))
            jac[:, i] = (mp - mm) / (2.0 * h)
        return m, jac

    def _estimate(self) -> OnlineEstimate:
        return OnlineEstimate(t_s=self.t_s, values=dict(self.current), std=dict(self.std), applied=dict(self.applied),
                              locked_hz=self.locked_hz, spread=self.spread,
                              good_intervals=int(self.fstate[kon.F_GOOD]))
