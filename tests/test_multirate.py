"""Multi-rate navigation (issue 26, item 1): ``navigation.rate_hz`` and the convergence to the full-rate solution.

The coning and sculling sums run at the filter rate; attitude, velocity and position update every
``n_sub = readout.output_rate_hz / rate_hz`` filter samples (Savage 1998). What differs from the
full-rate solution is what the low-rate update approximates: the composition of the sub-sample
rotations to second order within an update, and the navigation-frame, gravity and Coriolis terms
taken once per update (:mod:`sins_sim._kernels.strapdown`).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from sins_sim import earth
from sins_sim.config.errors import ConfigError
from sins_sim.config.scenario import load_scenario
from sins_sim.navigation.attitude import attitude_error
from sins_sim.navigation.coning import cone_increments
from sins_sim.navigation.strapdown import StrapdownNavigator

ROOT = Path(__file__).resolve().parents[1]
FS = 7200.0


@pytest.fixture(scope="module")
def cone_runs():
    """10 s at rest at 45 N under a 1 arcmin, 600 Hz cone (plus the Earth rate, gravity), navigated at
    the full 7.2 kHz and at 3.6 kHz, 1.2 kHz, 400 Hz, 200 Hz and 100 Hz; the same increments for all."""
    h, lat = 1.0 / FS, math.radians(45.0)
    n = int(10 * FS)
    dth = cone_increments(math.radians(1.0 / 60.0), 2.0 * math.pi * 600.0, h, n + 3, start=-3)
    dth = dth + earth.earth_rate_ned(lat) * h
    dv = np.tile(-earth.gravity_ned(lat, 0.0) * h, (n + 3, 1))
    out = {}
    for n_sub in (1, 2, 6, 18, 36, 72):
        nav = StrapdownNavigator(lat, 0.0, 0.0, np.zeros(3), [1.0, 0, 0, 0], h, n_sub=n_sub,
                                 dtheta_prev=dth[:3], dv_prev=dv[:3])
        sol = nav.process(dth[3:], dv[3:])
        out[n_sub] = (sol.q_nb[-1], sol.lat_rad[-1], sol.lon_rad[-1], sol.v_ned_m_s[-1])
    return out


def test_raising_the_rate_converges_to_the_full_rate_result(cone_runs):
    """The velocity difference from the full-rate solution after 10 s shrinks with every rise of the rate
    (measured |dv| = 7.8e-5, 3.9e-5, 2.0e-5, 8.8e-6, 5.5e-7 m/s at 100, 200, 400, 1200, 3600 Hz), and so
    does the attitude difference down to 400 Hz, below which the update spans whole cone periods
    (0.095 arcsec at 100 and 200 Hz; 3.9e-6, 3.4e-6, 7.8e-8 arcsec at 400, 1200, 3600 Hz: the sums'
    second-order composition, far below any filter's coning error)."""
    q1, lat1, lon1, v1 = cone_runs[1]
    dv, dphi = {}, {}
    for n_sub, (q, lat, lon, v) in cone_runs.items():
        dv[n_sub] = float(np.linalg.norm(v - v1))
        dphi[n_sub] = float(np.linalg.norm(attitude_error(q[None], q1[None])[0])) / math.radians(1.0 / 3600.0)
    rates = sorted(cone_runs, reverse=True)  # n_sub descending: the rate rising
    for slow, fast in zip(rates[:-2], rates[1:-1]):
        assert dv[fast] < dv[slow], (fast, slow, dv)
    assert dv[2] < 1e-6 and dphi[2] < 1e-6
    assert dphi[18] < 1e-5 and dphi[6] < 1e-5  # arcsec
    assert dphi[36] > 1e-2  # the slower rates do differ: the test can fail


def test_rate_hz_sets_n_sub():
    doc = {"name": "t", "duration_s": 2.0, "imu": str(ROOT / "configs" / "default-imu.yaml"),
           "navigation": {"rate_hz": 400}}
    assert load_scenario(doc).nav.n_sub == 18
    doc["navigation"] = {"rate_hz": 400, "n_sub": 18}
    assert load_scenario(doc).nav.n_sub == 18


@pytest.mark.parametrize(("nav", "message"), [
    ({"rate_hz": 700}, r"navigation\.rate_hz: must divide the filter rate 7200 Hz .* e\.g\. 654\.545 or 720 Hz; "
                       r"got 700"),
    ({"rate_hz": 9000}, r"navigation\.rate_hz: must divide the filter rate"),
    ({"rate_hz": 400, "n_sub": 4}, r"navigation\.rate_hz: 400 Hz is n_sub = 18, but navigation\.n_sub is 4"),
])
def test_bad_rate_is_one_line(nav, message):
    doc = {"name": "t", "duration_s": 2.0, "imu": str(ROOT / "configs" / "default-imu.yaml"), "navigation": nav}
    with pytest.raises(ConfigError, match=message):
        load_scenario(doc)
