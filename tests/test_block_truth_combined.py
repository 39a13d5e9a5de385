"""The block's truth under angular and linear vibration together (issue 38, item 1).

A block on isolators whose chassis both turns and shakes: the block's c.g. sits at ``x`` from the chassis point
it rests on, in a frame that rotates at ``w``. Its accelerometers see (Groves 2013, sec. 2.3, motion with respect
to a rotating frame)

    ``f_b = R(theta)^T (f_c + x'' + 2 w x x' + w' x x + w x (w x x))``

and its velocity relative to the chassis point is ``x' + w x x``. The truth lacked the rotating-frame terms (and
took the tilt's mean over a sample half a plant step late), so the ideal increments drifted away from the truth's
velocity when both vibrations entered at the chassis. The checks:

- the kernel (``_kernels.block.block_truth``) against the integrals of the exact kinematics of a prescribed
  sinusoidal motion, within the trapezoid rule's error bound, and the same in chunks as whole;
- the engine: both vibrations as sines at the chassis of a block whose elastic centre is off its c.g.; the
  block's lines against the frequency-domain solution of its model, the closed-form velocity drift that the
  missing terms made, and the ideal navigation at the rigid unit's floor over 120 s;
- the issue's random case over 30 min (``slow``).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from sins_sim._kernels import block as kblock
from sins_sim.models.block import BlockParams
from sins_sim.models.motion.sines import AxisSines
from sins_sim.models.motion.vibration import LinearSines
from sins_sim.models.suspension import SuspensionParams
from sins_sim.simulation.channel import ChannelConfig
from sins_sim.simulation.sins import ImuConfig, NavSettings, simulate_sins

ARCSEC = math.pi / 648000

# --- the kernel against closed-form integrals ------------------------------------------------------------------

#: 16-point Gauss-Legendre on one filter sample: for these trigonometric products (frequencies up to 600 Hz over
#: 1/7200 s, ``w H <= 0.53``) its error is of order ``(w H / 2)^32 / 32!``, zero to rounding (A&S 25.4.30).
_GL_X, _GL_W = np.polynomial.legendre.leggauss(16)


class _Sine:
    """A vector ``c + A sin(w t + p)`` per axis and its first two derivatives (closed forms)."""

    def __init__(self, amp, f_hz, phase, const=(0.0, 0.0, 0.0)):
        self.a, self.w, self.p = np.asarray(amp, float), 2 * math.pi * f_hz, np.asarray(phase, float)
        self.c = np.asarray(const, float)

    def __call__(self, t, d=0):
        t = np.asarray(t, float)[..., None]
        arg = self.w * t + self.p
        val = [np.sin, np.cos, lambda x: -np.sin(x)][d](arg) * self.a * self.w ** d
        return val + (self.c if d == 0 else 0.0)

    def bounds(self):
        """Upper bounds of ``|v|, |v'|, |v''|`` (Euclidean norms)."""
        n = float(np.linalg.norm(self.a))
        return np.array([np.linalg.norm(self.c) + n, self.w * n, self.w ** 2 * n])


def _prod(f, g):
    """Bounds ``(|F|, |F'|, |F''|)`` of a cross product ``F = a x b`` from those of its factors (the product rule)."""
    return np.array([f[0] * g[0], f[1] * g[0] + f[0] * g[1], f[2] * g[0] + 2 * f[1] * g[1] + f[0] * g[2]])


def _integral(fun, t0, t1):
    """``int_t0^t1 fun(t) dt`` by :data:`_GL_X` (``fun`` vectorised over times, values (n, 3))."""
    t = 0.5 * (t1 - t0) * _GL_X + 0.5 * (t0 + t1)
    return 0.5 * (t1 - t0) * np.einsum("n,ni->i", _GL_W, fun(t))


def _rodrigues(th, v, kind):
    """``R(theta)^T v`` (``kind="rt"``) or ``J_r(theta) v`` (``"jr"``), exactly (Rodrigues' formula and the right
    Jacobian of the rotation vector, Bortz 1971; the coefficients' series to ``a^4``, exact to rounding for
    ``a = |theta|`` of 1e-3 rad)."""
    a2 = np.sum(th * th, axis=-1, keepdims=True)
    if kind == "rt":
        c1, c2 = 1 - a2 / 6 + a2 ** 2 / 120, 0.5 - a2 / 24 + a2 ** 2 / 720
    else:
        c1, c2 = 0.5 - a2 / 24 + a2 ** 2 / 720, 1 / 6 - a2 / 120 + a2 ** 2 / 5040
    tv = np.cross(th, v)
    return v - c1 * tv + c2 * np.cross(th, tv)


def test_block_truth_carries_the_chassis_rotation_into_the_block_translation():
    """``block_truth`` on a prescribed motion: the block rocks (``theta``, 180 Hz, 60-100 arcsec) and translates
    (``x``, 90 Hz, 40-80 micrometres, cm/s) on a chassis that turns (0.5-1 rad/s) and vibrates angularly
    (``w``, 230 Hz, 0.05-0.12 rad/s) and linearly (``a``, 300 Hz, 10-20 m/s^2), each axis with its own phase.
    Against the integrals over each filter sample of the exact kinematics (module docstring, with the exact
    rotation ``R(theta)^T`` and Jacobian ``J_r(theta)``):

    - velocity increment: within the sum of the composite trapezoid rule's error bounds
      ``H h^2 max|F''| / 12`` of each integral it takes (``H`` the sample, ``h`` the plant step, ``|F''|`` by the
      product rule from each factor's amplitude and frequency), of the mean tilt times ``int a`` (the mean's own
      trapezoid error, ``h^2 max|theta''| / 12``) and of the fourth order it leaves out
      (``H (|theta|^3 |x''| / 6 + |theta|^2 |rotating-frame terms| / 2)``). The rotating-frame terms exceed the
      bound by more than 100 times and the third order by more than 3 times, so leaving any of them out fails;
    - angle increments: within the trapezoid bound of ``int g dt`` and the fourth order it leaves out;
    - the tilt's mean over the sample: within ``h^2 max|theta''| / 12`` (the trapezoid; the mean taken at the
      plant steps' ends alone is off by ``h |theta'| / 2``, 50 times more);
    - the end values ``x' + w x x``, ``x`` and ``theta``: to rounding.
    """
    h, r, m = 1.0 / 72000.0, 10, 60
    hf = h * r
    x = _Sine([60e-6, -40e-6, 80e-6], 90.0, [0.3, 1.4, -0.7])
    th = _Sine(np.array([100.0, -60.0, 80.0]) * ARCSEC, 180.0, [0.9, -0.4, 2.0])
    om = _Sine([0.12, 0.05, -0.08], 230.0, [-1.1, 0.2, 0.6], const=[0.5, -1.0, 0.8])
    acc = _Sine([20.0, -10.0, 15.0], 300.0, [0.5, -2.2, 1.3])
    umat = np.eye(3) + np.array([[0, 2e-3, 0], [0, 0, 0], [-1e-3, 0, 0]])
    umat /= np.linalg.norm(umat, axis=1)[:, None]

    def g(t):  # the block's inertial rate beyond w + theta', exactly
        tt, w = th(t), om(t)
        return (_rodrigues(tt, w, "rt") - w) + (_rodrigues(tt, th(t, 1), "jr") - th(t, 1))

    def f_rel(t):  # the block's specific force beyond R^T f_c (the chassis' rotation carrying x), exactly
        w, xx, xd = om(t), x(t), x(t, 1)
        return _rodrigues(th(t), x(t, 2) + 2 * np.cross(w, xd) + np.cross(om(t, 1), xx)
                          + np.cross(w, np.cross(w, xx)), "rt")

    t_end = h * np.arange(1, m * r + 1)  # the plant steps' ends
    z = np.concatenate([x(t_end), th(t_end), x(t_end, 1), th(t_end, 1)], axis=1)
    rate = np.ascontiguousarray(om(t_end).T)
    a_nodes = acc(h * np.arange(m * r + 1))
    lin0 = np.ascontiguousarray(a_nodes[:-1].T)
    lin1 = np.ascontiguousarray(np.diff(a_nodes, axis=0).T / h)
    carry = np.zeros(kblock.T_SIZE)  # the motion's values at t = 0 (the kernel's state before its first step)
    w0, x0, xd0, t0_, td0 = om(0.0), x(0.0), x(0.0, 1), th(0.0), th(0.0, 1)
    wx0 = np.cross(w0, x0)
    tw, tdd = np.cross(t0_, w0), np.cross(t0_, td0)
    mm = np.cross(w0, xd0 + wx0)
    carry[kblock.T_THETA:kblock.T_THETA + 3] = t0_
    carry[kblock.T_XDOT:kblock.T_XDOT + 3] = xd0
    carry[kblock.T_G:kblock.T_G + 3] = -tw - 0.5 * tdd + np.cross(t0_, 0.5 * tw + tdd / 6)
    carry[kblock.T_THD:kblock.T_THD + 3] = td0
    carry[kblock.T_WV:kblock.T_WV + 3] = (mm - np.cross(t0_, mm) + np.cross(td0, wx0)
                                          - 0.5 * (np.cross(td0, np.cross(t0_, xd0)) + np.cross(t0_, np.cross(td0, xd0))))
    carry[kblock.T_WX:kblock.T_WX + 3] = wx0 - np.cross(t0_, wx0) + 0.5 * np.cross(t0_, np.cross(t0_, xd0))
    add = np.empty((3, m * r))
    out = {k: np.empty((3, m)) for k in ("dth", "tavg", "tend", "dvel", "xdot", "xend")}
    kblock.block_truth(z, rate, lin0, lin1, umat, h, r, carry, add, out["dth"], out["tavg"], out["tend"],
                       out["dvel"], out["xdot"], out["xend"])

    bx, bt, bw, ba = x.bounds(), th.bounds(), om.bounds(), acc.bounds()
    bxd = np.array([bx[1], bx[2], x.w * bx[2]])  # bounds of the derivatives of x', then of theta'
    btd = np.array([bt[1], bt[2], th.w * bt[2]])
    bwu = _prod(bw, bxd + _prod(bw, bx))  # w x (x' + w x x)
    trap = hf * h ** 2 / 12
    integrands_v = [_prod(btd, bxd), bwu, _prod(bt, ba),  # theta' x x', w x u, theta x a
                    _prod(bt, bwu), _prod(btd, _prod(bw, bx)),  # the third orders
                    0.5 * _prod(btd, _prod(bt, bxd)), 0.5 * _prod(bt, _prod(btd, bxd))]
    fourth_v = bt[0] ** 3 * bxd[1] / 6 + bt[0] ** 2 * (2 * bw[0] * bxd[0] + bw[1] * bx[0] + bw[0] ** 2 * bx[0]) / 2
    tol_v = trap * sum(f[2] for f in integrands_v) + (h ** 2 * bt[2] / 12) * hf * ba[0] + hf * fourth_v
    tw_b, td_b = _prod(bt, bw), _prod(bt, btd)
    integrands_g = [tw_b, 0.5 * td_b, 0.5 * _prod(bt, tw_b), _prod(bt, td_b) / 6]
    tol_g = trap * sum(f[2] for f in integrands_g) + hf * bt[0] ** 3 * (bw[0] / 6 + btd[0] / 24)
    rot_terms, third = [], []
    for k in range(m):
        t0, t1 = k * hf, (k + 1) * hf
        mean = _integral(th, t0, t1) / hf
        tilt_a = _integral(lambda t: np.cross(th(t) - mean, acc(t)), t0, t1)
        dvel = _integral(f_rel, t0, t1) - tilt_a
        rot = _integral(lambda t: 2 * np.cross(om(t), x(t, 1)) + np.cross(om(t, 1), x(t))
                        + np.cross(om(t), np.cross(om(t), x(t))), t0, t1)
        rot_terms.append(rot)
        second = x(t1, 1) - x(t0, 1) - _integral(lambda t: np.cross(th(t), x(t, 2)), t0, t1) + rot - tilt_a
        third.append(dvel - second)
        assert np.all(np.abs(out["dvel"][:, k] - dvel) <= tol_v), (k, out["dvel"][:, k] - dvel, tol_v)
        dang = umat @ (th(t1) - th(t0) + _integral(g, t0, t1))
        assert np.all(np.abs(out["dth"][:, k] - dang) <= tol_g), (k, out["dth"][:, k] - dang, tol_g)
        assert np.all(np.abs(out["tavg"][:, k] - mean) <= h ** 2 * bt[2] / 12), k
        assert np.allclose(out["xdot"][:, k], x(t1, 1) + np.cross(om(t1), x(t1)), rtol=0, atol=1e-15)
        last = z[(k + 1) * r - 1]  # the step ending at t1
        assert np.array_equal(out["xend"][:, k], last[0:3]) and np.array_equal(out["tend"][:, k], last[3:6])
    # the bound is tight enough that each rotating-frame term, and the velocity's third order, would be seen
    assert np.min(np.max(np.abs(rot_terms), axis=0)) > 100 * tol_v
    assert np.max(np.abs(third)) > 3 * tol_v, (np.max(np.abs(third)), tol_v)
    # the end-of-step mean is off by about h |theta'| / 2: the trapezoid bound resolves it
    assert 0.5 * h * bt[1] > 50 * h ** 2 * bt[2] / 12


def test_block_truth_is_the_same_in_chunks():
    """Two calls over halves of the steps give the whole call's numbers bit for bit (the carry holds every
    running value: ``w x x`` and ``w x (x' + w x x)`` at the last step included)."""
    rng = np.random.default_rng(38)
    h, r, m = 1.0 / 72000.0, 10, 8
    n = m * r
    z = rng.normal(size=(n, 12)) * np.array([1e-5] * 3 + [1e-4] * 3 + [1e-2] * 3 + [0.1] * 3)
    rate = rng.normal(size=(3, n)) * 0.1
    lin0, lin1 = rng.normal(size=(3, n)) * 10, rng.normal(size=(3, n)) * 1e4
    umat = np.eye(3)

    def run(parts):
        carry = np.zeros(kblock.T_SIZE)
        outs = []
        for lo, hi in parts:
            k = (hi - lo) // r
            o = [np.empty((3, hi - lo))] + [np.empty((3, k)) for _ in range(6)]
            kblock.block_truth(np.ascontiguousarray(z[lo:hi]), np.ascontiguousarray(rate[:, lo:hi]),
                               np.ascontiguousarray(lin0[:, lo:hi]), np.ascontiguousarray(lin1[:, lo:hi]), umat, h,
                               r, carry, *o)
            outs.append(o)
        return [np.concatenate([o[i] for o in outs], axis=1) for i in range(7)]

    whole, halves = run([(0, n)]), run([(0, 3 * r), (3 * r, n)])
    for a, b in zip(whole, halves):
        assert np.array_equal(a, b)


# --- the engine: both vibrations at the chassis of an offset mount ----------------------------------------------

CHANNELS = tuple(ChannelConfig(suspension=SuspensionParams(f0_hz=f)) for f in (386.0, 352.0, 421.0))
#: The test block of tests/test_block_engine.py (3 kg, 80 Hz translation and ~100 Hz rocking modes, 5 % damping)
#: with its elastic centre 10 mm along x and 30 mm below the c.g.
BLOCK = BlockParams(mass_kg=3.0, inertia_kg_m2=np.diag([0.012, 0.013, 0.015]), gyro_inertia_kg_m2=[2.5e-4] * 3,
                    k_trans_n_per_m=[7.6e5] * 3, k_rot_n_m_per_rad=[4740.0, 5100.0, 5900.0],
                    c_trans_n_s_per_m=[150.0] * 3, c_rot_n_m_s_per_rad=[0.75, 0.8, 0.95],
                    elastic_centre_m=[0.01, 0.0, 0.03])
#: Both vibrations at 100 Hz, on the rocking modes: the chassis turns about x and y (100 and 80 arcsec) and shakes
#: along x, y and z (1 g, 6 and 8 m/s^2), each with its own phase.
F_HZ = 100.0
ANGULAR = AxisSines((100 * ARCSEC, 80 * ARCSEC, 0.0), (F_HZ,) * 3, (0.0, 0.7, 0.0))
LINEAR = LinearSines((9.81, 6.0, 8.0), (F_HZ,) * 3, (0.3, 1.1, 2.0))


def _mission(block, duration_s, **kw):
    nav = NavSettings(start_s=1.0, n_sub=1, coning="two_sample", sculling="two_sample", spectrum_s=2.0)
    return simulate_sins(ImuConfig(channels=CHANNELS, block=block), ANGULAR, duration_s, seed=3, nav=nav,
                         translation=LINEAR, filters=("ideal",), **kw)


def _phasors(block):
    """The block's steady response ``(x, theta)`` (complex amplitudes, ``Re(q e^{i w t})``) to :data:`ANGULAR`
    and :data:`LINEAR` at the chassis: ``(-w^2 M + i w C + K) q = -M (a_c, alpha_c)`` (models.block), each gyro
    on its suspension adding ``J_g w0^2 / (w0^2 - w^2)`` about its axis to ``M`` on both sides (its dynamic
    inertia below resonance, as in tests/test_block_engine.py; the suspension turns with the block's absolute
    rotation, the chassis' included). A sine ``A sin(w t + p)`` is the phasor ``-i A e^{i p}``."""
    w = 2 * math.pi * F_HZ
    ang = np.array(ANGULAR.amplitude_rad) * np.exp(1j * np.array(ANGULAR.phase_rad)) * -1j
    lin = np.array(LINEAR.amplitude_m_s2) * np.exp(1j * np.array(LINEAR.phase_rad)) * -1j
    m, c, k = block.mass_matrix(), block.damping_matrix(), block.stiffness_matrix()
    mm = m.astype(complex)
    for i, ch in enumerate(CHANNELS):
        w0 = ch.suspension.omega0
        u = block.input_axes[i]
        mm[3:, 3:] += block.gyro_inertia_kg_m2[i] * w0 ** 2 / (w0 ** 2 - w ** 2) * np.outer(u, u)
    q = np.linalg.solve(-w ** 2 * mm + 1j * w * c + k, -mm @ np.concatenate([lin, -w ** 2 * ang]))
    return ang, q[:3], q[3:]


def _line(t, y, f_hz):
    """Least-squares phasor of ``y`` at ``f_hz`` (``Re(c e^{i w t})``)."""
    w = 2 * math.pi * f_hz
    co, *_ = np.linalg.lstsq(np.stack([np.cos(w * t), -np.sin(w * t), np.ones_like(t)], axis=1), y, rcond=None)
    return complex(co[0], co[1])


@pytest.fixture(scope="module")
def missions():
    """121 s with both vibrations at the chassis of the offset-mount block, and the rigid unit under the same
    vibration (the block's sensors moved as the profiles say)."""
    return _mission(BLOCK, 121.0), _mission(None, 121.0)


def test_both_vibrations_through_an_offset_elastic_centre_navigate_at_the_rigid_floor(missions):
    """The block's rocking against the closed form, the drift the old truth made, and the ideal's floor.

    - The rocking line about each axis (64-254 arcsec) against :func:`_phasors` within 2e-3 relative (the
      frequency-domain model leaves out the suspensions' damping and hysteresis, which change the gyros' 2 % share
      of the inertia by well under 1 %; the 3 arcsec dithers 250 Hz away leak under 1e-4 of the line into the
      2 s fit; measured 1e-4 to 3e-4).
    - The closed form of what the old truth left out: the chassis' rotation carrying the block's translation has
      the mean ``<w x x'> = (1/2) Re(W x conj(X'))`` (``W = i w P`` the chassis' rate, ``X' = i w X`` from the
      same solution; with both vibrations at one frequency ``<2 w x x' + w' x x> = <w x x'>``): 3.3e-3 m/s^2 east
      here. The old truth's ideal navigation was 1.49 m off after 30 s, ``(1/2) 3.32e-3 30^2 = 1.49`` m: that
      term alone. The ideal's north and east velocity now ramp by less than 1 % of it over the mission's last
      60 s (measured 2.5e-4 of it: the floor's own wander).
    - The ideal's largest horizontal error within 1.5 times the rigid unit's under the same vibration (the
      issue's acceptance; measured 1.18 times: 5.2 mm against 4.4 mm in 120 s).
    """
    block_res, rigid_res = missions
    ang, x_ph, th_ph = _phasors(BLOCK)
    rec = block_res.block
    for i in range(3):
        got = _line(rec["t_s"], rec["theta_rad"][:, i], F_HZ)
        assert abs(th_ph[i]) > 20 * ARCSEC
        assert abs(got / th_ph[i] - 1) < 2e-3, (i, got, th_ph[i])
    w = 2 * math.pi * F_HZ
    mean_wxv = 0.5 * np.real(np.cross(1j * w * ang, np.conj(1j * w * x_ph)))
    horiz = float(np.hypot(mean_wxv[0], mean_wxv[1]))
    assert horiz > 1e-3, mean_wxv
    ser = block_res.series["ideal"]
    late = ser["t_s"] >= ser["t_s"][-1] - 60.0
    for col in (0, 1):
        slope = np.polyfit(ser["t_s"][late], ser["velocity_ned_m_s"][late, col], 1)[0]
        assert abs(slope) < 1e-2 * horiz, (col, slope, horiz)
    floor = rigid_res.stats["ideal"].horizontal_max_m
    got = block_res.stats["ideal"].horizontal_max_m
    assert got <= 1.5 * floor, (got, floor)


#: The issue's unit and vibration: the offset-mount block (configs/offset-mount-block.yaml) at rest, angular random
#: vibration (scenarios/random-vibration.yaml's) and the linear random vibration of
#: scenarios/block-chassis-vibration.yaml, both entering at the chassis (the defaults), seed 7.
RANDOM_SCENARIO = {
    "name": "block-combined-vibration", "seed": 7, "duration_s": 1801.0, "filters": ["ideal"],
    "imu": str(Path(__file__).resolve().parents[1] / "configs" / "offset-mount-block.yaml"),
    "motion": [{"type": "static"},
               {"type": "random_vibration", "psd_deg2_s2_per_hz": [[20, 1.0e-3], [2000, 1.0e-3]], "f_lo_hz": 20,
                "f_hi_hz": 2000, "axes": [1.0, 1.0, 1.0]}],
    "linear_vibration": [{"type": "random", "psd_g2_per_hz": [[20, 0.002], [2000, 0.002]], "f_lo_hz": 20,
                          "f_hi_hz": 2000}],
    "navigation": {"rate_hz": 7200, "coning": "two_sample", "sculling": "two_sample", "start_s": 1.0},
}


@pytest.mark.slow
def test_thirty_minutes_of_random_vibration_at_the_chassis_stay_at_the_rigid_floor():
    """30 min (1801 s, navigated from 1 s) of :data:`RANDOM_SCENARIO`: the ideal's largest horizontal error within
    1.5 times the rigid unit's (the same unit and vibration without the block), the issue's acceptance. Measured on
    2026-12-07: 0.030 m against 0.022 m (1.39 times; before the fix 0.70 m); both floors are random walks of the
    two-sample algorithms under 20-2000 Hz vibration, so the ratio is that of one seed's two realisations (at
    120 s, over seeds 1-3 and 7, it ranged from 0.5 to 2.2). About 8 minutes of computing on a loaded 2-core
    machine.

    (The sines of the 120 s check are not used here: at the rocking modes the block's own coning, 250 arcsec
    about two axes, leaves the two-sample coning algorithm a fourth-order residual of 1.3e-9 rad/s, which
    halving the sample period divides by 15, not a truth error; over 30 min it is metres, while the rigid unit's
    100 arcsec leaves it 7e-11 rad/s.)"""
    import warnings

    from sins_sim.config.scenario import load_scenario

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the scenario's advisories on the vibration near the dithers
        sc = load_scenario(RANDOM_SCENARIO)

    def run(imu):
        return simulate_sins(imu, sc.motion, sc.duration_s, seed=sc.seed, nav=sc.nav, filters=sc.filters,
                             vehicle=sc.vehicle, translation=sc.translation, vibration_enters=sc.vibration_enters,
                             motion_enters=sc.motion_enters).stats["ideal"].horizontal_max_m

    got = run(sc.imu)
    floor = run(dataclasses.replace(sc.imu, block=None))
    assert got <= 1.5 * floor, (got, floor)
