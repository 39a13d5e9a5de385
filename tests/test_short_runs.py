"""Short runs with plots (issue 25, item 7): a run of 0.1 s, or a stored series slower than the run, used to fail
after the simulation with matplotlib's "Data cannot be log-scaled" and write nothing. Now the run completes and
writes the figures that have data, and report.md lists exactly those."""

import re
import warnings

import pytest

from sins_sim.cli import main

IMU = "{channels: {x: {f0_hz: 386}, y: {f0_hz: 352}, z: {f0_hz: 421}}}"


@pytest.mark.parametrize("body", [
    "duration_s: 0.1\nnavigation: {start_s: 0.02}\n",
    "duration_s: 3\nnavigation: {timeseries_rate_hz: 0.3}\n",
], ids=["0.1 s", "series slower than the run"])
def test_short_runs_with_plots_complete(tmp_path, body, capsys):
    sc = tmp_path / "s.yaml"
    sc.write_text(f"name: s\nimu: {IMU}\n{body}")
    out = tmp_path / "o"
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)  # matplotlib's warnings are UserWarnings
        assert main(["run", str(sc), "--out", str(out), "--quiet"]) == 0
    written = {p.name for p in out.glob("*.png")}
    listed = set(re.findall(r"!\[[^\]]*\]\(([^)]+\.png)\)", (out / "report.md").read_text()))
    assert written == listed and written  # at least the spectrum has data
    assert "Traceback" not in capsys.readouterr().err
