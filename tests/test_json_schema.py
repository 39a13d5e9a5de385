"""``sins-sim schema FORMAT --json-schema``: a JSON Schema for editors, generated from the validator's own schema.

Checked with the independent ``jsonschema`` implementation: the bundled files validate against it, and the
mistakes the loader refuses one key at a time (a misspelt key, a value out of range, a wrong choice, a
missing required key) are flagged by it too, at the same key path.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from sins_sim.cli import main
from sins_sim.config.reference import JSON_SCHEMA_FORMATS, render_json_schema
from sins_sim.config.schema import Map, Num, OneOf, Str, Vec, _yaml_key, json_schema
from sins_sim.config.yaml_io import load_yaml

jsonschema = pytest.importorskip("jsonschema")

ROOT = Path(__file__).resolve().parents[1]

BUNDLED = ([(p, "imu") for p in sorted((ROOT / "configs").glob("*.yaml"))]
           + [(p, "sweep") for p in sorted((ROOT / "scenarios").glob("sweep-*.yaml"))]
           + [(p, "scenario") for p in sorted((ROOT / "scenarios").glob("*.yaml")) if not p.name.startswith("sweep-")]
           + [(p, "experiment") for p in sorted((ROOT / "scenarios" / "experiments").glob("*.yaml"))]
           + [(p, "log") for p in sorted((ROOT / "scenarios" / "logs").glob("*.yaml"))])


def _validator(fmt):
    schema = json.loads(render_json_schema(fmt))
    jsonschema.Draft202012Validator.check_schema(schema)  # a valid draft 2020-12 schema
    return jsonschema.Draft202012Validator(schema)


def _errors(fmt, doc) -> list:
    return [(list(e.absolute_path), e.message) for e in _validator(fmt).iter_errors(doc)]


def test_every_format_exports_a_valid_draft_2020_12_schema(capsys):
    for fmt in JSON_SCHEMA_FORMATS:
        assert main(["schema", fmt, "--json-schema"]) == 0
        schema = json.loads(capsys.readouterr().out)
        assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"
        jsonschema.Draft202012Validator.check_schema(schema)


@pytest.mark.parametrize("path,fmt", BUNDLED, ids=[p.name for p, _ in BUNDLED])
def test_bundled_files_validate(path, fmt):
    assert _errors(fmt, load_yaml(path)) == []


def test_misspelt_key_is_flagged_where_it_is():
    doc = load_yaml(ROOT / "scenarios" / "stationary.yaml")
    doc.setdefault("navigation", {})["conig"] = "two_sample"
    errors = _errors("scenario", doc)
    assert len(errors) == 1
    path, message = errors[0]
    assert path == ["navigation"] and "'conig' was unexpected" in message


@pytest.mark.parametrize("edit,where,words", [
    (lambda d: d.update(duration_s=-1.0), ["duration_s"], "less than or equal to the minimum"),
    (lambda d: d.setdefault("navigation", {}).update(coning="five_sample"), ["navigation", "coning"], "is not one of"),
    (lambda d: d.pop("name"), [], "'name' is a required property"),
    (lambda d: d.update(motion=[{"type": "wobble"}]), ["motion", 0, "type"], "is not one of"),
    (lambda d: d.update(motion=[{"type": "static", "amplitude_arcmin": 1.0}]), ["motion", 0],
     "'amplitude_arcmin' was unexpected"),
    (lambda d: d.update(seed=1.5), ["seed"], "is not of type 'integer'"),
])
def test_what_the_loader_refuses_is_flagged(edit, where, words):
    doc = load_yaml(ROOT / "scenarios" / "stationary.yaml")
    edit(doc)
    errors = _errors("scenario", doc)
    assert any(path == where and words in message for path, message in errors), errors


def test_filter_parameters_shorthands_are_accepted():
    doc = load_yaml(ROOT / "configs" / "default-imu.yaml")
    for value in (True, "true", "nominal", {"source": True}, {"source": "explicit", "f0": "given"}):
        assert _errors("imu", {**doc, "filter_parameters": value}) == [], value
    assert _errors("imu", {**doc, "filter_parameters": "explicit"})  # needs the mapping


def test_generated_from_the_schema_objects():
    """Units in the key names, ranges, choices, defaults and the variants come from the same objects."""
    spec = Map({"rate": Num(unit="hz", min=0.0, min_exclusive=True, required=True, doc="r"),
                "gain": Num(min=-1.0, max=1.0, nonzero=True, default=0.5),
                "mode": Str(choices=("a", "b"), default="a"),
                "axis": Vec(n=3, unit="deg", min=-90.0, max=90.0),
                "part": OneOf({"x": Map({"k": Num(unit="s", required=True)}), "y": Map({})})})
    js = json_schema(spec)
    assert js["required"] == ["rate_hz"] and js["additionalProperties"] is False
    assert js["properties"]["rate_hz"] == {"type": "number", "exclusiveMinimum": 0.0, "description": "[Hz] r"}
    assert js["properties"]["gain"] == {"type": "number", "minimum": -1.0, "maximum": 1.0, "not": {"const": 0},
                                        "default": 0.5}
    assert js["properties"]["mode"] == {"type": "string", "enum": ["a", "b"], "default": "a"}
    assert js["properties"]["axis_deg"]["minItems"] == js["properties"]["axis_deg"]["maxItems"] == 3
    v = jsonschema.Draft202012Validator(js)
    assert v.is_valid({"rate_hz": 1, "part": {"type": "x", "k_s": 2}})
    assert not v.is_valid({"rate_hz": 1, "part": {"type": "x"}})  # k_s required in variant x
    assert not v.is_valid({"rate_hz": 1, "part": {"type": "y", "k_s": 2}})  # variant y has no k_s
    assert not v.is_valid({"rate_hz": 0})  # exclusive minimum
    assert not v.is_valid({"rate_hz": 1, "gain": 0})  # nonzero


def test_every_scenario_key_is_a_property():
    """The navigation section (keys and units) is the validator's, key for key."""
    from sins_sim.config.scenario import SCENARIO_SCHEMA

    nav = SCENARIO_SCHEMA.fields["navigation"]
    expected = {_yaml_key(k, getattr(s, "unit", None)) for k, s in nav.fields.items()}
    schema = json.loads(render_json_schema("scenario"))
    assert set(schema["properties"]["navigation"]["properties"]) == expected
    assert set(schema["properties"]) == {_yaml_key(k, getattr(s, "unit", None))
                                         for k, s in SCENARIO_SCHEMA.fields.items()}


def test_trajectory_and_bad_flags_are_one_line_errors(capsys):
    assert main(["schema", "trajectory", "--json-schema"]) == 2
    assert "CSV or Parquet" in capsys.readouterr().err
    assert main(["schema", "--json-schema"]) == 2
    assert "name the format" in capsys.readouterr().err
