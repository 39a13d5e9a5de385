"""The resolve stage between configuration and the engine (issue 38, item 7): ``load_scenario -> resolve_plan ->
run_plan``.

``config/`` checks keys, units and ranges and enters the plan (``sins_sim.plan``) once; the plan refuses what does
not compose with a ``PlanError`` line that configuration raises unchanged as a ``ConfigError`` located in the file;
the engine runs the plan the scenario carries. The import direction itself is checked in tests/test_layers.py.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sins_sim.config.errors import ConfigError
from sins_sim.config.scenario import load_scenario

ROOT = Path(__file__).resolve().parents[1]
IMU = ROOT / "configs" / "default-imu.yaml"

#: a scenario file whose temperature section moves the isolators of a unit that has none (a rigid block): keys that
#: are right one by one and do not compose
_NO_BLOCK = f"""name: t
imu: {IMU}
duration_s: 2.0
navigation: {{start_s: 1.0}}
temperature:
  profile: constant
  initial_k: 293.15
  f0_ppm_per_k: -30.0
  isolators: {{stiffness_ppm_per_k: -5000.0}}
"""


def test_a_pair_refused_by_the_plan_is_the_files_configuration_error(tmp_path):
    """The plan's refusal names both keys and reaches the user as the ConfigError of the file, located at the key's
    line and column (line 9: ``temperature:`` is line 5, ``isolators`` its fourth key), not as a PlanError."""
    from sins_sim.plan import PlanError

    path = tmp_path / "s.yaml"
    path.write_text(_NO_BLOCK)
    with pytest.raises(ConfigError) as info:
        load_scenario(path)
    msg = str(info.value)
    assert not isinstance(info.value, PlanError)
    assert msg.startswith(f"{path}:9:3: temperature.isolators: needs an IMU block: section")
    assert "imu has none" in msg and "add imu.block" in msg and "\n" not in msg


def test_resolve_plan_raises_the_same_line_as_a_plan_error(tmp_path):
    """Called directly (as an experiment or a twin could), the plan raises PlanError, a ValueError, with the message
    configuration shows, minus the file position configuration adds."""
    import yaml

    from sins_sim.config.imu import parse_imu
    from sins_sim.config.scenario import SCENARIO_SCHEMA
    from sins_sim.config.schema import validate
    from sins_sim.config.yaml_io import load_yaml
    from sins_sim.plan import PlanError, resolve_plan

    doc = yaml.safe_load(_NO_BLOCK)
    c = validate(doc, SCENARIO_SCHEMA, "s.yaml")
    unit = parse_imu(load_yaml(IMU), "s.yaml -> default-imu.yaml", base_dir=IMU.parent)
    with pytest.raises(PlanError) as info:
        resolve_plan({"c": c, "doc": doc, "imu": unit, "ctx": "s.yaml", "base_dir": tmp_path,
                      "duration_key": "duration_s"})
    assert isinstance(info.value, ValueError) and not isinstance(info.value, ConfigError)
    assert str(info.value).startswith("s.yaml: temperature.isolators: needs an IMU block: section")


def test_loading_enters_the_plan_once(monkeypatch):
    """A scenario's configuration calls resolve_plan exactly once, and the unit is built once, inside it."""
    import sins_sim.plan as plan
    import sins_sim.plan.imu as plan_imu

    calls = {"plan": 0, "imu": 0}
    real_plan, real_imu = plan.resolve_plan, plan_imu.resolve_imu

    def count_plan(parsed):
        calls["plan"] += 1
        return real_plan(parsed)

    def count_imu(parsed):
        calls["imu"] += 1
        return real_imu(parsed)

    monkeypatch.setattr(plan, "resolve_plan", count_plan)
    monkeypatch.setattr(plan_imu, "resolve_imu", count_imu)
    sc = load_scenario(ROOT / "scenarios" / "stationary.yaml")
    assert calls == {"plan": 1, "imu": 1}
    # the scenario's engine inputs are the plan's own objects, not copies that could drift apart
    for name in ("imu", "motion", "translation", "vehicle", "nav", "filters", "seed", "duration_s", "site"):
        assert getattr(sc, name) is getattr(sc.plan, name), name


def test_run_plan_runs_every_field_of_the_plan():
    """run_plan hands the engine every field: a plan with translation entering at the chassis, a cone and a short
    mission gives, sample for sample, what simulate_sins gives on the same fields spelt out (same seed, one
    thread: the engine is deterministic), and differs from a run without the translation (so a dropped field would
    show)."""
    import dataclasses

    from sins_sim.plan import run_plan
    from sins_sim.simulation.sins import simulate_sins

    sc = load_scenario({"name": "t", "imu": str(IMU), "duration_s": 0.6, "seed": 3,
                        "navigation": {"start_s": 0.2}, "filters": ["ideal", "correcting"],
                        "motion": [{"type": "coning", "amplitude_arcmin": 1.0, "frequency_hz": 5.0}],
                        "linear_vibration": [{"type": "sines", "amplitude_m_s2": [0.0, 0.0, 5.0],
                                              "frequency_hz": [30.0, 30.0, 30.0]}]})
    assert sc.translation is not None
    got = run_plan(sc.plan, threads=1)
    p = sc.plan
    ref = simulate_sins(p.imu, p.motion, p.duration_s, seed=p.seed, nav=p.nav, filters=p.filters, threads=1,
                        vehicle=p.vehicle, translation=p.translation, vibration_enters=p.vibration_enters,
                        motion_enters=p.motion_enters)
    bare = run_plan(dataclasses.replace(p, translation=None), threads=1)
    for name in p.filters:
        assert got.series[name].keys() == ref.series[name].keys()
        for key, arr in got.series[name].items():
            assert np.array_equal(arr, ref.series[name][key], equal_nan=True), (name, key)
    # 5 m/s^2 at 30 Hz on z moves the velocity by 5 / (2 pi 30) = 27 mm/s peak: the ideal's error series see it
    assert any(not np.array_equal(arr, bare.series["ideal"][key], equal_nan=True)
               for key, arr in got.series["ideal"].items())


# --- a command that varies the unit re-resolves what depends on it (with_unit) -----------------------------------------

def _tuned_doc(filter_parameters) -> dict:
    return {"name": "tuned", "imu": str(IMU), "duration_s": 2.0, "filters": ["correcting", "eliminator"],
            "filter_parameters": filter_parameters,
            "navigation": {"start_s": 1.0, "coning": "filter_tuned", "tuned_band_hz": [20.0, 200.0]}}


def test_with_unit_redesigns_the_filter_tuned_coefficients_on_the_new_units_filters():
    """The budget's ``filter_mismatch`` off makes the filters believe the truth: the plan on that unit must carry the
    coefficients designed on those filters, which a scenario whose filters believe the truth (``filter_parameters:
    true``, resolved independently) has. They differ from the mismatched unit's: with eq. 5 2 % off f0 the 20-200 Hz
    design is ill-conditioned and falls back to the two-sample coefficients (with a warning), on the true f0 it is
    not, so a plan that kept the old designs fails the first comparison. Equality is exact: the same design computed
    on the same unit."""
    import warnings

    from sins_sim.config.scenario import Scenario
    from sins_sim.jobs.budget import apply_off
    from sins_sim.plan import with_unit

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the mismatched design's fall-back line
        mismatched = Scenario(_tuned_doc({"source": True, "f0_mismatch_ppm": 20000.0}), "t", ROOT)
    truth = Scenario(_tuned_doc(True), "t", ROOT)
    plan = with_unit(mismatched.plan, apply_off(mismatched.imu, ("filter_mismatch",)))
    for name in ("correcting", "eliminator"):
        got, want = (np.asarray(p.nav.designs[name]["coefficients"]) for p in (plan, truth.plan))
        assert np.array_equal(got, want), name
    assert not np.array_equal(np.asarray(mismatched.plan.nav.designs["correcting"]["coefficients"]),
                              np.asarray(plan.nav.designs["correcting"]["coefficients"]))
    # what the command did not vary is the scenario's own
    assert plan.motion is mismatched.plan.motion and plan.vehicle is mismatched.plan.vehicle


def test_with_unit_refuses_a_unit_at_another_filter_rate():
    """``n_sub`` was resolved on the filter rate: a unit at another rate needs the scenario resolved again."""
    import dataclasses

    from sins_sim.plan import PlanError, with_unit

    sc = load_scenario(ROOT / "scenarios" / "stationary.yaml")
    chans = tuple(dataclasses.replace(c, readout=dataclasses.replace(c.readout, output_rate_hz=2.0 * c.readout.output_rate_hz))
                  for c in sc.imu.channels)
    with pytest.raises(PlanError, match=r"^cmd: readout\.output_rate_hz: .*resolve the scenario again"):
        with_unit(sc.plan, dataclasses.replace(sc.imu, channels=chans), "cmd")
