"""Configuration errors that say where: ``file:line:column``, and "did you mean" for a misspelt key."""

from __future__ import annotations

import pickle
import textwrap
from pathlib import Path

import pytest
import yaml

from sins_sim._validate import unknown_key
from sins_sim.cli import main
from sins_sim.config.imu import load_imu
from sins_sim.config.scenario import load_scenario
from sins_sim.config.schema import ConfigError, Map, Num, Str, validate
from sins_sim.config.yaml_io import StrictLoader, key_marks, load_yaml

ROOT = Path(__file__).resolve().parents[1]
IMU = ROOT / "configs" / "default-imu.yaml"


def _write(tmp_path, name, text) -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text).lstrip())
    return path


def _scenario(tmp_path, body: str) -> Path:
    return _write(tmp_path, "s.yaml", f"name: s\nimu: {IMU}\n" + textwrap.dedent(body).lstrip())


# --- did you mean -------------------------------------------------------------------------------------------------
def test_misspelt_key_gets_the_closest_allowed_key():
    spec = Map({"coning": Str(default="two_sample"), "sculling": Str(default="two_sample")})
    with pytest.raises(ConfigError) as exc:
        validate({"conig": "x"}, spec, "f.yaml", "navigation")
    assert str(exc.value) == ("f.yaml: navigation.conig: unknown key; did you mean 'coning'? "
                              "(allowed: coning, sculling)")


def test_misspelt_key_with_a_unit_suffix_finds_the_key_with_its_unit():
    spec = Map({"amplitude": Num(unit="arcmin", default=1.0), "frequency": Num(unit="hz", default=1.0)})
    with pytest.raises(ConfigError, match=r"amplitud_arcmin: unknown key; did you mean 'amplitude_arcmin'\?"):
        validate({"amplitud_arcmin": 1.0}, spec, "f.yaml")
    # a known name with a wrong unit keeps its own, more precise rule
    with pytest.raises(ConfigError, match=r"amplitude_deg: unknown unit in 'amplitude_deg': write amplitude_arcmin$"):
        validate({"amplitude_deg": 1.0}, spec, "f.yaml")


def test_no_suggestion_when_nothing_is_close():
    assert unknown_key("zzz", ["coning", "sculling"]) == "unknown key (allowed: coning, sculling)"


def test_sensor_section_suggests_too(tmp_path):
    """The sensors section is parsed once the rest of the file has passed its schema (the parser needs the models;
    the schema does not, issue 23): a file whose only error is in ``sensors`` gets the suggestion there."""
    path = _write(tmp_path, "imu.yaml", """
        sensors:
          gyro:
            arw_deg_rt_h: 0.001
          acelerometer: {}
        channels: {x: {f0_hz: 386}, y: {f0_hz: 352}, z: {f0_hz: 421}}
    """)
    with pytest.raises(ConfigError) as exc:
        load_imu(path)
    assert str(exc.value).startswith(f"{path}:4:3: sensors.acelerometer: unknown key; did you mean 'accelerometer'?")


# --- file:line:column ---------------------------------------------------------------------------------------------
def test_unknown_key_names_file_line_and_column(tmp_path):
    path = _scenario(tmp_path, """
        duration_s: 10
        navigation:
          coning: two_sample
          conig: three_sample
    """)
    with pytest.raises(ConfigError) as exc:
        load_scenario(path)
    assert str(exc.value).startswith(f"{path}:6:3: navigation.conig: unknown key; did you mean 'coning'? (allowed: ")


def test_value_error_names_the_line_of_its_key(tmp_path):
    path = _scenario(tmp_path, """
        duration_s: -10
    """)
    with pytest.raises(ConfigError) as exc:
        load_scenario(path)
    assert str(exc.value) == f"{path}:3:1: duration_s: must be > 0, got -10"


def test_list_items_and_missing_keys_point_at_the_item(tmp_path):
    path = _scenario(tmp_path, """
        duration_s: 10
        motion:
          - type: static
          - type: coning
            frequency_hz: 1.0
    """)
    with pytest.raises(ConfigError) as exc:
        load_scenario(path)
    # amplitude is required and absent: the error points at the entry that lacks it
    assert str(exc.value) == f"{path}:6:5: motion[1].amplitude_arcmin: is required"


def test_errors_in_an_imu_file_named_by_a_scenario_give_the_imu_files_line(tmp_path):
    imu = _write(tmp_path, "imu.yaml", """
        name: mine
        drive:
          amplitud_arcmin: 3.0
    """)
    path = _write(tmp_path, "s.yaml", "name: s\nimu: imu.yaml\nduration_s: 10\n")
    with pytest.raises(ConfigError) as exc:
        load_scenario(path)
    assert str(exc.value).startswith(f"{path} -> imu.yaml:3:3: drive.amplitud_arcmin: unknown key; "
                                     "did you mean 'amplitude_arcmin'?")
    with pytest.raises(ConfigError, match=rf"^{imu}:3:3: drive\.amplitud_arcmin: unknown key"):
        load_imu(imu)


def test_an_overridden_key_points_nowhere_in_the_file(tmp_path):
    """``--seed`` replaces the file's seed: a bad value is the command line's, so no line of the file."""
    path = _scenario(tmp_path, """
        duration_s: 10
        seed: 3
    """)
    with pytest.raises(ConfigError) as exc:
        load_scenario(path, overrides={"seed": -1})
    assert str(exc.value) == f"{path}: seed: must be >= 0, got -1"


def test_merge_keys_point_at_where_the_value_is_written(tmp_path):
    path = _write(tmp_path, "m.yaml", """
        base: &b
          coning: two_sample
          conig: x
        navigation:
          <<: *b
          sculling: none
    """)
    marks = key_marks(yaml.compose(path.read_text(), Loader=StrictLoader))
    assert marks[("navigation",)] == (4, 1) and marks[("navigation", "sculling")] == (6, 3)
    doc = load_yaml(path)  # registers the marks
    assert doc["navigation"]["conig"] == "x"
    with pytest.raises(ConfigError) as exc:
        validate(doc["navigation"], Map({"coning": Str(), "sculling": Str()}), str(path), "navigation")
    # the merged key's own position: line 3 of the anchored mapping
    assert str(exc.value).startswith(f"{path}:3:3: navigation.conig: unknown key; did you mean 'coning'?")


def test_the_cli_prints_file_line_and_suggestion(tmp_path, capsys):
    path = _scenario(tmp_path, """
        duration_s: 10
        duraton_s: 4
    """)
    assert main(["run", str(path), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"sins-sim: error: {path}:4:1: duraton_s: unknown key; did you mean 'duration_s'?")


def test_a_located_error_survives_pickling_unchanged(tmp_path):
    """Errors cross process boundaries (sweep workers): the position is added once, not again."""
    path = _scenario(tmp_path, "duration_s: -1\n")
    with pytest.raises(ConfigError) as exc:
        load_scenario(path)
    again = pickle.loads(pickle.dumps(exc.value))
    assert str(again) == str(exc.value) == f"{path}:3:1: duration_s: must be > 0, got -1"


def test_an_alias_bomb_is_walked_once():
    text = "a: &a [1, 2]\nb: &b [*a, *a, *a, *a]\nc: &c [*b, *b, *b, *b]\nd: [*c, *c, *c, *c]\n"
    marks = key_marks(yaml.compose(text, Loader=StrictLoader))
    assert len(marks) < 30  # 4 keys + the items of each list node once, not 4^3 copies
