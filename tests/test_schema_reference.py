"""The input reference (``sins-sim schema``, ``docs/scenario-reference.md``): generated from the schemas, and current."""

from __future__ import annotations

from pathlib import Path

import pytest

from sins_sim.cli import main
from sins_sim.io.trajectory import TRAJECTORY_COLUMNS
from sins_sim.config.reference import FORMATS, REGENERATE, render_markdown, render_text, rows
from sins_sim.config.schema import Map, Num, describe

ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "scenario-reference.md"


def test_the_checked_in_reference_is_current():
    current = render_markdown()
    assert DOC.is_file(), f"{DOC} is missing: regenerate it with `{REGENERATE}`"
    assert DOC.read_text() == current, (
        f"{DOC.relative_to(ROOT)} is out of date with the schemas: regenerate it with `{REGENERATE}` "
        "(from the repository root) and commit it")


@pytest.mark.parametrize("fmt", list(FORMATS))
def test_schema_command_prints_every_key_with_unit_range_and_default(capsys, fmt):
    assert main(["schema", fmt]) == 0
    out = capsys.readouterr().out
    for r in rows(fmt):
        if r["kind"] in ("rule", "variant"):
            assert r["doc"] in out
            continue
        line = next((ln for ln in out.splitlines() if ln.split(" ", 1)[0] == r["key"]), None)
        assert line is not None, r["key"]
        assert f"default {r['default']}" in line and (r["range"] or r["kind"]) in line
        if r["unit"]:
            assert f"[{r['unit']}]" in line


def test_scenario_reference_examples(capsys):
    assert main(["schema", "scenario"]) == 0
    out = capsys.readouterr().out
    lines = {ln.split(" ", 1)[0]: ln for ln in out.splitlines() if ln and not ln.startswith(" ")}
    assert "[s]" in lines["duration_s"] and "(0, 9.0072e+09]" in lines["duration_s"]
    amp = lines["motion[type=sines].amplitude_arcmin"]
    assert "[arcmin]" in amp and "[0, 600] each" in amp and "default required" in amp
    assert "default 45" in lines["site.lat_deg"] and "[-89, 89]" in lines["site.lat_deg"]
    assert "one of two_sample" not in lines["navigation.coning"] and "none, two_sample, three_sample" in \
        lines["navigation.coning"]
    assert "filter Nyquist" in out  # the rules across keys are listed
    assert main(["schema", "imu"]) == 0
    imu = capsys.readouterr().out
    assert any(ln.startswith("suspension.k5_rad_per_v") and "[-0.01, 0.01], != 0" in ln for ln in imu.splitlines())


def test_trajectory_reference_comes_from_the_column_constants(capsys):
    assert main(["schema", "trajectory"]) == 0
    out = capsys.readouterr().out
    for col in TRAJECTORY_COLUMNS:
        assert any(ln.startswith(col + " ") for ln in out.splitlines()), col


def test_reference_follows_the_schema_objects():
    spec = Map({"speed": Num(unit="m_s", min=0.0, max=12.5, default=3.0, doc="how fast")})
    (row,) = describe(spec)
    assert row == {"key": "speed_m_s", "kind": "number", "unit": "m/s", "range": "[0, 12.5]", "default": "3",
                   "doc": "how fast"}


def test_schema_command_all_formats_and_markdown(capsys):
    assert main(["schema"]) == 0
    out = capsys.readouterr().out
    assert all(f"# {fmt}: " in out for fmt in FORMATS)
    assert main(["schema", "--markdown"]) == 0
    assert capsys.readouterr().out == render_markdown()
    assert render_text("imu").startswith("# imu: ")


def test_schema_command_refuses_an_unknown_format(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["schema", "nonsense"])
    assert exc.value.code == 2
    assert capsys.readouterr().err.startswith("sins-sim: error: argument format: invalid choice")


def test_imu_reference_lists_every_sensor_key():
    """The sensors section is parsed by its own loader; its reference rows come from the same field specs,
    so every key the loader accepts is listed with a unit and a range."""
    from sins_sim.config.reference import rows
    from sins_sim.models.sensor_errors import _ACCEL_KEYS, _GYRO_KEYS

    listed = {r["key"]: r for r in rows("imu")}
    for section, keys in (("gyro", _GYRO_KEYS), ("accelerometer", _ACCEL_KEYS)):
        for key in keys:
            row = listed[f"sensors.{section}.{key}"]
            assert row["range"] and row["doc"], key
