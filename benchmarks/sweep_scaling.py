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
* ``speedup = wall_s(1) / wall_s(2)``, for each round of one worker followed by one of two (``--workers 1 2 1 2``
  alternates them, so that each pair ran under about the same load);
* CPU per run of each process over the tasks' phase (``psutil`` ``cpu_times``, user + system): the client's
  (the sweep's own process: the ``LocalCluster``'s scheduler and nannies, the result writer) and each worker's
  (the runs, the batch's packing, the worker's event loop), and the workers' system CPU per run. On ``C`` cores
  the runs' rate cannot pass ``C / (client + sum of workers' CPU per run)``; with one worker on two cores the client
  has a core of its own, so ``speedup <= 2 (w1 + o1) / (w2 + o2 + client2)`` where ``w`` is a worker's CPU per run
  and ``o`` the other costs; the script prints the measured shares.

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
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2],
                    help="worker counts, in this order; repeat them (1 2 1 2) to alternate under the same load")
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
    import psutil

    import sins_sim.jobs.sweep.job as job

    run_tasks = job._run_tasks
    cpu: dict = {}

    def counted(client, *a, **k):
        """The tasks' phase with the CPU times of this process and of the worker processes around it."""
        me = psutil.Process()
        procs = [me, *me.children(recursive=True)]
        before = {p.pid: (p.cpu_times(),) for p in procs}
        r = run_tasks(client, *a, **k)
        cpu.clear()
        for p in procs:
            try:
                t = p.cpu_times()
            except psutil.NoSuchProcess:
                continue
            t0 = before[p.pid][0]
            cpu[p.pid] = {"client": p.pid == me.pid, "s": (t.user - t0.user) + (t.system - t0.system),
                          "system_s": t.system - t0.system}
        return r

    job._run_tasks = counted
    out["runs"], out["rounds"] = {}, []
    for k, w in enumerate(args.workers):
        out["machine_load"][f"before_{w}"] = _load()
        folder = tmp / f"w{w}-{k}"
        res = run_sweep(path, folder, workers=w, batch=args.batch, log=lambda s: None, plots=False)
        client_s = sum(c["s"] for c in cpu.values() if c["client"])
        workers_s = [c for c in cpu.values() if not c["client"] and c["s"] > 0.05]  # not the resource tracker
        rows = pd.read_parquet(folder / "runs.parquet")
        wall = float(res["wall_s"])
        in_runs = float(rows["wall_s"].sum())
        n_tasks = len(_batches(tasks, w, args.batch))
        r = {"wall_s": wall, "runs_per_s": args.units / wall, "tasks": n_tasks,
             "batch": -(-args.units // n_tasks), "run_wall_s_mean": in_runs / args.units,
             "overhead_in_tasks_ms": 1e3 * (w * wall - in_runs) / args.units,
             "overhead_vs_alone_ms": 1e3 * (w * wall / args.units - out["alone_s"]),
             "failed": res["failed"],
             "client_cpu_ms_per_run": 1e3 * client_s / args.units,
             "client_cpu_share_of_a_core": client_s / wall,
             "workers_cpu_ms_per_run": 1e3 * sum(c["s"] for c in workers_s) / args.units,
             "workers_system_ms_per_run": 1e3 * sum(c["system_s"] for c in workers_s) / args.units,
             "workers_cpu_share_of_a_core": [c["s"] / wall for c in workers_s]}
        out["runs"][str(w)] = r  # the last round of w workers
        out["rounds"].append({"workers": w, **r})
        out["machine_load"][f"after_{w}"] = _load()
        print(f"{w} worker(s): {args.units} runs in {wall:.2f} s = {r['runs_per_s']:.2f} runs/s, {n_tasks} tasks of "
              f"about {r['batch']} run(s); mean run {1e3 * r['run_wall_s_mean']:.1f} ms in the workers; overhead "
              f"per run {r['overhead_in_tasks_ms']:.2f} ms outside the runs, {r['overhead_vs_alone_ms']:.2f} ms "
              f"against the run alone; load {out['machine_load'][f'after_{w}']}")
        print(f"    CPU per run: client {r['client_cpu_ms_per_run']:.2f} ms ({100 * r['client_cpu_share_of_a_core']:.0f} % "
              f"of a core), workers {r['workers_cpu_ms_per_run']:.2f} ms (of which system "
              f"{r['workers_system_ms_per_run']:.2f} ms; each worker busy "
              f"{', '.join(f'{100 * x:.0f} %' for x in r['workers_cpu_share_of_a_core'])} of the wall time)")
    # each round of 1 worker followed by one of 2 (``--workers 1 2 1 2`` alternates them under the same load)
    out["pairs"] = []
    for one, two in zip(out["rounds"], out["rounds"][1:]):
        if (one["workers"], two["workers"]) != (1, 2):
            continue
        # the CPU bound (module docstring): one worker has a core to itself, two share both cores with the client
        pair = {"speedup": one["wall_s"] / two["wall_s"],
                "cpu_bound": 2 * one["workers_cpu_ms_per_run"] / (two["workers_cpu_ms_per_run"]
                                                                  + two["client_cpu_ms_per_run"])}
        out["pairs"].append(pair)
        print(f"speed-up from 1 to 2 workers: {pair['speedup']:.2f}x; CPU bound on 2 cores, 2 w1 / (w2 + client2): "
              f"{pair['cpu_bound']:.2f}x (w: the workers' CPU per run; the wall-time speed-up reaches the bound "
              f"only where the sweep has both cores)")
    if out["pairs"]:
        out["speedup_1_to_2"] = out["pairs"][-1]["speedup"]
        out["cpu_bound_speedup_1_to_2"] = out["pairs"][-1]["cpu_bound"]
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
