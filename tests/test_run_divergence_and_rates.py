"""Issue 12, points 1 and 5, through the command line.

1. A filter that diverges is reported as diverged (which filter, axis, time, why) in ``metrics.json`` and
   ``report.md``, and the run goes on for the others: the paper form of eq. 5 under a 100 deg/s turn about z.
5. The metrics come from the full-rate solution: ``navigation.timeseries_rate_hz`` changes only what is
   stored, never the final errors (it used to: 0.0177 m at 720 Hz, 0 at 1 Hz, an IndexError at 0.3 Hz).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
import yaml

from sins_sim.cli import main

ROOT = Path(__file__).resolve().parents[1]
IMU = str(ROOT / "configs" / "default-imu.yaml")


def _write(tmp_path, name, **doc):
    base = {"name": name, "imu": IMU, "outputs": {"plots": False}}
    base.update(doc)
    p = tmp_path / f"{name}.yaml"
    p.write_text(yaml.safe_dump(base))
    return p


def _finite_numbers(tree):
    if isinstance(tree, dict):
        for v in tree.values():
            yield from _finite_numbers(v)
    elif isinstance(tree, list):
        for v in tree:
            yield from _finite_numbers(v)
    elif isinstance(tree, (int, float)) and not isinstance(tree, bool):
        yield tree


def test_a_diverging_filter_is_reported_and_the_run_goes_on(tmp_path, capsys):
    p = _write(tmp_path, "turn", duration_s=15.0, navigation={"start_s": 1.0},
               motion=[{"type": "constant_rate", "rate_deg_s": [0.0, 0.0, 100.0]}])
    out = tmp_path / "out"
    assert main(["run", str(p), "--out", str(out), "--quiet"]) == 0
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err and "error" not in captured.err
    assert "diverged: correcting_paper, axis z, t = " in captured.out
    metrics = json.loads((out / "metrics.json").read_text())
    div = metrics["diverged"]
    assert set(div) == {"correcting_paper"}
    d = div["correcting_paper"]
    assert d["axis"] == "z" and 5.0 < d["time_s"] < 15.0 and isinstance(d["reason"], str) and d["reason"]
    assert metrics["filters"]["correcting_paper"]["status"] == "diverged"
    assert metrics["filters"]["correcting_paper"]["diverged"] == d
    for name in ("ideal", "eliminator", "correcting"):
        m = metrics["filters"][name]
        assert m["status"] == "ok" and m["diverged"] is None
        # complete: every metric of the filter is there and finite, navigated to the end
        for key in ("horizontal_position_error_m", "vertical_position_error_m", "velocity_error_m_s",
                    "attitude_error_arcsec", "attitude_drift_deg_h", "gyro_drift_deg_h", "events"):
            assert key in m, (name, key)
        assert m["navigated_s"] == pytest.approx(14.0, abs=0.01)
        assert all(math.isfinite(x) for x in _finite_numbers(m)), name
        assert m["horizontal_position_error_m"]["final"] < 0.01
    report = (out / "report.md").read_text()
    assert "## Diverged filters" in report
    assert f"- correcting_paper: axis z, t = {d['time_s']:.4g} s: {d['reason']}" in report
    assert "| correcting_paper |" in report and "| diverged |" in report


def test_final_errors_do_not_depend_on_the_stored_series_rate(tmp_path, capsys):
    finals = {}
    for rate in (400, 7.2, 1, 0.3):  # 400 Hz: every update at the default navigation rate
        p = _write(tmp_path, f"rate{rate}", duration_s=2.2,
                   navigation={"start_s": 1.0, "timeseries_rate_hz": rate},
                   motion=[{"type": "coning", "amplitude_arcmin": 1.0, "frequency_hz": 100.0}])
        out = tmp_path / f"out{rate}"
        assert main(["run", str(p), "--out", str(out), "--quiet"]) == 0, capsys.readouterr().err
        metrics = json.loads((out / "metrics.json").read_text())
        finals[rate] = {name: (m["horizontal_position_error_m"]["final"], m["velocity_error_m_s"]["final"],
                               m["attitude_error_arcsec"]["rms"]["down"])
                        for name, m in metrics["filters"].items()}
    assert "Traceback" not in capsys.readouterr().err
    assert finals[400]["correcting"][0] > 0.0
    assert finals[400] == finals[7.2] == finals[1] == finals[0.3]  # identical, not merely close
