"""``sins-sim identify`` on a log that fails its data checks: the verdict ``invalid data``, in a folder, in one line.

The logs are made here at rest from closed forms (``C_bn w_ie^n``, ``C_bn (0, 0, -g)``: Titterton and Weston 2004,
sec. 10.2) with white noise, then quantised as a unit's pulse counter does (the whole pulses of the running sum,
the remainder carried), and then spoilt in one known place.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from test_identify_twin import H_M, HEADING, LAT, N_SI, VRW_SI  # noqa: E402  (shared log constants)

from sins_sim.earth import earth_rate_ned, gravity_down  # noqa: E402
from sins_sim.identification.log_checks import check_log  # noqa: E402
from sins_sim.jobs.import_log import write_log_table  # noqa: E402
from sins_sim.units import ARCSEC  # noqa: E402

DT = 0.01
#: The bundled unit's pulse weights: 0.1 arcsec and 125 ug s.
Q_GYRO, Q_ACCEL = 0.1 * ARCSEC, 125e-6 * 9.80665


def _quantise(x, q, rng):
    """Whole pulses per interval of the running sum, the counter starting at a random residue."""
    total = np.cumsum(x, axis=0) / q + rng.random(x.shape[1])
    counts = np.diff(np.floor(total), axis=0, prepend=np.floor(total[:1] - x[:1] / q))
    return counts * q


def rest_increments(seed, seconds=60.0, quantised=True):
    rng = np.random.default_rng(seed)
    n = int(seconds / DT)
    t = np.arange(1, n + 1) * DT
    c, s = math.cos(HEADING), math.sin(HEADING)
    c_nb = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    dth = np.tile(c_nb.T @ earth_rate_ned(LAT) * DT, (n, 1)) + rng.standard_normal((n, 3)) * N_SI * math.sqrt(DT)
    dv = (np.tile(c_nb.T @ np.array([0.0, 0.0, -gravity_down(LAT, H_M)]) * DT, (n, 1))
          + rng.standard_normal((n, 3)) * VRW_SI * math.sqrt(DT))
    if quantised:
        dth, dv = _quantise(dth, Q_GYRO, rng), _quantise(dv, Q_ACCEL, rng)
    return t, dth, dv


def _write(path, t, dth, dv, meta=None):
    write_log_table(path, t, dth, dv, meta or {"site": {"lat_rad": LAT, "lon_rad": 0.2, "height_m": H_M}})
    return path


def test_clean_logs_pass_quantised_or_not():
    # the stuck check's union bound holds a false finding below STUCK_ALPHA = 1e-3 per log for independent samples;
    # a pulse counter's counts at rest repeat in runs of about 1 / frac(pulses per interval), which are the channel's
    # common values and pass. Six logs, three quantised (the horizontal accelerometers count 0 or 1 pulse over
    # hundreds of intervals) and three not: none may give a finding (a chance below 6e-3 if the bound holds)
    for seed in range(3):
        for quantised in (True, False):
            assert check_log(*rest_increments(seed, quantised=quantised), nominal_rate_hz=100.0) == []


def test_each_check_names_its_channel_row_and_time():
    t, dth, dv = rest_increments(7)
    # time order: row 3001 repeats row 3000's time
    tb = t.copy()
    tb[3000] = tb[2999]
    f = check_log(tb, dth, dv)[0]
    assert (f["check"], f["channel"], f["sample"]) == ("time order", "time", 3000)
    assert f["time_s"] == pytest.approx(t[2999]) and "sort the log by time" in f["remedy"]
    # a gap: four intervals missing after row 2000 (the time axis jumps by five periods)
    tg = t.copy()
    tg[2000:] += 4 * DT
    f = check_log(tg, dth, dv)
    assert [x["check"] for x in f] == ["time gap"]
    assert f[0]["sample"] == 1999 and f[0]["time_s"] == pytest.approx(20.0)
    assert "4 interval(s) of 0.01 s missing" in f[0]["message"] and "--until-s 20" in f[0]["remedy"]
    # one step 0.2 % long (the tolerance is 0.1 %): the next row's time is off the even axis
    tj = t.copy()
    tj[1500:] += 0.002 * DT
    f = check_log(tj, dth, dv)
    assert [(x["check"], x["sample"]) for x in f] == [("time step", 1500)]
    # the rate against the description's: 100 Hz logged, 100.2 Hz nominal (0.2 % off); 100.05 Hz passes
    assert [x["check"] for x in check_log(t, dth, dv, nominal_rate_hz=100.2)] == ["rate"]
    assert check_log(t, dth, dv, nominal_rate_hz=100.05) == []
    # a float channel (no readout quantum) held at its last value for 50 samples from row 4000: its smallest step
    # between values is a few float spacings, so 2 q / sigma_L and the bound on the chance are far below 1e-3 / 6
    t2, dth2, dv2 = rest_increments(8, quantised=False)
    dth2[4000:4050, 1] = dth2[3999, 1]
    f = check_log(t2, dth2, dv2)
    assert [(x["check"], x["channel"], x["sample"]) for x in f] == [("stuck", "gyro y", 3999)]
    assert "stuck at" in f[0]["message"] and f[0]["time_s"] == pytest.approx(t2[3999])
    # a quantised gyro clipped at a count above its largest for 30 samples: saturated. Its noise per sample (ARW
    # 0.003 deg/sqrt(h): 8.7e-8 rad) is a fifth of a pulse (4.8e-7 rad), so a run of 30 equal counts alone is
    # common (the log has one of 38 at its usual count); this one sits 30 (c q - mean) ~ 60 q from where 30 samples
    # sum to, z ~ 60 / sqrt(30 * 0.03) ~ 60
    dth[5000:5030, 2] = dth[:, 2].max() + Q_GYRO
    f = check_log(t, dth, dv)
    assert [(x["check"], x["channel"], x["sample"]) for x in f] == [("stuck", "gyro z", 5000)]
    assert "saturated" in f[0]["message"] and "--until-s 50" in f[0]["remedy"]


@pytest.fixture(scope="module")
def gappy(tmp_path_factory):
    folder = tmp_path_factory.mktemp("invalid")
    t, dth, dv = rest_increments(3)
    t = t.copy()
    t[2500:] += 2 * DT                                   # two intervals missing after 25 s
    return _write(folder / "gappy.parquet", t, dth, dv), folder


def test_identify_writes_the_verdict_invalid_data_with_its_finding(gappy):
    from sins_sim.jobs.identify import identify

    log, folder = gappy
    m = identify(log, folder / "out", twin_seeds=2)
    assert m.invalid and m.verdict["status"] == "invalid data" and m.figures == []
    (check,) = m.verdict["checks"]
    assert (check["check"], check["sample"]) == ("time gap", 2499) and check["time_s"] == pytest.approx(25.0)
    assert sorted(m.files) == ["metrics.json", "report.md"]
    saved = json.loads((folder / "out" / "metrics.json").read_text())
    assert saved["verdict"]["status"] == "invalid data" and saved["verdict"]["checks"][0]["check"] == "time gap"
    assert saved["summary"].startswith("invalid data: time gap: rows 2500-2501") and "\n" not in saved["summary"]
    manifest = json.loads((folder / "out" / "manifest.json").read_text())
    assert manifest["command"] == "identify"
    report = (folder / "out" / "report.md").read_text()
    assert "**invalid data**" in report and "| time gap | time | 25 | 2500 |" in report and "--until-s 25" in report
    assert list(m.to_pandas()) == ["checks"] and m.to_pandas()["checks"]["check"].tolist() == ["time gap"]
    with pytest.raises(ValueError, match="invalid data"):
        m.plot("psd")
    # the remedy it names works: the 25 s before the gap pass the checks and are fitted
    fitted = identify(log, None, until_s=25.0, twin_seeds=0)
    assert not fitted.invalid and "noise" in fitted


def test_the_command_prints_one_line_and_exits_0_as_diagnose_does(gappy, capsys):
    from sins_sim.cli import main

    log, folder = gappy
    assert main(["identify", str(log), "--out", str(folder / "cli"), "--twin-seeds", "0"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("invalid data: time gap: rows 2500-2501: a gap from 25 to 25.03 s, 2 interval(s)")
    assert out[1].startswith(f"wrote {folder / 'cli'}: metrics.json, report.md") and len(out) == 2
    assert (folder / "cli" / "manifest.json").is_file()
