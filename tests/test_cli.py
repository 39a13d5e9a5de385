"""The command line (sins_sim.cli.main), run in-process."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from sins_sim.cli import main

RMS_KEYS = {"raw", "eliminator", "correcting", "correcting_paper"}


def test_channel_writes_png_metrics_and_timeseries(tmp_path, capsys):
    out = tmp_path / "run"
    rc = main(["channel", "--duration", "0.6", "--settle", "0.3", "--out", str(out), "--quiet"])
    assert rc == 0
    captured = capsys.readouterr()
    assert captured.err == ""  # --quiet: no progress bar, and nothing went wrong
    assert (out / "channel.png").stat().st_size > 1000
    assert (out / "channel.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    metrics = json.loads((out / "metrics.json").read_text())
    rms = metrics["residual_rms_arcsec"]
    assert set(rms) == RMS_KEYS
    for name, val in rms.items():
        assert isinstance(val, float) and math.isfinite(val) and val > 0.0, name
    # the raw readout carries the dither (> 100 arcsec RMS); the filters remove most of it
    assert rms["raw"] > 100.0
    assert rms["correcting"] < 2.0 and rms["eliminator"] < 2.0
    with np.load(out / "timeseries.npz") as ts:
        assert RMS_KEYS <= set(ts.files)
        assert ts["t"].size == round(0.6 * 7200)
        for name in RMS_KEYS:
            assert ts[name].shape == ts["t"].shape


# the error names the flag the user typed, not the internal field (suspension.f0_hz -> --f0)
@pytest.mark.parametrize("args, field", [
    (["--f0", "-1"], "--f0"),
    (["--f0", "nan"], "--f0"),
    (["--k2", "0"], "--k2"),
    # 72000 / 700 is not an integer: the decimation rule fires first
    (["--filter-rate", "700"], "--filter-rate"),
    # 72000 / 720 = 100 is, and 720 Hz < 2 f0 = 772 Hz: eq. 5 needs w < pi
    (["--filter-rate", "720"], "--filter-rate"),
    (["--filter-rate", "7000"], "--filter-rate"),
])
def test_bad_input_is_one_line_error_with_status_2(tmp_path, capsys, args, field):
    out = tmp_path / "run"
    rc = main(["channel", "--duration", "0.6", "--settle", "0.3", "--out", str(out), "--quiet", *args])
    assert rc == 2
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    assert len(lines) == 1, captured.err
    assert lines[0].startswith(f"sins-sim: error: {field}")
    assert "Traceback" not in captured.err and "Traceback" not in captured.out
    assert not (out / "metrics.json").exists()


def test_filter_rate_below_twice_f0_names_the_rule(capsys, tmp_path):
    rc = main(["channel", "--out", str(tmp_path), "--quiet", "--filter-rate", "720"])
    assert rc == 2
    assert "2 x f0" in capsys.readouterr().err


def test_channel_help_exits_0(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["channel", "--help"])
    assert exc.value.code == 0
    assert "--duration" in capsys.readouterr().out
