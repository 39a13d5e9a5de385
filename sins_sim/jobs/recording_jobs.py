"""Recording jobs the CLI calls: write, import, diagnose and blindly evaluate recordings.

Each function returns a dictionary and prints nothing:

- :func:`simulate_recording` (``sins-sim simulate-recording SPEC.yaml --out REC.npz``): a recording from a
  small YAML experiment description, effects switched on but not written into the file;
- :func:`import_csv` (``sins-sim import-csv LAB.csv --out REC.npz ...``): a lab export into the format
  (columns in ``sins_sim.io.recording``);
- :func:`diagnose` (``sins-sim diagnose REC.npz --json OUT.json --report DIR``);
- :func:`diagnose_many` (``sins-sim diagnose A.npz B.npz ... --jobs N --json DIR --report DIR``): several
  recordings, in parallel across recordings;
- :func:`diagnose_eval` (``sins-sim diagnose-eval --n N --seed S``).

The experiment file's format, schema and loader are configuration: :mod:`sins_sim.config.experiment`.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from sins_sim.config.experiment import (DEFAULT_F0_HZ, EXPERIMENT_SCHEMA, SUSPENSION_YAML_KEYS,  # noqa: F401
                                        experiment_from_dict)
from sins_sim.config.yaml_io import load_yaml
from sins_sim.io.recording import read_csv_recording, read_recording, write_recording
from sins_sim.simulation.experiment import record
from sins_sim.units import ARCSEC

#: ``EXPERIMENT_SCHEMA``, ``DEFAULT_F0_HZ`` and ``experiment_from_dict`` are re-exported from
#: :mod:`sins_sim.config.experiment`, where they live
__all__ = ["EXPERIMENT_SCHEMA", "DEFAULT_F0_HZ", "experiment_from_dict", "simulate_recording", "import_csv",
           "diagnose", "diagnose_many", "diagnose_eval", "format_diagnosis", "format_eval", "write_suggestion"]


def simulate_recording(yaml_path, out_npz) -> dict:
    """Write the recording an experiment YAML describes (effects on, nothing about them in the file).

    Parameters
    ----------
    yaml_path : path
        Experiment description (:mod:`sins_sim.config.experiment`).
    out_npz : path
        Recording to write (``sins-sim-recording/1``).

    Returns
    -------
    dict
        ``path``, ``experiment``, ``axes``, ``n_samples``, ``fs_hz``, ``duration_s``, ``quantum_arcsec``,
        ``effects`` (what was switched on, for the caller's log only).
    """
    path = Path(yaml_path)
    spec = experiment_from_dict(load_yaml(path), str(path))
    rec = record(spec["inputs"], spec["truth"], spec["nominal"], spec["quantum_rad"], spec["effects"],
                 spec["settings"], spec["noise_rad"], spec["seed"], spec["experiment"], spec["description"],
                 spec["preroll_samples"], extra_meta={"site": spec["site"]} if spec["site"] else None)
    out = write_recording(out_npz, rec)
    return {"path": str(out), "experiment": rec.experiment, "axes": list(rec.axes), "n_samples": rec.n_samples,
            "fs_hz": rec.fs_hz, "duration_s": rec.duration_s, "quantum_arcsec": rec.quantum_rad / ARCSEC,
            "initial_state": rec.initial_state, "effects": [e.to_dict() for e in spec["effects"]]}


def _header_nominal(nominal):
    """Per-axis nominal parameters with the IMU/experiment YAML names (``k2_rad``, ``k4_per_rad``,
    ``k5_rad_per_v``) renamed to the recording header's (``k2``, ``k4``, ``k5``); giving both names of
    one parameter is an error naming them."""
    if not isinstance(nominal, dict):
        return nominal
    out = {}
    for axis, entry in nominal.items():
        if not isinstance(entry, dict):
            out[axis] = entry
            continue
        clean = {}
        for key, val in entry.items():
            name = SUSPENSION_YAML_KEYS.get(key, key) if key != "zeta" else key
            if name in clean:
                raise ValueError(f"import_csv: nominal.{axis}.{key}: gives {name} a second time (use one of "
                                 f"{name} or {key})")
            clean[name] = val
        out[axis] = clean
    return out


def import_csv(csv_path, out_npz, **meta) -> dict:
    """Convert a lab CSV export into a recording.

    Parameters
    ----------
    csv_path, out_npz : path
    **meta
        ``quantum_rad`` (or ``quantum_arcsec``), required; ``nominal``: a mapping axis ->
        ``{f0_hz, k1, ..., k5}`` (or with the names of ``configs/*.yaml``: ``k2_rad``, ``k4_per_rad``,
        ``k5_rad_per_v``) or the path of a JSON/YAML file holding one, required;
        optional ``experiment`` (default ``stationary``), ``initial_state`` (``rest``),
        ``description``, ``fs_hz`` (default from ``time_s``); anything else is stored in the header.
        Options given as ``None`` count as not given (so a CLI can pass its defaults through).

    Returns
    -------
    dict
        ``path``, ``axes``, ``n_samples``, ``fs_hz``, ``duration_s``, ``has_sins_angle``.
    """
    meta = {k: v for k, v in meta.items() if v is not None}  # options the caller left unset
    if "quantum_arcsec" in meta:
        if "quantum_rad" in meta:
            raise ValueError("import_csv: give quantum_rad or quantum_arcsec, not both")
        meta["quantum_rad"] = float(meta.pop("quantum_arcsec")) * ARCSEC
    for key in ("quantum_rad", "nominal"):
        if meta.get(key) is None:
            raise ValueError(f"import_csv: {key}: is required")
    nominal = meta.pop("nominal")
    if isinstance(nominal, (str, Path)):
        p = Path(nominal)
        if p.suffix.lower() == ".json":
            import json

            try:
                nominal = json.loads(p.read_text())
            except (OSError, ValueError) as exc:
                raise ValueError(f"import_csv: nominal: cannot read {p} ({exc})") from None
        else:
            nominal = load_yaml(p)
    nominal = _header_nominal(nominal)
    rec = read_csv_recording(csv_path, nominal=nominal, **meta)
    out = write_recording(out_npz, rec)
    return {"path": str(out), "axes": list(rec.axes), "n_samples": rec.n_samples, "fs_hz": rec.fs_hz,
            "duration_s": rec.duration_s, "has_sins_angle": rec.sins_angle is not None}


def diagnose(rec_path, json_out=None, report_dir=None, effects=None, threads: int | None = None,
             suggest_out=None) -> dict:
    """Diagnose a recording; write the JSON and the report directory when given; return the JSON dict.

    Parameters
    ----------
    rec_path : path
        A recording (``sins-sim-recording/1``).
    json_out : path, optional
        Where to write the JSON (keys of ``sins_sim.identification.diagnose.Diagnosis.to_json``).
    report_dir : path, optional
        Where to write ``report.md``, ``spectrum.png``, ``envelope.png``, ``ranking.png``.
    effects : list of str, optional
        Catalogue effects to try (default all).
    threads : int, optional
        Worker threads of the diagnosis (default ``DiagnoseSettings``'s: the cores it may use).
    suggest_out : path, optional
        When the verdict is a close call, write the experiment that separates it here (a
        ``simulate-recording`` YAML, :func:`write_suggestion`); otherwise nothing is written.

    Returns
    -------
    DiagnosisResult
        The JSON as a dict, with ``to_pandas()`` and ``plot(kind)`` (:class:`sins_sim.results.DiagnosisResult`,
        which keeps the diagnosis for its figures).
    """
    from sins_sim.identification.diagnose import DiagnoseSettings, diagnose_recording, write_report

    rec = read_recording(rec_path)
    settings = DiagnoseSettings(effects=tuple(effects) if effects else None)
    if threads is not None:
        settings = replace(settings, threads=int(threads))
    from sins_sim.results import DiagnosisResult

    diag = diagnose_recording(rec, settings)
    if suggest_out is not None:
        write_suggestion(diag.verdict, suggest_out)
    if report_dir is not None:
        return DiagnosisResult(write_report(diag, report_dir, json_out), diagnosis=diag)
    js = diag.to_json()
    if json_out is not None:
        import json

        Path(json_out).parent.mkdir(parents=True, exist_ok=True)
        Path(json_out).write_text(json.dumps(js, indent=2) + "\n")
    return DiagnosisResult(js, diagnosis=diag)


def write_suggestion(verdict: dict, out_yaml) -> bool:
    """Write a close call's separating experiment (``verdict["close_call"]["experiment"]``) as YAML.

    The document is checked by the experiment loader first (it must run as written). Returns whether a
    file was written (``False``: the verdict is no close call, nothing to separate).
    """
    cc = verdict.get("close_call")
    if not cc:
        return False
    import yaml

    doc = cc["experiment"]
    experiment_from_dict(doc, "suggested experiment")  # runs as written, or a ConfigError here
    effects = ", ".join(e["effect"] for e in cc["effects"])
    head = (f"# Suggested by sins-sim diagnose: the experiment that separates {effects}\n"
            f"# ({cc['why']}).\n# {cc['criterion']}.\n"
            "# Record it on the unit (or simulate it: sins-sim simulate-recording THIS.yaml --out REC.npz, with the\n"
            "# effect under test added to an effects: list), then diagnose that recording.\n")
    Path(out_yaml).parent.mkdir(parents=True, exist_ok=True)
    Path(out_yaml).write_text(head + yaml.safe_dump(doc, sort_keys=False, default_flow_style=None, width=120))
    return True


def _diagnose_task(task) -> dict:
    path, json_out, report_dir, effects, threads = task
    return diagnose(path, json_out=json_out, report_dir=report_dir, effects=effects, threads=threads)


def diagnose_many(rec_paths, json_dir=None, report_dir=None, effects=None, jobs: int = 1, progress=None) -> list:
    """Diagnose several recordings, ``jobs`` at once in separate processes; their JSON dicts in input order.

    Every recording is read (and so checked) before any diagnosis starts, so a wrong file fails at
    once. Outputs are named by each recording's file stem: ``json_dir/STEM.json`` and
    ``report_dir/STEM/`` (stems must differ). With ``jobs > 1`` each diagnosis runs on one thread
    (the recordings are the parallel work); a diagnosis's result does not depend on ``jobs``.

    Parameters
    ----------
    rec_paths : sequence of paths
    json_dir, report_dir : path, optional
        Existing (or creatable) folders for the JSON files and the report folders.
    effects : list of str, optional
    jobs : int
        Recordings diagnosed at once (>= 1).
    progress : callable(str) or None
        Called with a line as each diagnosis ends.
    """
    jobs = int(jobs)
    if jobs < 1:
        raise ValueError(f"diagnose.jobs: must be >= 1, got {jobs!r}")
    paths = [Path(p) for p in rec_paths]
    if not paths:
        raise ValueError("diagnose.recording: needs at least one recording")
    seen = {}
    for p in paths:
        if p.stem in seen:
            raise ValueError(f"diagnose.recording: {seen[p.stem]} and {p} share the name {p.stem!r}; their outputs "
                             "would collide (rename one)")
        seen[p.stem] = p
    from sins_sim.identification.checks import require_inputs

    for p in paths:
        # a wrong file, or one that lacks what its experiment needs, fails here, before hours of work on the others
        require_inputs(read_recording(p))
    threads = 1 if jobs > 1 and len(paths) > 1 else None
    tasks = [(str(p), None if json_dir is None else str(Path(json_dir) / f"{p.stem}.json"),
              None if report_dir is None else str(Path(report_dir) / p.stem), effects, threads) for p in paths]
    out = [None] * len(tasks)

    def done(i, js):
        out[i] = js
        if progress is not None:
            v = js["verdict"]
            progress(f"{paths[i]}: {v['effect']} ({v['status']})")

    if threads is None:
        for i, task in enumerate(tasks):
            done(i, _diagnose_task(task))
        return out
    from sins_sim.identification.refit import in_processes

    in_processes(_diagnose_task, tasks, jobs, done)
    return out


def diagnose_eval(n: int, seed: int, duration_s: float = 1.0, json_out=None, progress=None, jobs: int = 1,
                  suite: str = "standard", seeds=None, labels=None) -> dict:
    """Blind evaluation (``sins_sim.identification.blind.evaluate``); the result dictionary.

    Parameters
    ----------
    n : int
        Number of recordings.
    seed : int
        Seed of the case generator.
    duration_s : float
        Length of each recording (s).
    json_out : path, optional
        Write the result as JSON too.
    progress : callable(str) or None
        Called after each case with a one-line summary.
    jobs : int
        Recordings diagnosed at once (separate processes).
    suite : str
        ``standard`` (:mod:`sins_sim.identification.blind`) or ``hard``
        (:mod:`sins_sim.identification.blind_hard`).
    seeds : sequence of int, optional
        Several seeds instead of ``seed``: ``n`` recordings each, accuracy pooled per class
        (:func:`sins_sim.identification.blind_hard.evaluate_seeds`).
    labels : sequence of str, optional
        Only these classes (default all of the suite's).
    """
    if seeds is not None:
        from sins_sim.identification.blind_hard import evaluate_seeds

        res = evaluate_seeds(n, seeds, duration_s=duration_s, suite=suite, progress=progress, jobs=jobs, labels=labels)
    else:
        from sins_sim.identification.blind import evaluate

        res = evaluate(n, seed, duration_s=duration_s, progress=progress, jobs=jobs, suite=suite, labels=labels)
    if json_out is not None:
        import json

        Path(json_out).parent.mkdir(parents=True, exist_ok=True)
        Path(json_out).write_text(json.dumps(res, indent=2) + "\n")
    return res



def _fmt(x, spec: str) -> str:
    """``x`` formatted by ``spec``, or ``n/a`` where the diagnosis holds no number (None, a missing key)."""
    return "n/a" if x is None else format(x, spec)


def format_diagnosis(js: dict) -> str:
    """A few lines summarising a diagnosis' JSON (for the CLI to print).

    Any number may be ``None`` (a fit that gave no value, a verdict ``none``): it is printed as ``n/a``.
    """
    v = js.get("verdict") or {}
    if js.get("findings"):
        from sins_sim.identification.checks import format_findings

        return format_findings(js["findings"]) + "\nverdict: none given (the data failed the checks above)"
    g = js.get("gap") or {}
    lines = [f"noise floor {_fmt(js.get('noise_floor_arcsec'), '.4g')} arcsec; baseline residual "
             f"{_fmt((js.get('baseline') or {}).get('residual_rms_arcsec'), '.4g')} arcsec RMS"]
    if g.get("significant"):
        lines.append(f"gap on axis {g.get('axis')}: band {g.get('band_hz')} Hz, time {g.get('time_s')} s")
        for c in (js.get("candidates") or [])[:3]:
            lines.append(f"  {c.get('effect')!s:<16} gap reduction {_fmt(c.get('gap_reduction'), '.3f')}  "
                         f"score {_fmt(c.get('score'), '.4g')}  {c.get('params')}")
    else:
        lines.append("no significant gap: the refit nominal model sits at the noise floor")
    alts = f" (or: {', '.join(v['alternatives'])})" if v.get("alternatives") else ""
    lines.append(f"verdict: {v.get('effect')}{alts} [{v.get('status')}], explained fraction "
                 f"{_fmt(v.get('explained_fraction') or 0.0, '.3f')}")
    if v.get("unconfirmed"):
        lines.append(f"in-sample only: {v['unconfirmed'].get('message')}")
    cc = v.get("close_call")
    if cc:
        lines.append("close call: " + ", ".join(f"{e.get('effect')} {_fmt(e.get('explained_fraction'), '.5f')}"
                                                for e in cc.get("effects", [])) + f"; separated by {cc.get('why')}")
    if len(v.get("effects") or []) > 1:
        lines.append("effects: " + ", ".join(f"{e.get('effect')} {_fmt(e.get('explained_fraction'), '.3f')}"
                                             for e in v["effects"]))
    r = v.get("remainder")
    if r:
        lines.append(f"remainder on axis {r.get('axis')}: band {r.get('band_hz')} Hz, time {r.get('time_s')} s")
    sr = v.get("steady_rate")
    if sr:
        lines.append(f"steady rate ({sr.get('finding')}): {sr.get('message')}")
    return "\n".join(lines)


def format_eval(res: dict) -> str:
    """The blind evaluation's confusion matrix and statistics as text (for the CLI to print)."""
    if "per_seed" in res:
        from sins_sim.identification.blind_hard import format_seeds

        return format_seeds(res)
    from sins_sim.identification.blind import format_result

    return format_result(res)
