"""The Earth model against the WGS-84 values published beside its formulas (NIMA TR8350.2, 3rd ed., 2000).

``sins_sim.earth`` is used alike by the trajectory truth and the navigation, so a wrong formula there never shows as
a navigation error: only an independent value can catch it. Checked here:

- normal gravity at the equator and at the poles, ``gamma_e = 9.7803253359`` and ``gamma_p = 9.8321849378`` m/s^2
  (TR8350.2 table 3.4; the pole value is not an input of the Somigliana form, which gets it from ``k`` and ``e^2``);
- the free-air gradient: ``-2 gamma / a (1 + f + m - 2 f sin^2 lat)`` (eq. 4-3), within 1 % of the spherical
  ``-2 g / a`` (the ellipsoid and rotation add ``f + m = 0.68 %``);
- the radii of curvature at the equator and the poles: ``R_N(0) = b^2 / a``, ``R_E(0) = a``,
  ``R_N(90) = R_E(90) = a^2 / b`` (Titterton & Weston 2004, sec. 3.7: both radii meet at the pole);
- the signs of the transport rate: flying east turns the local level about north (positive), flying north about
  east (negative: the down axis tips north), each at speed over radius.

Tolerances: the published values carry 10-11 digits: 1e-9 relative; the radii are closed forms: 1e-12.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sins_sim import earth

GAMMA_POLE_M_S2 = 9.8321849378  # TR8350.2 table 3.4


def test_normal_gravity_at_the_equator_and_the_poles():
    assert float(earth.gravity_down(0.0, 0.0)) == pytest.approx(earth.GAMMA_EQUATOR_M_S2, rel=1e-12)
    for lat in (0.5 * math.pi, -0.5 * math.pi):
        assert float(earth.gravity_down(lat, 0.0)) == pytest.approx(GAMMA_POLE_M_S2, rel=1e-9)
    # gravity grows from the equator to the poles, monotonically
    g = earth.gravity_down(np.radians(np.arange(0.0, 91.0, 5.0)), 0.0)
    assert np.all(np.diff(g) > 0)


@pytest.mark.parametrize("lat_deg", [0.0, 45.0, 80.0])
def test_free_air_gradient(lat_deg):
    lat = math.radians(lat_deg)
    step = 10.0
    grad = float(earth.gravity_down(lat, step) - earth.gravity_down(lat, -step)) / (2 * step)
    g0 = float(earth.gravity_down(lat, 0.0))
    assert grad == pytest.approx(-2.0 * g0 / earth.WGS84_A_M, rel=1e-2)
    s2 = math.sin(lat) ** 2
    exact = -2.0 * g0 / earth.WGS84_A_M * (1 + earth.WGS84_F + earth.WGS84_M - 2 * earth.WGS84_F * s2)
    assert grad == pytest.approx(exact, rel=1e-9)  # the quadratic term cancels in the central difference


def test_radii_of_curvature_at_the_equator_and_the_poles():
    a, b = earth.WGS84_A_M, earth.WGS84_B_M
    r_n, r_e = earth.radii(0.0)
    assert r_n == pytest.approx(b * b / a, rel=1e-12)
    assert r_e == pytest.approx(a, rel=1e-12)
    r_n, r_e = earth.radii(0.5 * math.pi)
    assert r_n == pytest.approx(a * a / b, rel=1e-12)
    assert r_e == pytest.approx(a * a / b, rel=1e-12)


def test_transport_rate_signs_and_sizes():
    lat, h, v = math.radians(30.0), 500.0, 250.0
    r_n, r_e = earth.radii(lat)
    east = earth.transport_rate_ned(lat, h, np.array([0.0, v, 0.0]))
    north = earth.transport_rate_ned(lat, h, np.array([v, 0.0, 0.0]))
    assert east[0] == pytest.approx(v / (r_e + h), rel=1e-12)
    assert east[2] == pytest.approx(-v * math.tan(lat) / (r_e + h), rel=1e-12)
    assert north[1] == pytest.approx(-v / (r_n + h), rel=1e-12)
    assert north[0] == 0.0 and north[2] == 0.0
    # Earth rate: north and up components, Omega cos lat and Omega sin lat
    w = earth.earth_rate_ned(lat)
    assert w[0] == pytest.approx(earth.EARTH_RATE_RAD_S * math.cos(lat), rel=1e-15)
    assert w[2] == pytest.approx(-earth.EARTH_RATE_RAD_S * math.sin(lat), rel=1e-15)
