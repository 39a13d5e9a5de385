"""Property tests (hypothesis) over the valid parameter space (issue 12, "Deliver also").

* no NaN or inf in the outputs of short runs of the suspension (plant), the correcting filter, the eliminator
  and a whole channel, anywhere in their valid parameter space; a combination of individually valid values
  that breaks a rule across fields (Q, the drive voltage, the eliminator's band) draws a ValueError naming
  a field and nothing else;
* streaming (any chunking) equals whole-array, bit for bit, for the correcting filter and the eliminator;
* every invalid value of a parameter dataclass, or of any key of the scenario, IMU and experiment schemas,
  draws a ValueError (ConfigError) whose message names its field.

Runtime: about 15 s in all on the development machine (``max_examples`` per test below).
"""

from __future__ import annotations

import math
import re
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from sins_sim.filters.correcting import CorrectingFilter, CorrectingFilterDesign
from sins_sim.filters.eliminator import Eliminator, EliminatorDesign
from sins_sim.config.schema import ConfigError, ListOf, Map, Num, OneOf, Str, Vec, describe
from sins_sim.models.drive import DriveParams
from sins_sim.models.plant import PlantSettings, simulate_plant
from sins_sim.models.readout import AntiAliasParams, ReadoutParams
from sins_sim.models.suspension import SuspensionParams
from sins_sim.units import ARCMIN

ROOT = Path(__file__).resolve().parents[1]
FAST = settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
FIELD = re.compile(r"^[\w.\[\]]+: ")


def _log_uniform(lo, hi):
    return st.floats(math.log10(lo), math.log10(hi)).map(lambda e: 10.0 ** e)


def _quiet():
    """Unusual-but-legal values warn by design; the properties are about errors and numbers."""
    ctx = warnings.catch_warnings()
    ctx.__enter__()
    warnings.simplefilter("ignore")
    return ctx


def _names_a_field(exc: BaseException, fields) -> None:
    text = str(exc)
    assert isinstance(exc, ValueError), repr(exc)
    assert FIELD.match(text), text
    assert "\n" not in text
    if fields is not None:
        assert any(f in text.split(":", 1)[0] for f in fields), text


# --- the valid parameter space ---------------------------------------------------------------------------
@st.composite
def suspensions(draw, f0_max=5000.0):
    f0 = draw(_log_uniform(20.0, f0_max))
    k2 = draw(_log_uniform(1e-6, 0.1))
    k1 = draw(st.floats(0.0, 0.999)) * min(0.1, 2.0 * k2 * 0.999)
    zeta = draw(st.floats(0.0, 0.1))
    k4 = draw(st.one_of(st.floats(-20.0, 1e4), st.floats(-20.0, 500.0)))
    # the loss rule: k3 (1 + k4 a) + 2 zeta < 1 up to a = 0.05 rad (sins_sim.models.suspension)
    k3 = draw(st.floats(0.0, 0.999)) * min(0.2, (1.0 - 2.0 * zeta) / (1.0 + max(k4, 0.0) * 0.05))
    if k3 == 0.0 and zeta == 0.0:
        zeta = 1e-3
    k5 = draw(st.sampled_from([-1.0, 1.0])) * draw(_log_uniform(1e-9, 1e-2))
    return dict(f0_hz=f0, k1=k1, k2=k2, k3=k3, k4=k4, k5=k5, zeta=zeta)


SUSPENSION_FIELDS = ("suspension.f0_hz", "suspension.k1", "suspension.k2", "suspension.k3", "suspension.k4",
                     "suspension.k5", "suspension.zeta", "drive.amplitude_rad", "drive.dac_rate_hz")


@FAST
@given(params=suspensions(), amp_arcmin=_log_uniform(0.01, 60.0), seconds=st.floats(0.005, 0.03))
def test_valid_suspensions_run_finite(params, amp_arcmin, seconds):
    ctx = _quiet()
    try:
        s = SuspensionParams(**params)
        rate = max(72000.0, 7200.0 * math.ceil(40.0 * s.f0_hz / 7200.0))
        try:
            drive = DriveParams(amplitude_rad=amp_arcmin * ARCMIN, dac_rate_hz=rate).resolve(s)
        except ValueError as exc:  # Q out of its range, or a drive beyond a piezo stack: a rule across fields
            _names_a_field(exc, SUSPENSION_FIELDS)
            event("refused: a rule across fields")
            return
        event("ran")
        n = int(seconds * rate)
        t, delta, phi_rlg, _ = simulate_plant(s, drive.samples(0, n), settings=PlantSettings(rate_hz=rate))
        assert np.all(np.isfinite(delta)) and np.all(np.isfinite(phi_rlg))
        assert math.isfinite(s.q_factor(amp_arcmin * ARCMIN)) and math.isfinite(s.resonance_hz(amp_arcmin * ARCMIN))
    finally:
        ctx.__exit__(None, None, None)


@st.composite
def correcting_designs(draw):
    p = draw(suspensions())
    p["k5"] = draw(st.sampled_from([0.0, p["k5"]]))
    p.pop("zeta")
    fs = min(1.0e6, p["f0_hz"] * draw(st.floats(2.05, 200.0)))
    return CorrectingFilterDesign(**p, fs_hz=fs, form=draw(st.sampled_from(["unity", "paper"])),
                                  hysteresis=draw(st.sampled_from(["paper", "masing"])))


def _chunks(draw, n):
    cuts = sorted(set(draw(st.lists(st.integers(0, n), max_size=6))))
    return [0, *cuts, n]


@FAST
@given(design=correcting_designs(), amp_arcmin=_log_uniform(0.01, 60.0), volts=st.floats(0.0, 1000.0),
       data=st.data())
def test_correcting_filter_streams_bit_for_bit(design, amp_arcmin, volts, data):
    """Any chunking gives the whole-array output, bit for bit (NaN where the whole-array run has NaN).

    The input is synthetic (a dither-like sine building up over three periods, a drive that need not fit it),
    so finiteness is not asked here: eq. 5 inverts the suspension and an input no suspension could produce
    may drive its deflection estimate out of its domain. Finiteness on physical inputs:
    test_valid_channels_run_finite.
    """
    n = 1500
    k = np.arange(n)
    w = 2.0 * math.pi * min(design.f0_hz * data.draw(st.floats(0.8, 1.2)), 0.45 * design.fs_hz) / design.fs_hz
    period = 2.0 * math.pi / w
    env = np.where(k < 3 * period, 0.5 - 0.5 * np.cos(np.pi * k / (3 * period)), 1.0)
    x = amp_arcmin * ARCMIN * np.sin(w * k) * env + data.draw(st.floats(-1e-3, 1e-3)) * k / n
    v = volts * np.cos(w * k) * env
    ctx = _quiet()
    try:
        whole = CorrectingFilter(design).process(x, v)
        flt = CorrectingFilter(design)
        cuts = _chunks(data.draw, n)
        pieces = [flt.process(x[a:b], v[a:b]) for a, b in zip(cuts[:-1], cuts[1:])]
    finally:
        ctx.__exit__(None, None, None)
    np.testing.assert_array_equal(np.concatenate(pieces), whole)


@st.composite
def eliminator_designs(draw):
    fs = draw(_log_uniform(100.0, 1.0e6))
    nyq = fs / 2.0
    lo = nyq * draw(st.floats(1e-3, 0.9))
    hi = lo + (nyq - lo) * draw(st.floats(1e-3, 0.99))
    rp = draw(st.floats(0.01, 6.0))
    rs = draw(st.floats(rp + 1.0, 200.0))
    return dict(fs_hz=fs, band_hz=(lo, hi), order=draw(st.integers(1, 20)), rp_db=rp, rs_db=rs)


@FAST
@given(params=eliminator_designs(), data=st.data())
def test_eliminator_streams_bit_for_bit_and_stays_finite(params, data):
    ctx = _quiet()
    try:
        design = EliminatorDesign(**params)
        try:
            design.sos
        except ValueError as exc:  # a design float64 cannot hold stable: refused, naming the band
            _names_a_field(exc, ("eliminator.band_hz",))
            return
        n = 1200
        rng = np.random.default_rng(data.draw(st.integers(0, 2 ** 32 - 1)))
        x = rng.standard_normal(n) * data.draw(_log_uniform(1e-8, 1e-1))
        whole = Eliminator(design).process(x)
        elim = Eliminator(design)
        cuts = _chunks(data.draw, n)
        pieces = [elim.process(x[a:b]) for a, b in zip(cuts[:-1], cuts[1:])]
    finally:
        ctx.__exit__(None, None, None)
    assert np.all(np.isfinite(whole))
    np.testing.assert_array_equal(np.concatenate(pieces), whole)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(params=suspensions(f0_max=1800.0), amp_arcmin=_log_uniform(0.01, 60.0))
def test_valid_channels_run_finite(params, amp_arcmin):
    """Plant, drive, readout and every filter on the default 72 kHz / 7.2 kHz chain: no NaN, no inf."""
    from sins_sim.simulation.channel import ChannelConfig, simulate_channel

    ctx = _quiet()
    try:
        try:
            cfg = ChannelConfig(suspension=SuspensionParams(**params), drive=DriveParams(amplitude_rad=amp_arcmin * ARCMIN))
            cfg.eliminator_design().sos
        except ValueError as exc:
            _names_a_field(exc, SUSPENSION_FIELDS + ("eliminator.band_hz", "eliminator.dither_hz"))
            event("refused: a rule across fields")
            return
        event("ran")
        res = simulate_channel(cfg, 0.2)
    finally:
        ctx.__exit__(None, None, None)
    for name, out in res.outputs.items():
        assert np.all(np.isfinite(out)), name


# --- every invalid value of a parameter dataclass names its field -------------------------------------------------
BAD_ANY = [math.nan, math.inf, -math.inf, "3", None, True, [1.0]]


#: fields where None is a legal value (computed from the others)
NONE_OK = {"v_m", "frequency_hz"}


def _bad_numbers(field, lo, hi):
    """Values outside [lo, hi] and non-numbers."""
    out = [x for x in BAD_ANY if not (x is None and field in NONE_OK)]
    if lo is not None:
        out += [lo - max(abs(lo), 1.0), -1e30]
    if hi is not None:
        out += [hi * 10 + 1.0, 1e300]
    return out


DATACLASS_FIELDS = [
    (SuspensionParams, "f0_hz", (20.0, 5000.0)), (SuspensionParams, "k1", (0.0, 0.1)),
    (SuspensionParams, "k2", (1e-6, 0.1)), (SuspensionParams, "k3", (0.0, 0.2)),
    (SuspensionParams, "k4", (-20.0, 1e4)), (SuspensionParams, "k5", (-1e-2, 1e-2)),
    (SuspensionParams, "zeta", (0.0, 0.1)),
    (DriveParams, "amplitude_rad", (0.01 * ARCMIN, 60 * ARCMIN)), (DriveParams, "v_m", (0.0, 1000.0)),
    (DriveParams, "dac_rate_hz", (0.0, 1e6)), (DriveParams, "phase_rad", (-1e3, 1e3)),
    (PlantSettings, "rate_hz", (1e3, 1e6)),
    (ReadoutParams, "quantum_rad", (1e-15, 60 * 4.848e-6)), (ReadoutParams, "noise_rad", (0.0, 60 * 4.848e-6)),
    (ReadoutParams, "input_rate_hz", (0.0, 1e6)), (ReadoutParams, "output_rate_hz", (0.0, 1e6)),
    (AntiAliasParams, "numtaps", (1, 1001)), (AntiAliasParams, "cutoff_hz", (0.0, None)),
    (CorrectingFilterDesign, "f0_hz", (20.0, 5000.0)), (CorrectingFilterDesign, "k1", (0.0, 0.1)),
    (CorrectingFilterDesign, "k2", (1e-6, 0.1)), (CorrectingFilterDesign, "k3", (0.0, 0.2)),
    (CorrectingFilterDesign, "k4", (-20.0, 1e4)), (CorrectingFilterDesign, "k5", (-1e-2, 1e-2)),
    (CorrectingFilterDesign, "fs_hz", (772.0, 1e6)),
    (EliminatorDesign, "fs_hz", (820.0, 1e6)), (EliminatorDesign, "order", (1, 20)),
    (EliminatorDesign, "rp_db", (0.0, 6.0)), (EliminatorDesign, "rs_db", (0.1, 200.0)),
]
CHOICE_FIELDS = [(PlantSettings, "hysteresis"), (PlantSettings, "integrator"), (CorrectingFilterDesign, "form"),
                 (CorrectingFilterDesign, "hysteresis")]


@settings(max_examples=400, deadline=None)
@given(case=st.sampled_from(DATACLASS_FIELDS), data=st.data())
def test_every_invalid_dataclass_value_names_its_field(case, data):
    cls, field, (lo, hi) = case
    bad = data.draw(st.sampled_from(_bad_numbers(field, lo, hi)))
    if field == "numtaps" and isinstance(bad, float):
        bad = data.draw(st.sampled_from([0, -3, 1003, 10 ** 9, 20]))  # integers out of range, or even
    if field == "k5" and cls is SuspensionParams and bad == lo - max(abs(lo), 1.0):
        bad = 1e-30  # |k5| below its range
    ctx = _quiet()
    try:
        with pytest.raises(ValueError) as info:
            cls(**{field: bad})
    finally:
        ctx.__exit__(None, None, None)
    _names_a_field(info.value, None)
    assert field in str(info.value).split(":", 1)[0], str(info.value)


@settings(max_examples=30, deadline=None)
@given(case=st.sampled_from(CHOICE_FIELDS), bad=st.sampled_from(["", "PAPER", "rk5", 3, None]))
def test_every_invalid_choice_names_its_field(case, bad):
    cls, field = case
    with pytest.raises(ValueError, match=rf"^\w+\.{field}: must be one of"):
        cls(**{field: bad})


@settings(max_examples=30, deadline=None)
@given(band=st.sampled_from([(410.0, 370.0), (0.0, 10.0), (-5.0, 10.0), (370.0, 3600.0), (370.0,), "x",
                             (math.nan, 400.0), (370.0, math.inf)]))
def test_every_invalid_eliminator_band_names_its_field(band):
    with pytest.raises(ValueError, match=r"^eliminator\.band_hz: "):
        EliminatorDesign(band_hz=band)


# --- every invalid key of the YAML schemas names its key path ------------------------------------------------------
def _valid(spec):
    """A value the schema accepts (its default, or a value inside its range)."""
    if isinstance(spec, Num):
        if spec.default is not None:
            return spec.default
        lo, hi = spec.min, spec.max
        if lo is None:
            return 1.0 if hi is None or hi >= 1.0 else hi
        v = lo if not spec.min_exclusive else (lo + 1.0 if hi is None or lo + 1.0 <= hi else (lo + hi) / 2.0)
        return int(v) if spec.integer else v
    if isinstance(spec, Vec):
        if spec.default is not None:
            return list(spec.default)
        if spec.items is not None:
            return [_valid(it) for it in spec.items]
        return [_valid(Num(min=spec.min, min_exclusive=spec.min_exclusive, max=spec.max))] * spec.n
    if isinstance(spec, Str):
        return spec.choices[0] if spec.choices else "x"
    if isinstance(spec, ListOf):
        return [_valid(spec.item) for _ in range(max(spec.min_len, 1))]
    if isinstance(spec, OneOf):
        kind = sorted(spec.variants)[0]
        return {spec.key: kind, **_valid(spec.variants[kind])}
    if isinstance(spec, Map):
        return {_key(name, sub): _valid(sub) for name, sub in spec.fields.items() if getattr(sub, "required", False)}
    return True  # Bool


def _key(name, spec):
    unit = getattr(spec, "unit", None)
    return f"{name}_{unit}" if unit else name


def _leaves(spec, path=(), out=None):
    """(path of (key | (list index, variant)), spec) for every number, vector, string and bool of a schema."""
    out = [] if out is None else out
    if isinstance(spec, Map):
        for name, sub in spec.fields.items():
            _leaves(sub, path + (_key(name, sub),), out)
    elif isinstance(spec, OneOf):  # a mapping whose key selects the variant (e.g. the temperature profile)
        for kind, variant in spec.variants.items():
            _leaves(variant, path + (("oneof", kind),), out)
    elif isinstance(spec, ListOf) and isinstance(spec.item, (OneOf, Map)):
        if isinstance(spec.item, OneOf):
            for kind, variant in spec.item.variants.items():
                _leaves(variant, path + ((0, kind),), out)
        else:
            _leaves(spec.item, path + ((0, None),), out)
    elif isinstance(spec, (Num, Vec, Str, ListOf)) or type(spec).__name__ == "Bool":
        out.append((path, spec))
    elif type(spec).__name__ == "_PerAxis":  # axis name -> suspension keys (experiment format)
        _leaves(spec.item, path + ("x",), out)
    elif type(spec).__name__ == "_SpecEntry":  # vibration.spec: a file path or the mapping written inline
        _leaves(_spec_entry_schema(), path, out)
    return out


def _spec_entry_schema():
    from sins_sim.config.vibration_spec import VIBRATION_SPEC_SCHEMA

    return VIBRATION_SPEC_SCHEMA


def _set(doc, schema, path, value):
    """Put ``value`` at ``path`` of ``doc``, filling the required keys of every level on the way."""
    node, spec = doc, schema
    for i, step in enumerate(path):
        last = i == len(path) - 1
        if isinstance(step, tuple) and step[0] == "oneof":  # the variant of the mapping entered just before
            continue
        if isinstance(step, tuple):  # into a list: entry 0 of the given variant
            item = spec.item
            kind = step[1]
            entry = {item.key: kind, **_valid(item.variants[kind])} if isinstance(item, OneOf) else _valid(item)
            node[:] = [entry]
            node, spec = entry, (item.variants[kind] if isinstance(item, OneOf) else item)
            continue
        if isinstance(spec, Map):
            sub = next(s for n, s in spec.fields.items() if _key(n, s) == step)
        else:  # an axis of a per-axis mapping
            sub = spec.item
        if type(sub).__name__ == "_SpecEntry":  # written inline: its mapping's keys
            sub = _spec_entry_schema()
        if last:
            node[step] = value
        elif isinstance(sub, OneOf):
            kind = path[i + 1][1]
            node[step] = {sub.key: kind, **_valid(sub.variants[kind])}
            node, spec = node[step], sub.variants[kind]
        else:
            node.setdefault(step, [] if isinstance(sub, ListOf) else {})
            node, spec = node[step], sub
    return doc


def _shown(path):
    steps = [s for s in path if not (isinstance(s, tuple) and s[0] == "oneof")]
    return ".".join(f"[{s[0]}]" if isinstance(s, tuple) else s for s in steps).replace(".[", "[")


def _bad_values(spec):
    if isinstance(spec, Num):
        out = [math.nan, math.inf, "3e0x", True, [1]]
        if spec.min is not None:
            out.append(spec.min - max(abs(spec.min), 1.0))
        if spec.max is not None:
            out.append(spec.max * 10.0 + 1.0 if spec.max >= 0 else spec.max / 10.0)
        if spec.integer:
            out.append(1.5 + (spec.min or 0))
        return out
    if isinstance(spec, Vec):
        return [[1.0] * (spec.n + 1), "x", [math.nan] * spec.n] + (
            [[spec.max * 10.0 + 1.0] * spec.n] if spec.max is not None else [])
    if isinstance(spec, Str):
        return [3, None, ["a"]] + (["not-a-choice"] if spec.choices else [])
    if isinstance(spec, ListOf):
        return ["x", {"a": 1}] + ([[]] if spec.min_len else [])
    return ["yes", 1, None]  # Bool


def _imu_schema():
    from sins_sim.config.imu import IMU_SCHEMA

    return IMU_SCHEMA


def _scenario_schema():
    from sins_sim.config.scenario import SCENARIO_SCHEMA

    return SCENARIO_SCHEMA


def _experiment_schema():
    from sins_sim.config.experiment import EXPERIMENT_SCHEMA

    return EXPERIMENT_SCHEMA


def _load(fmt, doc):
    """The real loader of each format (schema and the rules across keys)."""
    if fmt == "imu":
        from sins_sim.config.imu import imu_from_dict

        return imu_from_dict(doc, "imu.yaml")
    if fmt == "scenario":
        from sins_sim.config.scenario import Scenario

        return Scenario(doc, "s.yaml", ROOT / "scenarios")
    from sins_sim.config.experiment import experiment_from_dict

    return experiment_from_dict(doc, "e.yaml")


BASES = {
    "imu": lambda: {"channels": {"x": {"f0_hz": 386}, "y": {"f0_hz": 352}, "z": {"f0_hz": 421}}},
    "scenario": lambda: {"name": "p", "duration_s": 1.5, "imu": "../configs/default-imu.yaml",
                         "navigation": {"start_s": 1.0}},
    "experiment": lambda: {"experiment": "stationary", "duration_s": 0.1},
}
LEAVES = [("imu", p, s) for p, s in _leaves(_imu_schema())] + \
         [("scenario", p, s) for p, s in _leaves(_scenario_schema()) if p != ("imu",)] + \
         [("experiment", p, s) for p, s in _leaves(_experiment_schema())]


@settings(max_examples=600, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(case=st.sampled_from(LEAVES), data=st.data())
def test_every_invalid_yaml_value_names_its_key_path(case, data):
    fmt, path, spec = case
    schema = {"imu": _imu_schema, "scenario": _scenario_schema, "experiment": _experiment_schema}[fmt]()
    bad = data.draw(st.sampled_from(_bad_values(spec)))
    doc = _set(BASES[fmt](), schema, path, bad)
    ctx = _quiet()
    try:
        with pytest.raises(ConfigError) as info:
            _load(fmt, doc)
    finally:
        ctx.__exit__(None, None, None)
    text = str(info.value)
    assert "\n" not in text
    assert f": {_shown(path)}" in text, (text, _shown(path), bad)


def test_the_leaves_cover_the_reference():
    """Every number/vector/string/bool the reference lists is exercised by the invalid-value property."""
    n_rows = sum(1 for fmt, sch in (("imu", _imu_schema()), ("scenario", _scenario_schema()),
                                    ("experiment", _experiment_schema()))
                 for r in describe(sch) if r["kind"] in ("number", "integer", "string", "bool")
                 or r["kind"].startswith("list of"))
    assert len(LEAVES) == n_rows
