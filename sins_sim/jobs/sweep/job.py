"""``sins-sim sweep``: every (unit, scenario) run as a dask.distributed task, results on disk as they finish.

:func:`run_sweep` validates the sweep file, every scenario and every unit's drawn IMU (:mod:`.tasks`)
before anything starts, opens the output folder (:mod:`.store`), skips the runs whose key already has
a part there, submits the rest to a dask cluster (a ``LocalCluster`` of ``workers`` single-threaded
processes by default, or the scheduler at ``scheduler``), writes each part as its task finishes, and
records a failed task (its parameters, error and traceback) without stopping the others. At the end
it writes ``runs.parquet``, ``summary.json`` (:mod:`.summary`) and the plots.

Runs are grouped into tasks (:func:`batch_size`: a task of about :data:`TARGET_TASK_S`, every worker thread
given several tasks); the worker packs a task's rows into one Parquet part and the client writes its bytes
(:mod:`.store`), so the client's CPU per run stays small beside the workers'. The
workers are set up before the first task (:mod:`.worker`: one thread, a node-local numba cache, a warm-up
run). :func:`rerun` runs one run of the sweep alone, in this process (``sins-sim sweep --rerun``).
"""

from __future__ import annotations

import json
import logging
import math
import os
import time
import traceback
from contextlib import contextmanager
from pathlib import Path

from sins_sim.config.errors import ConfigError
from sins_sim.config.sweep import load_sweep
from sins_sim.jobs.sweep.store import SweepStore
from sins_sim.jobs.sweep.summary import (DRIVER_ALPHA, driver_tests, metric_filters, parameter_names,
                                        quantile_n_required, summarize)
from sins_sim.jobs.sweep.tasks import (HEADLINE_METRICS, METRICS, PARAM_PREFIX, build_tasks, package_version,
                                       run_task)

__all__ = ["run_sweep", "rerun", "find_task", "prepare_sweep", "parameter_label", "batch_size", "CONNECT_TIMEOUT_S"]

#: A Dask task (a batch of runs) should last about this long (s): :func:`batch_size`.
TARGET_TASK_S = 1.0
#: At most this many runs per task (a task's results are written when it finishes: the resume's granularity).
MAX_BATCH = 64
#: Every worker thread gets at least this many tasks where the runs allow it (load balance).
TASKS_PER_SLOT = 4
#: How long to wait for ``--scheduler`` to answer (s).
CONNECT_TIMEOUT_S = 15.0
#: About how long a worker's first run spends compiling the numba kernels without a cache (s; measured on the
#: 2-core machine of the README, said to the user while the first run is under way).
FIRST_COMPILE_S = 30.0
#: Sensitivity figures show at most this many parameters (the strongest rank correlations first).
MAX_SENSITIVITY_PANELS = 8
#: The metrics drawn against the parameters (every headline metric's drivers are in summary.json).
SENSITIVITY_METRICS = ("horizontal_position_error_m_final", "event_step_arcsec_max")

_PARAM_LABELS = {
    "f0_ppm": "f0 offset, axis {ax} (ppm)", "f0_hz": "f0 offset, axis {ax} (Hz)",
    "k1_percent": "k1, axis {ax} (% from nominal)", "k2_percent": "k2, axis {ax} (% from nominal)",
    "k3_percent": "k3, axis {ax} (% from nominal)", "k4_percent": "k4, axis {ax} (% from nominal)",
    "k5_percent": "k5, axis {ax} (% from nominal)",
    "temperature_coefficient_ppm_per_k": "f0 temperature coefficient, axis {ax} (ppm/K)",
}


#: Unit suffixes of the sensor keys and how a label writes them.
_UNITS = {"deg_h": "deg/h", "ppm": "ppm", "ug": "ug", "ug_g2": "ug/g^2", "arcsec": "arcsec"}


def _split_unit(key: str) -> tuple:
    """``bias_deg_h`` -> (``bias``, ``deg/h``): the longest unit suffix of :data:`_UNITS`."""
    for suffix in sorted(_UNITS, key=len, reverse=True):
        if key.endswith("_" + suffix):
            return key[: -len(suffix) - 1], _UNITS[suffix]
    return key, ""


#: Unit suffixes of the block's keys (``sins_sim.config.block_schema``) and how a label writes them.
_BLOCK_UNITS = {"kg": "kg", "kg_m2": "kg m^2", "n_per_m": "N/m", "n_s_per_m": "N s/m", "n_m_per_rad": "N m/rad",
                "n_m_s_per_rad": "N m s/rad", "mm": "mm"}


def _block_label(name: str) -> str:
    """``block.isolators.stiffness_n_per_m.x`` -> ``block isolators stiffness, axis x (N/m)``; ``block.mass_kg`` ->
    ``block mass (kg)``; ``block.inertia_kg_m2.xx`` -> ``block inertia, xx (kg m^2)``."""
    parts = name.split(".")
    last = parts[-1]
    ax = None
    if last in ("x", "y", "z", "xx", "yy", "zz"):
        ax, parts = last, parts[:-1]
    what = parts[-1]
    for suffix in sorted(_BLOCK_UNITS, key=len, reverse=True):
        if what.endswith("_" + suffix):
            what, unit = what[: -len(suffix) - 1], _BLOCK_UNITS[suffix]
            break
    else:
        unit = ""
    head = " ".join(parts[:-1] + [what.replace("_", " ")])
    where = "" if ax is None else (f", axis {ax}" if len(ax) == 1 else f", {ax}")
    return f"{head}{where} ({unit})" if unit else f"{head}{where}"


def parameter_label(name: str) -> str:
    """Axis label (with unit) of a drawn parameter (``f0_ppm.x``, ``temperature_k``, ``gyro.bias_deg_h.x``,
    ``block.isolators.stiffness_n_per_m.x``)."""
    if name == "temperature_k":
        return "temperature offset from calibration (K)"
    if name.startswith("block."):
        return _block_label(name)
    key, _, ax = name.rpartition(".")
    if key in _PARAM_LABELS:
        return _PARAM_LABELS[key].format(ax=ax)
    section, _, sensor_key = key.partition(".")
    if section in ("gyro", "accelerometer") and "_" in sensor_key:  # gyro.bias_deg_h: "gyro bias, axis x (deg/h)"
        from sins_sim.jobs.sweep.population import SENSOR_SIGMA_KEYS

        if sensor_key in SENSOR_SIGMA_KEYS.get(section, ()):
            what, unit = _split_unit(sensor_key)
            return f"{section} {what.replace('_', ' ')}, {'angle' if len(ax) == 2 else 'axis'} {ax} ({unit})"
    return name


def prepare_sweep(path, units=None):
    """The validated sweep, its tasks and scenario labels (nothing started, nothing written)."""
    import warnings

    sweep = load_sweep(path)
    with warnings.catch_warnings():
        # an unusual drawn value warns in its run too (the runs' warnings column): not once per unit here
        warnings.simplefilter("ignore")
        tasks, labels = build_tasks(sweep, units)
    return sweep, tasks, labels


@contextmanager
def _quiet_dask():
    """dask's own log lines (worker start and stop, closed streams) are not the user's business."""
    loggers = [logging.getLogger(n) for n in ("distributed", "distributed.worker", "distributed.nanny",
                                              "distributed.scheduler", "distributed.core", "distributed.comm",
                                              "distributed.batched", "distributed.client")]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.ERROR)
    try:
        yield
    finally:
        for lg, lv in zip(loggers, levels):
            lg.setLevel(lv)


def _local_workers(workers, n_tasks) -> int:
    """Worker processes of the LocalCluster: ``workers``, else the cores; at most the tasks."""
    return max(1, min(workers or os.cpu_count() or 1, n_tasks))


#: Longest wait for the workers to stop and the cluster to close at the end (s).
CLOSE_TIMEOUT_S = 30.0


def _close_quietly(client, cluster) -> None:
    """Close ``client`` then ``cluster`` (its workers, then its scheduler), with distributed's loggers muted
    for the closing window only, in the workers and here.

    Order: mute the workers' loggers (``client.run``), then this process's (the nannies and the scheduler
    of a ``LocalCluster`` live here), close the client (no more heartbeats of ours to a closing scheduler),
    close the cluster (it retires the workers and waits for them before the scheduler goes), restore this
    process's levels. A worker's heartbeat that meets the scheduler while it closes otherwise prints
    ``CommClosedError ... heartbeat_worker`` with a traceback (issue 25, item 12): a race between two
    periodic callbacks that no order of the closing calls removes, hence the muting.
    """
    from sins_sim.jobs.sweep.worker import mute_distributed_logs, mute_worker_logs, restore_logs

    if client is not None:
        try:
            client.run(mute_worker_logs, wait=True)
        except Exception:  # noqa: BLE001 - a worker already gone has nothing left to print
            pass
    saved = mute_distributed_logs()
    try:
        if client is not None:
            try:
                client.close(timeout=CLOSE_TIMEOUT_S)
            except Exception:  # noqa: BLE001 - closing a client whose scheduler is gone
                pass
        if cluster is not None:
            cluster.close(timeout=CLOSE_TIMEOUT_S)
    finally:
        restore_logs(saved)


@contextmanager
def _cluster_settings():
    """While a ``LocalCluster`` starts: :data:`~sins_sim.jobs.sweep.worker.DASK_CONFIG` (read by its scheduler,
    nannies and workers when they start), and the nannies give the worker processes
    :data:`~sins_sim.jobs.sweep.worker.MALLOC_VARIABLES` instead of dask's ``MALLOC_TRIM_THRESHOLD_=65536``.

    glibc reads them when a process starts, so they must be in the nanny's ``pre-spawn-environ``, which the nanny
    writes into this process's ``os.environ`` before it starts a worker and where a value already in ``os.environ``
    wins over the configuration (an earlier cluster of this process left dask's there): both are set here, and this
    process's environment is put back as it was once the cluster has started (a nanny that restarts a worker
    keeps its own copy).
    """
    import dask

    from sins_sim.jobs.sweep.worker import DASK_CONFIG, MALLOC_VARIABLES

    saved = {k: os.environ.get(k) for k in MALLOC_VARIABLES}
    os.environ.update(MALLOC_VARIABLES)
    try:
        with dask.config.set({**DASK_CONFIG, **{f"distributed.nanny.pre-spawn-environ.{k}": v
                                                for k, v in MALLOC_VARIABLES.items()}}):
            yield
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


@contextmanager
def _dask_client(scheduler, workers, n_tasks):
    from dask.distributed import Client, LocalCluster

    from sins_sim.jobs.sweep.worker import mute_distributed_logs, restore_logs

    if scheduler:
        try:
            client = Client(scheduler, timeout=CONNECT_TIMEOUT_S)
        except (OSError, TimeoutError, ValueError) as exc:
            raise ConfigError(f"--scheduler: cannot reach {scheduler} within {CONNECT_TIMEOUT_S:g} s "
                              f"({' '.join(str(exc).split()) or type(exc).__name__})") from None
        try:
            yield client
        finally:
            saved = mute_distributed_logs()
            try:
                client.close(timeout=CLOSE_TIMEOUT_S)  # the cluster is not ours: its workers stay
            finally:
                restore_logs(saved)
        return
    n = _local_workers(workers, n_tasks)
    from sins_sim.jobs.sweep.worker import worker_environment

    # one thread per worker process, NUMBA_NUM_THREADS=1, a node-local numba cache: set before the process starts
    with _cluster_settings():
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                               silence_logs=logging.ERROR, env=worker_environment())
    client = None
    try:
        client = Client(cluster)
        yield client
    finally:
        _close_quietly(client, cluster)


def batch_size(est_run_s: float, n_runs: int, slots: int) -> int:
    """Runs per Dask task: enough that a task lasts about :data:`TARGET_TASK_S`, at most :data:`MAX_BATCH`, and
    few enough that every worker thread still gets :data:`TASKS_PER_SLOT` tasks of the ``n_runs``.

    ``ceil(TARGET_TASK_S / est_run_s)`` bounds the scheduling overhead (a few ms per task: submit, schedule,
    serialise the specs and rows, store the result) to below 1 % of the task's time; the cap by
    ``n_runs / (TASKS_PER_SLOT slots)`` keeps the load balanced: the last task to finish holds a worker at most
    about a quarter of its share. Runs of 1 s or more are never batched.

    Examples
    --------
    >>> batch_size(0.05, 10_000, 2), batch_size(0.05, 40, 2), batch_size(6.0, 400, 2)
    (20, 5, 1)
    """
    by_time = math.ceil(TARGET_TASK_S / max(est_run_s, 1e-6))
    by_balance = math.ceil(n_runs / (TASKS_PER_SLOT * max(slots, 1)))
    return max(1, min(by_time, MAX_BATCH, by_balance))


def _batches(todo, slots: int, batch: int | None) -> list:
    """The runs grouped into tasks: runs of one scenario together (their estimated times are equal), in unit order."""
    groups: dict = {}
    for t in todo:
        groups.setdefault(t.scenario_index, []).append(t)
    out = []
    for runs in groups.values():
        b = batch or batch_size(runs[0].est_s, len(runs), slots)
        out += [runs[k:k + b] for k in range(0, len(runs), b)]
    return out


def _failure_record(task, error: str, text: str) -> dict:
    return {"key": task.key, "unit": task.unit, "scenario": task.scenario, "seed": task.seed,
            "params": task.params, "error": error, "traceback": text}


def _exception_record(task, exc, tb) -> dict:
    text = "".join(traceback.format_exception(type(exc), exc, tb)) if tb is not None else repr(exc)
    return _failure_record(task, f"{type(exc).__name__}: {' '.join(str(exc).split())}", text)


def _setup_workers(client, todo, version, phase=None) -> None:
    """Register :class:`~sins_sim.jobs.sweep.worker.SweepWorkerSetup` (one thread, node-local numba cache,
    a warm-up run) on every worker; returns when every worker has warmed."""
    from sins_sim.jobs.sweep.worker import SweepWorkerSetup, warm_spec

    if phase is not None:
        phase(f"warming the workers: each loads the numba kernels once (a cold cache compiles them, about "
              f"{FIRST_COMPILE_S:.0f} s on an idle core, once per node)")
    client.register_plugin(SweepWorkerSetup(warm_spec(todo[0].spec(version))))


def _run_tasks(client, todo, store, progress, task_fn, version, phase=None, batch=None) -> tuple[int, int]:
    from dask.distributed import as_completed

    from sins_sim.jobs.sweep.worker import run_batch_part

    slots = sum(client.nthreads().values()) or 1
    futures = {}
    for runs in _batches(todo, slots, batch):
        # longest tasks first (dask runs higher priorities first): the short ones then fill the workers' tails
        # instead of one long task finishing alone at the end (longest-processing-time-first scheduling)
        prio = int(min(sum(t.est_s for t in runs) * 1e3, 1e12))
        fut = client.submit(run_batch_part, [t.spec(version) for t in runs], None if task_fn is run_task else task_fn,
                            key=f"sins-sim-runs-{runs[0].key}-{len(runs)}", pure=False, priority=prio)
        futures[fut] = runs
    ok = failed = 0
    if phase is not None:
        phase(f"waiting for the first runs ({len(todo)} run(s) in {len(futures)} task(s) on {slots} worker "
              f"thread(s); the bar moves as each task ends)")
    try:
        for fut in as_completed(list(futures)):
            runs = futures.pop(fut)
            if fut.status == "finished":
                by_key = {t.key: t for t in runs}
                res = fut.result()
                if res["part"] is not None:  # packed by the worker: the client writes the bytes (.store)
                    store.write_part(res["part"], res["keys"])
                    ok += len(res["keys"])
                for item in res["failures"]:
                    store.write_failure(_failure_record(by_key[item["key"]], item["error"], item["traceback"]))
                    failed += 1
            else:  # the task itself failed (its worker died): every run of it is recorded
                exc, tb = fut.exception(), fut.traceback()
                for t in runs:
                    store.write_failure(_exception_record(t, exc, tb))
                    failed += 1
            fut.release()
            if progress is not None:
                progress(ok + failed, len(todo), failed)
    except BaseException:
        client.cancel(list(futures))
        raise
    return ok, failed


def run_sweep(path, out, scheduler: str | None = None, workers: int | None = None, progress=None, log=print,
              client=None, task_fn=run_task, plots: bool = True, force: bool = False, manifest=None,
              phase=None, batch: int | None = None) -> dict:
    """Run a sweep file; results into ``out`` (resumed if it holds this sweep's earlier results).

    Parameters
    ----------
    path : path
        The sweep YAML (``sins-sim schema sweep``).
    out : path
        The sweep folder (:mod:`sins_sim.jobs.sweep.store`): created, or taken up where it stopped.
    scheduler : str, optional
        Address of a running dask scheduler (``tcp://host:port``); default a ``LocalCluster``.
    workers : int, optional
        Worker processes of the ``LocalCluster`` (one thread each; default: the cores, at most the tasks).
    progress : callable(done, total, failed), optional
        Told the number of tasks to run before the cluster starts, and after each finished task.
    phase : callable(str), optional
        Told, in one line, what happens before the first task finishes (the cluster starting, the first
        runs compiling).
    log : callable(str)
        Where the one-line notes go (what was already done, what failed).
    client : dask.distributed.Client, optional
        Use this client instead of making one (``scheduler`` and ``workers`` are then ignored); its workers are
        set up as a cluster of sins-sim's own (:mod:`.worker`: one numba thread, a warm-up run).
    task_fn : callable(spec) -> row
        The task (default :func:`sins_sim.jobs.sweep.tasks.run_task`).
    plots : bool
        Draw the figures (redrawn only when the table changed since they were drawn).
    force : bool
        Take up a folder that holds another sweep (another name): its stored runs stay in ``runs/`` as a
        cache, its table, summary and figures are replaced. Without it such a folder is refused; a folder
        of the same sweep is always resumed.
    manifest : sins_sim.jobs.manifest.Manifest, optional
        Completed and written as ``manifest.json`` when the sweep ends (default: one without a command line).
    batch : int, optional
        Runs per Dask task (default: :func:`batch_size` from the estimated run time). The rows do not depend on it.

    Returns
    -------
    SweepResult
        A dict (with ``to_pandas()``, ``to_xarray()`` and ``plot()``): ``name``, ``summary`` (as in
        ``summary.json``), ``tasks``, ``already_done``, ``computed``, ``failed``
        (this invocation), ``wall_s`` (the tasks' phase), ``runs_per_s`` and ``files``.
    """
    from sins_sim.jobs.manifest import Manifest

    if manifest is None:
        manifest = Manifest("sweep")
    store = SweepStore(out)
    store.check()
    sweep, tasks, labels = prepare_sweep(path)
    store.check_same(sweep.name, force)
    manifest.add_input("sweep", path)
    keys = [t.key for t in tasks]
    store.open({"name": sweep.name, "sweep_file": str(Path(path).resolve()), "version": package_version(),
                "tasks": len(tasks), "units": sweep.units, "scenarios": labels},
               Path(path).read_text())
    done = store.done_keys()
    todo = [t for t in tasks if t.key not in done]
    already = len(tasks) - len(todo)
    retry = len(store.failed_keys() & {t.key for t in todo})
    stale = len(done - set(keys))
    log(f"{sweep.name}: {len(tasks)} runs ({sweep.units} units x {len(labels)} scenarios): {already} already done, "
        f"{len(todo)} to run" + (f" ({retry} failed before, tried again)" if retry else "")
        + (f"; {stale} stored runs of an earlier sweep definition left aside" if stale else ""))
    ok = failed = 0
    wall = 0.0
    if todo:
        if progress is not None:
            progress(0, len(todo), 0)
        with _quiet_dask():
            if client is not None:
                _setup_workers(client, todo, package_version(), phase)
                t0 = time.perf_counter()
                ok, failed = _run_tasks(client, todo, store, progress, task_fn, package_version(), phase, batch)
                wall = time.perf_counter() - t0
            else:
                if phase is not None:
                    phase(f"connecting to the Dask scheduler at {scheduler}" if scheduler else
                          f"starting a Dask cluster of {_local_workers(workers, len(todo))} "
                          "worker process(es)")
                with _dask_client(scheduler, workers, len(todo)) as cl:
                    _setup_workers(cl, todo, package_version(), phase)
                    t0 = time.perf_counter()
                    ok, failed = _run_tasks(cl, todo, store, progress, task_fn, package_version(), phase, batch)
                    wall = time.perf_counter() - t0
    table = store.table(keys)
    if len(table):
        table = table.sort_values(["scenario_index", "unit"], kind="stable").reset_index(drop=True)
    have = set(table["key"]) if len(table) else set()
    failures = store.failures([k for k in keys if k not in have])
    tests = driver_tests(table, labels) if len(table) else []
    summary = summarize(table, failures, labels, tests)
    files = ["runs.parquet", "summary.json"]
    text = json.dumps(summary, indent=2, allow_nan=False) + "\n"
    drawn = store.root / ".figures-of-summary.json"  # the sweep name and summary the figures were drawn from
    unchanged = drawn.is_file() and drawn.read_text() == sweep.name + "\n" + text
    if len(table):
        store.write_table(table)
    store.write_text("summary.json", text)
    if len(table) and plots:
        if unchanged:
            files += sorted(p.name for p in store.root.glob("*.png"))
        else:
            drawn.unlink(missing_ok=True)
            for old in store.root.glob("*.png"):
                old.unlink()
            files += _plots(table, labels, store, sweep.name, tests)
            store.write_text(drawn.name, sweep.name + "\n" + text)
    for rec in failures:
        log(f"failed: unit {rec['unit']}, {rec['scenario']}: {rec['error']} (traceback in failed/{rec['key']}.json)")
    manifest.doc["sweep"] = {"name": sweep.name, "tasks": len(tasks), "already_done": already, "computed": ok,
                             "failed": failed}
    manifest.write(store.root)  # the folder grows over resumes: the manifest is the last invocation's
    from sins_sim.results import SweepResult

    return SweepResult({"name": sweep.name, "summary": summary, "tasks": len(tasks), "already_done": already,
                        "computed": ok, "failed": failed, "wall_s": wall,
                        "runs_per_s": (ok + failed) / wall if wall > 0 else None, "files": files,
                        "warned_runs": int((table["warnings"].fillna("") != "").sum()) if len(table) else 0,
                        "table": table})


#: Columns of a row that say where and how fast it ran, not what it computed (left out of a rerun's comparison).
VOLATILE_COLUMNS = ("wall_s", "worker")


def _same_value(a, b) -> bool:
    if isinstance(a, float) or isinstance(b, float):
        try:
            a, b = float(a), float(b)
        except (TypeError, ValueError):
            return False
        return a == b or (math.isnan(a) and math.isnan(b))
    return a == b


def find_task(path, run_id: str, flag: str = "--rerun"):
    """The task of one run of a sweep file: by its key or as ``UNIT:SCENARIO`` (:func:`rerun`).

    Raises
    ------
    ConfigError
        No such run (the message starts with ``flag``, the option or function the user called).
    """
    import re

    sweep = load_sweep(path)
    m = re.fullmatch(r"\s*(\d+):(.+?)\s*", run_id)
    if m:
        unit, label = int(m.group(1)), m.group(2)
        if unit >= sweep.units:
            raise ConfigError(f"{flag}: unit {unit} is not in {path} (units: {sweep.units}, numbered 0 to "
                              f"{sweep.units - 1})")
        _, tasks, labels = prepare_sweep(path, units=[unit])
        found = [t for t in tasks if t.scenario == label]
        if not found:
            raise ConfigError(f"{flag}: {label!r} is not a scenario of {path} ({', '.join(labels)})")
    else:
        _, tasks, _ = prepare_sweep(path)
        found = [t for t in tasks if t.key == run_id.strip()]
        if not found:
            raise ConfigError(f"{flag}: {run_id!r} is no run of {path}: give a key of its runs.parquet (20 hex "
                              f"digits) or UNIT:SCENARIO")
    return found[0]


def rerun(path, run_id: str, out=None, task_fn=run_task) -> dict:
    """Run one run of a sweep alone, in this process, with the seed and drawn parameters it has in the sweep.

    Unit ``i``'s draws and its run seed depend only on ``(sweep seed, i)`` (:mod:`.population`), so one run
    needs neither the other units nor a cluster.

    Parameters
    ----------
    path : path
        The sweep YAML.
    run_id : str
        The run's key (column ``key`` of ``runs.parquet`` and of its part in ``runs/``, the name of
        ``failed/<key>.json``) or ``UNIT:SCENARIO`` (unit index and scenario label, e.g. ``3:stationary``).
    out : path, optional
        A sweep folder: the row is compared with the stored row of the same key, column by column, exactly.
    task_fn : callable(spec) -> row

    Returns
    -------
    dict
        ``task``, ``row``, ``wall_s``, ``stored`` (the part's path, or None), ``differs`` (the columns whose
        values differ from the stored part's, :data:`VOLATILE_COLUMNS` aside; None without a stored part).
    """
    task = find_task(path, run_id)
    t0 = time.perf_counter()
    row = task_fn(task.spec(package_version()))
    wall = time.perf_counter() - t0
    stored = differs = None
    if out is not None:
        found = SweepStore(out).stored_row(task.key)
        if found is not None:
            part, old = found
            stored = str(part)
            differs = sorted(c for c in set(old) | set(row) if c not in VOLATILE_COLUMNS
                             and (c not in old or c not in row or not _same_value(old[c], row[c])))
    return {"task": task, "row": row, "wall_s": wall, "stored": stored, "differs": differs}


def _plots(table, labels, store, name, tests) -> list:
    from sins_sim.plots import sweep as ps

    filters = metric_filters(table)
    files = []
    head = {m: METRICS[m] for m in HEADLINE_METRICS}
    tmp = store.root / ".distributions.tmp-.png"
    if ps.plot_distributions(table, head, filters, labels, tmp, f"{name}: distribution over {table['unit'].nunique()} units",
                             p95_min_n=quantile_n_required(0.95)):
        os.replace(tmp, store.root / "distributions.png")
        files.append("distributions.png")
    for j, label in enumerate(labels):
        sub = table[table["scenario"] == label]
        params = parameter_names(sub)
        if len(sub) < 3 or not params:
            continue
        for metric in SENSITIVITY_METRICS:
            # the summary's tests (one family, corrected): a panel names a driver only where it is significant
            found = {(PARAM_PREFIX + t["parameter"], t["filter"]): t for t in tests
                     if t["scenario"] == label and t["metric"] == metric}
            # significant drivers first (smallest adjusted p), then the others by their largest |rho|
            rank = {p: min(((not t["significant"], t["p_adjusted"] if t["significant"] else 1.0, -abs(t["spearman"]))
                            for (pc, _), t in found.items() if pc == PARAM_PREFIX + p), default=(True, 1.0, 0.0))
                    for p in params}
            top = sorted(params, key=lambda p: rank[p])[:MAX_SENSITIVITY_PANELS]
            fname = f"sensitivity_{j}_{metric}.png"
            tmp = store.root / f".{fname}.tmp-.png"
            n_tests = len(tests)
            if ps.plot_sensitivity(sub, metric, METRICS[metric], {PARAM_PREFIX + p: parameter_label(p) for p in top},
                                   filters, tmp, f"{label}: {metric} against the drawn parameters\n"
                                                 f"(rho: Spearman; p: adjusted over all {n_tests} driver tests "
                                                 f"of the sweep, Westfall-Young maxT; n.s.: not significant "
                                                 f"at {DRIVER_ALPHA:g})", found):
                os.replace(tmp, store.root / fname)
                files.append(fname)
    return files
