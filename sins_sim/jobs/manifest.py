"""Provenance: every result folder says what made it, and a ``run`` can be made again from it.

Every command that writes a result folder writes ``manifest.json`` into it (:class:`Manifest`,
through :func:`result_dir`)::

    schema            "sins-sim-manifest/1" (MANIFEST_SCHEMA)
    sins_sim_version  the package's version; versions: python, numpy, scipy, numba, ...; git_commit
                      (and git_dirty) when the package runs from a git checkout, else null
    command, argv, command_line, cwd
    started_utc, finished_utc, wall_s, cpu_s (this process), cpu_children_s (worker processes)
    settings          the command's parsed flags
    inputs            role -> {path, sha256[, copy, copy_sha256]}: every file the job read
    outputs           file -> sha256 of everything else in the folder

and, for ``sins-sim run`` (:func:`record_run`):

    run.scenario      the scenario as run: the file with the command line's overrides applied and every
                      default written out, in the file's own keys and units (sins_sim.config.schema.fill_defaults)
    run.imu           the IMU the same way, with the scenario's filter_parameters merged in
    run.overrides     what the command line replaced (seed, duration_s, imu, filter_parameters)
    run.seed          the seed every random stream of the run derives from
    run.filter_parameters
                      where the filters' parameters came from, and filter -> axis -> the values each filter
                      actually used (sins_sim.plan.imu.filters_used): f0_hz, k1 .. k5 in SI,
                      the unit's f0 and the filter's f0 error in ppm, source, f0 source, mismatch, tracking

``run.scenario`` and ``run.imu`` are also written as ``inputs/scenario.yaml`` and ``inputs/imu.yaml``,
with a copy of the trajectory file and of a diagnosis file when the run used one, so that
``sins-sim run --rerun DIR`` (:func:`rerun_scenario`) depends on nothing outside the folder: it checks
each copy against its hash in the manifest and runs ``inputs/scenario.yaml``. The run is
deterministic in its seed, so the rerun's ``metrics.json`` equals the original byte for byte
(timings live in the manifest, never in ``metrics.json``).
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import shutil
import subprocess
import time
import warnings
from contextlib import contextmanager
from datetime import datetime, timezone
from pathlib import Path

from sins_sim.config.errors import ConfigError

__all__ = ["MANIFEST", "MANIFEST_SCHEMA", "INPUTS", "Manifest", "result_dir", "sha256_file", "environment",
           "read_manifest", "describe_folder", "record_run", "record_scenario", "rerun_scenario", "resolve_run_inputs"]

#: The manifest's file name in every result folder.
MANIFEST = "manifest.json"
#: Format of the manifest; a rerun refuses another one.
MANIFEST_SCHEMA = "sins-sim-manifest/1"
#: Folder of the input copies inside a ``run`` folder.
INPUTS = "inputs"
#: Distributions whose versions the manifest records (those installed; read from their metadata, not imported).
_PACKAGES = ("numpy", "scipy", "numba", "llvmlite", "matplotlib", "pandas", "dask", "distributed", "allantools",
             "pyarrow", "PyYAML")


def sha256_file(path) -> str:
    """The SHA-256 of a file's bytes (hex)."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _git(*args) -> str | None:
    """git's answer in the checkout holding this package (None: no git, or the package is not in a checkout)."""
    package = Path(__file__).resolve().parents[1]

    def ask(*a):
        try:
            done = subprocess.run(["git", "-C", str(package), *a], capture_output=True, text=True, timeout=5)
        except (OSError, subprocess.SubprocessError):
            return None
        return done.stdout.strip() if done.returncode == 0 else None

    top = ask("rev-parse", "--show-toplevel")
    if not top or not (Path(top) / package.name).resolve() == package:  # e.g. a venv inside another repository
        return None
    return ask(*args)


def environment() -> dict:
    """sins-sim's version, Python's and the numerical packages', the platform, and the git commit if any."""
    from importlib import metadata

    from sins_sim._version import __version__

    versions = {"python": platform.python_version()}
    for name in _PACKAGES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            continue
    commit = _git("rev-parse", "HEAD")
    dirty = None
    if commit:
        status = _git("status", "--porcelain", "--untracked-files=no")
        dirty = bool(status) if status is not None else None
    return {"sins_sim_version": __version__, "versions": versions, "platform": platform.platform(),
            "git_commit": commit, "git_dirty": dirty}


def _utc_now() -> str:
    return datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")


def _jsonable(x):
    if isinstance(x, Path):
        return str(x)
    if isinstance(x, (set, tuple)):
        return list(x)
    if hasattr(x, "item"):  # numpy scalars
        return x.item()
    return str(x)


class Manifest:
    """A result folder's ``manifest.json`` being collected while the job runs (module docstring).

    Parameters
    ----------
    command : str
        The sins-sim command (``run``, ``budget``, ...).
    argv : sequence of str, optional
        The command line after ``sins-sim`` (None: called from Python).
    settings : dict, optional
        The command's parsed flags.
    """

    def __init__(self, command: str, argv=None, settings: dict | None = None):
        import shlex

        self.doc = {"schema": MANIFEST_SCHEMA, **environment(), "command": command,
                    "argv": None if argv is None else [str(a) for a in argv],
                    "command_line": None if argv is None else shlex.join(["sins-sim", *map(str, argv)]),
                    "cwd": os.getcwd(), "started_utc": _utc_now(), "settings": settings or {}, "inputs": {}}
        self._t0 = time.perf_counter()
        self._times0 = os.times()
        self.written_to: set = set()
        self.clock_stopped = False

    def add_input(self, role: str, path, **extra) -> None:
        """Record a file the job read: its absolute path and SHA-256 (plus ``extra`` keys)."""
        p = Path(path)
        self.doc["inputs"][role] = {"path": str(p.resolve()), "sha256": sha256_file(p), **extra}

    def stop_clock(self) -> None:
        """Finish the timings now, for a job computed in memory and written later (a notebook's
        :meth:`~sins_sim.results.MissionResult.save`): its wall time is the run's, not the session's."""
        t = os.times()
        self.doc.update(finished_utc=_utc_now(), wall_s=time.perf_counter() - self._t0,
                        cpu_s=(t.user - self._times0.user) + (t.system - self._times0.system),
                        cpu_children_s=(t.children_user - self._times0.children_user)
                        + (t.children_system - self._times0.children_system))
        self.clock_stopped = True

    def write(self, folder) -> Path:
        """Finish the timings (unless :meth:`stop_clock` did), hash the folder's files and write ``manifest.json``."""
        folder = Path(folder)
        if not self.clock_stopped:
            self.stop_clock()
            self.clock_stopped = False
        outputs = {}
        for p in sorted(folder.rglob("*")):
            rel = p.relative_to(folder).as_posix()
            if p.is_file() and rel != MANIFEST and not p.name.startswith("."):
                outputs[rel] = sha256_file(p)
        self.doc["outputs"] = outputs
        path = folder / MANIFEST
        from sins_sim.jobs.output import atomic_write_text

        atomic_write_text(path, json.dumps(self.doc, indent=2, allow_nan=False, default=_jsonable) + "\n")
        self.written_to.add(folder.resolve())
        return path


@contextmanager
def result_dir(out, manifest: Manifest, flag: str = "--out", inputs=(), force: bool = False):
    """:func:`~sins_sim.jobs.output.atomic_output_dir` that leaves ``manifest.json`` in the folder.

    Yields the temporary folder; when the job succeeds the manifest is written into it (unless the
    job wrote it already) before the folder takes its place. ``inputs`` are recorded by role
    ``input``, ``input2``, ... unless the job recorded them itself.
    """
    from sins_sim.jobs.output import atomic_output_dir

    with atomic_output_dir(out, flag, inputs=inputs, force=force) as tmp:
        yield tmp
        if Path(tmp).resolve() not in manifest.written_to:
            known = {v["path"] for v in manifest.doc["inputs"].values()}
            for i, path in enumerate(p for p in inputs if p is not None):
                if str(Path(path).resolve()) not in known and Path(path).is_file():
                    manifest.add_input("input" if i == 0 else f"input{i + 1}", path)
            manifest.write(tmp)


# --- reading a folder back ------------------------------------------------------------------------------------
def read_manifest(folder, flag: str = "--rerun") -> dict:
    """The manifest of a result folder, checked: one :class:`ConfigError` line when it cannot be used.

    A manifest of another schema is refused; one written by another sins-sim version is accepted with a
    one-line warning (the rerun may then differ).
    """
    from sins_sim._version import __version__

    folder = Path(folder)
    path = folder / MANIFEST
    if not folder.is_dir():
        raise ConfigError(f"{flag}: {folder} is not a folder")
    try:
        doc = json.loads(path.read_text())
    except FileNotFoundError:
        raise ConfigError(f"{flag}: {folder} has no {MANIFEST} (not a sins-sim result, or written by a sins-sim "
                          "older than the manifest)") from None
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise ConfigError(f"{flag}: {path} cannot be read ({type(exc).__name__})") from None
    if not isinstance(doc, dict) or doc.get("schema") != MANIFEST_SCHEMA:
        got = doc.get("schema") if isinstance(doc, dict) else None
        raise ConfigError(f"{flag}: {path}: schema {got!r} is not {MANIFEST_SCHEMA!r}, which this sins-sim "
                          f"{__version__} reads")
    if doc.get("sins_sim_version") != __version__:
        warnings.warn(f"{flag}: {folder} was written by sins-sim {doc.get('sins_sim_version')}, this is "
                      f"{__version__}: the rerun may differ", UserWarning, stacklevel=2)
    return doc


def describe_folder(folder) -> str:
    """What an existing result folder holds, in a few words (for the refusal of an existing ``--out``)."""
    folder = Path(folder)
    try:
        n = sum(1 for p in folder.rglob("*") if p.is_file() and not p.name.startswith("."))
    except OSError:
        n = None
    files = f" ({n} files)" if n is not None else ""
    try:
        doc = json.loads((folder / MANIFEST).read_text())
    except (OSError, UnicodeDecodeError, ValueError):
        doc = None
    if isinstance(doc, dict) and doc.get("command"):
        run = doc.get("run") or {}
        name = (run.get("scenario") or {}).get("name") if isinstance(run, dict) else None
        what = f"a 'sins-sim {doc['command']}' result"
        if name:
            what += f" of scenario '{name}'"
        return f"{what} written {doc.get('started_utc', 'at an unknown time')}{files}"
    try:
        sweep = json.loads((folder / "sweep.json").read_text())
        return f"the sweep '{sweep.get('name')}'{files}"
    except (OSError, UnicodeDecodeError, ValueError, AttributeError):
        pass
    return f"an earlier sins-sim result without a {MANIFEST}{files}"


# --- run: the inputs as run, and the rerun ----------------------------------------------------------------------
def _filter_parameters_doc(value) -> dict:
    """``filter_parameters`` written out: the short forms as a mapping, every default (f0 by source) filled."""
    from sins_sim.config import filter_params as fp
    from sins_sim.config.schema import fill_defaults

    if value is True or value is None:
        value = {"source": "true"}
    elif isinstance(value, str):
        value = {"source": value}
    elif isinstance(value, dict) and value.get("source") is True:
        value = dict(value, source="true")
    out = fill_defaults(dict(value), fp.FILTER_PARAMETERS_SCHEMA)
    out.setdefault("f0", fp._DEFAULT_F0[out["source"]])
    if out["source"] != "online":
        out.pop("online", None)  # the estimator's settings belong to source online only (as the parser keeps them)
    return out


def resolve_run_inputs(path, overrides: dict | None = None, base_dir=None) -> dict:
    """The scenario and IMU as run (every default written out) and the files they name.

    Parameters
    ----------
    path : path or mapping
        The scenario file, or the scenario as a mapping (already validated by
        :func:`sins_sim.config.scenario.load_scenario`).
    overrides : dict, optional
        The command line's replacements.
    base_dir : path, optional
        Where the scenario's relative paths are taken from (default: the file's folder, or the working
        directory for a mapping).

    Returns
    -------
    dict
        ``scenario`` and ``imu`` (documents that load to the same run: ``scenario.imu`` is ``imu.yaml``,
        ``trajectory.file`` and ``filter_parameters.file`` name the copies), ``files`` (role -> the original
        path: scenario, imu, trajectory, diagnosis, gnss, vibration_spec) and ``copies`` (role -> the copy's name in ``inputs/``).
    """
    from sins_sim.config.imu import IMU_SCHEMA, load_yaml
    from sins_sim.config.scenario import SCENARIO_SCHEMA, scenario_document
    from sins_sim.config.schema import fill_defaults

    from collections.abc import Mapping

    if isinstance(path, Mapping):  # no scenario file: inputs/scenario.yaml is the only copy
        base = Path(base_dir) if base_dir is not None else Path.cwd()
        files = {}
    else:
        path = Path(path)
        base = Path(base_dir) if base_dir is not None else path.parent
        files = {"scenario": path}
    doc = dict(scenario_document(path, overrides))
    imu = doc.get("imu")
    if isinstance(imu, str):
        imu_path = (base / imu).resolve()
        files["imu"] = imu_path
        imu_doc, imu_base = dict(load_yaml(imu_path)), imu_path.parent
    else:
        imu_doc, imu_base = dict(imu), base
    if doc.get("filter_parameters") is not None:  # the scenario's replaces the IMU file's
        imu_doc["filter_parameters"] = doc.pop("filter_parameters")
    doc.pop("filter_parameters", None)
    fpar = _filter_parameters_doc(imu_doc.pop("filter_parameters", True))
    copies = {"scenario": "scenario.yaml", "imu": "imu.yaml"}
    if fpar.get("file"):
        diag = Path(fpar["file"])
        files["diagnosis"] = diag if diag.is_absolute() else imu_base / diag
        copies["diagnosis"] = "diagnosis" + (diag.suffix or ".json")
        fpar["file"] = copies["diagnosis"]
    has_sensors = "sensors" in imu_doc  # parsed by its own reader: kept as written (null included)
    sensors = imu_doc.pop("sensors", None)
    imu_doc = fill_defaults(imu_doc, IMU_SCHEMA)
    imu_doc["filter_parameters"] = fpar
    if has_sensors:
        imu_doc["sensors"] = sensors
    doc["imu"] = copies["imu"]
    written_tol = "velocity_tolerance_m_s" in (doc.get("trajectory") or {})
    doc = fill_defaults(doc, SCENARIO_SCHEMA)
    traj = doc.get("trajectory") or {}
    if not written_tol and isinstance(doc.get("trajectory"), dict):
        # refused beside segments and beside a file without velocity columns: only as the user wrote it
        doc["trajectory"].pop("velocity_tolerance_m_s", None)
    if traj.get("file"):
        tpath = (base / traj["file"]).resolve()
        files["trajectory"] = tpath
        copies["trajectory"] = "trajectory" + tpath.suffix
        # a file holds the whole motion and its start: the segment keys and the site are not part of the run
        # (and are refused beside a file), so the defaults filled in for them are left out
        doc["trajectory"] = {k: v for k, v in dict(traj, file=copies["trajectory"]).items()
                             if k not in ("segments", "speed_m_s", "transition_s")}
        doc.pop("site", None)
    aid = doc.get("aiding") or {}
    if aid.get("file"):  # a recorded GNSS solution: copied; the simulated fixes' error keys are refused beside it
        gpath = (base / aid["file"]).resolve()
        files["gnss"] = gpath
        copies["gnss"] = "gnss" + gpath.suffix
        doc["aiding"] = {k: v for k, v in dict(aid, file=copies["gnss"]).items()
                         if k not in ("markov_sigma_m", "markov_tau_s")}
    vib = doc.get("vibration") or {}
    if isinstance(vib.get("spec"), str):  # a specification file: recorded, and written inline (one document)
        spath = (base / vib["spec"]).resolve()
        files["vibration_spec"] = spath
        doc["vibration"] = dict(vib, spec=load_yaml(spath))
    return {"scenario": doc, "imu": imu_doc, "files": files, "copies": copies}


def _dump_yaml(doc, title: str) -> str:
    import yaml

    return f"# {title}\n" + yaml.safe_dump(doc, sort_keys=False, default_flow_style=None, width=120)


def record_scenario(manifest: Manifest, path, overrides: dict | None = None) -> dict:
    """Record a (validated) scenario's files with their hashes and the scenario and IMU as run (no copies).

    For commands that run a scenario in several variants (``budget``): ``scenario`` and ``imu`` of the
    manifest hold the documents of :func:`resolve_run_inputs`. Returns them.
    """
    res = resolve_run_inputs(path, overrides)
    for role, original in res["files"].items():
        manifest.add_input(role, original)
    manifest.doc.update(scenario=res["scenario"], imu=res["imu"], overrides=dict(overrides or {}))
    return res


def record_run(manifest: Manifest, scenario, path, overrides: dict | None, folder) -> None:
    """Write ``inputs/`` into a run's folder and the run's part of the manifest (module docstring).

    ``path`` is the scenario file or, for a scenario given as a mapping, that mapping (its relative
    paths taken from ``scenario.base_dir``).
    """
    from sins_sim.plan.imu import filters_used
    from sins_sim.simulation.unit import run_channels  # the drives the run builds its filters on (a block's own)

    res = resolve_run_inputs(path, overrides, getattr(scenario, "base_dir", None))
    inputs = Path(folder) / INPUTS
    inputs.mkdir(parents=True, exist_ok=True)
    note = "written by sins-sim run: the {} as run, every default filled in (sins-sim run --rerun reads it)"
    (inputs / res["copies"]["scenario"]).write_text(_dump_yaml(res["scenario"], note.format("scenario")))
    (inputs / res["copies"]["imu"]).write_text(_dump_yaml(res["imu"], note.format("IMU")))
    for role in ("trajectory", "diagnosis", "gnss"):
        if role in res["copies"]:
            shutil.copyfile(res["files"][role], inputs / res["copies"][role])
    for role, original in res["files"].items():
        copy = inputs / res["copies"][role] if role in res["copies"] else None
        extra = {"copy": f"{INPUTS}/{copy.name}", "copy_sha256": sha256_file(copy)} if copy is not None else {}
        manifest.add_input(role, original, **extra)
    for role in ("scenario", "imu"):  # inline IMU: the copy is the only file
        if role not in res["files"]:
            copy = inputs / res["copies"][role]
            manifest.doc["inputs"][role] = {"path": None, "sha256": None, "copy": f"{INPUTS}/{copy.name}",
                                            "copy_sha256": sha256_file(copy)}
    spec = scenario.filter_spec
    manifest.doc["run"] = {
        "scenario": res["scenario"], "imu": res["imu"], "overrides": dict(overrides or {}),
        "seed": scenario.seed,
        "seed_note": "every random stream of the run (readout noise, random vibration, sensor errors) derives "
                     "from this seed",
        "filter_parameters": {"source": spec["source"], "f0_source": spec["f0"],
                              "f0_mismatch_ppm": float(spec["f0_mismatch_ppm"]), "track": bool(spec["track"]),
                              "filters": filters_used(run_channels(scenario.imu), spec, scenario.filters)},
    }


def rerun_scenario(folder, flag: str = "--rerun") -> tuple:
    """The scenario file to run again from a ``run`` folder, its copies checked against the manifest.

    Returns
    -------
    (Path, dict)
        ``inputs/scenario.yaml`` of ``folder`` and the manifest.

    Raises
    ------
    ConfigError
        The folder is not a ``run`` result with a readable manifest of this schema, or an input copy is
        missing or was changed since the run.
    """
    folder = Path(folder)
    doc = read_manifest(folder, flag)
    if doc.get("command") != "run" or "run" not in doc:
        raise ConfigError(f"{flag}: {folder} holds a 'sins-sim {doc.get('command')}' result, not a run")
    for role, entry in doc.get("inputs", {}).items():
        copy = entry.get("copy")
        if not copy:
            continue
        p = folder / copy
        if not p.is_file():
            raise ConfigError(f"{flag}: {p} is missing: the folder no longer holds the {role} the run used")
        if sha256_file(p) != entry.get("copy_sha256"):
            raise ConfigError(f"{flag}: {p} was changed since the run (its SHA-256 differs from the manifest's): "
                              f"the rerun would not reproduce it; run the changed file as a new scenario instead")
    return folder / INPUTS / "scenario.yaml", doc
