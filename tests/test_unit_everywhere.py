"""The user's unit everywhere (issue 38, item 3): ``compare-filters --imu/--scenario``, a sweep of the block and its
isolators, and ``sins-sim online-study`` over every filter that takes parameters."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from sins_sim.cli import main
from sins_sim.config.imu import load_imu, load_yaml

ROOT = Path(__file__).resolve().parents[1]
#: The helicopter unit of issue 38: three RLGs at 338, 379 and 417 Hz (the bundled paper suspension otherwise).
HELI_F0 = {"x": 338.0, "y": 379.0, "z": 417.0}


def _heli_imu(folder: Path, block: bool = False) -> Path:
    doc = dict(load_yaml(ROOT / "configs" / ("isolated-block.yaml" if block else "default-imu.yaml")))
    doc["name"] = "heli-unit"
    doc["channels"] = {ax: {"f0_hz": f} for ax, f in HELI_F0.items()}
    p = folder / ("heli-block.yaml" if block else "heli-imu.yaml")
    p.write_text(yaml.safe_dump(doc))
    return p


def _hover(folder: Path, imu: str = "heli-imu.yaml") -> Path:
    """3 s in hover: the 4-blade rotor's 21.6 Hz line on x and y, the tail-rotor line at 86.4 Hz on z."""
    doc = {"name": "hover-rotor", "seed": 5, "duration_s": 3.0, "imu": imu,
           "motion": [{"type": "sines", "amplitude_arcmin": [0.5, 0.5, 0.2], "frequency_hz": [21.6, 21.6, 86.4]}],
           "navigation": {"coning": "two_sample", "start_s": 1.0}}
    p = folder / "hover.yaml"
    p.write_text(yaml.safe_dump(doc))
    return p


# --- compare-filters on the user's unit and mission ------------------------------------------------------------------

def test_compare_filters_runs_on_the_users_unit_and_mission(tmp_path):
    """The comparison at a tiny resolution on the helicopter unit and its hover mission: every channel's eliminator
    is centred on that unit's drive (the amplitude-dependent resonance of 338/379/417 Hz, eq. 9's backbone: 0.5-0.6 %
    below f0 at 3 arcmin, not the default unit's 386/352/421 Hz), and the position-error column is the hover's."""
    from sins_sim.jobs.compare_filters import CompareSettings, run_compare_filters

    imu = _heli_imu(tmp_path)
    scen = _hover(tmp_path)
    st = CompareSettings(n_gain=2, gain_axes=(0,), settle_s=0.4, measure_s=0.1, stationary_s=0.6, coning_s=1.5,
                         coning_start_s=0.4, mission_s=None, cost_samples=2000, quick=True)
    res = run_compare_filters(tmp_path / "out", tmp_path / "out" / "f.json", filters=(), imu=imu, scenario=scen,
                              settings=st)
    details = json.loads((tmp_path / "out" / "details.json").read_text())
    drives = {ax: ch.drive_signal().frequency_hz for ax, ch in zip("xyz", load_imu(imu).channels)}
    unit = details["unit"]
    assert unit["source"] == str(imu.resolve()) and unit["name"] == "heli-unit" and not unit["block"]
    for ax, row in unit["channels"].items():
        assert row["f0_hz"] == HELI_F0[ax]
        assert row["drive_hz"] == drives[ax]
        # the band is drive +- width / 2: its centre is the drive to rounding
        assert row["eliminator_centre_hz"] == pytest.approx(drives[ax], rel=1e-12)
        assert 0.99 * HELI_F0[ax] < row["drive_hz"] < HELI_F0[ax]
    # the single-channel gain sweep leaves out +-2 % around the user's dithers, not the default unit's
    assert details["gain"]["dither_hz"] == pytest.approx([drives[a] for a in "xyz"], rel=1e-12)
    pe = details["position_error_m"]
    assert pe["mission"] == "hover-rotor" and pe["duration_s"] == 3.0
    assert set(pe["horizontal_final"]) == {"ideal", "eliminator", "correcting", "correcting_paper"}
    assert all(math.isfinite(v) for v in pe["horizontal_final"].values())
    report = (tmp_path / "out" / "report.md").read_text()
    assert f"Unit `{imu.resolve()}` (heli-unit)" in report and "mission `hover-rotor`" in report
    assert f"| x | 338 | {drives['x']:.6g} | {drives['x']:.6g} |" in report
    assert set(res["filters"]) == {"eliminator", "correcting", "correcting_paper"}


def test_the_scenarios_own_imu_is_the_unit_and_a_block_moves_the_drives(tmp_path):
    """``--scenario`` alone: its IMU is the unit. With a block the SINS runs' drives and eliminator centres are the
    coupled resonances on the block, listed beside the rigid-fixture ones (issue 38: 336.141 Hz on a fixture,
    about 3 Hz higher on the block)."""
    from sins_sim.jobs.compare_filters import resolve_unit, unit_table
    from sins_sim.models.block import coupled_dither_frequencies

    _heli_imu(tmp_path, block=True)
    um = resolve_unit(None, _hover(tmp_path, imu="heli-block.yaml"))
    assert um.source == str((tmp_path / "heli-block.yaml").resolve()) and um.imu.block is not None
    rigid = [c.drive_signal().frequency_hz for c in um.imu.channels]
    coupled = coupled_dither_frequencies(um.imu.block, [2.0 * math.pi * f for f in rigid])
    table = unit_table(um.imu)
    for a, (ax, row) in enumerate(table.items()):
        assert row["eliminator_centre_hz"] == pytest.approx(rigid[a], rel=1e-12)
        assert row["drive_on_block_hz"] == pytest.approx(coupled[a], rel=1e-12)
        assert row["eliminator_centre_on_block_hz"] == pytest.approx(coupled[a], rel=1e-12)
    assert table["x"]["drive_hz"] == pytest.approx(336.141, abs=5e-4)
    assert table["x"]["drive_on_block_hz"] - table["x"]["drive_hz"] > 2.0


@pytest.mark.parametrize("flag, write, expect", [
    ("--imu", None, "--imu: file not found: "),
    ("--imu", "channels: {x: {f0_hz: 338}, y: {f0_hz: 379}, z: {f0_hz: -417}}\n", "--imu: "),
    ("--scenario", "name: s\nduration_s: -3\nimu: ../configs/default-imu.yaml\nmotion: [{type: static}]\n",
     "--scenario: "),
    ("--scenario", None, "--scenario: file not found: "),
])
def test_bad_unit_or_mission_files_are_one_line_naming_the_flag(tmp_path, capsys, flag, write, expect):
    path = tmp_path / "bad.yaml"
    if write is not None:
        path.write_text(write)
    out = tmp_path / "out"
    assert main(["compare-filters", flag, str(path), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"sins-sim: error: {expect}") and "\n" not in err and "Traceback" not in err, err
    assert not out.exists()


# --- a sweep of the block and its isolators -------------------------------------------------------------------------

def _block_sweep(tmp_path, population, units=3) -> Path:
    doc = {"name": "mount-lot", "seed": 11, "units": units, "run_seed": "scenario",
           "scenarios": [{"path": str(ROOT / "scenarios" / "isolated-block.yaml"), "duration_s": 1.1}],
           "population": population}
    p = tmp_path / "mount.yaml"
    p.write_text(yaml.safe_dump(doc))
    return p


def test_a_sweep_of_isolator_stiffness_moves_each_units_modes(tmp_path):
    """Three units of the isolated block with the isolators' stiffness spread 10 % per axis and the mass 2 %: the
    table holds the values each run used (N/m, kg, under the IMU file's keys), and each unit's translation modes are
    ``sqrt(k_i / m) / (2 pi)`` of its own columns. With the elastic centre at the c.g. and a diagonal inertia the
    translations decouple from the rocking and the gyros (their mass is in m), so the closed form is exact: the
    tolerance 1e-9 is the eigen-solver's rounding on a 18 x 18 system (1e-15 relative) with margin."""
    from sins_sim import __version__
    from sins_sim.jobs.sweep.job import prepare_sweep
    from sins_sim.jobs.sweep.tasks import BLOCK_MODE_PREFIX, PARAM_PREFIX, run_task

    path = _block_sweep(tmp_path, {"block": {"stiffness_percent": {"width": 10.0},
                                             "mass_percent": {"distribution": "uniform", "width": 2.0}}})
    _, tasks, _ = prepare_sweep(path)
    file_k = 7.58e5
    rows = [run_task(t.spec(__version__)) for t in tasks]
    modes = []
    for t, row in zip(tasks, rows):
        k = [row[f"{PARAM_PREFIX}block.isolators.stiffness_n_per_m.{ax}"] for ax in "xyz"]
        m = row[f"{PARAM_PREFIX}block.mass_kg"]
        draws = [t.params[f"block.isolators.stiffness_n_per_m.{ax}"] for ax in "xyz"]
        assert k == draws and not any(c.startswith(f"{PARAM_PREFIX}block.stiffness_percent") for c in row)
        assert all(0.5 * file_k < x < 1.5 * file_k for x in k) and 2.9 < m < 3.1  # physical values, not scores
        got = sorted(row[f"{BLOCK_MODE_PREFIX}{i}"] for i in range(1, 7))[:3]
        expected = sorted(math.sqrt(x / m) / (2.0 * math.pi) for x in k)
        np.testing.assert_allclose(got, expected, rtol=1e-9)
        modes.append(got)
        assert row["ideal.status"] == "ok"
    # every unit and every axis its own mode: the spread moves them by ~5 % (half the stiffness spread)
    flat = np.ravel(modes)
    assert np.min(np.abs(flat[:, None] - flat[None, :]) + np.eye(flat.size)) > 1e-3


@pytest.mark.parametrize("population, expect", [
    ({"block": {"stiffness_percent": {"distribution": "uniform", "mean": -30.0, "width": 80.0}}},
     "population.block.stiffness_percent: mean - width = -110 % lets a unit's value reach zero or below"),
    ({"block": {"mass_percent": {"distribution": "grid", "values": [0.0, -100.0]}}},
     "population.block.mass_percent.values: -100 % makes the quantity zero or negative"),
    ({"block": {"rotational_stiffness_percent": {"mean": -60.0, "width": 30.0}}},
     "population.block.rotational_stiffness_percent.width: 30 draws "),
])
def test_a_spread_that_makes_the_block_unphysical_is_refused_naming_the_key(tmp_path, capsys, population, expect):
    """Uniform and grid spreads by their range, at load; a normal spread by the units it draws (the IMU schema
    refuses a negative stiffness; seed 11 draws -108 % for unit 1's y), naming the key, the unit and the draw."""
    out = tmp_path / "out"
    assert main(["sweep", str(_block_sweep(tmp_path, population, units=4)), "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert expect in err and "\n" not in err and "Traceback" not in err, err
    assert not out.exists()


def test_a_block_spread_over_an_imu_without_a_block_is_refused(tmp_path, capsys):
    doc = {"name": "no-block", "seed": 1, "units": 2,
           "scenarios": [{"path": str(ROOT / "scenarios" / "stationary.yaml"), "duration_s": 1.5}],
           "population": {"block": {"damping_percent": {"width": 5.0}}}}
    p = tmp_path / "s.yaml"
    p.write_text(yaml.safe_dump(doc))
    assert main(["sweep", str(p), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert "population.block.damping_percent: scenarios[0] (stationary) runs " in err and "no block: section" in err


def test_apply_unit_draws_every_block_quantity():
    """Each spread key lands on its IMU key: percent on positive quantities, mm added to the elastic centre."""
    from sins_sim.jobs.sweep.population import apply_unit, block_values

    doc = dict(load_yaml(ROOT / "configs" / "offset-mount-block.yaml"))
    unit = {"block.mass_percent": 10.0, **{f"block.{k}.{ax}": v for ax, v in zip("xyz", (10.0, -20.0, 50.0))
                                           for k in ("inertia_percent", "gyro_inertia_percent", "stiffness_percent",
                                                     "damping_percent", "rotational_stiffness_percent",
                                                     "rotational_damping_percent", "elastic_centre_mm")}}
    got = apply_unit(doc, unit)["block"]
    b = doc["block"]
    assert got["mass_kg"] == pytest.approx(3.3, rel=1e-12)
    assert [got["inertia_kg_m2"][m] for m in ("xx", "yy", "zz")] == pytest.approx([0.0132, 0.0104, 0.0225])
    assert got["gyro_inertia_kg_m2"] == pytest.approx([2.2e-4, 1.6e-4, 3.0e-4])
    assert got["isolators"]["stiffness_n_per_m"] == pytest.approx([7.58e5 * 1.1, 7.58e5 * 0.8, 7.58e5 * 1.5])
    assert got["isolators"]["elastic_centre_mm"] == pytest.approx([20.0, -20.0, 80.0])  # file: 10, 0, 30 mm
    assert b["isolators"]["elastic_centre_mm"] == [10.0, 0.0, 30.0]  # the file's mapping is not changed
    vals = block_values({"block": got}, unit)
    assert vals["block.mass_kg"] == pytest.approx(3.3) and vals["block.inertia_kg_m2.yy"] == pytest.approx(0.0104)
    assert vals["block.isolators.rotational_damping_n_m_s_per_rad.z"] == pytest.approx(0.942 * 1.5)
    assert len(vals) == 1 + 7 * 3


# --- sins-sim online-study -----------------------------------------------------------------------------------------

def test_the_filters_that_take_parameters():
    """Eq. 5 in both forms and the wideband designs read the believed f0 and k1..k5; the truth, the readout, the
    eliminator (the drive frequency only) and the LMS stripper (its own adaptation) do not."""
    from sins_sim.filters import registry

    # other test modules register their own plug-ins (named *_test) at import: they take parameters too
    shipped = tuple(n for n in registry.parameter_filters() if not n.endswith("_test"))
    assert shipped == ("correcting", "correcting_paper", "correcting_aligned", "correcting_lownoise",
                       "correcting_wideband")
    assert not any(registry.takes_parameters(n) for n in ("ideal", "raw", "eliminator", "lms_stripper"))


def test_online_study_is_a_command_over_the_filters_that_take_parameters(tmp_path, capsys):
    out = tmp_path / "study"
    assert main(["online-study", str(ROOT / "scenarios" / "online-estimation-ramp.yaml"), "--out", str(out),
                 "--duration", "1.5", "--threads", "1", "--filters", "correcting", "correcting_wideband",
                 "--quiet"]) == 0
    res = json.loads((out / "online-study.json").read_text())
    assert res["filters"] == ["ideal", "correcting", "correcting_wideband"]
    assert set(res["variants"]) == {"online", "true", "nominal", "nominal_track"}
    for row in res["variants"].values():
        for name in res["filters"]:
            assert math.isfinite(row[name]["horizontal_position_error_final_m"])
            assert len(row["gyro_error_rms_arcsec"][name]) == 3
    md = (out / "online-study.md").read_text()
    assert "| online | correcting_wideband |" in md and "| nominal_track | correcting |" in md
    assert (out / "manifest.json").is_file() and (out / "online-estimates.png").stat().st_size > 0
    assert "filters: ideal, correcting, correcting_wideband" in capsys.readouterr().out


@pytest.mark.parametrize("argv, expect", [
    (["--filters", "eliminator"], "--filters: eliminator takes no suspension parameters"),
    (["--filters", "correctin"], "--filters: unknown filter 'correctin'"),
    ([], "scenario: give a scenario and --out"),
])
def test_online_study_refusals_are_one_line(tmp_path, capsys, argv, expect):
    scen = [str(ROOT / "scenarios" / "online-estimation-ramp.yaml"), "--out", str(tmp_path / "o")] if argv else []
    assert main(["online-study", *scen, *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert expect in err and "\n" not in err, err
