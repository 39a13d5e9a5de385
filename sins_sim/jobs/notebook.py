"""The notebook's commands: :func:`run` a scenario in memory, :func:`load` a result folder, :func:`sweep_run`
one run of a sweep with its time series.

Both return the result objects of :mod:`sins_sim.results` (the rooms below the commands): :func:`run` a
:class:`~sins_sim.results.mission.MissionResult` that keeps a :class:`RunOrigin`, the part of this command
that knows the run's inputs and writes its folder (``MissionResult.save`` and ``MissionResult.configuration``
hand off to it, so the result objects never import a command).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from sins_sim.config.errors import ConfigError
from sins_sim.results import BudgetResult, DiagnosisResult, MissionResult, StoredRun, SweepResult
from sins_sim.results._folder import read_json

__all__ = ["run", "load", "sweep_run", "RunOrigin"]


class RunOrigin:
    """Where an in-memory run came from: its source, overrides and manifest (module docstring).

    Parameters
    ----------
    source : path or mapping
        The scenario file, or the scenario as a mapping.
    overrides : dict
        ``seed``, ``duration_s``, ``imu`` as given to :func:`run`.
    manifest : Manifest
        The run's manifest, its clock stopped when the run ended.
    """

    def __init__(self, source, overrides: dict, manifest):
        self.source = source
        self.overrides = dict(overrides)
        self.manifest = manifest

    def configuration(self, base_dir=None) -> dict:
        """The scenario and the IMU as run, every default written out
        (:func:`sins_sim.jobs.manifest.resolve_run_inputs`)."""
        from sins_sim.jobs.manifest import resolve_run_inputs

        r = resolve_run_inputs(self.source, self.overrides, base_dir)
        return {"scenario": r["scenario"], "imu": r["imu"]}

    def save(self, folder, force: bool, mission) -> dict:
        """Write ``mission``'s folder with the writer of ``sins-sim run``; return the manifest written."""
        from sins_sim.jobs.manifest import record_run, result_dir
        from sins_sim.jobs.run import write_run

        with result_dir(folder, self.manifest, "save", force=force) as tmp:
            record_run(self.manifest, mission.scenario, self.source, self.overrides, tmp)
            write_run(tmp, mission.scenario, mission.result, mission.metrics, self.manifest)
        return self.manifest.doc


def run(scenario, *, seed: int | None = None, duration_s: float | None = None, imu=None, threads: int | None = None,
        progress=None) -> MissionResult:
    """Run a scenario in memory and return its :class:`MissionResult` (nothing is written).

    Parameters
    ----------
    scenario : path, mapping or Scenario
        A scenario file; the same content as a dict (validated exactly like a file, errors naming
        ``scenario (dict)`` and the key; relative paths taken from the working directory); or a
        :class:`~sins_sim.config.scenario.Scenario` from :func:`~sins_sim.config.scenario.load_scenario`.
    seed, duration_s : optional
        Replace the scenario's (like ``--seed`` and ``--duration``).
    imu : path or mapping, optional
        Replaces the scenario's IMU (like ``--imu``).
    threads : int, optional
        Threads for the three axes (default: the cores available, at most 3).
    progress : bool or callable(fraction), optional
        ``True``: a progress bar; ``False`` or ``None`` (default): none; a callable: called with the fraction
        done (0 to 1) as the run goes.

    Returns
    -------
    MissionResult

    Raises
    ------
    ConfigError
        One line naming the file (or ``scenario (dict)``), the key and the rule.
    """
    from collections.abc import Mapping

    from sins_sim.config.scenario import Scenario

    overrides = {k: v for k, v in (("seed", seed), ("duration_s", duration_s), ("imu", imu)) if v is not None}
    if isinstance(scenario, Scenario):
        if scenario.document is None:
            raise ConfigError("run: this Scenario keeps no document to run again; give its file or dict")
        source, base = scenario.document, scenario.base_dir
    elif isinstance(scenario, Mapping):
        import copy

        source, base = copy.deepcopy(dict(scenario)), None
    elif isinstance(scenario, (str, Path)):
        source, base = Path(scenario), None
    else:
        raise ConfigError(f"run: scenario must be a path, a mapping or a Scenario, got {type(scenario).__name__}")
    return _run(source, base, overrides, threads, progress, "sins_sim.run")


class _Bar:
    """The default progress of :func:`run` (``progress=True``): a tqdm bar in percent (``tqdm.auto``: a widget in a
    notebook, text on stderr elsewhere), opened at the first report."""

    def __init__(self, label: str):
        self.label = label
        self.bar = None

    def __call__(self, fraction: float) -> None:
        if self.bar is None:
            from tqdm.auto import tqdm

            self.bar = tqdm(total=100.0, desc=self.label, unit="%", bar_format="{desc}: {percentage:3.0f}%|{bar}| "
                                                                               "[{elapsed}<{remaining}]")
        done = 100.0 * min(max(float(fraction), 0.0), 1.0)
        if done > self.bar.n:
            self.bar.update(done - self.bar.n)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def _progress_for(progress, api: str):
    """``progress`` as the jobs take it (a callable or None) and a function that closes what was opened.

    ``None`` or ``False``: no progress; ``True``: the default bar (:class:`_Bar`); a callable: called with the
    fraction done. Anything else is refused naming the argument before the run starts.
    """
    if progress is None or progress is False:
        return None, lambda: None
    if progress is True:
        bar = _Bar(api)
        return bar, bar.close
    if callable(progress):
        return progress, lambda: None
    raise ConfigError(f"{api}: progress: must be True (a progress bar), False or None (none) or a callable taking "
                      f"the fraction done, got {type(progress).__name__} {progress!r}")


def _run(source, base, overrides: dict, threads, progress, api: str) -> MissionResult:
    """:func:`run` of a validated source (a path or a mapping whose relative paths are taken from ``base``)."""
    from sins_sim.jobs.manifest import Manifest
    from sins_sim.jobs.run import compute_run, prepare_run

    progress, close = _progress_for(progress, api)  # checked before anything runs
    try:
        manifest = Manifest("run", settings={"overrides": dict(overrides), "api": api})
        sc, config_warnings = prepare_run(source, overrides or None, progress, base_dir=base)
        res, metrics = compute_run(sc, config_warnings, progress, threads)
        manifest.stop_clock()
    finally:
        close()
    return MissionResult(sc, metrics, res, origin=RunOrigin(source, overrides, manifest))


def sweep_run(sweep, run_id: str, *, threads: int | None = None, progress=None) -> MissionResult:
    """One run of a sweep as a :class:`MissionResult`, with the time series the sweep does not keep.

    A sweep keeps one row of scalar metrics per run (:class:`~sins_sim.results.SweepResult`); the time
    series of a run (for an envelope over time of chosen runs, or a look at an outlier) come from running
    it again: the same scenario document, drawn parameters and seed as in the sweep (unit ``i``'s draws
    depend only on the sweep's seed and ``i``), so its metrics are the row's (``tests/test_results.py``).

    Parameters
    ----------
    sweep : path
        The sweep YAML.
    run_id : str
        The run's key (column ``key`` of ``runs.parquet``) or ``UNIT:SCENARIO`` (``3:stationary``).
    threads : int, optional
        Threads for the three axes (the result does not depend on it).
    progress : bool or callable(fraction), optional
        As for :func:`run`.

    Returns
    -------
    MissionResult

    Raises
    ------
    ConfigError
        No such run in the sweep, or a sweep file that does not validate.
    """
    from sins_sim.jobs.sweep.job import find_task
    from sins_sim.jobs.sweep.tasks import package_version

    spec = find_task(sweep, run_id, flag="sweep_run").spec(package_version())
    return _run(spec["doc"], Path(spec["base_dir"]), {}, threads, progress, "sins_sim.jobs.notebook.sweep_run")


def load(folder):
    """A result folder as its object: a :class:`MissionResult` from a ``sins-sim run`` folder (or one
    :meth:`MissionResult.save` wrote); a :class:`BudgetResult` from a ``sins-sim budget`` folder and a
    :class:`SweepResult` from a ``sins-sim sweep`` folder (by the command in its ``manifest.json``); a
    :class:`~sins_sim.results.DiagnosisResult` from the JSON file of ``sins-sim diagnose --json`` (the JSON
    only: its ``to_pandas``, not its figures, which need the recording: diagnose it again).

    Restored: :attr:`~MissionResult.metrics` (``metrics.json``), the stored series (``timeseries.npz``),
    hence :meth:`~MissionResult.to_pandas`, :meth:`~MissionResult.to_xarray` and every figure but
    ``allan``; the manifest; the scenario, validated again from ``inputs/scenario.yaml``. Not restored:
    the engine's full-rate statistics, the sensor-level error records and the Allan curves (only their
    readings are in ``metrics.json``); :attr:`~MissionResult.result` is a :class:`StoredRun`.

    Raises
    ------
    ConfigError
        The folder is not a readable run result.
    """
    import warnings

    from sins_sim.jobs.manifest import INPUTS, read_manifest
    from sins_sim.config.scenario import load_scenario

    folder = Path(folder)
    if folder.is_file():  # a diagnosis is one JSON file, not a folder
        js = read_json(folder, "diagnosis")
        if not isinstance(js, dict) or "verdict" not in js:
            raise ConfigError(f"load: {folder} is not the JSON of 'sins-sim diagnose --json' (no 'verdict'); a run, "
                              "budget or sweep result is a folder")
        return DiagnosisResult(js)
    doc = read_manifest(folder, "load")
    if doc.get("command") == "budget":
        return BudgetResult.from_folder(folder)
    if doc.get("command") == "sweep":
        return SweepResult.from_folder(folder)
    if doc.get("command") != "run":
        raise ConfigError(f"load: {folder} holds a 'sins-sim {doc.get('command')}' result, not a run, budget "
                          "or sweep")
    try:
        metrics = json.loads((folder / "metrics.json").read_text())
    except (OSError, ValueError) as exc:
        raise ConfigError(f"load: {folder / 'metrics.json'} cannot be read ({type(exc).__name__})") from None
    arrays = {}
    if (folder / "timeseries.npz").is_file():
        with np.load(folder / "timeseries.npz") as z:
            arrays = {k: z[k] for k in z.files}
    scenario = None
    if (folder / INPUTS / "scenario.yaml").is_file():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # told when the run was made; kept in metrics['warnings']
            try:
                scenario = load_scenario(folder / INPUTS / "scenario.yaml")
            except ConfigError:
                scenario = None
    out = MissionResult(scenario, metrics, StoredRun(arrays, metrics), folder=folder)
    out.manifest = doc
    return out
