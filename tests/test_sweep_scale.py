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
    # a part per run, as without batching: the resume stays per run
    assert len(list((out / "runs").glob("*.parquet"))) == 12


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
