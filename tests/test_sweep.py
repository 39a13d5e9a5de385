"""``sins-sim sweep`` (issue 14): the sweep file, reproducible draws, dask tasks equal to serial runs, resume,
a real multi-process cluster, failures recorded without stopping the sweep.

Runs are tiny (1.5 s at rest and the 2.5 s impact scenario); every cluster has one thread per worker. Rows
are compared exactly: a run is a pure function of its scenario document and seed, whatever process runs it.
"""

from __future__ import annotations

import hashlib
import json
import os
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from sins_sim.cli import main
from sins_sim.config.errors import ConfigError
from sins_sim.jobs.sweep.job import prepare_sweep, run_sweep
from sins_sim.jobs.sweep.population import apply_unit, draw_unit
from sins_sim.config.sweep import load_sweep
from sins_sim.jobs.sweep.tasks import run_task

ROOT = Path(__file__).resolve().parents[1]
SCEN = ROOT / "scenarios"
#: columns that say where and how fast a run ran, not what it computed
VOLATILE = ["wall_s", "worker"]

TINY = f"""
name: tiny
seed: 5
units: 3
scenarios:
  - {{path: {SCEN / 'stationary.yaml'}, duration_s: 1.5}}
  - {{path: {SCEN / 'impact.yaml'}}}
population:
  f0_ppm: {{width: 2000}}
  k3_percent: {{distribution: uniform, width: 10}}
  temperature_k: {{distribution: grid, values: [-10, 30]}}
  temperature_coefficient_ppm_per_k: {{mean: -30, width: 5}}
"""


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    p = tmp_path_factory.mktemp("sweep") / "tiny.yaml"
    p.write_text(TINY)
    return p


def _serial(path) -> pd.DataFrame:
    """Each unit run alone, in this process, with the same seeds."""
    from sins_sim import __version__

    _, tasks, _ = prepare_sweep(path)
    rows = [run_task(t.spec(__version__)) for t in tasks]
    return pd.DataFrame(rows).sort_values(["scenario_index", "unit"]).reset_index(drop=True)


def _same_rows(a: pd.DataFrame, b: pd.DataFrame) -> None:
    a = a.drop(columns=VOLATILE).sort_values(["scenario_index", "unit"]).reset_index(drop=True)
    b = b.drop(columns=VOLATILE).sort_values(["scenario_index", "unit"]).reset_index(drop=True)
    pd.testing.assert_frame_equal(a, b[a.columns], check_dtype=False, check_exact=True)


@pytest.fixture(scope="module")
def local(tiny, tmp_path_factory):
    """The tiny sweep on a 2-worker LocalCluster (the default path of ``sins-sim sweep``)."""
    out = tmp_path_factory.mktemp("local") / "sweep"
    lines = []
    res = run_sweep(tiny, out, workers=2, log=lines.append)
    return SimpleNamespace(out=out, res=res, lines=lines, table=pd.read_parquet(out / "runs.parquet"))


# --- the sweep file --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("edit, field", [
    ({"units": 0}, "units: must be >= 1"),
    ({"population": {"f0_ppm": {"width": -1}}}, "population.f0_ppm.width: must be >= 0"),
    ({"population": {"f0": {"width": 1}}}, "population.f0: unknown key"),
    ({"population": {"f0_ppm": {"width": 1}, "f0_hz": {"width": 1}}}, "population.f0_hz: give f0_ppm or f0_hz"),
    ({"population": {"k3_percent": {"distribution": "grid"}}}, "population.k3_percent.values: a grid needs"),
    ({"filter_parameters": "guessed"}, "filter_parameters: must be true, nominal or a mapping"),
    ({"scenarios": [{"path": "nowhere.yaml"}]}, "scenarios[0].path: file not found"),
    ({"scenarios": [{"path": str(SCEN / "stationary.yaml"), "duration_s": 0}]}, "scenarios[0].duration_s: must be > 0"),
    ({"scenarios": [{"path": str(SCEN / "stationary.yaml")}] * 2}, "scenarios[1].label: 'stationary' is already"),
    # every unit's drawn IMU is checked before a task starts: k5 pushed to 0 is refused, naming the sweep key the
    # user wrote, the grid value, the unit and the IMU key with its rule (issue 25, item 11)
    ({"population": {"k5_percent": {"distribution": "grid", "values": [0, -100]}}},
     "population.k5_percent.values: -100 gives unit 1 "),
])
def test_bad_sweep_file_is_one_line_naming_the_field(tmp_path, capsys, edit, field):
    import yaml

    doc = yaml.safe_load(TINY)
    doc.update(edit)
    p = tmp_path / "bad.yaml"
    p.write_text(yaml.safe_dump(doc))
    assert main(["sweep", str(p), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("sins-sim: error: ") and "\n" not in err and field in err, err
    if "unit 1" in field:
        assert "channels.x.suspension.k5_rad_per_v" in err and "!= 0" in err
    assert not (tmp_path / "out").exists()  # refused before anything was written or started


def test_out_folder_of_another_kind_is_refused(tiny, tmp_path, capsys):
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "notes.txt").write_text("keep")
    assert main(["sweep", str(tiny), "--out", str(tmp_path / "mine"), "--quiet"]) == 2
    assert "not a sweep" in capsys.readouterr().err
    assert (tmp_path / "mine" / "notes.txt").read_text() == "keep"


# --- the population ---------------------------------------------------------------------------------------------
def test_draws_depend_only_on_seed_and_unit(tiny, tmp_path):
    sweep = load_sweep(tiny)
    first = [draw_unit(sweep, i) for i in range(3)]
    # the same units in reverse order, and in a sweep with more units and one more spread parameter
    assert [draw_unit(sweep, i) for i in reversed(range(3))][::-1] == first
    more = tmp_path / "more.yaml"
    more.write_text(TINY.replace("units: 3", "units: 50") + "  k1_percent: {width: 3}\n")
    bigger = load_sweep(more)
    for i in range(3):
        d = draw_unit(bigger, i)
        assert {k: d[k] for k in first[i]} == first[i]
    # the grid is a full factorial on the unit index; the run seeds differ between units
    assert [draw_unit(sweep, i)["temperature_k"] for i in range(3)] == [-10.0, 30.0, -10.0]
    assert len({d["run_seed"] for d in first}) == 3
    # another sweep seed draws other units
    other = tmp_path / "other.yaml"
    other.write_text(TINY.replace("seed: 5", "seed: 6"))
    assert draw_unit(load_sweep(other), 0)["f0_ppm.x"] != first[0]["f0_ppm.x"]


def test_draws_follow_their_distributions(tmp_path):
    p = tmp_path / "s.yaml"
    p.write_text(f"name: s\nseed: 1\nunits: 4000\nscenarios: [{{path: {SCEN / 'stationary.yaml'}}}]\n"
                 "population:\n  f0_ppm: {mean: 100, width: 2000}\n  k3_percent: {distribution: uniform, width: 10}\n")
    sweep = load_sweep(p)
    d = [draw_unit(sweep, i) for i in range(1000)]
    f0 = np.array([u[f"f0_ppm.{a}"] for u in d for a in "xyz"])  # 3000 draws
    k3 = np.array([u[f"k3_percent.{a}"] for u in d for a in "xyz"])
    # 3000 normal draws: the mean's standard error is 2000 / sqrt(3000) = 37 ppm (4 sigma: 146 ppm), the
    # standard deviation's 2000 / sqrt(6000) = 26 ppm (4 sigma: 103 ppm)
    assert abs(f0.mean() - 100.0) < 146.0 and abs(f0.std() - 2000.0) < 103.0
    # uniform on [-10, 10]: all inside, standard deviation 10 / sqrt(3) = 5.77 (standard error 0.07; 4 sigma)
    assert k3.min() >= -10.0 and k3.max() <= 10.0 and abs(k3.std() - 10.0 / np.sqrt(3.0)) < 0.3


def test_apply_unit_sets_the_true_parameters():
    imu = {"suspension": {"k3": 4.4e-3}, "channels": {"x": {"f0_hz": 400.0}, "y": {"f0_hz": 350.0, "suspension":
                                                                                    {"k3": 5.0e-3}},
                                                      "z": {"f0_hz": 420.0}},
           "sensors": {"gyro": {"bias_deg_h": 0.01, "arw_deg_rt_h": 0.002, "misalignment_arcsec": [1, 2, 3, 4, 5, 6]}}}
    unit = {"f0_ppm.x": 1000.0, "f0_ppm.y": 0.0, "f0_ppm.z": 0.0, "temperature_k": 10.0,
            **{f"temperature_coefficient_ppm_per_k.{a}": -30.0 for a in "xyz"},
            **{f"k3_percent.{a}": 10.0 for a in "xyz"},
            **{f"gyro.bias_deg_h.{a}": z for a, z in zip("xyz", (1.0, -2.0, 0.5))},
            **{f"gyro.misalignment_arcsec.{p}": 1.0 for p in ("xy", "xz", "yx", "yz", "zx", "zy")},
            **{f"gyro.{k}.{a}": 0.0 for k in ("scale_factor_ppm", "scale_factor_asymmetry_ppm") for a in "xyz"}}
    doc = apply_unit(imu, unit, "nominal", draw_sensors=True)
    ch = doc["channels"]
    assert ch["x"]["f0_hz"] == pytest.approx(400.0 * 1.001 * (1.0 - 300e-6), rel=1e-15)
    assert ch["y"]["f0_hz"] == pytest.approx(350.0 * (1.0 - 300e-6), rel=1e-15)
    assert ch["x"]["suspension"]["k3"] == pytest.approx(4.84e-3, rel=1e-14)  # from the shared block
    assert ch["y"]["suspension"]["k3"] == pytest.approx(5.5e-3, rel=1e-14)   # from the channel's own
    assert ch["z"]["suspension"]["k3"] == pytest.approx(4.84e-3, rel=1e-14)
    g = doc["sensors"]["gyro"]
    assert g["bias_deg_h"] == pytest.approx([0.01, -0.02, 0.005]) and g["arw_deg_rt_h"] == 0.002
    assert g["misalignment_arcsec"] == [1, 2, 3, 4, 5, 6]
    assert doc["filter_parameters"] == "nominal" and "filter_parameters" not in apply_unit(imu, unit, "true")
    assert imu["channels"]["x"]["f0_hz"] == 400.0  # the file's mapping is left as it was


# --- dask -------------------------------------------------------------------------------------------------------
def test_local_cluster_gives_the_rows_of_serial_runs(tiny, local):
    assert local.res["computed"] == 6 and local.res["failed"] == 0 and local.res["already_done"] == 0
    assert "0 already done, 6 to run" in local.lines[0]
    t = local.table
    assert len(t) == 6 and t["key"].is_unique and set(t["scenario"]) == {"stationary", "impact"}
    assert len({w for w in t["worker"]}) == 2  # both worker processes ran tasks
    _same_rows(t, _serial(tiny))
    # the parts in runs/ are the same table
    parts = pd.concat([pd.read_parquet(p) for p in sorted((local.out / "runs").glob("*.parquet"))])
    _same_rows(t, parts)
    # the summary's percentiles are numpy's over the finite values of the table, where n supports them (6 values
    # bracket the median in a 95 % interval, 72 the 95th percentile, 368 the 99th: tests/test_sweep_stats.py)
    s = json.loads((local.out / "summary.json").read_text())
    assert s["runs"] == 6 and s["failed"] == 0
    x = t["correcting.horizontal_position_error_m_final"].to_numpy()
    q = s["percentiles"]["horizontal_position_error_m_final"]["correcting"]
    assert (q["p50"]["value"], q["n"]) == (np.percentile(x, 50), 6)
    assert q["p95"] == {"supported": False, "n_required": 72, "n": 6}
    assert q["p99"] == {"supported": False, "n_required": 368, "n": 6}
    imp = s["by_scenario"]["impact"]["percentiles"]["event_step_arcsec_max"]["eliminator"]
    assert imp["n"] == 3 and imp["p50"] == {"supported": False, "n_required": 6, "n": 3}
    assert "event_step_arcsec_max" not in s["by_scenario"]["stationary"]["percentiles"]  # no event at rest
    assert (local.out / "distributions.png").stat().st_size > 10_000


#: The interrupted sweep's gate (``_first_two_then_wait``): runs started, and the event that releases the others.
_GATE = {"lock": threading.Lock(), "started": 0, "interrupted": threading.Event()}


def _first_two_then_wait(spec):
    """``run_task`` for the first two runs a worker thread starts; every later run waits until the test has
    interrupted the sweep, then raises without computing (its future is cancelled by then, nothing is stored).

    So the interruption finds exactly two runs done and no run computing, however fast or loaded the machine:
    with plain ``run_task`` the other worker thread is inside a third run when the interrupt comes, which then
    finishes (or not) while the client closes and the resumed sweep starts."""
    with _GATE["lock"]:
        _GATE["started"] += 1
        mine = _GATE["started"]
    if mine > 2:
        # a guard against a deadlock if the test broke, not a timing: the test sets the event before it raises
        if not _GATE["interrupted"].wait(timeout=600):
            raise RuntimeError("the test never interrupted the sweep")
        raise RuntimeError("run not started: the sweep was interrupted")
    return run_task(spec)


def test_resume_after_an_interruption_runs_only_what_is_missing(tiny, local, tmp_path, capsys):
    out = tmp_path / "sweep"
    _GATE["started"] = 0
    _GATE["interrupted"].clear()

    def interrupt_after_two(done, total, failed):
        if done >= 2:
            _GATE["interrupted"].set()  # the waiting runs return at once, so the client closes on idle threads
            raise KeyboardInterrupt

    from dask.distributed import Client

    with Client(processes=False, n_workers=1, threads_per_worker=2, dashboard_address=None) as client:
        with pytest.raises(KeyboardInterrupt):
            run_sweep(tiny, out, client=client, progress=interrupt_after_two, log=lambda s: None,
                      task_fn=_first_two_then_wait)
    assert _GATE["interrupted"].is_set()
    parts = list((out / "runs").glob("*.parquet"))
    assert len(parts) == 2 and not list((out / "failed").glob("*.json"))
    assert not list(out.rglob(".*tmp-*")) and not (out / "summary.json").exists()
    assert main(["sweep", str(tiny), "--out", str(out), "--workers", "2", "--quiet"]) == 0
    text = capsys.readouterr().out
    assert f"{len(parts)} already done, {6 - len(parts)} to run" in text
    assert f"ran {6 - len(parts)} runs" in text
    _same_rows(pd.read_parquet(out / "runs.parquet"), local.table)
    assert json.loads((out / "summary.json").read_text()) == json.loads((local.out / "summary.json").read_text())
    figures = {p.name: p.stat().st_mtime_ns for p in out.glob("*.png")}
    assert "distributions.png" in figures
    # a third invocation finds everything done, starts no cluster and leaves the figures as they were
    assert main(["sweep", str(tiny), "--out", str(out), "--quiet"]) == 0
    assert "6 already done, 0 to run" in capsys.readouterr().out
    assert {p.name: p.stat().st_mtime_ns for p in out.glob("*.png")} == figures
    # the manifest is the last invocation's (issue 22, point 5): its command line, what it found done
    m = json.loads((out / "manifest.json").read_text())
    assert m["command"] == "sweep" and m["argv"][-1] == "--quiet" and m["sweep"]["already_done"] == 6
    assert m["outputs"]["runs.parquet"] == hashlib.sha256((out / "runs.parquet").read_bytes()).hexdigest()


def _fails_for_unit_1(spec):
    if spec["unit"] == 1:
        raise RuntimeError("a deliberate failure of unit 1")
    return run_task(spec)


def test_a_task_that_raises_is_recorded_and_the_others_finish(tiny, local, tmp_path):
    from dask.distributed import Client

    out = tmp_path / "sweep"
    lines = []
    with Client(processes=False, n_workers=1, threads_per_worker=2, dashboard_address=None) as client:
        res = run_sweep(tiny, out, client=client, task_fn=_fails_for_unit_1, log=lines.append, plots=False)
        assert res["computed"] == 4 and res["failed"] == 2
        s = json.loads((out / "summary.json").read_text())
        assert s["runs"] == 4 and s["failed"] == 2
        recs = [json.loads(p.read_text()) for p in (out / "failed").glob("*.json")]
        assert sorted(r["scenario"] for r in recs) == ["impact", "stationary"] and {r["unit"] for r in recs} == {1}
        drawn = {k: v for k, v in draw_unit(load_sweep(tiny), 1).items() if k != "run_seed"}
        for r in recs:
            assert r["error"] == "RuntimeError: a deliberate failure of unit 1"
            assert "_fails_for_unit_1" in r["traceback"] and r["params"] == drawn
        assert sum("failed: unit 1" in ln for ln in lines) == 2
        # the failed runs are tried again on a resume (and only they)
        lines.clear()
        res = run_sweep(tiny, out, client=client, log=lines.append, plots=False)
    assert res["computed"] == 2 and res["failed"] == 0
    assert "4 already done, 2 to run (2 failed before, tried again)" in lines[0]
    assert not list((out / "failed").glob("*.json"))
    _same_rows(pd.read_parquet(out / "runs.parquet"), local.table)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_real_cluster_of_scheduler_and_two_worker_processes(tmp_path, capsys):
    """``dask scheduler`` and two ``dask worker`` processes on 127.0.0.1; the smoke sweep through --scheduler."""
    from dask.distributed import Client

    dask_cli = Path(sys.executable).parent / "dask"
    port = _free_port()
    addr = f"tcp://127.0.0.1:{port}"
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    procs = []
    log = open(tmp_path / "dask.log", "w")
    try:
        procs.append(subprocess.Popen([str(dask_cli), "scheduler", "--host", "127.0.0.1", "--port", str(port),
                                       "--no-dashboard"], stdout=log, stderr=subprocess.STDOUT, env=env))
        for _ in range(2):
            procs.append(subprocess.Popen([str(dask_cli), "worker", addr, "--nworkers", "1", "--nthreads", "1",
                                           "--no-dashboard", "--host", "127.0.0.1"],
                                          stdout=log, stderr=subprocess.STDOUT, env=env))
        with Client(addr, timeout=60) as client:
            client.wait_for_workers(2, timeout=90)
            assert len(client.scheduler_info()["workers"]) == 2
        out = tmp_path / "smoke"
        assert main(["sweep", str(SCEN / "sweep-smoke.yaml"), "--out", str(out), "--scheduler", addr,
                     "--quiet"]) == 0
        assert "0 already done, 8 to run" in capsys.readouterr().out
        table = pd.read_parquet(out / "runs.parquet")
        assert len(table) == 8 and table["worker"].nunique() == 2
        _same_rows(table, _serial(SCEN / "sweep-smoke.yaml"))
    finally:
        for p in reversed(procs):  # workers first, then the scheduler: by their ids
            p.terminate()
        deadline = time.monotonic() + 30
        for p in procs:
            try:
                p.wait(timeout=max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait(timeout=10)
        log.close()
    assert all(p.poll() is not None for p in procs)


def test_unreachable_scheduler_is_one_line(tiny, tmp_path, capsys, monkeypatch):
    from sins_sim.jobs.sweep import job

    monkeypatch.setattr(job, "CONNECT_TIMEOUT_S", 1.0)
    addr = f"tcp://127.0.0.1:{_free_port()}"
    assert main(["sweep", str(tiny), "--out", str(tmp_path / "o"), "--scheduler", addr, "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"sins-sim: error: --scheduler: cannot reach {addr}") and "\n" not in err


def test_sweep_keys_change_with_what_determines_a_run(tiny, tmp_path):
    _, tasks, _ = prepare_sweep(tiny)
    again = prepare_sweep(tiny)[1]
    assert [t.key for t in tasks] == [t.key for t in again]
    longer = tmp_path / "longer.yaml"
    longer.write_text(TINY.replace("duration_s: 1.5", "duration_s: 1.6"))
    changed = prepare_sweep(longer)[1]
    same = [a.key == b.key for a, b in zip(tasks, changed)]
    assert same == [t.scenario == "impact" for t in tasks]  # only the stationary runs changed


def test_nominal_filter_parameters_are_passed_to_the_imu(tiny, tmp_path):
    from sins_sim.config.imu import IMU_SCHEMA

    nominal = tmp_path / "nominal.yaml"
    nominal.write_text(TINY + "filter_parameters: nominal\n")
    if "filter_parameters" not in IMU_SCHEMA.fields:  # an IMU without the key: refused before any task
        with pytest.raises(ConfigError, match=r"nominal.yaml: filter_parameters: 'nominal' needs the IMU key"):
            prepare_sweep(nominal)
        return
    _, tasks, _ = prepare_sweep(nominal)
    keys = {t.key for t in prepare_sweep(tiny)[1]}
    assert all(t.doc["imu"]["filter_parameters"] == "nominal" and t.key not in keys for t in tasks)
