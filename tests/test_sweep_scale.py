"""Sweeps that scale out (issue 26, item 4): several runs per Dask task, workers of one thread with a node-local
numba cache warmed before the first task, and any single run reproduced alone (``sins-sim sweep --rerun``).

Rows are compared exactly (every column but ``wall_s`` and ``worker``): a run is a pure function of its scenario
document and seed, whatever process runs it and whatever else ran in the same task.
"""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import pandas as pd
import pytest

from sins_sim.cli import main
from sins_sim.jobs.sweep.job import (MAX_BATCH, TARGET_TASK_S, TASKS_PER_SLOT, VOLATILE_COLUMNS, _batches,
                                     batch_size, prepare_sweep, rerun, run_sweep)

ROOT = Path(__file__).resolve().parents[1]
SCEN = ROOT / "scenarios"

SMALL = f"""
name: small
seed: 11
units: 6
scenarios:
  - {{path: {SCEN / 'stationary.yaml'}, duration_s: 1.2}}
  - {{path: {SCEN / 'impact.yaml'}}}
population:
  f0_ppm: {{width: 2000}}
  k3_percent: {{distribution: uniform, width: 10}}
"""


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    p = tmp_path_factory.mktemp("scale") / "small.yaml"
    p.write_text(SMALL)
    return p


@pytest.fixture(scope="module")
def unbatched(small, tmp_path_factory):
    """The small sweep, one run per task, on a 2-worker LocalCluster."""
    out = tmp_path_factory.mktemp("unbatched") / "sweep"
    res = run_sweep(small, out, workers=2, batch=1, log=lambda s: None, plots=False)
    return SimpleNamespace(out=out, res=res, table=pd.read_parquet(out / "runs.parquet"))


def _same_rows(a: pd.DataFrame, b: pd.DataFrame) -> None:
    drop = list(VOLATILE_COLUMNS)
    a = a.drop(columns=drop).sort_values(["scenario_index", "unit"]).reset_index(drop=True)
    b = b.drop(columns=drop).sort_values(["scenario_index", "unit"]).reset_index(drop=True)
    assert list(a.columns) == list(b.columns)
    pd.testing.assert_frame_equal(a, b, check_dtype=False, check_exact=True)


# --- the batch size ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("est, n, slots", [(0.05, 10_000, 2), (0.05, 40, 2), (6.0, 400, 2), (0.3, 200, 2),
                                           (1e-4, 10_000, 8), (0.05, 1, 2), (TARGET_TASK_S, 1000, 2)])
def test_batch_size_follows_its_rule(est, n, slots):
    """The rule written out: tasks of about TARGET_TASK_S, at most MAX_BATCH runs, TASKS_PER_SLOT tasks per slot."""
    b = batch_size(est, n, slots)
    expect = max(1, min(math.ceil(TARGET_TASK_S / est), MAX_BATCH, math.ceil(n / (TASKS_PER_SLOT * slots))))
    assert b == expect
    assert 1 <= b <= MAX_BATCH
    assert b == 1 or b * est <= TARGET_TASK_S + est  # never more than one run beyond the target time


def test_batches_keep_each_scenario_together_in_unit_order(small):
    _, tasks, _ = prepare_sweep(small)
    groups = _batches(tasks, slots=1, batch=4)
    assert [len(g) for g in groups] == [4, 2, 4, 2]
    assert all(len({t.scenario for t in g}) == 1 for g in groups)
    assert [t.key for g in groups for t in g] == [t.key for t in sorted(tasks, key=lambda t: (t.scenario_index,
                                                                                                t.unit))]
    # the estimate the automatic size starts from: the stationary 1.2 s run is cheaper than the 2.5 s impact
    est = {t.scenario: t.est_s for t in tasks}
    assert 0 < est["stationary"] < est["impact"]


# --- batched against unbatched ---------------------------------------------------------------------------------
def test_a_batched_sweep_gives_the_rows_of_an_unbatched_one(small, unbatched, tmp_path):
    assert unbatched.res["computed"] == 12 and unbatched.res["failed"] == 0
    out = tmp_path / "batched"
    res = run_sweep(small, out, workers=2, batch=3, log=lambda s: None, plots=False)
    assert res["computed"] == 12 and res["failed"] == 0
    table = pd.read_parquet(out / "runs.parquet")
    _same_rows(table, unbatched.table)
    # each task of 3 runs (units 0-2 and 3-5 of a scenario) ran in one worker process: batching took place
    for (_, first), rows in table.groupby(["scenario_index", table["unit"] // 3]):
        assert rows["worker"].nunique() == 1 and len(rows) == 3
    # a part per task (the worker packs its rows, the client writes the bytes): 4 parts of 3 rows, named by the
    # first run's key and the count; the store finds every run in them, so a second invocation runs nothing and
    # --rerun finds a row inside a part of several
    parts = sorted((out / "runs").glob("*.parquet"))
    assert [len(pd.read_parquet(p)) for p in parts] == [3] * 4
    assert all(p.stem == f"{pd.read_parquet(p)['key'].iloc[0]}-3" for p in parts)
    lines = []
    again = run_sweep(small, out, workers=2, batch=3, log=lines.append, plots=False)
    assert again["computed"] == 0 and "12 already done, 0 to run" in lines[0]
    _same_rows(pd.read_parquet(out / "runs.parquet"), unbatched.table)
    middle = table[(table["unit"] == 1) & (table["scenario_index"] == 1)].iloc[0]  # row 2 of its part
    res = rerun(small, middle["key"], out)
    assert res["differs"] == [] and res["stored"].endswith("-3.parquet")


def test_workers_have_one_thread_and_a_warm_node_local_numba_cache(small):
    from sins_sim.jobs.sweep.job import _dask_client, _setup_workers
    from sins_sim.jobs.sweep.tasks import package_version
    from sins_sim.jobs.sweep.worker import node_cache_dir

    _, tasks, _ = prepare_sweep(small)

    def probe(dask_worker):
        import os

        import numba

        return {"env": os.environ.get("NUMBA_NUM_THREADS"), "numba_threads": numba.get_num_threads(),
                "cache": numba.config.CACHE_DIR, "nthreads": dask_worker.state.nthreads,
                "warm_s": getattr(dask_worker, "sins_sim_warm_s", None)}

    with _dask_client(None, 2, 2) as client:
        _setup_workers(client, tasks, package_version())
        seen = list(client.run(probe).values())
    assert len(seen) == 2
    for w in seen:
        assert w["env"] == "1" and w["numba_threads"] == 1 and w["nthreads"] == 1
        assert w["cache"] == node_cache_dir() and w["warm_s"] is not None
    # the warm-up wrote the kernels' index files into the node-local folder (numba mirrors the source path there)
    assert list(Path(node_cache_dir()).rglob("*.nbi"))


def test_local_workers_start_with_the_heap_settings_and_leave_this_process_as_it_was():
    """dask's nanny would start the workers with MALLOC_TRIM_THRESHOLD_=65536 (a fixed 128 kB mmap threshold: the
    runs' arrays page-faulted in anew each run); they get MALLOC_VARIABLES, read by glibc at the process's start,
    and DASK_CONFIG (no profiler sampling the runs' stacks); this process's environment and dask configuration are
    what they were before the cluster."""
    import os

    import dask

    from sins_sim.jobs.sweep.job import _dask_client
    from sins_sim.jobs.sweep.worker import DASK_CONFIG, MALLOC_VARIABLES

    config_before = {k: dask.config.get(k) for k in DASK_CONFIG}
    assert config_before != DASK_CONFIG  # dask's defaults differ: the check below can fail

    def worker_config():
        import dask

        return {k: dask.config.get(k) for k in DASK_CONFIG}

    before = {k: os.environ.get(k) for k in MALLOC_VARIABLES}

    def start_environment():
        with open("/proc/self/environ", "rb") as fh:  # the environment the process started with
            env = dict(kv.split(b"=", 1) for kv in fh.read().split(b"\0") if b"=" in kv)
        return {k: env.get(k.encode(), b"").decode() for k in MALLOC_VARIABLES}

    for _ in range(2):  # the second cluster too: the first one's nannies wrote dask's value into os.environ
        with _dask_client(None, 1, 1) as client:
            seen = list(client.run(start_environment).values())
            config = list(client.run(worker_config).values())
        assert seen == [MALLOC_VARIABLES] and config == [DASK_CONFIG]
        assert {k: os.environ.get(k) for k in MALLOC_VARIABLES} == before
        assert {k: dask.config.get(k) for k in DASK_CONFIG} == config_before


def test_packed_rows_read_back_as_pandas_builds_them():
    """A part (pack_rows) read by pandas is pandas.DataFrame(rows): same columns in order, same values exactly,
    a key missing from a row NaN there."""
    import io

    import numpy as np

    from sins_sim.jobs.sweep.store import pack_rows

    rows = [{"key": "a" * 20, "unit": 0, "seed": 2**32 - 1, "x.status": "ok", "x.m": 0.1 + 0.2, "warnings": ""},
            {"key": "b" * 20, "unit": 1, "seed": 7, "x.status": "ok", "x.m": np.nan, "warnings": "one\ntwo",
             "param.f0_ppm.x": -1e-300}]
    got = pd.read_parquet(io.BytesIO(pack_rows(rows)))
    pd.testing.assert_frame_equal(got, pd.DataFrame(rows), check_exact=True)


# --- one run alone ---------------------------------------------------------------------------------------------
def test_rerun_reproduces_a_stored_row_bit_for_bit(small, unbatched, capsys):
    stored = unbatched.table.sort_values(["scenario_index", "unit"]).reset_index(drop=True)
    row = stored.iloc[-1]  # the last unit of the impact scenario
    res = rerun(small, row["key"], unbatched.out)
    assert res["stored"] and res["differs"] == []
    new = pd.DataFrame([res["row"]])
    _same_rows(new, stored.iloc[[-1]])
    # through the CLI, by key and by UNIT:SCENARIO
    assert main(["sweep", str(small), "--rerun", row["key"], "--out", str(unbatched.out)]) == 0
    text = capsys.readouterr().out
    assert f"unit {row['unit']}, impact (key {row['key']}, seed {row['seed']})" in text and "identical to" in text
    assert main(["sweep", str(small), "--rerun", "2:stationary", "--out", str(unbatched.out)]) == 0
    key = stored[(stored["unit"] == 2) & (stored["scenario"] == "stationary")]["key"].item()
    text = capsys.readouterr().out
    assert f"(key {key}," in text and "identical to" in text


def test_rerun_reports_a_row_that_differs(small, unbatched, tmp_path, capsys):
    """The comparison can fail: a stored part altered in one metric is named."""
    import shutil

    out = tmp_path / "copy"
    shutil.copytree(unbatched.out, out)
    row = unbatched.table.iloc[0]
    part = out / "runs" / f"{row['key']}.parquet"
    frame = pd.read_parquet(part)
    col = "correcting.horizontal_position_error_m_final"
    frame[col] = frame[col] * (1 + 1e-15) + 1e-300
    frame.to_parquet(part, index=False)
    assert main(["sweep", str(small), "--rerun", row["key"], "--out", str(out)]) == 1
    assert f"differs from {part} in 1 column(s): {col}" in capsys.readouterr().out


@pytest.mark.parametrize("run_id, text", [("9:stationary", "--rerun: unit 9 is not in"),
                                          ("0:nowhere", "--rerun: 'nowhere' is not a scenario of"),
                                          ("0123456789abcdef0123", "is no run of")])
def test_a_run_id_not_in_the_sweep_is_one_line(small, capsys, run_id, text):
    assert main(["sweep", str(small), "--rerun", run_id]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("sins-sim: error: ") and "\n" not in err and text in err, err


def test_out_is_required_without_rerun(small, capsys):
    assert main(["sweep", str(small), "--quiet"]) == 2
    assert "--out: name the sweep folder" in capsys.readouterr().err
