"""The command line under misuse: bad outputs, interrupts, warnings, internal failures, library misuse.

Most tests replace the job behind a command by a small fake (monkeypatch) so
that what the CLI does around the job is checked in milliseconds; a few run
the real ``channel`` job, and one runs ``sins-sim`` as a process to send it
SIGTERM.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

import sins_sim
from sins_sim.cli import main
from sins_sim.jobs import output
from sins_sim.jobs.messages import format_warning_lines, warning_text
from sins_sim.jobs.output import (MARKER, atomic_output_dir, atomic_output_file, atomic_write_text, check_out_dir,
                                  check_out_file)
from sins_sim.config.errors import ConfigError

IS_ROOT = hasattr(os, "geteuid") and os.geteuid() == 0


def _one_error_line(captured, status_line="sins-sim: error: ") -> str:
    lines = captured.err.splitlines()
    assert lines, captured
    assert lines[-1].startswith(status_line), captured.err
    assert "Traceback" not in captured.err and "Traceback" not in captured.out
    return lines[-1]


def _leftovers(parent: Path) -> list:
    """Temporary or set-aside siblings that a run must not leave behind."""
    return sorted(p.name for p in parent.iterdir() if ".tmp-" in p.name or ".old-" in p.name)


class FakeChannel:
    """Stands in for ``sins_sim.jobs.channel.run_channel_job``: writes files, may warn, fail or be interrupted."""

    def __init__(self, files=None, raise_=None, warn=(), progress=()):
        self.files = files or {"metrics.json": "{}"}
        self.raise_ = raise_
        self.warn = warn
        self.progress = progress
        self.calls = []

    def __call__(self, config, duration_s, motion, out_dir, settle_s=None, seed=0, progress=None):
        self.calls.append({"out_dir": Path(out_dir), "settle_s": settle_s, "duration_s": duration_s})
        for name, text in self.files.items():
            (Path(out_dir) / name).write_text(text)
        for message in self.warn:
            warnings.warn(message, RuntimeWarning)
        for f in self.progress:
            progress(f)
        if self.raise_ is not None:
            raise self.raise_
        return {"residual_rms_arcsec": {"raw": 1.0}, "drive": {"frequency_hz": 384.0, "v_m": 0.39},
                "suspension": {"q_at_amplitude": 186.6}}


@pytest.fixture
def fake_channel(monkeypatch):
    def install(**kw):
        fake = FakeChannel(**kw)
        monkeypatch.setattr("sins_sim.jobs.channel.run_channel_job", fake)
        return fake
    return install


def _channel(out, *extra):
    return ["channel", "--out", str(out), "--quiet", *extra]


# --- --version ------------------------------------------------------------------------------------------
def test_version(capsys):
    """The version, then a pointer to the changelog, which has a section for it (or Unreleased for a .dev)."""
    import re
    from importlib.metadata import distribution

    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    first, second = capsys.readouterr().out.splitlines()
    assert first == f"sins-sim {sins_sim.__version__}"
    assert "CHANGELOG.md" in second
    root = Path(__file__).resolve().parents[1]
    changelog = (root / "CHANGELOG.md").read_text()
    release = re.fullmatch(r"(\d+\.\d+\.\d+)(\.dev\d+)?", sins_sim.__version__)
    assert release, sins_sim.__version__
    heading = "## [Unreleased]" if release.group(2) else f"## [{release.group(1)}]"
    assert heading in changelog
    # the installed metadata says the same, where the installed distribution is this tree (pyproject reads
    # the version from sins_sim/_version.py; another checkout's install has its own)
    dist = distribution("sins-sim")
    direct = json.loads(dist.read_text("direct_url.json") or "{}")
    if direct.get("url", "").rstrip("/") == root.as_uri():
        assert dist.version == sins_sim.__version__


# --- channel: defaults and flags ----------------------------------------------------------------------------
def test_channel_duration_1_runs_with_the_default_settle(tmp_path, capsys):
    """--settle defaulted to 1 s, so --duration 1 failed; it now adapts: min(1, duration / 2)."""
    out = tmp_path / "ch"
    assert main(_channel(out, "--duration", "1")) == 0
    assert capsys.readouterr().err == ""
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["settle_s"] == 0.5 and metrics["duration_s"] == 1.0
    assert (out / MARKER).is_file() and _leftovers(tmp_path) == []


def test_channel_default_settle_unchanged_for_long_runs(tmp_path, fake_channel):
    fake = fake_channel()
    assert main(_channel(tmp_path / "a", "--duration", "5")) == 0
    assert main(_channel(tmp_path / "b", "--duration", "0.4")) == 0
    assert [c["settle_s"] for c in fake.calls] == [1.0, 0.2]


@pytest.mark.parametrize("args, start, absent", [
    (["--duration", "1", "--settle", "2"], "sins-sim: error: --settle: ", "settle_s"),
    (["--filter-rate", "700"], "sins-sim: error: --filter-rate: --plant-rate / --filter-rate must be", "rate_hz"),
    (["--f0", "-1"], "sins-sim: error: --f0: must be > 0", "suspension."),
    (["--k5", "0"], "sins-sim: error: --k5: must be != 0", "suspension."),
    (["--plant-rate", "7200"], "sins-sim: error: --anti-alias-hz: must be < --plant-rate / 2", "cutoff_hz"),
    (["--duration", "0"], "sins-sim: error: argument --duration: must be > 0", "Traceback"),
    (["--settle", "-1"], "sins-sim: error: argument --settle: must be >= 0", "Traceback"),
    (["--seed", "-1"], "sins-sim: error: argument --seed: must be an integer >= 0", "Traceback"),
    (["--noise-arcsec", "nan"], "sins-sim: error: argument --noise-arcsec: must be a finite number", "rad"),
    (["--bogus"], "sins-sim: error: unrecognized arguments: --bogus", "usage"),
])
def test_channel_errors_name_the_flag(tmp_path, capsys, fake_channel, args, start, absent):
    fake = fake_channel()
    assert _status(_channel(tmp_path / "o", *args)) == 2
    captured = capsys.readouterr()
    assert len(captured.err.splitlines()) == 1, captured.err
    line = _one_error_line(captured)
    assert line.startswith(start), line
    assert absent not in line, line
    assert fake.calls == [] and not (tmp_path / "o").exists()


def _status(argv) -> int:
    """main's exit status, whether returned or raised by argparse."""
    try:
        return main(argv)
    except SystemExit as exc:
        return exc.code


# --- output that cannot lie ---------------------------------------------------------------------------------
@pytest.mark.parametrize("make_out, rule", [
    (lambda tmp: "", "--out: must name a directory"),
    (lambda tmp: "   ", "--out: must name a directory"),
    (lambda tmp: _file(tmp / "f"), "exists and is not a directory"),
    (lambda tmp: _file(tmp / "f") / "sub", "is not a directory"),
    (lambda tmp: _file(tmp / "d" / "mine.txt").parent, "holds files that sins-sim did not write"),
])
def test_unusable_out_is_refused_before_the_job_runs(tmp_path, capsys, fake_channel, make_out, rule):
    fake = fake_channel()
    out = make_out(tmp_path)
    before = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*"))
    assert main(_channel(out)) == 2
    line = _one_error_line(capsys.readouterr())
    assert line.startswith("sins-sim: error: --out: ") and rule in line, line
    assert fake.calls == []
    assert sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*")) == before  # nothing created or removed


def _file(path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("keep me\n")
    return path


def test_out_current_directory_is_refused(tmp_path, monkeypatch, capsys, fake_channel):
    fake = fake_channel()
    monkeypatch.chdir(tmp_path)
    (tmp_path / MARKER).write_text("")  # even a folder sins-sim wrote: renaming the cwd away is not an option
    assert main(_channel(".")) == 2
    assert "current directory" in _one_error_line(capsys.readouterr())
    assert fake.calls == []
    (tmp_path / "sub").mkdir()
    monkeypatch.chdir(tmp_path / "sub")  # the cwd inside an earlier result: it would vanish with it
    assert main(_channel(tmp_path)) == 2
    assert "one holding it" in _one_error_line(capsys.readouterr())
    assert fake.calls == [] and (tmp_path / "sub").is_dir()


def test_out_holding_the_input_is_refused(tmp_path, capsys, monkeypatch):
    record = []
    _install_run(monkeypatch, _fake_run(record))
    out = tmp_path / "o"
    assert main(["run", "scen.yaml", "--out", str(out), "--quiet"]) == 0
    scen = out / "scen.yaml"
    scen.write_text("name: kept\n")  # the user keeps the scenario in the earlier result folder
    assert main(["run", str(scen), "--out", str(out), "--quiet"]) == 2
    assert f"holds the input {scen}" in _one_error_line(capsys.readouterr())
    assert scen.read_text() == "name: kept\n" and len(record) == 1


def test_free_space_rule(tmp_path):
    with pytest.raises(ConfigError, match=r"^--out: not enough free disk space for .* need at least"):
        check_out_dir(tmp_path / "x", "--out", min_free_bytes=2 ** 62)
    with pytest.raises(ConfigError, match=r"^--json: not enough free disk space"):
        check_out_file(tmp_path / "x.json", "--json", min_free_bytes=2 ** 62)
    assert check_out_dir(tmp_path / "x", "--out") == tmp_path / "x"


@pytest.mark.skipif(IS_ROOT or os.name != "posix", reason="root may write anywhere")
def test_unwritable_parent_is_refused(tmp_path):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o555)
    try:
        with pytest.raises(ConfigError, match="no permission to write"):
            check_out_dir(locked / "out", "--out")
    finally:
        locked.chmod(0o755)


def test_success_replaces_the_earlier_result_whole(tmp_path, capsys, fake_channel):
    """With --force (issue 22, point 5: never without it) the new result replaces the earlier one whole."""
    out = tmp_path / "ch"
    fake_channel(files={"metrics.json": "first", "stale.txt": "only in the first run"})
    assert main(_channel(out)) == 0
    assert (out / "stale.txt").exists()
    fake_channel(files={"metrics.json": "second"})
    assert main(_channel(out, "--force")) == 0
    assert sorted(p.name for p in out.iterdir()) == [MARKER, "manifest.json", "metrics.json"]  # never a mix
    assert (out / "metrics.json").read_text() == "second"
    assert _leftovers(tmp_path) == []


@pytest.mark.parametrize("exc, status, last", [
    (RuntimeError("boom in the engine"), 1, "sins-sim: error: internal error (RuntimeError: boom in the engine)"),
    (MemoryError(), 1, "sins-sim: error: out of memory"),
    (OSError(28, "No space left on device", "x/timeseries.npz"),
     1, "sins-sim: error: x/timeseries.npz: No space left on device"),
    (ValueError("settle_s: must be in [0, duration_s = 2.0), got 3.0"),
     2, "sins-sim: error: --settle: must be in [0, --duration = 2.0), got 3.0"),
    (KeyboardInterrupt(), 130, "sins-sim: interrupted"),
])
def test_failed_run_leaves_the_earlier_result_untouched(tmp_path, capsys, fake_channel, exc, status, last):
    out = tmp_path / "ch"
    fake_channel(files={"metrics.json": "good"})
    assert main(_channel(out)) == 0
    capsys.readouterr()
    fake = fake_channel(files={"metrics.json": "half", "channel.png": "half"}, raise_=exc)
    assert main(_channel(out, "--force")) == status
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith(last), captured.err
    assert "Traceback" not in captured.err
    assert fake.calls[0]["out_dir"].parent == tmp_path and fake.calls[0]["out_dir"] != out  # a sibling
    assert sorted(p.name for p in out.iterdir()) == [MARKER, "manifest.json", "metrics.json"]
    assert (out / "metrics.json").read_text() == "good"
    assert _leftovers(tmp_path) == []


def test_failed_first_run_leaves_nothing(tmp_path, capsys, fake_channel):
    fake_channel(raise_=RuntimeError("x"))
    assert main(_channel(tmp_path / "ch")) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_debug_env_reraises(tmp_path, monkeypatch, fake_channel):
    fake_channel(raise_=RuntimeError("show me"))
    monkeypatch.setenv("SINS_SIM_DEBUG", "1")
    with pytest.raises(RuntimeError, match="show me"):
        main(_channel(tmp_path / "ch"))
    assert _leftovers(tmp_path) == [] and not (tmp_path / "ch").exists()


def test_atomic_output_dir_directly(tmp_path):
    target = tmp_path / "a" / "b"
    with atomic_output_dir(target) as tmp:
        assert tmp.parent == target.parent and tmp.is_dir() and not target.exists()
        (tmp / "x").write_text("1")
    assert (target / "x").read_text() == "1" and (target / MARKER).exists()
    mode = target.stat().st_mode & 0o777
    assert mode == 0o777 & ~_umask()  # not mkdtemp's 0o700
    with pytest.raises(KeyboardInterrupt):
        with atomic_output_dir(target, force=True) as tmp:
            (tmp / "y").write_text("2")
            raise KeyboardInterrupt
    assert sorted(p.name for p in target.iterdir()) == [MARKER, "x"]
    assert _leftovers(target.parent) == []


def test_commit_puts_the_old_result_back_when_the_rename_fails(tmp_path, monkeypatch):
    target = tmp_path / "out"
    with atomic_output_dir(target) as tmp:
        (tmp / "x").write_text("old")
    real_rename = os.rename

    def rename(src, dst):
        if ".tmp-" in str(src):
            raise OSError(18, "Invalid cross-device link")
        return real_rename(src, dst)

    monkeypatch.setattr(output.os, "rename", rename)
    with pytest.raises(OSError):
        with atomic_output_dir(target, force=True) as tmp:
            (tmp / "x").write_text("new")
    monkeypatch.undo()
    assert (target / "x").read_text() == "old"
    assert _leftovers(tmp_path) == []


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def test_single_file_outputs(tmp_path):
    with pytest.raises(ConfigError, match=r"^--json: .* is a directory, not a file"):
        check_out_file(tmp_path, "--json")
    with pytest.raises(ConfigError, match=r"^--json: must name a file"):
        check_out_file("", "--json")
    with pytest.raises(ConfigError, match=r"^--out: .* is not a directory"):
        check_out_file(_file(tmp_path / "f") / "rec.npz", "--out")
    if Path("/dev/null").exists():
        with pytest.raises(ConfigError, match="not a regular file"):
            check_out_file("/dev/null", "--json")
    target = tmp_path / "sub" / "r.json"
    atomic_write_text(target, "old")
    with pytest.raises(RuntimeError):
        with atomic_output_file(target, "--json") as tmp:
            assert tmp.parent == target.parent and tmp.suffix == ".json"
            tmp.write_text("half")
            raise RuntimeError
    assert target.read_text() == "old"
    with atomic_output_file(target, "--json") as tmp:
        tmp.write_text("new")
    assert target.read_text() == "new"
    assert target.stat().st_mode & 0o777 == 0o666 & ~_umask()
    assert _leftovers(target.parent) == []


def test_bench_json_checked_before_the_benchmark_runs(tmp_path, capsys, monkeypatch):
    calls = []
    monkeypatch.setattr("sins_sim.bench.run_bench", lambda quick=False: calls.append(quick) or {"a": 1.0})
    monkeypatch.setattr("sins_sim.bench.format_table", lambda result: "table")
    assert main(["bench", "--quick", "--json", str(tmp_path)]) == 2
    assert "--json: " in _one_error_line(capsys.readouterr()) and calls == []
    assert main(["bench", "--quick", "--json", str(tmp_path / "b.json")]) == 0
    assert json.loads((tmp_path / "b.json").read_text()) == {"a": 1.0} and calls == [True]
    assert _leftovers(tmp_path) == []


def _lab_csv(path: Path, n: int, bad_row: int | None = None) -> Path:
    rows = ["time_s,counts_x,drive_v_x"]
    for i in range(n):
        rows.append(f"{i / 1000:.6f},{'1.5' if i == bad_row else i},{0.1 * i:.3f}")
    path.write_text("\n".join(rows) + "\n")
    return path


def test_import_csv_writes_whole_files_only(tmp_path, capsys):
    nominal = tmp_path / "nominal.yaml"
    nominal.write_text("x: {f0_hz: 386, k1: 1.75e-4, k2: 1.05e-3, k3: 4.4e-3, k4: 250, k5: -1.2e-5}\n")
    out = tmp_path / "rec.npz"
    args = ["import-csv", "--out", str(out), "--quantum-arcsec", "0.15125", "--nominal", str(nominal)]
    assert main([*args[:1], str(_lab_csv(tmp_path / "a.csv", 20)), *args[1:]]) == 0
    first = out.read_bytes()
    capsys.readouterr()
    # a bad file: one line, the earlier recording kept, no temporary file
    assert main([*args[:1], str(_lab_csv(tmp_path / "b.csv", 20, bad_row=7)), *args[1:]]) == 2
    assert "counts_x row 8" in _one_error_line(capsys.readouterr())
    assert out.read_bytes() == first and _leftovers(tmp_path) == []
    # the output is a directory: refused before the CSV is read
    assert main([*args[:1], str(tmp_path / "missing.csv"), "--out", str(tmp_path), *args[3:]]) == 2
    assert "--out: " in _one_error_line(capsys.readouterr())


def test_diagnose_refuses_a_two_sample_recording_in_one_line(tmp_path, capsys):
    meta = {"format": "sins-sim-recording/1", "axes": ["x"], "fs_hz": 7200.0, "drive_fs_hz": 7200.0,
            "quantum_rad": 7.3e-7, "initial_state": "rest", "experiment": "stationary",
            "nominal": {"x": {"f0_hz": 386.0, "k1": 1.75e-4, "k2": 1.05e-3, "k3": 4.4e-3, "k4": 250.0,
                              "k5": -1.2e-5}}}
    rec = tmp_path / "two.npz"
    np.savez(rec, meta=np.array(json.dumps(meta)), counts=np.array([[0], [3]], np.int64),
             drive_v=np.zeros((2, 1)))
    assert main(["diagnose", str(rec), "--report", str(tmp_path / "rep")]) == 2
    line = _one_error_line(capsys.readouterr())
    assert "counts: must hold at least 4 samples" in line and "got 2" in line
    assert not (tmp_path / "rep").exists() and _leftovers(tmp_path) == []
    # an unusable --json is found before the recording is even read
    assert main(["diagnose", str(tmp_path / "nope.npz"), "--json", str(tmp_path)]) == 2
    assert "--json: " in _one_error_line(capsys.readouterr())
    # a JSON inside the report folder would be deleted with the folder it is replaced by
    rep = tmp_path / "rep"
    assert main(["diagnose", str(rec), "--json", str(rep / "d.json"), "--report", str(rep)]) == 2
    assert "--json: must not be inside --report" in _one_error_line(capsys.readouterr())
    assert sorted(p.name for p in tmp_path.iterdir()) == ["two.npz"]


# --- run: --seed and --duration --------------------------------------------------------------------------
def _install_run(monkeypatch, func):
    """The CLI imports ``run_scenario`` from ``sins_sim.jobs.run`` when ``run`` is called: give it ``func``
    (a stand-in module, so that these tests do not depend on the scenario engine)."""
    import types

    module = types.ModuleType("sins_sim.jobs.run")
    module.run_scenario = func
    monkeypatch.setitem(sys.modules, "sins_sim.jobs.run", module)


def _fake_run(record):
    def run_scenario(path, out_dir, progress=None, overrides=None, manifest=None):
        record.append({"path": path, "out_dir": Path(out_dir), "overrides": overrides})
        (Path(out_dir) / "report.md").write_text("r")
        progress(1.0)
        return {"duration_s": 1.0, "navigation": {"start_s": 0.5},
                "filters": {"ideal": {"status": "ok", "horizontal_position_error_m": {"final": 0.0, "max": 0.0},
                                      "vertical_position_error_m": {"final": 0.0},
                                      "velocity_error_m_s": {"final": 0.0, "max": 0.0},
                                      "attitude_error_arcsec": {"rms": {"north": 0.0, "east": 0.0, "down": 0.0}}}},
                "diverged": {}, "warnings": ["engine note one", "engine note one"]}

    return run_scenario


@pytest.mark.parametrize("flags, overrides", [
    ([], {}),
    (["--seed", "7"], {"seed": 7}),
    (["--duration", "0.5"], {"duration_s": 0.5}),
    (["--seed", "0", "--duration", "3"], {"seed": 0, "duration_s": 3.0}),
])
def test_run_passes_only_the_given_overrides(tmp_path, capsys, monkeypatch, flags, overrides):
    record = []
    _install_run(monkeypatch, _fake_run(record))
    out = tmp_path / "o"
    assert main(["run", "scen.yaml", "--out", str(out), "--quiet", *flags]) == 0
    assert record[0]["overrides"] == overrides
    assert record[0]["out_dir"] != out and (out / "report.md").exists()
    err = capsys.readouterr().err
    assert err.splitlines() == ["warning: engine note one"]  # the job's warnings, once, also with --quiet


def test_run_overrides_reach_the_scenario_and_are_validated(tmp_path, capsys):
    """Real job: ``--duration`` replaces the file's value and is checked like it (one line, exit 2)."""
    scen = tmp_path / "s.yaml"
    scen.write_text("name: s\nduration_s: 2.0\nimu: " + str(Path("configs/default-imu.yaml").resolve()) +
                    "\nnavigation: {start_s: 1.0}\noutputs: {plots: false}\n")
    assert main(["run", str(scen), "--out", str(tmp_path / "o"), "--quiet", "--duration", "0.5"]) == 2
    assert "navigation.start_s: must be < duration_s = 0.5" in _one_error_line(capsys.readouterr())
    assert main(["run", str(scen), "--out", str(tmp_path / "o"), "--quiet", "--duration", "1.3", "--seed", "4"]) == 0
    saved = json.loads((tmp_path / "o" / "metrics.json").read_text())
    assert saved["duration_s"] == 1.3 and saved["seed"] == 4


@pytest.mark.parametrize("flag, value", [("--seed", "-2"), ("--seed", "1.5"), ("--duration", "0"),
                                         ("--duration", "inf")])
def test_run_override_values_are_checked(tmp_path, capsys, flag, value):
    assert _status(["run", "scen.yaml", "--out", str(tmp_path / "o"), flag, value]) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and err.startswith(f"sins-sim: error: argument {flag}: "), err


# --- warnings and progress -------------------------------------------------------------------------------
def test_warnings_are_one_readable_line_each(tmp_path, capsys, fake_channel):
    fake_channel(warn=["plant: 3 half-cycles too short\n  second line of detail",
                       "plant: 3 half-cycles too short",
                       "filter left its domain at /work/main/sins_sim/filters/correcting.py:181"])
    assert main(_channel(tmp_path / "ch")) == 0  # --quiet: progress off, warnings still shown
    err = capsys.readouterr().err.splitlines()
    assert err == ["warning: plant: 3 half-cycles too short",
                   "warning: filter left its domain at correcting.py:181"]


def test_real_channel_warnings_without_paths(tmp_path, capsys):
    """The 1500 Hz motion drives the paper's hysteresis rule out of its domain: three warnings, one line each."""
    out = tmp_path / "ch"
    assert main(_channel(out, "--duration", "0.4", "--motion", "sine", "--motion-hz", "1500")) == 0
    err = capsys.readouterr().err.splitlines()
    assert err and all(line.startswith("warning: ") for line in err), err
    assert len(err) == len(set(err))
    assert not any(".py" in line or "/" in line.split("since")[0] for line in err), err
    assert any("hysteresis='masing'" in line for line in err)


def test_warnings_printed_before_the_error_line(tmp_path, capsys, fake_channel):
    fake_channel(warn=["early note"], raise_=ValueError("duration_s: too short"))
    assert main(_channel(tmp_path / "ch")) == 2
    assert capsys.readouterr().err.splitlines() == ["warning: early note", "sins-sim: error: --duration: too short"]


def test_format_warning_lines():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        warnings.warn("a\nb", UserWarning)
        warnings.warn("a", RuntimeWarning)
        warnings.warn("see C:\\src\\sins_sim\\x.py now", UserWarning)
    assert format_warning_lines([*caught, "  ", "c"]) == ["warning: a", "warning: see x.py now", "warning: c"]
    assert warning_text(RuntimeWarning("keep scenarios/impact.yaml")) == "keep scenarios/impact.yaml"


def test_progress_bar_shows_rate_and_time_left_on_stderr(tmp_path, capsys, fake_channel):
    fake_channel(progress=(0.25, 0.5, 1.0))
    assert main(["channel", "--out", str(tmp_path / "ch")]) == 0
    captured = capsys.readouterr()
    # the time left is measured on the run (three quick reports: still "estimating"; tests/test_hardening_round3.py)
    assert "channel: 100%" in captured.err and "%/s" in captured.err and "estimating the time left" in captured.err
    assert "%" not in captured.out
    fake_channel(progress=(0.25, 0.5, 1.0))
    assert main(_channel(tmp_path / "ch", "--force")) == 0
    assert capsys.readouterr().err == ""


# --- signals ------------------------------------------------------------------------------------------------
def test_sigterm_stops_a_long_run_cleanly(tmp_path):
    """SIGTERM while ``channel --duration 60`` computes: one line, status 130, nothing left behind."""
    out = tmp_path / "ch"
    err_path = tmp_path / "stderr.txt"
    cmd = [sys.executable, "-c", "import sys; from sins_sim.cli import main; sys.exit(main())",
           "channel", "--duration", "60", "--out", str(out)]
    with open(err_path, "wb") as err:
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=err, cwd=tmp_path)
    try:
        deadline = time.monotonic() + 40.0
        started = False
        while time.monotonic() < deadline and proc.poll() is None:
            text = err_path.read_text(errors="replace")
            if any(f" {p}%|" in text for p in range(1, 100)):  # the simulation is under way
                started = True
                break
            time.sleep(0.1)
        assert started, err_path.read_text(errors="replace")
        proc.send_signal(signal.SIGTERM)
        rc = proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    text = err_path.read_text(errors="replace")
    assert rc == 130, text
    assert text.splitlines()[-1] == "sins-sim: interrupted"
    assert "Traceback" not in text
    assert proc.stdout.read() == b""
    proc.stdout.close()
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["stderr.txt"]


def test_sigterm_handler_is_restored_after_main(tmp_path, fake_channel):
    fake_channel()
    before = signal.getsignal(signal.SIGTERM)
    assert main(_channel(tmp_path / "ch")) == 0
    assert signal.getsignal(signal.SIGTERM) is before


# --- library misuse: correct() without the drive ----------------------------------------------------------------
def test_correct_requires_volts():
    from sins_sim.filters import CorrectingFilterDesign, correct

    x = 1e-3 * np.sin(np.linspace(0, 20, 200))
    design = CorrectingFilterDesign()
    with pytest.raises(TypeError, match="volts"):
        correct(x, design)  # the piezo term used to be dropped silently
    with pytest.raises(ValueError, match=r"correcting\.volts: .*k5"):
        correct(x, design, None)
    volts = 0.3 * np.cos(np.linspace(0, 20, 200))
    with_drive = correct(x, design, volts)
    assert np.max(np.abs(with_drive - correct(x, design, None, drive_free=True))) > 0.0
    assert np.array_equal(correct(x, design, None, drive_free=True), correct(x, design, np.zeros_like(x)))
    free = CorrectingFilterDesign(k5=0.0)
    assert np.array_equal(correct(x, free, None), correct(x, free, volts))


def test_sigterm_stops_a_diagnosis_within_a_second(tmp_path):
    """SIGTERM during ``diagnose`` (worker threads inside long numba fits): the worker fits check a cancel flag
    between model evaluations, so the command ends within a second with one line and status 130 (issue 12,
    point 6; a Python signal handler alone would wait for every running fit to finish)."""
    rec = tmp_path / "rec.npz"
    exp = tmp_path / "exp.yaml"
    example = Path(__file__).resolve().parent.parent / "scenarios" / "experiments" / "experiment-example.yaml"
    text = example.read_text()
    exp.write_text(text.replace("duration_s: 1.0", "duration_s: 4.0"))
    subprocess.run([sys.executable, "-m", "sins_sim.cli", "simulate-recording", str(exp), "--out", str(rec)],
                   check=True, capture_output=True, timeout=300)
    err_path = tmp_path / "stderr.txt"
    cmd = [sys.executable, "-c", "import sys; from sins_sim.cli import main; sys.exit(main())",
           "diagnose", str(rec), "--json", str(tmp_path / "d.json")]
    with open(err_path, "wb") as err:
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=err, cwd=tmp_path)
    try:
        time.sleep(4.0)  # imports, the checks and the first refits are under way
        assert proc.poll() is None, err_path.read_text(errors="replace")
        t0 = time.monotonic()
        proc.send_signal(signal.SIGTERM)
        rc = proc.wait(timeout=30)
        waited = time.monotonic() - t0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    text = err_path.read_text(errors="replace")
    proc.stdout.close()
    assert rc == 130, text
    assert text.splitlines()[-1] == "sins-sim: interrupted"
    assert "Traceback" not in text
    # The rule is one second on an idle machine (the fits check the cancel flag between model evaluations, each
    # well under a second; without the flag the command waited for every running fit, tens of seconds). The
    # wait is wall time, so it stretches with the runnable processes per core (the suite runs one worker per
    # core, and other jobs may share the machine): the bound scales with the one-minute load per core when that
    # exceeds one, which is why this bound is machine-dependent.
    busy = max(1.0, os.getloadavg()[0] / (os.cpu_count() or 1))
    assert waited < 1.0 * busy, (waited, busy)
    assert not (tmp_path / "d.json").exists()


@pytest.mark.parametrize("command", ["channel", "lockin-study", "diagnose-eval"])
def test_every_seed_flag_refuses_a_negative_seed_in_one_line(tmp_path, capsys, command):
    status = _status([command, "--seed", "-3", "--out", str(tmp_path / "o")] if command != "diagnose-eval"
                     else [command, "--seed", "-3"])
    assert status == 2
    line = _one_error_line(capsys.readouterr())
    assert line.startswith("sins-sim: error: argument --seed: must be an integer >= 0, got '-3'"), line
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("text, want", [("1e3", 1000), ("10.0", 10), ("7", 7)])
def test_a_seed_is_read_as_a_file_reads_it(text, want):
    """``--seed 1e3`` was refused while ``seed: 1e1`` was accepted in a sweep file (issue 25, item 11): a whole
    number in any notation is a seed; a fraction, a negative number or one past 2^32 - 1 is not."""
    from sins_sim.cli import _seed

    assert _seed(text) == want


@pytest.mark.parametrize("text", ["1.5", "-3", "nan", "inf", "4294967296", "x"])
def test_a_seed_that_is_not_a_whole_number_in_range_is_refused(text):
    import argparse

    from sins_sim.cli import _seed

    with pytest.raises(argparse.ArgumentTypeError, match=r"^must be "):
        _seed(text)
