"""Sim-to-real diagnosis: refit round trips, verdicts on known recordings, report, jobs, blind evaluation.

Recordings are short (about 1 s, one axis where possible) and written with
a different integrator or plant rate than the diagnosis uses, so that
"no effect" really means no effect and not an identical simulator.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from sins_sim.identification.blind import evaluate, format_result, make_case
from sins_sim.identification.diagnose import DiagnoseSettings, diagnose_recording, operating_points
from sins_sim.io.recording import read_recording
from sins_sim.models.effects import EFFECTS, make_effect
from sins_sim.models.suspension import SuspensionParams
from sins_sim.jobs import recording_jobs
from sins_sim.simulation.experiment import (ExperimentInputs, ExperimentSettings, afc_drive, record,
                                            stationary_drive, table_motion)
from sins_sim.units import ARCMIN, ARCSEC, DEG, INTERPOLATED_QUANTUM_RAD

FS = 7200.0
NOM = {"x": SuspensionParams(f0_hz=386.0), "y": SuspensionParams(f0_hz=352.0)}
#: The unit on the bench: f0 +0.15 %, k by a few per cent (fixed, so the tests are reproducible).
TRUTH = {"x": NOM["x"].replace(f0_hz=386.0 * 1.0015, k1=1.75e-4 * 1.06, k2=1.05e-3 * 0.97, k3=4.4e-3 * 1.04,
                               k4=250.0 * 0.95, k5=-1.2e-5 * 0.98),
         "y": NOM["y"].replace(f0_hz=352.0 * 0.999, k3=4.4e-3 * 0.97, k5=-1.2e-5 * 1.03)}
TRUTH_SETTINGS = ExperimentSettings(plant_rate_hz=72000.0, integrator="rk4")


def _recording(experiment="stationary", effects=(), duration=1.0, axes=("x",), noise_arcsec=0.0, seed=0,
               settings=TRUTH_SETTINGS, preroll_s=0.0):
    axes = list(axes)
    pre = int(round(preroll_s * FS))
    n = int(round(duration * FS)) + 1 + pre
    nom = {a: NOM[a] for a in axes}
    table = None
    if experiment == "afc_sweep":
        drive, _ = afc_drive(nom, axes, 3 * ARCMIN, [0.6, 1.0, 1.3], [-2.0, 0.0, 2.0], (n / FS) / 9, FS, n)
    else:
        drive = stationary_drive(nom, axes, 3 * ARCMIN, FS, n)
    if experiment == "rate_table":
        mot = table_motion(12 * DEG, [(30 * ARCMIN, 7.0, 0.3), (3 * ARCMIN, 80.0, 1.0), (1 * ARCMIN, 230.0, 2.0)])
        table = {a: mot for a in axes}
    inputs = ExperimentInputs(axes, FS, n, FS, drive, table)
    return record(inputs, {a: TRUTH[a] for a in axes}, nom, INTERPOLATED_QUANTUM_RAD, list(effects), settings,
                  noise_rad=noise_arcsec * ARCSEC, seed=seed, experiment=experiment, preroll_samples=pre)


# --- refit round trips -------------------------------------------------------------------------------
def test_round_trip_afc_sweep_recovers_the_parameters():
    """An AFC sweep (3 voltages x 3 frequencies, 1.5 s) written at 72 kHz by RK4: the refit recovers the unit.

    Tolerances: f0 0.02 Hz (the sweep pins the resonance curve to far better than its 1 Hz half width),
    k3 and k5 2 % (the amplitude at three drive levels), k1, k2, k4 only as far as 1.5 s can tell
    (20 %; their reported 1-sigma uncertainty must cover the error within 4 sigma)."""
    rec = _recording("afc_sweep", duration=1.5)
    diag = diagnose_recording(rec, DiagnoseSettings(effects=()))
    js = diag.to_json()
    assert js["verdict"]["effect"] == "none" and not js["gap"]["significant"]
    p = js["baseline"]["params"]["x"]
    sd = js["baseline"]["uncertainty"]["x"]
    t = TRUTH["x"]
    assert abs(p["f0_hz"] - t.f0_hz) < 0.02
    assert abs(p["k3"] / t.k3 - 1) < 0.02 and abs(p["k5"] / t.k5 - 1) < 0.02
    for k in ("k1", "k2", "k4"):
        assert abs(p[k] / getattr(t, k) - 1) < 0.2
    for k in ("f0_hz", "k1", "k2", "k3", "k4", "k5"):
        assert abs(p[k] - getattr(t, k)) < 4 * sd[k] + 1e-3 * abs(getattr(t, k)), k
    assert js["baseline"]["residual_rms_arcsec"] < 1.15 * js["noise_floor_arcsec"]


def test_noise_floor_from_the_data():
    """White readout noise of 0.1 arcsec on top of the quantisation: the floor follows the data."""
    clean = diagnose_recording(_recording(duration=0.6), DiagnoseSettings(effects=())).to_json()
    noisy = diagnose_recording(_recording(duration=0.6, noise_arcsec=0.1), DiagnoseSettings(effects=())).to_json()
    q = INTERPOLATED_QUANTUM_RAD / ARCSEC / math.sqrt(12)
    assert clean["noise_floor_arcsec"] == pytest.approx(q, rel=0.05)
    assert noisy["noise_floor_arcsec"] == pytest.approx(math.hypot(0.1, q), rel=0.1)
    assert noisy["verdict"]["effect"] == "none"


# --- verdicts -----------------------------------------------------------------------------------------
@pytest.mark.parametrize("effect", [None, ("scale_factor", {"error": 3e-4})])
def test_none_on_a_clean_rate_table_recording_and_not_on_one_with_an_effect(effect):
    """Another integrator (RK4 at 72 kHz), a sampled table angle and noise are no effect; the same recording with a
    scale-factor error of 300 ppm (the size ``test_each_effect_is_identified`` identifies) is not ``none``: an
    always-``none`` detector fails one of the two."""
    effects = [] if effect is None else [make_effect(effect[0], **effect[1])]
    js = diagnose_recording(_recording("rate_table", effects, noise_arcsec=0.05)).to_json()
    if effect is None:
        assert js["verdict"]["effect"] == "none"
        assert not js["gap"]["significant"]
        assert js["candidates"] == []
    else:
        assert js["gap"]["significant"]
        assert js["verdict"]["effect"] != "none"
        assert js["verdict"]["status"] != "none"


def test_none_when_the_recording_starts_mid_operation():
    rec = _recording("stationary", duration=0.8, preroll_s=2.0)
    assert rec.initial_state == "unknown"
    js = diagnose_recording(rec).to_json()
    assert js["verdict"]["effect"] == "none"


def test_unknown_on_an_off_catalogue_disturbance():
    """A 50 Hz pickup of 0.8 arcsec is no catalogue effect: the gap is found at 50 Hz and left unexplained."""
    e = make_effect("mains_pickup", amplitude_rad=0.8 * ARCSEC, frequency_hz=50.0)
    js = diagnose_recording(_recording("stationary", [e], duration=0.8)).to_json()
    assert js["gap"]["significant"] and js["gap"]["axis"] == "x"
    lo, hi = js["gap"]["band_hz"]
    assert lo <= 50.0 <= hi and hi - lo < 20.0
    assert js["verdict"]["effect"] == "unknown"
    assert all(not c["closes_gap"] for c in js["candidates"])


def test_secant_fit_uncertainty_jacobian_and_model_memo():
    """The fit's solver updates its Jacobian by secants; the Jacobian it reports uncertainties from is a
    finite-difference one at the solution, and a model asked for again is not simulated again (a copy)."""
    from sins_sim.identification.recording_inputs import _masks, _model_inputs
    from sins_sim.identification.refit import _Problem, _solve, fit_axis
    from sins_sim.simulation.experiment import suspension_from_nominal

    rec = _recording("rate_table", [make_effect("piezo_lag", tau_s=1.2e-4)], duration=0.4)
    settings = DiagnoseSettings(threads=1)
    nominal = suspension_from_nominal(rec.nominal["x"])
    used, train = _masks(rec, settings, {"x": nominal})
    q = rec.quantum_rad
    prob = _Problem(_model_inputs(rec, 0), "x", rec.angle("x") + 0.5 * q, nominal, settings, used, train, False,
                    q / math.sqrt(12.0), None, 3 * ARCMIN, 0)
    cls = EFFECTS["piezo_lag"]
    space = cls.fit_space("x", rec.axes)
    x0 = np.concatenate([prob.x_c, [1e-4 / space[0].scale]])
    x, jac, unpack, exact = _solve(prob, cls, x0, space, 8, 1, prob.train)
    j_fd = exact()
    # the finite-difference Jacobian at x, as the chord method takes it at its start
    _, j_ref, _, _ = _solve(prob, cls, x, space, 2, 1, prob.train, frozen_jac=True)
    # Both are forward differences with the same steps at the same x (up to the rounding of x0 + z * xs),
    # so they differ only by the model's own evaluation noise over the step: a few ulps of the residual,
    # amplified by 1/h (h = 1e-3 relative for k1..k5 and the effect, 2e-7 for f0), plus whatever tolerance
    # the simulation's solvers leave, which varies with the machine's libm and BLAS (measured 9e-9 of a
    # column's largest entry on one machine, over 1e-6 on another). The bound, per column, is 1e-3 of the
    # column's largest entry: the forward difference's own truncation error (h f''/2, with h = 1e-3
    # relative), which no two differences at one point can exceed without one of them being something
    # else. The secant Jacobian the solver ends with differs from the finite one by 0.29-3.4 of each
    # column's largest entry (measured), so a bug that reported the secant would fail here by 290x or more.
    scale = np.abs(j_ref).max(axis=0)
    assert np.all(np.abs(j_fd - j_ref).max(axis=0) <= 1e-3 * scale), np.abs(j_fd - j_ref).max(axis=0) / scale
    # the model memo: the same parameters give the same model without a simulation, and a caller
    # changing what it got changes nothing kept
    sus, eff, start = unpack(x)
    m1 = prob.model(sus, eff, start)
    n = prob.nfev
    kept = m1.copy()
    m1[:] = 0.0
    m2 = prob.model(sus, eff, start)
    assert prob.nfev == n and np.array_equal(m2, kept) and np.any(kept != 0.0)
    fit = fit_axis(prob, cls, effect_starts=[{"tau_s": 1e-4}])
    assert fit.effect.params["tau_s"] == pytest.approx(1.2e-4, rel=0.1)
    assert 0.0 < fit.sigma["tau_s"] < 0.1 * fit.effect.params["tau_s"]


def test_polish_from_shared_jacobian_columns_differences_only_the_effect():
    """A candidate's polish that takes the nominal and start-state columns of its Jacobian from the
    baseline's polish (``jac_hint``) runs the model only for the effect's column and its steps, and
    lands where the polish that differences every column lands (tau within 1 %: the chord method's steps
    are accepted on the true cost either way; the hint changes only the search direction)."""
    from sins_sim.identification.recording_inputs import _masks, _model_inputs
    from sins_sim.identification.refit import NOMINAL_KEYS, _Problem, fit_axis

    rec = _recording("rate_table", [make_effect("piezo_lag", tau_s=1.2e-4)], duration=0.4)
    settings = DiagnoseSettings(threads=1)
    from sins_sim.simulation.experiment import suspension_from_nominal

    nominal = suspension_from_nominal(rec.nominal["x"])
    used, train = _masks(rec, settings, {"x": nominal})
    q = rec.quantum_rad

    def problem():
        return _Problem(_model_inputs(rec, 0), "x", rec.angle("x") + 0.5 * q, nominal, settings, used, train, False,
                        q / math.sqrt(12.0), None, 3 * ARCMIN, 0)

    base = fit_axis(problem(), None)
    base_polish = fit_axis(problem(), None, start=base, polish=True, keep_jac=True)
    hint = base_polish.shared_jac
    assert hint.shape[1] == len(NOMINAL_KEYS) + len(problem().nuisance)
    cls = EFFECTS["piezo_lag"]
    start = fit_axis(problem(), cls, start=base, effect_starts=[{"tau_s": 1e-4}])
    p_full, p_hint = problem(), problem()
    full = fit_axis(p_full, cls, start=start, polish=True)
    hinted = fit_axis(p_hint, cls, start=start, polish=True, jac_hint=hint)
    n_eff = len(cls.fit_space("x", rec.axes))
    # model runs: the start, the differenced columns, the steps (at most polish_nfev); the hint's columns
    # are not run
    assert p_full.nfev >= 1 + hint.shape[1] + n_eff
    assert p_hint.nfev <= 1 + n_eff + settings.polish_nfev
    assert hinted.effect.params["tau_s"] == pytest.approx(full.effect.params["tau_s"], rel=0.01)
    assert hinted.effect.params["tau_s"] == pytest.approx(1.2e-4, rel=0.1)
    # a hint whose rows do not belong to this problem is not used
    wrong = fit_axis(problem(), cls, start=start, polish=True, jac_hint=hint[:-1])
    assert wrong.effect.params["tau_s"] == full.effect.params["tau_s"]


#: Each effect on its own recording, in an experiment that can show it, and the parameter tolerance.
CASES = {
    "piezo_lag": ("rate_table", {"tau_s": 1.2e-4}, 0.05),
    "readout_delay": ("rate_table", {"delay_s": 1.5e-5}, 0.05),
    "viscous_damping": ("rate_table", {"zeta": 1e-3}, 0.1),
    "resonance_drift": ("stationary", {"rate_hz_per_s": 0.4}, 0.1),
    "scale_factor": ("rate_table", {"error": 3e-4}, 0.02),
    "block_mode": ("rate_table", {"frequency_hz": 650.0, "zeta": 0.06, "gain": 0.5}, 0.05),
    "lock_in": ("stationary", {"threshold_rad_s": 2.5e-3, "phase_rad": 1.0}, 0.1),
}


@pytest.mark.parametrize("name", list(CASES))
def test_each_effect_is_identified(name):
    experiment, params, tol = CASES[name]
    rec = _recording(experiment, [make_effect(name, **params)], duration=0.6)
    js = diagnose_recording(rec).to_json()
    assert js["gap"]["significant"]
    assert js["verdict"]["effect"] == name, [(c["effect"], c["gap_reduction"], c["score"]) for c in js["candidates"]]
    assert js["verdict"]["gap_reduction"] > 0.9
    got = js["candidates"][0]["params"]["x"]
    for k, val in params.items():
        if k == "phase_rad":
            assert abs(math.remainder(got[k] - val, 2 * math.pi)) < 0.2
        else:
            assert got[k] == pytest.approx(val, rel=tol), k


def test_axis_coupling_is_identified_on_two_axes():
    e = make_effect("axis_coupling", coefficients={"x": {"y": 0.01}})
    rec = _recording("stationary", [e], duration=0.8, axes=("x", "y"))
    js = diagnose_recording(rec).to_json()
    assert js["gap"]["significant_axes"] == ["x"] and js["gap"]["axis"] == "x"
    lo, hi = js["gap"]["band_hz"]
    f_y = NOM["y"].resonance_hz(3 * ARCMIN)
    assert lo - 3 <= f_y <= hi + 3  # the gap sits at y's dither line
    assert js["verdict"]["effect"] == "axis_coupling"
    assert js["candidates"][0]["params"]["x"]["c_y"] == pytest.approx(0.01, rel=0.05)


# --- localisation, report and JSON ------------------------------------------------------------------------
def test_operating_points_of_an_afc_sweep():
    n = int(0.9 * FS)
    drive, plan = afc_drive({"x": NOM["x"]}, ["x"], 3 * ARCMIN, [0.6, 1.0, 1.3], [-2.0, 0.0, 2.0], 0.1, FS, n)
    pts = operating_points(drive[:, 0], FS)
    assert len(pts) == 9
    for p, q in zip(pts, plan):
        assert p["frequency_hz"] == pytest.approx(q["frequency_hz"]["x"], abs=0.01)
        assert p["v_m"] == pytest.approx(q["v_m"]["x"], rel=1e-3)
        assert p["t_s"][0] == pytest.approx(q["t_s"][0], abs=0.021)


def test_json_keys_report_and_jobs(tmp_path):
    """The issue's JSON keys; report.md with the three figures; the CLI's job functions."""
    yaml_text = """
experiment: stationary
description: drift on the bench
axes: [x]
duration_s: 0.8
seed: 3
integrator: rk4
perturb: {f0: 0.001, k: 0.03}
effects:
  - {name: resonance_drift, rate_hz_per_s: 0.5}
"""
    spec = tmp_path / "drift.yaml"
    spec.write_text(yaml_text)
    out = recording_jobs.simulate_recording(spec, tmp_path / "drift.npz")
    assert out["n_samples"] == int(0.8 * FS) + 1 and out["effects"][0]["name"] == "resonance_drift"
    rec = read_recording(tmp_path / "drift.npz")
    assert "drift" not in json.dumps(rec.meta).replace("drift on the bench", "")
    js = recording_jobs.diagnose(tmp_path / "drift.npz", tmp_path / "out.json", tmp_path / "report",
                                 effects=["resonance_drift", "piezo_lag"])
    assert set(js) >= {"noise_floor_arcsec", "baseline", "gap", "candidates", "verdict"}
    assert set(js["baseline"]) >= {"residual_rms_arcsec", "params"}
    assert set(js["gap"]) >= {"significant", "axis", "band_hz", "time_s"}
    for c in js["candidates"]:
        assert set(c) >= {"effect", "residual_rms_arcsec", "gap_reduction", "score", "params"}
    assert [c["score"] for c in js["candidates"]] == sorted(c["score"] for c in js["candidates"])
    assert set(js["verdict"]) >= {"effect", "gap_reduction"}
    assert js["verdict"]["effect"] == "resonance_drift"
    assert json.loads((tmp_path / "out.json").read_text()) == js
    for f in ("report.md", "spectrum.png", "envelope.png", "ranking.png"):
        assert (tmp_path / "report" / f).stat().st_size > 0
    assert "resonance_drift" in (tmp_path / "report" / "report.md").read_text()
    assert "verdict: resonance_drift" in recording_jobs.format_diagnosis(js)


def test_yaml_errors_name_the_key(tmp_path):
    spec = tmp_path / "bad.yaml"
    spec.write_text("experiment: stationary\nduration_s: 1\neffects:\n  - {name: piezo_lag, tau_s: -1}\n")
    with pytest.raises(ValueError, match=r"effects\[0\]: effects.piezo_lag.tau_s: must be in"):
        recording_jobs.simulate_recording(spec, tmp_path / "x.npz")
    spec.write_text("experiment: stationary\nduration: 1\n")
    with pytest.raises(ValueError, match="duration: needs a unit"):
        recording_jobs.simulate_recording(spec, tmp_path / "x.npz")


def test_import_csv_job(tmp_path):
    rec = _recording("rate_table", duration=0.05)
    t = rec.time()
    lines = ["time_s,counts_x,drive_v_x,sins_angle_rad_x"]
    lines += [f"{t[i]:.9f},{rec.counts[i, 0]},{float(rec.drive_v[i, 0])!r},{float(rec.sins_angle[i, 0])!r}"
              for i in range(rec.n_samples)]
    csv = tmp_path / "lab.csv"
    csv.write_text("\n".join(lines) + "\n")
    nominal = tmp_path / "nominal.json"
    nominal.write_text(json.dumps({"x": rec.nominal["x"]}))
    out = recording_jobs.import_csv(csv, tmp_path / "lab.npz", quantum_arcsec=2.42 / 16, nominal=str(nominal),
                                    experiment="rate_table", description="bench 2")
    back = read_recording(out["path"])
    np.testing.assert_array_equal(back.counts, rec.counts)
    np.testing.assert_array_equal(back.drive_v, rec.drive_v)
    np.testing.assert_array_equal(back.sins_angle, rec.sins_angle)
    assert back.fs_hz == pytest.approx(FS, rel=1e-9) and out["has_sins_angle"]
    with pytest.raises(ValueError, match="nominal: is required"):
        recording_jobs.import_csv(csv, tmp_path / "lab2.npz", quantum_rad=1e-6)


def test_settings_validation():
    with pytest.raises(ValueError, match="diagnose.effects"):
        DiagnoseSettings(effects=("teleport",))
    with pytest.raises(ValueError, match="diagnose.min_gap_reduction"):
        DiagnoseSettings(min_gap_reduction=1.5)
    assert set(DiagnoseSettings().effects or EFFECTS) == set(EFFECTS)


# --- blind evaluation -----------------------------------------------------------------------------------------
def test_blind_cases_hide_their_label():
    rec, info = make_case("block_mode", np.random.default_rng(0), 0.2)
    assert info["label"] == "block_mode" and "block" not in json.dumps(rec.meta)
    assert rec.experiment == "rate_table"


def test_diagnose_eval_small_fixed_set():
    """Four hidden cases (a clean one, an off-catalogue one, two effects): at least three right."""
    res = evaluate(4, seed=5, duration_s=0.8, labels=["none", "off_catalogue", "scale_factor", "lock_in"])
    assert res["n"] == 4 and sum(sum(r.values()) for r in res["confusion"].values()) == 4
    assert res["accuracy"] >= 0.75, format_result(res)
    assert "accuracy" in format_result(res) == recording_jobs.format_eval(res)


def test_several_recordings_in_parallel_give_what_each_gives_alone(tmp_path, capsys):
    """``sins-sim diagnose A B --jobs 2``: one JSON and one report folder per recording, named by the file
    stem, each equal to the diagnosis of that recording alone (the verdicts and every gap reduction: the
    recordings are independent, and a diagnosis does not depend on its thread count); a second recording
    with the same stem is refused in one line before any work."""
    import json

    from sins_sim.cli import main
    from sins_sim.io.recording import write_recording

    recs = {"piezo": _recording("rate_table", [make_effect("piezo_lag", tau_s=1.2e-4)], duration=0.4),
            "clean": _recording("stationary", duration=0.4, seed=3)}
    paths = []
    for name, rec in recs.items():
        paths.append(str(write_recording(tmp_path / f"{name}.npz", rec)))
    assert main(["diagnose", *paths, "--jobs", "2", "--json", str(tmp_path / "js"), "--report",
                 str(tmp_path / "rep")]) == 0
    for name, path in zip(recs, paths):
        both = json.loads((tmp_path / "js" / f"{name}.json").read_text())
        assert (tmp_path / "rep" / name / "report.md").is_file()
        assert main(["diagnose", path, "--json", str(tmp_path / f"{name}-alone.json")]) == 0
        alone = json.loads((tmp_path / f"{name}-alone.json").read_text())
        assert both["verdict"]["effect"] == alone["verdict"]["effect"]
        assert both["verdict"]["status"] == alone["verdict"]["status"]
        assert [c["gap_reduction"] for c in both["candidates"]] == [c["gap_reduction"] for c in alone["candidates"]]
    assert json.loads((tmp_path / "js" / "piezo.json").read_text())["verdict"]["effect"] == "piezo_lag"
    assert json.loads((tmp_path / "js" / "clean.json").read_text())["verdict"]["effect"] == "none"
    capsys.readouterr()
    (tmp_path / "other").mkdir()
    same = write_recording(tmp_path / "other" / "piezo.npz", recs["piezo"])
    assert main(["diagnose", paths[0], str(same), "--json", str(tmp_path / "js2")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "share the name 'piezo'" in err[0]
    assert not (tmp_path / "js2").exists()
