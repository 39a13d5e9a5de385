"""What one sweep run of a long mission costs: wall time per simulated second, memory, bytes per result row.

The numbers the scale-out note of ``docs/user-guide/sweeps.md`` derives a cluster from. Each cut of the mission
runs in a fresh process (its peak RSS is the run's), as a sweep worker runs it (:func:`sins_sim.jobs.sweep.tasks.
run_task`, one thread), after a 2 s warm-up cut in the same process (the kernels loaded)::

    PYTHONPATH=. python benchmarks/sweep_mission_cost.py scenarios/nav-stationary-1h.yaml --cuts 31 121

The wall time is taken as ``fixed + slope x duration`` through the two cuts (the engine is linear in the
simulated time, :mod:`sins_sim.jobs.estimate`) and extrapolated to the scenario's own duration; the peak RSS of the
two cuts shows whether memory grows with the duration; the row's bytes are its one-row Parquet part, as the
sweep stores it (``runs/<key>.parquet``), and its size inside a many-row ``runs.parquet``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

_CHILD = r"""
import json, resource, sys, time
from pathlib import Path
import pandas as pd
from sins_sim.config.yaml_io import load_yaml
from sins_sim.jobs.sweep.tasks import package_version, run_task

path, duration, tmp = Path(sys.argv[1]), float(sys.argv[2]), Path(sys.argv[3])
doc = dict(load_yaml(path))
imu = doc["imu"]
if isinstance(imu, str):
    doc["imu"] = load_yaml((path.parent / imu).resolve())
doc["outputs"] = {"plots": False, "timeseries": False}

def spec(d):
    return {"key": "cost", "unit": 0, "scenario": doc["name"], "scenario_index": 0, "seed": int(doc.get("seed", 0)),
            "params": {}, "doc": {**doc, "duration_s": d}, "ctx": str(path), "base_dir": str(path.parent),
            "version": package_version()}

run_task(spec(2.0))
rss_warm = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
t0, c0 = time.perf_counter(), time.process_time()
row = run_task(spec(duration))
wall, cpu = time.perf_counter() - t0, time.process_time() - c0
rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
part = tmp / "part.parquet"
from sins_sim.jobs.sweep.store import pack_rows
part.write_bytes(pack_rows([row]))  # the one-row part as the sweep stores it
many = tmp / "many.parquet"
import numpy as np
rng = np.random.default_rng(0)  # 1000 rows as different as a lot's: every number moved by a random 10 %
frame = pd.DataFrame([row] * 1000).assign(key=[f"{i:020x}" for i in range(1000)])
for c in frame.columns:
    if frame[c].dtype.kind == "f":
        frame[c] = frame[c] * (1 + 0.1 * rng.standard_normal(1000))
frame.to_parquet(many, index=False)
print(json.dumps({"duration_s": duration, "wall_s": wall, "cpu_s": cpu, "peak_rss_bytes": rss, "rss_after_warm_bytes": rss_warm,
                  "part_bytes": part.stat().st_size, "bytes_per_row_in_1000": many.stat().st_size / 1000,
                  "columns": len(row)}))
"""


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scenario", nargs="?", default=str(ROOT / "scenarios" / "nav-stationary-1h.yaml"))
    ap.add_argument("--cuts", type=float, nargs=2, default=[31.0, 121.0], help="two durations to run (s)")
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)

    from sins_sim.config.yaml_io import load_yaml

    full = float(load_yaml(Path(args.scenario))["duration_s"])
    env = {**os.environ, "NUMBA_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "PYTHONPATH": str(ROOT)}
    cuts = []
    with tempfile.TemporaryDirectory() as tmp:
        for d in args.cuts:
            proc = subprocess.run([sys.executable, "-c", _CHILD, args.scenario, str(d), tmp], capture_output=True,
                                  text=True, env=env, check=True)
            cuts.append(json.loads(proc.stdout.strip().splitlines()[-1]))
            c = cuts[-1]
            print(f"{d:g} s simulated: {c['wall_s']:.2f} s wall, {c['cpu_s']:.2f} s CPU, peak RSS {c['peak_rss_bytes'] / 2**20:.0f} MiB "
                  f"(after the warm-up cut {c['rss_after_warm_bytes'] / 2**20:.0f} MiB); row {c['columns']} columns, "
                  f"{c['part_bytes']} B as a part, {c['bytes_per_row_in_1000']:.0f} B in a 1000-row table")
    out = {"scenario": args.scenario, "cuts": cuts, "full_duration_s": full, "load_average": list(os.getloadavg()),
           "command": " ".join([Path(sys.argv[0]).name, *sys.argv[1:]])}
    for what in ("wall_s", "cpu_s"):  # CPU time: the run's own cost, less sensitive to other jobs than its wall time
        (d1, w1), (d2, w2) = [(c["duration_s"], c[what]) for c in cuts]
        slope = (w2 - w1) / (d2 - d1)
        fixed = w1 - slope * d1
        out[what] = {"slope_s_per_simulated_s": slope, "fixed_s": fixed, "run_s_full": fixed + slope * full}
        print(f"{what[:-2]}: {1e3 * slope:.2f} ms per simulated second ({1 / slope:.1f}x real time), fixed {fixed:.2f} "
              f"s: one run of {full:g} s costs about {out[what]['run_s_full']:.0f} s of one core")
    print(f"load average {out['load_average']}")
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
