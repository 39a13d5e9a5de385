"""The twin's readout pulses: a quantised log beside its twin (``sins-sim identify``).

The log is made here, independently of the code under test: at rest the body rate and specific force are
``C_bn w_ie^n`` and ``C_bn (0, 0, -g)`` (Titterton and Weston 2004, sec. 10.2), white rate noise of density ``N``
has the per-sample sigma ``N / sqrt(dt)`` (IEEE Std 952-1997, Annex C), and a pulse readout outputs the differences of
its accumulated count ``floor(r0 + (sum of the increments) / q)`` (Savage 2007, sec. 7.1.2.3), written here as a
cumulative sum rather than the carried residue of the code under test.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sins_sim.earth import earth_rate_ned, gravity_down
from sins_sim.jobs.identify import identify, pulse_weights
from sins_sim.jobs.import_log import write_log_table
from sins_sim.simulation.twin import pulse_weight_of, quantise_pulses
from sins_sim.units import ARCSEC, MICRO_G

LAT = math.radians(50.0)
#: 400 Hz, one arcsec and 1 mm/s per pulse.
DT = 0.0025
Q_GYRO = 1.0 * ARCSEC
Q_ACC = 1e-3
#: ARW 0.067 deg/sqrt(h) = 4 arcsec/sqrt(s): 0.2 pulse of rate noise per interval, so the quantisation slope
#: sqrt(3) Q / tau (Q = q / sqrt(12)) dominates the ARW N / sqrt(tau) below tau = q^2 / (4 N^2) = 16 ms, over
#: about a decade of taus above the 2.5 ms interval.
N_SI = 4.0 * ARCSEC
#: VRW 408 ug/sqrt(Hz) = 4e-3 m/s^2/sqrt(Hz): the same 0.2 pulse per interval for the accelerometers.
VRW_SI = 0.2 * Q_ACC / math.sqrt(DT)
MINUTES = 2.0


def quantised_log(path, seed):
    rng = np.random.default_rng(seed)
    n = int(MINUTES * 60.0 / DT)
    t = np.arange(1, n + 1) * DT
    h = math.radians(30.0)
    c_nb = np.array([[math.cos(h), -math.sin(h), 0.0], [math.sin(h), math.cos(h), 0.0], [0.0, 0.0, 1.0]])
    w_b = c_nb.T @ earth_rate_ned(LAT)
    f_b = c_nb.T @ np.array([0.0, 0.0, -gravity_down(LAT, 0.0)])
    x_g = np.tile(w_b * DT, (n, 1)) + rng.standard_normal((n, 3)) * N_SI * math.sqrt(DT)
    x_a = np.tile(f_b * DT, (n, 1)) + rng.standard_normal((n, 3)) * VRW_SI * math.sqrt(DT)

    def pulses(x, q):
        count = np.floor(rng.uniform(0.0, 1.0, 3) + np.cumsum(x, axis=0) / q)
        return np.diff(np.vstack([np.zeros(3), count]), axis=0) * q

    # the first count's floor of r0 alone is 0 (r0 < 1), so the differences start from 0 pulses
    write_log_table(path, t, pulses(x_g, Q_GYRO), pulses(x_a, Q_ACC),
                    {"site": {"lat_rad": LAT, "lon_rad": 0.0, "height_m": 0.0}})
    return path


def test_quantiser_keeps_the_total_within_a_pulse():
    """The carried residue: the emitted total never differs from the true integral by a pulse or more, also
    through a signed-permutation axes matrix (a log in right-forward-up)."""
    rng = np.random.default_rng(3)
    x = rng.normal(0.37e-5, 1e-6, (5000, 3))
    axes = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
    w = np.array([1e-6, 2e-6, 5e-7])
    out = quantise_pulses(x, w, axes, rng)
    err_log = (np.cumsum(out, axis=0) - np.cumsum(x, axis=0)) @ axes.T
    assert np.all(np.abs(err_log) < w)
    k = (out @ axes.T) / w
    assert np.max(np.abs(k - np.round(k))) < 1e-9
    assert pulse_weight_of(out[:, 2]) == pytest.approx(5e-7, rel=1e-12)
    assert pulse_weight_of(x[:, 0]) is None                         # not quantised


def test_quantised_log_beside_its_twin(tmp_path):
    """A quantised log: the weights read off it, its quantisation term Q near q / sqrt(12), and its twin (with
    the pulses) leaves no Allan or line finding."""
    log = quantised_log(tmp_path / "q.parquet", 11)
    r = identify(log, twin_seeds=5)
    pw = r["pulse_weights"]
    assert pw["gyro_weight_arcsec"] == pytest.approx([1.0] * 3, rel=1e-9)
    assert pw["accelerometer_weight_ug_s"] == pytest.approx([Q_ACC / MICRO_G] * 3, rel=1e-9)
    # Q: the residue is randomised by the rate noise accumulated in the angle, s = 0.2 pulse per interval, not at
    # once: the residues m intervals apart keep a correlation rho(m) <= exp(-2 pi^2 m s^2) (the first harmonic of the
    # sawtooth, the others smaller), and the quantisation's Allan variance 3 V (1 - 4/3 rho(m) + 1/3 rho(2m)) / tau^2
    # is off its closed form by at most 5/3 rho(m); the fitted region starts at m = 2: 5/3 exp(-1.58) = 0.34 on the
    # variance, 1 - sqrt(1 - 0.34) = 19 % on Q.
    q_expect = 1.0 / math.sqrt(12.0)
    for ax in "xyz":
        e = r["noise"]["gyro"][ax]["quantization_arcsec"]
        assert "value" in e, e
        assert abs(e["value"] / q_expect - 1.0) < 0.19
    allan = [f for f in r["twin"]["findings"] if f["quantity"] == "allan_deviation"]
    lines = [f for f in r["twin"]["findings"] if f["quantity"] == "psd_line"]
    assert not allan, [f["statement"] for f in allan]
    assert not lines, [f["statement"] for f in lines]


def test_unquantised_twin_shows_the_gap(tmp_path):
    """Without the pulses (the weights withheld) the same log leaves its twin at short tau: the test above can
    fail."""
    import sins_sim.jobs.identify as ident

    log = quantised_log(tmp_path / "q.parquet", 11)
    orig = ident.pulse_weights
    ident.pulse_weights = lambda meta, dth, dv: None
    try:
        r = identify(log, twin_seeds=5)
    finally:
        ident.pulse_weights = orig
    assert any(f["quantity"] == "allan_deviation" and f["sensor"] == "gyro" and f["tau_range_s"][0] < 0.02
               for f in r["twin"]["findings"])


def test_weights_from_the_description():
    """A counts log's description gives the weights in the log's axes (RFU: gyro 0.1 arcsec, 125 ug s)."""
    meta = {"description": {"format": {"type": "text"}, "columns": {"gyro": [1, 2, 3], "accelerometer": [4, 5, 6]},
                            "time": {"rate_hz": 100}, "gyro": {"kind": "counts", "weight_arcsec": 0.1},
                            "accelerometer": {"kind": "counts", "weight_ug_s": 125}, "axes": "RFU",
                            "source": "x", "axes_matrix_frd": [[0, 1, 0], [1, 0, 0], [0, 0, -1]]}}
    pw = pulse_weights(meta, np.zeros((10, 3)), np.zeros((10, 3)))
    assert np.allclose(pw.gyro_rad, 0.1 * ARCSEC) and np.allclose(pw.accel_m_s, 125 * MICRO_G)
    assert np.allclose(pw.axes, [[0, 1, 0], [1, 0, 0], [0, 0, -1]])
