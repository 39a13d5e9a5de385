"""A seeded generator of mutated inputs: scenario, IMU and experiment YAML files, recordings, trajectory files
and ``channel`` command lines.

Every case starts from a valid input and applies one mutation of one class (:data:`CLASSES`); it carries
what the run must end in (``expect``):

* ``valid``: the input is legal, the run must accept it;
* ``invalid``: the input is illegal, the run must refuse it in one line naming a field;
* ``either``: acceptance depends on where a cut or a flipped byte lands; only a traceback or a hang fails.

A case the format cannot tell apart today carries ``gap``: the reason, naming the module that would have
to change (for example a recording's header holding a duplicate JSON key, which ``json`` resolves by keeping
the last). Gaps are counted apart so that they stay visible.

``generate(n, seed)`` is deterministic: the same ``n`` and ``seed`` give the same cases, byte for byte
(the recordings are simulated once, from their own seed).
"""

from __future__ import annotations

import copy
import io
import json
import math
import random
import zipfile
from dataclasses import dataclass, field
from decimal import Decimal
from pathlib import Path

import numpy as np
import yaml

from .families import families

ROOT = Path(__file__).resolve().parents[2]

#: Mutation classes (issue 12: the classes of the fuzz campaign).
CLASSES = ("valid", "wrong_type", "missing_key", "unknown_key", "out_of_range", "nan_inf", "huge_size",
           "duplicate_key", "malformed", "truncated_corrupted", "wrong_units")
#: Input kinds and their share of the cases.
KINDS = {"scenario": 0.28, "imu": 0.18, "experiment": 0.14, "recording": 0.16, "trajectory": 0.14, "channel": 0.10}
#: Share of each class (valid inputs are a class of their own, so that "valid rejected" is measured).
CLASS_WEIGHTS = {"valid": 0.16, "wrong_type": 0.09, "missing_key": 0.07, "unknown_key": 0.08, "out_of_range": 0.16,
                 "nan_inf": 0.07, "huge_size": 0.08, "duplicate_key": 0.06, "malformed": 0.07,
                 "truncated_corrupted": 0.07, "wrong_units": 0.09}

GAP_JSON_DUPLICATES = ("sins_sim/io/recording.py: a duplicate key in the JSON header is resolved by json.loads "
                       "(the last one wins)")
GAP_QUANTUM = "sins_sim/io/recording.py: meta.quantum_rad has no physical range (only > 0)"
GAP_FS = ("sins_sim/io/recording.py: meta.fs_hz has no physical range and no rule against the nominal f0 (only > 0): "
          "a 0.3 s recording read at 7.2 Hz becomes 500 s of simulation (diagnose runs for minutes), at 1e30 Hz "
          "diagnose stops on an OverflowError (identification/recording_inputs.py, _masks)")


@dataclass
class Case:
    """One fuzz input: its files, the file under test, and what the run must end in."""

    id: str
    kind: str
    cls: str
    expect: str
    what: str
    files: dict = field(default_factory=dict)  # file name -> bytes
    main: str = ""
    args: list = field(default_factory=list)  # channel: the flags after ``sins-sim channel``
    gap: str | None = None
    family: str | None = None  # a kind from ``families/`` (its command and validation), None for the classes here

    def write(self, folder: Path) -> Path:
        folder.mkdir(parents=True, exist_ok=True)
        for name, data in self.files.items():
            (folder / name).parent.mkdir(parents=True, exist_ok=True)  # a family may write into sub-folders
            (folder / name).write_bytes(data)
        return folder / self.main if self.main else folder


# --- the valid bases -------------------------------------------------------------------------------------------
def _schemas():
    from sins_sim.config.imu import IMU_SCHEMA
    from sins_sim.config.experiment import EXPERIMENT_SCHEMA
    from sins_sim.config.scenario import SCENARIO_SCHEMA

    return {"scenario": SCENARIO_SCHEMA, "imu": IMU_SCHEMA, "experiment": EXPERIMENT_SCHEMA}


def _imu_doc(rng: random.Random) -> dict:
    from sins_sim.config.yaml_io import load_yaml

    name = rng.choice(["default-imu.yaml", "spread-imu.yaml"])
    return load_yaml(ROOT / "configs" / name)


IMU_TEXT = None


def _default_imu_bytes() -> bytes:
    return (ROOT / "configs" / "default-imu.yaml").read_bytes()


MOTIONS = [
    [{"type": "static"}],
    [{"type": "coning", "amplitude_arcmin": 1.0, "frequency_hz": 100.0}],
    [{"type": "sines", "amplitude_arcmin": [1.0, 0.5, 0.0], "frequency_hz": [60.0, 90.0, 0.0]}],
    [{"type": "shock", "axis": [1.0, 0.3, 0.0], "peak_rate_deg_s": 20.0, "duration_ms": 0.3, "start_s": 1.1,
      "ring_frequency_hz": 1600.0, "ring_amplitude_deg_s": 10.0, "ring_decay_ms": 5.0}],
    [{"type": "turn", "axis": [0.0, 0.0, 1.0], "angle_deg": 10.0, "duration_s": 0.2, "start_s": 1.05}],
    [{"type": "random_vibration", "psd_deg2_s2_per_hz": [[20.0, 1.0e-6], [400.0, 2.0e-6], [2000.0, 1.0e-6]],
      "f_lo_hz": 20.0, "f_hi_hz": 2000.0, "axes": [1.0, 1.0, 0.7]}],
    [{"type": "sweep", "axis": [1.0, 0.0, 0.0], "amplitude_arcmin": 0.5, "f_start_hz": 50.0, "f_stop_hz": 200.0,
      "duration_s": 0.3, "start_s": 1.0}],
    [{"type": "constant_rate", "rate_deg_s": [0.0, 0.0, 5.0]},
     {"type": "sines", "amplitude_arcmin": [0.2, 0.2, 0.2], "frequency_hz": [130.0, 170.0, 210.0]}],
]
LINEAR = [
    [{"type": "sines", "amplitude_m_s2": [1.0, 0.0, 0.5], "frequency_hz": [60.0, 70.0, 80.0]}],
    [{"type": "random", "psd_g2_per_hz": [[20.0, 0.002], [2000.0, 0.002]], "f_lo_hz": 20.0, "f_hi_hz": 2000.0}],
]


def _scenario_doc(rng: random.Random, imu: str = "imu.yaml", trajectory_file: str | None = None) -> dict:
    doc = {"name": f"fuzz-{rng.randrange(10 ** 6)}", "description": "a fuzz case", "seed": rng.randrange(1000),
           "duration_s": 1.3, "imu": imu, "motion": copy.deepcopy(rng.choice(MOTIONS))}
    if rng.random() < 0.3:
        doc["linear_vibration"] = copy.deepcopy(rng.choice(LINEAR))
    if trajectory_file is not None:
        doc["trajectory"] = {"file": trajectory_file}
    elif rng.random() < 0.3:
        doc["site"] = {"lat_deg": 48.0, "lon_deg": 11.5, "height_m": 500.0, "heading_deg": 30.0}
        doc["trajectory"] = {"speed_m_s": 50.0, "transition_s": 0.5,
                             "segments": [{"type": "cruise", "duration_s": 0.5},
                                          {"type": "turn", "duration_s": 3.0, "heading_change_deg": 20.0}]}
    if rng.random() < 0.4:
        doc["filters"] = rng.choice([["ideal", "correcting"], ["eliminator", "correcting_paper", "raw"]])
    doc["navigation"] = {"start_s": 1.0}
    if rng.random() < 0.3:
        doc["navigation"]["coning"] = "three_sample"
    doc["outputs"] = {"plots": False, "timeseries": rng.random() < 0.5}
    return doc


def _experiment_doc(rng: random.Random) -> dict:
    kind = rng.choice(["stationary", "afc_sweep", "rate_table"])
    doc = {"experiment": kind, "duration_s": 0.3, "axes": rng.choice([["x"], ["x", "y"]]), "seed": rng.randrange(100)}
    if kind == "afc_sweep":
        doc["afc"] = {"voltage_factors": [0.8, 1.0], "frequency_offsets_hz": [-1.0, 0.0, 1.0], "dwell_s": 0.05}
    if kind == "rate_table":
        doc["rate_table"] = {"rate_deg_s": 5.0, "sines": [{"amplitude_arcmin": 3.0, "frequency_hz": 20.0}]}
    if rng.random() < 0.3:
        doc["noise_arcsec"] = 0.05
    return doc


def _trajectory_rows(rows=40, rate=10.0, speed=100.0):
    """A level flight north at ``speed`` from 45 deg N: (header, rows of strings)."""
    r_n = 6378137.0 * (1 - 0.00669437999014) / (1 - 0.00669437999014 * math.sin(math.radians(45.0)) ** 2) ** 1.5
    dlat = math.degrees(speed / rate / (r_n + 1000.0))
    header = ["time_s", "lat_deg", "lon_deg", "height_m", "roll_deg", "pitch_deg", "yaw_deg"]
    out = []
    for i in range(rows):
        out.append([f"{i / rate:.6f}", f"{45.0 + i * dlat:.13f}", "7.0000000000000", "1000.00000000",
                    "0.0", "0.0", "0.0"])
    return header, out


def _csv(header, rows, comments=()) -> bytes:
    lines = [f"# {c}" for c in comments] + [",".join(header)] + [",".join(r) for r in rows]
    return ("\n".join(lines) + "\n").encode()


_RECORDINGS: dict = {}


def _recording_base(axes: tuple) -> tuple:
    """A real recording (0.3 s, simulated once per process): (meta, arrays)."""
    if axes not in _RECORDINGS:
        import tempfile

        from sins_sim.io.recording import read_recording
        from sins_sim.jobs.recording_jobs import simulate_recording

        with tempfile.TemporaryDirectory() as tmp:
            spec = Path(tmp) / "e.yaml"
            spec.write_text(yaml.safe_dump({"experiment": "stationary", "duration_s": 0.3, "axes": list(axes),
                                            "seed": 5}))
            simulate_recording(spec, Path(tmp) / "r.npz")
            rec = read_recording(Path(tmp) / "r.npz")
            arrays = {"counts": np.array(rec.counts), "drive_v": np.array(rec.drive_v)}
            _RECORDINGS[axes] = (copy.deepcopy(rec.meta), arrays)
    meta, arrays = _RECORDINGS[axes]
    return copy.deepcopy(meta), {k: v.copy() for k, v in arrays.items()}


def _npz(meta, arrays, compressed=True, meta_text=None) -> bytes:
    buf = io.BytesIO()
    items = dict(arrays)
    items["meta"] = np.array(meta_text if meta_text is not None else json.dumps(meta))
    (np.savez_compressed if compressed else np.savez)(buf, **items)
    return _fixed_time(buf.getvalue())


def _fixed_time(data: bytes) -> bytes:
    """The same zip with every member dated 1980-01-01: numpy stamps the wall clock into each member, so two
    generations a second apart differed byte for byte (a seed must give the same files)."""
    src = zipfile.ZipFile(io.BytesIO(data))
    return _zip({info.filename: src.read(info) for info in src.infolist()},
                src.infolist()[0].compress_type if src.infolist() else zipfile.ZIP_DEFLATED)


# --- walking a YAML document with its schema ----------------------------------------------------------------------
def _ykey(name, spec):
    unit = getattr(spec, "unit", None)
    return f"{name}_{unit}" if unit else name


def _nodes(doc, spec, path=()):
    """(path, spec, value) of every node of ``doc`` that ``spec`` describes (maps, lists and leaves)."""
    from sins_sim.config.schema import ListOf, Map, OneOf, Str

    yield path, spec, doc
    if isinstance(spec, OneOf) and isinstance(doc, dict):
        variant = spec.variants.get(doc.get(spec.key))
        for k, v in doc.items():
            if k == spec.key:
                yield path + (k,), Str(choices=tuple(spec.variants), required=True), v
            elif variant is not None:
                sub = {_ykey(n, s): s for n, s in variant.fields.items()}.get(k)
                if sub is not None:
                    yield from _nodes(v, sub, path + (k,))
    elif isinstance(spec, Map) and isinstance(doc, dict):
        lookup = {_ykey(n, s): s for n, s in spec.fields.items()}
        for k, v in doc.items():
            if lookup.get(k) is not None:
                yield from _nodes(v, lookup[k], path + (k,))
    elif isinstance(spec, ListOf) and isinstance(doc, list):
        for i, v in enumerate(doc):
            yield from _nodes(v, spec.item, path + (i,))
    elif type(spec).__name__ == "_PerAxis" and isinstance(doc, dict):
        for k, v in doc.items():
            yield from _nodes(v, spec.item, path + (k,))


def _get(doc, path):
    for p in path:
        doc = doc[p]
    return doc


def _set(doc, path, value):
    _get(doc, path[:-1])[path[-1]] = value


def _show(path):
    out = ""
    for p in path:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else str(p))
    return out


def _leaves(doc, spec, kinds=("Num", "Vec", "Str", "Bool", "ListOf")):
    return [(p, s, v) for p, s, v in _nodes(doc, spec) if p and type(s).__name__ in kinds]


def _maps(doc, spec):
    """Mappings of ``doc`` with their schema (Map, a OneOf entry, a per-axis mapping): (path, spec)."""
    from sins_sim.config.schema import Map, OneOf

    out = []
    for p, s, v in _nodes(doc, spec):
        if isinstance(v, dict) and (isinstance(s, (Map, OneOf)) or type(s).__name__ == "_PerAxis"):
            out.append((p, s))
    return out


def _fields_of(spec, value):
    """(yaml key -> spec) of a mapping node."""
    from sins_sim.config.schema import OneOf

    if isinstance(spec, OneOf):
        variant = spec.variants.get(value.get(spec.key))
        return {spec.key: None, **({_ykey(n, s): s for n, s in variant.fields.items()} if variant else {})}
    if type(spec).__name__ == "_PerAxis":
        return {}
    return {_ykey(n, s): s for n, s in spec.fields.items()}


def _dump(doc, flow=False) -> str:
    return yaml.safe_dump(doc, sort_keys=False, default_flow_style=flow, allow_unicode=True, width=100000)


def _num_range(spec):
    """(min, min_exclusive, max) of a Num or Vec (a Vec with per-element items: its first item's range)."""
    if type(spec).__name__ == "Vec" and spec.items is not None:
        spec = spec.items[0]
    return spec.min, spec.min_exclusive, spec.max


def _out_of_range(rng, spec):
    lo, lo_excl, hi = _num_range(spec)
    options = []
    if lo is not None:
        options += [lo - max(abs(lo), 1.0), -1e30] + ([lo] if lo_excl else [])
    if hi is not None:
        options += [hi * 10.0 + 1.0 if hi >= 0 else hi / 10.0, 1e300]
    if getattr(spec, "integer", False):
        options.append((lo or 0) + 0.5)
    return rng.choice(options) if options else None


def _to_yaml12(x: float) -> str:
    """``1.3`` -> ``13e-1``: a float in the YAML 1.2 form that PyYAML alone reads as a string."""
    d = Decimal(repr(float(x))).normalize()
    sign, digits, exp = d.as_tuple()
    return f"{'-' if sign else ''}{''.join(map(str, digits))}e{exp}"


# --- YAML cases -------------------------------------------------------------------------------------------------
#: Safe valid edits per kind: (path, values) that keep every rule across keys.
SAFE_EDITS = {
    "scenario": [(("seed",), [0, 7, 123456]), (("description",), ["ünïcode — résumé ✓", "", "multi\nline"]),
                 (("name",), ["x", "a b c"]), (("navigation", "align_s"), [0.0, 0.3, 0.9]),
                 (("navigation", "n_sub"), [1, 2, 4]), (("navigation", "spectrum_s"), [0.0, 0.2]),
                 (("navigation", "sculling"), ["none", "three_sample"]),
                 (("navigation", "vertical"), ["free", "height_aid"]),
                 (("navigation", "accel_delay"), ["none", "matched"]),
                 (("navigation", "height_aid_tau_s"), [10.0, 1000.0])],
    "imu": [(("suspension", "k1"), [0.0, 1.0e-4, 1.0e-3]), (("suspension", "k3"), [2.0e-3, 8.0e-3]),
            (("suspension", "k4_per_rad"), [0.0, 100.0, 400.0]), (("suspension", "k5_rad_per_v"), [-3.0e-5, -5.0e-6]),
            (("drive", "amplitude_arcmin"), [1.5, 4.0]), (("readout", "noise_arcsec"), [0.0, 0.2]),
            (("readout", "quantum_arcsec"), [0.1, 2.42]), (("eliminator", "width_hz"), [30.0, 50.0]),
            (("eliminator", "rs_db"), [40.0, 80.0]), (("correcting", "hysteresis"), ["masing"]),
            (("plant", "hysteresis"), ["masing"]), (("name",), ["u", "ünit"]),
            (("drive", "control"), ["open_loop"]), (("drive", "modulation_depth"), [0.1])],
    "experiment": [(("seed",), [0, 99]), (("noise_arcsec",), [0.0, 0.1]), (("amplitude_arcmin",), [2.0, 4.0]),
                   (("hysteresis",), ["masing"]), (("integrator",), ["rk4"]), (("description",), ["bench ✓"]),
                   (("perturb",), [{"f0": 0.001, "k": 0.02}]), (("quantum_arcsec",), [0.2])],
}
#: Value-scale confusions (the right key, the number in another unit) that the ranges must catch.
SCALE_ERRORS = {
    "imu": [(("channels", "x", "f0_hz"), 0.386, "f0 in kHz"), (("drive", "amplitude_arcmin"), 0.00087,
                                                                "amplitude in rad"),
            (("suspension", "k2_rad"), 3.6, "k2 in arcmin"), (("plant", "rate_hz"), 72.0, "plant rate in kHz"),
            (("readout", "output_rate_hz"), 7.2, "filter rate in kHz"),
            (("readout", "quantum_arcsec"), 7.3e-7, "quantum in rad"),
            (("suspension", "k5_rad_per_v"), -12.0, "k5 in urad/V"), (("drive", "amplitude_arcmin"), 180.0,
                                                                     "amplitude in arcsec")],
    "scenario": [(("site", "lat_deg"), 4500.0, "latitude in centidegrees"), (("duration_s",), 0.0013,
                                                                               "duration in ks"),
                 (("navigation", "start_s"), 1000.0, "start in ms")],
    "experiment": [(("duration_s",), 300000.0, "duration in ms"), (("amplitude_arcmin",), 180.0,
                                                                   "amplitude in arcsec"),
                   (("fs_hz",), 7.2, "readout rate in kHz"), (("plant_rate_hz",), 72.0, "plant rate in kHz"),
                   (("quantum_arcsec",), 7.3e-7, "quantum in rad")],
}
HUGE = {
    "scenario": [(("duration_s",), 1.0e9), (("duration_s",), 1.0e30), (("duration_s",), 3.0e7),
                 (("navigation", "n_sub"), 10 ** 9), (("navigation", "spectrum_s"), 1.0e9), (("seed",), 10 ** 30),
                 (("navigation", "timeseries_rate_hz"), 1.0e12)],
    "imu": [(("plant", "rate_hz"), 1.0e12), (("readout", "anti_alias", "numtaps"), 10 ** 8 + 1),
            (("drive", "block_cycles"), 10 ** 12), (("readout", "output_rate_hz"), 1.0e15),
            (("drive", "loop_time_s"), 1.0e30)],
    "experiment": [(("duration_s",), 1.0e9), (("preroll_s",), 1.0e9), (("plant_rate_hz",), 1.0e12),
                   (("fs_hz",), 1.0e12), (("seed",), 10 ** 40)],
}
UNIT_SWAPS = {"hz": ["khz", "rpm", "rad_s"], "s": ["ms", "min", "h"], "ms": ["s", "us"], "arcmin": ["arcsec", "deg", "rad"],
              "arcsec": ["arcmin", "rad"], "deg": ["rad", "arcmin"], "deg_s": ["rad_s", "deg_h"], "rad": ["deg", "mrad"],
              "m": ["km", "ft"], "m_s": ["kt", "km_h"], "m_s2": ["g"], "db": ["np"], "per_rad": ["per_deg"],
              "rad_per_v": ["deg_per_v", "urad_per_v"], "v": ["mv"], "deg2_s2_per_hz": ["rad2_s2_per_hz"]}


def _yaml_case(rng: random.Random, kind: str, cls: str) -> tuple:
    """(expect, what, text, gap) for one mutated YAML document of ``kind``."""
    spec = _schemas()[kind]
    doc = {"scenario": _scenario_doc, "imu": _imu_doc, "experiment": _experiment_doc}[kind](rng)
    if cls == "valid":
        how = rng.choice(["yaml12", "comments", "reorder", "flow", "edit", "edit", "drop_optional", "quoted_keys"])
        if how == "edit":
            path, values = rng.choice(SAFE_EDITS[kind])
            if kind == "scenario" and path[0] == "navigation":
                doc["navigation"][path[1]] = rng.choice(values)
            else:
                node = doc
                for p in path[:-1]:
                    node = node.setdefault(p, {})
                node[path[-1]] = rng.choice(values)
            return "valid", f"{_show(path)} set to a legal value", _dump(doc), None
        if how == "drop_optional":
            cands = [(p, k) for p, s in _maps(doc, spec) for k, sub in _fields_of(s, _get(doc, p)).items()
                     if sub is not None and not sub.required and k in _get(doc, p)
                     and k not in ("start_s", "amplitude_arcmin", "dwell_s", "ring_frequency_hz", "transition_s")
                     and not _show(p + (k,)).startswith(("afc", "rate_table", "outputs", "navigation"))]
            if cands:
                p, k = rng.choice(cands)
                del _get(doc, p)[k]
                return "valid", f"optional {_show(p + (k,))} left out (its default)", _dump(doc), None
        text = _dump(doc, flow=(how == "flow"))
        if how == "yaml12":
            lines = text.splitlines()
            idx = [i for i, ln in enumerate(lines) if ": " in ln and _is_float(ln.split(": ", 1)[1])]
            for i in rng.sample(idx, min(len(idx), 3)):
                head, val = lines[i].split(": ", 1)
                lines[i] = f"{head}: {_to_yaml12(float(val))}"
            return "valid", "numbers written in YAML 1.2 forms (13e-1, 386e0)", "\n".join(lines) + "\n", None
        if how == "comments":
            lines = text.splitlines()
            for _ in range(3):
                i = rng.randrange(len(lines) + 1)
                indent = " " * (len(lines[i]) - len(lines[i].lstrip())) if i < len(lines) else ""
                lines.insert(i, f"{indent}# a comment: with colons, - dashes and 'quotes'")
            return "valid", "comment lines added", "\n".join(lines) + "\n", None
        if how == "reorder":
            return "valid", "keys in reverse order", _dump(_reversed(doc)), None
        if how == "quoted_keys":
            return "valid", "keys quoted", yaml.safe_dump(doc, sort_keys=False, default_style=None,
                                                          allow_unicode=True).replace("name:", "'name':", 1), None
        return "valid", "flow style", text, None
    if cls == "wrong_type":
        path, sub, value = rng.choice(_leaves(doc, spec, ("Num", "Vec", "Str", "Bool", "ListOf", "_Any")) +
                                      [(p, s, _get(doc, p)) for p, s in _maps(doc, spec) if p])
        kind_name = type(sub).__name__
        if kind_name in ("Num",):
            bad = rng.choice(["abc", "3", True, [1.0, 2.0], {"v": 1.0}, None])
            if getattr(sub, "integer", False):
                bad = rng.choice([bad, 1.5])
        elif kind_name == "Str":
            bad = rng.choice([3, 2.5, True, ["a"], {"a": 1}, None])
        elif kind_name == "Bool":
            bad = rng.choice(["yes", 1, 0.0, None, "false"])
        elif kind_name in ("Vec", "ListOf"):
            bad = rng.choice(["abc", 3.0, {"a": 1.0}, True])
        elif kind_name == "Map" and getattr(sub, "allow_null", False):
            bad = rng.choice(["abc", 3.0, [1.0]])
        elif kind_name == "_Any":
            bad = rng.choice([3, True, ["imu.yaml"]])
        else:
            bad = rng.choice(["abc", 3.0, [1.0], True])
        _set(doc, path, bad)
        return "invalid", f"{_show(path)} set to {type(bad).__name__} {bad!r}", _dump(doc), None
    if cls == "missing_key":
        cands = [(p, k) for p, s in _maps(doc, spec) for k, sub in _fields_of(s, _get(doc, p)).items()
                 if k in _get(doc, p) and (sub is None or sub.required)]
        p, k = rng.choice(cands)
        del _get(doc, p)[k]
        return "invalid", f"required {_show(p + (k,))} left out", _dump(doc), None
    if cls == "unknown_key":
        p, s = rng.choice(_maps(doc, spec))
        node = _get(doc, p)
        known = set(_fields_of(s, node)) | set(node)
        new = None
        for _ in range(20):
            base = rng.choice(sorted(known) or ["key"])
            how = rng.choice(["typo", "no_unit", "word"])
            if how == "typo" and len(base) > 2:
                i = rng.randrange(len(base) - 1)
                new = base[:i] + base[i + 1] + base[i] + base[i + 2:]
            elif how == "no_unit" and "_" in base:
                new = base.rsplit("_", 1)[0]
            else:
                new = rng.choice(["colour", "durration_s", "gain", "f0_hz2", "enabled", "q"])
            if new not in known and new != "type":
                break
        if type(s).__name__ == "_PerAxis":  # an axis name that is not one of axes
            new = "q"
        node[new] = rng.choice([1.0, "x", True])
        return "invalid", f"unknown key {_show(p + (new,))}", _dump(doc), None
    if cls == "out_of_range":
        if kind in ("imu", "scenario") and rng.random() < 0.35:
            path, value, what = rng.choice(ISSUE_VALUES[kind])
            _put(doc, path, value)
            return "invalid", f"{_show(path)} = {value!r} ({what})", _dump(doc), None
        cands = [(p, s, v) for p, s, v in _leaves(doc, spec, ("Num", "Vec")) if _out_of_range(rng, s) is not None]
        path, sub, value = rng.choice(cands)
        bad = _out_of_range(rng, sub)
        if isinstance(value, list):
            if value and isinstance(value[0], list):  # not reached (a list of rows is a ListOf)
                value[0][0] = bad
            else:
                value[rng.randrange(len(value))] = bad
        else:
            _set(doc, path, bad)
        return "invalid", f"{_show(path)} out of its range ({bad!r})", _dump(doc), None
    if cls == "nan_inf":
        cands = _leaves(doc, spec, ("Num", "Vec"))
        for p, s, v in _nodes(doc, spec):  # rows of tables (PSD, ...)
            if type(s).__name__ == "ListOf" and type(s.item).__name__ == "Vec" and isinstance(v, list) and v:
                cands.append((p + (0,), s.item, v[0]))
        path, sub, value = rng.choice(cands)
        bad = rng.choice([math.nan, math.inf, -math.inf])
        if isinstance(value, list):
            value[rng.randrange(len(value))] = bad
        else:
            _set(doc, path, bad)
        return "invalid", f"{_show(path)} set to {bad!r}", _dump(doc), None
    if cls == "huge_size":
        big = rng.random()
        if kind == "scenario" and big < 0.3:
            which = rng.choice(["motion", "segments", "psd", "filters", "tones", "series"])
            if which == "motion":
                doc["motion"] = [{"type": "static"}] * 5000
            elif which == "segments":
                doc["trajectory"] = {"segments": [{"type": "stationary", "duration_s": 1.0}] * 20000}
            elif which == "psd":
                doc["motion"] = [{"type": "random_vibration", "f_lo_hz": 20.0, "f_hi_hz": 2000.0,
                                  "psd_deg2_s2_per_hz": [[20.0 + i * 0.1, 1e-6] for i in range(20000)]}]
            elif which == "filters":
                doc["filters"] = ["ideal"] * 100000
            elif which == "tones":
                doc["duration_s"] = 1.0e6
                doc["motion"] = [{"type": "random_vibration", "psd_deg2_s2_per_hz": [[20.0, 1e-6], [2800.0, 1e-6]],
                                  "f_lo_hz": 20.0, "f_hi_hz": 2800.0, "method": "tones"}]
            else:
                doc["duration_s"] = 3600.0
                doc["navigation"]["timeseries_rate_hz"] = 7200.0
            return "invalid", f"huge {which}", _dump(doc), None
        if kind == "experiment" and big < 0.3:
            which = rng.choice(["afc", "sines"])
            if which == "afc":
                doc["experiment"] = "afc_sweep"
                doc["afc"] = {"voltage_factors": [1.0] * 100000}
            else:
                doc["experiment"] = "rate_table"
                doc["rate_table"] = {"sines": [{"amplitude_arcmin": 0.1, "frequency_hz": 10.0}] * 10000}
            return "invalid", f"huge {which} list", _dump(doc), None
        path, value = rng.choice(HUGE[kind])
        _put(doc, path, value)
        return "invalid", f"{_show(path)} = {value!r}", _dump(doc), None
    if cls == "duplicate_key":
        text = _dump(doc)
        lines = text.splitlines()
        idx = [i for i, ln in enumerate(lines) if _is_mapping_line(ln)]
        i = rng.choice(idx)
        head = lines[i].split(":", 1)[0]
        lines.insert(i + 1 + rng.randrange(2) * 0, f"{head}: {rng.choice(['1.0', 'x', '[1, 2]', '2'])}")
        return "invalid", f"key {head.strip()!r} written twice", "\n".join(lines) + "\n", None
    if cls == "malformed":
        text = _dump(doc)
        how = rng.choice(["unclosed", "tab", "quote", "binary", "empty", "list_top", "scalar"])
        if how == "unclosed":
            text = text + "x: {a: 1\n"
        elif how == "tab":
            lines = text.splitlines()
            i = rng.randrange(1, len(lines)) if len(lines) > 1 else 0
            lines[i] = "\t" + lines[i]
            text = "\n".join(lines) + "\n"
        elif how == "quote":
            text = text + 'name: "unterminated\n'
        elif how == "binary":
            return "invalid", "binary garbage", None, bytes(rng.randrange(256) for _ in range(200)) + b"\xff\xfe"
        elif how == "empty":
            text = ""
        elif how == "list_top":
            text = "- a\n- b\n"
        else:
            text = "just a sentence\n"
        return "invalid", f"malformed YAML ({how})", text, None
    if cls == "truncated_corrupted":
        data = _dump(doc).encode()
        if rng.random() < 0.5:
            cut = rng.randrange(len(data))
            return "either", f"truncated at byte {cut} of {len(data)}", None, data[:cut]
        data = bytearray(data)
        for _ in range(rng.randint(1, 4)):
            data[rng.randrange(len(data))] = rng.randrange(256)
        return "either", "bytes flipped", None, bytes(data)
    if cls == "wrong_units":
        if kind in SCALE_ERRORS and rng.random() < 0.5:
            path, value, what = rng.choice(SCALE_ERRORS[kind])
            _put(doc, path, value)
            return "invalid", f"{_show(path)} = {value!r} ({what})", _dump(doc), None
        cands = [(p, k) for p, s in _maps(doc, spec) for k in list(_get(doc, p))
                 if any(k.endswith("_" + u) for u in UNIT_SWAPS)]
        p, k = rng.choice(cands)
        unit = max((u for u in UNIT_SWAPS if k.endswith("_" + u)), key=len)
        new = k[: -len(unit)] + rng.choice(UNIT_SWAPS[unit])
        node = _get(doc, p)
        node[new] = node.pop(k)
        return "invalid", f"{_show(p + (k,))} written as {new}", _dump(doc), None
    raise AssertionError(cls)


#: The issue's unphysical values (point 4) and a few like them.
ISSUE_VALUES = {
    "imu": [(("suspension", "k5_rad_per_v"), 1e-30, "a 1e25 V drive"), (("drive", "amplitude_arcmin"), 1e-30, "no dither"),
            (("drive", "amplitude_arcmin"), 10000.0, "dies later"), (("channels", "x", "f0_hz"), 1e-30, "no resonance"),
            (("plant", "rate_hz"), 1e300, "no plant"), (("plant", "rate_hz"), 14400.0, "under 40 steps per period"),
            (("suspension", "k1"), 0.05, "k1 > 2 k2"), (("suspension", "k3"), 0.15, "loss above 1"),
            (("suspension", "k5_rad_per_v"), -1.0e-9, "a 4700 V drive"),
            (("eliminator", "width_hz"), 900.0, "band beyond zero")],
    "scenario": [(("motion",), [{"type": "coning", "amplitude_arcmin": 1.0, "frequency_hz": 5000.0}],
                  "above the filter Nyquist"),
                 (("motion",), [{"type": "sines", "amplitude_arcmin": [1.0, 0, 0], "frequency_hz": [1.0e6, 0, 0]}],
                  "above the plant Nyquist"),
                 (("motion",), [{"type": "constant_rate", "rate_deg_s": [0.0, 0.0, 5000.0]}], "beyond an RLG"),
                 (("motion",), [{"type": "turn", "axis": [0, 0, 1], "angle_deg": 3600.0, "duration_s": 0.5}],
                  "a 14400 deg/s turn"),
                 (("linear_vibration",), [{"type": "sines", "amplitude_m_s2": [1.0, 0, 0],
                                           "frequency_hz": [9000.0, 0, 0]}], "above the filter Nyquist"),
                 (("navigation", "start_s"), 5.0, "after the end")],
}


def _put(doc, path, value):
    node = doc
    for p in path[:-1]:
        node = node.setdefault(p, {})
    node[path[-1]] = value


def _reversed(x):
    if isinstance(x, dict):
        return {k: _reversed(x[k]) for k in reversed(list(x))}
    if isinstance(x, list):
        return [_reversed(v) for v in x]
    return x


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return "." in text and "e" not in text.lower() and len(text) < 12


def _is_mapping_line(line: str) -> bool:
    s = line.strip()
    return bool(s) and not s.startswith(("-", "#")) and ":" in s and s.split(":", 1)[0].replace("_", "").isalnum()


# --- recordings --------------------------------------------------------------------------------------------------
def _npy_claiming(arr: np.ndarray, rows: int) -> bytes:
    """The .npy bytes of ``arr`` with a header claiming ``rows`` rows (same header length)."""
    buf = io.BytesIO()
    np.lib.format.write_array(buf, arr)
    data = buf.getvalue()
    hlen = int.from_bytes(data[8:10], "little")
    header = data[10:10 + hlen].decode("latin1")
    new = header.replace(f"({arr.shape[0]},", f"({rows},", 1)
    new = new.rstrip("\n").rstrip(" ")
    new = new + " " * (hlen - 1 - len(new)) + "\n"
    return data[:10] + new.encode("latin1") + data[10 + hlen:]


#: The date of every zip member the generator writes (the wall clock would make a seed's files differ).
_ZIP_DATE = (1980, 1, 1, 0, 0, 0)


def _zip(members: dict, compression=zipfile.ZIP_DEFLATED) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression) as zf:
        for name, data in members.items():
            zf.writestr(zipfile.ZipInfo(name, date_time=_ZIP_DATE), data, compress_type=compression)
    return buf.getvalue()


def _npy(arr) -> bytes:
    buf = io.BytesIO()
    np.lib.format.write_array(buf, np.asarray(arr))
    return buf.getvalue()


def _recording_case(rng: random.Random, cls: str) -> tuple:
    """(expect, what, bytes, gap) of one mutated recording."""
    axes = rng.choice([("x",), ("x", "y")])
    meta, arrays = _recording_base(axes)
    a0 = axes[0]
    if cls == "valid":
        how = rng.choice(["extra_meta", "extra_array", "uncompressed", "description", "float32", "unknown_state",
                          "nominal_extra"])
        if how == "extra_meta":
            meta["operator"] = {"name": "fuzz", "bench": 3}
        elif how == "extra_array":
            arrays["notes"] = np.arange(5)
        elif how == "description":
            meta["description"] = "bench run ✓ 3"
        elif how == "float32":
            arrays["drive_v"] = arrays["drive_v"].astype(np.float32)
        elif how == "unknown_state":
            meta["initial_state"] = "unknown"
        elif how == "nominal_extra":
            meta["nominal"][a0]["serial"] = "A-17"
        return "valid", f"recording: {how}", _npz(meta, arrays, compressed=(how != "uncompressed")), None
    if cls == "wrong_type":
        how = rng.choice(["fs_str", "axes_str", "nominal_list", "quantum_bool", "experiment_num", "f0_str",
                          "counts_float", "drive_int", "meta_num"])
        if how == "counts_float":
            arrays["counts"] = arrays["counts"].astype(np.float64)
        elif how == "drive_int":
            arrays["drive_v"] = arrays["drive_v"].astype(np.int64)
        elif how == "meta_num":
            members = {"meta.npy": _npy(np.arange(3)), "counts.npy": _npy(arrays["counts"]),
                       "drive_v.npy": _npy(arrays["drive_v"])}
            return "invalid", "recording: meta is a number array", _zip(members), None
        else:
            key, bad = {"fs_str": ("fs_hz", "7200"), "axes_str": ("axes", "x"), "nominal_list": ("nominal", [1, 2]),
                        "quantum_bool": ("quantum_rad", True), "experiment_num": ("experiment", 3),
                        "f0_str": (None, None)}[how]
            if key is None:
                meta["nominal"][a0]["f0_hz"] = "386"
            else:
                meta[key] = bad
        return "invalid", f"recording: {how}", _npz(meta, arrays), None
    if cls == "missing_key":
        how = rng.choice(["meta_key", "nominal_key", "array", "nominal_axis"])
        if how == "meta_key":
            k = rng.choice(["format", "axes", "fs_hz", "drive_fs_hz", "quantum_rad", "initial_state", "experiment",
                            "nominal"])
            del meta[k]
        elif how == "nominal_key":
            del meta["nominal"][a0][rng.choice(["f0_hz", "k1", "k2", "k3", "k4", "k5"])]
        elif how == "nominal_axis":
            del meta["nominal"][a0]
        else:
            k = rng.choice(["counts", "drive_v", "meta"])
            if k == "meta":
                buf = io.BytesIO()
                np.savez_compressed(buf, **arrays)
                return "invalid", "recording: no meta array", _fixed_time(buf.getvalue()), None
            del arrays[k]
        return "invalid", f"recording: {how} missing", _npz(meta, arrays), None
    if cls == "unknown_key":
        how = rng.choice(["meta", "array", "nominal_axis"])
        if how == "nominal_axis":
            meta["nominal"]["q"] = dict(meta["nominal"][a0])
            return "invalid", "recording: nominal entry for an axis not in axes", _npz(meta, arrays), None
        if how == "meta":
            meta["calibrated_by"] = "someone"
        else:
            arrays["temperature_c"] = np.full(4, 21.5)
        return "valid", f"recording: unknown {how} kept (the format preserves them)", _npz(meta, arrays), None
    if cls == "out_of_range":
        how = rng.choice(["fs_neg", "fs_zero", "fs_huge", "ratio", "quantum_zero", "quantum_huge", "f0_neg",
                          "f0_tiny", "f0_huge", "k2_zero", "k5_zero", "k5_tiny", "k1_neg", "k3_huge", "state",
                          "axes4", "short"])
        gap = None
        n = meta["nominal"][a0]
        if how == "fs_neg":
            meta["fs_hz"] = -1.0
        elif how == "fs_zero":
            meta["fs_hz"] = 0.0
        elif how == "fs_huge":
            meta["fs_hz"] = meta["drive_fs_hz"] = 1.0e30
        elif how == "ratio":
            meta["drive_fs_hz"] = 1.5 * meta["fs_hz"]
        elif how == "quantum_zero":
            meta["quantum_rad"] = 0.0
        elif how == "quantum_huge":
            meta["quantum_rad"] = 1.0e30
        elif how == "f0_neg":
            n["f0_hz"] = -386.0
        elif how == "f0_tiny":
            n["f0_hz"] = 1e-30
        elif how == "f0_huge":
            n["f0_hz"] = 1e9
        elif how == "k2_zero":
            n["k2"] = 0.0
        elif how == "k5_zero":
            n["k5"] = 0.0
        elif how == "k5_tiny":
            n["k5"] = 1e-30
        elif how == "k1_neg":
            n["k1"] = -1.0
        elif how == "k3_huge":
            n["k3"] = 1000.0
        elif how == "state":
            meta["initial_state"] = "sometimes"
        elif how == "axes4":
            meta["axes"] = ["x", "y", "z", "w"]
        else:
            arrays["counts"] = arrays["counts"][:2]
            arrays["drive_v"] = arrays["drive_v"][:2 * int(round(meta["drive_fs_hz"] / meta["fs_hz"]))]
        return "invalid", f"recording: {how}", _npz(meta, arrays), gap
    if cls == "nan_inf":
        how = rng.choice(["drive_nan", "drive_inf", "meta_nan", "nominal_inf", "sins_nan"])
        if how == "drive_nan":
            arrays["drive_v"][rng.randrange(arrays["drive_v"].shape[0]), 0] = math.nan
        elif how == "drive_inf":
            arrays["drive_v"][rng.randrange(arrays["drive_v"].shape[0]), 0] = -math.inf
        elif how == "meta_nan":
            text = json.dumps(meta).replace(f'"fs_hz": {json.dumps(meta["fs_hz"])}', '"fs_hz": NaN')
            return "invalid", "recording: meta.fs_hz NaN", _npz(meta, arrays, meta_text=text), None
        elif how == "nominal_inf":
            text = json.dumps(meta).replace(f'"k3": {json.dumps(meta["nominal"][a0]["k3"])}', '"k3": Infinity', 1)
            return "invalid", "recording: nominal k3 Infinity", _npz(meta, arrays, meta_text=text), None
        else:
            meta["sins_fs_hz"] = meta["fs_hz"]
            sa = np.zeros((arrays["counts"].shape[0], len(axes)))
            sa[3, 0] = math.nan
            arrays["sins_angle"] = sa
        return "invalid", f"recording: {how}", _npz(meta, arrays), None
    if cls == "huge_size":
        how = rng.choice(["header_rows", "deep_meta", "many_axes", "long_meta_list"])
        if how == "header_rows":
            members = {"meta.npy": _npy(np.array(json.dumps(meta))), "counts.npy": _npy_claiming(arrays["counts"], 2 ** 40),
                       "drive_v.npy": _npy(arrays["drive_v"])}
            return "invalid", "recording: counts header claims 2^40 rows", _zip(
                members, rng.choice([zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED])), None
        if how == "deep_meta":
            text = json.dumps(meta)[:-1] + ', "deep": ' + "[" * 5000 + "]" * 5000 + "}"
            return "invalid", "recording: meta nested 5000 deep", _npz(meta, arrays, meta_text=text), None
        if how == "many_axes":
            meta["axes"] = [f"a{i}" for i in range(100000)]
        else:
            meta["nominal"][a0]["f0_hz"] = [386.0] * 100000
        return "invalid", f"recording: {how}", _npz(meta, arrays), None
    if cls == "duplicate_key":
        if rng.random() < 0.6:
            text = json.dumps(meta)
            text = text[:-1] + f', "fs_hz": {rng.choice([1.0, -5.0, 7200.0])}}}'
            return "invalid", "recording: meta holds fs_hz twice", _npz(meta, arrays, meta_text=text), None
        members = {"meta.npy": _npy(np.array(json.dumps(meta))), "counts.npy": _npy(arrays["counts"]),
                   "drive_v.npy": _npy(arrays["drive_v"])}
        buf = io.BytesIO()
        with zipfile.ZipFile(buf, "w") as zf:
            for name, data in members.items():
                zf.writestr(zipfile.ZipInfo(name, date_time=_ZIP_DATE), data)
            import warnings

            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                zf.writestr(zipfile.ZipInfo("counts.npy", date_time=_ZIP_DATE), _npy(arrays["counts"][:5]))
        return "invalid", "recording: counts stored twice in the archive", buf.getvalue(), None
    if cls == "malformed":
        how = rng.choice(["text", "empty", "npy", "no_members", "meta_not_json", "meta_array_2d"])
        if how == "text":
            return "invalid", "recording: a text file", b"time_s,counts_x\n0,1\n", None
        if how == "empty":
            return "invalid", "recording: empty file", b"", None
        if how == "npy":
            return "invalid", "recording: a single .npy", _npy(arrays["counts"]), None
        if how == "no_members":
            return "invalid", "recording: an empty zip", _zip({}), None
        if how == "meta_not_json":
            return "invalid", "recording: meta not JSON", _npz(meta, arrays, meta_text="{fs_hz: 7200,"), None
        members = {"meta.npy": _npy(np.array([json.dumps(meta)] * 2)), "counts.npy": _npy(arrays["counts"]),
                   "drive_v.npy": _npy(arrays["drive_v"])}
        return "invalid", "recording: meta is a 1-d array", _zip(members), None
    if cls == "truncated_corrupted":
        data = _npz(meta, arrays)
        if rng.random() < 0.5:
            cut = rng.randrange(len(data) - 22)  # the end-of-central-directory record is the last 22 bytes
            return "invalid", f"recording: truncated at byte {cut} of {len(data)}", data[:cut], None
        data = bytearray(data)
        for _ in range(rng.randint(1, 4)):
            data[rng.randrange(len(data))] ^= 1 << rng.randrange(8)
        return "either", "recording: bits flipped", bytes(data), None
    if cls == "wrong_units":
        how = rng.choice(["f0_khz", "k2_arcmin", "k5_urad", "quantum_arcsec", "fs_khz"])
        n = meta["nominal"][a0]
        gap = None
        if how == "f0_khz":
            n["f0_hz"] = n["f0_hz"] / 1000.0
        elif how == "k2_arcmin":
            n["k2"] = 3.6
        elif how == "k5_urad":
            n["k5"] = -12.0
        elif how == "quantum_arcsec":
            meta["quantum_rad"] = 0.15125
        else:
            meta["fs_hz"] = meta["fs_hz"] / 1000.0
            meta["drive_fs_hz"] = meta["drive_fs_hz"] / 1000.0
        return "invalid", f"recording: {how}", _npz(meta, arrays), gap
    raise AssertionError(cls)


# --- trajectory files --------------------------------------------------------------------------------------------
def _trajectory_case(rng: random.Random, cls: str) -> tuple:
    """(expect, what, bytes, gap) of one mutated trajectory CSV (a scenario of 1.3 s flies it)."""
    header, rows = _trajectory_rows()
    if cls == "valid":
        how = rng.choice(["comments", "spaces", "blank_end", "reorder", "sci", "velocity"])
        if how == "comments":
            return "valid", "csv: comments on top", _csv(header, rows, ["level flight", "10 Hz, north"]), None
        if how == "spaces":
            return "valid", "csv: spaces around cells", _csv([f" {h} " for h in header],
                                                             [[f" {c} " for c in r] for r in rows]), None
        if how == "blank_end":
            return "valid", "csv: blank lines at the end", _csv(header, rows) + b"\n\n", None
        if how == "reorder":
            order = list(range(len(header)))
            rng.shuffle(order)
            return "valid", "csv: columns in another order", _csv([header[i] for i in order],
                                                                  [[r[i] for i in order] for r in rows]), None
        if how == "sci":
            return "valid", "csv: times in e-notation", _csv(header, [[f"{float(r[0]):.6e}"] + r[1:] for r in rows]), None
        return "valid", "csv: velocity columns", _csv(header + ["vn_m_s", "ve_m_s", "vd_m_s"],
                                                      [r + ["100.0", "0.0", "0.0"] for r in rows]), None
    if cls == "wrong_type":
        i, j = rng.randrange(len(rows)), rng.randrange(len(header))
        rows[i][j] = rng.choice(["abc", "", "true", "1,2", "0x10"])
        return "invalid", f"csv: row {i + 1} column {header[j]} = {rows[i][j]!r}", _csv(header, rows), None
    if cls == "missing_key":
        if rng.random() < 0.3:
            h = header + ["vn_m_s", "ve_m_s"]
            return "invalid", "csv: two of three velocity columns", _csv(h, [r + ["100.0", "0.0"] for r in rows]), None
        j = rng.randrange(len(header))
        return "invalid", f"csv: no {header[j]} column", _csv(header[:j] + header[j + 1:],
                                                              [r[:j] + r[j + 1:] for r in rows]), None
    if cls == "unknown_key":
        name = rng.choice(["speed_kt", "time", "alt_ft", "lat"])
        return "invalid", f"csv: unknown column {name}", _csv(header + [name], [r + ["1.0"] for r in rows]), None
    if cls == "out_of_range":
        how = rng.choice(["lat", "height", "pitch", "time_back", "time_gap", "jump", "yaw_jump", "few_rows", "short"])
        i = rng.randrange(2, len(rows))
        if how == "lat":
            rows[i][1] = "95.0"
        elif how == "height":
            rows[i][3] = "200000.0"
        elif how == "pitch":
            rows[i][5] = "95.0"
        elif how == "time_back":
            rows[i][0] = rows[i - 2][0]
        elif how == "time_gap":
            for r in rows[i:]:
                r[0] = f"{float(r[0]) + 2.0:.6f}"
        elif how == "jump":
            rows[i][1] = f"{float(rows[i][1]) + 0.01:.13f}"
        elif how == "yaw_jump":
            rows[i][6] = "100.0"
        elif how == "few_rows":
            rows = rows[:3]
        else:
            rows = rows[:12]  # 1.1 s: shorter than the scenario's 1.3 s + 0.1 s
        return "invalid", f"csv: {how}", _csv(header, rows), None
    if cls == "nan_inf":
        i, j = rng.randrange(len(rows)), rng.randrange(len(header))
        rows[i][j] = rng.choice(["nan", "inf", "-inf", "NaN"])
        return "invalid", f"csv: {rows[i][j]} at row {i + 1}", _csv(header, rows), None
    if cls == "huge_size":
        if rng.random() < 0.5:
            return "invalid", "csv: 10000 columns", _csv(header + [f"c{i}" for i in range(10000)],
                                                         [r + ["0"] * 10000 for r in rows[:5]]), None
        rows[3] = rows[3] + ["1.0"] * 100000
        return "invalid", "csv: a row of 100007 cells", _csv(header, rows), None
    if cls == "duplicate_key":
        j = rng.randrange(len(header))
        return "invalid", f"csv: {header[j]} twice", _csv(header + [header[j]], [r + [r[j]] for r in rows]), None
    if cls == "malformed":
        how = rng.choice(["comment_after", "blank_middle", "binary", "empty", "semicolons", "header_only"])
        if how == "comment_after":
            data = _csv(header, rows[:5]) + b"# late comment\n" + _csv(header, rows[5:]).split(b"\n", 1)[1]
        elif how == "blank_middle":
            data = _csv(header, rows[:5]) + b"\n" + _csv(header, rows[5:]).split(b"\n", 1)[1]
        elif how == "binary":
            data = bytes(rng.randrange(256) for _ in range(300))
        elif how == "empty":
            data = b""
        elif how == "semicolons":
            data = _csv(header, rows).replace(b",", b";")
        else:
            data = _csv(header, [])
        return "invalid", f"csv: {how}", data, None
    if cls == "truncated_corrupted":
        data = _csv(header, rows)
        if rng.random() < 0.5:
            cut = rng.randrange(len(data))
            return "either", f"csv: truncated at byte {cut}", data[:cut], None
        data = bytearray(data)
        for _ in range(rng.randint(1, 3)):
            data[rng.randrange(len(data))] = rng.randrange(256)
        return "either", "csv: bytes flipped", bytes(data), None
    if cls == "wrong_units":
        j = rng.randrange(len(header))
        swaps = {"time_s": "time_ms", "lat_deg": "lat_rad", "lon_deg": "lon_rad", "height_m": "height_ft",
                 "roll_deg": "roll_rad", "pitch_deg": "pitch_rad", "yaw_deg": "yaw_rad"}
        h = list(header)
        h[j] = swaps[h[j]]
        return "invalid", f"csv: {header[j]} written as {h[j]}", _csv(h, rows), None
    raise AssertionError(cls)


# --- channel command lines ----------------------------------------------------------------------------------------
CHANNEL_VALID = [["--duration", "0.3"],
                 ["--duration", "0.3", "--motion", "sine", "--motion-hz", "120", "--motion-arcmin", "0.5"],
                 ["--duration", "0.3", "--f0", "400"], ["--duration", "0.3", "--hysteresis", "masing"],
                 ["--duration", "0.3", "--noise-arcsec", "0.1", "--seed", "4"], ["--duration", "0.3", "--dither-arcmin", "2.5"],
                 ["--duration", "0.3", "--filter-rate", "9000"], ["--duration", "0.25", "--settle", "0.1"],
                 ["--duration", "3e-1", "--k5=-2e-5"]]
CHANNEL_BAD = {
    "wrong_type": [["--f0", "abc"], ["--duration", "x"], ["--seed", "1.5"], ["--motion", "square"], ["--k2", "1,05e-3"]],
    "missing_key": [["--f0"], ["--duration"]],
    "unknown_key": [["--colour", "red"], ["--k6", "1"], ["--f00", "386"]],
    "out_of_range": [["--f0", "1e-30"], ["--k5", "1e-30"], ["--dither-arcmin", "1e-30"], ["--dither-arcmin", "10000"],
                     ["--plant-rate", "1e300"], ["--motion", "sine", "--motion-hz", "1e6"], ["--filter-rate", "7000"],
                     ["--quantum-arcsec", "1e9"], ["--noise-arcsec", "1e9"], ["--k3", "5"], ["--k1", "1"],
                     ["--f0", "3000"], ["--motion", "sine", "--motion-arcmin", "600", "--motion-hz", "100"]],
    "nan_inf": [["--f0", "nan"], ["--k2", "inf"], ["--duration", "inf"], ["--k5", "-inf"], ["--dither-arcmin", "nan"]],
    "huge_size": [["--duration", "1e9"], ["--duration", "1e30"], ["--plant-rate", "1e12"], ["--duration", "1e5"],
                  ["--filter-rate", "1e12"]],
    "malformed": [["foo"], ["--duration", "--f0", "386"], ["-", "1"]],
    "wrong_units": [["--f0", "0.386"], ["--dither-arcmin", "180"], ["--plant-rate", "72"], ["--filter-rate", "7.2"],
                    ["--k2", "3.6"]],
}


def _channel_case(rng: random.Random, cls: str) -> tuple:
    if cls == "valid":
        return "valid", "channel: legal flags", rng.choice(CHANNEL_VALID)
    if cls not in CHANNEL_BAD:
        cls = rng.choice(sorted(CHANNEL_BAD))
    args = list(rng.choice(CHANNEL_BAD[cls]))
    if cls != "missing_key":
        args = ["--duration", "0.3"] + args if "--duration" not in args else args
    return "invalid", f"channel: {' '.join(args)}", args, cls


# --- the generator ------------------------------------------------------------------------------------------------
def _pick(rng: random.Random, weights: dict) -> str:
    x = rng.random() * sum(weights.values())
    for key, w in weights.items():
        x -= w
        if x <= 0:
            return key
    return key


def all_kinds() -> dict:
    """The kinds and their weights: the mutated inputs here and every family of ``families/``."""
    return {**KINDS, **{k: f.weight for k, f in families().items()}}


def all_classes() -> tuple:
    """The mutation classes here, then each family's classes (in family order, without repeats)."""
    extra = [c for f in families().values() for c in f.classes]
    return tuple(dict.fromkeys((*CLASSES, *extra)))


def generate(n: int, seed: int = 0, kinds=None) -> list:
    """``n`` cases from ``seed`` (deterministic); ``kinds`` restricts the input kinds."""
    fams = families()
    weights = {k: w for k, w in all_kinds().items() if kinds is None or k in kinds}
    cases = []
    for i in range(n):
        rng = random.Random(f"{seed}:{i}")
        kind = _pick(rng, weights)
        if kind in fams:
            made = fams[kind].make(rng)
            cases.append(Case(f"{seed}-{i:05d}", kind, made.cls, made.expect, made.what, dict(made.files), made.main,
                              gap=made.gap, family=kind))
            continue
        cls = _pick(rng, CLASS_WEIGHTS)
        cid = f"{seed}-{i:05d}"
        if kind in ("scenario", "imu", "experiment"):
            expect, what, text, raw = _yaml_case(rng, kind, cls)
            data = raw if isinstance(raw, bytes) else text.encode()
            if kind == "experiment":
                files, main = {"experiment.yaml": data}, "experiment.yaml"
            elif kind == "scenario":
                files, main = {"scenario.yaml": data, "imu.yaml": _default_imu_bytes()}, "scenario.yaml"
            else:
                scen = _dump(_scenario_doc(random.Random(f"{seed}:{i}:s"))).encode()
                files, main = {"imu.yaml": data, "scenario.yaml": scen}, "imu.yaml"
            cases.append(Case(cid, kind, cls, expect, what, files, main))
        elif kind == "recording":
            expect, what, data, gap = _recording_case(rng, cls)
            cases.append(Case(cid, kind, cls, expect, what, {"recording.npz": data}, "recording.npz", gap=gap))
        elif kind == "trajectory":
            expect, what, data, gap = _trajectory_case(rng, cls)
            scen = _dump(_scenario_doc(random.Random(f"{seed}:{i}:s"), trajectory_file="trajectory.csv")).encode()
            cases.append(Case(cid, kind, cls, expect, what, {"trajectory.csv": data, "scenario.yaml": scen,
                                                             "imu.yaml": _default_imu_bytes()}, "trajectory.csv",
                              gap=gap))
        else:
            expect, what, args, *rest = _channel_case(rng, cls)
            if rest:
                cls = rest[0]
            cases.append(Case(cid, kind, cls, expect, what, {}, "", args=args))
    return cases
