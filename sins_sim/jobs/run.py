"""``sins-sim run``: a scenario through the full INS loop, and its results on disk.

Writes into the output folder:

* ``metrics.json``: per filter, the navigation errors of the integrated solution against
  the truth (horizontal and vertical position, velocity, attitude per NED axis), the CEP rate
  for missions of 30 min or more, a drift only where a ramp explains the attitude error (with
  its 95 % interval), steps across shocks and scale-factor errors across block turns, and the
  linear error model's prediction as a labelled cross-check;
* ``timeseries.npz``: the stored error series (block means with min/max envelopes, never a
  decimated sample), the truth path, and the gyro-angle errors at the full filter rate over
  ``navigation.spectrum_s``;
* the figures that have data (``navigation_error.png``, ``attitude_error.png``, ``trajectory.png``,
  ``gyro_error_spectrum.png``, ``allan.png``, with a block ``block_spectrum.png`` and ``block_coning.png``: see
  :func:`sins_sim.plots.navigation.plot_run`) and
  ``report.md``, which lists them and the parameters each filter used;
* ``manifest.json`` and ``inputs/`` (:mod:`sins_sim.jobs.manifest`): versions, command line,
  timings, the scenario and IMU as run with every default filled in, input hashes, the seed
  and the parameters each filter used; ``sins-sim run --rerun`` runs the folder again.
"""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path

import numpy as np

from sins_sim.units import ARCMIN, ARCSEC, DEG_PER_H, MICRO_G

__all__ = ["run_scenario", "prepare_run", "compute_run", "write_run", "timeseries_arrays", "scenario_metrics", "excess_over_ideal", "NMI_M", "CEP_RATE_MIN_S", "DEFINITIONS"]

#: One international nautical mile (m).
NMI_M = 1852.0
#: The CEP rate (final horizontal error over the navigated time) is reported for missions at
#: least this long (s): over shorter ones the Schuler oscillation (84.4 min) dominates a radial
#: error rate.
CEP_RATE_MIN_S = 1800.0
_NED = ("north", "east", "down")
#: What the per-filter figures of ``metrics.json`` are (written under ``definitions``).
DEFINITIONS = {
    "attitude_error_arcsec": (
        "phi, per NED axis: the rotation vector of q_est (x) q_true*, the computed body attitude against the true "
        "NED frame at the true position (C_nb_est = (I + [phi x]) C_nb_true); bounded by the Schuler loop. 'final' "
        "and 'rms' (full rate) are phi; 'final_psi' is psi = phi + (dlon cos L, -dlat, -dlon sin L), the attitude "
        "error against the NED frame at the computed position, whose dynamics carry no velocity error"),
    "attitude_drift_deg_h": (
        "the effective attitude drift the navigation sees, per NED axis: the slope of psi(t) - psi(t0) + "
        "int (Omega_ie + w_en) x psi dt (psi-angle equations; Earth- and transport-rate coupling removed), where a "
        "ramp explains it; coning and sculling losses of the attitude integration show here and in no gyro axis"),
    "gyro_drift_deg_h": (
        "the drift of each filter's increments per body axis: the slope of its gyro-angle error (output minus the "
        "true increments, accumulated), where a ramp explains it; a gyro bias shows here"),
    "excess_over_ideal": "a filter's cost: the norm of the difference of its and ideal's final error vectors",
    "dither_under_vibration": (
        "per sine line of the angular motion and gyro whose forced deflection reaches the drive's synchronous "
        "detector (at least one readout quantum): the block's rotation about the gyro's axis at the line, the "
        "suspension's transmissibility and forced deflection, what the detector reads of it, the dither the closed "
        "amplitude loop then leaves at the drive frequency (forecast: the mean modulus over the beat held at the "
        "target) and its peak rate against the lock_in threshold, and the block_cycles that put the line at the "
        "detector's first null (sins_sim.plan.advisories.dither_under_lines)"),
    "timeseries": (
        "timeseries.npz (and the figures, drifts, beats and steps read from it): per stored interval the mean of the "
        "error over every filter sample, never over the navigation updates alone (below the filter rate each "
        "update's attitude and velocity error gains its between-update part, measured from the filter-rate "
        "gyro-angle and accelerometer errors; position takes the line between updates), with the min/max envelope "
        "of those means and of the errors at the updates; 'rms', 'max' and 'final' are taken at the updates"),
    "allan": ("noise terms read only on the longest span at rest, a line removed, where the power-law model "
              "describes the curve and the term's region shows its own slope; otherwise null with the reason"),
    "filter_report": ("what a plug-in reports about itself (lms_stripper: its final gain matrices E and F in rad "
                      "per V s, its convergence time, the last time the gains were more than 1 % from their final "
                      "values, and why it diverged, if it did)"),
}


def _ned(vec) -> dict:
    return {k: float(x) for k, x in zip(_NED, vec)}


def scenario_metrics(res, scenario) -> dict:
    """The ``filters`` section of ``metrics.json`` from a :class:`~sins_sim.simulation.sins.SinsResult`."""
    from sins_sim import earth
    from sins_sim.navigation.error import position_error_from_attitude_error
    from sins_sim.simulation.metrics import drift_angle_of_series, drift_metrics, event_steps, gyro_drift

    out = {}
    mission_s = res.duration_s - res.nav_start_s
    events = _events_ned(scenario)
    ideal = res.stats.get("ideal")
    for name in res.filters:
        st = res.stats.get(name)
        div = res.diverged.get(name)
        if st is None or st.n == 0:
            out[name] = {"status": "diverged" if div else "no data", "diverged": div}
            if name in getattr(res, "filter_reports", {}):
                out[name]["filter_report"] = res.filter_reports[name]
            continue
        ser = res.series[name]
        last = st.last
        m = {
            "status": "diverged" if div else "ok",
            "diverged": div,
            "navigated_s": last["t_s"] - res.nav_start_s,
            "horizontal_position_error_m": {"final": last["horizontal_m"], "max": st.horizontal_max_m,
                                            "final_north": last["north_m"], "final_east": last["east_m"]},
            "vertical_position_error_m": {"final": last["vertical_m"]},
            "velocity_error_m_s": {"final": last["velocity_m_s"], "max": st.velocity_max_m_s,
                                   "final_ned": [float(x) for x in last["velocity_ned_m_s"]]},
            "attitude_error_arcsec": {"final": _ned(last["attitude_ned_rad"] / ARCSEC),
                                      "rms": _ned(st.attitude_rms_rad / ARCSEC)},
            "cep_rate_nmi_h": (last["horizontal_m"] / NMI_M / (mission_s / 3600.0)
                               if res.duration_s >= CEP_RATE_MIN_S and not div else None),
        }
        if ideal is not None and ideal.n and name != "ideal":
            m["excess_over_ideal"] = excess_over_ideal(last, ideal.last)
        t = ser["t_s"]
        if t.size >= 8:
            psi, drift_angle = drift_angle_of_series(ser, res.truth_series)
            m["attitude_error_arcsec"]["final_psi"] = _ned(psi[-1] / ARCSEC)
            m["attitude_drift_deg_h"] = drift_metrics(t, drift_angle, _NED)
            m["events"] = event_steps(t, ser["attitude_ned_rad"], events)
            lat0 = float(scenario.site["lat_rad"])
            lin = position_error_from_attitude_error(t - t[0], ser["attitude_free_ned_rad"] - ser["attitude_free_ned_rad"][0],
                                                     lat0, earth_rate_rad_s=earth.EARTH_RATE_RAD_S)
            m["linear_model"] = {
                "horizontal_position_error_final_m": float(lin.horizontal_m[-1]),
                "note": "cross-check, not the result: the psi-angle error equations (Titterton & Weston 2004, "
                        "ch. 12) at rest, driven by the filter's gyro-angle error accumulated in the navigation "
                        "frame (its free attitude error)"}
        else:
            m["attitude_drift_deg_h"] = None
            m["events"] = []
        m["gyro_drift_deg_h"] = gyro_drift(res.records, name)
        if name in res.allan:
            m["allan"] = {ax: a.to_dict() for ax, a in res.allan[name].items()}
        if name in getattr(res, "filter_reports", {}):  # a plug-in's account of itself (lms_stripper: gains, convergence)
            m["filter_report"] = res.filter_reports[name]
        if name in getattr(res, "aided", {}):
            m["aided"] = aided_metrics(res.aided[name])
        if name in getattr(res, "alignments", {}):
            m["alignment"] = alignment_metrics(res.alignments[name])
            if "linear_model" in m:
                m["linear_model"]["note"] += "; without the alignment's initial attitude error"
        out[name] = m
    return out


def alignment_metrics(entry: dict) -> dict:
    """One filter's alignment in ``metrics.json``: what the method found and stated
    (:meth:`~sins_sim.navigation.alignment_result.AlignmentResult.to_dict`) and its error against the true
    attitude at the navigation start, each component over its stated sigma (NED: north and east tilt in
    arcsec, heading in deg)."""
    res, err = entry["result"], np.asarray(entry["error_rad"], dtype=np.float64)
    sig = res.sigma_rad
    over = [float(e / s) if s > 0.0 else None for e, s in zip(err, sig)]
    return {**res.to_dict(), "error_tilt_north_arcsec": float(err[0] / ARCSEC),
            "error_tilt_east_arcsec": float(err[1] / ARCSEC), "error_heading_deg": float(np.degrees(err[2])),
            "error_over_sigma_ned": over}


_XYZ = ("x", "y", "z")


def aided_metrics(entry: dict) -> dict:
    """One filter's aided navigation in ``metrics.json`` (flat keys, units in the names; a sweep aggregates them).

    Errors over the filter's epochs (every update, every second, the outage growth's times) against the truth;
    the outage growth per outage ``i`` at 10, 30, 60 and 120 s into it with the filter's closed-form predicted
    sigma; the final bias estimates against the biases the filter's increments carry (:func:`~sins_sim.simulation.
    aiding.true_biases`) with their sigmas; the mean NIS per measurement with its chi-square 95 % bounds for the
    mean of ``n`` values (independent innovations assumed); NEES per 3-state block: the fraction of epochs inside
    the per-epoch chi-square(3) 95 % interval, and its mean, with ``n``.
    """
    from scipy.stats import chi2

    res, err = entry["result"], entry["errors"]
    out = {"epochs_n": int(len(res))}
    hor = np.hypot(err[:, 0], err[:, 1])
    vel = np.linalg.norm(err[:, 3:6], axis=1)
    out["horizontal_position_error_rms_m"] = float(np.sqrt(np.mean(hor ** 2)))
    upd = res.updated if np.any(res.updated) else np.ones(len(res), dtype=bool)
    out["horizontal_position_sigma_median_m"] = float(np.median(np.hypot(res.sigma[upd, 0], res.sigma[upd, 1])))
    out["horizontal_position_error_max_m"] = float(np.max(hor))
    out["vertical_position_error_rms_m"] = float(np.sqrt(np.mean(err[:, 2] ** 2)))
    out["velocity_error_rms_m_s"] = float(np.sqrt(np.mean(vel ** 2)))
    out["velocity_error_max_m_s"] = float(np.max(vel))
    for i, ax in enumerate(_NED):
        a = err[:, 6 + i] / ARCSEC
        out[f"attitude_error_rms_{ax}_arcsec"] = float(np.sqrt(np.mean(a ** 2)))
        out[f"attitude_error_max_{ax}_arcsec"] = float(np.max(np.abs(a)))
    for i, g in enumerate(entry["growth"]):
        out[f"outage{i + 1}_start_s"], out[f"outage{i + 1}_end_s"] = (float(x) for x in g.window_s)
        for a, e, sgm in zip(g.after_s, g.error_m, g.predicted_sigma_m):
            out[f"outage{i + 1}_horizontal_error_{a:g}s_m"] = None if not np.isfinite(e) else float(e)
            out[f"outage{i + 1}_predicted_sigma_{a:g}s_m"] = None if not np.isfinite(sgm) else float(sgm)
    tb = entry["true_bias"]
    sig = res.sigma[-1]
    for i, ax in enumerate(_XYZ):
        out[f"gyro_bias_estimate_{ax}_deg_h"] = float(res.gyro_bias_rad_s[-1, i] / DEG_PER_H)
        out[f"gyro_bias_sigma_{ax}_deg_h"] = float(sig[9 + i] / DEG_PER_H)
        out[f"gyro_bias_prior_sigma_{ax}_deg_h"] = float(entry["unaided_bias_sigma"][i] / DEG_PER_H)
        out[f"accel_bias_estimate_{ax}_ug"] = float(res.accel_bias_m_s2[-1, i] / MICRO_G)
        out[f"accel_bias_sigma_{ax}_ug"] = float(sig[12 + i] / MICRO_G)
        if tb is not None:
            out[f"gyro_bias_true_{ax}_deg_h"] = float(tb["gyro_rad_s"][i] / DEG_PER_H)
            out[f"accel_bias_true_{ax}_ug"] = float(tb["accel_m_s2"][i] / MICRO_G)
    for name in ("position", "velocity"):
        nis = res.nis[res.innovation_name == name]
        n = int(nis.size)
        out[f"nis_{name}_n"] = n
        if n:
            out[f"nis_{name}_mean"] = float(np.mean(nis))
            out[f"nis_{name}_bound_low"] = float(chi2.ppf(0.025, 3 * n) / n)
            out[f"nis_{name}_bound_high"] = float(chi2.ppf(0.975, 3 * n) / n)
    for key, val in (entry.get("filter_model") or {}).items():   # what the filter was told (flat, SI)
        if isinstance(val, (list, tuple)):
            for i, ax in enumerate(("x", "y", "z") if key.endswith("_body") else _NED):
                out[f"filter_{key}_{ax}"] = float(val[i])
        else:
            out[f"filter_{key}"] = val
    lo, hi = chi2.ppf(0.025, 3), chi2.ppf(0.975, 3)
    for name, val in entry["nees"].items():
        ok = np.isfinite(val)
        n = int(np.count_nonzero(ok))
        out[f"nees_{name}_n"] = n
        if n:
            out[f"nees_{name}_mean"] = float(np.mean(val[ok]))
            out[f"nees_{name}_within_95_fraction"] = float(np.mean((val[ok] >= lo) & (val[ok] <= hi)))
    sm = entry.get("smoothed")
    if sm is not None:
        e = sm["errors"]
        out["smoothed_horizontal_position_error_rms_m"] = float(np.sqrt(np.mean(e[:, 0] ** 2 + e[:, 1] ** 2)))
        out["smoothed_velocity_error_rms_m_s"] = float(np.sqrt(np.mean(np.sum(e[:, 3:6] ** 2, axis=1))))
        for i, ax in enumerate(_NED):
            out[f"smoothed_attitude_error_rms_{ax}_arcsec"] = float(np.sqrt(np.mean(e[:, 6 + i] ** 2)) / ARCSEC)
    return out


def aiding_section(scenario) -> dict | None:
    """``metrics.json`` ``aiding``: the receiver and the filter as run (SI, units in the names)."""
    a = getattr(scenario.nav, "aiding", None)
    if a is None:
        return None
    g = a.gnss
    return {"source": "file" if a.file is not None else "simulated", "rate_hz": g.rate_hz,
            "update_rate_hz": a.update_rate_hz, "latency_s": g.latency_s, "lever_arm_m": list(g.lever_arm_b_m),
            "position_sigma_m": list(g.position_sigma_m), "velocity_sigma_m_s": list(g.velocity_sigma_m_s),
            "markov_sigma_m": list(g.markov_sigma_m), "markov_tau_s": g.markov_tau_s,
            "outages_s": [list(w) for w in g.outages_s], "measurements": list(a.measurements),
            "feedback": a.feedback, "smoother": a.smoother}


def excess_over_ideal(last: dict, ideal_last: dict) -> dict:
    """A filter's cost: the vector difference of its final errors and the ideal increments' (never negative).

    The difference of two error magnitudes can be negative (two errors of equal size in different
    directions differ by up to twice their size); the magnitude of the difference of the two error
    vectors cannot. The two solutions share the truth, the accelerometers and the seed, so the
    difference is what the filter alone adds (paired). Both final rows are at the last navigation
    update each filter reached (they differ by the filter's delay, a few samples).
    """
    d_pos = np.array([last["north_m"] - ideal_last["north_m"], last["east_m"] - ideal_last["east_m"]])
    d_vel = np.asarray(last["velocity_ned_m_s"]) - np.asarray(ideal_last["velocity_ned_m_s"])
    d_att = np.asarray(last["attitude_ned_rad"]) - np.asarray(ideal_last["attitude_ned_rad"])
    return {"horizontal_position_error_final_m": float(np.hypot(*d_pos)),
            "position_error_final_north_east_m": [float(x) for x in d_pos],
            "vertical_position_error_final_m": float(last["vertical_m"] - ideal_last["vertical_m"]),
            "velocity_error_final_m_s": float(np.linalg.norm(d_vel)),
            "attitude_error_final_arcsec": float(np.linalg.norm(d_att) / ARCSEC),
            "definition": "norm of the difference of the filter's and ideal's final error vectors (paired: same "
                          "truth, accelerometers and seed)"}


def _events_ned(scenario):
    """Block turns get their axis in NED (vehicle attitude at the turn's start times the body axis)."""
    from sins_sim.navigation.attitude import dcm_from_quat

    out = []
    for ev in scenario.events:
        ev = dict(ev)
        if ev["kind"] == "turn":
            stream = scenario.vehicle.stream() if hasattr(scenario.vehicle, "stream") else scenario.vehicle
            q = np.asarray(stream.evaluate(np.array([ev["start_s"]])).q_nv)[0]
            ev["axis_ned"] = (dcm_from_quat(q) @ np.asarray(ev["axis_body"])).tolist()
        out.append(ev)
    return out


def run_scenario(path, out_dir, progress=None, overrides: dict | None = None, threads: int | None = None,
                 manifest=None) -> dict:
    """Run a scenario file end to end; write the results into ``out_dir``; return the metrics.

    The steps are :func:`prepare_run` (``load_scenario``: the keys checked and the plan resolved,
    :func:`sins_sim.plan.resolve_plan`), :func:`compute_run` (:func:`sins_sim.plan.run_plan` and the metrics, in
    memory) and :func:`write_run` (the folder); :func:`sins_sim.jobs.notebook.run` does the first two
    for a notebook and :meth:`~sins_sim.results.MissionResult.save` the last.

    Parameters
    ----------
    path : path or mapping
        The scenario YAML (or its content as a dict).
    out_dir : path
        Folder for the results (created).
    progress : callable(fraction) or None
    overrides : dict, optional
        Top-level keys replacing the file's (``seed``, ``duration_s``).
    threads : int, optional
        Threads for the three axes (default: the cores available, at most 3).
    manifest : sins_sim.jobs.manifest.Manifest, optional
        The command's manifest (default: one without a command line); completed and written into
        ``out_dir`` with ``inputs/``.
    """
    from sins_sim.jobs.manifest import Manifest, record_run

    if manifest is None:
        manifest = Manifest("run", settings={"overrides": dict(overrides or {})})
    scenario, config_warnings = prepare_run(path, overrides, progress)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    record_run(manifest, scenario, path, overrides, out)  # before the engine: a missing input copy fails now
    res, metrics = compute_run(scenario, config_warnings, progress, threads)
    phase = getattr(progress, "phase", None)  # the CLI's bar says the engine is done and the files are written
    if phase is not None:
        phase(f"simulation done; writing metrics{', figures' if scenario.outputs['plots'] else ''} and the report")
    write_run(out, scenario, res, metrics, manifest)
    return metrics


def prepare_run(source, overrides: dict | None = None, progress=None, base_dir=None):
    """The scenario validated and checked to finish (:func:`sins_sim.jobs.estimate.check_run`).

    Configuration-time warnings are told now (through ``progress.advise`` where the CLI gives one, else as
    one :class:`UserWarning` each) and returned, for ``metrics.json``.

    ``base_dir`` is where a mapping's relative paths are taken from (default: the working directory).

    Returns
    -------
    (Scenario, list of str)
    """
    from sins_sim.jobs.messages import warning_text
    from sins_sim.config.scenario import load_scenario

    with warnings.catch_warnings(record=True) as caught:  # configuration-time warnings: told now, kept for metrics
        warnings.simplefilter("always")
        scenario = load_scenario(source, overrides, base_dir=base_dir)
    config_warnings = list(dict.fromkeys(t for t in map(warning_text, caught) if t))
    advise = getattr(progress, "advise", None)
    for text in config_warnings:
        if advise is not None:  # the CLI prints it now, before the engine runs
            advise(text)
        else:
            warnings.warn(text, UserWarning, stacklevel=3)
    from sins_sim.jobs.estimate import check_run

    check_run(scenario, progress)  # refuse a run that cannot finish, before the engine starts (issue 12, point 3)
    return scenario, config_warnings


def compute_run(scenario, config_warnings=(), progress=None, threads: int | None = None):
    """The engine on a validated scenario and the run's metrics (the content of ``metrics.json``), in memory.

    Returns
    -------
    (SinsResult, dict)
    """
    from sins_sim.plan import advisories, run_plan

    res = run_plan(scenario.plan, progress=progress, threads=threads)  # the engine runs what load_scenario resolved
    metrics = {
        "scenario": scenario.name,
        "description": scenario.description,
        "seed": scenario.seed,
        "duration_s": scenario.duration_s,
        "mission": {"site": {"lat_deg": math.degrees(scenario.site["lat_rad"]),
                             "lon_deg": math.degrees(scenario.site["lon_rad"]), "height_m": scenario.site["height_m"]},
                    "trajectory": scenario.vehicle.describe() if hasattr(scenario.vehicle, "describe") else "file",
                    # a file with velocity columns: the smoothing fit's residuals and noise levels (else None)
                    "trajectory_fit": getattr(scenario.vehicle, "fit", None),
                    # vibration.spec: its source and closed-form g_rms per axis (random, sine lines, total)
                    "vibration_spec": (None if getattr(scenario, "vibration_spec", None) is None
                                       else scenario.vibration_spec.summary())},
        "navigation": {"coning": scenario.nav.coning, "sculling": scenario.nav.sculling,
                       "start_s": scenario.nav.start_s, "n_sub": scenario.nav.n_sub,
                       "update_rate_hz": res.filter_rate_hz / scenario.nav.n_sub,
                       "vertical": scenario.nav.vertical, "accel_delay": scenario.nav.accel_delay,
                       "alignment": {"method": scenario.nav.alignment.method,
                                     **({"duration_s": scenario.nav.alignment.duration_s}
                                        if scenario.nav.alignment.active else {})},
                       **_coning_design(res.nav)},
        "imu": scenario.imu.name,
        "definitions": DEFINITIONS,
        "filters": scenario_metrics(res, scenario),
        "gyro_error_rms_arcsec": {name: [float(x) for x in np.sqrt(np.mean((e - e.mean(axis=0)) ** 2, axis=0)) / ARCSEC]
                                  for name, e in res.spectra.items() if name != "t" and e.shape[0]},
        "allan": _allan_section(res),
        "alignment_samples": {k: val for k, val in res.delays.items() if k != "residual_eliminator"},
        "drives": [{**d, "amplitude_measured_arcmin": d["amplitude_measured_rad"] / ARCMIN,
                    "amplitude_target_arcmin": d["amplitude_target_rad"] / ARCMIN} for d in res.drives],
        "dither_under_vibration": list(getattr(scenario, "dither_forecast", ())),
        "diverged": res.diverged,
        "warnings": list(dict.fromkeys([*config_warnings, *res.warnings,
                                        *advisories.drive_advisories(res.drives, scenario.imu, scenario.duration_s)])),
    }
    online = _online_section(res)
    if online:
        metrics["online_estimator"] = online
        metrics["warnings"] = list(dict.fromkeys([*metrics["warnings"], *online_warnings(online)]))
    pc = _pseudo_coning_section(scenario, res, metrics["filters"])
    if pc:
        metrics["pseudo_coning"] = pc
    ct = _coning_table_section(scenario, res, metrics["filters"])
    if ct:
        metrics["coning_algorithms"] = ct
    aid = aiding_section(scenario)
    if aid:
        metrics["aiding"] = aid
    blk = _block_section(scenario, res)
    if blk:
        metrics["block"] = blk
    return res, metrics


def _block_section(scenario, res) -> dict | None:
    """With a block on isolators: its own rotation over the record (``SinsResult.block``), the line at each dither
    against the linear coupled model, and the isolator modes (issue 27)."""
    rec = res.block
    if rec is None or rec["theta_rad"].shape[0] < 64:
        return None
    from sins_sim.models.block import block_rotation_per_deflection
    from sins_sim.simulation.responses import line_amplitudes
    from sins_sim.simulation.sins import AXES

    block = scenario.imu.block
    t, theta = rec["t_s"], rec["theta_rad"]
    freqs = [d["frequency_hz"] for d in res.drives]
    om = [2.0 * math.pi * ch.suspension.f0_hz for ch in scenario.imu.channels]
    lines = {}
    for i, ax in enumerate(AXES):
        meas = line_amplitudes(t, theta[:, i], freqs)
        lines[ax] = {f"{AXES[j]}_dither": {
            "frequency_hz": freqs[j], "simulated_arcsec": meas[j] / ARCSEC,
            "linear_model_arcsec": float(abs(block_rotation_per_deflection(block, j, freqs[j], om)[i])
                                         * res.drives[j]["amplitude_measured_rad"] / ARCSEC)}
            for j in range(3)}
    return {"record_s": float(t[-1] - t[0] + 1.0 / rec["rate_hz"]),
            "dither_coning": _dither_coning(scenario, res, freqs, lines),
            "rotation_rms_arcsec": {ax: float(np.sqrt(np.mean((theta[:, i] - theta[:, i].mean()) ** 2)) / ARCSEC)
                                    for i, ax in enumerate(AXES)},
            "dither_lines": lines,
            "isolator_modes_hz": rec["isolator_modes_hz"], "isolator_damping": rec["isolator_damping"],
            "vibration_enters": scenario.vibration_enters if scenario.translation is not None else None,
            "motion_enters": scenario.motion_enters,
            "note": "the block's rotation relative to the chassis about block axes x, y, z; dither_lines: the line "
                    "of that rotation at each gyro's drive (least squares on the three at once) beside the linear "
                    "coupled model (models.block.block_rotation_per_deflection x the gyro's measured amplitude; "
                    "the other gyros on undamped linear suspensions)"}


#: Estimator events that reach the user as a warning (a start-up's amplitude outside the band and a modulation
#: too small to estimate from are routine and only counted).
_ONLINE_WARN = ("range", "saturation", "nonfinite", "filter")


def _online_section(res) -> dict | None:
    """With ``filter_parameters: {source: online}``: per axis the estimator's last estimate (SI), its stated standard
    deviations, the values fed to the filters, the unit's truth then, and the count of each kind of event with its
    first message."""
    if not getattr(res, "online", None):
        return None
    out = {}
    for axis, d in res.online.items():
        hist = d["history"]
        events = {}
        for t_s, kind, message in d["events"]:
            e = events.setdefault(kind, {"count": 0, "first_t_s": float(t_s), "first": message})
            e["count"] += 1
        row = {"events": events, "updates": len(hist)}
        if hist:
            last = hist[-1]
            def finite(d):  # JSON has no NaN: a standard deviation not stated yet (or of k4, held) is null
                return {k: (float(v) if math.isfinite(v) else None) for k, v in d.items()}

            row.update(t_s=last["t_s"], estimate=finite(last["estimate"]), std=finite(last["std"]),
                       fed=finite(last["fed"]), truth=finite(last["truth"]), applied=last["applied"])
        out[axis] = row
    return out


def online_warnings(section: dict) -> list:
    """One line per axis and kind of estimator event that the user should hear of (:data:`_ONLINE_WARN`)."""
    lines = []
    for axis, row in section.items():
        for kind, e in row["events"].items():
            if kind in _ONLINE_WARN:
                lines.append(f"online estimator, axis {axis}: {e['count']} {kind} event(s), the first at "
                             f"t = {e['first_t_s']:.3g} s: {e['first']}")
    return lines


def _coning_table_section(scenario, res, filt_metrics) -> dict | None:
    """Under a single coning motion: each filter's heading drift error with each coning algorithm (issue 28)."""
    from sins_sim.jobs.coning_table import algorithm_drifts, band_for, coning_frequency_hz

    f = coning_frequency_hz(scenario)
    if f is None or scenario.nav is None:
        return None
    band = band_for(scenario, f, res.filter_rate_hz)
    drifts = algorithm_drifts(scenario, res, band)
    if not drifts:
        return None
    full = {}
    for name in drifts:
        d = (filt_metrics.get(name) or {}).get("attitude_drift_deg_h") or {}
        full[name] = (d.get("down") or {}).get("value")
    return {"frequency_hz": f, "tuned_band_hz": list(band), "heading_drift_error_deg_h": drifts,
            "full_navigation_deg_h": {"algorithm": scenario.nav.coning, "heading_drift": full},
            "note": "attitude replay of each filter's increments (true gyro angle + the run's gyro-angle error) "
                    "with each algorithm from the true attitude at the record's start: the drift of the attitude "
                    "error about the cone axis (sins_sim.jobs.coning_table); full_navigation: the run's own "
                    "navigation (attitude drift, down)"}


#: Frequency at which a filter's DC gain is read (Hz): far below every filter's corner, above zero so that the
#: response functions' frequency grid stays regular.
DC_PROBE_HZ = 1e-3


def _pseudo_pairs(scenario):
    """``(amplitudes rad, frequency Hz, phases rad, [(i, j, k)])`` of an in-phase planar vibration, or None.

    The scenario qualifies when its only motion is one ``sines`` part in which two axes ``j, k`` share
    one frequency and phase, and the vehicle is at rest (body axes = NED, so the drift about body
    axis ``i`` is the NED attitude drift of the same index).
    """
    spec = scenario.motion_spec
    traj = scenario.trajectory_spec or {}
    if len(spec) != 1 or spec[0].get("type") != "sines" or scenario.nav is None:
        return None
    if traj.get("file") or traj.get("segments") or traj.get("speed_m_s"):
        return None
    amp = np.asarray(spec[0]["amplitude_rad"], dtype=float)
    freq = np.asarray(spec[0]["frequency_hz"], dtype=float)
    ph = np.asarray(spec[0]["phase_rad"], dtype=float)
    pairs = [(i, (i + 1) % 3, (i + 2) % 3) for i in range(3)]
    pairs = [(i, j, k) for i, j, k in pairs
             if amp[j] > 0 and amp[k] > 0 and freq[j] > 0 and freq[j] == freq[k] and ph[j] == ph[k]]
    if not pairs:
        return None
    return amp, float(freq[pairs[0][1]]), ph, pairs


def _pseudo_coning_section(scenario, res, filt_metrics) -> dict | None:
    """Per filter, the false heading drift of an in-phase planar vibration beside its closed form (issue 28).

    The closed form ``(1/2) a b w |H_j||H_k| sin(phi_j - phi_k)`` times the navigation algorithm's
    factor (:func:`sins_sim.navigation.coning.pseudo_coning_drift`) uses each filter's response
    measured from the run's own gyro-angle error record (:func:`sins_sim.simulation.responses.measured_response`)
    and, beside it, the model response (R1) of :func:`sins_sim.simulation.responses.increment_responses`.
    """
    found = _pseudo_pairs(scenario)
    t = res.spectra.get("t") if res.spectra else None
    if found is None or t is None or len(t) < 2:
        return None
    from sins_sim.earth import EARTH_RATE_RAD_S
    from sins_sim.navigation.coning import pseudo_coning_drift
    from sins_sim.simulation.responses import increment_responses, measured_response
    from sins_sim.simulation.unit import run_channels

    amp, f, ph, pairs = found
    fs = res.filter_rate_hz
    w = 2.0 * math.pi * f
    out = {"frequency_hz": f, "amplitude_arcmin": [float(a / ARCMIN) for a in amp],
           "record_s": float(t[-1] - t[0]),
           "note": "false drift about body axis i of the in-phase vibration of axes j, k: "
                   "(1/2) a b w |H_j||H_k| sin(phi_j - phi_k) x the coning algorithm's factor, with H measured "
                   "from the run's gyro-angle error (lock-in at the vibration frequency) and from the model "
                   "response (suspension x readout FIR x filter); closed_form_total adds the Earth rate about the "
                   "axis times the filter's DC gain error (H(0) - 1); simulated: the attitude drift of the "
                   "navigation about the same axis (body = NED at rest)", "filters": {}}
    for name in res.filters:
        err = res.spectra.get(name)
        m = filt_metrics.get(name, {})
        if err is None or not len(err) or "attitude_drift_deg_h" not in m or not m["attitude_drift_deg_h"]:
            continue
        h_meas = measured_response(t, err, amp, f, ph)
        h_model = increment_responses(run_channels(scenario.imu), name, [f])[:, 0] if name != "ideal" else np.ones(3)
        coef = res.nav.compensation(name)[0]
        # a filter whose DC gain is not one scales the Earth rate the gyro sees at rest (body = NED): that is a drift
        # of (H(0) - 1) Omega_ie about the axis, beside the pseudo-coning (the paper form of eq. 5: about 1 %)
        dc = (increment_responses(run_channels(scenario.imu), name, [DC_PROBE_HZ])[:, 0].real if name != "ideal"
              else np.ones(3))
        lat = scenario.site["lat_rad"]
        earth_ned = EARTH_RATE_RAD_S * np.array([math.cos(lat), 0.0, -math.sin(lat)])
        rows = {}
        for i, j, k in pairs:
            axis = "xyz"[i]
            drift = m["attitude_drift_deg_h"][_NED[i]]
            closed = {}
            for label, hh in (("measured_response", h_meas), ("model_response", h_model)):
                rate = pseudo_coning_drift(amp[j], amp[k], w, hh[j], hh[k], 1.0 / fs, coef=coef, component=i)
                closed[label] = math.degrees(rate) * 3600.0
            earth_term = math.degrees((dc[i] - 1.0) * earth_ned[i]) * 3600.0 + 0.0  # + 0.0: no -0 in the table
            rows[axis] = {
                "closed_form_deg_h": closed,
                "dc_gain_earth_rate_deg_h": earth_term,
                "closed_form_total_deg_h": {k_: v_ + earth_term for k_, v_ in closed.items()},
                "simulated_deg_h": drift.get("value"),
                "simulated_bound_95_deg_h": drift.get("bound_95"),
                "response": {"xyz"[a]: {"gain": float(abs(h_meas[a])), "phase_deg": float(np.degrees(np.angle(h_meas[a])))}
                             for a in (j, k)},
                "phase_difference_deg": float(np.degrees(np.angle(h_meas[j] * np.conj(h_meas[k])))),
            }
        out["filters"][name] = rows
    return out


def timeseries_arrays(res) -> dict:
    """The arrays of ``timeseries.npz``: ``truth_<key>``, ``<filter>__<key>``, ``gyro_error_<filter>`` / ``_t``, with
    aiding ``aided.<filter>.t_s`` / ``.errors`` (K, 9) / ``.sigma`` (K, 15) and,
    with a block on isolators, ``block_t_s`` and ``block_theta_rad``."""
    arrays = {f"truth_{k}": val for k, val in res.truth_series.items()}
    for name, ser in res.series.items():
        arrays.update({f"{name}__{k}": val for k, val in ser.items()})
    arrays.update({f"gyro_error_{k}": val for k, val in res.spectra.items()})
    for name, a in getattr(res, "aided", {}).items():  # the aided runs' epochs: errors and the filter's 1-sigma
        if name != "fixes":
            arrays.update({f"aided.{name}.t_s": a["result"].t_s, f"aided.{name}.errors": a["errors"],
                           f"aided.{name}.sigma": a["result"].sigma})
    blk = getattr(res, "block", None)
    if blk is not None:  # the block's own rotation over the spectrum window (SinsResult.block)
        arrays.update({"block_t_s": blk["t_s"], "block_theta_rad": blk["theta_rad"]})
    return arrays


def write_run(out, scenario, res, metrics: dict, manifest) -> list:
    """Write a computed run into folder ``out`` (``inputs/`` already recorded by
    :func:`sins_sim.jobs.manifest.record_run`): ``metrics.json``, ``timeseries.npz``, the figures,
    ``report.md`` and ``manifest.json``. Returns the figures' file names."""
    out = Path(out)
    (out / "metrics.json").write_text(json.dumps(metrics, indent=2, allow_nan=False, default=_json_default) + "\n")
    if scenario.outputs["timeseries"]:
        np.savez_compressed(out / "timeseries.npz", **timeseries_arrays(res))
    figures = []
    if scenario.outputs["plots"]:
        from sins_sim.plots import navigation as pn

        figures = pn.plot_run(res, out, scenario.name, metrics)
        figures += aided_figures(res, out, scenario.name)
    (out / "report.md").write_text(_report(scenario, metrics, figures,
                                           _filter_parameters_report(manifest.doc["run"]["filter_parameters"])))
    manifest.write(out)
    return figures


def aided_figures(res, out, title: str) -> list:
    """With aiding: per filter the error with its 3-sigma envelope (outages shaded) and the bias estimates
    converging, and its growth in each outage against its own covariance (``sins_sim.plots.aided``). Returns the
    file names."""
    aided = {n: a for n, a in getattr(res, "aided", {}).items() if n != "fixes"}
    if not aided:
        return []
    import matplotlib.pyplot as plt

    from sins_sim.plots import aided as pa

    names = []
    outages = aided[next(iter(aided))]["growth"]
    windows = [g.window_s for g in outages]
    for name, a in aided.items():
        tb = a["true_bias"] or {}
        for stem, fig in ((f"aided_error_{name}.png",
                           pa.aided_error_figure(a["result"], truth_errors=a["errors"], outages_s=windows,
                                                 title=f"{title}: {name}, aided")),
                          (f"aided_bias_{name}.png",
                           pa.bias_figure(a["result"], true_gyro_bias_rad_s=tb.get("gyro_rad_s"),
                                          true_accel_bias_m_s2=tb.get("accel_m_s2")))):
            fig.savefig(Path(out) / stem, dpi=110)
            plt.close(fig)
            names.append(stem)
        if a["growth"]:  # one figure per filter: the growth is read against that filter's own covariance
            fig = pa.outage_growth_figure(a["growth"], result=a["result"])
            stem = f"aided_outage_growth_{name}.png"
            fig.savefig(Path(out) / stem, dpi=110)
            plt.close(fig)
            names.append(stem)
    return names


def _filter_parameters_report(fp: dict) -> str:
    """The report's table of the parameters each filter used (from the manifest's ``run.filter_parameters``)."""
    lines = ["", "## Filter parameters (what each filter believed; `manifest.json` holds them in SI)", "",
             f"Source `{fp['source']}`, f0 from `{fp['f0_source']}`, f0 mismatch {fp['f0_mismatch_ppm']:g} ppm, "
             f"PLL tracking {'on' if fp['track'] else 'off'} (sins_sim.config.filter_params).", "",
             "| filter | axis | f0 (Hz) | f0 error vs unit (ppm) | k1 | k2 (rad) | k3 | k4 (1/rad) | k5 (rad/V) |",
             "|---|---|---|---|---|---|---|---|---|"]
    other = []
    for name, axes in fp["filters"].items():
        for axis, r in axes.items():
            if "f0_hz" in r:
                lines.append(f"| {name} | {axis} | {r['f0_hz']:.9g} | {r['f0_error_ppm']:.4g} | {r['k1']:.6g} | "
                             f"{r['k2_rad']:.6g} | {r['k3']:.6g} | {r['k4_per_rad']:.6g} | {r['k5_rad_per_v']:.6g} |")
            elif "band_hz" in r:
                other.append(f"- {name}, axis {axis}: elliptic band-stop {r['band_hz'][0]:.6g}-{r['band_hz'][1]:.6g} "
                             f"Hz (order {r['order']}, {r['rp_db']:g} dB ripple, {r['rs_db']:g} dB stop) around the "
                             f"drive at {r['drive_hz']:.6g} Hz")
    return "\n".join(lines + ([""] + other if other else []) + [""])


def _allan_section(res) -> dict | None:
    """What the per-filter ``allan`` readings are, and the accelerometers' own."""
    if not res.allan:
        return None
    acc = res.allan.get("accelerometers")
    return {"rate_hz": res.allan["rate_hz"], "record_s": res.allan["record_s"],
            "rest_span_s": res.allan.get("rest_span_s"),
            "what": "overlapping Allan deviation (allantools) of each filter's gyro-angle error (output minus the "
                    "true gyro angle, sensor errors included) and of the accelerometers' accumulated velocity "
                    "error, sampled over the navigation period; terms read by sins_sim.navigation.allan.fit_allan "
                    "(IEEE Std 952-1997 Annex C) on the longest span at rest (rest_span_s), a line removed, and kept "
                    "by sins_sim.navigation.allan.screen_noise; null where a term is not determinable (reason given) "
                    "or does not dominate anywhere on the curve",
            "accelerometers": {ax: a.to_dict() for ax, a in acc.items()} if acc else None}


def _json_default(x):
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    raise TypeError(f"not JSON serialisable: {type(x).__name__}")


def _fmt(x, spec=".3g"):
    return "n/a" if x is None else format(x, spec)


def _drift_cells(dr, axes) -> str:
    """'v +- ci' where a drift, '< bound' where not, per axis."""
    if not dr:
        return "n/a"
    cells = []
    for ax in axes:
        d = dr[ax]
        if d["value"] is not None:
            cells.append(f"{d['value']:.3g} +- {d['ci95']:.2g}")
        elif d["bound_95"] == 0.0:
            cells.append("0")
        elif d["bound_95"] is not None:
            cells.append(f"< {d['bound_95']:.2g}")
        else:
            cells.append("n/a")
    return ", ".join(cells)


def _coning_design(nav) -> dict:
    """The filter-tuned design of each filter for ``metrics.json`` (empty unless ``filter_tuned``)."""
    if nav is None or not nav.tuned or not nav.designs:
        return {}
    out = {}
    for name, d in nav.designs.items():
        out[name] = {
            "coefficients": {ax: [float(c) for c in row] for ax, row in zip("xyz", d["coefficients"])},
            "flat_coefficients": [float(c) for c in d["flat_coefficients"][0]],
            "uncompensated_fraction_rms": {label: {ax: float(x) for ax, x in zip("xyz", r["rms"])}
                                           for label, r in d["residual"].items()},
            "uncompensated_fraction_max": {label: {ax: float(x) for ax, x in zip("xyz", r["max"])}
                                           for label, r in d["residual"].items()},
            "tuned_coefficients": {ax: [float(c) for c in row] for ax, row in zip("xyz", d["tuned_coefficients"])},
            "whole_band_hz": [float(x) for x in d["whole_band_hz"]],
            "whole_band_uncompensated_fraction_rms": {label: {ax: float(x) for ax, x in zip("xyz", r["rms"])}
                                                      for label, r in d["whole_band_residual"].items()},
            "fallback": d["fallback"], **({"fallback_reason": d["reason"]} if d["fallback"] else {}),
        }
    return {"tuned_band_hz": list(nav.tuned_band_hz), "coning_design": out,
            "coning_design_note": "lag coefficients [c1, c2, c3] of dtheta_{k-j} x dtheta_k per body axis "
                                  "(Mark & Tazartes 2001; docs/theory/navigation.md); uncompensated_fraction: the "
                                  "drift under classical coning over the band as a fraction of the classical "
                                  "coning rate, for the filter's model response, tuned and two-sample; fallback two_sample: the tuned "
                                  "design was ill-conditioned for the filter (it left more over the whole band than "
                                  "it removed in its own) and coefficients are the two-sample ones"}


def _pseudo_coning_report(pc) -> list:
    """The pseudo-coning table of ``report.md`` (empty without the section)."""
    if not pc:
        return []
    lines = ["", "## Pseudo-coning", "",
             f"In-phase planar vibration at {pc['frequency_hz']:g} Hz: no true coning, but each filter's phase "
             "difference between the axes makes the navigation see one. Closed form "
             "`(1/2) a b w |H_j||H_k| sin(phi_j - phi_k)` (times the coning algorithm's factor) from the response "
             "measured in this run and from the model response, plus the Earth rate about the axis scaled by the "
             "filter's DC gain error, `(H(0) - 1) Omega_ie` (the paper form of eq. 5: about 1 %), beside the "
             "simulated attitude drift.", "",
             "| filter | axis | phase difference (deg) | pseudo-coning, measured H (deg/h) | pseudo-coning, model H "
             "(deg/h) | Earth rate x (H(0) - 1) (deg/h) | total, measured H (deg/h) | simulated (deg/h) |",
             "|---|---|---|---|---|---|---|---|"]
    for name, rows in pc["filters"].items():
        for axis, r in rows.items():
            sim = r["simulated_deg_h"]
            sim_s = f"{sim:.4g}" if sim is not None else f"< {r['simulated_bound_95_deg_h']:.2g}"
            lines.append(f"| {name} | {axis} | {r['phase_difference_deg']:.3g} | "
                         f"{r['closed_form_deg_h']['measured_response']:.4g} | "
                         f"{r['closed_form_deg_h']['model_response']:.4g} | {r['dc_gain_earth_rate_deg_h']:.3g} | "
                         f"{r['closed_form_total_deg_h']['measured_response']:.4g} | {sim_s} |")
    return lines + [""]


def _start_words(nv: dict) -> str:
    al = nv.get("alignment") or {"method": "truth"}
    if al["method"] == "truth":
        return "aligned to the truth"
    return (f"from a `{al['method']}` alignment over the {al['duration_s']:g} s before it (each filter its own, from "
            f"its own increments; zero velocity, surveyed position)")


def _alignment_report(metrics: dict) -> list:
    """The alignment table of ``report.md`` (empty with a truth start)."""
    rows = [(n, m["alignment"]) for n, m in metrics["filters"].items() if "alignment" in m]
    if not rows:
        return []
    lines = ["", "## Alignment of each filter", "",
             "What each filter's alignment found, against the true attitude at the navigation start, and the sigma it "
             "stated (from the observability bounds of the unit's sensor-error model and the data's own scatter, or "
             "from the filter's covariance). A dither filter's residual bias and noise enter here.", "",
             "| filter | method | heading error (deg) | sigma heading (deg) | tilt error N, E (arcsec) | "
             "sigma tilt N, E (arcsec) | settling (deg) |", "|---|---|---|---|---|---|---|"]
    for name, a in rows:
        settle = a.get("settling_heading_deg")
        lines.append(f"| {name} | {a['method']} | {a['error_heading_deg']:.4g} | {a['sigma_heading_deg']:.3g} | "
                     f"{a['error_tilt_north_arcsec']:.3g}, {a['error_tilt_east_arcsec']:.3g} | "
                     f"{a['sigma_tilt_north_arcsec']:.3g}, {a['sigma_tilt_east_arcsec']:.3g} | "
                     f"{'' if settle is None else f'{settle:.2g}'} |")
    return lines


def _aided_report(metrics: dict) -> list:
    """The "Aided navigation" section of ``report.md``: the table, and where the filter's choice shows, read from
    the numbers (empty without aiding)."""
    rows = [(n, m["aided"]) for n, m in metrics["filters"].items() if "aided" in m]
    if not rows:
        return []
    a = metrics.get("aiding", {})
    n_states = rows[0][1].get("filter_states", 15)
    lines = ["", "## Aided navigation", "",
             f"Every filter's increments navigated again by the {n_states}-state error-state filter with the same GNSS fixes "
             f"({a.get('source', '')}, {a.get('rate_hz', 0):g} Hz, applied at {a.get('update_rate_hz', 0):g} Hz: "
             f"{', '.join(a.get('measurements', []))}; outages {a.get('outages_s', [])} s). Errors over the "
             "filter's epochs against the truth; the outage growth is the horizontal error at the times into the "
             "outage against the filter's own predicted 1-sigma; the bias estimates are the last epoch's, against the "
             "bias the filter's increments carry (gyros: the unit's fixed and turn-on bias plus what the dither filter "
             "adds at DC, the slope of its gyro-angle error over ideal's; accelerometers: the slope of their "
             "accumulated error, bias plus scale factor and misalignment times the specific force).", "",
             "| filter | horizontal RMS (m) | velocity RMS (m/s) | attitude RMS N, E, D (arcsec) | outage error at "
             "60 s (m) | predicted sigma 60 s (m) | gyro bias est. x, y, z (deg/h) | true (deg/h) | sigma (deg/h) | "
             "NEES pos/vel/att within 95 % |", "|---|---|---|---|---|---|---|---|---|---|"]

    def trip(m, stem, fmt=".3g"):
        vals = [m.get(stem.format(ax)) for ax in ("x", "y", "z")]
        return ", ".join("" if x is None else format(x, fmt) for x in vals)

    for name, m in rows:
        lines.append(
            f"| {name} | {m['horizontal_position_error_rms_m']:.3g} | {m['velocity_error_rms_m_s']:.3g} | "
            f"{m['attitude_error_rms_north_arcsec']:.3g}, {m['attitude_error_rms_east_arcsec']:.3g}, "
            f"{m['attitude_error_rms_down_arcsec']:.3g} | {_fmt(m.get('outage1_horizontal_error_60s_m'))} | "
            f"{_fmt(m.get('outage1_predicted_sigma_60s_m'))} | {trip(m, 'gyro_bias_estimate_{}_deg_h')} | "
            f"{trip(m, 'gyro_bias_true_{}_deg_h')} | {trip(m, 'gyro_bias_sigma_{}_deg_h')} | "
            + "/".join(_fmt(m.get(f'nees_{b}_within_95_fraction'), '.2f') for b in ('position', 'velocity', 'attitude'))
            + f" (n = {m.get('nees_position_n', 0)}) |")
    lines += [""] + _aided_findings(metrics, dict(rows))
    return lines


def _aided_findings(metrics: dict, aided: dict) -> list:
    """Sentences from the numbers. The yardstick is the aided solution's own resolution, ``ideal``'s median
    horizontal 1-sigma at its updates: a filter's difference from ``ideal`` shows where it exceeds it (free: the
    final excess over ideal; aided: the difference of the horizontal RMS; in the outage: the difference at 60 s,
    against the predicted sigma there). The aiding hides the filter's choice where the free solution shows it and
    the aided one does not. A bias estimate is judged against the bias the increments carry, in units of its
    final sigma."""
    ref = aided.get("ideal")
    if ref is None:
        return ["(No `ideal` in the filters: the filters' differences are not separated from the common floor.)"]
    res_m = ref["horizontal_position_sigma_median_m"]
    out = [f"The aided solution resolves {res_m:.3g} m horizontally (`ideal`'s median 1-sigma at its updates): a "
           "difference below that is not the filter's choice showing."]
    for name, m in aided.items():
        if name == "ideal":
            continue
        free = metrics["filters"][name].get("excess_over_ideal", {}).get("horizontal_position_error_final_m")
        d_aided = m["horizontal_position_error_rms_m"] - ref["horizontal_position_error_rms_m"]
        shows_aided = abs(d_aided) > res_m
        words = [f"- `{name}`: aided horizontal RMS {m['horizontal_position_error_rms_m']:.3g} m against ideal's "
                 f"{ref['horizontal_position_error_rms_m']:.3g} m ({d_aided:+.2g} m)"]
        if free is not None:
            shows_free = free > res_m
            verdict = ("the aiding hides the filter's choice" if shows_free and not shows_aided else
                       "the filter's choice shows free and aided" if shows_free else
                       "the filter's choice shows aided only" if shows_aided else
                       "the filter's choice shows neither free nor aided")
            words.append(f"; free, its final horizontal error is {free:.3g} m from ideal's: {verdict}")
        e60, e60_ref = m.get("outage1_horizontal_error_60s_m"), ref.get("outage1_horizontal_error_60s_m")
        s60 = m.get("outage1_predicted_sigma_60s_m")
        if e60 is not None and e60_ref is not None and s60:
            words.append(f". 60 s into the outage: {e60:.3g} m against ideal's {e60_ref:.3g} m (predicted sigma "
                         f"{s60:.3g} m): the filter's choice "
                         + ("shows" if abs(e60 - e60_ref) > s60 else "stays within the predicted sigma"))
        off = []
        for ax in "xyz":
            est, true = m[f"gyro_bias_estimate_{ax}_deg_h"], m.get(f"gyro_bias_true_{ax}_deg_h")
            sg = m[f"gyro_bias_sigma_{ax}_deg_h"]
            if true is not None and sg > 0.0 and abs(est - true) > 3.0 * sg:
                off.append(f"{ax} ({est:.3g} against {true:.3g} deg/h, {abs(est - true) / sg:.0f} sigma)")
        added = [m.get(f"gyro_bias_true_{ax}_deg_h", 0.0) - ref.get(f"gyro_bias_true_{ax}_deg_h", 0.0)
                 for ax in "xyz"]
        words.append(f". The gyro bias the filter adds over ideal's is {', '.join(f'{d:+.2g}' for d in added)} "
                     "deg/h (x, y, z)")
        words.append(f"; the estimate misses it beyond 3 sigma on {', '.join(off)}: the unit's bias model (the "
                     "filter's prior and its wander) does not cover what the dither filter adds" if off else
                     "; every gyro bias estimate is within 3 sigma of the bias the increments carry")
        out.append("".join(words) + ".")
    cons = [f"NEES within the chi-square(3) 95 % interval (a consistent filter: 0.95 of the epochs), `ideal`: "
            f"position {_fmt(ref.get('nees_position_within_95_fraction'), '.2f')}, velocity "
            f"{_fmt(ref.get('nees_velocity_within_95_fraction'), '.2f')}, attitude "
            f"{_fmt(ref.get('nees_attitude_within_95_fraction'), '.2f')} (n = {ref.get('nees_position_n', 0)} "
            f"epochs, one run); mean NIS position {_fmt(ref.get('nis_position_mean'))} in "
            f"[{_fmt(ref.get('nis_position_bound_low'))}, {_fmt(ref.get('nis_position_bound_high'))}] "
            f"(n = {ref.get('nis_position_n', 0)})."]
    az, az_t, az_s = (ref.get(f"accel_bias_{k}_z_ug") for k in ("estimate", "true", "sigma"))
    if az_t is not None and az_s:
        cons.append(f" The vertical accelerometer bias (observable through the fixes' height): `ideal`'s estimate "
                    f"{az:.3g} ug against the {az_t:.3g} ug its increments carry, sigma {az_s:.2g} ug "
                    f"({abs(az - az_t) / az_s:.1f} sigma).")
    aid = metrics.get("aiding", {})
    gm = max(aid.get("markov_sigma_m") or [0.0])
    told = [ref.get(f"filter_position_sigma_told_m_{ax}") for ax in ("north", "east", "down")]
    if gm > 0.0 and "filter_gnss_markov_tau_s" in ref:      # the fix-error states (not only sensor-error states)
        cons.append(f" The fixes carry a Gauss-Markov error of up to {gm:g} m (1 sigma, correlation "
                    f"{ref.get('filter_gnss_markov_tau_s', 0.0):g} s) that the filter estimates as three position "
                    f"states ({ref['filter_states']} states; R the white noise), so the position NIS keeps its "
                    "chi-square meaning, as the velocity NIS does.")
    elif gm > 0.0 and all(told) and aid.get("position_sigma_m"):
        # E[NIS] per axis <= (sigma_w^2 + sigma_gm^2 + HPH^T) / (R_told + HPH^T) <= (sigma_w^2 + sigma_gm^2) / R_told
        # (R_told >= sigma_w^2 + sigma_gm^2; docs/theory/aided.md, "The filter's model in a mission")
        bound = sum((w * w + g * g) / (r * r) for w, g, r in zip(aid["position_sigma_m"], aid["markov_sigma_m"], told))
        cons.append(f" The fixes carry a Gauss-Markov error of up to {gm:g} m (1 sigma) that the 15-state filter "
                    f"does not estimate: its R holds it as an equivalent white variance over the longest aided "
                    f"stretch (position sigma told {', '.join(f'{r:.3g}' for r in told)} m north, east, down), so the "
                    f"position NIS is expected at most {bound:.2g}, not 3, and below its chi-square interval it is "
                    "what that R predicts, not a mis-tuned filter; the velocity NIS keeps its meaning.")
    groups = ref.get("filter_sensor_error_states", "none")
    if groups != "none":
        cons.append(f" The filter estimates the scale-factor and misalignment groups {groups} as states (priors the "
                    "unit's sensor errors, fed back into the increments), not as process noise.")
    return out + ["", "".join(cons)]


def _spec_lines(spec) -> list:
    """The report's line of a ``vibration.spec``: the closed-form g_rms per axis (random + lines) and its source."""
    if not spec:
        return []
    parts = [f"{ax} {a['grms_g']:.4g} g (random {a['random_grms_g']:.4g}, lines {a['sine_grms_g']:.4g})"
             for ax, a in spec["axes"].items()]
    src = f"; source: {spec['source']}" if spec["source"] else ""
    return [f"- vibration specification: g_rms {', '.join(parts)}{src}"]


def _report(scenario, metrics, figures, filter_table: str = "") -> str:
    nv = metrics["navigation"]
    lines = [f"# {scenario.name}", "", scenario.description or "", "",
             f"- mission: {metrics['duration_s']:g} s, {metrics['mission']['trajectory']}",
             *_spec_lines(metrics["mission"].get("vibration_spec")),
             f"- unit: IMU `{scenario.imu.name}` ({scenario.imu_source}), seed {scenario.seed}",
             f"- navigation: from t = {nv['start_s']:g} s {_start_words(nv)}, updates at {nv['update_rate_hz']:g} Hz, "
             f"`{nv['coning']}` coning, `{nv['sculling']}` sculling, vertical channel `{nv['vertical']}`, "
             f"accelerometers `{nv['accel_delay']}` to each filter's delay", "",
             "## Navigation error of the integrated solution against the truth", "",
             "| filter | horizontal final (m) | horizontal max (m) | excess over ideal (m) | vertical final (m) | "
             "velocity final (m/s) | attitude error phi RMS N, E, D (arcsec) | CEP rate (nmi/h) | status |",
             "|---|---|---|---|---|---|---|---|---|"]
    for name, m in metrics["filters"].items():
        if "horizontal_position_error_m" not in m:
            lines.append(f"| {name} | | | | | | | | {m['status']} |")
            continue
        rms = m["attitude_error_arcsec"]["rms"]
        exc = m.get("excess_over_ideal")
        lines.append(f"| {name} | {m['horizontal_position_error_m']['final']:.3g} | "
                     f"{m['horizontal_position_error_m']['max']:.3g} | "
                     f"{_fmt(exc['horizontal_position_error_final_m']) if exc else ''} | "
                     f"{m['vertical_position_error_m']['final']:.3g} | "
                     f"{m['velocity_error_m_s']['final']:.3g} | {rms['north']:.3g}, {rms['east']:.3g}, {rms['down']:.3g} | "
                     f"{_fmt(m['cep_rate_nmi_h'])} | {m['status']} |")
    lines += _alignment_report(metrics)
    lines += _aided_report(metrics)
    lines += ["", "`ideal` runs the true gyro increments through the same navigation: the algorithm's and the "
              "accelerometers' floor. Every other filter's excess over it (the norm of the difference of the two final "
              "horizontal error vectors) is that filter's cost. phi is the attitude error against the true NED frame "
              "(tilt and heading; the Schuler loop bounds its tilt). The CEP rate is "
              f"the final horizontal error over the mission time, for missions of {CEP_RATE_MIN_S / 60:.0f} min or more.",
              "", "## Drift", "",
              "Two different quantities. The **gyro drift** is the slope of each filter's gyro-angle error (output "
              "minus the true increments, accumulated) per body axis: a gyro bias shows here. The **attitude drift** "
              "is the slope of the navigation's accumulated attitude drift angle per NED axis (the psi angle with its "
              "Earth- and transport-rate coupling removed): coning losses of the attitude integration show here and "
              "in no gyro axis. The tilt phi of the table above is bounded by the Schuler loop and is never read as "
              "a drift.", "",
              "| filter | gyro drift x, y, z (deg/h) | attitude drift N, E, D (deg/h) |", "|---|---|---|"]
    for name, m in metrics["filters"].items():
        if "horizontal_position_error_m" not in m:
            continue
        lines.append(f"| {name} | {_drift_cells(m.get('gyro_drift_deg_h'), 'xyz')} | "
                     f"{_drift_cells(m.get('attitude_drift_deg_h'), _NED)} |")
    lines += ["", "A value with its 95 % interval is a drift: a ramp explains at least 90 % of the variance and the "
              "slope exceeds its interval (residual autocorrelation taken into account) and the resolution "
              "(1e-4 deg/h). Otherwise `< b` gives the largest ramp the record allows at 95 %.", ""]
    for name, m in metrics["filters"].items():
        evs = m.get("events") or []
        lm = m.get("linear_model")
        if not evs and not lm:
            continue
        lines.append(f"- **{name}**:")
        for ev in evs:
            step = ", ".join(f"{x:.3g}" for x in ev["step_arcsec"])
            extra = (f", scale-factor error {ev['scale_factor_error_ppm']:.4g} ppm"
                     if "scale_factor_error_ppm" in ev else "")
            lines.append(f"  - {ev['kind']} at {ev['start_s']:g} s: step N, E, D = {step} arcsec{extra}")
        if lm:
            lines.append(f"  - linear error model cross-check: horizontal error "
                         f"{lm['horizontal_position_error_final_m']:.3g} m at the end "
                         f"(integrated solution: {m['horizontal_position_error_m']['final']:.3g} m)")
    lines += ["",
              "## Gyro-angle error of each filter (output minus truth, full rate, over the spectrum window)", "",
              "| filter | RMS x, y, z (arcsec) |", "|---|---|"]
    for name, r in metrics["gyro_error_rms_arcsec"].items():
        lines.append(f"| {name} | {', '.join(f'{x:.3g}' for x in r)} |")
    al = metrics.get("allan")
    if al and not al.get("rest_span_s"):
        lines += ["", "## Allan deviation of each filter's gyro error", "",
                  "No noise term is determinable: the vehicle is never at rest long enough for an Allan curve. Noise "
                  "terms are read only at rest, where the error is not the deterministic response to a manoeuvre "
                  "(`allan` in metrics.json gives each record's reason)."]
    elif al:
        span = al["rest_span_s"]
        where = f"{al['record_s']:.4g} s at rest from t = {span[0]:.4g} s, at {al['rate_hz']:.3g} Hz"
        lines += ["", f"## Allan deviation of each filter's gyro error ({where})", "",
                  "| filter | axis | ARW (deg/sqrt(h)) | bias instability (deg/h) | rate random walk "
                  "(deg/h/sqrt(h)) | quantisation (arcsec) |", "|---|---|---|---|---|---|"]
        reasons = {}
        for name, m in metrics["filters"].items():
            for ax, r in (m.get("allan") or {}).items():
                if not r.get("determinable", True):
                    reasons.setdefault(r.get("reason", ""), []).append(f"{name} {ax}")
                    lines.append(f"| {name} | {ax} | not determinable | | | |")
                    continue
                lines.append(f"| {name} | {ax} | {_fmt(r['arw_deg_rt_h'])} | {_fmt(r['bias_instability_deg_h'])} | "
                             f"{_fmt(r['rrw_deg_h_rt_h'])} | {_fmt(r['quantization_arcsec'])} |")
        lines += ["", "Noise terms are read only on the longest span at rest, a line removed, where the power-law "
                  "model describes the curve (goodness of fit) and a term's region shows its own slope; n/a: the term "
                  "does not dominate anywhere on a curve that is noise."]
        for why, who in reasons.items():
            lines.append(f"- not determinable ({', '.join(who)}): {why}")
    lines += ["", "## Drives (closed-loop amplitude at the amplitude-dependent resonance)", "",
              "| axis | f0 (Hz) | drive (Hz) | V_m start -> end (V) | amplitude (arcmin) |", "|---|---|---|---|---|"]
    for d in metrics["drives"]:
        lines.append(f"| {d['axis']} | {d['f0_hz']:g} | {d['frequency_hz']:.3f} | {d['v_m_initial']:.4g} -> "
                     f"{d['v_m_final']:.4g} | {d['amplitude_measured_arcmin']:.4g} |")
    if metrics["diverged"]:
        lines += ["", "## Diverged filters", ""]
        for name, d in metrics["diverged"].items():
            lines.append(f"- {name}: axis {d['axis']}, t = {d['time_s']:.4g} s: {d['reason']}")
    if metrics["warnings"]:
        lines += ["", "## Warnings", ""] + [f"- {w}" for w in metrics["warnings"]]
    lines += _pseudo_coning_report(metrics.get("pseudo_coning"))
    ct = metrics.get("coning_algorithms")
    if ct:
        from sins_sim.jobs.coning_table import coning_algorithm_table

        lines += ["", "## Coning algorithms", "",
                  coning_algorithm_table({n: {f"{ct['frequency_hz']:g}": r}
                                          for n, r in ct["heading_drift_error_deg_h"].items()}),
                  f"Design band of the tuned algorithm: {ct['tuned_band_hz'][0]:g}-{ct['tuned_band_hz'][1]:g} Hz. "
                  f"The run's own navigation (`{ct['full_navigation_deg_h']['algorithm']}`) is the drift table above.",
                  ""]
    lines += _block_report(metrics.get("block"))
    lines += [filter_table] if filter_table else []
    lines += [""] + [f"![{f}]({f})" for f in figures] + [""]
    return "\n".join(lines)


def _dither_coning(scenario, res, freqs, lines) -> list:
    """Each pair of dithers whose beat the stored series resolve: the coning beat's closed form from the block's
    measured rocking, and the beat in each filter's attitude error about the third axis (at rest only).

    Two axes rocking at ``f_a`` and ``f_b`` make a coning angle about the third that beats at ``|f_a - f_b|`` with
    amplitude ``a_a a_b (w_a + w_b) / (4 |w_a - w_b|)`` (:func:`sins_sim.models.block.coning_beat_amplitude`). The
    stored series are means over ``1 / rate``: the dither lines average out and a beat below a quarter of the
    rate is measured (:func:`sins_sim.simulation.metrics.stored_line`). At rest and level the body axes are the
    NED axes turned by the site's heading about down.
    """
    from sins_sim.models.block import coning_beat_amplitude
    from sins_sim.simulation.metrics import stored_line

    traj = scenario.trajectory_spec or {}
    if scenario.nav is None or traj.get("file") or traj.get("segments") or traj.get("speed_m_s"):
        return []
    from sins_sim.earth import level_body_from_ned

    rate = scenario.nav.series_rate_hz(scenario.duration_s)
    psi = float(scenario.site.get("heading_rad", 0.0))
    record_s = scenario.duration_s - scenario.nav.start_s
    out = []
    for a, b in ((0, 1), (0, 2), (1, 2)):
        delta = abs(freqs[a] - freqs[b])
        if not 0.0 < delta <= 0.25 * rate:
            continue
        c = 3 - a - b
        ax_a, ax_b = "xyz"[a], "xyz"[b]
        rock_a = lines[ax_a][f"{ax_a}_dither"]["simulated_arcsec"] * ARCSEC
        rock_b = lines[ax_b][f"{ax_b}_dither"]["simulated_arcsec"] * ARCSEC
        beat = coning_beat_amplitude(rock_a, rock_b, 2 * math.pi * freqs[a], 2 * math.pi * freqs[b])
        # a beat is measured over at least one of its periods: over less, the fitted line and trend trade off and
        # the amplitude is not the beat's (the closed form stands alone then)
        resolved = record_s * delta >= 1.0
        filt = {}
        for name in res.filters:
            ser = res.series.get(name)
            if not resolved or name in res.diverged or ser is None or ser["t_s"].size < 8:
                continue
            err = level_body_from_ned(ser["attitude_ned_rad"], psi)
            filt[name] = stored_line(ser["t_s"], err[:, c], delta, rate) / ARCSEC
        out.append({"pair": [ax_a, ax_b], "about": "xyz"[c], "separation_hz": delta, "heading_rad": psi,
                    "beat_closed_form_arcsec": beat / ARCSEC, "beat_in_attitude_error_arcsec": filt,
                    "record_s": record_s, "beat_resolved": resolved, "series_rate_hz": rate})
    return out


def _block_report(blk) -> list:
    """The report's section on the block on its isolators (``metrics.json`` ``block``)."""
    if not blk:
        return []
    lines = ["", f"## The block on its isolators ({blk['record_s']:.3g} s record)", "",
             "Its own rotation relative to the chassis: RMS and the line at each gyro's drive, beside the linear "
             "coupled model (`models.block.block_rotation_per_deflection` x the measured dither amplitude).", "",
             "| about | RMS (arcsec) | " + " | ".join(f"at {a} drive: simulated / model (arcsec)" for a in "xyz") + " |",
             "|---|---|---|---|---|"]
    for ax, row in blk["dither_lines"].items():
        cells = " | ".join(f"{r['simulated_arcsec']:.4g} / {r['linear_model_arcsec']:.4g}" for r in row.values())
        lines.append(f"| block {ax} | {blk['rotation_rms_arcsec'][ax]:.4g} | {cells} |")
    for cn in blk.get("dither_coning") or []:
        a, b = cn["pair"]
        lines += ["", f"Dither coning of gyros {a} and {b}, {cn['separation_hz']:.4g} Hz apart: a beat about {cn['about']} "
                  f"of {cn['beat_closed_form_arcsec']:.3g} arcsec (closed form from the block's measured rocking). "
                  f"The beat in each filter's attitude error about {cn['about']} (from the stored means):", "",
                  "| filter | beat (arcsec) |", "|---|---|"]
        lines += [f"| {n} | {v:.3g} |" for n, v in cn["beat_in_attitude_error_arcsec"].items()]
        if not cn["beat_resolved"]:
            lines.append(f"| (not measured: the {cn['record_s']:.3g} s navigated are less than one beat period, "
                         f"{1.0 / cn['separation_hz']:.3g} s) | |")
    modes = ", ".join(f"{f:.1f}" for f in blk["isolator_modes_hz"])
    lines += ["", f"Isolator modes: {modes} Hz."]
    if blk.get("vibration_enters"):
        lines.append(f"The linear vibration enters at the {blk['vibration_enters']}.")
    if blk.get("motion_enters") == "block":
        lines.append("The angular motion profiles enter at the block (its own rotation as measured on it; the "
                     "rotation above is the response to the dithers and the chassis, superposed on them).")
    return lines
