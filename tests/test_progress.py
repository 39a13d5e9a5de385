"""Progress that tells the truth (issue 22, point 8): a compile phase with its own estimate when numba's cache is
cold, run estimates calibrated on the machine that runs them, and configuration errors before the heavy imports.

The calibration arithmetic is checked against hand-computed values of its definition
(``sins_sim.jobs.estimate.record_timing``: measured speed over the model's between the first and the last
progress report; compile time = time to the first report minus the first chunk's share at that speed).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from sins_sim.jobs import estimate as es

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    return tmp_path / "xdg" / "sins-sim"


def _est(compile_s=0.0, kind="run"):
    """A run the model puts at 3 s fixed + 10 s of simulation."""
    return {"simulated_s": 100.0, "wall_s": 13.0, "breakdown": {"fixed_s": 3.0, "chains_s": 10.0}, "kind": kind,
            "compile_s": compile_s, "calibration": {"ratio": 1.0, "runs": 0}}


def test_cache_dir_follows_xdg_and_falls_back_to_home(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "x"))
    assert es.cache_dir() == tmp_path / "x" / "sins-sim"
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert es.cache_dir() == tmp_path / "home" / ".cache" / "sins-sim"


def test_uncalibrated_estimate_is_the_model_and_says_so(cache):
    out = es.calibrate(_est())
    assert out["wall_display_s"] == pytest.approx(13.0)
    assert out["calibration"]["runs"] == 0 and "not yet calibrated" in out["calibration"]["text"]


def test_a_measured_run_calibrates_the_next_estimate(cache):
    """First report at t = 12 s after the start with 10 % done, last at t = 30 s with all done, end at 35 s:
    speed ratio (30 - 12) / (0.9 x 10 s) = 2; compile 12 - 0.1 x 10 x 2 = 10 s; tail 5 s. The next estimate
    of the same run: 5 + 2 x 10 = 25 s."""
    cal = es.record_timing(_est(compile_s=30.0), 0.0, 12.0, 0.1, 30.0, 1.0, t_end=35.0)
    assert cal["ratios"]["run"] == [pytest.approx(2.0)]
    assert cal["compile_s"] == pytest.approx(10.0)
    assert cal["tails"]["run"] == [pytest.approx(5.0)]
    assert json.loads((cache / "calibration.json").read_text()) == cal
    out = es.calibrate(_est())
    assert out["wall_display_s"] == pytest.approx(25.0)
    assert out["calibration"]["runs"] == 1 and "calibrated on this machine" in out["calibration"]["text"]
    # the median of the last runs: 2, 4, 3 -> 3
    es.record_timing(_est(), 0.0, 1.0, 0.1, 1.0 + 4.0 * 9.0, 1.0, t_end=37.0 + 5.0)
    es.record_timing(_est(), 0.0, 1.0, 0.1, 1.0 + 3.0 * 9.0, 1.0, t_end=28.0 + 5.0)
    assert es.calibrate(_est())["wall_display_s"] == pytest.approx(5.0 + 3.0 * 10.0)
    # another kind of job keeps its own ratio
    assert es.calibrate(_est(kind="channel"))["calibration"]["runs"] == 0


def test_an_unfinished_run_calibrates_nothing(cache):
    es.record_timing(_est(compile_s=30.0), 0.0, 12.0, 0.1, 20.0, 0.6, t_end=21.0)
    assert not (cache / "calibration.json").exists()


def test_compile_phase_only_while_the_kernels_cache_is_cold(cache, tmp_path, monkeypatch):
    """An empty numba cache folder and no run recorded: cold, with the built-in compile estimate; after a finished
    run with these kernels: warm; after the kernels change (another stamp): cold again, with the measured time."""
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "numba-empty"))
    assert es.kernels_cold("run")
    assert es.calibrate(_est())["compile_s"] == es.COMPILE_S
    es.record_timing(_est(compile_s=es.COMPILE_S), 0.0, 12.0, 0.1, 30.0, 1.0, t_end=31.0)
    assert not es.kernels_cold("run") and es.calibrate(_est())["compile_s"] == 0.0
    assert es.kernels_cold("channel")  # a channel job has not run with these kernels
    monkeypatch.setattr(es, "_kernel_stamp", lambda: "kernels edited")
    assert es.calibrate(_est())["compile_s"] == pytest.approx(10.0)


def test_progress_shows_the_compile_phase_then_the_run(cache, capsys):
    from sins_sim.cli import _Progress

    p = _Progress("demo", disable=False)
    p.estimate(es.calibrate(_est()) | {"compile_s": 40.0})
    p(0.05)
    p(1.0)
    p.close()
    err = capsys.readouterr().err
    assert "demo: compiling (first run only)" in err and "estimate 40 s" in err
    # two reports are too few to measure the run's speed: the model's figure is named as the model's
    assert "100/100 s" in err and "estimating the time left (model: 13 s, not yet calibrated)" in err
    assert err.index("compiling (first run only)") < err.index("100/100 s")


def test_progress_without_a_cold_cache_has_no_compile_phase(cache, capsys):
    from sins_sim.cli import _Progress

    p = _Progress("demo", disable=False)
    p.estimate(es.calibrate(_est()) | {"compile_s": 0.0})
    p(1.0)
    p.close()
    assert "compiling" not in capsys.readouterr().err


def test_after_the_engine_the_bar_says_the_files_are_being_written(cache, capsys):
    """The engine's last report is 100 %; writing metrics and figures can take as long again (a mission with
    aiding draws three figures per filter), so the bar replaces its time left by what is being done."""
    from sins_sim.cli import _Progress

    p = _Progress("demo", disable=False)
    p.estimate(es.calibrate(_est()) | {"compile_s": 0.0})
    p(1.0)
    p.phase("simulation done; writing metrics")
    p.close()
    err = capsys.readouterr().err
    assert err.rstrip().endswith("simulation done; writing metrics]")


def test_run_scenario_tells_the_phase_after_the_engine(tmp_path):
    """``run_scenario`` calls ``progress.phase`` once, after the engine's last report and before the files."""
    from sins_sim.jobs.run import run_scenario

    calls = []

    class Recorder:
        def __call__(self, fraction):
            calls.append(("fraction", float(fraction)))

        def phase(self, text):
            calls.append(("phase", text, (tmp_path / "out" / "metrics.json").exists()))

    doc = tmp_path / "s.yaml"
    doc.write_text("name: phase\nimu: " + str(ROOT / "configs" / "default-imu.yaml") + "\nduration_s: 0.2\n"
                   "navigation: {start_s: 0.05}\noutputs: {plots: false}\n")
    run_scenario(doc, tmp_path / "out", progress=Recorder())
    phases = [c for c in calls if c[0] == "phase"]
    assert len(phases) == 1 and "writing metrics" in phases[0][1] and not phases[0][2]
    assert calls.index(phases[0]) == len(calls) - 1 and calls[-2] == ("fraction", 1.0)


# --- configuration errors before the heavy imports -----------------------------------------------------------
_PROBE = """
import sys
from sins_sim.cli import main
status = main(["run", sys.argv[1], "--out", sys.argv[2]])
heavy = sorted(m for m in ("numba", "scipy", "dask", "matplotlib", "pandas", "sins_sim.simulation.sins",
                           "sins_sim._kernels", "sins_sim.models") if m in sys.modules)
print(status, ",".join(heavy))
"""


@pytest.mark.parametrize("body, message", [
    ("name: bad\nimu: {imu}\nduration_s: -1\n", "duration_s: must be > 0, got -1"),
    ("name: bad\nimu: {imu}\nduration_s: 5\nfilters: [corecting]\n", "filters[0]: must be one of"),
    ("name: bad\nimu: {imu}\nduration_s: 5\nnavigation: {{start_s: 9}}\n", "navigation.start_s: must be < duration_s"),
    ("name: bad\nimu: {imu}\nduration: 5\n", "duration: needs a unit: write duration_s"),
    ("name: bad\nimu: {imu}\nduration_s: [5\n", ""),  # a YAML syntax error
])
def test_a_scenario_error_comes_before_numba_and_the_engine(tmp_path, body, message):
    """``sins-sim run bad.yaml`` reports the scenario's error (exit status 2) without having imported numba,
    scipy, dask, matplotlib, pandas, the models or the engine: the error appears in a fraction of a second
    instead of after the 3-15 s those imports take (measured here: 0.4 s against 3.7-4.1 s before)."""
    sc = tmp_path / "bad.yaml"
    sc.write_text(body.format(imu=ROOT / "configs" / "default-imu.yaml"))
    line = _refused_light(_PROBE, sc, tmp_path / "out")
    assert line.startswith("sins-sim: error: ") and message in line and "\n" not in line


def _refused_light(probe: str, scenario, out) -> str:
    """Run ``probe`` on ``scenario`` in a fresh interpreter; assert exit status 2 with nothing heavy imported and
    return the error line."""
    r = subprocess.run([sys.executable, "-c", probe, str(scenario), str(out)], capture_output=True,
                       text=True, cwd=ROOT, timeout=120)
    status, heavy = r.stdout.split()[0], r.stdout.split()[1:]
    assert status == "2", r.stdout + r.stderr
    assert heavy == [], f"imported before the error: {heavy}"
    return r.stderr.strip()


_IMU = (ROOT / "configs" / "default-imu.yaml").read_text()
#: As _PROBE; the packages and their constants-only modules (``ranges``, the filter ``registry``) may be loaded,
#: no model, filter or engine module may.
_IMU_PROBE = """
import sys
from sins_sim.cli import main
status = main(["run", sys.argv[1], "--out", sys.argv[2]])
heavy = sorted(m for m in sys.modules if m.split(".")[0] in ("numba", "scipy", "dask", "matplotlib", "pandas")
               and "." not in m or m.startswith(("sins_sim.simulation.", "sins_sim._kernels", "sins_sim.models.",
                                                 "sins_sim.filters.")) and not m.endswith((".ranges", ".registry")))
print(status, ",".join(heavy))
"""


@pytest.mark.parametrize("old, new, message", [
    ("k3: 4.4e-3", "k3x: 4.4e-3", "suspension.k3x: unknown key; did you mean 'k3'?"),
    ("k3: 4.4e-3", "k3: 4.4", "suspension.k3: must be <= 0.2, got 4.4"),
    ("f0_hz: 386", "f0_hz: -386", "channels.x.f0_hz: must be >= 20"),
    ("rate_hz: 72000, hysteresis", "rate_hz: fast, hysteresis", "plant.rate_hz: must be a number"),
    ("rs_db: 60", "rs_db: 600", "eliminator.rs_db: must be <= 200"),
    ("output_rate_hz: 7200", "output_rate_hz: 7000", "plant.rate_hz / output_rate_hz must be a whole number"),
])
def test_an_imu_error_comes_before_numba_and_the_models(tmp_path, old, new, message):
    """``sins-sim run`` of a scenario whose IMU file is wrong (a misspelt key, a value out of the models' range, a
    wrong type, rates that do not divide) reports it, naming the IMU file, the line and the key, without having
    imported numba, scipy, the models or the engine: the IMU schema is built from the ranges the models declare in
    ``sins_sim.models.ranges`` / ``sins_sim.filters.ranges`` (no heavy import there). Measured on the 2-core
    machine, loaded: 0.6-0.75 s wall for ``sins-sim run`` against 3.6 s before (2026-11-27,
    ``time sins-sim run s.yaml``, suspension.k3 misspelt)."""
    assert old in _IMU
    imu = tmp_path / "imu.yaml"
    imu.write_text(_IMU.replace(old, new, 1))
    sc = tmp_path / "bad.yaml"
    sc.write_text(f"name: bad\nimu: {imu}\nduration_s: 5\n")
    line = _refused_light(_IMU_PROBE, sc, tmp_path / "out")
    assert line.startswith(f"sins-sim: error: {sc} -> imu.yaml:") and message in line and "\n" not in line


def test_an_inline_imu_error_from_the_api_comes_before_numba(tmp_path):
    """The notebook path: ``load_imu(dict)`` and ``load_scenario(dict)`` with an inline IMU refuse a misspelt key
    with a ConfigError before numba, scipy or the models are imported."""
    probe = """
import sys
import sins_sim
from sins_sim.config.errors import ConfigError
msgs = []
for call in (lambda: sins_sim.load_imu({"channels": {"x": {"f0_hz": 386}, "y": {"f0_hz": 352},
                                                     "z": {"f0_hz": 421}}, "suspension": {"k33": 1e-3}}),
             lambda: sins_sim.load_scenario({"name": "s", "duration_s": 5, "imu": {"channels": {"x": {"f0_hz": 386},
                                             "y": {"f0_hz": 352}, "z": {"f0_hz": 421}}, "plant": {"rate": 1}}})):
    try:
        call()
    except ConfigError as exc:
        msgs.append(str(exc))
heavy = sorted(m for m in ("numba", "scipy", "sins_sim._kernels", "sins_sim.models.suspension",
                           "sins_sim.simulation.sins") if m in sys.modules)
print(repr(msgs), "|", ",".join(heavy))
"""
    r = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, cwd=ROOT, timeout=120)
    msgs, heavy = r.stdout.rsplit("|", 1)
    assert heavy.strip() == "", f"imported before the error: {heavy}" + r.stderr
    assert "IMU (dict): suspension.k33: unknown key; did you mean 'k3'?" in msgs
    assert "scenario (dict): imu.plant.rate: " in msgs


def test_an_imu_error_is_still_reported(tmp_path):
    """An error in the IMU file is one line (in process, after the models may already be loaded)."""
    from sins_sim.cli import main

    imu = tmp_path / "imu.yaml"
    imu.write_text((ROOT / "configs" / "default-imu.yaml").read_text().replace("f0_hz: 386", "f0_hz: -386"))
    sc = tmp_path / "s.yaml"
    sc.write_text(f"name: s\nimu: {imu}\nduration_s: 2\n")
    assert "f0_hz: -386" in imu.read_text()
    assert main(["run", str(sc), "--out", str(tmp_path / "out")]) == 2
