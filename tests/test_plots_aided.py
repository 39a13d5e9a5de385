"""Figures of a GNSS-aided run (issue 37): ``sins_sim.plots.aided``.

One short real run (straight and level at 100 m/s, 120 s, increments at 20 Hz, GNSS at 5 Hz with an outage
from 50 to 90 s, a tactical unit's constant biases and white noise from a fixed seed) feeds every figure. The
checks read the drawn artists back: the envelopes are 3 sigma of the right state in the display unit, the
errors and estimates are the data in that unit, the outage patches span the windows, the labels name their
units, and the statistics written on the panels equal an independent computation. No warning may come
from matplotlib while drawing.
"""

from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np
import pytest
from scipy.stats import chi2

matplotlib = pytest.importorskip("matplotlib")
matplotlib.use("Agg")
from matplotlib.figure import Figure  # noqa: E402

from sins_sim import earth  # noqa: E402
from sins_sim.models.motion import Cruise, Trajectory  # noqa: E402
from sins_sim.navigation import ekf  # noqa: E402
from sins_sim.navigation.aided import navigate_aided, outage_growth, smooth  # noqa: E402
from sins_sim.navigation.attitude import quat_from_rotvec, quat_multiply  # noqa: E402
from sins_sim.navigation.gnss import GnssSettings, simulate_gnss  # noqa: E402
from sins_sim.plots import aided as pa  # noqa: E402
from sins_sim.simulation.external import ideal_increments  # noqa: E402
from sins_sim.units import ARCMIN, ARCSEC, DEG_PER_H, MICRO_G  # noqa: E402

DT = 0.05
DURATION = 120.0
OUTAGE = (50.0, 90.0)
AFTER = (5.0, 10.0, 20.0, 39.0)
NOISE = ekf.ImuNoise.from_datasheet(0.05, 50.0, 1.0, 500.0)
P0 = ekf.initial_covariance(2.0, 0.1, 2e-4, 5e-3, NOISE)


@pytest.fixture(scope="module")
def run():
    """The run, its errors against the truth at its epochs, the true biases and the outage growth."""
    traj = Trajectory(math.radians(45.0), math.radians(10.0), 1000.0, 100.0, math.radians(30.0), [Cruise(DURATION)])
    n = round(DURATION / DT)
    t = DT * np.arange(1, n + 1)
    dth, dv = ideal_increments(traj, t)
    tt = np.concatenate([[0.0], t])
    tr = traj.evaluate(tt)
    rng = np.random.default_rng(37)
    bg = rng.normal(0.0, NOISE.gyro_bias_sigma_rad_s, 3)
    ba = rng.normal(0.0, NOISE.accel_bias_sigma_m_s2, 3)
    dth = dth + bg * DT + rng.normal(0.0, NOISE.gyro_arw_rad_sqrt_s * math.sqrt(DT), (n, 3))
    dv = dv + ba * DT + rng.normal(0.0, NOISE.accel_vrw_m_s_sqrt_s * math.sqrt(DT), (n, 3))
    x0 = rng.multivariate_normal(np.zeros(ekf.N_STATES), P0)
    lat, h = float(tr.lat_rad[0]), float(tr.h_m[0])
    r_n, r_e = earth.radii(lat)
    start = ekf.NavState(0.0, lat + x0[0] / (r_n + h), tr.lon_rad[0] + x0[1] / ((r_e + h) * math.cos(lat)), h - x0[2],
                         tr.v_ned_m_s[0] + x0[3:6], quat_multiply(quat_from_rotvec(x0[6:9]), tr.q_nv[0]),
                         bg + x0[9:12], ba + x0[12:15])
    settings = GnssSettings(rate_hz=5.0, position_sigma_m=2.0, velocity_sigma_m_s=0.1, outages_s=[OUTAGE])
    fixes = simulate_gnss(tt, tr.lat_rad, tr.lon_rad, tr.h_m, tr.v_ned_m_s, settings, rng)
    t_a = OUTAGE[0] - 0.2                      # the last fix before the outage is valid (and applied) there
    out_t = np.union1d(np.arange(0.0, DURATION + 0.5, 1.0), t_a + np.array(AFTER))
    res = navigate_aided(t, dth, dv, start, NOISE, P0, fixes, output_t_s=out_t)
    te = traj.evaluate(res.t_s)
    err = res.errors(te.lat_rad, te.lon_rad, te.h_m, te.v_ned_m_s, te.q_nv)
    growth = outage_growth(res, settings.outages_s, after_s=AFTER, errors=err)
    return res, err, bg, ba, growth


@pytest.fixture(autouse=True)
def _no_warnings_and_closed_figures():
    import matplotlib.pyplot as plt

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        yield
    plt.close("all")


def _by_gid(fig, gid):
    found = [a for ax in fig.axes for a in (*ax.lines, *ax.patches, *ax.collections) if a.get_gid() == gid]
    assert len(found) == 1, (gid, len(found))
    return found[0]


def _axis_of(fig, artist):
    return next(ax for ax in fig.axes if artist in (*ax.lines, *ax.patches, *ax.collections))


def _outage_spans(ax):
    """(x0, x1) in data units of the outage patches of an axes (``axvspan``: data x, axes y)."""
    spans = []
    for p in ax.patches:
        if (p.get_gid() or "").startswith("outage_"):
            x = p.get_patch_transform().transform(p.get_path().vertices)[:, 0]     # rectangle corners, data x
            spans.append((float(np.min(x)), float(np.max(x))))
    return spans


def test_error_figure_envelopes_are_3_sigma_in_display_units_and_errors_on_top(run):
    res, err, *_ = run
    fig = pa.aided_error_figure(res, err, [OUTAGE], title="")
    assert isinstance(fig, Figure) and len(fig.axes) == 9
    for col, name in enumerate(ekf.STATE_NAMES[:9]):
        upper = _by_gid(fig, f"sigma3_{name}_upper")
        ax = _axis_of(fig, upper)
        label = ax.get_ylabel()
        unit = label[label.rindex("(") + 1:-1]
        scale = {"m": 1.0, "m/s": 1.0, "arcsec": ARCSEC, "arcmin": ARCMIN}[unit]
        assert unit == ("m" if col < 3 else "m/s" if col < 6 else unit)
        # K < 2 MAX_BINS: every epoch drawn, the envelope exactly 3 sigma of this state in the axis unit
        assert np.allclose(upper.get_ydata(), 3.0 * res.sigma[:, col] / scale, rtol=1e-12, atol=0.0)
        assert np.allclose(_by_gid(fig, f"sigma3_{name}_lower").get_ydata(), -3.0 * res.sigma[:, col] / scale)
        line = _by_gid(fig, f"error_{name}")
        assert np.array_equal(line.get_xdata(), res.t_s)
        assert np.allclose(line.get_ydata(), err[:, col] / scale, rtol=1e-12, atol=0.0)
        assert line.get_zorder() > upper.get_zorder()                   # the error is drawn over its envelope
        # the share written on the panel, computed independently
        share = 100.0 * np.mean(np.abs(err[:, col]) <= 3.0 * res.sigma[:, col])
        assert f"at {share:.1f} % of {len(res)} epochs" in ax.get_title()
        assert _outage_spans(ax) == [pytest.approx(OUTAGE, abs=1e-9)]
        assert ax.get_xlabel() in ("time (s)", "")
    # the heading starts at 5e-3 rad x 3 = 52 arcmin: drawn in arcmin; a tilt at 2e-4 x 3 = 124 arcsec: in arcsec
    assert "(arcmin)" in _axis_of(fig, _by_gid(fig, "sigma3_psi_d_rad_upper")).get_ylabel()
    assert "(arcsec)" in _axis_of(fig, _by_gid(fig, "sigma3_psi_n_rad_upper")).get_ylabel()
    texts = [t.get_text() for t in fig.legends[0].get_texts()]
    assert "GNSS outage 50-90 s" in texts and "error (computed - true)" in texts
    assert "no truth" not in fig._suptitle.get_text()


def test_error_figure_without_truth_draws_the_envelope_only_and_says_so(run):
    res = run[0]
    sm = smooth(res)
    fig = pa.aided_error_figure(sm, outages_s=[OUTAGE])
    assert "no truth given" in fig._suptitle.get_text() and "Smoothed" in fig._suptitle.get_text()
    assert not any((ln.get_gid() or "").startswith("error_") for ax in fig.axes for ln in ax.lines)
    assert np.allclose(_by_gid(fig, "sigma3_dv_e_m_s_upper").get_ydata(), 3.0 * sm.sigma[:, 4])


def test_bias_figure_in_deg_h_and_ug_with_the_band_around_the_estimate_and_the_truth(run):
    res, _, bg, ba, _ = run
    fig = pa.bias_figure(res, bg, ba, outages_s=[OUTAGE])
    assert len(fig.axes) == 6
    for c, ax_name in enumerate("xyz"):
        for kind, est, truth, block, scale, unit in (
                ("gyro", res.gyro_bias_rad_s, bg, ekf.GYRO_BIAS, DEG_PER_H, "deg/h"),
                ("accel", res.accel_bias_m_s2, ba, ekf.ACCEL_BIAS, MICRO_G, "ug")):
            col = block.start + c
            line = _by_gid(fig, f"estimate_{kind}_{ax_name}")
            ax = _axis_of(fig, line)
            assert ax.get_ylabel() == f"{kind} bias body {ax_name} ({unit})"
            assert np.allclose(line.get_ydata(), est[:, c] / scale, rtol=1e-12, atol=0.0)
            upper = _by_gid(fig, f"sigma3_{ekf.STATE_NAMES[col]}_upper")
            assert np.allclose(upper.get_ydata(), (est[:, c] + 3.0 * res.sigma[:, col]) / scale, rtol=1e-12, atol=0.0)
            true_line = _by_gid(fig, f"true_{kind}_{ax_name}")
            assert np.allclose(true_line.get_ydata(), truth[c] / scale)
            assert f"true {truth[c] / scale:.3g}, final {est[-1, c] / scale:.3g}" in ax.get_title()
            assert _outage_spans(ax) == [pytest.approx(OUTAGE, abs=1e-9)]
    # a time-varying truth is drawn as a line through its values
    drift = np.outer(np.linspace(0.0, 1.0, len(res)), bg) + bg
    fig = pa.bias_figure(res, true_gyro_bias_rad_s=drift)
    assert np.allclose(_by_gid(fig, "true_gyro_y").get_ydata(), drift[:, 1] / DEG_PER_H)
    assert "no true biases" not in fig._suptitle.get_text()
    assert "no true biases given" in pa.bias_figure(res)._suptitle.get_text()


def test_outage_growth_figure_measured_markers_and_the_predicted_sigma(run):
    res, _, _, _, growth = run
    g = growth[0]
    assert np.all(np.isfinite(g.error_m)) and np.all(np.isfinite(g.predicted_sigma_m))
    fig = pa.outage_growth_figure(growth)
    meas = _by_gid(fig, "measured")
    assert np.array_equal(meas.get_xdata(), g.after_s) and np.array_equal(meas.get_ydata(), g.error_m)
    assert np.array_equal(_by_gid(fig, "predicted_1sigma").get_ydata(), g.predicted_sigma_m)
    assert np.allclose(_by_gid(fig, "predicted_3sigma").get_ydata(), 3.0 * g.predicted_sigma_m)
    assert np.allclose(_by_gid(fig, "ratio").get_ydata(), g.error_m / g.predicted_sigma_m)
    ax = _axis_of(fig, meas)
    assert ax.get_ylabel() == "horizontal position error (m)" and "50-90 s" in ax.get_title()
    # with the run: the dense prediction from every epoch's P of the outage passes through the read values
    fig = pa.outage_growth_figure(growth, result=res)
    dense = _by_gid(fig, "predicted_1sigma")
    x, y = dense.get_xdata(), dense.get_ydata()
    assert x[0] == 0.0 and x[-1] < OUTAGE[1] - OUTAGE[0] + 0.2 + 1e-9             # from t_a to before the next fix
    for tau, s in zip(g.after_s, g.predicted_sigma_m):
        k = int(np.argmin(np.abs(x - tau)))
        assert abs(x[k] - tau) < 1e-9 and y[k] == pytest.approx(s, rel=1e-12)
    k_a = int(np.flatnonzero(res.t_s == g.t_last_update_s)[0])
    assert y[0] == pytest.approx(math.sqrt(res.p_upd[k_a, 0, 0] + res.p_upd[k_a, 1, 1]), rel=1e-12)   # after the fix
    # 40 s without a fix, far below the Schuler period (84 min): the sigma only grows
    assert np.all(np.diff(y) > 0.0)
    # no truth: prediction only, said in the title
    bare = [dataclasses.replace(g, error_m=np.full_like(g.error_m, np.nan))]
    fig = pa.outage_growth_figure(bare)
    assert "no truth given" in fig._suptitle.get_text() and len(fig.axes) == 1


def test_innovation_figure_normalised_innovations_and_nis_bounds(run):
    res = run[0]
    window = 20
    fig = pa.innovation_figure(res, window=window, outages_s=[OUTAGE])
    assert len(fig.axes) == 3
    for name in ("position", "velocity"):
        sel = res.innovation_name == name
        z = res.innovation[sel] / res.innovation_sigma[sel]
        for c in range(3):
            pts = _by_gid(fig, f"nu_{name}_{c}")
            assert np.allclose(pts.get_ydata(), z[:, c], rtol=1e-12, atol=0.0)
        ax = _axis_of(fig, pts)
        assert sorted(ln.get_ydata()[0] for ln in ax.lines if ln.get_linestyle() == "--") == [-3.0, 3.0]
        assert _outage_spans(ax) == [pytest.approx(OUTAGE, abs=1e-9)]
        # NIS window means: whole windows before the outage, a break, whole windows after; none across the gap
        nis, t = res.nis[sel], res.innovation_t_s[sel]
        before, after = t < OUTAGE[0], t >= OUTAGE[1]
        assert before.sum() + after.sum() == sel.sum()
        def whole(x):
            return x[:(x.size // window) * window].reshape(-1, window).mean(axis=1)

        want = np.concatenate([whole(nis[before]), [np.nan], whole(nis[after])])
        got = _by_gid(fig, f"nis_{name}").get_ydata()
        assert np.allclose(got, want, equal_nan=True, rtol=1e-12, atol=0.0)
    band = [p for p in fig.axes[-1].patches if not (p.get_gid() or "").startswith("outage_")]
    assert len(band) == 1
    lo, hi = chi2.ppf([0.025, 0.975], 3 * window) / window
    y = band[0].get_patch_transform().transform(band[0].get_path().vertices)[:, 1]      # axhspan: data y
    ylo, yhi = float(np.min(y)), float(np.max(y))
    assert (ylo, yhi) == (pytest.approx(lo, rel=1e-12), pytest.approx(hi, rel=1e-12))
    assert f"{lo:.2f}-{hi:.2f}" in " ".join(t.get_text() for t in fig.axes[-1].get_legend().get_texts())


def test_long_records_are_decimated_by_min_max_without_losing_a_peak(run):
    """A record of 30 000 epochs (synthetic, from the run's first row): the error drawn keeps every bin's smallest
    and largest value, so a one-epoch spike survives, and at most 2 MAX_BINS points are drawn per curve; the
    envelope keeps each bin's largest sigma, so it never falls below the data's 3 sigma by more than a bin's
    change."""
    res = run[0]
    k = 30_000
    t = np.linspace(0.0, 3000.0, k)
    rng = np.random.default_rng(1)
    err = rng.normal(0.0, 1.0, (k, 9))
    err[12_345, 0] = 50.0                                   # one spike
    sigma = np.tile(res.sigma[-1], (k, 1)) * (1.0 + 0.5 * np.sin(t / 100.0))[:, None]
    big = dataclasses.replace(res, t_s=t, sigma=sigma, updated=np.zeros(k, bool), t_valid_s=np.full(k, np.nan),
                              lat_rad=np.full(k, res.lat_rad[0]))
    fig = pa.aided_error_figure(big, err)
    line = _by_gid(fig, "error_dpos_n_m")
    assert line.get_xdata().size <= 2 * pa.MAX_BINS
    assert line.get_ydata().max() == 50.0 and line.get_ydata().min() == err[:, 0].min()
    assert "time (min)" in fig.axes[-1].get_xlabel()
    upper = _by_gid(fig, "sigma3_dpos_n_m_upper")
    assert upper.get_xdata().size <= pa.MAX_BINS
    # each drawn envelope point is a bin's largest 3 sigma: an epoch of the data at a time of the data
    tm = t / 60.0
    idx = np.searchsorted(tm, upper.get_xdata())
    assert np.allclose(upper.get_ydata(), 3.0 * sigma[idx, 0], rtol=1e-12, atol=0.0)


def test_minmax_decimate_keeps_every_bins_extremes():
    """Against an independent reshape: t = 0, 1, ..., 10 000 in 100 bins of 100 (the last sample closes the last
    bin)."""
    rng = np.random.default_rng(5)
    t = np.arange(10_001, dtype=float)
    y = rng.normal(size=t.size)
    td, yd = pa.minmax_decimate(t, y, max_bins=100)
    bins = [y[100 * j:100 * (j + 1)] for j in range(99)] + [y[9_900:]]
    assert np.array_equal(yd, np.concatenate([[s.min(), s.max()][::1 if s.argmin() < s.argmax() else -1]
                                              for s in bins]))
    assert np.all(np.diff(td) > 0.0)                          # in time order, a subset of the samples
    assert np.array_equal(y[td.astype(int)], yd)
    short = np.arange(10.0)
    assert np.array_equal(pa.minmax_decimate(short, short, max_bins=5)[1], short)   # <= 2 bins' worth: unchanged


@pytest.mark.parametrize("call, match", [
    (lambda r: pa.aided_error_figure(object()), r"^result: must be an AidedResult or a SmoothedResult"),
    (lambda r: pa.aided_error_figure(r[0], np.zeros((3, 9))), r"^truth_errors: must be a finite array of shape"),
    (lambda r: pa.aided_error_figure(r[0], r[1][:, :6]), r"^truth_errors: .*got shape \(\d+, 6\)"),
    (lambda r: pa.aided_error_figure(r[0], outages_s=[(90.0, 50.0)]), r"^outages_s\[0\]: must be a \(start, end\)"),
    (lambda r: pa.aided_error_figure(r[0], outages_s=5.0), r"^outages_s: must be a sequence"),
    (lambda r: pa.bias_figure(r[0], np.zeros(2)), r"^true_gyro_bias_rad_s: must be a finite array of shape"),
    (lambda r: pa.bias_figure(r[0], None, [0.0, np.nan, 0.0]), r"^true_accel_bias_m_s2: must be a finite"),
    (lambda r: pa.outage_growth_figure([]), r"^growths: must hold at least one OutageGrowth"),
    (lambda r: pa.outage_growth_figure([r[4][0], "x"]), r"^growths\[1\]: must be an OutageGrowth"),
    (lambda r: pa.outage_growth_figure(r[4], result=smooth(r[0])), r"^result: must be the AidedResult"),
    (lambda r: pa.innovation_figure(r[0], window=0), r"^window: must be an integer >= 1"),
    (lambda r: pa.innovation_figure(smooth(r[0])), r"^result: must be an AidedResult"),
    (lambda r: pa.minmax_decimate(np.arange(3.0), np.arange(4.0)), r"^y: must have the shape of t"),
])
def test_bad_input_gives_one_clear_line(run, call, match):
    with pytest.raises(ValueError, match=match) as info:
        call(run)
    assert "\n" not in str(info.value)


def test_figures_are_written_to_a_path(run, tmp_path):
    res, err, bg, ba, growth = run
    paths = [tmp_path / f"{n}.png" for n in ("error", "bias", "growth", "innovation")]
    pa.aided_error_figure(res, err, [OUTAGE], path=paths[0])
    pa.bias_figure(res, bg, ba, path=paths[1])
    pa.outage_growth_figure(growth, result=res, path=paths[2])
    pa.innovation_figure(res, path=paths[3])
    for p in paths:
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and p.stat().st_size > 20_000
