"""vibration.spec: a sine-on-random specification, its closed-form g_rms, the simulated vibration against it, and
the scenario's checks (one line naming the key).

The simulated record is the specification resolved to the existing models (LinearRandomVibration for the
background, LinearSines for the lines), sampled at 7200 Hz for 60 s. Tolerances come from the statistics of the
estimates, not from a run:

* mean square of a record of length T of a Gaussian process with one-sided PSD G: its variance is
  ``(1/T) integral G^2 df`` (Bendat & Piersol, *Random Data*, 4th ed., 2010, ch. 8, the random error of a
  mean-square estimate: ``1 / (B T)`` relative variance for band-limited white noise), plus for each line of peak
  ``a`` the cross term ``a^2 G(f_line) / T`` (the variance of ``(2a/T) integral x sin(wt) dt``); the test
  allows 5 sigma (two-sided false alarm 6e-7), and the generator's interpolation images (``image_level_db``,
  about -106 dB) on top;
* Welch PSD with a Hann window, 50 % overlap, K segments: ``nu G_hat / G`` is chi-square with
  ``nu = 2K / (1 + 2 c^2)`` degrees of freedom, ``c = 0.167`` the correlation of overlapping Hann segments
  (Welch 1967; Harris 1978, Table 1); each bin within the chi-square quantiles at a false-alarm
  probability of 1e-3 shared over all bins tested (Bonferroni), widened by the generator's 0.02 dB in-band
  deviation from the table (sins_sim.models.motion.vibration, "Normalisation").
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy import integrate, signal, stats

from sins_sim.config.errors import ConfigError
from sins_sim.config.scenario import load_scenario
from sins_sim.jobs.run import _spec_lines
from sins_sim.models.motion import STANDARD_GRAVITY
from sins_sim.models.vibration_spec import AxisSpec, SineOnRandomSpec, loglog_power_g2, rotor_lines

ROOT = Path(__file__).resolve().parents[1]
SPEC_FILE = ROOT / "scenarios" / "specs" / "helicopter-sine-on-random.yaml"
TABLE = ((10.0, 1.0e-5), (500.0, 1.0e-5), (2000.0, 2.0e-6))
FS, T = 7200.0, 60.0


def test_loglog_power_is_the_integral_of_the_interpolated_table():
    table = ((5.0, 0.02), (40.0, 0.02), (80.0, 0.1), (300.0, 0.1), (1000.0, 0.003), (2000.0, 0.003))
    fr, ps = np.array(table).T

    def g(f):
        return math.exp(np.interp(math.log(f), np.log(fr), np.log(ps)))

    quad = sum(integrate.quad(g, a, b, epsrel=1e-12)[0] for a, b in zip(fr[:-1], fr[1:]))
    assert loglog_power_g2(table) == pytest.approx(quad, rel=1e-10)  # quadrature of a smooth power law: 1e-12
    # the slope -1 segment (G f = const): G_i f_i ln(f_{i+1} / f_i)
    assert loglog_power_g2(((100.0, 1e-3), (1000.0, 1e-4))) == pytest.approx(1e-3 * 100.0 * math.log(10.0), rel=1e-14)


def test_rotor_lines_are_blade_passage_harmonics():
    lines = rotor_lines(324.0 / 60.0, 4, [0.8, 0.3, 0.1])
    assert [f for f, _ in lines] == pytest.approx([21.6, 43.2, 64.8], rel=1e-15)
    assert [a for _, a in lines] == [0.8, 0.3, 0.1]


def _record(spec, seed=5):
    t = np.arange(int(FS * T)) / FS
    return spec.translation(seed).accel(t) / STANDARD_GRAVITY


def test_simulated_vibration_matches_the_spec_closed_form():
    lines = ((21.6, 0.1), (43.2, 0.05), (64.8, 0.03), (89.5, 0.02))
    spec = SineOnRandomSpec((AxisSpec(TABLE, lines),) * 3)
    a = _record(spec)
    g_tab = lambda f: np.exp(np.interp(np.log(f), np.log([r[0] for r in TABLE]), np.log([r[1] for r in TABLE])))
    p_rand = loglog_power_g2(TABLE)
    var_ms = (integrate.quad(lambda f: g_tab(f) ** 2, 10.0, 2000.0, points=[500.0])[0]
              + sum(amp ** 2 * g_tab(f) for f, amp in lines)) / T
    images = 10.0 ** (-106.0 / 10.0) * p_rand
    want = spec.grms_g ** 2
    for ax in range(3):
        ms = float(np.mean(a[:, ax] ** 2))
        assert abs(ms - want[ax]) <= 5.0 * math.sqrt(var_ms) + images, (ax, ms, want[ax])
    # the PSD: Welch, 1 Hz bins, against the breakpoint table away from the band edges and the lines
    nper = int(FS)
    f, pxx = signal.welch(a, fs=FS, window="hann", nperseg=nper, noverlap=nper // 2, axis=0, detrend=False)
    k = (a.shape[0] - nper) // (nper // 2) + 1
    nu = 2.0 * k / (1.0 + 2.0 * 0.167 ** 2)
    edge = 10.0 / 4.0 + 2.0  # the generator's edge smoothing (<= f_lo / 4) and the Hann main lobe (2 bins)
    keep = (f > 10.0 + edge) & (f < 2000.0 - edge)
    for fl, _ in lines:  # a line's Hann leakage falls as 1/k^3: 5 bins away it is below 1e-3 of the background
        keep &= np.abs(f - fl) > 5.0
    n_bins = 3 * int(keep.sum())
    alpha = 1e-3 / n_bins
    ripple = 10.0 ** (0.02 / 10.0)
    lo = stats.chi2.ppf(alpha / 2.0, nu) / nu / ripple
    hi = stats.chi2.ppf(1.0 - alpha / 2.0, nu) / nu * ripple
    ratio = pxx[keep] / g_tab(f[keep])[:, None]
    assert lo <= ratio.min() and ratio.max() <= hi, (ratio.min(), ratio.max(), lo, hi)
    # each line's power in its bins (7 bins around it, the background's expected share taken out) against a^2 / 2.
    # Its spread: the line-noise cross term, whose variance a^2 G / T the Hann-windowed segments raise by at most
    # integral w^4 / (integral w^2)^2 = 35/18 < 2 (uneven weighting of the record), and the 7 background bins'
    # chi-square spread, at most 7 G sqrt(2 / nu) (bins fully correlated); 5 sigma of their sum
    for fl, amp in lines:
        near = np.abs(f - fl) <= 3.0
        g_line = g_tab(np.array([fl]))[0]
        line_power = (pxx[near].sum(axis=0) - g_line * near.sum()) * (f[1] - f[0])
        sigma = amp * math.sqrt(2.0 * g_line / T) + near.sum() * g_line * math.sqrt(2.0 / nu)
        np.testing.assert_allclose(line_power, amp ** 2 / 2.0, rtol=0, atol=5.0 * sigma)


def test_per_axis_spec_leaves_other_axes_still_and_reports():
    spec = SineOnRandomSpec((None, AxisSpec(None, ((30.0, 0.5),)), AxisSpec(TABLE, ())), source="test")
    a = _record(spec, seed=11)
    assert np.all(a[:, 0] == 0.0)
    assert np.mean(a[:, 1] ** 2) == pytest.approx(0.125, rel=1e-3)  # a^2/2; 1800 whole periods + rounding of t
    assert spec.grms_g.tolist() == pytest.approx([0.0, 0.5 / math.sqrt(2.0), math.sqrt(loglog_power_g2(TABLE))])
    line = _spec_lines(spec.summary())[0]
    assert line.startswith("- vibration specification: g_rms y 0.3536 g (random 0, lines 0.3536), z 0.1054 g")
    assert line.endswith("; source: test")


def _doc(**kw):
    doc = {"name": "t", "duration_s": 5.0, "imu": str(ROOT / "configs" / "nav-grade-rlg.yaml"),
           "vibration": {"spec": {"all": {"random": {"psd_g2_per_hz": [[10, 1e-5], [2000, 1e-5]]}}}}}
    doc.update(kw)
    return doc


def test_the_bundled_spec_loads_from_a_scenario_with_its_source():
    sc = load_scenario(ROOT / "scenarios" / "helicopter-spec-hover.yaml")
    s = sc.vibration_spec.summary()
    assert "illustrative" in s["source"] and "MIL-STD-810H Method 514.8" in s["source"]
    assert [f for f, _ in s["axes"]["z"]["lines_hz_g"]] == pytest.approx([89.5, 21.6, 43.2, 64.8])
    assert "ILLUSTRATIVE" in SPEC_FILE.read_text()
    # the user guide quotes the bundled file's closed form
    page = (ROOT / "docs" / "user-guide" / "vibration-specs.md").read_text()
    z = s["axes"]["z"]
    assert f"{z['random_grms_g']:.4f} g random, {z['sine_grms_g']:.4f} g lines, {z['grms_g']:.4f} g in all" in page


@pytest.mark.parametrize("spec, match", [
    ({"all": {"rotor": {"speed_rpm": 324, "speed_rev_s": 5.4, "blades": 4, "amplitude_g": [0.1]}}},
     r"vibration\.spec\.all\.rotor\.speed_rev_s: give exactly one of speed_rev_s and speed_rpm, got speed_rev_s "
     r"and speed_rpm"),
    ({"all": {"rotor": {"speed_hz": 5.4, "blades": 4, "amplitude_g": [0.1]}}}, r"vibration\.spec\.all\.rotor\.speed_hz"),
    ({"all": {"sines": [{"frequency_hz": 20, "amplitude_g": 0.1}]}, "x": {"sines": []}},
     r"vibration\.spec\.all: refused beside vibration\.spec\.x"),
    ({"x": {}}, r"vibration\.spec\.x: must give random, sines or rotor"),
    ({"all": {"sines": [{"frequency_hz": 4000, "amplitude_g": 0.1}]}},
     r"vibration\.spec\.all\.sines\[0\]\.frequency_hz: must be < the filter Nyquist 3600 Hz"),
    ({"all": {"sines": [{"frequency_hz": 21.6, "amplitude_g": 0.1}],
              "rotor": {"speed_rev_s": 5.4, "blades": 4, "amplitude_g": [0.1]}}},
     r"rotor\.amplitude_g\[0\] \(harmonic 1, 21\.6 Hz\): a line at 21\.6 Hz is already given by "
     r"vibration\.spec\.all\.sines\[0\]\.frequency_hz"),
    ({"all": {"random": {"psd_g2_per_hz": [[100, 1e-5], [50, 1e-5]]}}},
     r"vibration\.spec\.all\.random\.psd_g2_per_hz\[1\]: frequencies must increase"),
    ({"all": {"sines": [{"frequency_hz": 20, "amplitude_g": 200}]}},
     r"vibration\.spec\.all\.sines\[0\]\.amplitude_g: must be <= 100"),
])
def test_refusals_name_the_key(spec, match):
    with pytest.raises(ConfigError, match=match):
        load_scenario(_doc(vibration={"spec": spec}))


def test_spec_beside_linear_vibration_is_refused_naming_both():
    doc = _doc(linear_vibration=[{"type": "sines", "amplitude_m_s2": [1, 1, 1], "frequency_hz": [20, 20, 20]}])
    with pytest.raises(ConfigError, match=r"vibration\.spec: refused beside linear_vibration"):
        load_scenario(doc)


def test_spec_file_errors_name_the_file_and_key(tmp_path):
    (tmp_path / "s.yaml").write_text("all:\n  rotor: {speed_rpm: 324, blades: 0, amplitude_g: [0.1]}\n")
    doc = _doc(vibration={"spec": "s.yaml"})
    with pytest.raises(ConfigError, match=r"-> s\.yaml: all\.rotor\.blades: must be >= 1"):
        load_scenario(doc, base_dir=tmp_path)
    with pytest.raises(ConfigError, match=r"vibration\.spec: file not found"):
        load_scenario(_doc(vibration={"spec": "missing.yaml"}), base_dir=tmp_path)
