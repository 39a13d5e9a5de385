"""What runs on the sweep's Dask workers besides the runs: their set-up, batches of runs, quiet shutdown logs.

Set-up (:class:`SweepWorkerSetup`, a worker plugin registered before the first task):

* **one thread**: ``NUMBA_NUM_THREADS=1`` (and the BLAS/OpenMP pools at 1) in every worker process, one
  worker thread per process (``--nthreads 1``): a run is one core's work (``run_plan(plan, threads=1)``) and
  the sweep's parallelism is the workers'; more threads would only compete for the same cores;
* **the C heap kept between runs**: dask's nanny starts every worker with ``MALLOC_TRIM_THRESHOLD_=65536``
  (``distributed.nanny.pre-spawn-environ``), which also fixes glibc's mmap threshold at 128 kB: every array a run
  allocates above it is a fresh ``mmap`` whose pages fault in on first touch, and every free gives them back.
  Measured on the 2-core machine (2026-11-27, 20 runs of 1.2 s at rest): 6,700 page faults and 11-15 ms of
  system CPU per 30 ms run, against 50-300 faults and 0-0.3 ms with :data:`MALLOC_VARIABLES` (a 128 MiB trim
  threshold, a 32 MiB mmap threshold: glibc's own dynamic ceiling). The ``LocalCluster`` starts its workers with
  them (they must be in the environment when the process starts);
* **quiet event loops**: :data:`DASK_CONFIG` for the ``LocalCluster`` (its scheduler, nannies and workers): no
  statistical profiler (by default a thread that samples the running task's stack every 10 ms, taking the GIL
  from the run), the event-loop tick every second instead of every 20 ms, the system and memory monitors every
  2 s and 1 s instead of 0.5 s and 0.1 s. Measured on the 2-core machine (2026-11-27, two workers whose tasks
  sleep 10 s): the client's process 3.2 % of a core and each worker 2.8 % with dask's defaults, 0.7 % and
  0.2-0.3 % with these;
* **a node-local numba cache**: ``NUMBA_CACHE_DIR`` is the worker's own setting if it has one, else
  :func:`node_cache_dir` (``$TMPDIR`` or ``/tmp``, on the worker's node). numba's default writes beside the
  installed package, which on a cluster is often a shared file system: slow, and written by every node at once;
* **warmed once per worker, before the first task**: a 0.3 s run at rest of the sweep's first unit's IMU
  loads (or on a cold cache compiles and stores) the kernels, under a file lock in the cache folder so that the
  workers of one node compile once and the others load what it stored.

Variables that numba reads when it is imported are set by the ``LocalCluster``'s nannies before the worker
process starts; a worker of an existing cluster (``--scheduler``) gets them from the plugin only if it has
not imported numba yet (a freshly started ``dask worker`` has not), else ``numba.set_num_threads(1)`` and its
own cache folder: start such workers as ``docs/user-guide/sweeps.md`` shows.

This module imports only the standard library and distributed at the top, so that unpickling the plugin on a
worker does not load numba before the environment is set.
"""

from __future__ import annotations

import logging
import os
import sys
import tempfile
import time
import traceback
from pathlib import Path

from distributed.diagnostics.plugin import WorkerPlugin

__all__ = ["mute_distributed_logs", "restore_logs", "mute_worker_logs", "SHUTDOWN_LOGGERS", "THREAD_VARIABLES",
           "MALLOC_VARIABLES", "DASK_CONFIG", "node_cache_dir", "worker_environment", "SweepWorkerSetup", "warm_spec", "run_batch",
           "run_batch_part"]

#: One thread per worker process: numba's pool and the BLAS/OpenMP pools numpy and scipy may start.
THREAD_VARIABLES = {"NUMBA_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1",
                    "MKL_NUM_THREADS": "1"}
#: glibc's heap settings of a worker process (module docstring): freed memory up to 128 MiB stays in the process's
#: heap for the next run, arrays below 32 MiB come from the heap, not each from its own ``mmap``.
MALLOC_VARIABLES = {"MALLOC_TRIM_THRESHOLD_": str(128 << 20), "MALLOC_MMAP_THRESHOLD_": str(32 << 20)}
#: dask settings of the sweep's ``LocalCluster`` (module docstring); a worker's memory limit is still checked
#: every second (a run's memory grows over seconds, not milliseconds).
DASK_CONFIG = {"distributed.worker.profile.enabled": False, "distributed.admin.tick.interval": "1s",
               "distributed.admin.system-monitor.interval": "2s", "distributed.worker.memory.monitor-interval": "1s"}
#: Simulated seconds of the warm-up run (at rest; 0.1 s before navigation starts).
WARM_DURATION_S = 0.3


def node_cache_dir() -> str:
    """The numba cache folder of a worker: ``NUMBA_CACHE_DIR`` if set, else ``sins-sim-numba-<user>`` in the
    node's temporary folder (``$TMPDIR``, else ``/tmp``; on SLURM and Kubernetes nodes a local disk)."""
    own = os.environ.get("NUMBA_CACHE_DIR", "").strip()
    if own:
        return own
    user = str(os.getuid()) if hasattr(os, "getuid") else os.environ.get("USERNAME", "user")
    return str(Path(tempfile.gettempdir()) / f"sins-sim-numba-{user}")


def worker_environment() -> dict:
    """Environment of a ``LocalCluster``'s worker processes (set by the nanny before the process starts)."""
    return {**THREAD_VARIABLES, **MALLOC_VARIABLES, "NUMBA_CACHE_DIR": node_cache_dir()}


def warm_spec(spec: dict) -> dict:
    """A run spec that loads the kernels ``spec``'s runs use: :data:`WARM_DURATION_S` at rest with its IMU."""
    doc = {"name": "sins-sim-sweep-warm-up", "imu": spec["doc"]["imu"], "duration_s": WARM_DURATION_S,
           "motion": [{"type": "static"}], "navigation": {"start_s": 0.1},
           "outputs": {"plots": False, "timeseries": False}}
    if "filters" in spec["doc"]:
        doc["filters"] = spec["doc"]["filters"]
    return {**spec, "doc": doc, "key": "warm-up", "ctx": f"{spec['ctx']} (warm-up run)"}


class SweepWorkerSetup(WorkerPlugin):
    """Worker plugin: one thread, the node-local numba cache, and a warm-up run before the first task
    (module docstring). ``warm`` is a :func:`warm_spec`, or None (no warm-up)."""

    name = "sins-sim-sweep-setup"

    def __init__(self, warm: dict | None = None):
        self.warm = warm
        self.warm_error = ""

    def setup(self, worker=None):
        numba_loaded = "numba" in sys.modules
        if not numba_loaded:
            for k, v in THREAD_VARIABLES.items():
                os.environ.setdefault(k, v)
            os.environ["NUMBA_CACHE_DIR"] = node_cache_dir()
        else:
            import numba

            numba.set_num_threads(1)
        cache = Path(os.environ.get("NUMBA_CACHE_DIR") or node_cache_dir())
        t0 = time.perf_counter()
        if self.warm is not None:
            try:
                cache.mkdir(parents=True, exist_ok=True)
                lock = open(cache / ".sins-sim-warm.lock", "a")
            except OSError:
                lock = None  # no writable cache folder: numba compiles in memory, the warm-up still loads
            try:
                if lock is not None:
                    try:
                        import fcntl

                        fcntl.flock(lock, fcntl.LOCK_EX)  # one compile per node; the others load its cache
                    except (ImportError, OSError):
                        pass
                from sins_sim.jobs.sweep.tasks import run_task

                run_task(self.warm)
            except Exception as exc:  # noqa: BLE001 - the first task raises it again, recorded with its run
                self.warm_error = f"{type(exc).__name__}: {exc}"
            finally:
                if lock is not None:
                    lock.close()  # releases the lock
        self.warm_s = time.perf_counter() - t0
        if worker is not None:
            worker.sins_sim_warm_s = self.warm_s
            worker.sins_sim_numba_cache = str(cache)


def run_batch(specs: list, task_fn=None) -> list:
    """Run several tasks one after the other on a worker; one result per spec, in order.

    Each result is ``{"key", "row"}`` or, for a run that raised, ``{"key", "error", "traceback"}``: a failing
    run is recorded and the batch goes on, as a failing task does when runs are not batched.
    """
    if task_fn is None:
        from sins_sim.jobs.sweep.tasks import run_task as task_fn
    out = []
    for spec in specs:
        try:
            out.append({"key": spec["key"], "row": task_fn(spec)})
        except Exception as exc:  # noqa: BLE001 - recorded with its traceback, as a failed task
            out.append({"key": spec["key"], "error": f"{type(exc).__name__}: {' '.join(str(exc).split())}",
                        "traceback": "".join(traceback.format_exception(type(exc), exc, exc.__traceback__))})
    return out


def run_batch_part(specs: list, task_fn=None) -> dict:
    """:func:`run_batch`, its rows packed here into one Parquet part (:func:`~sins_sim.jobs.sweep.store.pack_rows`).

    Returns ``{"keys", "part", "failures"}``: the keys of the finished runs in order, the part's bytes (None if
    every run failed) and the failed runs' items of :func:`run_batch`. The client only writes the bytes
    (:meth:`~sins_sim.jobs.sweep.store.SweepStore.write_part`): the packing is paid by the workers, in parallel.
    """
    from sins_sim.jobs.sweep.store import pack_rows

    items = run_batch(specs, task_fn)
    rows = [it["row"] for it in items if "row" in it]
    return {"keys": [r["key"] for r in rows], "part": pack_rows(rows) if rows else None,
            "failures": [it for it in items if "row" not in it]}

#: Loggers whose records during the cluster's shutdown are the cluster's business, not the user's: a worker's
#: heartbeat that meets a scheduler already closing logs ``CommClosedError ... heartbeat_worker`` with its
#: traceback (distributed.worker.Worker.heartbeat, logger.exception), the nannies log the processes they stop.
SHUTDOWN_LOGGERS = ("distributed", "tornado", "asyncio")


def mute_distributed_logs() -> list:
    """Silence :data:`SHUTDOWN_LOGGERS` and every child logger in this process; returns what
    :func:`restore_logs` needs to put the levels back.

    Called on every worker (``client.run``) and in the client's process just before the cluster closes, and
    only then: while the runs go on, a worker's error still reaches its log.
    """
    names = [n for n in list(logging.root.manager.loggerDict)
             if any(n == r or n.startswith(r + ".") for r in SHUTDOWN_LOGGERS)]
    saved = []
    for name in sorted(set(names) | set(SHUTDOWN_LOGGERS)):
        lg = logging.getLogger(name)
        saved.append((lg, lg.level, lg.disabled))
        lg.setLevel(logging.CRITICAL + 1)
        lg.disabled = True
    return saved


def restore_logs(saved: list) -> None:
    """Undo :func:`mute_distributed_logs`."""
    for lg, level, disabled in saved:
        lg.setLevel(level)
        lg.disabled = disabled


def mute_worker_logs() -> None:
    """:func:`mute_distributed_logs` on a worker (``client.run``; the worker process ends with the cluster)."""
    mute_distributed_logs()
