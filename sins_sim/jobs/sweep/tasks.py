"""The sweep's tasks: one per (unit, scenario), each a self-contained scenario document and its key.

:func:`build_tasks` (on the client) reads every scenario and IMU file once, applies each unit's draws
(:mod:`.population`), validates every unit's IMU before anything runs, and keys each run by a hash of
what determines its result. :func:`run_task` (on a worker) runs one task through the INS loop with one
thread and returns one flat row of metrics per filter, and nothing else (no plots, no files).

The key is the first 20 hex digits of the SHA-256 of the canonical JSON of the run's scenario
document with the unit's IMU inlined (its drawn parameters, the filter-parameter mode, the run seed
and the duration are all in it), the SHA-256 of a trajectory file it names (its content, not its
path), the package version, and the unit's index and scenario label (so that two units that happen
to be identical still get a row each). Equal keys mean equal results; a resumed sweep skips every key
already stored.
"""

from __future__ import annotations

import copy
import hashlib
import json
import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path

from sins_sim.config.errors import ConfigError
from sins_sim.results.sweep import HEADLINE_METRICS, METRICS  # the table's columns, defined with its object

__all__ = ["package_version", "Task", "build_tasks", "estimated_run_s", "TASK_FIXED_S", "run_task", "run_key", "flatten_metrics", "METRICS",
           "HEADLINE_METRICS", "ID_COLUMNS", "PARAM_PREFIX", "BLOCK_MODE_PREFIX"]

#: Columns that name a run (before the drawn parameters and the metrics).
ID_COLUMNS = ("key", "scenario", "scenario_index", "unit", "seed")
#: Prefix of the drawn-parameter columns (``param.f0_ppm.x``).
PARAM_PREFIX = "param."
#: Columns of a unit with a block: its isolator modes, ascending (``block.isolator_mode_hz.1`` .. ``.6``, Hz; the
#: gyros' inertia included, :meth:`sins_sim.models.block.BlockParams.isolator_modes`).
BLOCK_MODE_PREFIX = "block.isolator_mode_hz."
_NED = ("north", "east", "down")


#: A run's cost on a warm worker besides the simulation (s): reading the scenario, designing the filters, the
#: metrics. Measured on the 2-core development machine on 2026-11-27 (loaded by other jobs): a 0.3 s run at rest of
#: the default IMU took 42-45 ms warm, of which about 12 ms the simulation (:mod:`sins_sim.jobs.estimate`).
TASK_FIXED_S = 0.035


def estimated_run_s(est: dict) -> float:
    """A sweep run's wall time on a warm worker (s): the engine's part of :func:`sins_sim.jobs.estimate.
    estimate_run` (its ``wall_s`` without the command's start-up, plots and report, ``fixed_s``) plus
    :data:`TASK_FIXED_S`."""
    return max(float(est["wall_s"]) - float(est["breakdown"]["fixed_s"]), 0.0) + TASK_FIXED_S


def package_version() -> str:
    """sins-sim's version (part of every run's key: a new version recomputes every run)."""
    from sins_sim._version import __version__

    return __version__


@dataclass
class Task:
    """One (unit, scenario) run."""

    key: str
    unit: int
    scenario: str
    scenario_index: int
    seed: int
    params: dict
    doc: dict = field(repr=False)
    ctx: str = ""
    base_dir: str = ""
    #: estimated wall time of the run on a warm worker (s): :func:`estimated_run_s`
    est_s: float = 0.0

    def spec(self, version: str) -> dict:
        """What a worker needs (plain data: pickles to any worker of the same sins-sim version)."""
        return {"key": self.key, "unit": self.unit, "scenario": self.scenario,
                "scenario_index": self.scenario_index, "seed": self.seed, "params": self.params,
                "doc": self.doc, "ctx": self.ctx, "base_dir": self.base_dir, "version": version}


def _sha256_file(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def run_key(doc: dict, files: dict, version: str, ident: dict | None = None) -> str:
    """The run's key: SHA-256 of (scenario document with the unit inlined, file contents, version, ``ident``),
    the first 20 hex digits. ``ident`` (unit index, scenario label) keeps two identical runs apart."""
    text = json.dumps({"doc": doc, "files": files, "version": version, "ident": ident or {}}, sort_keys=True,
                      separators=(",", ":"), allow_nan=False, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:20]


def _scenario_base(entry: dict) -> dict:
    """Read one scenario of the sweep (and its IMU file), validate it once; what every unit's run starts from."""
    from sins_sim.jobs.estimate import check_run
    from sins_sim.config.imu import load_yaml
    from sins_sim.config.scenario import Scenario

    path = entry["path"]
    doc = dict(load_yaml(path))
    if entry["duration_s"] is not None:
        doc["duration_s"] = entry["duration_s"]
    doc["outputs"] = {"plots": False, "timeseries": False}
    scenario = Scenario(doc, str(path), path.parent)  # the scenario as the sweep runs it, before any draw
    est = check_run(scenario)  # refuse a run that cannot finish (48 h, 8 GiB), before any task starts
    imu = doc.get("imu")
    if isinstance(imu, str):
        imu_path = (path.parent / imu).resolve()
        imu_doc, imu_ctx = load_yaml(imu_path), str(imu_path)
    else:
        imu_doc, imu_ctx = imu, f"{path} (imu)"
    files = {}
    traj = doc.get("trajectory")
    if isinstance(traj, dict) and traj.get("file"):
        tpath = (path.parent / traj["file"]).resolve()
        doc["trajectory"] = {**traj, "file": str(tpath)}
        files["trajectory.file"] = _sha256_file(tpath)
    label = entry["label"] or scenario.name
    return {"doc": doc, "imu_doc": imu_doc, "imu_ctx": imu_ctx, "files": files, "label": label,
            "scenario": scenario, "path": path, "est_s": estimated_run_s(est)}


#: Population keys that act only together (f0 moves by coefficient x temperature offset).
_TOGETHER = ("temperature_k", "temperature_coefficient_ppm_per_k")


def _check_sensor_draw(sweep, j: int, base: dict, preset) -> None:
    """``population.sensors.draw: true`` must draw something in scenario ``j``: its sensors block (the preset's,
    else the scenario's IMU file's) needs a non-zero 1-sigma key (:data:`~.population.SENSOR_SIGMA_KEYS`)."""
    from sins_sim.jobs.sweep.population import SENSOR_SIGMA_KEYS, sigma_values

    block = preset if preset is not None else base["imu_doc"].get("sensors")
    where = f"the preset {sweep.sensor_preset}" if preset is not None else f"the IMU file {base['imu_ctx']}"
    for section, keys in SENSOR_SIGMA_KEYS.items():
        sec = block.get(section) if isinstance(block, dict) else None
        for key in keys if isinstance(sec, dict) else ():
            try:
                if any(sigma_values(sec, key)):
                    return
            except (TypeError, ValueError, IndexError):
                return  # not a number: the IMU schema names it when the unit is checked
    names = ", ".join(f"{section}.{key}" for section, keys in SENSOR_SIGMA_KEYS.items() for key in keys)
    what = "has no sensors: block" if not block else f"has no non-zero 1-sigma value ({names})"
    raise ConfigError(f"{sweep.ctx}: population.sensors.draw: true would draw nothing for scenarios[{j}] "
                      f"({base['label']}): {where} {what}; name a population.sensors.preset with those values or "
                      f"remove draw")


def _population_error(sweep, base: dict, unit: dict, i: int, preset, rule: str) -> ConfigError:
    """The error of a drawn unit the IMU schema refuses, naming the sweep key the user wrote.

    The culprit is found by elimination: the sweep's IMU without any draw (then ``population.sensors.preset``
    or ``filter_parameters`` is at fault), else the first population key whose draws alone are refused; of that
    key the grid value (``values``), the centre (``mean``: refused already at the mean) or the spread
    (``width``). ``rule`` is the IMU schema's message (key inside the IMU and its rule)."""
    from sins_sim.config.imu import imu_from_dict
    from sins_sim.jobs.sweep.population import apply_unit

    imu_ctx = base["imu_ctx"]

    def refused(draws: dict, fp=sweep.filter_parameters, sensors=preset, draw_sensors=False) -> bool:
        try:
            imu_from_dict(apply_unit(base["imu_doc"], draws, fp, sensors, draw_sensors), imu_ctx)
        except ConfigError:
            return True
        return False

    tail = f"gives unit {i} an IMU the IMU schema refuses: {imu_ctx}: {rule}"
    if preset is not None and refused({}, fp="true"):
        return ConfigError(f"{sweep.ctx}: population.sensors.preset: {sweep.sensor_preset} {tail}")
    if refused({}):
        return ConfigError(f"{sweep.ctx}: filter_parameters: {sweep.filter_parameters!r} {tail}")
    for key, spec in sweep.spreads.items():
        own = {c: v for c, v in unit.items() if c == key or c.startswith(key + ".")}
        group = (key,)
        if key in _TOGETHER:  # they act only together: f0 (1 + tc 1e-6 dT)
            group = _TOGETHER
        cols = {c: v for c, v in unit.items() if any(c == g or c.startswith(g + ".") for g in group)}
        if not refused(cols):
            continue
        if spec["distribution"] == "grid":
            return ConfigError(f"{sweep.ctx}: population.{key}.values: {next(iter(own.values())):g} {tail}")
        if refused({**cols, **dict.fromkeys(own, float(spec["mean"]))}):
            return ConfigError(f"{sweep.ctx}: population.{key}.mean: {spec['mean']:g} {tail}")
        drawn = ", ".join(f"{c} {v:+.4g}" for c, v in own.items())
        return ConfigError(f"{sweep.ctx}: population.{key}.width: {spec['width']:g} draws {drawn} for unit {i}, "
                           f"which the IMU schema refuses: {imu_ctx}: {rule}")
    if sweep.sensors["draw"] and refused({c: v for c, v in unit.items() if c.startswith(("gyro.", "accelerometer."))},
                                         draw_sensors=True):
        return ConfigError(f"{sweep.ctx}: population.sensors.draw: the sensor-error draw {tail}")
    keys = ", ".join(sweep.spreads) or "sensors"  # no key alone is refused: their combination is
    return ConfigError(f"{sweep.ctx}: population: {keys} together {tail}")


def build_tasks(sweep, units=None) -> tuple[list, list]:
    """Every (unit, scenario) task of ``sweep``, validated; and the scenario labels in order.

    Parameters
    ----------
    sweep : Sweep
    units : iterable of int, optional
        The unit indices (default: all ``range(sweep.units)``).

    Raises
    ------
    ConfigError
        One line naming the file, the unit and the key when a scenario or a unit's drawn IMU breaks a rule.
    """
    from sins_sim.config.imu import IMU_SCHEMA, imu_from_dict, load_yaml
    from sins_sim.jobs.sweep.population import apply_unit, draw_unit, table_parameters

    if sweep.filter_parameters not in ("true", True) and "filter_parameters" not in IMU_SCHEMA.fields:
        raise ConfigError(f"{sweep.ctx}: filter_parameters: {sweep.filter_parameters!r} needs the IMU key "
                          "filter_parameters, which this version of sins-sim does not have (use true)")
    bases = [_scenario_base(entry) for entry in sweep.scenarios]
    labels = [b["label"] for b in bases]
    for j, label in enumerate(labels):
        if label in labels[:j]:
            raise ConfigError(f"{sweep.ctx}: scenarios[{j}].label: {label!r} is already the name of "
                              f"scenarios[{labels.index(label)}]: give each a unique label")
    preset = None
    if sweep.sensor_preset is not None:
        preset = load_yaml(sweep.sensor_preset).get("sensors")
        if not preset:
            raise ConfigError(f"{sweep.ctx}: population.sensors.preset: {sweep.sensor_preset} has no sensors: block")
    if sweep.sensors["draw"]:
        for j, base in enumerate(bases):
            _check_sensor_draw(sweep, j, base, preset)
    block_keys = [k for k in sweep.spreads if k.startswith("block.")]
    for j, base in enumerate(bases):  # a block spread on an IMU without a block would draw nothing
        if block_keys and not isinstance((base["imu_doc"] or {}).get("block"), dict):
            raise ConfigError(f"{sweep.ctx}: population.{block_keys[0]}: scenarios[{j}] ({base['label']}) runs "
                              f"{base['imu_ctx']}, which has no block: section, so the block spreads draw nothing "
                              f"there: give that scenario an IMU with a block or remove population.block")
    tasks = []
    checked: dict = {}
    for i in (range(sweep.units) if units is None else units):
        unit = draw_unit(sweep, i)
        for j, base in enumerate(bases):
            imu_doc = apply_unit(base["imu_doc"], unit, sweep.filter_parameters, preset, sweep.sensors["draw"])
            ident = (base["imu_ctx"], json.dumps(imu_doc, sort_keys=True, default=str))
            if ident not in checked:  # scenarios naming the same IMU file share the unit's check
                ctx = f"{sweep.ctx}: unit {i}: {base['imu_ctx']}"
                try:
                    imu_from_dict(imu_doc, ctx)
                except ConfigError as exc:
                    raise _population_error(sweep, base, unit, i, preset, str(exc).removeprefix(ctx + ": ")) \
                        from None
                checked[ident] = True
            doc = copy.deepcopy(base["doc"])
            doc["imu"] = imu_doc
            if "run_seed" in unit:
                doc["seed"] = unit["run_seed"]
            seed = int(doc.get("seed", base["scenario"].seed))
            doc["seed"] = seed
            keyed = doc
            if base["files"]:  # a trajectory file enters the key by its content, not by where it lies
                keyed = {**doc, "trajectory": {**doc["trajectory"], "file": "(content)"}}
            key = run_key(keyed, base["files"], package_version(), {"unit": i, "scenario": base["label"]})
            # every column in the unit its name carries: the sensor errors and the block's quantities as the values
            # the run used (not their scores or percent draws)
            params = table_parameters(imu_doc, unit)
            tasks.append(Task(key=key, unit=i, scenario=base["label"],
                              scenario_index=j, seed=seed, params=params,
                              doc=doc, ctx=f"{base['path']} (unit {i})", base_dir=str(base["path"].parent),
                              est_s=base["est_s"]))
    return tasks, labels


def _num(x) -> float:
    return float(x) if x is not None and math.isfinite(float(x)) else math.nan


def flatten_metrics(filters: dict, gyro_rms: dict) -> dict:
    """``<filter>.<metric>`` columns from ``scenario_metrics``' per-filter dict (missing values: NaN)."""
    row = {}
    for name, m in filters.items():
        row[f"{name}.status"] = m["status"]
        vals = dict.fromkeys(METRICS, math.nan)
        if "horizontal_position_error_m" in m:
            h, v = m["horizontal_position_error_m"], m["velocity_error_m_s"]
            rms, fin = m["attitude_error_arcsec"]["rms"], m["attitude_error_arcsec"]["final"]
            vals.update({
                "horizontal_position_error_m_final": _num(h["final"]), "horizontal_position_error_m_max": _num(h["max"]),
                "vertical_position_error_m_final": _num(m["vertical_position_error_m"]["final"]),
                "velocity_error_m_s_final": _num(v["final"]), "velocity_error_m_s_max": _num(v["max"]),
                **{f"attitude_error_arcsec_rms_{a}": _num(rms[a]) for a in _NED},
                "attitude_error_arcsec_rms_total": math.sqrt(sum(_num(rms[a]) ** 2 for a in _NED)),
                **{f"attitude_error_arcsec_final_{a}": _num(fin[a]) for a in _NED},
                "cep_rate_nmi_h": _num(m.get("cep_rate_nmi_h")),
            })
            for key, axes in (("attitude_drift_deg_h", _NED), ("gyro_drift_deg_h", ("x", "y", "z"))):
                dr = m.get(key)
                if dr:
                    vals.update({f"{key}_{a}": _num(dr[a]["value"]) for a in axes})
            exc = m.get("excess_over_ideal")
            if exc:
                vals["excess_over_ideal_horizontal_m"] = _num(exc["horizontal_position_error_final_m"])
            steps = [abs(s) for ev in m.get("events") or [] for s in ev.get("step_arcsec", [])]
            if steps:
                vals["event_step_arcsec_max"] = _num(max(steps))
        for a, x in zip(("x", "y", "z"), gyro_rms.get(name, [math.nan] * 3)):
            vals[f"gyro_error_rms_arcsec_{a}"] = _num(x)
        row.update({f"{name}.{k}": val for k, val in vals.items()})
    return row


def run_task(spec: dict) -> dict:
    """Run one task on a worker: the scenario through the INS loop, one thread; one flat row.

    The row holds :data:`ID_COLUMNS`, the drawn parameters (``param.*``), ``<filter>.<metric>`` for every
    filter and :data:`METRICS` entry, ``<filter>.status``, with a block its isolator modes
    (:data:`BLOCK_MODE_PREFIX`), and ``wall_s``, ``worker`` and ``warnings``
    (the run's warnings, one per line). Raises what the run raises (the client records it).
    """
    import os
    import socket
    import time

    import numpy as np

    from sins_sim.jobs.messages import format_warning_lines
    from sins_sim.jobs.run import scenario_metrics
    from sins_sim.config.scenario import Scenario
    from sins_sim.plan import run_plan
    from sins_sim.units import ARCSEC

    if spec["version"] != package_version():
        raise RuntimeError(f"worker {socket.gethostname()} runs sins-sim {package_version()}, the sweep was built "
                           f"with {spec['version']}: install the same version on every worker")
    t0 = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sc = Scenario(spec["doc"], spec["ctx"], Path(spec["base_dir"]))
        res = run_plan(sc.plan, threads=1)  # the unit's scenario as resolved (its drawn unit in the document)
        filters = scenario_metrics(res, sc)
    gyro_rms = {name: np.sqrt(np.mean((e - e.mean(axis=0)) ** 2, axis=0)) / ARCSEC
                for name, e in res.spectra.items() if name != "t" and e.shape[0]}
    row = {"key": spec["key"], "scenario": spec["scenario"], "scenario_index": spec["scenario_index"],
           "unit": spec["unit"], "seed": spec["seed"]}
    row.update({PARAM_PREFIX + k: float(v) for k, v in spec["params"].items()})
    row.update(flatten_metrics(filters, gyro_rms))
    if res.block is not None:  # the unit's own mount: its modes move with the drawn masses and stiffnesses
        row.update({f"{BLOCK_MODE_PREFIX}{k + 1}": float(f) for k, f in enumerate(res.block["isolator_modes_hz"])})
    lines = format_warning_lines([*res.warnings, *caught], prefix="")
    row.update({"wall_s": time.perf_counter() - t0, "worker": f"{socket.gethostname()}:{os.getpid()}",
                "warnings": "\n".join(lines)})
    return row
