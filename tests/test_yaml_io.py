"""YAML as people write it (sins_sim.config.yaml_io): YAML 1.2 numbers, duplicate keys, one-line errors."""

from __future__ import annotations

import math
import os
import re
from pathlib import Path

import pytest
import yaml

from sins_sim.config.errors import ConfigError
from sins_sim.config.yaml_io import StrictLoader, load_yaml, parse_yaml

ROOT = Path(__file__).resolve().parents[1]


def _write(tmp_path, text, name="c.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def _error(path) -> str:
    with pytest.raises(ConfigError) as exc:
        load_yaml(path)
    msg = str(exc.value)
    assert "\n" not in msg, msg
    assert str(path) in msg, msg
    return msg


# --- numbers -----------------------------------------------------------------------------------------
@pytest.mark.parametrize("text, value", [
    ("3e0", 3.0), ("1e-3", 1e-3), ("1E+9", 1e9), (".5", 0.5), ("-2.5e-3", -2.5e-3), ("+.5e1", 5.0),
    ("1.5", 1.5), ("1.", 1.0), ("1.0e+3", 1e3), ("1_000.5", 1000.5), ("-.inf", -math.inf),
])
def test_yaml_12_floats_are_numbers(tmp_path, text, value):
    doc = load_yaml(_write(tmp_path, f"k: {text}\nnested: {{a: [{text}]}}\n"))
    assert isinstance(doc["k"], float) and doc["k"] == value
    assert doc["nested"]["a"] == [value]


def test_nan_is_a_float():
    assert math.isnan(parse_yaml("k: .nan")["k"])


@pytest.mark.parametrize("text, value", [("'3e0'", "3e0"), ('"1e-3"', "1e-3"), ("e5", "e5"), ("1e", "1e"),
                                         ("._", "._"), ("7", 7), ("-12", -12), ("1_000", 1000), ("0x1F", 31)])
def test_strings_stay_strings_and_integers_stay_integers(tmp_path, text, value):
    doc = load_yaml(_write(tmp_path, f"k: {text}\n"))
    assert doc["k"] == value and type(doc["k"]) is type(value)


def test_the_global_safe_loader_is_untouched():
    assert yaml.safe_load("k: 1e-3") == {"k": "1e-3"}  # PyYAML's YAML 1.1 rule, for everyone else
    assert yaml.load("k: 1e-3", Loader=StrictLoader) == {"k": 1e-3}
    assert StrictLoader.yaml_implicit_resolvers is not yaml.SafeLoader.yaml_implicit_resolvers


def test_a_config_with_exponent_numbers_loads(tmp_path):
    """The reason for the change: ``k1: 1.75e-4`` works in PyYAML, ``k1: 175e-6`` did not (a string)."""
    from sins_sim.config.imu import imu_from_dict

    doc = load_yaml(_write(tmp_path, "suspension: {k1: 175e-6, k5_rad_per_v: -12e-6}\n"
                                     "channels: {x: {f0_hz: 386}, y: {f0_hz: 352}, z: {f0_hz: 4.21e2}}\n"))
    imu = imu_from_dict(doc, "c.yaml")
    assert imu.channels[0].suspension.k1 == pytest.approx(1.75e-4)
    assert imu.channels[2].suspension.f0_hz == 421.0


# --- duplicate keys --------------------------------------------------------------------------------
def test_duplicate_top_level_key_names_both_lines(tmp_path):
    path = _write(tmp_path, "name: a\nseed: 1\nduration_s: 4\nimu: x.yaml\n\nmotion: []\nduration_s: 8\n")
    assert _error(path) == f"{path}: duplicate key 'duration_s' at lines 3 and 7"


@pytest.mark.parametrize("text, key, lines", [
    ("a:\n  b:\n    c: 1\n    d: 2\n    c: 3\n", "c", (3, 5)),
    ("m: {x: 1, y: 2, x: 3}\n", "x", (1, 1)),
    ("l:\n  - {p: 1}\n  - p: 1\n    q: 2\n    p: 3\n", "p", (3, 5)),
])
def test_duplicate_nested_keys(tmp_path, text, key, lines):
    path = _write(tmp_path, text)
    assert f"duplicate key '{key}' at lines {lines[0]} and {lines[1]}" in _error(path)


def test_merge_keys_may_be_overridden(tmp_path):
    doc = load_yaml(_write(tmp_path, "base: &b {a: 1, b: 2}\nd:\n  <<: *b\n  a: 3\n"))
    assert doc["d"] == {"a": 3, "b": 2}


# --- every failure is one line naming the file ---------------------------------------------------------
def test_missing_file(tmp_path):
    assert "no such file" in _error(tmp_path / "nope.yaml")


def test_directory(tmp_path):
    assert "is a directory" in _error(tmp_path)


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="root reads any file")
def test_unreadable_file(tmp_path):
    path = _write(tmp_path, "a: 1\n")
    path.chmod(0)
    try:
        assert "cannot read" in _error(path)
    finally:
        path.chmod(0o644)


def test_not_utf8(tmp_path):
    path = tmp_path / "b.yaml"
    path.write_bytes(b"a: \xff\xfe\x00\n")
    assert "not UTF-8" in _error(path)


@pytest.mark.parametrize("text, where", [("a: [1, 2\n", "line 2, column 1"), ("a: b: c\n", "line 1, column 5"),
                                         ("a: 1\n b: 2\n", "line 2")])
def test_malformed_yaml_names_line_and_column(tmp_path, text, where):
    msg = _error(_write(tmp_path, text))
    assert "malformed YAML" in msg and where in msg, msg


def test_deep_nesting_is_a_clean_error(tmp_path):
    msg = _error(_write(tmp_path, "a: " + "[" * 5000 + "]" * 5000 + "\n"))
    assert "malformed YAML" in msg


@pytest.mark.parametrize("text, got", [("- 1\n- 2\n", "list"), ("", "an empty file"), ("3e0\n", "float")])
def test_top_level_must_be_a_mapping(tmp_path, text, got):
    msg = _error(_write(tmp_path, text))
    assert "top level must be a mapping" in msg and got in msg


def test_imu_module_still_exports_load_yaml():
    from sins_sim.config import imu, yaml_io
    assert imu.load_yaml is yaml_io.load_yaml
    assert "load_yaml" in imu.__all__


def test_every_bundled_yaml_file_loads():
    """No bundled file relied on a duplicate key or on a 1.1-only reading of a number."""
    files = sorted((ROOT / "configs").glob("*.yaml")) + sorted((ROOT / "scenarios").glob("*.yaml"))
    assert files
    for path in files:
        assert isinstance(load_yaml(path), dict), path


# --- scenarios/turn-with-vibration.yaml: the description's numbers ---------------------------------------
def test_turn_description_gives_the_z_axis_loss():
    """The turn is about z; the text must quote eq. 5's paper-form loss at z's f0 (not x's 386 Hz)."""
    from sins_sim.config.imu import load_imu

    path = ROOT / "scenarios" / "turn-with-vibration.yaml"
    doc = load_yaml(path)
    turn = next(m for m in doc["motion"] if m["type"] == "turn")
    assert turn["axis"] == [0, 0, 1]
    imu = load_imu((path.parent / doc["imu"]).resolve())
    z = imu.channels[2]
    design = z.correcting_design("paper")
    b = design.dc_gain
    assert b == pytest.approx(2 * (1 - math.cos(design.w)) / design.w ** 2)
    loss_arcmin = (1.0 - b) * turn["angle_deg"] * 60.0
    text = " ".join(doc["description"].split())
    assert f"f0 = {z.suspension.f0_hz:g} Hz" in text
    assert f"B = 2 (1 - cos w) / w^2 = {b:.5f}" in text
    pct = float(re.search(r"1 - B = ([0-9.]+) %", text).group(1))
    assert pct == pytest.approx(100 * (1 - b), abs=0.005)
    arcmin = float(re.search(r"about ([0-9.]+) arcmin", text).group(1))
    assert arcmin == pytest.approx(loss_arcmin, abs=0.5)
