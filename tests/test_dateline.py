"""A segment flight across the antimeridian (issue 25, item 1): the truth's longitude between two vehicle nodes
astride 180 deg was interpolated across the globe, so a few rows had an east error of half the Earth's
circumference (horizontal max 1.97e7 m for every filter, ideal included) while the final error was 1 mm."""

import numpy as np
import pytest

from sins_sim.config.scenario import load_scenario
from sins_sim.simulation.sins import simulate_sins
from sins_sim.simulation.truth import _continuous_lon, _wrap_lon


def test_a_flight_across_the_date_line_has_no_jump_in_its_errors(tmp_path):
    """250 m/s east from 179.99 deg E at 10 deg N crosses 180 deg after about 4.4 s. The ideal increments'
    largest horizontal error must stay at the algorithm's floor: 1 cm bounds it with margin (the final
    error is 1.2 mm after 30 s; a jump would be 2e7 m)."""
    sc = tmp_path / "dl.yaml"
    sc.write_text("name: dateline\nimu: {channels: {x: {f0_hz: 386}, y: {f0_hz: 352}, z: {f0_hz: 421}}}\n"
                  "duration_s: 30\nsite: {lat_deg: 10, lon_deg: 179.99, height_m: 1000, heading_deg: 90}\n"
                  "trajectory: {speed_m_s: 250}\n")
    s = load_scenario(sc)
    res = simulate_sins(s.imu, s.motion, s.duration_s, seed=s.seed, nav=s.nav, filters=("ideal",),
                        vehicle=s.vehicle, translation=s.translation)
    assert res.stats["ideal"].horizontal_max_m < 0.01
    lon = np.degrees(res.truth_series["lon_rad"])
    assert lon.min() >= -180.0 and lon.max() < 180.0 and lon[0] > 179.0 and lon[-1] < -179.0


def test_longitude_nodes_are_made_continuous_and_wrapped_back_exactly():
    """Nodes astride the antimeridian become continuous (steps below pi), across chunks too; values away
    from a jump are left bit for bit, and the wrap back into [-pi, pi) leaves in-range values untouched."""
    a = np.array([3.1410, 3.1414, -3.1413, -3.1409])
    c = _continuous_lon(a)
    assert np.all(np.abs(np.diff(c)) < np.pi) and c[0] == a[0] and c[1] == a[1]
    assert c[2] == pytest.approx(a[2] + 2 * np.pi, abs=0)
    nxt = _continuous_lon(np.array([-3.1405, -3.1401]), prev=c[-1])
    assert abs(nxt[0] - c[-1]) < 1e-3
    inside = np.array([0.1, -1.0, 2.0])  # steps below pi: nothing to remove
    assert np.array_equal(_continuous_lon(inside, prev=0.05), inside)
    assert np.array_equal(_continuous_lon(inside), inside)
    w = c.copy()
    _wrap_lon(w)
    np.testing.assert_array_equal(w[:2], a[:2])
    assert np.all((w >= -np.pi) & (w < np.pi))
