"""Strapdown navigation kernel: attitude, velocity and position in a local-level NED frame on WGS-84.

One kernel, :func:`strapdown_run`, processes a chunk of gyro angle increments
``dtheta`` (rad) and accelerometer velocity increments ``dv`` (m/s), both
body frame and integrals over one input sample of ``dt`` seconds, and
advances the navigation state held in a caller-owned ``state`` array. The
public wrapper is :class:`sins_sim.navigation.strapdown.StrapdownNavigator`
(which validates; this module never does).

Conventions: quaternions Hamilton, scalar first, ``q_nb`` body to NED, body
rotations compose on the right (:mod:`sins_sim._kernels.nav`); geodetic
latitude/longitude in rad, height ``h`` in m positive up, ``v_ned`` in m/s
with ``v_D`` positive down; Earth model :mod:`sins_sim.earth` (WGS-84 radii,
Earth rate, Somigliana normal gravity with height).

Two rates (Savage 1998, Parts 1 and 2: high-rate coning/sculling
accumulation, low-rate navigation update). Input sample
``l`` (period ``dt``) feeds the accumulators; every ``n_sub`` samples the
navigation update ``m`` runs with ``T = n_sub dt``.

High rate, per input sample ``l`` of update ``m`` (``alpha_0 = upsilon_0 = 0``;
the previous increments ``dtheta_{l-j}, dv_{l-j}`` (``j = 1..3``) run across
update boundaries: previous-sample algorithms), component ``i``::

    beta_i  += (1/2 alpha_{l-1} x dtheta_l)_i + sum_j c[i,j] (dtheta_{l-j} x dtheta_l)_i        (K1)
    S_i     += (1/2 alpha_{l-1} x dv_l + 1/2 upsilon_{l-1} x dtheta_l)_i
             + sum_j s[i,j] (dtheta_{l-j} x dv_l + dv_{l-j} x dtheta_l)_i                     (K2)
    alpha_l = alpha_{l-1} + dtheta_l,   upsilon_l = upsilon_{l-1} + dv_l

(K1) is Savage's (1998, Part 1) high-rate coning accumulation: for
``c[i] = (1/12, 0, 0)`` it is his ``1/2 (alpha_{l-1} + 1/6 dalpha_{l-1}) x dalpha_l``;
the ``1/2 alpha_{l-1} x dtheta_l`` part composes the sub-sample rotations to
second order (Bortz 1971) and is present for every choice, so that one
algorithm has the same per-sample error whatever ``n_sub``. (K2) is the
sculling counterpart (Savage 1998, Part 2, high-rate sculling accumulation):
``1/2 [(alpha_{l-1} + 1/6 dalpha_{l-1}) x dv_l + (upsilon_{l-1} + 1/6 dv_{l-1}) x dalpha_l]``
for the two-sample choice. Coefficient rows ``c[i] = (c_1, c_2, c_3)`` (lags
1, 2, 3): ``(0, 0, 0)`` "none", ``(1/12, 0, 0)`` "two_sample" (Savage 1998;
Ignagni 1996), ``(7/60, -1/60, 0)`` "three_sample" (Ignagni 1990 Algorithm E
in previous-sample form, :mod:`sins_sim._kernels.nav`), ``(113/840, -13/420,
1/280)`` "four_sample"; for sculling the same coefficients by the
coning/sculling duality (Ignagni 1998). The rows differ only for a
filter-tuned design (:func:`sins_sim.navigation.coning.tuned_coefficients`).

Low rate, navigation update ``m`` (state ``x_{m-1}`` -> ``x_m``):

1. Mid-interval extrapolation from the last two updates (Savage 1998 Part 2:
   the navigation-frame rates of the update are taken at ``t_{m-1/2}``,
   extrapolated from past values; the rates below are evaluated there)::

       x_{m-1/2} = x_{m-1} + (x_{m-1} - x_{m-2}) / 2,   x in {lat, h, v_ned}

2. Rates (Titterton & Weston 2004, sec. 3.7; :mod:`sins_sim.earth`)::

       omega_ie^n = Omega [cos lat, 0, -sin lat]
       omega_en^n = [v_E/(R_E+h), -v_N/(R_N+h), -v_E tan(lat)/(R_E+h)]
       zeta       = (omega_ie^n + omega_en^n) T                                          (N1)

3. Velocity (Savage 1998 Part 2: specific-force increment with rotation
   and sculling compensation, navigation-frame rotation correction,
   gravity/Coriolis increment; Titterton & Weston 2004, ch. 11)::

       dV_b = upsilon_m + 1/2 alpha_m x upsilon_m + S_m                                  (V1)
       dV_n = (I - 1/2 [zeta x]) C_nb[m-1] dV_b                                           (V2)
       v_m  = v_{m-1} + dV_n + (g^n - (2 omega_ie^n + omega_en^n) x v_{m-1/2}) T         (V3)

   with ``g^n = [0, 0, gamma(lat, h)]`` Somigliana normal gravity with height
   (:func:`sins_sim.earth.gravity_down`).

4. Vertical-channel damping (third-order loop, Widnall & Sinha 1980), with
   ``dh = h_{m-1} - h_aid`` the height error of the previous update::

       v_D,m += (k2 dh + a_c) T,   a_c += k3 dh T,   h_m -= k1 dh T                      (H1)

   ``k1 = k2 = k3 = 0`` and ``a_c = 0`` when not aided ("free").

5. Position, trapezoidal integration of the latitude/longitude/height rates
   (Titterton & Weston 2004, sec. 3.7; Savage 1998 Part 2), radii at the
   extrapolated latitude and the mid height::

       h_m   = h_{m-1} - T/2 (v_D,m-1 + v_D,m)
       lat_m = lat_{m-1} + T/2 (v_N,m-1 + v_N,m) / (R_N + h_mid)
       lon_m = lon_{m-1} + T/2 (v_E,m-1 + v_E,m) / ((R_E + h_mid) cos lat)               (P1)

6. Attitude (Savage 1998 Part 1: body-frame update by the rotation vector
   ``phi_m``, navigation-frame update by ``zeta``; Titterton & Weston 2004,
   ch. 11)::

       phi_m  = alpha_m + beta_m
       q_nb,m = normalise(q(-zeta) (x) q_nb,m-1 (x) q(phi_m))                             (A1)

What is neglected (all third order in the update's angles): the product
``-1/4 zeta x (alpha x upsilon)`` of (V1) and (V2) (at rest ``(Omega T)^2 g / 4``
relative, 6.5e-13 m/s^2 at 100 Hz), the ``(1 - cos|alpha|)/|alpha|^2`` term of
the body rotation within an update in (V1), and the third-order terms of
composing the sub-sample rotations in (K1)/(K2) (Savage 1998 neglects the
same).

Streaming: everything the next sample needs is in ``state``, so processing a
sequence in one call or in chunks of any sizes gives the same bits.

References
----------
.. [1] P. G. Savage, "Strapdown inertial navigation integration algorithm
   design, Part 1: Attitude algorithms", J. Guidance, Control, and Dynamics
   21(1), 19-28, 1998.
.. [2] P. G. Savage, "Strapdown inertial navigation integration algorithm
   design, Part 2: Velocity and position algorithms", J. Guidance, Control,
   and Dynamics 21(2), 208-221, 1998.
.. [3] D. H. Titterton, J. L. Weston, *Strapdown Inertial Navigation
   Technology*, 2nd ed., IEE, 2004, ch. 3 and 11.
.. [4] M. B. Ignagni, "Optimal strapdown attitude integration algorithms",
   J. Guidance, Control, and Dynamics 13(2), 363-369, 1990.
.. [5] M. B. Ignagni, "Duality of optimal strapdown sculling and coning
   compensation algorithms", Navigation (J. ION) 45(2), 85-95, 1998.
.. [6] W. S. Widnall, P. K. Sinha, "Optimizing the gains of the
   baro-inertial vertical channel", J. Guidance and Control 3(2), 172-178, 1980.
.. [7] J. W. Bortz, "A new mathematical formulation for strapdown inertial
   navigation", IEEE Trans. Aerosp. Electron. Syst. AES-7(1), 61-66, 1971.
"""

from __future__ import annotations

import math

import numpy as np

from sins_sim import earth
from sins_sim._kernels._config import jit
from sins_sim._kernels.nav import quat_mul, rotvec_to_quat

# --- state layout (float64[STATE_SIZE]) --------------------------------------------
#: Latitude (rad).
ST_LAT = 0
#: Longitude (rad), wrapped to [-pi, pi).
ST_LON = 1
#: Height above the ellipsoid (m, up).
ST_H = 2
#: NED velocity, 3 entries (m/s).
ST_V = 3
#: Attitude q_nb, 4 entries (scalar first).
ST_Q = 6
#: dtheta of the previous input sample, 3 entries (rad).
ST_DTH1 = 10
#: dtheta two input samples back, 3 entries (rad).
ST_DTH2 = 13
#: dv of the previous input sample, 3 entries (m/s).
ST_DV1 = 16
#: dv two input samples back, 3 entries (m/s).
ST_DV2 = 19
#: alpha: sum of dtheta since the last update, 3 entries (rad).
ST_ALPHA = 22
#: upsilon: sum of dv since the last update, 3 entries (m/s).
ST_UPS = 25
#: beta: coning sum since the last update, 3 entries (rad).
ST_BETA = 28
#: sculling sum since the last update, 3 entries (m/s).
ST_SCUL = 31
#: Input samples accumulated towards the next update (0 .. n_sub - 1), as float.
ST_COUNT = 34
#: Latitude of the update before the last (rad), for the extrapolation.
ST_PREV_LAT = 35
#: Height of the update before the last (m).
ST_PREV_H = 36
#: NED velocity of the update before the last, 3 entries (m/s).
ST_PREV_V = 37
#: Height error ``h - h_aid`` after the last update (m).
ST_DH = 40
#: Vertical-loop acceleration correction ``a_c`` (m/s^2, down positive).
ST_ACC = 41
#: dtheta three input samples back, 3 entries (rad).
ST_DTH3 = 42
#: dv three input samples back, 3 entries (m/s).
ST_DV3 = 45
#: Length of the state array.
STATE_SIZE = 48

# --- output row layout (float64[M, OUT_SIZE]) --------------------------------------
OUT_LAT = 0
OUT_LON = 1
OUT_H = 2
OUT_V = 3
OUT_Q = 6
OUT_SIZE = 10

#: Earth rate (rad/s), :data:`sins_sim.earth.EARTH_RATE_RAD_S`.
EARTH_RATE = earth.EARTH_RATE_RAD_S

#: :func:`sins_sim.earth.radii` compiled for scalars (same source, one Earth model).
radii = jit(earth.radii)
#: :func:`sins_sim.earth.gravity_down` compiled for scalars.
gravity_down = jit(earth.gravity_down)


@jit
def _cross_add(c, a0, a1, a2, b0, b1, b2, acc):
    """``acc[i] += c[i] (a x b)_i``, ``c`` one column of a coefficient array."""
    acc[0] += c[0] * (a1 * b2 - a2 * b1)
    acc[1] += c[1] * (a2 * b0 - a0 * b2)
    acc[2] += c[2] * (a0 * b1 - a1 * b0)


@jit
def _per_component(a0, a1, a2, u0, u1, u2, d0, d1, d2, e0, e1, e2, p0, p1, p2, m0, m1, m2, o0, o1, o2,
                   w0, w1, w2, y0, y1, y2, z0, z1, z2, cc1, cc2, cc3, sc1, sc2, sc3, bb, ss):
    """(K1) and (K2) of one sample with coefficients per component (a filter-tuned design): ``bb``, ``ss``."""
    # (K1) 1/2 alpha x dtheta_l + sum_j c[:, j] (dtheta_{l-j} x dtheta_l)
    bb[0] = 0.5 * (a1 * d2 - a2 * d1)
    bb[1] = 0.5 * (a2 * d0 - a0 * d2)
    bb[2] = 0.5 * (a0 * d1 - a1 * d0)
    _cross_add(cc1, p0, p1, p2, d0, d1, d2, bb)
    _cross_add(cc2, m0, m1, m2, d0, d1, d2, bb)
    _cross_add(cc3, o0, o1, o2, d0, d1, d2, bb)
    # (K2) 1/2 (alpha x dv_l + upsilon x dtheta_l) + sum_j s[:, j] (dtheta_{l-j} x dv_l + dv_{l-j} x dtheta_l)
    ss[0] = 0.5 * ((a1 * e2 - a2 * e1) + (u1 * d2 - u2 * d1))
    ss[1] = 0.5 * ((a2 * e0 - a0 * e2) + (u2 * d0 - u0 * d2))
    ss[2] = 0.5 * ((a0 * e1 - a1 * e0) + (u0 * d1 - u1 * d0))
    _cross_add(sc1, p0, p1, p2, e0, e1, e2, ss)
    _cross_add(sc1, w0, w1, w2, d0, d1, d2, ss)
    _cross_add(sc2, m0, m1, m2, e0, e1, e2, ss)
    _cross_add(sc2, y0, y1, y2, d0, d1, d2, ss)
    _cross_add(sc3, o0, o1, o2, e0, e1, e2, ss)
    _cross_add(sc3, z0, z1, z2, d0, d1, d2, ss)


@jit
def strapdown_run(dtheta, dv, h_aid, dt, n_sub, ccoef, scoef, aided, k1, k2, k3, state, out):
    """Strapdown navigation over one chunk of increments (module docstring, K1-A1).

    Parameters
    ----------
    dtheta : ndarray, shape (N, 3), float64
        Gyro angle increments (rad, body frame), one per input sample.
    dv : ndarray, shape (N, 3), float64
        Accelerometer velocity increments (m/s, body frame), same samples.
    h_aid : ndarray, shape (N,) or (0,), float64
        Aiding height (m) at the end of each input sample; read only at the
        samples that complete an update, and only when ``aided``.
    dt : float
        Input sample period (s).
    n_sub : int
        Input samples per navigation update (>= 1).
    ccoef, scoef : ndarray, shape (3, 3), float64
        Coning and sculling coefficients, ``[component i, lag j - 1]`` (K1, K2).
    aided : bool
        Apply the vertical loop (H1).
    k1, k2, k3 : float
        Vertical-loop gains (1/s, 1/s^2, 1/s^3).
    state : ndarray, shape (STATE_SIZE,), float64
        Navigation state (layout ``ST_*``); read and updated in place.
    out : ndarray, shape (M, OUT_SIZE), float64
        One row per completed update (layout ``OUT_*``); ``M`` must be at
        least ``(state[ST_COUNT] + N) // n_sub``. Rows beyond the count
        returned are not written.

    Returns
    -------
    int
        Number of updates completed (rows written).
    """
    cc1, cc2, cc3 = ccoef[:, 0].copy(), ccoef[:, 1].copy(), ccoef[:, 2].copy()
    sc1_, sc2_, sc3_ = scoef[:, 0].copy(), scoef[:, 1].copy(), scoef[:, 2].copy()
    # the named algorithms have one row for all components: (K1)/(K2) then take one cross product
    # per sum, ``(1/2 alpha + sum_j c_j x_{l-j}) x y`` (the same terms, fewer operations)
    uniform = True
    for i in range(1, 3):
        for j in range(3):
            if ccoef[i, j] != ccoef[0, j] or scoef[i, j] != scoef[0, j]:
                uniform = False
    k1c, k2c, k3c = ccoef[0, 0], ccoef[0, 1], ccoef[0, 2]
    k1s, k2s, k3s = scoef[0, 0], scoef[0, 1], scoef[0, 2]
    bb = np.empty(3)
    ss = np.empty(3)
    big_t = n_sub * dt
    half_t = 0.5 * big_t
    two_pi = 2.0 * math.pi

    lat = state[ST_LAT]
    lon = state[ST_LON]
    h = state[ST_H]
    vn = state[ST_V]
    ve = state[ST_V + 1]
    vd = state[ST_V + 2]
    q = np.empty(4)
    for j in range(4):
        q[j] = state[ST_Q + j]
    p0, p1, p2 = state[ST_DTH1], state[ST_DTH1 + 1], state[ST_DTH1 + 2]  # dtheta_{l-1}
    m0, m1, m2 = state[ST_DTH2], state[ST_DTH2 + 1], state[ST_DTH2 + 2]  # dtheta_{l-2}
    w0, w1, w2 = state[ST_DV1], state[ST_DV1 + 1], state[ST_DV1 + 2]  # dv_{l-1}
    y0, y1, y2 = state[ST_DV2], state[ST_DV2 + 1], state[ST_DV2 + 2]  # dv_{l-2}
    o0, o1, o2 = state[ST_DTH3], state[ST_DTH3 + 1], state[ST_DTH3 + 2]  # dtheta_{l-3}
    z0_, z1_, z2_ = state[ST_DV3], state[ST_DV3 + 1], state[ST_DV3 + 2]  # dv_{l-3}
    a0, a1, a2 = state[ST_ALPHA], state[ST_ALPHA + 1], state[ST_ALPHA + 2]
    u0, u1, u2 = state[ST_UPS], state[ST_UPS + 1], state[ST_UPS + 2]
    b0, b1, b2 = state[ST_BETA], state[ST_BETA + 1], state[ST_BETA + 2]
    sc0, sc1, sc2 = state[ST_SCUL], state[ST_SCUL + 1], state[ST_SCUL + 2]
    count = int(state[ST_COUNT])
    lat_p = state[ST_PREV_LAT]
    h_p = state[ST_PREV_H]
    vn_p, ve_p, vd_p = state[ST_PREV_V], state[ST_PREV_V + 1], state[ST_PREV_V + 2]
    dh = state[ST_DH]
    acc = state[ST_ACC]

    phi = np.empty(3)
    qb = np.empty(4)
    qn = np.empty(4)
    qt = np.empty(4)
    n_out = 0
    for i in range(dtheta.shape[0]):
        d0, d1, d2 = dtheta[i, 0], dtheta[i, 1], dtheta[i, 2]
        e0, e1, e2 = dv[i, 0], dv[i, 1], dv[i, 2]
        if uniform:
            # (K1) beta += (1/2 alpha + sum_j c_j dtheta_{l-j}) x dtheta_l
            r0 = 0.5 * a0 + k1c * p0 + k2c * m0 + k3c * o0
            r1 = 0.5 * a1 + k1c * p1 + k2c * m1 + k3c * o1
            r2 = 0.5 * a2 + k1c * p2 + k2c * m2 + k3c * o2
            b0 += r1 * d2 - r2 * d1
            b1 += r2 * d0 - r0 * d2
            b2 += r0 * d1 - r1 * d0
            # (K2) S += (1/2 alpha + sum_j s_j dtheta_{l-j}) x dv_l + (1/2 upsilon + sum_j s_j dv_{l-j}) x dtheta_l
            r0 = 0.5 * a0 + k1s * p0 + k2s * m0 + k3s * o0
            r1 = 0.5 * a1 + k1s * p1 + k2s * m1 + k3s * o1
            r2 = 0.5 * a2 + k1s * p2 + k2s * m2 + k3s * o2
            t0 = 0.5 * u0 + k1s * w0 + k2s * y0 + k3s * z0_
            t1 = 0.5 * u1 + k1s * w1 + k2s * y1 + k3s * z1_
            t2 = 0.5 * u2 + k1s * w2 + k2s * y2 + k3s * z2_
            sc0 += (r1 * e2 - r2 * e1) + (t1 * d2 - t2 * d1)
            sc1 += (r2 * e0 - r0 * e2) + (t2 * d0 - t0 * d2)
            sc2 += (r0 * e1 - r1 * e0) + (t0 * d1 - t1 * d0)
        else:
            _per_component(a0, a1, a2, u0, u1, u2, d0, d1, d2, e0, e1, e2, p0, p1, p2, m0, m1, m2, o0, o1, o2,
                           w0, w1, w2, y0, y1, y2, z0_, z1_, z2_, cc1, cc2, cc3, sc1_, sc2_, sc3_, bb, ss)
            b0 += bb[0]
            b1 += bb[1]
            b2 += bb[2]
            sc0 += ss[0]
            sc1 += ss[1]
            sc2 += ss[2]
        a0 += d0
        a1 += d1
        a2 += d2
        u0 += e0
        u1 += e1
        u2 += e2
        o0, o1, o2 = m0, m1, m2
        m0, m1, m2 = p0, p1, p2
        p0, p1, p2 = d0, d1, d2
        z0_, z1_, z2_ = y0, y1, y2
        y0, y1, y2 = w0, w1, w2
        w0, w1, w2 = e0, e1, e2
        count += 1
        if count < n_sub:
            continue

        # ---- navigation update m --------------------------------------------------
        # 1. mid-interval extrapolation (Savage 1998 Part 2)
        lat_x = lat + 0.5 * (lat - lat_p)
        h_x = h + 0.5 * (h - h_p)
        vxn = vn + 0.5 * (vn - vn_p)
        vxe = ve + 0.5 * (ve - ve_p)
        vxd = vd + 0.5 * (vd - vd_p)
        # 2. rates (N1): Titterton & Weston 2004 sec. 3.7; sins_sim.earth
        sl = math.sin(lat_x)
        cl = math.cos(lat_x)
        r_n, r_e = radii(lat_x)
        g = gravity_down(lat_x, h_x)
        inv_re = 1.0 / (r_e + h_x)
        wie_n = EARTH_RATE * cl
        wie_d = -EARTH_RATE * sl
        wen_n = vxe * inv_re
        wen_e = -vxn / (r_n + h_x)
        wen_d = -wen_n * sl / cl
        z0 = (wie_n + wen_n) * big_t
        z1 = wen_e * big_t
        z2 = (wie_d + wen_d) * big_t
        # 3. velocity: (V1) dV_b = upsilon + 1/2 alpha x upsilon + S
        f0 = u0 + 0.5 * (a1 * u2 - a2 * u1) + sc0
        f1 = u1 + 0.5 * (a2 * u0 - a0 * u2) + sc1
        f2 = u2 + 0.5 * (a0 * u1 - a1 * u0) + sc2
        # C_nb[m-1] dV_b = f + q0 t + qv x t,  t = 2 qv x f
        q0, q1, q2, q3 = q[0], q[1], q[2], q[3]
        t0 = 2.0 * (q2 * f2 - q3 * f1)
        t1 = 2.0 * (q3 * f0 - q1 * f2)
        t2 = 2.0 * (q1 * f1 - q2 * f0)
        n0 = f0 + q0 * t0 + (q2 * t2 - q3 * t1)
        n1 = f1 + q0 * t1 + (q3 * t0 - q1 * t2)
        n2 = f2 + q0 * t2 + (q1 * t1 - q2 * t0)
        # (V2) (I - 1/2 [zeta x]) C_nb dV_b
        dvn0 = n0 - 0.5 * (z1 * n2 - z2 * n1)
        dvn1 = n1 - 0.5 * (z2 * n0 - z0 * n2)
        dvn2 = n2 - 0.5 * (z0 * n1 - z1 * n0)
        # (V3) + (g^n - (2 omega_ie + omega_en) x v_mid) T
        cw0 = 2.0 * wie_n + wen_n
        cw1 = wen_e
        cw2 = 2.0 * wie_d + wen_d
        vn_new = vn + dvn0 - (cw1 * vxd - cw2 * vxe) * big_t
        ve_new = ve + dvn1 - (cw2 * vxn - cw0 * vxd) * big_t
        vd_new = vd + dvn2 + (g - (cw0 * vxe - cw1 * vxn)) * big_t
        # 4. vertical loop (H1), Widnall & Sinha 1980
        if aided:
            vd_new += (k2 * dh + acc) * big_t
            acc += k3 * dh * big_t
        # 5. position (P1), trapezoidal
        h_new = h - half_t * (vd + vd_new)
        if aided:
            h_new -= k1 * dh * big_t
        h_mid = 0.5 * (h + h_new)
        lat_new = lat + half_t * (vn + vn_new) / (r_n + h_mid)
        lon_new = lon + half_t * (ve + ve_new) / ((r_e + h_mid) * cl)
        if lon_new >= math.pi:
            lon_new -= two_pi
        elif lon_new < -math.pi:
            lon_new += two_pi
        # 6. attitude (A1): q <- q(-zeta) (x) q (x) q(alpha + beta)
        phi[0] = a0 + b0
        phi[1] = a1 + b1
        phi[2] = a2 + b2
        rotvec_to_quat(phi, qb)
        phi[0] = -z0
        phi[1] = -z1
        phi[2] = -z2
        rotvec_to_quat(phi, qn)
        quat_mul(q, qb, qt)
        quat_mul(qn, qt, q)
        inv = 1.0 / math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
        for j in range(4):
            q[j] *= inv

        lat_p, h_p = lat, h
        vn_p, ve_p, vd_p = vn, ve, vd
        lat, lon, h = lat_new, lon_new, h_new
        vn, ve, vd = vn_new, ve_new, vd_new
        if aided:
            dh = h - h_aid[i]
        out[n_out, OUT_LAT] = lat
        out[n_out, OUT_LON] = lon
        out[n_out, OUT_H] = h
        out[n_out, OUT_V] = vn
        out[n_out, OUT_V + 1] = ve
        out[n_out, OUT_V + 2] = vd
        for j in range(4):
            out[n_out, OUT_Q + j] = q[j]
        n_out += 1
        a0 = a1 = a2 = 0.0
        u0 = u1 = u2 = 0.0
        b0 = b1 = b2 = 0.0
        sc0 = sc1 = sc2 = 0.0
        count = 0

    state[ST_LAT] = lat
    state[ST_LON] = lon
    state[ST_H] = h
    state[ST_V] = vn
    state[ST_V + 1] = ve
    state[ST_V + 2] = vd
    for j in range(4):
        state[ST_Q + j] = q[j]
    state[ST_DTH1], state[ST_DTH1 + 1], state[ST_DTH1 + 2] = p0, p1, p2
    state[ST_DTH2], state[ST_DTH2 + 1], state[ST_DTH2 + 2] = m0, m1, m2
    state[ST_DV1], state[ST_DV1 + 1], state[ST_DV1 + 2] = w0, w1, w2
    state[ST_DV2], state[ST_DV2 + 1], state[ST_DV2 + 2] = y0, y1, y2
    state[ST_DTH3], state[ST_DTH3 + 1], state[ST_DTH3 + 2] = o0, o1, o2
    state[ST_DV3], state[ST_DV3 + 1], state[ST_DV3 + 2] = z0_, z1_, z2_
    state[ST_ALPHA], state[ST_ALPHA + 1], state[ST_ALPHA + 2] = a0, a1, a2
    state[ST_UPS], state[ST_UPS + 1], state[ST_UPS + 2] = u0, u1, u2
    state[ST_BETA], state[ST_BETA + 1], state[ST_BETA + 2] = b0, b1, b2
    state[ST_SCUL], state[ST_SCUL + 1], state[ST_SCUL + 2] = sc0, sc1, sc2
    state[ST_COUNT] = float(count)
    state[ST_PREV_LAT] = lat_p
    state[ST_PREV_H] = h_p
    state[ST_PREV_V], state[ST_PREV_V + 1], state[ST_PREV_V + 2] = vn_p, ve_p, vd_p
    state[ST_DH] = dh
    state[ST_ACC] = acc
    return n_out
