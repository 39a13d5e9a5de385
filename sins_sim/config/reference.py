"""The reference of every input format: each key with its unit, range and default, from the schemas themselves.

``sins-sim schema [FORMAT]`` prints it; ``sins-sim schema --markdown`` writes the checked-in
``docs/scenario-reference.md`` (``tests/test_schema_reference.py`` fails when that file is out of date).
Nothing here is written by hand twice: the YAML formats come from their schema objects
(:func:`sins_sim.config.schema.describe`), the trajectory file format from the column constants of
:mod:`sins_sim.io.trajectory`.
"""

from __future__ import annotations

__all__ = ["FORMATS", "JSON_SCHEMA_FORMATS", "rows", "render_text", "render_markdown", "render_json_schema",
           "REGENERATE"]

#: The formats, in the order the reference lists them, with one line on what each file is.
FORMATS = {
    "scenario": "a mission for `sins-sim run` (scenarios/*.yaml)",
    "imu": "an IMU configuration (configs/*.yaml, or inline under a scenario's `imu` key)",
    "experiment": "an experiment for `sins-sim simulate-recording`",
    "trajectory": "a trajectory file (CSV or Parquet) named by a scenario's `trajectory.file`",
    "sweep": "a Monte Carlo sweep for `sins-sim sweep` (scenarios/sweep-*.yaml)",
    "log": "a unit's log description for `sins-sim import-log LOG --describe LOG.yaml`",
}
#: The YAML formats a JSON Schema is exported for (a trajectory file is a CSV/Parquet table, not YAML).
JSON_SCHEMA_FORMATS = ("scenario", "imu", "experiment", "sweep", "log")
#: How to regenerate the checked-in reference.
REGENERATE = "sins-sim schema --markdown > docs/scenario-reference.md"


def _schema(fmt: str):
    if fmt == "scenario":
        from sins_sim.config.scenario import SCENARIO_SCHEMA

        return SCENARIO_SCHEMA
    if fmt == "imu":
        from sins_sim.config.imu import IMU_SCHEMA

        return IMU_SCHEMA
    if fmt == "experiment":
        from sins_sim.config.experiment import EXPERIMENT_SCHEMA

        return EXPERIMENT_SCHEMA
    if fmt == "sweep":
        from sins_sim.config.sweep import SWEEP_SCHEMA

        return SWEEP_SCHEMA
    if fmt == "log":
        from sins_sim.config.log import LOG_SCHEMA

        return LOG_SCHEMA
    raise ValueError(f"FORMAT: must be one of {list(FORMATS)}, got {fmt!r}")


def _trajectory_rows() -> list:
    from sins_sim.io import trajectory as tj

    unit_of = {"s": "s", "deg": "deg", "m": "m", "m_s": "m/s"}
    rules = {
        "time_s": (f"strictly increasing, steps <= {tj.MAX_TIME_STEP_S:g} s", "sample time (rate >= 1 Hz, spacing "
                                                                             "need not be uniform)"),
        "lat_deg": (f"[-{tj.MAX_ABS_LAT_DEG:g}, {tj.MAX_ABS_LAT_DEG:g}]",
                    f"geodetic latitude (WGS-84); not nearer the poles: {tj.POLE_REASON}"),
        "lon_deg": ("[-360, 360]", "longitude"),
        "height_m": (f"[{tj.HEIGHT_RANGE_M[0]:g}, {tj.HEIGHT_RANGE_M[1]:g}]", "height above the WGS-84 ellipsoid"),
        "roll_deg": ("[-360, 360]", "Euler angles body (x forward, y right, z down) w.r.t. NED, sequence 3-2-1"),
        "pitch_deg": ("(-90, 90)", "pitch"),
        "yaw_deg": ("[-360, 360]", "yaw (heading)"),
        "vn_m_s": (f"|v| <= {tj.MAX_SPEED_M_S:g}", "NED ground velocity: all three columns or none; a measurement "
                                                  "(see the rule on velocity columns)"),
        "ve_m_s": (f"|v| <= {tj.MAX_SPEED_M_S:g}", "east velocity"),
        "vd_m_s": (f"|v| <= {tj.MAX_SPEED_M_S:g}", "down velocity"),
    }
    out = []
    for col in tj.TRAJECTORY_COLUMNS:
        unit = unit_of[col.split("_", 1)[1]]
        rng, doc = rules.get(col, ("", ""))
        out.append({"key": col, "kind": "column", "unit": unit, "range": rng,
                    "default": "required" if col in tj.REQUIRED_COLUMNS else "optional", "doc": doc})
    for text in (f"at least {tj.MIN_ROWS} rows; every cell a finite decimal number (no NaN, inf or empty cell); no "
                 "other columns, each at most once, any order",
                 f"between rows the position moves at most {tj.MAX_SPEED_M_S:g} m/s and each Euler angle changes by "
                 f"less than {tj.MAX_ANGLE_STEP_DEG:g} deg and at most {tj.MAX_ANGLE_RATE_DEG_S:g} deg/s (roll and "
                 "yaw the shorter way round)",
                 "CSV: one header row; `#` comment lines only before it, blank lines only at the end; Parquet "
                 "(.parquet, .pq): the same columns, numeric, no nulls",
                 "velocity columns are a measurement: the truth is a smoothing fit of positions and velocities "
                 "together (fixed-interval Rauch-Tung-Striebel smoother, constant-acceleration model, noise levels "
                 "from the file: sins_sim.models.motion.smoothing), with its RMS residuals in metrics.json "
                 "(mission.trajectory_fit) and the report; a velocity column that differs from the velocity of the "
                 "positions' own fit by more than the scenario's trajectory.velocity_tolerance_m_s (default 1 m/s) "
                 "at some row is refused naming the row and the column; without velocity columns the positions are "
                 "interpolated (a quintic spline) and should be written to ~1e-13 deg / 1e-8 m"):
        out.append({"key": "(file)", "kind": "rule", "unit": "", "range": "", "default": "", "doc": text})
    return out


def rows(fmt: str) -> list:
    """The reference rows of one format (keys ``key, kind, unit, range, default, doc``)."""
    if fmt == "trajectory":
        return _trajectory_rows()
    from sins_sim.config.schema import describe

    return describe(_schema(fmt))


def render_text(fmt: str) -> str:
    """One line per key (``key [unit]  range  default  -- what it is``), rules at the end."""
    rs = rows(fmt)
    keys = [r for r in rs if r["kind"] != "rule"]
    width = max(len(r["key"]) for r in keys) if keys else 10
    lines = [f"# {fmt}: {FORMATS[fmt]}", ""]
    for r in keys:
        if r["kind"] == "variant":
            lines.append(f"{r['key']}  -- {r['doc']}".rstrip(" -"))
            continue
        unit = f"[{r['unit']}]" if r["unit"] else ""
        doc = f"  -- {r['doc']}" if r["doc"] else ""
        lines.append(f"{r['key']:<{width}}  {unit:<15} {r['range'] or r['kind']:<28} default {r['default']}{doc}")
    rules = [r for r in rs if r["kind"] == "rule"]
    if rules:
        lines += ["", "rules across keys:"] + [f"  {r['key']}: {r['doc']}" for r in rules]
    return "\n".join(lines) + "\n"


def _cell(text) -> str:
    return str(text).replace("|", "\\|")


def render_markdown(formats=None) -> str:
    """The whole reference as Markdown (``docs/scenario-reference.md``)."""
    formats = list(formats or FORMATS)
    out = ["# Input reference", "",
           "Every key of sins-sim's input formats with its unit, range and default. Generated from the schema "
           f"objects by `sins-sim schema --markdown` (do not edit by hand: `{REGENERATE}`; "
           "`tests/test_schema_reference.py` fails when this file is out of date). Units are part of the key "
           "names (`_hz`, `_s`, `_arcmin`, ...); lists are written `key[]`, the variants of a list of typed "
           "entries `key[type=NAME]`. A value outside its range is refused with one line naming the key; "
           "an unusual but legal value draws a one-line warning.", "",
           "Editors: `sins-sim schema FORMAT --json-schema > sins-sim-FORMAT.schema.json` (scenario, imu, "
           "experiment, sweep, log) writes a JSON Schema generated from the same schemas; with the first line "
           "`# yaml-language-server: $schema=sins-sim-scenario.schema.json` (a path relative to the YAML file, or "
           "a URL) an editor with yaml-language-server (VS Code's YAML extension, Neovim, Helix, ...) completes "
           "the keys with their units and underlines a misspelt key or a value out of range as you type.", ""]
    for fmt in formats:
        out += [f"## {fmt}", "", f"{FORMATS[fmt][0].upper()}{FORMATS[fmt][1:]}.", "",
                "| key | unit | range | default | description |", "|---|---|---|---|---|"]
        rs = rows(fmt)
        for r in rs:
            if r["kind"] == "rule":
                continue
            if r["kind"] == "variant":
                out.append(f"| **`{_cell(r['key'])}`** | | | | {_cell(r['doc'])} |")
                continue
            out.append(f"| `{_cell(r['key'])}` | {_cell(r['unit'])} | {_cell(r['range'] or r['kind'])} | "
                       f"{_cell(r['default'])} | {_cell(r['doc'])} |")
        rules = [r for r in rs if r["kind"] == "rule"]
        if rules:
            out += ["", "Rules across keys:", ""] + [f"- `{r['key']}`: {r['doc']}" for r in rules]
        out.append("")
    return "\n".join(out)


def render_json_schema(fmt: str) -> str:
    """The JSON Schema (draft 2020-12) of a YAML format, as JSON text, for editors.

    Generated from the schema the loader validates with (:func:`sins_sim.config.schema.json_schema`).
    Save it and point yaml-language-server (VS Code's YAML extension, Neovim, Helix...) at it with a
    modeline on the first line of a scenario file::

        # yaml-language-server: $schema=../sins-sim-scenario.schema.json

    The editor then completes keys (with their unit suffixes), shows each key's unit, range and default,
    and underlines a misspelt key or a value out of range as you type. The rules that involve several
    keys stay with ``sins-sim run``'s loader.
    """
    import json

    from sins_sim.config.schema import JSON_SCHEMA_DIALECT, json_schema

    if fmt not in JSON_SCHEMA_FORMATS:
        raise ValueError(f"--json-schema: a JSON Schema exists for the YAML formats {list(JSON_SCHEMA_FORMATS)}; "
                         f"{fmt!r} is {FORMATS.get(fmt, 'not a format')} (sins-sim schema {fmt} lists its columns)")
    out = {"$schema": JSON_SCHEMA_DIALECT, "title": f"sins-sim {fmt}",
           "description": f"{FORMATS[fmt][0].upper()}{FORMATS[fmt][1:]}. Generated by "
                          f"`sins-sim schema {fmt} --json-schema`; the full rules: `sins-sim schema {fmt}`.",
           **json_schema(_schema(fmt))}
    return json.dumps(out, indent=2) + "\n"
