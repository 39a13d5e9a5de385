"""Issue 40, items 1-13: defects an outside campaign and a new user found, each reproduced here.

Every test failed before its fix: a traceback, a file deleted without a word, an input accepted and ignored, a
message in internal words or naming no input, a README command that exits 2, a column in the wrong unit, a doc
pointing at a file no user has, a summary cut at "eq.", an estimate 3x too short, a rule missing from the schema.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from sins_sim.config.errors import ConfigError
from sins_sim.io.recording import (FORMAT, SINS_RATE_MAX_RAD_S, SINS_SWING_MAX_RAD, RecordingError,
                                   read_recording)

ROOT = Path(__file__).resolve().parents[1]
CHANNELS = {"x": {"f0_hz": 386.0}, "y": {"f0_hz": 352.0}, "z": {"f0_hz": 421.0}}
NOMINAL = {"f0_hz": 386.0, "k1": 1.75e-4, "k2": 1.05e-3, "k3": 4.4e-3, "k4": 250.0, "k5": -1.2e-5}


# --- item 1: a recording's sins_angle beyond any physical block angle ----------------------------------------------
def _recording(tmp_path, angle: np.ndarray) -> Path:
    n = angle.shape[0]
    meta = {"format": FORMAT, "axes": ["x"], "fs_hz": 7200.0, "drive_fs_hz": 7200.0, "sins_fs_hz": 7200.0,
            "quantum_rad": 7.3e-7, "initial_state": "rest", "experiment": "rate_table", "nominal": {"x": NOMINAL}}
    path = tmp_path / "rec.npz"
    np.savez_compressed(path, meta=np.array(json.dumps(meta)), counts=np.zeros((n, 1), np.int64),
                        drive_v=np.zeros((n, 1)), sins_angle=angle)
    return path


def _table_angle(n=2161, fs=7200.0, rate_deg_s=5.0):
    """A 5 deg/s table with a 3 arcmin, 20 Hz swing (the rate_table experiment's block angle)."""
    t = np.arange(n) / fs
    return (math.radians(rate_deg_s) * t + math.radians(3.0 / 60.0) * np.sin(2 * math.pi * 20.0 * t))[:, None]


def test_a_physical_block_angle_is_read(tmp_path):
    assert read_recording(_recording(tmp_path, _table_angle())).sins_angle.shape == (2161, 1)


@pytest.mark.parametrize("scale", [1e300, 1e6])  # the campaign's corruption; microradians read as rad
def test_a_block_angle_beyond_its_physical_range_is_refused_naming_sins_angle(tmp_path, scale):
    with pytest.raises(RecordingError) as exc:
        read_recording(_recording(tmp_path, _table_angle() * scale))
    msg = str(exc.value)
    assert "sins_angle: must stay within the physical range" in msg and "1000 deg/s" in msg and "axis x" in msg, msg


def test_the_bound_is_the_largest_swing_plus_the_largest_rate_times_t(tmp_path):
    """Just inside the bound at the last sample is read, just outside is refused (the bound is 10 deg + 1000 deg/s t,
    so a relative margin of 1e-9 is far above the float64 rounding of the comparison, 1e-16)."""
    n, fs = 721, 7200.0
    limit = SINS_SWING_MAX_RAD + SINS_RATE_MAX_RAD_S * (n - 1) / fs
    for factor, ok in ((1 - 1e-9, True), (1 + 1e-9, False)):
        angle = np.zeros((n, 1))
        angle[-1, 0] = factor * limit
        if ok:
            read_recording(_recording(tmp_path, angle))
        else:
            with pytest.raises(RecordingError, match="sins_angle"):
                read_recording(_recording(tmp_path, angle))
    start = np.full((n, 1), 7.0)  # 7 rad > 2 pi: no orientation about an axis
    with pytest.raises(RecordingError, match="sins_angle: must start within one turn"):
        read_recording(_recording(tmp_path, start))


def test_format_diagnosis_prints_none_as_n_a():
    from sins_sim.jobs.recording_jobs import format_diagnosis

    js = {"verdict": {"effect": "none", "status": "none", "explained_fraction": None, "alternatives": [],
                      "effects": [{"effect": "a", "explained_fraction": None}, {"effect": "b",
                                                                              "explained_fraction": 0.5}]},
          "noise_floor_arcsec": None, "baseline": {"residual_rms_arcsec": None},
          "gap": {"significant": True, "axis": "x", "band_hz": None, "time_s": None},
          "candidates": [{"effect": "x", "gap_reduction": None, "score": None, "params": {}}]}
    text = format_diagnosis(js)
    assert "noise floor n/a arcsec" in text and "gap reduction n/a" in text and "a n/a" in text, text


# --- item 2: --force never deletes a file sins-sim did not write -----------------------------------------------------
def _earlier_result(folder: Path, outputs=("metrics.json", "plots/a.png")) -> dict:
    from sins_sim.jobs.output import MARKER

    for rel in outputs:
        (folder / rel).parent.mkdir(parents=True, exist_ok=True)
        (folder / rel).write_text(rel)
    (folder / MARKER).write_text("written by sins-sim\n")
    (folder / "manifest.json").write_text(json.dumps({"command": "run", "outputs": {r: "0" for r in outputs}}))
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in folder.rglob("*") if p.is_file()}


def test_force_replaces_a_folder_holding_only_what_sins_sim_wrote(tmp_path):
    from sins_sim.jobs.output import check_out_dir

    out = tmp_path / "out"
    out.mkdir()
    _earlier_result(out)
    assert check_out_dir(out, "--out", min_free_bytes=0, force=True) == out


@pytest.mark.parametrize("foreign", ["notes.txt", "plots/mine.png"])
def test_force_onto_a_result_with_a_users_file_is_refused_naming_it_and_changes_nothing(tmp_path, foreign):
    from sins_sim.jobs.manifest import Manifest, result_dir

    out = tmp_path / "out"
    out.mkdir()
    (out / "plots").mkdir()
    (out / foreign).write_text("keep\n")
    before = _earlier_result(out)
    with pytest.raises(ConfigError) as exc:
        with result_dir(out, Manifest("run", []), force=True) as tmp:
            (Path(tmp) / "metrics.json").write_text("{}")
    msg = str(exc.value)
    assert msg.startswith(f"--out: {out} also holds files sins-sim did not write ({foreign})"), msg
    assert "\n" not in msg
    after = {p.relative_to(out).as_posix(): p.read_bytes() for p in out.rglob("*") if p.is_file()}
    assert after == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # no temporary folder left beside it


def test_force_without_a_list_of_what_sins_sim_wrote_cannot_tell_and_refuses(tmp_path):
    """An older result: its marker lists no files and it has no manifest."""
    from sins_sim.jobs.output import MARKER, check_out_dir

    out = tmp_path / "out"
    out.mkdir()
    (out / MARKER).write_text("written by sins-sim; a later run with --force may replace this folder\n")
    (out / "metrics.json").write_text("{}")
    with pytest.raises(ConfigError, match=r"holds no list of the files sins-sim wrote there"):
        check_out_dir(out, "--out", min_free_bytes=0, force=True)


def test_the_marker_lists_what_sins_sim_wrote_and_force_keeps_to_it(tmp_path):
    """A folder written by atomic_output_dir alone (no manifest): replaced with --force while it holds only what was
    written; with a user's file added, refused and kept."""
    from sins_sim.jobs.output import atomic_output_dir, foreign_files

    out = tmp_path / "out"
    with atomic_output_dir(out, min_free_bytes=0) as tmp:
        (tmp / "sub").mkdir()
        (tmp / "sub" / "a.txt").write_text("1")
    assert foreign_files(out) == []
    with atomic_output_dir(out, min_free_bytes=0, force=True) as tmp:
        (tmp / "b.txt").write_text("2")
    assert sorted(p.name for p in out.iterdir() if not p.name.startswith(".")) == ["b.txt"]
    (out / "notes.txt").write_text("keep")
    with pytest.raises(ConfigError, match=r"also holds files sins-sim did not write \(notes\.txt\)"):
        with atomic_output_dir(out, min_free_bytes=0, force=True):
            pass
    assert (out / "notes.txt").read_text() == "keep" and (out / "b.txt").read_text() == "2"


# --- items 3 and 4: navigation settings accepted and ignored, or refused in internal words ---------------------------
def _nav_scenario(filters=("ideal", "eliminator"), motion=None, **nav):
    return {"name": "t", "duration_s": 2.0, "imu": str(ROOT / "configs" / "default-imu.yaml"),
            "motion": motion or [{"type": "sines", "amplitude_arcmin": [1.0, 1.0, 0.0], "frequency_hz": [300, 300, 0]}],
            "filters": list(filters), "navigation": {"start_s": 1.0, **nav}}


@pytest.mark.parametrize("nav", [{"coning": "two_sample"}, {"coning": "three_sample", "sculling": "four_sample"}])
def test_a_tuned_band_without_filter_tuned_is_refused(nav):
    from sins_sim.config.scenario import load_scenario

    with pytest.raises(ConfigError) as exc:
        load_scenario(_nav_scenario(tuned_band_hz=[200.0, 300.0], **nav))
    msg = str(exc.value)
    assert "navigation.tuned_band_hz: applies only with coning or sculling: filter_tuned" in msg and "\n" not in msg


def test_a_tuned_band_under_a_single_coning_motion_sets_the_coning_tables_band():
    """There the run's coning table designs filter_tuned over it (sins_sim.jobs.coning_table.band_for): not ignored."""
    from sins_sim.config.scenario import load_scenario
    from sins_sim.jobs.coning_table import band_for

    sc = load_scenario(_nav_scenario(motion=[{"type": "coning", "amplitude_arcmin": 1.0, "frequency_hz": 300.0}],
                                     coning="two_sample", tuned_band_hz=[250.0, 350.0]))
    assert band_for(sc, 300.0, 7200.0) == (250.0, 350.0)


@pytest.mark.parametrize("which", ["coning", "sculling"])
def test_filter_tuned_with_the_lms_stripper_is_refused_at_load_saying_why(which):
    from sins_sim.config.scenario import load_scenario

    with pytest.raises(ConfigError) as exc:
        load_scenario(_nav_scenario(filters=("ideal", "lms_stripper"), tuned_band_hz=[200.0, 300.0],
                                    **{which: "filter_tuned"}))
    msg = str(exc.value)
    assert f"navigation.{which}: filter_tuned cannot go with the filter lms_stripper" in msg, msg
    assert "single-axis filter's fixed frequency response" in msg and "adapts its gains" in msg
    assert "only the SINS engine runs it" not in msg


# --- item 5: messages that name the user's input ---------------------------------------------------------------------
@pytest.mark.parametrize("offset", [1e6, -60.0, math.nan])
def test_separation_study_refuses_an_axis_offset_naming_the_flag_and_its_range(tmp_path, capsys, offset):
    from sins_sim.cli import main

    rc = main(["separation-study", str(ROOT / "configs" / "isolated-block.yaml"), "--out", str(tmp_path / "o"),
               "--axis-offset-mrad", str(offset)])
    line = capsys.readouterr().err.strip().splitlines()[-1]
    assert rc == 2 and line.startswith("sins-sim: error: --axis-offset-mrad: must lie in [-50, 50] mrad"), line
    assert "orthogonal" not in line and not (tmp_path / "o").exists()


def test_separation_study_counts_the_files_own_offset_in_the_range(tmp_path):
    """gyro_axes_mrad.y = [40, 0, 0] in the file plus a 20 mrad tilt of y towards x: 60 mrad in all."""
    from sins_sim.config.imu import load_imu
    from sins_sim.config.yaml_io import load_yaml
    from sins_sim.jobs.separation_study import separation_study

    doc = load_yaml(ROOT / "configs" / "isolated-block.yaml")
    doc["block"]["gyro_axes_mrad"] = {"y": [40.0, 0.0, 0.0]}
    (tmp_path / "imu.yaml").write_text(__import__("yaml").safe_dump(doc))
    imu = load_imu(tmp_path / "imu.yaml")
    with pytest.raises(ConfigError, match=r"--axis-offset-mrad: .* together with the IMU file's gyro_axes_mrad\.y\[0\]"):
        separation_study(imu, tmp_path / "o", axis_offset_mrad=20.0)


@pytest.mark.parametrize(("effect", "key", "hint"), [
    ({"name": "axis_coupling", "coefficient": {"x": {"y": 0.01}}}, "effects.axis_coupling.coefficient",
     "allowed: axes, coefficients); did you mean 'coefficients'?"),
    ({"name": "piezo_lag", "tau": 1e-4}, "effects.piezo_lag.tau", "allowed: axes, tau_s); did you mean 'tau_s'?"),
])
def test_a_misspelt_effect_parameter_names_the_key_the_allowed_ones_and_the_closest(effect, key, hint):
    from sins_sim.config.imu import load_imu

    with pytest.raises(ConfigError) as exc:
        load_imu({"channels": CHANNELS, "effects": [effect]})
    msg = str(exc.value)
    assert f"effects[0]: {key}: unknown parameter (" in msg and hint in msg, msg
    assert "__init__" not in msg and "keyword argument" not in msg


def _traj_file(folder: Path, rows: int) -> Path:
    """A level flight north at 10 Hz lasting (rows - 1) / 10 s."""
    lines = ["time_s,lat_deg,lon_deg,height_m,roll_deg,pitch_deg,yaw_deg"]
    lines += [f"{i / 10:.1f},{45.0 + i * 1e-5:.6f},7.0,1000.0,0.0,0.0,0.0" for i in range(rows)]
    path = folder / "t.csv"
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("source", ["file", "segments"])
def test_a_trajectory_too_short_for_any_run_never_advises_a_negative_duration(tmp_path, source):
    from sins_sim.config.scenario import load_scenario

    doc = {"name": "t", "duration_s": 1.0, "imu": str(ROOT / "configs" / "default-imu.yaml"),
           "navigation": {"start_s": 0.5}}
    if source == "file":
        doc["trajectory"] = {"file": str(_traj_file(tmp_path, 5))}  # 0.4 s
    else:
        doc["site"] = {"lat_deg": 48.0, "lon_deg": 11.5, "height_m": 500.0, "heading_deg": 30.0}
        doc["trajectory"] = {"segments": [{"type": "cruise", "duration_s": 0.05}]}
    with pytest.raises(ConfigError) as exc:
        load_scenario(doc)
    msg = str(exc.value)
    assert "too short for any run that starts navigating at navigation.start_s = 0.5 s" in msg, msg
    assert "must last more than 0.6 s" in msg and "<= -" not in msg and "set duration_s" not in msg


def test_a_trajectory_long_enough_for_a_shorter_run_still_advises_it(tmp_path):
    from sins_sim.config.scenario import load_scenario

    doc = {"name": "t", "duration_s": 5.0, "imu": str(ROOT / "configs" / "default-imu.yaml"),
           "navigation": {"start_s": 1.0}, "trajectory": {"file": str(_traj_file(tmp_path, 40))}}  # 3.9 s
    with pytest.raises(ConfigError, match=r"set duration_s <= 3\.8"):
        load_scenario(doc)


# --- item 6: the README's commands parse ------------------------------------------------------------------------------
def _documented_commands(path: Path) -> list:
    """Every ``sins-sim ...`` line of a file's code blocks as an argument list: the comment cut, each optional
    ``[--flag VALUE]`` and ``[a|b]`` written out (its first choice)."""
    import re
    import shlex

    out = []
    blocks = re.findall(r"^```[^\n]*\n(.*?)^```", path.read_text(encoding="utf-8"), re.M | re.S)
    for line in "\n".join(blocks).splitlines():
        if not line.startswith("sins-sim ") or ">" in line.split("#")[0]:
            continue
        cmd = re.split(r"\s{2,}#|\s#\s", line)[0]
        cmd = re.sub(r"\[([^\]|]*)\|[^\]]*\]", r"\1", cmd)  # [a|b|c] -> a
        cmd = cmd.replace("[", "").replace("]", "")
        values = {"N": "2", "S": "1.5"}  # the placeholders of numeric flags
        out.append((line, [values.get(a, a) for a in shlex.split(cmd)[1:]]))
    return out


@pytest.mark.parametrize("doc", ["README.md", "docs/reference/cli.md"])
def test_every_documented_command_line_parses(doc, capsys):
    from sins_sim.cli import build_parser

    parser = build_parser()
    lines = _documented_commands(ROOT / doc)
    assert any(args[0] == "compare-filters" for _, args in lines)
    for line, args in lines:
        try:
            parser.parse_args(args)
        except SystemExit as exc:
            pytest.fail(f"{doc}: {line!r} exits {exc.code}: {capsys.readouterr().err.strip()[-200:]}")


def test_compare_filters_out_alone_writes_the_numbers_into_the_folder(tmp_path, monkeypatch, capsys):
    """As the README says: ``--out DIR`` without ``--json``; ``--json F`` still writes a copy there (the study is
    replaced by one that writes its files, so that the command's own plumbing is what is tested)."""
    import sins_sim.jobs.compare_filters as cf
    from sins_sim.cli import main

    def fake(out_dir, json_path, quick=False, progress=None, **kw):
        Path(json_path).write_text('{"best": "eq5"}\n')
        (Path(out_dir) / "report.md").write_text("r\n")
        return {"best": "eq5"}

    monkeypatch.setattr(cf, "run_compare_filters", fake)
    assert main(["compare-filters", "--quick", "--out", str(tmp_path / "a"), "--quiet"]) == 0
    assert json.loads((tmp_path / "a" / "filters.json").read_text()) == {"best": "eq5"}
    assert main(["compare-filters", "--quick", "--out", str(tmp_path / "b"), "--json", str(tmp_path / "f.json"),
                 "--quiet"]) == 0
    assert (tmp_path / "f.json").read_text() == (tmp_path / "b" / "filters.json").read_text()
    assert "numbers: " + str(tmp_path / "f.json") in capsys.readouterr().out


# --- item 7: sins_sim.run(progress=...) takes a bool --------------------------------------------------------------
class _Stop(Exception):
    """Raised by the stand-in engine, once it has seen the progress it was given."""


def _seen_progress(monkeypatch, progress):
    """The ``progress`` that ``sins_sim.run`` hands the engine (the engine replaced by one that reports 0.5, 1)."""
    import sins_sim
    import sins_sim.jobs.run as jr

    seen = []

    def prepare(source, overrides=None, progress=None, base_dir=None):
        return object(), ()

    def compute(sc, warns, progress, threads):
        seen.append(progress)
        for f in (0.5, 1.0):
            if progress is not None:
                progress(f)
        raise _Stop()

    monkeypatch.setattr(jr, "prepare_run", prepare)
    monkeypatch.setattr(jr, "compute_run", compute)
    with pytest.raises(_Stop):
        sins_sim.run({"name": "x"}, progress=progress)
    return seen[0]


def test_run_takes_progress_false_as_none_and_true_as_a_bar(monkeypatch, capsys):
    assert _seen_progress(monkeypatch, False) is None
    assert _seen_progress(monkeypatch, None) is None
    bar = _seen_progress(monkeypatch, True)
    assert callable(bar) and bar.bar.n == pytest.approx(100.0)  # the bar reached the end (and was closed)
    fractions = []
    assert _seen_progress(monkeypatch, fractions.append) == fractions.append and fractions == [0.5, 1.0]


@pytest.mark.parametrize("bad", ["yes", 1, [0.5]])
def test_run_refuses_a_progress_that_is_neither_bool_nor_callable_before_the_run(monkeypatch, bad):
    import sins_sim
    import sins_sim.jobs.run as jr

    monkeypatch.setattr(jr, "prepare_run", lambda *a, **k: pytest.fail("the run started"))
    with pytest.raises(ConfigError, match=r"^sins_sim\.run: progress: must be True \(a progress bar\), False"):
        sins_sim.run({"name": "x"}, progress=bad)


# --- item 8: a dict read by plain yaml.safe_load -------------------------------------------------------------------
def test_a_number_pyyaml_read_as_text_is_refused_saying_why_and_pointing_to_load_yaml():
    """Refused, not converted: a quoted number is text in YAML, in the JSON Schema editors use and in every other
    reader, so converting would make sins-sim the one reader that disagrees (and would accept a value the user
    quoted on purpose); the message says what happened and how to load the file."""
    import yaml

    import sins_sim

    path = ROOT / "configs" / "isolated-block.yaml"
    with pytest.raises(ConfigError) as exc:
        sins_sim.load_imu(yaml.safe_load(path.read_text()))
    msg = str(exc.value)
    assert "stiffness_n_per_m[0]: must be a number, got str '7.58e5'" in msg, msg
    assert "yaml.safe_load reads forms such as 7.58e5 as strings" in msg and "sins_sim.load_yaml" in msg
    assert sins_sim.load_imu(sins_sim.load_yaml(path)).block is not None  # the pointer works


def test_text_that_is_no_number_gets_no_yaml_hint():
    from sins_sim.config.imu import load_imu

    with pytest.raises(ConfigError) as exc:
        load_imu({"channels": {**CHANNELS, "x": {"f0_hz": "abc"}}})
    assert "got str 'abc'" in str(exc.value) and "load_yaml" not in str(exc.value)


# --- item 9: the sweep table's sensor columns in the units their names say --------------------------------------------
def test_sweep_sensor_columns_hold_the_drawn_value_in_their_unit(tmp_path):
    """``param.accelerometer.bias_ug.x`` is the unit's accelerometer bias in ug (25 ug 1-sigma x its score), the
    misalignment angles in arcsec (signed 1-sigma magnitudes x scores): the values the run's IMU holds, computed
    here from the scores independently of the table."""
    import yaml

    from sins_sim.jobs.sweep.job import parameter_label, prepare_sweep
    from sins_sim.jobs.sweep.population import draw_unit
    from sins_sim.jobs.sweep.tasks import PARAM_PREFIX

    nav_grade = ROOT / "configs" / "nav-grade-rlg.yaml"
    doc = {"name": "cols", "seed": 3, "units": 3,
           "scenarios": [{"path": str(ROOT / "scenarios" / "stationary.yaml"), "duration_s": 1.5}],
           "population": {"sensors": {"draw": True, "preset": str(nav_grade)}}}
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(doc))
    sweep, tasks, _ = prepare_sweep(tmp_path / "s.yaml")
    acc = yaml.safe_load(nav_grade.read_text())["sensors"]["accelerometer"]
    for t in tasks:
        z = draw_unit(sweep, t.unit)
        row = {PARAM_PREFIX + k: float(v) for k, v in t.spec("v")["params"].items()}  # as run_task fills the row
        for ax in "xyz":
            assert row[f"param.accelerometer.bias_ug.{ax}"] == pytest.approx(25.0 * z[f"accelerometer.bias_ug.{ax}"],
                                                                            rel=1e-15)
        for k, lab in enumerate(("xy", "xz", "yx", "yz", "zx", "zy")):
            sigma = abs(acc["misalignment_arcsec"][k])
            assert row[f"param.accelerometer.misalignment_arcsec.{lab}"] == pytest.approx(
                sigma * z[f"accelerometer.misalignment_arcsec.{lab}"], rel=1e-15)
    assert parameter_label("accelerometer.bias_ug.x") == "accelerometer bias, axis x (ug)"


# --- item 10: no doc or docstring points at a file no user has ------------------------------------------------------
#: The project's specification files (outside the repository): the docs stand alone.
_PRIVATE = ("shared/", "reference-model.md", "recording-format.md", "correcting-filter-paper.txt")


def _user_facing_files():
    for top in ("docs", "sins_sim", "configs", "scenarios"):
        for p in sorted((ROOT / top).rglob("*")):
            if p.is_file() and p.suffix in (".py", ".md", ".bib", ".yaml", ".rst", ".txt", ".cff") \
                    and "_build" not in p.parts and "__pycache__" not in p.parts:
                yield p
    yield from (ROOT / n for n in ("README.md", "CHANGELOG.md", "CITATION.cff"))


def test_no_doc_or_docstring_mentions_the_projects_private_spec_files():
    found = [f"{p.relative_to(ROOT)}:{i}: {line.strip()[:100]}" for p in _user_facing_files()
             for i, line in enumerate(p.read_text(encoding="utf-8", errors="replace").splitlines(), 1)
             if any(s in line for s in _PRIVATE)]
    assert not found, "\n".join(found)



# --- item 11: the API page's one-line summaries are complete phrases -------------------------------------------------
#: Abbreviations a first sentence must not end in: autosummary cuts the summary at the first ". ".
_ABBREVIATIONS = ("eq.", "eqs.", "sec.", "fig.", "figs.", "ch.", "no.", "vs.", "cf.", "ref.", "approx.", "e.g.", "i.e.",
                  "et al.", "p.", "pp.", "vol.")


def _api_page_objects():
    """Every object the API page's autosummary tables list, and every name of ``sins_sim.__all__``."""
    import importlib
    import re

    import sins_sim

    out = {f"sins_sim.{n}": getattr(sins_sim, n) for n in sins_sim.__all__ if n != "__version__"}
    module = "sins_sim"
    for line in (ROOT / "docs" / "reference" / "api.md").read_text().splitlines():
        m = re.match(r"\.\. currentmodule:: (\S+)", line.strip())
        if m:
            module = m.group(1)
        elif re.fullmatch(r"   [A-Za-z_]\w*", line):
            out[f"{module}.{line.strip()}"] = getattr(importlib.import_module(module), line.strip())
    return out


def test_every_api_summary_is_a_complete_phrase():
    """The summary Sphinx's autosummary extracts (its own function) ends in no abbreviation."""
    import inspect

    pytest.importorskip("sphinx", reason="the docs extra (pip install -e \".[docs]\") gives Sphinx's summary rule")
    from docutils.frontend import get_default_settings
    from docutils.parsers.rst import Parser
    from sphinx.ext.autosummary import extract_summary

    settings = get_default_settings(Parser)
    objects = _api_page_objects()
    assert {"sins_sim.CorrectingFilter", "sins_sim.plots.navigation.plot_run"} <= set(objects)
    cut = {}
    for name, obj in objects.items():
        summary = extract_summary((inspect.getdoc(obj) or "").splitlines(), settings)
        last = summary.lower().rsplit(" ", 2)  # the last word (two for "et al.")
        if not summary or last[-1].lstrip("(") in _ABBREVIATIONS or " ".join(last[-2:]) in _ABBREVIATIONS:
            cut[name] = summary
    assert not cut, cut


# --- item 12: the time left, measured on the run ----------------------------------------------------------------------
class _FakeClock:
    def __init__(self):
        self.t = 0.0

    def __call__(self):
        return self.t


def _model_estimate(wall_s=52.0, fixed_s=3.0):
    return {"kind": "run", "simulated_s": 1800.0, "wall_s": wall_s, "wall_display_s": wall_s,
            "breakdown": {"fixed_s": fixed_s}, "calibration": {"runs": 0}}


def test_the_time_left_is_measured_not_counted_down_from_the_model(tmp_path, monkeypatch):
    """The issue's run: the model said 52 s; the run took 2 min 44 s: 20 s of compilation and start-up, then
    180 chunks of 0.8 s (144 s), then the 3 s tail. After the first chunk and three more the estimator knows the
    throughput exactly (constant here), so the time left is the closed form (180 - k) x 0.8 s + 3 s."""
    from sins_sim.jobs.estimate import RemainingTime

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))  # no calibration: the tail is the model's fixed 3 s
    clock = _FakeClock()
    left = RemainingTime(_model_estimate(), clock=clock)
    assert left.text() == "estimating the time left (model: 52 s, not yet calibrated)"
    clock.t = 20.0 + 0.8  # compilation, start-up and the first chunk
    for k in range(1, 181):
        left.update(k / 180)
        if k < 1 + RemainingTime.MIN_INTERVALS:
            assert left.seconds_left() is None and left.text().startswith("estimating")
        else:
            assert left.seconds_left() == pytest.approx((180 - k) * 0.8 + 3.0, rel=1e-12)
        clock.t += 0.8
    assert left.seconds_left() == pytest.approx(3.0)
    left2 = RemainingTime(_model_estimate(), clock=clock)
    for k in range(1, 6):
        left2.update(k / 180)
        clock.t += 0.8
    assert left2.text() == "about 2.4 min left (measured)"  # (180 - 5) x 0.8 + 3 = 143 s = 2.38 min


def test_a_slow_first_interval_is_averaged_not_extrapolated(tmp_path, monkeypatch):
    """Short chunks under MIN_MEASURED_S are not trusted; after that the rate is the mean since the first report:
    a first interval of 3 s followed by 1 s ones gives (3 + 1 + 1) s per 3 chunks, not 3 s per chunk."""
    from sins_sim.jobs.estimate import RemainingTime

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    clock = _FakeClock()
    left = RemainingTime(_model_estimate(fixed_s=0.0), clock=clock)
    for t, k in ((0.0, 1), (0.01, 2), (0.02, 3), (0.03, 4)):
        clock.t = t
        left.update(k / 100)
    assert left.seconds_left() is None  # four reports but 0.03 s: too short to time
    left = RemainingTime(_model_estimate(fixed_s=0.0), clock=clock)
    for t, k in ((0.0, 1), (3.0, 2), (4.0, 3), (5.0, 4)):
        clock.t = t
        left.update(k / 100)
    assert left.seconds_left() == pytest.approx(96 * 5.0 / 3)


# --- item 13: the zero-spread rule in the sweep reference ------------------------------------------------------------
def test_the_sweep_reference_states_the_zero_spread_rule_at_each_spread(capsys):
    """``sins-sim schema sweep`` lists, for every spread key, that mean 0 and width 0 draw nothing and are refused
    (the rule the loader enforces: sins_sim.config.sweep), and the checked-in reference holds it
    (tests/test_schema_reference.py checks the whole file is current)."""
    from sins_sim.cli import main
    from sins_sim.config.sweep import SPREAD_PARAMETERS

    assert main(["schema", "sweep"]) == 0
    out = capsys.readouterr().out
    reference = (ROOT / "docs" / "scenario-reference.md").read_text()
    for key in SPREAD_PARAMETERS:
        rule = f"population.{key}: normal and uniform need a non-zero mean or width: mean 0 and width 0"
        assert any(line.strip().startswith(rule) for line in out.splitlines()), (key, out[-2000:])
        assert f"`population.{key}`: normal and uniform need a non-zero mean or width" in reference


# --- found by the new fuzz classes (tests/fuzz/families: navigate_inputs, effect_parameters) --------------------------
def _navigate_files(tmp_path, n=300):
    """A 3.9 s level flight north at 10 Hz and an ideal IMU's increments along it at 100 Hz."""
    from sins_sim.io import read_trajectory
    from sins_sim.models.motion import SampledTrajectory
    from sins_sim.simulation.external import ideal_increments

    lat = [45.0 + i * 100.0 / 10.0 / 6367000.0 * 180.0 / math.pi for i in range(40)]
    rows = ["time_s,lat_deg,lon_deg,height_m,roll_deg,pitch_deg,yaw_deg"]
    rows += [f"{i / 10:.1f},{lat[i]:.13f},7.0,1000.0,0.0,0.0,0.0" for i in range(40)]
    truth = tmp_path / "truth.csv"
    truth.write_text("\n".join(rows) + "\n")
    t = 0.01 * np.arange(1, n + 1)
    dth, dv = ideal_increments(SampledTrajectory.from_data(read_trajectory(truth)), t)
    return truth, t, dth, dv


@pytest.mark.parametrize(("edit", "message"), [
    (lambda t, a, v: (t, a * 1e300, v), r"dtheta_z_rad: row 300: .* deg/s, beyond the 1000 deg/s an RLG measures"),
    (lambda t, a, v: (t, a + math.radians(2000.0) * 0.01, v), r"dtheta_x_rad: row 1: 0\.3491 in one 0\.01 s interval "
                                                             r"is 2000 deg/s"),
    (lambda t, a, v: (t, a, 1000.0 * v), r"dv_z_m_s: row \d+: .* m/s\^2, beyond 2000 m/s\^2"),
])
def test_navigate_refuses_increments_no_imu_measures_naming_column_and_row(tmp_path, edit, message):
    """They were navigated and reported as 'diverged' (a run's result, not an input error)."""
    from sins_sim.jobs.navigate import navigate_file, write_increments

    truth, t, dth, dv = _navigate_files(tmp_path)
    write_increments(tmp_path / "inc.csv", *edit(t, dth, dv))
    with pytest.raises(ConfigError, match=r"inc\.csv: " + message):
        navigate_file(tmp_path / "inc.csv", truth, tmp_path / "out")
    assert not (tmp_path / "out").exists()


def test_navigate_takes_increments_from_the_truths_start_and_counts_rows_as_the_file(tmp_path):
    """Ten increments from t = 0: ``t[0] - dt`` came out -1.7e-18 s and was refused as 'before the truth's start';
    a repeated time is reported at the file's data row (counted from 1, as the cell errors are)."""
    from sins_sim.jobs.navigate import navigate_file, write_increments

    truth, t, dth, dv = _navigate_files(tmp_path, n=10)
    write_increments(tmp_path / "inc.csv", t, dth, dv)
    m = navigate_file(tmp_path / "inc.csv", truth, tmp_path / "out")
    assert m["filters"]["external"]["status"] == "ok"
    t2 = t.copy()
    t2[5] = t2[4]
    write_increments(tmp_path / "inc2.csv", t2, dth, dv)
    with pytest.raises(ConfigError, match=r"inc2\.csv: time_s: must be strictly increasing \(row 6 is not after "
                                          r"row 5\)"):
        navigate_file(tmp_path / "inc2.csv", truth, tmp_path / "out2")


@pytest.mark.parametrize(("effects", "message"), [
    ([{"name": ["piezo_lag"]}], r"effects\[0\]\.name: must be the name of an effect"),  # was TypeError: unhashable
    ([{"name": "piezo_lag", "tau_s": 1e-4}, {"name": "piezo_lag", "tau_s": 2e-4}],
     r"effects\[1\]: piezo_lag is already given for axis x, y, z by imu\.effects\[0\]"),
    ([{"name": "lock_in", "threshold_rad_s": 2e-3, "axes": ["x"]},
      {"name": "lock_in", "threshold_rad_s": 3e-3, "axes": ["y", "x"]}], r"lock_in is already given for axis x "),
])
def test_effect_lists_the_engine_cannot_run_are_refused_in_one_line(effects, message):
    from sins_sim.config.scenario import load_scenario

    with pytest.raises(ConfigError, match=message):
        load_scenario(_nav_scenario() | {"imu": {"channels": CHANNELS, "effects": effects}})


def test_one_effect_per_axis_on_different_axes_is_accepted():
    from sins_sim.config.imu import load_imu

    imu = load_imu({"channels": CHANNELS, "effects": [{"name": "lock_in", "threshold_rad_s": 2e-3, "axes": ["x"]},
                                                      {"name": "lock_in", "threshold_rad_s": 3e-3, "axes": ["y"]}]})
    assert len(imu.effects) == 2


def test_an_axis_coupling_into_an_unknown_axis_names_the_coefficient_key():
    from sins_sim.models.effects import make_effect

    with pytest.raises(ValueError, match=r"^effects\.axis_coupling\.coefficients\.q: 'q' is not one of the axes"):
        make_effect("axis_coupling", coefficients={"q": {"x": 0.01}}).check_axes(("x", "y", "z"))


def test_an_empty_yaml_value_is_called_null_not_nonetype(tmp_path):
    """Found by the fuzz's new 'internal' verdict: a truncated file left ``axis: [1, 0.3,`` -> ``None``, shown as
    Python's ``NoneType None``."""
    from sins_sim.config.imu import load_imu

    with pytest.raises(ConfigError) as exc:
        load_imu({"channels": {**CHANNELS, "x": {"f0_hz": None}}})
    assert "channels.x.f0_hz: must be a number, got null (an empty value)" in str(exc.value)
    assert "NoneType" not in str(exc.value)
