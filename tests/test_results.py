"""Result objects for notebooks (issue 23, point 3): ``sins_sim.run``, ``MissionResult``, ``sins_sim.load``.

The tables and the Dataset are checked against the files the same run writes (``metrics.json``,
``timeseries.npz``), value for value: both come from the same stored series, so equality is exact
(the conversions are the same operations, ``/ ARCSEC`` and ``numpy.degrees``). Short missions (6 s, at
rest with a light sine vibration, so that every figure including the Allan one has data) keep the
file fast.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml

import sins_sim
from sins_sim.results import FIGURE_KINDS, SERIES_COLUMNS, MissionResult, StoredRun

#: The figures of a mission on the rigid block (the block's two need an IMU block:).
RIGID_KINDS = [k for k in FIGURE_KINDS if not k.startswith("block_")]
from sins_sim.config.errors import ConfigError
from sins_sim.units import ARCSEC

ROOT = Path(__file__).resolve().parents[1]
IMU = str(ROOT / "configs" / "default-imu.yaml")


def _doc(**extra) -> dict:
    """A short mission at rest (sines on the mounts): every figure has data, the Allan one included."""
    doc = {"name": "notebook-static", "seed": 3, "duration_s": 6.0, "imu": IMU,
           "motion": [{"type": "sines", "amplitude_arcmin": [0.2, 0.2, 0.2], "frequency_hz": [95, 143, 211]}],
           "navigation": {"coning": "two_sample", "start_s": 1.0}}
    doc.update(extra)
    return doc


@pytest.fixture(scope="module")
def mission() -> MissionResult:
    return sins_sim.run(_doc(), threads=2)


@pytest.fixture(scope="module")
def saved(mission, tmp_path_factory) -> Path:
    return mission.save(tmp_path_factory.mktemp("saved") / "run")


def _npz(folder):
    with np.load(folder / "timeseries.npz") as z:
        return {k: z[k] for k in z.files}


# --- the public names --------------------------------------------------------------------------------------------
def test_public_api_is_lazy_and_complete():
    import subprocess
    import sys

    from sins_sim import results

    for name in ("run", "load", "sweep_run", "MissionResult", "BudgetResult", "SweepResult", "DiagnosisResult"):
        assert name in sins_sim.__all__
    assert sins_sim.MissionResult is MissionResult
    assert (sins_sim.BudgetResult, sins_sim.SweepResult, sins_sim.DiagnosisResult) == \
        (results.BudgetResult, results.SweepResult, results.DiagnosisResult)
    # the result objects' room is light: importing it loads neither matplotlib, pandas, xarray nor the engine
    code = ("import sys, sins_sim.results; print(sorted(m for m in ('matplotlib', 'pandas', 'xarray', 'numba', "
            "'sins_sim.simulation.sins', 'sins_sim.jobs') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout + out.stderr


# --- to_pandas / to_xarray against the run's own files ------------------------------------------------------------
def test_to_pandas_shapes_and_values_agree_with_timeseries_npz(mission, saved):
    z = _npz(saved)
    frames = mission.to_pandas()
    drawn = [n for n in mission.filters]
    # one table per filter plus summary, truth and gyro error: the multi-trace shape (python-control #891, #957)
    assert set(frames) == {"summary", "truth", "gyro_error", *drawn}
    n_cols = sum(3 * len(stems) for stems, *_ in SERIES_COLUMNS.values())  # mean, min, max per component
    assert n_cols == 45
    for name in drawn:
        df = frames[name]
        t = z[f"{name}__t_s"]
        assert df.shape == (t.size, n_cols)
        assert df.index.name == "t_s" and np.array_equal(df.index.to_numpy(), t)
        for stat_npz, stat_col in (("", ""), ("_min", "_min"), ("_max", "_max")):
            assert np.array_equal(df[f"north{stat_col}_m"], z[f"{name}__north_m{stat_npz}"])
            assert np.array_equal(df[f"horizontal{stat_col}_m"], z[f"{name}__horizontal_m{stat_npz}"])
            assert np.array_equal(df[f"vertical{stat_col}_m"], z[f"{name}__vertical_m{stat_npz}"])
            v = z[f"{name}__velocity_ned_m_s{stat_npz}"]
            for i, c in enumerate(("vn", "ve", "vd")):
                assert np.array_equal(df[f"{c}{stat_col}_m_s"], v[:, i])
            phi = z[f"{name}__attitude_ned_rad{stat_npz}"] / ARCSEC
            for i, ax in enumerate(("north", "east", "down")):
                assert np.array_equal(df[f"phi_{ax}{stat_col}_arcsec"], phi[:, i])
            assert np.array_equal(df[f"lat{stat_col}_deg"], np.degrees(z[f"{name}__lat_rad{stat_npz}"]))
    truth = frames["truth"]
    assert list(truth.columns) == ["lat_deg", "lon_deg", "h_m"]
    assert np.array_equal(truth.index.to_numpy(), z["truth_t_s"])
    assert np.array_equal(truth["lat_deg"], np.degrees(z["truth_lat_rad"]))
    assert np.array_equal(truth["h_m"], z["truth_h_m"])
    g = frames["gyro_error"]
    assert g.shape == (z["gyro_error_t"].size, 3 * len(drawn))
    assert np.array_equal(g["correcting_y_arcsec"], z["gyro_error_correcting"][:, 1] / ARCSEC)


def test_summary_agrees_with_metrics_json(mission, saved):
    m = json.loads((saved / "metrics.json").read_text())
    s = mission.to_pandas()["summary"]
    assert list(s.index) == list(m["filters"])
    for name, f in m["filters"].items():
        assert s.loc[name, "status"] == f["status"]
        assert s.loc[name, "horizontal_final_m"] == f["horizontal_position_error_m"]["final"]
        assert s.loc[name, "vertical_final_m"] == f["vertical_position_error_m"]["final"]
        assert s.loc[name, "velocity_final_m_s"] == f["velocity_error_m_s"]["final"]
        for ax in ("north", "east", "down"):
            assert s.loc[name, f"phi_rms_{ax}_arcsec"] == f["attitude_error_arcsec"]["rms"][ax]
        assert np.isnan(s.loc[name, "cep_rate_nmi_h"])  # null in metrics.json: a 6 s mission has no CEP rate
    # metrics.json is what .metrics holds, through JSON (floats survive exactly)
    assert json.loads(json.dumps(mission.metrics, default=lambda x: x.tolist())) == m


def test_to_xarray_agrees_with_files_and_carries_attributes(mission, saved):
    z = _npz(saved)
    m = json.loads((saved / "metrics.json").read_text())
    ds = mission.to_xarray()
    assert {"time", "filter", "axis", "time_truth", "time_gyro", "gyro_axis"} <= set(ds.dims)
    assert list(ds["filter"].values) == list(mission.filters)
    assert list(ds["axis"].values) == ["north", "east", "down"]
    for name in mission.filters:
        t = z[f"{name}__t_s"]
        phi = ds["phi"].sel(filter=name).sel(time=t)
        assert np.array_equal(phi.values, z[f"{name}__attitude_ned_rad"] / ARCSEC)
        assert np.array_equal(ds["horizontal_max"].sel(filter=name, time=t).values, z[f"{name}__horizontal_m_max"])
        # a time this filter has no sample at is NaN, never a filled-in value
        other = np.setdiff1d(ds["time"].values, t)
        assert np.all(np.isnan(ds["horizontal"].sel(filter=name, time=other).values))
        f = m["filters"][name]
        assert ds["horizontal_final"].sel(filter=name).item() == f["horizontal_position_error_m"]["final"]
        assert [ds["phi_rms"].sel(filter=name, axis=a).item() for a in ("north", "east", "down")] == \
            [f["attitude_error_arcsec"]["rms"][a] for a in ("north", "east", "down")]
    assert np.array_equal(ds["gyro_error"].sel(filter="eliminator", gyro_axis="z").values,
                          z["gyro_error_eliminator"][:, 2] / ARCSEC)
    assert np.array_equal(ds["truth_lon"].values, np.degrees(z["truth_lon_rad"]))
    assert ds["phi"].attrs["units"] == "arcsec" and ds["velocity"].attrs["units"] == "m/s"
    assert ds.attrs["seed"] == 3 and ds.attrs["sins_sim_version"] == sins_sim.__version__
    conf = json.loads(ds.attrs["configuration"])
    manifest = json.loads((saved / "manifest.json").read_text())
    assert conf == {"scenario": manifest["run"]["scenario"], "imu": manifest["run"]["imu"]}


# --- save and load -------------------------------------------------------------------------------------------------
def test_save_writes_the_cli_folder_and_load_round_trips(mission, saved):
    names = {p.relative_to(saved).as_posix() for p in saved.rglob("*") if p.is_file()}
    for f in ("metrics.json", "timeseries.npz", "report.md", "manifest.json", "inputs/scenario.yaml",
              "inputs/imu.yaml", *(f"{k}.png" for k in RIGID_KINDS)):
        assert f in names
    back = sins_sim.load(saved)
    assert isinstance(back.result, StoredRun)
    assert back.metrics == json.loads((saved / "metrics.json").read_text())
    assert back.scenario is not None and back.scenario.name == mission.name
    a, b = mission.to_pandas(), back.to_pandas()
    assert set(a) == set(b)
    for k in a:
        pd.testing.assert_frame_equal(a[k], b[k], check_exact=True)
    x, y = mission.to_xarray(), back.to_xarray()
    assert x.identical(y)
    assert repr(back) == repr(mission)
    # every figure but the Allan one (its curves are not stored) is drawn again from the folder
    assert back.figures == [k for k in RIGID_KINDS if k != "allan"]
    with pytest.raises(ValueError, match="Allan curves are not stored"):
        back.plot("allan")
    with pytest.raises(ConfigError, match="loaded from a folder"):
        back.save(saved.parent / "again")


def test_save_refuses_an_existing_result_without_force(mission, saved):
    with pytest.raises(ConfigError, match="exists|already"):
        mission.save(saved)
    assert mission.save(saved, force=True) == saved
    assert json.loads((saved / "metrics.json").read_text())["seed"] == 3


def test_a_saved_folder_reruns_to_the_same_metrics(saved, tmp_path):
    from sins_sim.cli import main

    assert main(["run", "--rerun", str(saved), "--out", str(tmp_path / "rerun")]) in (0, None)
    assert (tmp_path / "rerun" / "metrics.json").read_bytes() == (saved / "metrics.json").read_bytes()


def test_load_refuses_what_is_not_a_run(tmp_path):
    with pytest.raises(ConfigError, match="load: .* is not a folder"):
        sins_sim.load(tmp_path / "missing")
    (tmp_path / "empty").mkdir()
    with pytest.raises(ConfigError, match="no manifest.json"):
        sins_sim.load(tmp_path / "empty")


# --- run(dict) == run(path); Scenario objects; overrides ---------------------------------------------------------
def test_run_dict_equals_run_path(mission, tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(_doc()))
    from_file = sins_sim.run(path, threads=2)
    assert from_file.metrics == mission.metrics


def test_run_scenario_object_with_overrides(tmp_path):
    sc = sins_sim.load_scenario(_doc(duration_s=8.0))
    r = sins_sim.run(sc, seed=5, duration_s=4.0, threads=2)
    assert (r.seed, r.duration_s) == (5, 4.0)
    direct = sins_sim.run(_doc(seed=5, duration_s=4.0), threads=2)
    assert r.metrics == direct.metrics
    # saved: the manifest says what was overridden, and the inputs copy runs the same mission
    r.save(tmp_path / "o")
    man = json.loads((tmp_path / "o" / "manifest.json").read_text())
    assert man["run"]["overrides"] == {"seed": 5, "duration_s": 4.0}
    assert man["run"]["scenario"]["seed"] == 5 and man["inputs"]["scenario"]["path"] is None


def test_run_refuses_other_types():
    with pytest.raises(ConfigError, match="run: scenario must be a path, a mapping or a Scenario, got int"):
        sins_sim.run(3)


# --- load_scenario / load_imu accept dicts ------------------------------------------------------------------------
def test_load_scenario_dict_validates_like_a_file(tmp_path):
    doc = _doc()
    before = json.dumps(doc, sort_keys=True)
    sc = sins_sim.load_scenario(doc)
    assert json.dumps(doc, sort_keys=True) == before  # the caller's dict is not changed
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(doc))
    from_file = sins_sim.load_scenario(path)
    assert (sc.name, sc.seed, sc.duration_s, sc.filters) == (from_file.name, from_file.seed, from_file.duration_s,
                                                             from_file.filters)
    assert sc.imu == from_file.imu and sc.path is None and from_file.path == path
    with pytest.raises(ConfigError, match=r"^scenario \(dict\): navigation\.start_s: must be < duration_s"):
        sins_sim.load_scenario(_doc(navigation={"start_s": 7.0}))
    with pytest.raises(ConfigError, match=r"^scenario \(dict\): .*duration_s"):
        sins_sim.load_scenario(_doc(duration_s="long"))


def test_relative_paths_in_a_dict_resolve_against_the_working_directory(monkeypatch, tmp_path):
    monkeypatch.chdir(ROOT)
    sc = sins_sim.load_scenario(_doc(imu="configs/default-imu.yaml"))
    assert sc.imu == sins_sim.load_imu(IMU)
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ConfigError, match=r"scenario \(dict\): imu: file not found: " + str(tmp_path)):
        sins_sim.load_scenario(_doc(imu="configs/default-imu.yaml"))


def test_load_imu_dict_equals_load_imu_path():
    from sins_sim.config.yaml_io import load_yaml

    doc = load_yaml(IMU)
    assert sins_sim.load_imu(doc) == sins_sim.load_imu(IMU)
    bad = dict(doc, readout=dict(doc["readout"], output_rate_hz=-1))
    with pytest.raises(ConfigError, match=r"^IMU \(dict\): readout\.output_rate_hz"):
        sins_sim.load_imu(bad)


# --- repr and figures ------------------------------------------------------------------------------------------------
def test_repr_shows_the_headline_numbers(mission):
    text, html = repr(mission), mission._repr_html_()
    assert "notebook-static" in text and "6 s" in text and "seed 3" in text
    assert "<table>" in html
    for name, f in mission.metrics["filters"].items():
        final = f"{f['horizontal_position_error_m']['final']:.4g}"
        rms = ", ".join(f"{f['attitude_error_arcsec']['rms'][a]:.3g}" for a in ("north", "east", "down"))
        line = next(ln for ln in text.splitlines() if ln.strip().startswith(name + " "))
        assert final in line and rms in line and f["status"] in line
        assert final in html and rms in html


@pytest.mark.parametrize("kind", RIGID_KINDS)
def test_plot_returns_a_figure_with_data(mission, kind):
    import matplotlib.pyplot as plt
    from matplotlib.figure import Figure

    assert kind in mission.figures
    fig = mission.plot(kind)
    try:
        assert isinstance(fig, Figure)
        drawn = [ln for ax in fig.axes for ln in ax.get_lines() if np.size(ln.get_xdata())]
        assert drawn, f"{kind}: no line with data"
    finally:
        plt.close(fig)


def test_plot_refuses_unknown_and_empty_kinds(tmp_path):
    r = sins_sim.run(_doc(filters=["ideal"], duration_s=3.0), threads=2)
    with pytest.raises(ValueError, match="unknown figure 'map'"):
        r.plot("map")
    # the ideal increments have no error: no spectrum
    with pytest.raises(ValueError, match="no data for the figure 'gyro_error_spectrum'"):
        r.plot("gyro_error_spectrum")


def test_a_notebook_reaches_a_first_plot_in_ten_lines(monkeypatch, tmp_path):
    """The issue's 'done': a first plot of a mission in at most 10 lines, without a file (an empty working
    directory: the IMU inline, every key but the resonances at its default)."""
    monkeypatch.chdir(tmp_path)
    cell = '''
import sins_sim
imu = {"channels": {"x": {"f0_hz": 386}, "y": {"f0_hz": 352}, "z": {"f0_hz": 421}}}
r = sins_sim.run({"name": "first", "duration_s": 5, "imu": imu, "navigation": {"start_s": 1}})
r
frames = r.to_pandas()
fig = r.plot("navigation_error")
'''
    lines = [ln for ln in cell.strip().splitlines() if ln.strip()]
    assert len(lines) <= 10
    ns = {}
    exec(compile(cell, "<notebook>", "exec"), ns)
    assert ns["frames"]["correcting"]["horizontal_m"].size > 0
    assert ns["fig"].axes and ns["r"].duration_s == 5.0
    assert list(tmp_path.iterdir()) == []  # nothing written
    import matplotlib.pyplot as plt

    plt.close(ns["fig"])


# --- the sweep, the budget and the diagnosis: the same shape, smaller ----------------------------------------------
SWEEP = f"""
name: tiny-notebook
seed: 5
units: 3
scenarios:
  - {{path: {ROOT / 'scenarios' / 'stationary.yaml'}, duration_s: 1.5}}
population:
  f0_ppm: {{width: 2000}}
"""


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    """The rows of a 3-unit sweep, computed serially (the tasks a cluster would run: test_sweep.py shows they
    are equal), as run_sweep hands them back."""
    from sins_sim.results import SweepResult
    from sins_sim.jobs.sweep.job import prepare_sweep
    from sins_sim.jobs.sweep.tasks import run_task

    p = tmp_path_factory.mktemp("sweep") / "tiny.yaml"
    p.write_text(SWEEP)
    _, tasks, _ = prepare_sweep(p)
    table = pd.DataFrame([run_task(t.spec(sins_sim.__version__)) for t in tasks])
    return SweepResult(name="tiny-notebook", summary={}, table=table)


def test_sweep_to_pandas_is_one_row_per_run_and_to_xarray_has_a_run_dimension(sweep, tmp_path):
    from sins_sim.results import SweepResult
    from sins_sim.results.sweep import metric_filters

    df = sweep.to_pandas()
    assert len(df) == 3 and df["unit"].tolist() == [0, 1, 2]
    filters = metric_filters(df)
    ds = sweep.to_xarray()
    assert ds.sizes["run"] == 3 and list(ds["filter"].values) == filters
    metric = "horizontal_position_error_m_final"
    for f in filters:
        assert np.array_equal(ds[metric].sel(filter=f).values, df[f"{f}.{metric}"].to_numpy())
    assert np.array_equal(ds["param.f0_ppm.x"].values, df["param.f0_ppm.x"].to_numpy())
    # the percentile envelope over the population, per scenario and filter
    env = ds[metric].groupby(ds["scenario"]).quantile([0.05, 0.5, 0.95], dim="run")
    assert env.sizes == {"scenario": 1, "quantile": 3, "filter": len(filters)}
    assert ds.attrs["sweep"] == "tiny-notebook"
    # from a folder: runs.parquet and summary.json
    df.to_parquet(tmp_path / "runs.parquet", index=False)
    (tmp_path / "summary.json").write_text("{}")
    pd.testing.assert_frame_equal(SweepResult.from_folder(tmp_path).to_pandas(), df)


def test_sweep_run_gives_one_run_of_the_sweep_with_its_time_series(sweep, tmp_path):
    """The sweep keeps per-run scalars, not time series; ``sweep_run`` runs one run again (same document, draws and
    seed) as a MissionResult. Its metrics are the sweep row's exactly (the same computation on the same inputs;
    the row was computed on one thread, this on the default threads: the axes do not share state), and it has
    the stored series an envelope over time needs."""
    from sins_sim.results.sweep import metric_filters

    sweep_run = sins_sim.sweep_run

    p = tmp_path / "tiny.yaml"
    p.write_text(SWEEP)
    df = sweep.to_pandas()
    row = df[df["unit"] == 1].iloc[0]
    r = sweep_run(p, f"1:{row['scenario']}")
    assert r.seed == row["seed"]
    for f in metric_filters(df):
        m = r.metrics["filters"][f]
        assert m["horizontal_position_error_m"]["final"] == row[f"{f}.horizontal_position_error_m_final"], f
        assert m["horizontal_position_error_m"]["max"] == row[f"{f}.horizontal_position_error_m_max"], f
    assert r.to_pandas()["correcting"]["horizontal_m"].size > 0
    assert sweep_run(p, row["key"]).metrics == r.metrics  # by key as well
    with pytest.raises(ConfigError, match=r"^sweep_run: unit 7 is not in"):
        sweep_run(p, "7:stationary")


def test_sweep_plot_is_the_distribution_figure(sweep):
    import matplotlib.pyplot as plt

    fig = sweep.plot()
    try:
        assert any(ln.get_xdata().size for ax in fig.axes for ln in ax.get_lines())
    finally:
        plt.close(fig)


def _budget():
    """A budget of two sources over two filters, assembled from made-up final error vectors."""
    from sins_sim.jobs.budget import _assemble
    from sins_sim.results import BudgetResult

    def e(n, ea, att):
        return {"position_ne_m": [n, ea], "attitude_ned_arcsec": att}

    runs = {"all": {"ideal": e(3.0, 4.0, [1.0, 2.0, 2.0]), "correcting": e(6.0, 8.0, [2.0, 4.0, 4.0])},
            "floor": {"ideal": e(0.3, 0.4, [0.1, 0.2, 0.2]), "correcting": e(0.6, 0.8, [0.2, 0.4, 0.4])},
            "off:gyro_bias": {"ideal": e(1.0, 1.0, [1.0, 1.0, 1.0]), "correcting": e(2.0, 2.0, [1.0, 1.0, 1.0])},
            "off:quantum": {"ideal": e(3.0, 4.0, [1.0, 2.0, 2.0]), "correcting": e(5.0, 8.0, [2.0, 4.0, 4.0])}}
    b = _assemble(runs, ["gyro_bias", "quantum"], ("ideal", "correcting"))
    b.update(scenario="made-up", duration_s=60.0, filters=["ideal", "correcting"])
    return BudgetResult(b)


def test_budget_to_pandas_rows_are_the_terms_per_filter():
    b = _budget()
    df = b.to_pandas()
    terms = ["total", "dither_residual", "gyro_bias", "quantum", "floor", "remainder"]
    assert list(df.index.get_level_values("term").unique()) == terms
    assert df.shape == (len(terms) * 2, 7)
    # total for correcting: |(6, 8)| = 10 m; gyro_bias's share: |(6 - 2, 8 - 2)| = sqrt(52) m (closed forms)
    assert df.loc[("total", "correcting"), "horizontal_position_error_m"] == pytest.approx(10.0, rel=1e-15)
    assert df.loc[("gyro_bias", "correcting"), "horizontal_position_error_m"] == pytest.approx(52 ** 0.5, rel=1e-15)
    assert df.loc[("quantum", "correcting"), "position_north_m"] == pytest.approx(1.0, rel=1e-15)
    assert df.loc[("floor", "ideal"), "attitude_error_arcsec"] == pytest.approx(0.3, rel=1e-14)


def test_budget_plot_returns_the_budget_figure():
    import matplotlib.pyplot as plt

    fig = _budget().plot()
    try:
        assert len(fig.axes) == 2 and any(len(ax.patches) for ax in fig.axes)
    finally:
        plt.close(fig)


def test_diagnosis_to_pandas_tables():
    from sins_sim.results import DiagnosisResult

    js = DiagnosisResult({
        "noise_floor_arcsec": 0.01, "noise_floor_axes_arcsec": {"x": 0.01, "y": 0.02},
        "baseline": {"residual_rms_arcsec": 0.5, "residual_rms_axes_arcsec": {"x": 0.4, "y": 0.6}},
        "candidates": [{"effect": "backlash", "residual_rms_arcsec": 0.02, "gap_reduction": 0.9, "score": 3.0,
                        "closes_gap": True, "remaining_excess_arcsec": 0.001, "p_heldout": 0.001, "p_f": 1e-6,
                        "significant": True, "unresolved": False, "params": {}},
                       {"effect": "stiction", "residual_rms_arcsec": 0.3, "gap_reduction": 0.1, "score": 0.2,
                        "closes_gap": False, "remaining_excess_arcsec": 0.2, "p_heldout": 0.4, "p_f": 0.3,
                        "significant": False, "unresolved": False, "params": {}}]})
    t = js.to_pandas()
    assert list(t["candidates"].index) == ["backlash", "stiction"]
    assert t["candidates"].loc["stiction", "gap_reduction"] == 0.1
    assert t["axes"].loc["y"].tolist() == [0.02, 0.6]
    empty = DiagnosisResult({"candidates": [], "findings": [{"check": "x"}]}).to_pandas()
    assert empty["candidates"].shape == (0, 9) and empty["axes"].empty


def test_load_of_a_diagnosis_json_is_its_result(tmp_path):
    """``sins_sim.load`` of the file ``diagnose --json`` writes gives the DiagnosisResult of that JSON (tables, no
    figures); a JSON that is no diagnosis is refused in one line naming the file."""
    from sins_sim.results import DiagnosisResult

    js = {"noise_floor_arcsec": 0.01, "noise_floor_axes_arcsec": {"x": 0.01}, "verdict": {"status": "none"},
          "baseline": {"residual_rms_axes_arcsec": {"x": 0.4}},
          "candidates": [{"effect": "backlash", "residual_rms_arcsec": 0.02, "gap_reduction": 0.9, "score": 3.0,
                          "closes_gap": True, "remaining_excess_arcsec": 0.001, "p_heldout": 0.001, "p_f": 1e-6,
                          "significant": True, "unresolved": False}]}
    (tmp_path / "d.json").write_text(json.dumps(js))
    d = sins_sim.load(tmp_path / "d.json")
    assert isinstance(d, DiagnosisResult) and dict(d) == js and d.diagnosis is None
    pd.testing.assert_frame_equal(d.to_pandas()["candidates"], DiagnosisResult(js).to_pandas()["candidates"])
    (tmp_path / "m.json").write_text(json.dumps({"scenario": "x"}))
    with pytest.raises(ConfigError, match=r"m\.json is not the JSON of 'sins-sim diagnose --json'"):
        sins_sim.load(tmp_path / "m.json")


def test_saving_from_a_session_with_pyplot_keeps_its_backend_and_figures(mission, tmp_path):
    """A notebook has pyplot loaded with its own backend: writing the CLI's figures must not switch it to Agg
    (switching closes every open figure of the session)."""
    import matplotlib
    import matplotlib.pyplot as plt

    before = matplotlib.get_backend()
    plt.switch_backend("svg")  # a non-interactive stand-in for a notebook's inline backend
    try:
        mine = plt.figure()
        mission.save(tmp_path / "from-a-session")
        assert plt.fignum_exists(mine.number)
        assert matplotlib.get_backend() == "svg"
        assert (tmp_path / "from-a-session" / "navigation_error.png").is_file()
    finally:
        plt.close("all")
        plt.switch_backend(before)


def test_load_dispatches_on_the_folders_command(tmp_path):
    from sins_sim.jobs.manifest import Manifest
    from sins_sim.results import BudgetResult

    b = _budget()
    folder = tmp_path / "budget"
    folder.mkdir()
    (folder / "budget.json").write_text(json.dumps(b))
    Manifest("budget").write(folder)
    back = sins_sim.load(folder)
    assert isinstance(back, BudgetResult) and back == b
    pd.testing.assert_frame_equal(back.to_pandas(), b.to_pandas())
    other = tmp_path / "channel"
    other.mkdir()
    Manifest("channel").write(other)
    with pytest.raises(ConfigError, match="holds a 'sins-sim channel' result, not a run, budget or sweep"):
        sins_sim.load(other)


@pytest.mark.parametrize("status", ["explained", "invalid data"])
def test_diagnosis_plot_draws_the_reports_figures(tmp_path, status):
    """``DiagnosisResult.plot(kind)`` is the figure ``diagnose --report`` writes as ``<kind>.png``: drawn by the
    same function, written at the report's dpi it gives the same pixels (exact: the same Agg renderer on the
    same data). A refit gives spectrum, envelope and ranking; refused data the angle with the failures marked.
    Pickled (between processes, as ``diagnose_many`` does) the result keeps its JSON and drops the diagnosis."""
    import pickle

    import matplotlib.image as mpimg
    import matplotlib.pyplot as plt
    from test_diagnose_report_statuses import CASES, EFFECTS

    from sins_sim.io.recording import write_recording
    from sins_sim.jobs import recording_jobs

    path = write_recording(tmp_path / "rec.npz", CASES[status]())
    res = recording_jobs.diagnose(path, report_dir=tmp_path / "report", effects=EFFECTS)
    assert res["verdict"]["status"] == status
    want = ["spectrum", "envelope", "ranking"] if status == "explained" else ["angle"]
    assert res.figures == want
    linked = sorted(p.stem for p in (tmp_path / "report").glob("*.png"))
    assert linked == sorted(want)
    for kind in want:
        fig = res.plot(kind)
        try:
            fig.savefig(tmp_path / f"mine-{kind}.png", dpi=110)
        finally:
            plt.close(fig)
        mine, report = mpimg.imread(tmp_path / f"mine-{kind}.png"), mpimg.imread(tmp_path / "report" / f"{kind}.png")
        assert mine.shape == report.shape and np.array_equal(mine, report), kind
    other = "angle" if status == "explained" else "spectrum"
    with pytest.raises(ValueError, match=f"diagnosis figure '{other}'"):
        res.plot(other)
    back = pickle.loads(pickle.dumps(res))
    assert dict(back) == dict(res) and back.diagnosis is None
    with pytest.raises(ValueError, match="JSON only"):
        back.plot()


def test_a_block_mission_draws_its_block_figures_and_keeps_them_through_a_folder(tmp_path):
    """``scenarios/block-dither-coupling.yaml`` cut to 6 s: the block's spectrum and its dither coning are among
    the figures, drawn with data, and again from the saved folder (``timeseries.npz`` keeps the block's record)."""
    import matplotlib.pyplot as plt

    root = Path(__file__).resolve().parents[1]
    r = sins_sim.run(root / "scenarios" / "block-dither-coupling.yaml", duration_s=6.0)
    assert {"block_spectrum", "block_coning"} <= set(r.figures)
    back = sins_sim.load(r.save(tmp_path / "blk"))
    assert {"block_spectrum", "block_coning"} <= set(back.figures)
    np.testing.assert_array_equal(back.result.block["theta_rad"], r.result.block["theta_rad"])
    for res in (r, back):
        for kind in ("block_spectrum", "block_coning"):
            fig = res.plot(kind)
            assert any(np.size(ln.get_xdata()) for ax in fig.axes for ln in ax.get_lines())
            plt.close(fig)
