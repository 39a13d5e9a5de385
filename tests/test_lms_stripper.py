"""Tests of the three-axis LMS dither stripper (sins_sim.filters.lms_stripper, issue 28 item 4), the pickoff triad
and nonlinearity (sins_sim.models.pickoff) and the stripper in the SINS engine, the IMU file and metrics.json.

References: the true gains are computed independently from the pickoff model's frequency response (scipy.signal.freqz
of its own coefficients), the readout's one-plant-step lag and the leaky integrator, by solving the 18 real
equations ``(E + F z_j^-1) w_j = t_j`` at the three drive frequencies (module docstring of the filter); the
single-axis baseline is sins_sim.filters.pickoff run on the same pickoff voltages in the same engine run.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from sins_sim.config.errors import ConfigError
from sins_sim.config.imu import load_imu, load_yaml
from sins_sim.filters import registry
from sins_sim.filters.lms_stripper import MU_MAX, LmsStripper, LmsStripperDesign
from sins_sim.filters.pickoff import PickoffStripper, PickoffStripperDesign
from sins_sim.models.motion import Static
from sins_sim.models.pickoff import PickoffParams, PickoffSensor, PickoffTriad, PickoffTriadParams
from sins_sim.simulation.sins import NavSettings, simulate_sins
from sins_sim.units import ARCMIN, ARCSEC
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FS = 7200.0
#: A unit whose coils see each other's axes by 2-6 % (not symmetric), with distinct gain errors.
COUPLING = ((1.0, 0.05, -0.03), (0.02, 1.0, 0.06), (-0.04, 0.03, 1.0))


def _imu(coupling=COUPLING, noise_v=5e-4, nonlinearity=0.0, settings=None):
    imu = load_imu(ROOT / "configs" / "default-imu.yaml")
    coils = tuple(PickoffParams(gain_error=ge, lag_s=2e-6, noise_v=noise_v, nonlinearity_per_rad2=nonlinearity)
                  for ge in (0.03, -0.02, 0.01))
    return dataclasses.replace(imu, pickoff=PickoffTriadParams(coils, coupling),
                               filter_settings={"lms_stripper": dict(settings or {})})


class _Baseline:
    """The single-axis pickoff stripper (sins_sim.filters.pickoff) on each axis: a three-axis plug-in for the test."""

    delay_samples = 0.0

    def __init__(self, ctx):
        self.flts = [PickoffStripper(PickoffStripperDesign(fs_hz=ctx.fs_hz, dither_hz=a.dither_hz,
                                                           scale_v_per_rad_s=s))
                     for a, s in zip(ctx.axes, ctx.pickoff_scale_v_per_rad_s)]

    def reset(self):
        for f in self.flts:
            f.reset()

    def process(self, x, volts):
        return np.stack([f.process(x[i], volts[i]) for i, f in enumerate(self.flts)])


@pytest.fixture(scope="module")
def baseline_registered():
    registry.register("pickoff_single_test", _Baseline, "test: single-axis baseline per axis", three_axis=True)
    yield "pickoff_single_test"
    registry._REGISTRY.pop("pickoff_single_test", None)
    registry.THREE_AXIS.discard("pickoff_single_test")


RUN_S = 4.0
START_S = 2.0  # residuals over [2, 4] s: after the convergence (about 1 s, measured below)


def _run(imu, filters, seed=3, chunk_s=1.0, duration=RUN_S, threads=1):
    return simulate_sins(imu, Static(), duration, seed=seed, filters=filters, chunk_s=chunk_s, threads=threads,
                         nav=NavSettings(start_s=START_S, align_s=0.0, spectrum_s=duration - START_S))


def _rms_arcsec(e):
    return np.sqrt(np.var(e, axis=0)) / ARCSEC


def true_gains(imu, design, drive_hz):
    """E, F that map the three pickoff integrals onto the counts' dither exactly at the three drive frequencies.

    Coil i reads ``sum_j C_ij delta_j`` through its response (V per rad, scipy freqz of the coil's coefficients);
    the stripper integrates it (``h / (1 - lambda z^-1)``); the readout counts ``delta`` one plant step late.
    """
    fs = imu.filter_rate_hz
    fp = imu.plant_rate_hz
    c = np.array(imu.pickoff.coupling)
    f = np.asarray(drive_hz)
    coil = np.stack([dataclasses.replace(p, rate_hz=fs).frequency_response(f) for p in imu.pickoff.coils])  # (i, j)
    w = design.integrator_response(f)[None, :] * coil * c  # w[:, j]: the integrals for a unit dither of axis j
    zinv = np.exp(-2j * math.pi * f / fs)
    t = np.exp(-2j * math.pi * f / fp)  # readout: one plant step late
    E = np.empty((3, 3))
    F = np.empty((3, 3))
    for i in range(3):
        a = np.concatenate([w.T, (w * zinv[None, :]).T], axis=1)  # rows j: [w_kj, w_kj z_j^-1] . [E_ik, F_ik]
        rhs = np.where(np.arange(3) == i, t, 0.0)
        sol = np.linalg.solve(np.concatenate([a.real, a.imag]), np.concatenate([rhs.real, rhs.imag]))
        E[i], F[i] = sol[:3], sol[3:]
    return E, F


@pytest.fixture(scope="module")
def coupled_run(baseline_registered):
    """The coupled unit (noise-free pickoffs, for the closed form) with the stripper, eq. 5, the eliminator and the
    single-axis baseline side by side."""
    return _run(_imu(noise_v=0.0), ("ideal", "correcting", "eliminator", "lms_stripper", baseline_registered))


def _reldiff(a, b):
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


# --- convergence to the true 3x3 gains ---------------------------------------------------------------------------


def test_converges_to_the_true_coupling_gains(coupled_run):
    res = coupled_run
    rep = res.filter_reports["lms_stripper"]
    d = LmsStripperDesign(fs_hz=FS)
    drive = [dr["frequency_hz"] for dr in res.drives]
    E0, F0 = true_gains(_imu(noise_v=0.0), d, drive)
    E, F = np.array(rep["E_rad_per_v_s"]), np.array(rep["F_rad_per_v_s"])
    # Tolerance 1e-3 of the largest gain, per element. With noise-free pickoffs what is left to perturb the gains is
    # the readout quantum (0.15 arcsec / sqrt(12) = 0.044 arcsec RMS against 180 arcsec of dither: 2.4e-4, averaged
    # by the adaptation over thousands of samples) and the plant's dither harmonics, which a two-tap fit at three
    # frequencies cannot follow. Measured (2026-11-27): 4e-5.
    tol = 1e-3
    assert _reldiff(E, E0) < tol and _reldiff(F, F0) < tol, (E, E0, F, F0)
    # the test can fail: the coupling moves the true gains far from the nominal start (diag(1/scale), 0), and the
    # off-diagonal gains are learned, not zero
    g0 = d.gains0
    assert _reldiff(g0[0], E0) > 50 * tol and _reldiff(g0[1], F0) > 50 * tol
    off = ~np.eye(3, dtype=bool)
    assert np.all(np.abs(E0[off]) > 0.01) and np.all(np.abs(E[off] - E0[off]) < tol * np.max(np.abs(E0)))
    # Convergence time: the slowest direction of the regressor (u_n - u_{n-1} of the lowest dither, eigenvalue
    # share (1 - cos w h) / 6 of the trace for three equal dithers; module docstring) has the NLMS time constant
    # tau = 6 / (mu (1 - cos w h)) samples; 1 % is reached within ln(100) tau after the hold.
    wh = 2.0 * math.pi * min(drive) / FS
    bound = d.hold_s + math.log(100.0) * 6.0 / (d.mu * (1.0 - math.cos(wh))) / FS
    assert 0.0 < rep["convergence_time_s"] <= bound, (rep["convergence_time_s"], bound)
    assert rep["failure"] is None and not res.diverged


# --- residual against the single-axis baseline ---------------------------------------------------------------------


@pytest.fixture(scope="module")
def noisy_runs(baseline_registered):
    """Default pickoff noise; the coupled unit and the same unit without coupling."""
    names = ("ideal", "correcting", "lms_stripper", baseline_registered)
    return {"coupled": _run(_imu(), names), "uncoupled": _run(_imu(coupling=PickoffTriadParams().coupling), names)}


def test_residual_within_the_single_axis_baseline(noisy_runs, baseline_registered):
    r = {k: {n: _rms_arcsec(res.spectra[n]) for n in ("lms_stripper", baseline_registered)}
         for k, res in noisy_runs.items()}
    lms_u, base_u = r["uncoupled"]["lms_stripper"], r["uncoupled"][baseline_registered]
    lms_c, base_c = r["coupled"]["lms_stripper"], r["coupled"][baseline_registered]
    # The stated factor is 1: the three-axis estimate contains the baseline's (E diagonal, F = 0), so once
    # converged it may not leave more, per axis, than the baseline on the unit the baseline is made for (no
    # coupling). Measured (2026-11-27): 0.13-0.16 arcsec against 3.4-4.0 (the baseline's single gain cannot follow
    # the readout's one-plant-step lag and the coil's lag; F can).
    assert np.all(lms_u <= base_u), (lms_u, base_u)
    # coupling costs the stripper nothing once learned (same pickoff noise, same seed: within 10 %), while the
    # baseline, blind to it, leaves the coupled dither (5 % of 3 arcmin)
    assert np.all(lms_c <= 1.1 * lms_u), (lms_c, lms_u)
    assert np.all(base_c > 1.5 * base_u), (base_c, base_u)
    for res in noisy_runs.values():
        assert not res.diverged
        for n in ("lms_stripper", baseline_registered):
            assert np.all(np.isfinite(res.spectra[n]))


# --- stability bound ---------------------------------------------------------------------------------------------


def test_diverges_beyond_the_bound_and_the_others_go_on():
    res = _run(_imu(settings={"mu": 2.5, "allow_unstable": True}), ("ideal", "correcting", "lms_stripper"),
               duration=3.0)
    div = res.diverged["lms_stripper"]
    # the a posteriori error grows by |1 - mu| = 1.5 per sample along each regressor: the gains pass 1000 x the
    # nominal calibration within ln(1000) / ln(1.5) = 17 adapting samples, a few ms after the 0.1 s hold
    assert 0.1 <= div["time_s"] < 0.2 and "mu = 2.5" in div["reason"], div
    assert res.filter_reports["lms_stripper"]["failure"] == div["reason"]
    assert res.filter_reports["lms_stripper"]["convergence_time_s"] is None
    assert set(res.diverged) == {"lms_stripper"}
    st = res.stats["correcting"]
    assert st.n > 0 and math.isfinite(st.last["horizontal_m"]) and np.all(np.isfinite(res.spectra["correcting"]))


def test_stable_just_inside_the_bound():
    res = _run(_imu(settings={"mu": 0.95 * MU_MAX}), ("ideal", "lms_stripper"), duration=3.0)
    assert not res.diverged and np.all(np.isfinite(res.spectra["lms_stripper"]))
    assert res.filter_reports["lms_stripper"]["failure"] is None


def test_loader_states_the_bound():
    doc = load_yaml(ROOT / "configs" / "default-imu.yaml")
    imu = load_imu(doc)
    assert imu.pickoff.coupling == ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    assert imu.filter_settings["lms_stripper"]["mu"] == 0.05
    for mu in (2.0, 2.5):
        with pytest.raises(ConfigError) as e:
            load_imu({**doc, "lms_stripper": {"mu": mu}})
        msg = str(e.value)
        assert "\n" not in msg and "lms_stripper.mu: must be in (0, 2)" in msg and repr(mu) in msg
    with pytest.raises(ConfigError, match=r"lms_stripper\.mu: must be > 0"):
        load_imu({**doc, "lms_stripper": {"mu": 0}})
    with pytest.raises(ConfigError, match=r"pickoff\.cross_coupling: condition number"):
        load_imu({**doc, "pickoff": {"cross_coupling": [[1, 1, 0], [1, 1, 0], [0, 0, 1]]}})
    with pytest.raises(ConfigError, match=r"pickoff\.cross_coupling"):
        load_imu({**doc, "pickoff": {"cross_coupling": [[1, 0], [0, 1]]}})
    got = load_imu({**doc, "pickoff": {"cross_coupling": [list(r) for r in COUPLING], "gain_error": 0.01}})
    assert got.pickoff.coupling == COUPLING and got.pickoff.coils[2].gain_error == 0.01


# --- streaming and settings --------------------------------------------------------------------------------------


def _synthetic(n=20000, seed=0, noise_v=5e-4, nl=0.0):
    """Three dithers at the default unit's resonances, coupled pickoffs, counts with a slow block motion."""
    t = np.arange(n) / FS
    f = np.array([386.0, 352.0, 421.0])
    delta = 3.0 * ARCMIN * np.sin(2.0 * math.pi * f[:, None] * t[None, :] + np.array([[0.0], [1.0], [2.0]]))
    coils = tuple(PickoffParams(gain_error=g, noise_v=noise_v, rate_hz=FS, nonlinearity_per_rad2=nl)
                  for g in (0.03, -0.02, 0.01))
    rngs = [np.random.default_rng([seed, i]) for i in range(3)]
    volts = PickoffTriad(PickoffTriadParams(coils, COUPLING), rngs).process(delta)
    x = delta + 20.0 * ARCSEC * np.sin(2.0 * math.pi * 3.0 * t)[None, :]
    return x, volts


def _pieces(n, sizes=(1, 7, 0, 3333, 2, 5000, 499, 13)):
    i, k = 0, 0
    while i < n:
        m = sizes[k % len(sizes)]
        yield i, min(n, i + m)
        i += m
        k += 1


def test_chunking_invariance():
    x, volts = _synthetic()
    d = LmsStripperDesign(fs_hz=FS, mu=0.2, history_hz=100.0)
    whole = LmsStripper(d)
    y = whole.process(x, volts)
    part = LmsStripper(d)
    y2 = np.concatenate([part.process(x[:, a:b], volts[:, a:b]) for a, b in _pieces(x.shape[1])], axis=1)
    assert_array_equal(y, y2)
    assert_array_equal(whole.gains, part.gains)
    assert_array_equal(whole.history()[1], part.history()[1])
    assert whole.convergence_time_s() == part.convergence_time_s()
    # the pickoff triad, with noise and nonlinearity, in chunks: one stream per coil
    delta = x - 20.0 * ARCSEC * np.sin(2.0 * math.pi * 3.0 * np.arange(x.shape[1]) / FS)[None, :]
    p = PickoffTriadParams(tuple(PickoffParams(noise_v=1e-3, lag_s=5e-6, rate_hz=FS, nonlinearity_per_rad2=300.0)
                                 for _ in range(3)), COUPLING)
    v1 = PickoffTriad(p, [np.random.default_rng(i) for i in range(3)]).process(delta)
    tri = PickoffTriad(p, [np.random.default_rng(i) for i in range(3)])
    v2 = np.concatenate([tri.process(delta[:, a:b]) for a, b in _pieces(delta.shape[1])], axis=1)
    assert_array_equal(v1, v2)
    # and reset() restores the start
    whole.reset()
    assert_array_equal(whole.process(x, volts), y)


def test_engine_chunking_invariance():
    imu = _imu(nonlinearity=200.0)
    a = _run(imu, ("ideal", "lms_stripper"), chunk_s=1.0, duration=2.5)
    b = _run(imu, ("ideal", "lms_stripper"), chunk_s=0.37, duration=2.5, threads=2)  # and on the threaded path
    assert_array_equal(a.spectra["lms_stripper"], b.spectra["lms_stripper"])
    assert a.filter_reports["lms_stripper"] == b.filter_reports["lms_stripper"]


@pytest.mark.parametrize("settings", [
    {"mu": 1e-3}, {"mu": 1.0}, {"mu": 1.99}, {"highpass_hz": 5.0, "leak_hz": 0.0}, {"highpass_hz": 300.0},
    {"regularisation": 0.0}, {"power_time_s": 1e-4, "hold_s": 0.0}, {"leak_hz": 4.0, "regularisation": 1.0},
    {"adapt_band": "dither", "dither_hz": (386.0, 352.0, 421.0)},
    {"adapt_band": "dither", "band_hz": 200.0, "dither_hz": (386.0, 352.0, 421.0), "mu": 1.5},
])
def test_no_nan_over_valid_settings(settings):
    x, volts = _synthetic(nl=500.0)
    s = LmsStripper(LmsStripperDesign(fs_hz=FS, **settings))
    y = s.process(x, volts)
    assert np.all(np.isfinite(y)) and s.failure is None and np.all(np.isfinite(s.gains))
    # an all-zero pickoff (a dead coil set) adapts nothing and stays finite
    s.reset()
    assert np.all(np.isfinite(s.process(x, np.zeros_like(volts))))
    assert_array_equal(s.gains, s.design.gains0)


def test_design_refuses_bad_settings():
    with pytest.raises(ValueError, match=r"lms_stripper\.mu: must be in \(0, 2\)"):
        LmsStripperDesign(mu=2.0)
    with pytest.raises(ValueError, match=r"lms_stripper\.highpass_hz"):
        LmsStripperDesign(highpass_hz=4000.0)
    with pytest.raises(ValueError, match=r"lms_stripper\.leak_hz"):
        LmsStripperDesign(leak_hz=60.0)
    with pytest.raises(ValueError, match=r"lms_stripper\.dither_hz: adapt_band 'dither' needs"):
        LmsStripperDesign(adapt_band="dither")
    with pytest.raises(ValueError, match=r"lms_stripper\.adapt_band"):
        LmsStripperDesign(adapt_band="notch")
    with pytest.raises(ValueError, match=r"lms_stripper\.volts"):
        LmsStripper(LmsStripperDesign()).process(np.zeros((3, 4)), np.zeros((2, 4)))
    with pytest.raises(ValueError, match="three-axis"):
        registry.build("lms_stripper", registry.FilterContext(f0_hz=386.0, k1=0, k2=0, k3=0, k4=0, k5=0,
                                                                fs_hz=FS, dither_hz=386.0))


# --- the kernel against a slow reference -------------------------------------------------------------------------


def _naive(x, volts, d: LmsStripperDesign):
    """The method of the module docstring, written out with numpy per sample (scipy's butter for the high-pass)."""
    from scipy import signal

    h = 1.0 / d.fs_hz
    lam = math.exp(-2.0 * math.pi * d.leak_hz * h)
    ba = ([signal.butter(2, d.highpass_hz, btype="highpass", fs=d.fs_hz)] if d.adapt_band == "highpass"
          else [signal.iirpeak(f, f / d.band_hz, fs=d.fs_hz) for f in d.dither_hz])
    kappa = min(1.0, 1.0 / (d.power_time_s * d.fs_hz))
    E, F = d.gains0[0].copy(), d.gains0[1].copy()
    u = np.zeros(3)
    up = np.zeros(3)
    uhp = np.zeros(3)
    p = 0.0
    xs = [np.zeros((3, 2)) for _ in ba]
    us = [np.zeros((3, 2)) for _ in ba]
    y = np.empty_like(x)
    for n in range(x.shape[1]):
        u = lam * u + h * volts[:, n]
        y[:, n] = x[:, n] - (E @ u + F @ up)
        xh = np.zeros(3)
        uh = np.zeros(3)
        for s, (b, a) in enumerate(ba):  # the bank's outputs summed
            yx, xs[s] = signal.lfilter(b, a, x[:, n:n + 1], axis=1, zi=xs[s])
            yu, us[s] = signal.lfilter(b, a, u[:, None], axis=1, zi=us[s])
            xh += yx[:, 0]
            uh += yu[:, 0]
        inst = uh @ uh + uhp @ uhp
        p = (1.0 - kappa) * p + kappa * inst
        if n + 1 > d.hold_s * d.fs_hz and inst + d.regularisation * p > 0.0:
            e = xh - E @ uh - F @ uhp
            g = d.mu / (inst + d.regularisation * p)
            E = E + g * np.outer(e, uh)
            F = F + g * np.outer(e, uhp)
        uhp = uh
        up = u
    return y, E, F


@pytest.mark.parametrize("band", ["highpass", "dither"])
def test_kernel_matches_the_naive_reference(band):
    x, volts = _synthetic(n=1500)
    d = LmsStripperDesign(fs_hz=FS, mu=0.5, hold_s=0.01, adapt_band=band, band_hz=20.0,
                          dither_hz=(386.0, 352.0, 421.0))
    s = LmsStripper(d)
    y = s.process(x, volts)
    y0, E0, F0 = _naive(x, volts, d)
    # same arithmetic in another order (lfilter's direct form, numpy's dot products): rounding only. The output is
    # the counts (1e-3 rad) minus an estimate of the same size: 1e-15 rad is a few ulps of it.
    np.testing.assert_allclose(y, y0, rtol=0, atol=1e-15)
    np.testing.assert_allclose(s.gains[0], E0, rtol=1e-10)
    np.testing.assert_allclose(s.gains[1], F0, rtol=1e-10, atol=1e-12)


# --- the pickoff model's nonlinearity ---------------------------------------------------------------------------


def test_pickoff_nonlinearity_integrates_to_the_cubic():
    """Sensitivity S (1 + b delta^2): the voltage's sum times h is S (delta + b delta^3 / 3) (lag 0: w = delta)."""
    b = 2000.0  # 1/rad^2: 0.5 % more sensitivity at 3 arcmin
    p = PickoffParams(gain_error=0.02, lag_s=0.0, noise_v=0.0, rate_hz=FS, nonlinearity_per_rad2=b)
    t = np.arange(4000) / FS
    delta = 3.0 * ARCMIN * np.sin(2.0 * math.pi * 386.0 * t)
    v = PickoffSensor(p).process(delta)
    integral = np.cumsum(v) / FS
    np.testing.assert_allclose(integral, p.sensitivity * (delta + b * delta ** 3 / 3.0), rtol=0, atol=1e-15)
    # with a lag, in chunks: the fundamental of the integral grows by b a^2 / 4 (sin^3 = (3 sin - sin 3) / 4) and a
    # third harmonic of b a^3 / 12 appears; least-squares amplitudes, 4000 samples = 214 whole periods of 386 Hz
    lagged = dataclasses.replace(p, lag_s=2e-6)
    sensor = PickoffSensor(lagged)
    v = np.concatenate([sensor.process(delta[i:i + 777]) for i in range(0, delta.size, 777)])
    integral = np.cumsum(v) / FS
    w = 2.0 * math.pi * 386.0 * t
    cols = np.column_stack([np.ones_like(t), np.sin(w), np.cos(w), np.sin(3 * w), np.cos(3 * w)])
    c = np.linalg.lstsq(cols, integral / lagged.sensitivity, rcond=None)[0]
    # the lagged deflection w: the lag as the model discretises it (first-order hold at 7.2 kHz: |.| = 1 - 8e-4 at
    # 386 Hz, mostly the linear interpolation between samples), its gain from scipy's freqz
    from scipy import signal

    a = 3.0 * ARCMIN * abs(signal.freqz(*lagged.lag_coefficients(), worN=[386.0], fs=FS)[1][0])
    # 1e-6 relative against a 3.8e-4 effect: the fit over whole periods is exact but for rounding and the lag's
    # phase on the third harmonic, which enters the fundamental at O(b a^2 (w lag)^2) = 1e-9
    assert math.hypot(c[1], c[2]) == pytest.approx(a * (1.0 + b * a * a / 4.0), rel=1e-6)
    assert math.hypot(c[3], c[4]) == pytest.approx(b * a ** 3 / 12.0, rel=1e-3)
    with pytest.raises(ValueError, match=r"pickoff\.cross_coupling"):
        PickoffTriadParams(coupling=((1.0, 0.0), (0.0, 1.0)))


# --- metrics.json -------------------------------------------------------------------------------------------------


def _scenario_doc(imu):
    return {"name": "lms", "seed": 1, "duration_s": 3.0, "imu": imu, "motion": [{"type": "static"}],
            "filters": ["ideal", "correcting", "lms_stripper"], "navigation": {"start_s": 1.0},
            "outputs": {"plots": False, "timeseries": False}}


def test_metrics_json_carries_the_adaptation_and_the_divergence():
    from sins_sim.config.scenario import load_scenario
    from sins_sim.jobs.run import compute_run, scenario_metrics

    doc = dict(load_yaml(ROOT / "configs" / "default-imu.yaml"))
    doc["pickoff"] = {"cross_coupling": [list(r) for r in COUPLING]}
    sc = load_scenario(_scenario_doc(doc))
    res, metrics = compute_run(sc, threads=1)
    m = metrics["filters"]["lms_stripper"]
    assert m["status"] == "ok" and m["filter_report"]["failure"] is None
    assert 0.0 < m["filter_report"]["convergence_time_s"] < 1.74  # the slow-mode bound of the convergence test
    assert np.asarray(m["filter_report"]["E_rad_per_v_s"]).shape == (3, 3)
    assert metrics["filters"]["correcting"]["status"] == "ok" and "filter_report" not in metrics["filters"]["correcting"]
    # beyond the bound (the Python API only): the same mission reports the stripper as diverged, eq. 5 as ok
    unstable = dataclasses.replace(sc.imu, filter_settings={"lms_stripper": {"mu": 2.5, "allow_unstable": True}})
    res = simulate_sins(unstable, sc.motion, sc.duration_s, seed=sc.seed, nav=sc.nav, filters=sc.filters, threads=1)
    m = scenario_metrics(res, sc)
    assert m["lms_stripper"]["status"] == "diverged" and "mu = 2.5" in m["lms_stripper"]["diverged"]["reason"]
    assert m["lms_stripper"]["filter_report"]["failure"] == m["lms_stripper"]["diverged"]["reason"]
    assert m["correcting"]["status"] == "ok" and math.isfinite(m["correcting"]["horizontal_position_error_m"]["final"])
