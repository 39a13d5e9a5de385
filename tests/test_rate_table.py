"""Gyro scale factors and misalignments from a simulated rate-table log (reversal pairs about each axis).

The log is made here from the model itself, independently of the fit: the body turns about body axis ``a`` at a
constant table rate ``W`` from a level, north-facing start, so ``C_nb(t) = R_a(W t)`` and the Earth's rate in body
axes is ``C_nb(t)^T w_ie^n`` (taken at each interval's middle: the error, of order ``(W dt)^2 / 24`` of it, is
1e-6 of the Earth's rate); the measured rate is ``(I + E) w + b + earth + white noise`` (Groves 2013, sec. 4.4.6).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sins_sim.earth import earth_rate_ned
from sins_sim.navigation.rate_table import fit_rate_table
from sins_sim.units import ARCSEC, DEG, DEG_PER_H

LAT = math.radians(45.0)
FS = 100.0
DT = 1.0 / FS
N_SI = 0.003 * DEG / 60.0                     # ARW 0.003 deg/sqrt(h)
SF_PPM = np.array([120.0, -60.0, 35.0])
MIS_ARCSEC = {"xy": 20.0, "xz": -10.0, "yx": 5.0, "yz": 15.0, "zx": -8.0, "zy": 12.0}


def _rot(axis: int, angle: np.ndarray) -> np.ndarray:
    """Rotation matrices (M, 3, 3) about a body axis by ``angle`` (rad): body to the table's base frame."""
    c, s = np.cos(angle), np.sin(angle)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    r = np.zeros((angle.size, 3, 3))
    r[:, axis, axis] = 1.0
    r[:, i, i], r[:, j, j] = c, c
    r[:, i, j], r[:, j, i] = -s, s
    return r


def table_log(seed: int, rate_deg_s: float, seconds: float, axes=(0, 1, 2)):
    rng = np.random.default_rng(seed)
    e = np.diag(SF_PPM * 1e-6)
    for key, val in MIS_ARCSEC.items():
        e["xyz".index(key[0]), "xyz".index(key[1])] = val * ARCSEC
    bias = np.array([0.01, -0.02, 0.015]) * DEG_PER_H
    w_ie = earth_rate_ned(LAT)
    n_seg = int(seconds * FS)
    chunks, segments, t0 = [], [], 0.0
    for axis in axes:
        for sign in (1.0, -1.0):
            w = sign * math.radians(rate_deg_s)
            t_mid = (np.arange(n_seg) + 0.5) * DT
            c_nb = _rot(axis, w * t_mid)                        # base = NED (level, facing north)
            earth = np.einsum("kji,j->ki", c_nb, w_ie)          # C_nb^T w_ie
            true = np.zeros((n_seg, 3))
            true[:, axis] = w
            meas = true @ (np.eye(3) + e).T + bias + earth + rng.standard_normal((n_seg, 3)) * N_SI * math.sqrt(FS)
            chunks.append(meas * DT)
            segments.append((t0, t0 + seconds, axis, w))
            t0 += seconds
    dth = np.vstack(chunks)
    return np.arange(1, dth.shape[0] + 1) * DT, dth, segments, e


def test_scale_factors_and_misalignments_within_three_sigma():
    # whole revolutions (36 s at 10 deg/s): the Earth's rate across the axis averages out exactly (the module's
    # bound 2 |sin(Theta / 2)| / Theta is 0 at Theta = 2 pi); each entry's sigma is then the noise of two 36-s means
    # over 2 W, N / sqrt(36 s) sqrt(2) / (2 W) = 8.7e-7 / 6 * 1.41 / 0.349 = 5.9e-7 (0.59 ppm, 0.12 arcsec)
    t, dth, segments, e = table_log(3, 10.0, 36.0)
    fit = fit_rate_table(t, dth, segments)
    assert fit.excited == (True, True, True)
    z = (fit.e_matrix - e) / fit.sigma
    assert np.all(np.abs(z) <= 3.0), z
    d = fit.to_dict()
    assert d["scale_factor_ppm"]["x"]["value"] == pytest.approx(SF_PPM[0], abs=3.0 * d["scale_factor_ppm"]["x"]["sigma"])
    assert d["misalignment_arcsec"]["yz"]["value"] == pytest.approx(15.0, abs=3.0 * d["misalignment_arcsec"]["yz"]["sigma"])
    # informative: the scale factor to about a ppm, the misalignments to under an arcsec
    assert np.all(np.diag(fit.sigma) < 1.5e-6) and np.all(fit.sigma < 1.0 * ARCSEC)


def test_only_the_excited_columns_are_reported():
    # a table turning about x alone excites column x (S_x, M_yx, M_zx); the rest is not excited, never a number
    t, dth, segments, _ = table_log(4, 10.0, 36.0, axes=(0,))
    d = fit_rate_table(t, dth, segments).to_dict()
    assert "value" in d["scale_factor_ppm"]["x"] and "value" in d["misalignment_arcsec"]["yx"]
    for key in ("y", "z"):
        assert d["scale_factor_ppm"][key] == {"status": "not excited"}
    for key in ("xy", "xz", "yz", "zy"):
        assert d["misalignment_arcsec"][key] == {"status": "not excited"}


def test_a_part_turn_is_covered_by_the_earth_bound():
    # 25 s at 10 deg/s: 250 deg, not a whole turn. The Earth's rate across the axis leaves 2 sin(125 deg) / 4.36 =
    # 0.38 of itself in each mean (about 2.7e-5 rad/s, 80 arcsec over 2 W); the sigma takes it as a uniform error of
    # that bound, so the truth stays within 3 sigma (the residual's projection is at most the bound, sqrt 3 sigma)
    t, dth, segments, e = table_log(5, 10.0, 25.0)
    fit = fit_rate_table(t, dth, segments)
    assert np.all(np.abs((fit.e_matrix - e) / fit.sigma) <= 3.0)


def test_bad_segment_is_one_line():
    t, dth, segments, _ = table_log(6, 10.0, 1.0, axes=(0,))
    with pytest.raises(ValueError, match=r"^segments\[0\]: axis must be 0, 1 or 2"):
        fit_rate_table(t, dth, [(0.0, 1.0, 3, 0.1)])


def test_cli_rate_table_writes_the_terms(tmp_path, capsys):
    import json

    from sins_sim.cli import EXIT_OK, EXIT_USAGE, main
    from sins_sim.jobs.import_log import write_log_table

    t, dth, segments, e = table_log(7, 10.0, 36.0)
    log = tmp_path / "table.parquet"
    write_log_table(log, t, dth, np.zeros_like(dth), {})
    seg = tmp_path / "segments.csv"
    seg.write_text("start_s,end_s,axis,rate_deg_s\n" + "".join(
        f"{a:.6g},{b:.6g},{'xyz'[ax]},{math.degrees(w):.12g}\n" for a, b, ax, w in segments))
    out = tmp_path / "fit"
    assert main(["identify", str(log), "--out", str(out), "--rate-table", str(seg)]) == EXIT_OK
    m = json.loads((out / "metrics.json").read_text())
    s_z = m["motion_terms"]["scale_factor_ppm"]["z"]
    assert abs(s_z["value"] - SF_PPM[2]) <= 3.0 * s_z["sigma"]
    assert "gyro scale_factor_ppm" in capsys.readouterr().out
    seg.write_text("start_s,end_s,axis,rate_deg_s\n0,36,w,10\n")
    assert main(["identify", str(log), "--out", str(tmp_path / "bad"), "--rate-table", str(seg)]) == EXIT_USAGE
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "line 2: axis must be x, y or z" in err[0]
