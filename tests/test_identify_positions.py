"""``sins-sim identify --positions``: a six-position log of known accelerometer bias, scale factor and misalignment
and gyro bias and g-sensitivity.

The log is made here from the error models (Groves 2013, sec. 4.4.6): in a still position with body unit vector
``u`` up, the true specific force is ``g u`` and the true rate the Earth's ``C_bn w_ie^n`` (Titterton and Weston
2004, sec. 10.2), ``m_f = b_a + (I + E_a) g u + n`` and ``m_w = b_g + C_bn w_ie + G g u + n``; white noise of
density ``N`` has the per-sample sigma ``N / sqrt(dt)`` (IEEE Std 952-1997, Annex C). Between positions the unit
turns for 5 s (a rate of 18 deg/s, the force swinging between the two faces).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import norm

from sins_sim.config.errors import ConfigError
from sins_sim.earth import earth_rate_ned, gravity_down
from sins_sim.jobs.identify import identify_positions
from sins_sim.jobs.import_log import write_log_table
from sins_sim.units import ARCSEC, DEG, DEG_PER_H, MICRO_G

LAT, H_M = math.radians(48.0), 100.0
DT = 0.01
HOLD_S, TURN_S = 60.0, 5.0
FACES = ((0, 1), (0, -1), (1, 1), (1, -1), (2, 1), (2, -1))
B_A = np.array([200.0, -150.0, 300.0]) * MICRO_G
E_A = np.array([[300e-6, 50 * ARCSEC, -30 * ARCSEC],
                [-40 * ARCSEC, -200e-6, 20 * ARCSEC],
                [10 * ARCSEC, 60 * ARCSEC, 100e-6]])
B_G = np.array([1.0, -0.5, 2.0]) * DEG_PER_H
#: g-sensitivity (rad/s per m/s^2): 2, -1.5, 3 deg/h/g on the diagonal, cross terms 0.5 deg/h/g.
G_SENS = (np.diag([2.0, -1.5, 3.0]) + 0.5 * (1 - np.eye(3))) * DEG_PER_H / 9.80665
VRW = 50.0 * MICRO_G                     # m/s^2/sqrt(Hz)
ARW = 0.05 * DEG / 60.0                  # rad/sqrt(s)


def _c_nb(axis: int, sign: int, heading: float) -> np.ndarray:
    """A body attitude with body ``axis`` up (``sign`` +1) or down, turned by ``heading`` about the vertical."""
    up_b = sign * np.eye(3)[axis]
    a = np.eye(3)[(axis + 1) % 3]                               # a body axis across the vertical one
    # rows of C_bn: the body axes in NED; build NED axes in body: down = -up_b, north = a turned by heading
    d_b = -up_b
    e1 = a
    e2 = np.cross(d_b, e1)
    n_b = math.cos(heading) * e1 + math.sin(heading) * e2
    e_b = np.cross(d_b, n_b)
    return np.stack([n_b, e_b, d_b])                            # C_nb: rows N, E, D in body components


def six_position_log(path, seed):
    rng = np.random.default_rng(seed)
    g = gravity_down(LAT, H_M)
    w_n = earth_rate_ned(LAT)
    t_rows, dth_rows, dv_rows = [], [], []
    prev_f = None
    for k, (axis, sign) in enumerate(FACES):
        c_nb = _c_nb(axis, sign, 0.7 * k + 0.3)
        f = c_nb.T @ np.array([0.0, 0.0, -g])
        w = c_nb.T @ w_n
        if prev_f is not None:                                   # the turn: 18 deg/s about body x, force swinging
            m = int(TURN_S / DT)
            s = np.linspace(0.0, 1.0, m)[:, None]
            dth_rows.append(np.tile([18.0 * DEG * DT, 0.0, 0.0], (m, 1)))
            dv_rows.append(((1 - s) * prev_f + s * f) * DT)
        n = int(HOLD_S / DT)
        f_m = B_A + (np.eye(3) + E_A) @ f
        w_m = B_G + w + G_SENS @ f
        dv_rows.append(np.tile(f_m * DT, (n, 1)) + rng.standard_normal((n, 3)) * VRW * math.sqrt(DT))
        dth_rows.append(np.tile(w_m * DT, (n, 1)) + rng.standard_normal((n, 3)) * ARW * math.sqrt(DT))
        prev_f = f
    dth, dv = np.vstack(dth_rows), np.vstack(dv_rows)
    t = np.arange(1, dth.shape[0] + 1) * DT
    write_log_table(path, t, dth, dv, {"site": {"lat_rad": LAT, "lon_rad": 0.0, "height_m": H_M}})
    return path


def test_six_positions_recovered_within_sigma(tmp_path):
    log = six_position_log(tmp_path / "six.parquet", 4)
    r = identify_positions(log, "auto", tmp_path / "out")
    pf = r["positions_fit"]
    assert [p["up"] for p in pf["positions"]] == ["+x", "-x", "+y", "-y", "+z", "-z"]
    acc, gy = pf["accelerometer"], pf["gyro"]
    per_g = 9.80665 / DEG_PER_H * (gravity_down(LAT, H_M) / 9.80665)
    truth = ([(acc["bias_ug"][a], B_A[i] / MICRO_G) for i, a in enumerate("xyz")]
             + [(acc["scale_factor_ppm"][a], E_A[i, i] * 1e6) for i, a in enumerate("xyz")]
             + [(acc["misalignment_arcsec"][a + b], E_A[i, j] / ARCSEC) for i, a in enumerate("xyz")
                for j, b in enumerate("xyz") if i != j]
             + [(gy["bias_deg_h"][a], B_G[i] / DEG_PER_H) for i, a in enumerate("xyz")]
             + [(gy["g_sensitivity_deg_h_per_g"][a + a], G_SENS[i, i] * per_g) for i, a in enumerate("xyz")])
    # 18 quantities, each estimate normal about the truth with its stated sigma: all inside the two-sided
    # 1 % family-wise band (Bonferroni, z = 3.45) when the sigmas are right
    z_max = norm.ppf(1.0 - 0.01 / (2 * len(truth)))
    z = [(e["value"] - want) / e["sigma"] for e, want in truth]
    assert max(abs(x) for x in z) < z_max, z
    # and the sigmas are not inflated to pass: the RMS z over 18 is within the chi-square 99 % interval
    from scipy.stats import chi2
    rms2 = float(np.mean(np.square(z)))
    assert chi2.ppf(0.005, len(z)) / len(z) < rms2 < chi2.ppf(0.995, len(z)) / len(z)
    assert all("not observable" in gy["g_sensitivity_deg_h_per_g"][k]["status"] for k in ("xy", "xz", "yx", "yz",
                                                                                             "zx", "zy"))
    text = (tmp_path / "out" / "imu-sensors.yaml").read_text()
    assert "scale_factor_ppm: [" in text and "misalignment_arcsec: [" in text and "G_xx:" in text


def test_given_positions_and_a_missing_pair(tmp_path):
    """Positions given in a file; with the -z face left out, column z of E_a and the z gyro terms are not
    excited (never a number); a file whose 'up' contradicts the log is refused."""
    log = six_position_log(tmp_path / "six.parquet", 5)
    step = HOLD_S + TURN_S
    rows = [(k * step + 2.0, k * step + HOLD_S - 2.0, f"{'+' if s > 0 else '-'}{'xyz'[a]}")
            for k, (a, s) in enumerate(FACES)]
    seg = tmp_path / "pos.csv"
    seg.write_text("start_s,end_s,up\n" + "\n".join(f"{a},{b},{u}" for a, b, u in rows[:5]) + "\n")
    r = identify_positions(log, seg)
    pf = r["positions_fit"]
    assert pf["accelerometer"]["scale_factor_ppm"]["z"]["status"] == "not excited"
    assert pf["accelerometer"]["misalignment_arcsec"]["xz"]["status"] == "not excited"
    assert "value" in pf["accelerometer"]["scale_factor_ppm"]["x"]
    assert "value" not in pf["gyro"]["g_sensitivity_deg_h_per_g"]["zz"]
    bad = tmp_path / "bad.csv"
    bad.write_text(f"start_s,end_s,up\n{rows[0][0]},{rows[0][1]},-x\n{rows[1][0]},{rows[1][1]},-x\n")
    with pytest.raises(ConfigError, match="has \\+x up in the log, the file says -x"):
        identify_positions(log, bad)
