"""Throughput of a sweep of short runs on 1 and 2 local workers against the per-run time alone (issue 26, item 4).

Not a test: a measurement, printed and optionally written as JSON. Run it on an idle machine::

    PYTHONPATH=. python benchmarks/sweep_scaling.py --units 200 --duration 1.2 --workers 1 2 --json sweep.json

What it measures
----------------
* ``alone_s``: the median wall time of one run of the sweep in this process, run after run (the kernels warm),
  over ``--alone`` runs: what a run costs without Dask.
* per worker count ``W``: the sweep (``--units`` units of ``scenarios/stationary.yaml`` cut to ``--duration``, an
  f0 spread) on a fresh ``LocalCluster`` of ``W`` single-threaded workers; ``wall_s`` is the tasks' phase of
  :func:`sins_sim.jobs.sweep.run_sweep` (from the first submit to the last result written; the cluster start and
  the workers' warm-up excluded), ``runs_per_s = units / wall_s``;
* overhead per run, two ways:
  ``overhead_in_tasks_ms = (W wall_s - sum of the rows' wall_s) / units`` (worker time outside the runs:
  scheduling, (de)serialising, the result's round trip and the part written by the client while the worker waits)
  and ``overhead_vs_alone_ms = W wall_s / units - alone_s`` (against the run alone, which also catches runs made
  slower by sharing the machine);
* ``speedup = wall_s(1) / wall_s(2)``.

The load average of the machine before and after each phase is recorded with the numbers: on a shared machine
the speed-up measures the cores the other jobs left free, not the sweep.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _sweep_file(folder: Path, units: int, duration: float) -> Path:
    p = folder / "scaling.yaml"
    p.write_text(f"name: scaling\nseed: 26\nunits: {units}\nscenarios:\n"
                 f"  - {{path: {ROOT / 'scenarios' / 'stationary.yaml'}, duration_s: {duration}}}\n"
                 f"population:\n  f0_ppm: {{width: 2000}}\n")
    return p


def _load() -> list:
    return [round(x, 2) for x in os.getloadavg()]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--units", type=int, default=200)
    ap.add_argument("--duration", type=float, default=1.2, help="simulated seconds per run (> 1: navigation starts "
                                                                 "at 1 s in scenarios/stationary.yaml)")
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--batch", type=int, default=None, help="runs per task [automatic]")
    ap.add_argument("--alone", type=int, default=15, help="runs timed alone in this process")
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)

    from sins_sim.jobs.sweep import run_sweep
    from sins_sim.jobs.sweep.job import _batches, prepare_sweep
    from sins_sim.jobs.sweep.tasks import package_version, run_task

    tmp = Path(tempfile.mkdtemp(prefix="sins-sim-sweep-scaling-"))
    path = _sweep_file(tmp, args.units, args.duration)
    _, tasks, _ = prepare_sweep(path)
    out = {"units": args.units, "duration_s": args.duration, "cpu_count": os.cpu_count(), "machine_load": {},
           "estimated_run_s": tasks[0].est_s, "command": " ".join([Path(sys.argv[0]).name, *sys.argv[1:]])}

    out["machine_load"]["before_alone"] = _load()
    run_task(tasks[0].spec(package_version()))  # compile or load the kernels
    times = []
    for t in tasks[1:1 + args.alone]:
        t0 = time.perf_counter()
        run_task(t.spec(package_version()))
        times.append(time.perf_counter() - t0)
    out["alone_s"] = statistics.median(times)
    out["machine_load"]["after_alone"] = _load()
    print(f"one run alone: median {1e3 * out['alone_s']:.1f} ms over {len(times)} runs "
          f"(estimate {1e3 * tasks[0].est_s:.1f} ms); load {out['machine_load']['after_alone']}")

    import pandas as pd

    out["runs"] = {}
    for w in args.workers:
        out["machine_load"][f"before_{w}"] = _load()
        folder = tmp / f"w{w}"
        res = run_sweep(path, folder, workers=w, batch=args.batch, log=lambda s: None, plots=False)
        rows = pd.read_parquet(folder / "runs.parquet")
        wall = float(res["wall_s"])
        in_runs = float(rows["wall_s"].sum())
        n_tasks = len(_batches(tasks, w, args.batch))
        r = {"wall_s": wall, "runs_per_s": args.units / wall, "tasks": n_tasks,
             "batch": -(-args.units // n_tasks), "run_wall_s_mean": in_runs / args.units,
             "overhead_in_tasks_ms": 1e3 * (w * wall - in_runs) / args.units,
             "overhead_vs_alone_ms": 1e3 * (w * wall / args.units - out["alone_s"]),
             "failed": res["failed"]}
        out["runs"][str(w)] = r
        out["machine_load"][f"after_{w}"] = _load()
        print(f"{w} worker(s): {args.units} runs in {wall:.2f} s = {r['runs_per_s']:.2f} runs/s, {n_tasks} tasks of "
              f"about {r['batch']} run(s); mean run {1e3 * r['run_wall_s_mean']:.1f} ms in the workers; overhead "
              f"per run {r['overhead_in_tasks_ms']:.2f} ms outside the runs, {r['overhead_vs_alone_ms']:.2f} ms "
              f"against the run alone; load {out['machine_load'][f'after_{w}']}")
    if "1" in out["runs"] and "2" in out["runs"]:
        out["speedup_1_to_2"] = out["runs"]["1"]["wall_s"] / out["runs"]["2"]["wall_s"]
        print(f"speed-up from 1 to 2 workers: {out['speedup_1_to_2']:.2f}x")
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
