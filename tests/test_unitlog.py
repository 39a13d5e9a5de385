"""A unit's own log gets in: ``sins-sim import-log`` (sins_sim.io.unitlog, .config.log, .jobs.import_log).

The round trip that matters: a vehicle's exact increments (:func:`ideal_increments` of a known trajectory) are
logged the way a real unit logs them (integer pulse counts from a counter that carries its residual, right-
forward-up axes, whitespace text, header rows with the site, comment lines), imported, and compared with the
exact increments rotated to forward-right-down by hand; navigating the imported table must give what navigating
the quantised increments gives. Then every axis convention against an independent construction, every format,
and every refusal as one line naming the key or the line.
"""

from __future__ import annotations

import hashlib
import itertools
import math
import re
from pathlib import Path

import numpy as np
import pytest

from sins_sim.cli import main
from sins_sim.config.errors import ConfigError
from sins_sim.config.log import load_log_description
from sins_sim.io.unitlog import LogFileError, axes_matrix, read_unit_log
from sins_sim.jobs.import_log import import_log, read_log_table
from sins_sim.jobs.navigate import INCREMENT_COLUMNS, navigate_increments, read_increments, write_increments
from sins_sim.models.motion import Stationary, Trajectory
from sins_sim.models.motion.trajectory import Accelerate, CoordinatedTurn, Cruise
from sins_sim.simulation.external import ideal_increments
from sins_sim.units import ARCSEC, MICRO_G

RATE_HZ = 100.0
W_GYRO = 0.1 * ARCSEC  # rad per pulse
W_ACCEL = 125.0 * MICRO_G  # m/s per pulse (125 ug s)
LAT_DEG, LON_DEG, HEIGHT_M = 56.8, 37.6, 150.0
#: rows: the log's axes (right, forward, up) in FRD, written out by hand
RFU = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
EPS = np.finfo(float).eps
ROOT = Path(__file__).resolve().parents[1]

DESCRIPTION = f"""\
name: RLG unit 7
format: {{type: text, delimiter: whitespace, header_rows: 4, comment: "#"}}
columns: {{time: 0, gyro: [1, 2, 3], accelerometer: [4, 5, 6]}}
time: {{unit: s, rate_hz: {RATE_HZ:g}}}
gyro: {{kind: counts, weight_arcsec: 0.1}}
accelerometer: {{kind: counts, weight_ug_s: 125}}
axes: right-forward-up
site:
  lat_deg: {{header: Latitude}}
  lon_deg: {{header: longitude}}
  height_m: {{header: Height}}
"""


@pytest.fixture(scope="module")
def vehicle():
    """A level vehicle heading 30 deg: 60 s at rest, then it drives off, cruises, turns right 90 deg, cruises."""
    truth = Trajectory(math.radians(LAT_DEG), math.radians(LON_DEG), HEIGHT_M, 0.0, math.radians(30.0),
                       [Stationary(60.0), Accelerate(20.0, 10.0), Cruise(20.0), CoordinatedTurn(30.0, math.pi / 2),
                        Cruise(20.0)])
    t = np.arange(1, int(round(truth.duration_s * RATE_HZ)) + 1) / RATE_HZ
    dth, dv = ideal_increments(truth, t)
    return truth, t, dth, dv


def _counter(x, w):
    """A pulse counter: whole pulses crossed per interval, the fraction carried on (N_k = floor(S_k) -
    floor(S_{k-1}), S_k the running sum in pulses), so the counted total is never a whole pulse behind."""
    total = np.floor(np.cumsum(x / w, axis=0))
    return np.diff(np.vstack([np.zeros((1, x.shape[1])), total]), axis=0).astype(np.int64)


def _rfu_counts(dth, dv):
    """The unit's counts along its right, forward, up axes: v_log = C v_frd."""
    return _counter(dth @ RFU.T, W_GYRO), _counter(dv @ RFU.T, W_ACCEL)


def _write_text_log(path, t, ng, na, *, header=(f"Latitude: {LAT_DEG}", f"Longitude = {LON_DEG}",
                                                f"Height: {HEIGHT_M}"), sep=" ", comments=(100, 4000)):
    lines = ["RLG unit 7, 100 Hz pulse log", *header]
    for i in range(t.size):
        if i in comments:
            lines.append(f"# operator note at row {i}")
        lines.append(sep.join([f"{t[i]:.2f}", *map(str, ng[i]), *map(str, na[i])]))
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture(scope="module")
def imported(vehicle, tmp_path_factory):
    _, t, dth, dv = vehicle
    d = tmp_path_factory.mktemp("log")
    ng, na = _rfu_counts(dth, dv)
    log = _write_text_log(d / "unit7.log", t, ng, na)
    (d / "unit7.yaml").write_text(DESCRIPTION)
    meta = import_log(log, d / "unit7.yaml", d / "unit7.parquet")
    return d, ng, na, meta, read_log_table(d / "unit7.parquet")


def test_imported_increments_are_the_direct_ones_to_one_pulse(vehicle, imported):
    """Per interval within one pulse weight of the exact increments rotated to FRD; the running sum never more
    than one pulse off.

    Why: the counter's total is floor(S_k), S_k the exact running sum in pulses, so the counted total lags the
    exact one by frac(S_k) in [0, 1) pulse and never more (a counter carrying its residual loses at most one
    quantum in total, however long it runs); interval k's error is the difference of two such lags, within
    (-1, 1) pulse. Rotating RFU to FRD permutes and flips axes, which keeps both bounds. Tolerance on top:
    float64 rounding of the running sums, n eps max|sum| (2e4 rows, |sum| < 2 rad or 600 m/s: < 3e-10 of a
    pulse weight).
    """
    _, t, dth, dv = vehicle
    _, _, _, _, (t_i, dth_i, dv_i, meta) = imported
    np.testing.assert_allclose(t_i, t, rtol=0, atol=1e-9)  # the grid t_0 + n dt (t_0 = 0.01 s)
    for got, exact, w in ((dth_i, dth, W_GYRO), (dv_i, dv, W_ACCEL)):
        float_tol = t.size * EPS * np.max(np.abs(np.cumsum(exact, axis=0)))
        assert np.max(np.abs(got - exact)) < w + float_tol
        drift = np.abs(np.cumsum(got - exact, axis=0))
        assert np.max(drift) < w + float_tol
        assert np.max(drift) > 0.5 * w  # the bound is reached, not vacuous: the counts are real pulses
    assert meta["report"]["rows"] == t.size and meta["report"]["duplicates_dropped"] == 0
    assert meta["report"]["gaps"] == []


def test_navigating_the_import_equals_navigating_the_quantised_increments(vehicle, imported):
    """The imported table is the counts times their weight rotated to FRD, to rounding; navigated against the truth
    it gives the quantised increments' position error to rounding.

    The quantised increments are built here independently: counts x weight in RFU, then to FRD by hand (x = the
    log's y, y = its x, z = minus its z). Each entry is one product count x weight either way: equal to a few
    ulp. The navigation's output is a smooth function of its inputs, so inputs equal to 1e-15 relative give
    positions equal far below 1 um (asserted: 1e-6 m).
    """
    truth, t, dth, dv = vehicle
    _, ng, na, _, (t_i, dth_i, dv_i, _) = imported
    def by_hand(c, w):
        return np.column_stack([c[:, 1] * w, c[:, 0] * w, -c[:, 2] * w])

    q_dth, q_dv = by_hand(ng, W_GYRO), by_hand(na, W_ACCEL)
    np.testing.assert_allclose(dth_i, q_dth, rtol=4 * EPS, atol=0)
    np.testing.assert_allclose(dv_i, q_dv, rtol=4 * EPS, atol=0)
    got = navigate_increments(t_i, dth_i, dv_i, truth)["filters"]["external"]
    ref = navigate_increments(t, q_dth, q_dv, truth)["filters"]["external"]
    assert got["status"] == ref["status"] == "ok"
    for key, stat in (("horizontal_position_error_m", "final"), ("horizontal_position_error_m", "max"),
                      ("vertical_position_error_m", "final"), ("velocity_error_m_s", "final")):
        assert abs(got[key][stat] - ref[key][stat]) < 1e-6, (key, stat)
    # and the quantisation did something: the pulses' error is visible next to the exact increments'
    exact = navigate_increments(t, dth, dv, truth)["filters"]["external"]
    assert exact["horizontal_position_error_m"]["max"] != ref["horizontal_position_error_m"]["max"]


def test_the_metadata_records_where_the_table_came_from(imported):
    from sins_sim import __version__

    d, _, _, meta, (_, _, _, stored) = imported
    assert stored == meta
    assert stored["source"]["sha256"] == hashlib.sha256((d / "unit7.log").read_bytes()).hexdigest()
    assert stored["sins_sim_version"] == __version__
    site = stored["site"]
    assert math.degrees(site["lat_rad"]) == pytest.approx(LAT_DEG, abs=1e-12)
    assert math.degrees(site["lon_rad"]) == pytest.approx(LON_DEG, abs=1e-12)
    assert site["height_m"] == HEIGHT_M and "Latitude" in site["from"]["lat_rad"]
    assert stored["initial_velocity_ned_m_s"] == [0.0, 0.0, 0.0]
    # the rest check: over the first 60 s (+1 s of the gentlest start) the summed angle is within one pulse per axis
    # of the exact one, sin(lat) within sqrt(3) 0.1 arcsec / (Omega 61 s) = 1.9e-4, the latitude within 0.02 deg
    rest = stored["report"]["rest_check"]
    assert rest["window_s"] >= 60.0 and rest["agrees_with_site"] is True
    assert rest["latitude_deg"] == pytest.approx(LAT_DEG, abs=0.02)
    assert stored["description"]["axes_matrix_frd"] == RFU.tolist()
    assert stored["report"]["rows_read"] == stored["report"]["rows"]
    # the resolved description loads again to the same layout
    again = {k: v for k, v in stored["description"].items() if k not in ("source", "axes_matrix_frd")}
    assert load_log_description(again).layout == load_log_description(d / "unit7.yaml").layout
    # navigate's reader takes the file as it is: exactly the increment columns
    t, _, _ = read_increments(d / "unit7.parquet")
    assert t.size == stored["report"]["rows"]
    import pyarrow.parquet as pq

    assert tuple(pq.read_schema(d / "unit7.parquet").names) == INCREMENT_COLUMNS


def test_a_plain_increments_file_has_no_metadata(tmp_path):
    t = 0.01 * np.arange(1, 11)
    for name in ("plain.csv", "plain.parquet"):
        write_increments(tmp_path / name, t, np.zeros((10, 3)), np.zeros((10, 3)))
        assert read_log_table(tmp_path / name)[3] == {}


# --- axes ------------------------------------------------------------------------------------------------------------
_PAIRS = (("F", "B"), ("R", "L"), ("D", "U"))  # FRD's positive and negative letters


def _component(letter, v_frd):
    """The component of an FRD vector along a labelled axis: forward = x, back = -x, ..., up = -z."""
    for i, (pos, neg) in enumerate(_PAIRS):
        if letter == pos:
            return v_frd[i]
        if letter == neg:
            return -v_frd[i]
    raise AssertionError(letter)


def _right_handed(triple) -> bool:
    """Independent: the parity of the permutation of the axes times the product of the signs."""
    order = [next(i for i, p in enumerate(_PAIRS) if c in p) for c in triple]
    inversions = sum(1 for a, b in itertools.combinations(order, 2) if a > b)
    signs = math.prod(1 if c in "FRD" else -1 for c in triple)
    return (-1) ** inversions * signs == 1


TRIPLES = ["".join(p) for axes in itertools.permutations(range(3))
           for p in itertools.product(*(_PAIRS[a] for a in axes))]


@pytest.mark.parametrize("triple", TRIPLES)
def test_every_letter_triple(triple):
    """All 48 triples: the 24 right-handed ones map a vector's FRD components to its components along the labelled
    axes (v_log = C v_frd), the 24 left-handed ones are refused saying so."""
    v = np.array([1.0, 2.0, 3.0])  # forward 1, right 2, down 3
    if _right_handed(triple):
        c = axes_matrix(triple)
        np.testing.assert_array_equal(c @ v, [_component(x, v) for x in triple])
        np.testing.assert_array_equal(axes_matrix(triple.lower()), c)
    else:
        with pytest.raises(ValueError, match="left-handed"):
            axes_matrix(triple)
    assert len(TRIPLES) == 48 and sum(map(_right_handed, TRIPLES)) == 24


@pytest.mark.parametrize("text", ["RFU", "right-forward-up", "Right Forward Up", "x right, y forward, z up",
                                  "right/forward/up", "starboard fwd up"])
def test_long_forms(text):
    np.testing.assert_array_equal(axes_matrix(text), RFU)


@pytest.mark.parametrize("text,words", [("FRU", "left-handed: F x R = D"), ("NED", "'N' is not a body axis"),
                                        ("FFU", "forward/back axis twice"), ("FR", "needs three axes"),
                                        ("forward right sideways", "'sideways' is not an axis")])
def test_bad_axes_strings_are_one_line(text, words):
    doc = _doc(axes=text)
    with pytest.raises(ConfigError) as e:
        load_log_description(doc)
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith("log description (dict): axes: ") and words in msg


def test_axes_matrix_must_be_a_rotation():
    assert load_log_description(_doc(axes=RFU.tolist())).layout.axes == tuple(map(tuple, RFU))
    c45 = math.sqrt(0.5)
    yawed = [[c45, c45, 0.0], [-c45, c45, 0.0], [0.0, 0.0, 1.0]]  # mounted 45 deg to the right
    np.testing.assert_allclose(load_log_description(_doc(axes=yawed)).layout.axes, yawed)
    for bad, words in (([[0.7071, 0.7071, 0], [-0.7071, 0.7071, 0], [0, 0, 1]], "not orthonormal"),
                       ([[1, 0, 0], [0, 1, 0], [0, 0, -1]], "determinant -1"),
                       ([[1, 0], [0, 1]], "3x3"), ([[1, 0, 0], [0, 1, 0], [0, 0, "a"]], "matrix of numbers")):
        with pytest.raises(ConfigError, match=words) as e:
            load_log_description(_doc(axes=bad))
        assert "axes: " in str(e.value) and "\n" not in str(e.value)


# --- formats ---------------------------------------------------------------------------------------------------------
def _doc(**over):
    doc = {"format": {"type": "text"}, "columns": {"time": 0, "gyro": [1, 2, 3], "accelerometer": [4, 5, 6]},
           "time": {"rate_hz": RATE_HZ}, "gyro": {"kind": "counts", "weight_arcsec": 0.1},
           "accelerometer": {"kind": "counts", "weight_ug_s": 125}, "axes": "RFU"}
    doc.update(over)
    return doc


@pytest.fixture()
def small():
    """30 s of a vehicle at rest at the header's site, then driving: times and the RFU counts."""
    truth = Trajectory(math.radians(LAT_DEG), math.radians(LON_DEG), HEIGHT_M, 0.0, 0.3,
                       [Stationary(10.0), Accelerate(20.0, 5.0)])
    t = np.arange(1, 3001) / RATE_HZ
    dth, dv = ideal_increments(truth, t)
    return t, *_rfu_counts(dth, dv)


def _read(path, doc):
    return read_unit_log(path, load_log_description(doc).layout)


def test_text_csv_and_parquet_read_alike(small, tmp_path):
    import pandas as pd

    t, ng, na = small
    ref = _read(_write_text_log(tmp_path / "a.txt", t, ng, na), _doc(format={"type": "text", "header_rows": 4}))
    names = ["t", "gR", "gF", "gU", "aR", "aF", "aU"]
    frame = pd.DataFrame(np.column_stack([t, ng, na]), columns=names).astype({n: "int64" for n in names[1:]})
    csv = tmp_path / "a.csv"
    csv.write_text(f"# unit 7\n# Latitude = {LAT_DEG}\n" + frame.to_csv(index=False))
    by_name = {"time": "t", "gyro": names[1:4], "accelerometer": names[4:]}
    site = {"lat_deg": {"header": "latitude"}}
    got_csv = _read(csv, _doc(format={"type": "csv"}, columns=by_name, site=site))
    semi = tmp_path / "semi.csv"  # a European export: semicolons
    semi.write_text(csv.read_text().replace(",", ";"))
    got_semi = _read(semi, _doc(format={"type": "csv", "delimiter": "semicolon"}, columns=by_name, site=site))
    comma = _write_text_log(tmp_path / "b.txt", t, ng, na, sep=", ")
    got_comma = _read(comma, _doc(format={"type": "text", "header_rows": 4, "delimiter": "comma"}))
    pq_path = tmp_path / "a.parquet"
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.Table.from_pandas(frame, preserve_index=False)
    pq.write_table(table.replace_schema_metadata({**table.schema.metadata, b"Latitude": str(LAT_DEG).encode()}),
                   pq_path)
    got_pq = _read(pq_path, _doc(format={"type": "parquet"}, columns=by_name, site=site))
    by_index = _read(pq_path, _doc(format={"type": "parquet"}, site=site))
    for got in (got_csv, got_semi, got_comma, got_pq, by_index):
        np.testing.assert_array_equal(got.t_s, ref.t_s)
        np.testing.assert_array_equal(got.dtheta, ref.dtheta)
        np.testing.assert_array_equal(got.dv, ref.dv)
    for got in (got_csv, got_pq):
        assert got.report["site"]["lat_rad"] == pytest.approx(math.radians(LAT_DEG), abs=1e-15)


def test_fixed_rate_without_a_time_column(small, tmp_path):
    t, ng, na = small
    log = tmp_path / "norate.txt"
    log.write_text("\n".join(" ".join(map(str, [*g, *a])) for g, a in zip(ng, na)) + "\n")
    doc = _doc(columns={"gyro": [0, 1, 2], "accelerometer": [3, 4, 5]}, time={"rate_hz": 100, "start_s": 5.0})
    got = _read(log, doc)
    np.testing.assert_allclose(got.t_s, 5.0 + t, rtol=0, atol=1e-12)
    assert "cannot be seen" in got.report["note"]


def test_rates_and_increments_in_their_own_units(small, tmp_path):
    """Rates x period (the rectangle rule) and increments x their unit give back the increments they came from:
    rates logged as the interval's mean (increment / dt) are integrated exactly by the rectangle rule."""
    t, ng, na = small
    dth = np.column_stack([ng[:, 1], ng[:, 0], -ng[:, 2]]) * W_GYRO  # FRD, as above
    dv = np.column_stack([na[:, 1], na[:, 0], -na[:, 2]]) * W_ACCEL
    dt = 1.0 / RATE_HZ
    rates = np.column_stack([t, np.degrees(dth / dt), dv / dt / 9.80665])  # deg/s and g, in FRD
    incr = np.column_stack([t, np.degrees(dth) * 3600.0, dv * 1e3])  # arcsec and mm/s
    for name, arr, gyro, accel in (
            ("rates.txt", rates, {"kind": "rates", "unit": "deg_s"}, {"kind": "rates", "unit": "g"}),
            ("incr.txt", incr, {"kind": "increments", "unit": "arcsec"}, {"kind": "increments", "unit": "mm_s"})):
        np.savetxt(tmp_path / name, arr, fmt="%.17g")
        got = _read(tmp_path / name, _doc(gyro=gyro, accelerometer=accel, axes="FRD"))
        # repr-exact text, then x unit (x dt): a few ulp of each increment
        np.testing.assert_allclose(got.dtheta, dth, rtol=8 * EPS, atol=4 * EPS * W_GYRO)
        np.testing.assert_allclose(got.dv, dv, rtol=8 * EPS, atol=4 * EPS * W_ACCEL)
        assert ("rectangle rule" in (got.report["integration"] or "")) == (name == "rates.txt")


def test_per_axis_and_negative_weights(small, tmp_path):
    """A weight per axis, and a channel that counts against its label (a negative weight) read as flipped."""
    t, ng, na = small
    log = _write_text_log(tmp_path / "a.txt", t, ng, na)
    ref = _read(log, _doc(format={"type": "text", "header_rows": 4}))
    flipped = _write_text_log(tmp_path / "b.txt", t, ng * [1, 1, -1], na * [1, 1, -1])
    got = _read(flipped, _doc(format={"type": "text", "header_rows": 4},
                              gyro={"kind": "counts", "weight_arcsec": [0.1, 0.1, -0.1]},
                              accelerometer={"kind": "counts", "weight_m_s": [W_ACCEL, W_ACCEL, -W_ACCEL]}))
    np.testing.assert_array_equal(got.dtheta, ref.dtheta)
    np.testing.assert_allclose(got.dv, ref.dv, rtol=2 * EPS, atol=0)


def _totals_log(path, t, ng, na, start, bits, drop=()):
    """Running totals of the counts read out at each row, the first row (t = 0) the reference, on a ``bits``-bit
    counter started at ``start`` (so it rolls over), rows ``drop`` (of the readings after the reference) lost."""
    full = 2 ** bits
    tg = (start + np.vstack([np.zeros((1, 3), np.int64), np.cumsum(ng, axis=0)])) % full
    ta = (start + np.vstack([np.zeros((1, 3), np.int64), np.cumsum(na, axis=0)])) % full
    tt = np.r_[0.0, t]
    keep = np.setdiff1d(np.arange(tt.size), np.asarray(drop, dtype=int) + 1)
    return _rows_log(path, tt[keep], tg[keep], ta[keep])


def test_running_totals_on_a_counter_that_rolls_over(small, tmp_path):
    """A 16-bit counter started near its top: the differences wrapped back give the counts to the pulse, so the
    import equals the counts log's exactly; across a gap the totals lose nothing (the sum over the gap is exact)."""
    t, ng, na = small
    totals = {"kind": "totals", "weight_arcsec": 0.1, "wrap_bits": 16}
    accel = {"kind": "totals", "weight_ug_s": 125, "wrap_bits": 16}
    ref = _read(_rows_log(tmp_path / "counts.txt", t, ng, na), _doc())
    log = _totals_log(tmp_path / "totals.txt", t, ng, na, start=65000, bits=16)
    up = np.loadtxt(log)[:, 6]  # the up accelerometer's total: 80 pulses per interval from 65000 up
    assert up[0] == 65000 and np.any(np.diff(up) < -65000)  # it does roll over
    got = _read(log, _doc(gyro=totals, accelerometer=accel))
    np.testing.assert_array_equal(got.t_s, ref.t_s)
    np.testing.assert_array_equal(got.dtheta, ref.dtheta)
    np.testing.assert_array_equal(got.dv, ref.dv)
    assert got.report["first_row_reference"] is True and got.report["rows"] == t.size
    gap = _totals_log(tmp_path / "gap.txt", t, ng, na, start=65000, bits=16, drop=(700, 701, 702))
    with pytest.raises(LogFileError, match="running totals lose nothing across a gap"):
        _read(gap, _doc(gyro=totals, accelerometer=accel))
    filled = _read(gap, _doc(gyro=totals, accelerometer=accel, time={"rate_hz": RATE_HZ, "gaps": "fill_mean"}))
    np.testing.assert_array_equal(filled.t_s, ref.t_s)
    # the four intervals 700..703 share the one difference the counter shows across the gap
    for got4, ref4 in ((filled.dtheta, ref.dtheta), (filled.dv, ref.dv)):
        np.testing.assert_allclose(got4[700:704], np.tile(ref4[700:704].sum(axis=0) / 4, (4, 1)), rtol=4 * EPS,
                                   atol=4 * EPS * np.abs(ref4[700:704]).max())
        np.testing.assert_array_equal(np.delete(got4, range(700, 704), axis=0), np.delete(ref4, range(700, 704),
                                                                                          axis=0))
    assert [f["interval"] for f in filled.report["filled_intervals"]] == [700, 701, 702]
    assert "shared" in filled.report["fill_rule"]
    with pytest.raises(ConfigError, match="time.stamp: a running total is read at an instant"):
        load_log_description(_doc(gyro=totals, time={"rate_hz": RATE_HZ, "stamp": "start"}))
    with pytest.raises(ConfigError, match="gyro.wrap_bits: only for kind totals"):
        load_log_description(_doc(gyro={"kind": "counts", "weight_arcsec": 0.1, "wrap_bits": 16}))


# --- the time base ---------------------------------------------------------------------------------------------------
def _rows_log(path, t, ng, na):
    path.write_text("\n".join(" ".join([f"{ti:.2f}", *map(str, g), *map(str, a)]) for ti, g, a in zip(t, ng, na))
                    + "\n")
    return path


def test_exact_duplicate_rows_are_dropped_and_counted(small, tmp_path):
    t, ng, na = small
    ref = _read(_rows_log(tmp_path / "a.txt", t, ng, na), _doc())
    rep = np.r_[np.arange(500), 499, np.arange(500, 2000), 1999, 1999, np.arange(2000, t.size)]
    got = _read(_rows_log(tmp_path / "b.txt", t[rep], ng[rep], na[rep]), _doc())
    assert got.report["duplicates_dropped"] == 3
    assert got.report["duplicate_rows"] == ["line 501", "line 2002", "line 2003"]
    np.testing.assert_array_equal(got.dtheta, ref.dtheta)
    np.testing.assert_array_equal(got.t_s, ref.t_s)


def test_a_repeated_time_with_other_data_is_refused_naming_both_lines(small, tmp_path):
    t, ng, na = small
    rep = np.r_[np.arange(500), 499, np.arange(500, t.size)]
    ng2 = ng[rep].copy()
    ng2[500, 0] += 1
    with pytest.raises(LogFileError) as e:
        _read(_rows_log(tmp_path / "b.txt", t[rep], ng2, na[rep]), _doc())
    msg = str(e.value)
    assert "\n" not in msg and "line 500 and line 501 hold the same time (5 s) with different data" in msg


def test_a_gap_is_refused_by_default_and_filled_when_asked(small, tmp_path):
    t, ng, na = small
    keep = np.ones(t.size, dtype=bool)
    keep[[700, 701, 702, 1500]] = False  # two gaps: 3 intervals after t = 7.00 s, 1 after 15.00 s
    log = _rows_log(tmp_path / "gap.txt", t[keep], ng[keep], na[keep])
    with pytest.raises(LogFileError) as e:
        _read(log, _doc())
    msg = str(e.value)
    assert "\n" not in msg
    assert ("gap between line 700 (7 s) and line 701 (7.04 s): 3 missing interval(s) of 0.01 s (2 gaps, 4 missing "
            "intervals in all); set time.gaps: fill_mean") in msg
    got = _read(log, _doc(time={"rate_hz": RATE_HZ, "gaps": "fill_mean"}))
    ref = _read(_rows_log(tmp_path / "full.txt", t, ng, na), _doc())
    np.testing.assert_array_equal(got.t_s, ref.t_s)
    assert [f["interval"] for f in got.report["filled_intervals"]] == [700, 701, 702, 1500]
    assert got.report["gaps_filled"] == 2 and "mean" in got.report["fill_rule"]
    for i, (lo, hi) in zip((700, 701, 702, 1500), ((699, 703), (699, 703), (699, 703), (1499, 1501))):
        np.testing.assert_allclose(got.dtheta[i], 0.5 * (ref.dtheta[lo] + ref.dtheta[hi]), rtol=2 * EPS)
    others = np.setdiff1d(np.arange(t.size), [700, 701, 702, 1500])
    np.testing.assert_array_equal(got.dtheta[others], ref.dtheta[others])


def test_time_in_milliseconds_stamped_at_the_start_and_fitted_rate(small, tmp_path):
    t, ng, na = small
    log = tmp_path / "ms.txt"
    jitter = 0.5 * np.sin(np.arange(t.size))  # +-0.05 period of timestamp jitter, in ms
    log.write_text("\n".join(" ".join([f"{1e3 * (ti - 0.01) + j:.4f}", *map(str, g), *map(str, a)])
                             for ti, j, g, a in zip(t, jitter, ng, na)) + "\n")
    got = _read(log, _doc(time={"unit": "ms", "stamp": "start"}))
    assert got.report["rate_hz"] == pytest.approx(RATE_HZ, rel=1e-6)
    np.testing.assert_allclose(got.t_s, t, rtol=0, atol=1e-6)
    assert 0.4e-3 < got.report["timestamp_offset_max_s"] < 0.6e-3


def test_a_clock_running_at_another_rate_is_refused(small, tmp_path):
    t, ng, na = small
    # a clock 0.6 % fast: each step within the jitter, row n off by 0.006 n periods: > 0.1 from row 17 (line 18)
    log = tmp_path / "fast.txt"
    log.write_text("\n".join(" ".join([f"{ti:.6f}", *map(str, g), *map(str, a)])
                             for ti, g, a in zip(t * (1 - 6e-3), ng, na)) + "\n")
    with pytest.raises(LogFileError) as e:
        _read(log, _doc())
    _one_line(e, "line 18: the time column is", "off the grid of 100 Hz started at the first row")
    # without rate_hz the rate is fitted: times rounded to 1 us (sigma 0.29 us) over N = 3000 intervals give a slope
    # error of 0.29 us / sqrt(N^3 / 12) = 6e-12 s per 0.01 s interval, 6e-10 relative; 1e-8 is 16 times that
    assert _read(log, _doc(time={})).report["rate_hz"] == pytest.approx(RATE_HZ / (1 - 6e-3), rel=1e-8)


def test_a_latitude_the_log_contradicts(small, tmp_path):
    """The small log's vehicle rests 10 s at 56.8 deg = 0.99135 rad: a latitude given as 0.99135 to lat_deg is refused
    as radians; the wrong hemisphere draws a warning; a log that does not start at rest is not checked."""
    t, ng, na = small
    log = _rows_log(tmp_path / "a.txt", t, ng, na)
    with pytest.raises(LogFileError) as e:
        _read(log, _doc(site={"lat_deg": 0.99135}))
    _one_line(e, "site.lat_deg = 0.99135 deg (from description), but the Earth rate the gyros measure about the "
                 "vertical over the log's first 11 s at rest implies 56.8 deg", "0.99135 rad is 56.8 deg: radians "
                 "under a _deg key?")
    with pytest.warns(UserWarning, match="site.lat_deg = -56.8 deg .* implies 56.8 deg"):
        got = _read(log, _doc(site={"lat_deg": -56.8}))
    assert got.report["rest_check"]["agrees_with_site"] is False
    assert _read(log, _doc(site={"lat_deg": 56.8})).report["rest_check"]["agrees_with_site"] is True
    moving = _rows_log(tmp_path / "b.txt", t[1200:], ng[1200:], na[1200:])
    rest = _read(moving, _doc(site={"lat_deg": 0.99135})).report["rest_check"]
    assert rest["window_s"] == 0.0 and rest["agrees_with_site"] is None


# --- refusals: one line naming the key or the line -------------------------------------------------------------------
def _one_line(exc, *words):
    msg = str(exc.value)
    assert "\n" not in msg, msg
    for w in words:
        assert w in msg, (w, msg)


def test_missing_columns(small, tmp_path):
    t, ng, na = small
    log = _rows_log(tmp_path / "a.txt", t, ng, na)
    with pytest.raises(LogFileError) as e:
        _read(log, _doc(columns={"time": 0, "gyro": [1, 2, 3], "accelerometer": [4, 5, 7]}))
    _one_line(e, "line 1: has 7 fields, column 7 (accelerometer z, columns.accelerometer[2]) needs at least 8")
    csv = tmp_path / "a.csv"
    csv.write_text("t,gx,gy,gz,ax,ay,az\n0.01,1,2,3,4,5,6\n0.02,1,2,3,4,5,6\n")
    with pytest.raises(LogFileError) as e:
        _read(csv, _doc(format={"type": "csv"}, columns={"time": "t", "gyro": ["gx", "gy", "GZ"],
                                                         "accelerometer": ["ax", "ay", "az"]}))
    _one_line(e, "columns.gyro[2]: no column 'GZ' (gyro z); did you mean 'gz'?")
    with pytest.raises(ConfigError) as e:
        load_log_description(_doc(columns={"gyro": ["gx", "gy", "gz"], "accelerometer": [4, 5, 6]}))
    _one_line(e, "columns.gyro[0]: 'gx' is a name, but a text log has no names row")
    with pytest.raises(ConfigError) as e:
        load_log_description(_doc(columns={"time": 0, "gyro": [1, 2, 3], "accelerometer": [3, 5, 6]}))
    _one_line(e, "columns.accelerometer[0]: column 3 is already columns.gyro[2]")


def test_a_cell_that_is_not_a_number_names_its_line_and_column(small, tmp_path):
    t, ng, na = small
    log = _write_text_log(tmp_path / "a.txt", t[:300], ng[:300], na[:300])
    lines = log.read_text().splitlines()
    assert lines[204].startswith("2.00 ")  # 4 header lines and the comment before row 100: row i on line i + 6
    cells = lines[204].split()
    cells[3] = "1O"
    lines[204] = " ".join(cells)
    log.write_text("\n".join(lines) + "\n")
    with pytest.raises(LogFileError) as e:
        _read(log, _doc(format={"type": "text", "header_rows": 4}))
    _one_line(e, f"{log}: line 205: column 3 (gyro z): '1O' is not a finite number")
    cells[3] = "1.5"
    lines[204] = " ".join(cells)
    log.write_text("\n".join(lines) + "\n")
    with pytest.raises(LogFileError) as e:
        _read(log, _doc(format={"type": "text", "header_rows": 4}))
    _one_line(e, "line 205: column 3 (gyro z): 1.5 is not a whole number of pulses")


@pytest.mark.parametrize("header,words", [
    ("Latitude: 5648.2", "header 'Latitude' = 5648.2 for site.lat_deg: must lie in [-90, 90] (decimal degrees"),
    ("Latitude: 56 48' N", "header 'Latitude' = \"56 48' N\" is not a decimal number"),
    ("Lat: 56.8", "site.lat_deg: no header 'Latitude' in the log's header rows (header keys found: Lat, Longitude, "
                  "Height)"),
])
def test_header_values_that_are_not_a_latitude(small, tmp_path, header, words):
    t, ng, na = small
    log = _write_text_log(tmp_path / "a.txt", t[:10], ng[:10], na[:10],
                          header=(header, f"Longitude = {LON_DEG}", f"Height: {HEIGHT_M}"))
    with pytest.raises(LogFileError) as e:
        _read(log, _doc(format={"type": "text", "header_rows": 4}, site={"lat_deg": {"header": "Latitude"}}))
    _one_line(e, words)


@pytest.mark.parametrize("over,words", [
    ({"site": {"lat_deg": 5648.2}}, "site.lat_deg: must lie in [-90, 90] deg, got 5648.2 (decimal degrees"),
    ({"site": {"lat_rad": 0.99}}, "site.lat_rad: unknown unit in 'lat_rad': write lat_deg"),
    ({"time": {"rate_hz": 100, "gaps": "fill_mean"}, "columns": {"gyro": [0, 1, 2], "accelerometer": [3, 4, 5]}},
     "time.gaps: needs a time column"),
    ({"columns": {"gyro": [0, 1, 2], "accelerometer": [3, 4, 5]}, "time": {}}, "time.rate_hz: needed without a time"),
    ({"gyro": {"kind": "counts", "weight_deg": 1e-5}}, "gyro.weight_deg: unknown unit: write one of weight_arcsec, "
                                                       "weight_rad"),
    ({"gyro": {"kind": "counts"}}, "gyro.weight_arcsec: counts need exactly one weight key"),
    ({"gyro": {"kind": "rates", "weight_arcsec": 0.1}}, "gyro.weight_arcsec: a weight is for counts"),
    ({"gyro": {"kind": "rates", "unit": "m_s2"}}, "gyro.unit: rates need a unit, one of ['rad_s', 'deg_s'"),
    ({"accelerometer": {"kind": "counts", "weight_ug_s": 0}}, "accelerometer.weight_ug_s: must be finite and != 0"),
    ({"format": {"type": "parquet", "delimiter": "tab"}}, "format.delimiter: only for text and csv logs"),
    ({"format": {"type": "csv", "delimiter": "whitespace"}}, "format.delimiter: a csv log's fields are split by"),
    ({"axes": None}, "axes: must be a convention string (e.g. RFU) or a 3x3 matrix"),
])
def test_description_refusals_name_the_key(over, words):
    with pytest.raises(ConfigError) as e:
        load_log_description(_doc(**over))
    _one_line(e, "log description (dict): " + words.split(":")[0], words)


def test_description_errors_in_a_file_name_the_line(tmp_path):
    path = tmp_path / "d.yaml"
    path.write_text(DESCRIPTION.replace("axes: right-forward-up", "axes: forward-right-up"))
    with pytest.raises(ConfigError) as e:
        load_log_description(path)
    _one_line(e, f"{path}:7:1: axes: 'forward-right-up' is left-handed")


# --- the command line ------------------------------------------------------------------------------------------------
def test_cli_end_to_end(small, tmp_path, capsys):
    t, ng, na = small
    log = _write_text_log(tmp_path / "unit7.log", t, ng, na)
    desc = tmp_path / "unit7.yaml"
    desc.write_text(DESCRIPTION)
    out = tmp_path / "unit7.parquet"
    assert main(["import-log", str(log), "--describe", str(desc), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "3000 rows -> 3000 intervals at 100 Hz (30 s" in text
    assert "duplicates dropped: 0; gaps: none" in text and "site: lat 56.8 deg, lon 37.6 deg, height 150 m" in text
    # 11 s at rest: one pulse per axis of quantisation is sqrt(3) 0.1 arcsec / (Omega 11 s) = 1.0e-3 in sin(lat),
    # 0.11 deg at 56.8 deg
    rest = re.search(r"at rest for the first 11 s: the gyros' Earth rate about the vertical implies latitude (\S+) "
                     r"deg\n", text)
    assert rest and abs(float(rest.group(1)) - LAT_DEG) < 0.11
    assert read_log_table(out)[3]["report"]["rows"] == 3000
    # an existing output: refused without --force, replaced with it
    assert main(["import-log", str(log), "--describe", str(desc), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--out:" in err and "already exists; pass --force" in err
    assert main(["import-log", str(log), "--describe", str(desc), "--out", str(out), "--force"]) == 0
    capsys.readouterr()
    # bad input: exit 2, one line
    bad = tmp_path / "bad.yaml"
    bad.write_text(DESCRIPTION.replace("right-forward-up", "FRU"))
    assert main(["import-log", str(log), "--describe", str(bad), "--out", str(tmp_path / "x.parquet")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("sins-sim: error: ") and "axes: 'FRU' is left-handed" in err
    assert not (tmp_path / "x.parquet").exists()
    assert main(["import-log", str(log), "--describe", str(desc), "--out", str(tmp_path / "x.csv")]) == 2
    assert "must end in .parquet" in capsys.readouterr().err
    assert main(["import-log", str(tmp_path / "none.log"), "--describe", str(desc), "--out",
                 str(tmp_path / "y.parquet")]) == 2
    assert "none.log: cannot read: no such file" in capsys.readouterr().err


# --- the bundled sample ----------------------------------------------------------------------------------------------
SAMPLE = ROOT / "scenarios" / "logs"


def _sample_truth():
    """The bundled sample's vehicle: 20 s at rest heading 30 deg at 56.8 N, 37.6 E, 150 m; 5 m/s in 10 s; 10 s on."""
    return Trajectory(math.radians(LAT_DEG), math.radians(LON_DEG), HEIGHT_M, 0.0, math.radians(30.0),
                      [Stationary(20.0), Accelerate(10.0, 5.0), Cruise(10.0)])


def _sample_text() -> str:
    truth = _sample_truth()
    t = np.arange(1, int(round(truth.duration_s * RATE_HZ)) + 1) / RATE_HZ
    ng, na = _rfu_counts(*ideal_increments(truth, t))
    lines = ["RLG-7 strapdown unit, serial 0412, pulse log (a sins-sim sample: tests/test_unitlog.py writes it)",
             f"Latitude: {LAT_DEG}", f"Longitude = {LON_DEG}", f"Height: {HEIGHT_M}",
             "# time_s  gR gF gU [0.1 arcsec]  aR aF aU [125 ug s]"]
    for i in range(t.size):
        if i == 2000:
            lines.append("# drive off")
        lines.append(" ".join([f"{t[i]:.2f}", *map(str, ng[i]), *map(str, na[i])]))
    return "\n".join(lines) + "\n"


def test_the_bundled_sample_is_what_it_says(tmp_path):
    """scenarios/logs/rlg-unit7.log (written by _sample_text) is the pulse counter's log of _sample_truth: imported
    with its description, every interval is within one pulse of the exact increments and the running sum never a
    pulse off (the bounds of the round trip above; not a comparison of the text, which a last-digit difference in
    another machine's increments could flip by a pulse); its truth file navigates it."""
    text = (SAMPLE / "rlg-unit7.log").read_text()
    assert text.splitlines()[:5] == _sample_text().splitlines()[:5]
    out = tmp_path / "unit7.parquet"
    meta = import_log(SAMPLE / "rlg-unit7.log", SAMPLE / "rlg-unit7.yaml", out)
    assert meta["report"]["rows"] == 4000 and meta["report"]["rate_hz"] == RATE_HZ
    t, dth, dv, _ = read_log_table(out)
    exact = ideal_increments(_sample_truth(), t)
    for got, ex, w in ((dth, exact[0], W_GYRO), (dv, exact[1], W_ACCEL)):
        float_tol = t.size * EPS * np.max(np.abs(np.cumsum(ex, axis=0)))
        assert np.max(np.abs(got - ex)) < w + float_tol
        assert np.max(np.abs(np.cumsum(got - ex, axis=0))) < w + float_tol
    assert main(["navigate", str(out), "--truth", str(SAMPLE / "rlg-unit7-truth.csv"), "--out",
                 str(tmp_path / "nav")]) == 0
