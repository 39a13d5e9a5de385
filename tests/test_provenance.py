"""Provenance and no silent loss (issue 22, point 5): manifest.json, ``run --rerun``, ``--force``.

The runs here are 1.5 s of a trajectory-file flight with plots and time series off (a few seconds each once
the kernels are compiled); the manifest's hashes are checked against hashlib on the files themselves, the
filters' f0 against the IMU file's values and eq. ``f0 (1 + ppm 1e-6)`` of sins_sim.config.filter_params.
"""

import hashlib
import json
import shutil
import warnings
from pathlib import Path

import pytest

import sins_sim
from sins_sim.cli import main
from sins_sim.jobs.manifest import MANIFEST_SCHEMA, Manifest, describe_folder, read_manifest, record_run
from sins_sim.config.scenario import load_scenario
from sins_sim.config.errors import ConfigError
from sins_sim.jobs.sweep.store import SweepStore

ROOT = Path(__file__).resolve().parents[1]
#: The bundled IMU's design f0 per axis (configs/default-imu.yaml), what ``filter_parameters: true`` hands eq. 5.
IMU_F0_HZ = {"x": 386.0, "y": 352.0, "z": 421.0}
SCENARIO = """\
name: prov
seed: 3
duration_s: 1.5
imu: imu-file.yaml
trajectory: {file: traj.csv}
motion:
  - {type: sines, amplitude_arcmin: [0.2, 0.2, 0.2], frequency_hz: [95, 143, 211]}
navigation: {start_s: 1.0, spectrum_s: 0.2}
outputs: {plots: false, timeseries: false}
"""


def _sha(path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def _inputs(folder: Path, extra: str = "") -> Path:
    """A scenario with a relative IMU file and trajectory file in ``folder``; returns the scenario's path."""
    folder.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(ROOT / "configs" / "default-imu.yaml", folder / "imu-file.yaml")
    shutil.copyfile(ROOT / "scenarios" / "trajectories" / "short-flight.csv", folder / "traj.csv")
    (folder / "s.yaml").write_text(SCENARIO + extra)
    return folder / "s.yaml"


def _err_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    return err[0]


@pytest.fixture(scope="module")
def baseline(tmp_path_factory):
    """One run of the scenario with ``--seed 5`` (the manifest must show the override)."""
    root = tmp_path_factory.mktemp("prov")
    scen = _inputs(root / "in")
    argv = ["run", str(scen), "--out", str(root / "a"), "--seed", "5", "--quiet"]
    assert main(argv) == 0
    return {"root": root, "scenario": scen, "out": root / "a", "argv": argv}


def test_manifest_holds_versions_argv_inputs_seed_and_each_filters_f0(baseline):
    out, scen = baseline["out"], baseline["scenario"]
    m = json.loads((out / "manifest.json").read_text())
    assert m["schema"] == MANIFEST_SCHEMA and m["sins_sim_version"] == sins_sim.__version__
    assert m["command"] == "run" and m["argv"] == baseline["argv"]
    assert set(m["versions"]) >= {"python", "numpy", "scipy", "numba"}
    assert m["wall_s"] > 0.0 and m["cpu_s"] >= 0.0 and m["started_utc"].endswith("Z")
    # every input file: its path and its hash (recomputed here), and a copy in the folder that the rerun reads
    folder = scen.parent
    for role, name in (("scenario", "s.yaml"), ("imu", "imu-file.yaml"), ("trajectory", "traj.csv")):
        entry = m["inputs"][role]
        assert entry["path"] == str((folder / name).resolve()) and entry["sha256"] == _sha(folder / name)
        assert entry["copy_sha256"] == _sha(out / entry["copy"])
    assert (out / "inputs" / "trajectory.csv").read_bytes() == (folder / "traj.csv").read_bytes()
    assert m["outputs"]["metrics.json"] == _sha(out / "metrics.json")
    run = m["run"]
    assert run["seed"] == 5 and run["overrides"] == {"seed": 5}
    # the scenario as run: the override applied, the file's own values kept, the defaults written out
    assert run["scenario"]["seed"] == 5 and run["scenario"]["duration_s"] == 1.5
    assert run["scenario"]["navigation"]["coning"] == "two_sample"  # not in the file: the schema's default
    assert run["imu"]["filter_parameters"] == {"source": "true", "f0": "unit", "f0_mismatch_ppm": 0.0,
                                               "suspension": {}, "channels": {a: {"suspension": {}} for a in "xyz"},
                                               "track": False}
    fp = run["filter_parameters"]
    assert (fp["source"], fp["f0_source"], fp["f0_mismatch_ppm"], fp["track"]) == ("true", "unit", 0.0, False)
    for name in ("correcting", "correcting_paper"):
        for axis, f0 in IMU_F0_HZ.items():
            row = fp["filters"][name][axis]
            assert row["f0_hz"] == f0 and row["unit_f0_hz"] == f0 and row["f0_error_ppm"] == 0.0
            assert (row["k1"], row["k2_rad"], row["k5_rad_per_v"]) == (1.75e-4, 1.05e-3, -1.2e-5)
    assert fp["filters"]["ideal"] == {"x": {}, "y": {}, "z": {}}
    for axis in "xyz":  # the eliminator's band: width_hz = 40 Hz centred on the drive
        el = fp["filters"]["eliminator"][axis]
        assert el["band_hz"][1] - el["band_hz"][0] == pytest.approx(40.0, rel=1e-12)
        assert sum(el["band_hz"]) / 2 == pytest.approx(el["drive_hz"], rel=1e-12)
    # timings live in the manifest only: metrics.json must stay reproducible byte for byte
    assert "wall_s" not in (out / "metrics.json").read_text()
    report = (out / "report.md").read_text()
    assert "## Filter parameters" in report and "| correcting | x | 386 | 0 |" in report


def test_f0_mismatch_differs_in_manifest_and_report(baseline, tmp_path):
    """The issue's case: ``f0_mismatch_ppm: 500`` used to give a report identical to the baseline's."""
    scen = _inputs(tmp_path / "in", "filter_parameters: {source: true, f0: unit, f0_mismatch_ppm: 500}\n")
    assert main(["run", str(scen), "--out", str(tmp_path / "m"), "--seed", "5", "--quiet"]) == 0
    m = json.loads((tmp_path / "m" / "manifest.json").read_text())["run"]["filter_parameters"]
    assert m["f0_mismatch_ppm"] == 500.0
    for axis, f0 in IMU_F0_HZ.items():
        row = m["filters"]["correcting"][axis]
        # f0 (1 + 500e-6): the product of two doubles, one rounding; 1e-15 relative covers it
        assert row["f0_hz"] == pytest.approx(f0 * 1.0005, rel=1e-15, abs=0.0)
        # the relative error recomputed from the two f0: 500 ppm up to the 1e-16 rounding of f0_hz, x 1e6
        assert row["f0_error_ppm"] == pytest.approx(500.0, rel=1e-9)
    report = (tmp_path / "m" / "report.md").read_text()
    base = (baseline["out"] / "report.md").read_text()
    section = report[report.index("## Filter parameters"):]
    assert section != base[base.index("## Filter parameters"):]
    assert "f0 mismatch 500 ppm" in section and "| correcting | x | 386.193 | 500 |" in section


def test_rerun_reproduces_metrics_byte_for_byte(baseline, capsys):
    new = baseline["root"] / "rerun"
    capsys.readouterr()
    assert main(["run", "--rerun", str(baseline["out"]), "--out", str(new), "--quiet"]) == 0
    assert "metrics.json is identical" in capsys.readouterr().out
    assert (new / "metrics.json").read_bytes() == (baseline["out"] / "metrics.json").read_bytes()
    m = json.loads((new / "manifest.json").read_text())
    assert m["rerun_of"]["folder"] == str(baseline["out"].resolve())
    old = json.loads((baseline["out"] / "manifest.json").read_text())
    assert m["run"]["scenario"] == old["run"]["scenario"] and m["run"]["imu"] == old["run"]["imu"]
    assert m["run"]["filter_parameters"] == old["run"]["filter_parameters"]


def test_rerun_refuses_its_own_folder_a_scenario_and_overrides(baseline, capsys):
    a = str(baseline["out"])
    before = (baseline["out"] / "manifest.json").read_bytes()
    for argv, part in ((["--out", a], "is the folder being rerun"),
                       (["--out", a + "-x", "--seed", "1"], "--seed would change it"),
                       ([str(baseline["scenario"]), "--out", a + "-x"], "give no scenario file")):
        assert main(["run", "--rerun", a, *argv, "--quiet"]) == 2
        assert part in _err_line(capsys)
    assert main(["run", "--out", a + "-x", "--quiet"]) == 2
    assert "name a scenario file, or --rerun DIR" in _err_line(capsys)
    assert main(["run", "--rerun", a + "-missing", "--out", a + "-x", "--quiet"]) == 2
    assert _err_line(capsys) == f"sins-sim: error: --rerun: {a}-missing is not a folder"
    assert (baseline["out"] / "manifest.json").read_bytes() == before and not Path(a + "-x").exists()


def test_existing_folder_is_refused_without_force_and_replaced_with_it(baseline, tmp_path, capsys):
    out = tmp_path / "a"
    shutil.copytree(baseline["out"], out)
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
    assert main(["run", str(baseline["scenario"]), "--out", str(out), "--quiet"]) == 2
    line = _err_line(capsys)
    started = json.loads(before["manifest.json"])["started_utc"]
    assert line.startswith(f"sins-sim: error: --out: {out} already holds a 'sins-sim run' result of scenario "
                           f"'prov' written {started}")
    assert "pass --force" in line
    assert {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()} == before  # untouched
    # --force: the new run (seed 7 now) replaces the old folder whole
    assert main(["run", str(baseline["scenario"]), "--out", str(out), "--seed", "7", "--force", "--quiet"]) == 0
    m = json.loads((out / "manifest.json").read_text())
    assert m["run"]["seed"] == 7 and json.loads((out / "metrics.json").read_text())["seed"] == 7
    # a folder sins-sim did not write is refused even with --force
    foreign = tmp_path / "mine"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("keep\n")
    assert main(["run", str(baseline["scenario"]), "--out", str(foreign), "--force", "--quiet"]) == 2
    assert "holds files that sins-sim did not write" in _err_line(capsys)
    assert (foreign / "notes.txt").read_text() == "keep\n"


@pytest.mark.parametrize("what", ["trajectory", "imu", "missing"])
def test_rerun_refuses_a_tampered_or_missing_input_copy(baseline, tmp_path, capsys, what):
    folder = tmp_path / "a"
    shutil.copytree(baseline["out"], folder)
    if what == "trajectory":
        with open(folder / "inputs" / "trajectory.csv", "a") as fh:
            fh.write("\n")
        part = "trajectory.csv was changed since the run"
    elif what == "imu":
        text = (folder / "inputs" / "imu.yaml").read_text()
        (folder / "inputs" / "imu.yaml").write_text(text.replace("f0_hz: 386", "f0_hz: 387"))
        part = "imu.yaml was changed since the run"
    else:
        (folder / "inputs" / "scenario.yaml").unlink()
        part = "scenario.yaml is missing"
    assert main(["run", "--rerun", str(folder), "--out", str(tmp_path / "b"), "--quiet"]) == 2
    line = _err_line(capsys)
    assert line.startswith("sins-sim: error: --rerun: ") and part in line, line
    assert not (tmp_path / "b").exists()


def test_manifest_schema_refused_version_warned(baseline, tmp_path):
    folder = tmp_path / "a"
    shutil.copytree(baseline["out"], folder)
    doc = json.loads((folder / "manifest.json").read_text())
    (folder / "manifest.json").write_text(json.dumps(dict(doc, sins_sim_version="0.0.1")))
    with pytest.warns(UserWarning, match=r"written by sins-sim 0\.0\.1, this is .*: the rerun may differ"):
        assert read_manifest(folder)["run"]["seed"] == 5
    (folder / "manifest.json").write_text(json.dumps(dict(doc, schema="sins-sim-manifest/99")))
    with pytest.raises(ConfigError, match=r"^--rerun: .*schema 'sins-sim-manifest/99' is not"):
        read_manifest(folder)
    (folder / "manifest.json").unlink()
    with pytest.raises(ConfigError, match="has no manifest.json"):
        read_manifest(folder)
    assert describe_folder(folder).startswith("an earlier sins-sim result without a manifest.json")


def _diagnosis(path: Path) -> None:
    params = {a: {"f0_hz": f, "k1": 1.8e-4, "k2": 1.0e-3, "k3": 4.3e-3, "k4": 245.0, "k5": -1.22e-5}
              for a, f in (("x", 383.4), ("y", 347.3), ("z", 428.8))}
    path.write_text(json.dumps({"baseline": {"params": params}}))


@pytest.mark.parametrize("path", sorted(p for p in (ROOT / "scenarios").glob("*.yaml")
                                        if not p.name.startswith("sweep-")) + ["diagnose", "inline", "sensors"])
def test_the_inputs_as_run_load_to_the_same_scenario(path, tmp_path):
    """inputs/scenario.yaml (every default filled in, files copied) builds the very scenario the file built."""
    overrides = None
    if path == "sensors":  # --imu: a unit with sensor errors and a lock-in effect, from the command line
        path = _inputs(tmp_path / "in")
        imu = (ROOT / "configs" / "nav-grade-rlg.yaml").read_text()
        (tmp_path / "in" / "ng.yaml").write_text(imu + "effects:\n  - {name: lock_in, axes: [x], threshold_rad_s: 2.0e-3}\n")
        overrides = {"imu": str(tmp_path / "in" / "ng.yaml"), "seed": 9}
    elif path == "diagnose":  # a diagnosis file named relative to the IMU file, copied into inputs/
        path = _inputs(tmp_path / "in", "filter_parameters: {source: diagnose, file: unit.json}\n")
        _diagnosis(tmp_path / "in" / "unit.json")
    elif path == "inline":  # the IMU inline in the scenario, the short form of filter_parameters
        imu = (ROOT / "configs" / "spread-imu.yaml").read_text().replace("\n", "\n  ")
        path = tmp_path / "inline.yaml"
        path.write_text(f"name: inline\nduration_s: 5\nfilter_parameters: nominal\nimu:\n  {imu}\n")
    with warnings.catch_warnings():  # bundled scenarios may warn (a motion near the Nyquist): not this test's
        warnings.simplefilter("ignore")
        sc = load_scenario(path, overrides)
        record_run(Manifest("run"), sc, path, overrides, tmp_path / "out")
        again = load_scenario(tmp_path / "out" / "inputs" / "scenario.yaml")
    if overrides:  # the case exercises what it means to: sensor errors and an effect, and the --seed override
        assert sc.imu.sensors is not None and len(sc.imu.effects) == 1 and again.seed == 9
    assert again.imu == sc.imu and again.filter_spec["file"] in (None, "diagnosis.json")
    assert {k: v for k, v in again.filter_spec.items() if k != "file"} == \
           {k: v for k, v in sc.filter_spec.items() if k != "file"}
    for attr in ("name", "seed", "duration_s", "nav", "motion_spec", "site", "filters", "outputs", "events",
                 "vibration_spec"):
        assert getattr(again, attr) == getattr(sc, attr), attr
    assert {k: v for k, v in again.trajectory_spec.items() if k != "file"} == \
           {k: v for k, v in sc.trajectory_spec.items() if k != "file"}
    assert repr(again.temperature) == repr(sc.temperature)


def test_other_commands_write_a_manifest_and_refuse_an_existing_folder(tmp_path, capsys):
    out = tmp_path / "ch"
    argv = ["channel", "--out", str(out), "--duration", "0.2", "--settle", "0.1", "--quiet"]
    assert main(argv) == 0
    m = json.loads((out / "manifest.json").read_text())
    assert m["command"] == "channel" and m["argv"] == argv and m["settings"]["f0"] == 386.0
    assert m["outputs"]["metrics.json"] == _sha(out / "metrics.json")
    capsys.readouterr()
    assert main(argv) == 2
    assert f"--out: {out} already holds a 'sins-sim channel' result written" in _err_line(capsys)
    assert main([*argv, "--force"]) == 0


def test_a_sweep_folder_resumes_the_same_sweep_and_refuses_another_without_force(tmp_path):
    store = SweepStore(tmp_path / "sw")
    store.open({"name": "lot-a", "sweep_file": "/x/lot-a.yaml", "tasks": 4}, "name: lot-a\n")
    store.check()
    store.check_same("lot-a")  # the documented way to continue an interrupted sweep
    with pytest.raises(ConfigError, match=r"holds the sweep 'lot-a' \(/x/lot-a.yaml, 4 runs\), not 'lot-b'; "
                                          r"pass --force"):
        store.check_same("lot-b")
    store.check_same("lot-b", force=True)


def test_budget_manifest_holds_the_scenario_as_run(tmp_path, monkeypatch):
    """budget runs its scenario in variants: its manifest records the files' hashes and the scenario as run."""
    scen = _inputs(tmp_path / "in")

    def fake_budget(path, out, overrides=None, workers=2, progress=None):
        load_scenario(path, overrides)  # the real job validates the scenario first
        (Path(out) / "budget.json").write_text("{}")
        return {"filters": [], "total": {}, "sources": {}, "floor": {}, "remainder": {}, "duration_s": 1.5, "runs": 0}

    monkeypatch.setattr("sins_sim.jobs.budget.run_budget", fake_budget)
    assert main(["budget", str(scen), "--out", str(tmp_path / "b"), "--duration", "1.2", "--quiet"]) == 0
    m = json.loads((tmp_path / "b" / "manifest.json").read_text())
    assert m["command"] == "budget" and m["overrides"] == {"duration_s": 1.2}
    assert m["scenario"]["duration_s"] == 1.2 and m["imu"]["channels"]["x"]["f0_hz"] == 386
    for role, name in (("scenario", "s.yaml"), ("imu", "imu-file.yaml"), ("trajectory", "traj.csv")):
        assert m["inputs"][role]["sha256"] == _sha(tmp_path / "in" / name)
