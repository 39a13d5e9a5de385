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
* ``navigation_error.png``, ``attitude_error.png``, ``trajectory.png``,
  ``gyro_error_spectrum.png`` and ``report.md``.
"""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path

import numpy as np

from sins_sim.simulation.metrics import drift_metrics, event_steps
from sins_sim.simulation.sins import simulate_sins
from sins_sim.units import ARCMIN, ARCSEC

__all__ = ["run_scenario", "scenario_metrics", "NMI_M", "CEP_RATE_MIN_S"]

#: One international nautical mile (m).
NMI_M = 1852.0
#: The CEP rate (final horizontal error over the navigated time) is reported for missions at
#: least this long (s): over shorter ones the Schuler oscillation (84.4 min) dominates a radial
#: error rate.
CEP_RATE_MIN_S = 1800.0
_NED = ("north", "east", "down")


def _ned(vec) -> dict:
    return {k: float(x) for k, x in zip(_NED, vec)}


def scenario_metrics(res, scenario) -> dict:
    """The ``filters`` section of ``metrics.json`` from a :class:`~sins_sim.simulation.sins.SinsResult`."""
    from sins_sim import earth
    from sins_sim.navigation.error import position_error_from_attitude_error

    out = {}
    mission_s = res.duration_s - res.nav_start_s
    events = _events_ned(scenario)
    ideal = res.stats.get("ideal")
    for name in res.filters:
        st = res.stats.get(name)
        div = res.diverged.get(name)
        if st is None or st.n == 0:
            out[name] = {"status": "diverged" if div else "no data", "diverged": div}
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
            m["excess_over_ideal"] = {
                "horizontal_position_error_final_m": last["horizontal_m"] - ideal.last["horizontal_m"],
                "attitude_error_rms_arcsec": _ned((st.attitude_rms_rad - ideal.attitude_rms_rad) / ARCSEC)}
        t = ser["t_s"]
        if t.size >= 8:
            m["drift_deg_per_h"] = drift_metrics(t, ser["attitude_ned_rad"])
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
            m["drift_deg_per_h"] = None
            m["events"] = []
        if name in res.allan:
            m["allan"] = {ax: a.to_dict() for ax, a in res.allan[name].items()}
        out[name] = m
    return out


def _events_ned(scenario):
    """Block turns get their axis in NED (vehicle attitude at the turn's start times the body axis)."""
    out = []
    for ev in scenario.events:
        ev = dict(ev)
        if ev["kind"] == "turn":
            stream = scenario.vehicle.stream() if hasattr(scenario.vehicle, "stream") else scenario.vehicle
            q = np.asarray(stream.evaluate(np.array([ev["start_s"]])).q_nv)[0]
            ev["axis_ned"] = _rotate(q, np.asarray(ev["axis_body"]))
        out.append(ev)
    return out


def _rotate(q, x):
    q0, q1, q2, q3 = q
    c = np.array([[1 - 2 * (q2 * q2 + q3 * q3), 2 * (q1 * q2 - q0 * q3), 2 * (q1 * q3 + q0 * q2)],
                  [2 * (q1 * q2 + q0 * q3), 1 - 2 * (q1 * q1 + q3 * q3), 2 * (q2 * q3 - q0 * q1)],
                  [2 * (q1 * q3 - q0 * q2), 2 * (q2 * q3 + q0 * q1), 1 - 2 * (q1 * q1 + q2 * q2)]])
    return (c @ x).tolist()


def run_scenario(path, out_dir, progress=None, overrides: dict | None = None, threads: int | None = None) -> dict:
    """Run a scenario file end to end; write the results into ``out_dir``; return the metrics.

    Parameters
    ----------
    path : path
        The scenario YAML.
    out_dir : path
        Folder for the results (created).
    progress : callable(fraction) or None
    overrides : dict, optional
        Top-level keys replacing the file's (``seed``, ``duration_s``).
    threads : int, optional
        Threads for the three axes (default: the cores available, at most 3).
    """
    from sins_sim.jobs import advisories
    from sins_sim.jobs.messages import warning_text
    from sins_sim.jobs.scenario import load_scenario

    with warnings.catch_warnings(record=True) as caught:  # configuration-time warnings: told now, kept for metrics
        scenario = load_scenario(path, overrides)
    config_warnings = list(dict.fromkeys(t for t in map(warning_text, caught) if t))
    advise = getattr(progress, "advise", None)
    for text in config_warnings:
        if advise is not None:  # the CLI prints it now, before the engine runs
            advise(text)
        else:
            warnings.warn(text, UserWarning, stacklevel=2)
    from sins_sim.jobs.estimate import check_run

    check_run(scenario, progress)  # refuse a run that cannot finish, before the engine starts (issue 12, point 3)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    res = simulate_sins(scenario.imu, scenario.motion, scenario.duration_s, seed=scenario.seed, nav=scenario.nav,
                        filters=scenario.filters, progress=progress, threads=threads, vehicle=scenario.vehicle,
                        translation=scenario.translation)
    metrics = {
        "scenario": scenario.name,
        "description": scenario.description,
        "seed": scenario.seed,
        "duration_s": scenario.duration_s,
        "mission": {"site": {"lat_deg": math.degrees(scenario.site["lat_rad"]),
                             "lon_deg": math.degrees(scenario.site["lon_rad"]), "height_m": scenario.site["height_m"]},
                    "trajectory": scenario.vehicle.describe() if hasattr(scenario.vehicle, "describe") else "file"},
        "navigation": {"coning": scenario.nav.coning, "sculling": scenario.nav.sculling,
                       "start_s": scenario.nav.start_s, "n_sub": scenario.nav.n_sub,
                       "update_rate_hz": res.filter_rate_hz / scenario.nav.n_sub,
                       "vertical": scenario.nav.vertical, "accel_delay": scenario.nav.accel_delay},
        "imu": scenario.imu.name,
        "filters": scenario_metrics(res, scenario),
        "gyro_error_rms_arcsec": {name: [float(x) for x in np.sqrt(np.mean((e - e.mean(axis=0)) ** 2, axis=0)) / ARCSEC]
                                  for name, e in res.spectra.items() if name != "t" and e.shape[0]},
        "allan": _allan_section(res),
        "alignment_samples": {k: val for k, val in res.delays.items() if k != "residual_eliminator"},
        "drives": [{**d, "amplitude_measured_arcmin": d["amplitude_measured_rad"] / ARCMIN,
                    "amplitude_target_arcmin": d["amplitude_target_rad"] / ARCMIN} for d in res.drives],
        "diverged": res.diverged,
        "warnings": list(dict.fromkeys([*config_warnings, *res.warnings,
                                        *advisories.drive_advisories(res.drives, scenario.imu, scenario.duration_s)])),
    }
    (out / "metrics.json").write_text(json.dumps(metrics, indent=2, allow_nan=False, default=_json_default) + "\n")
    if scenario.outputs["timeseries"]:
        arrays = {f"truth_{k}": val for k, val in res.truth_series.items()}
        for name, ser in res.series.items():
            arrays.update({f"{name}__{k}": val for k, val in ser.items()})
        arrays.update({f"gyro_error_{k}": val for k, val in res.spectra.items()})
        np.savez_compressed(out / "timeseries.npz", **arrays)
    figures = []
    if scenario.outputs["plots"]:
        from sins_sim.plots import navigation as pn

        figures = pn.plot_run(res, out, scenario.name)
    (out / "report.md").write_text(_report(scenario, metrics, figures))
    return metrics


def _allan_section(res) -> dict | None:
    """What the per-filter ``allan`` readings are, and the accelerometers' own."""
    if not res.allan:
        return None
    acc = res.allan.get("accelerometers")
    return {"rate_hz": res.allan["rate_hz"], "record_s": res.allan["record_s"],
            "what": "overlapping Allan deviation (allantools) of each filter's gyro-angle error (output minus the "
                    "true gyro angle, sensor errors included) and of the accelerometers' accumulated velocity "
                    "error, sampled over the navigation period; terms read by sins_sim.navigation.allan.fit_allan "
                    "(IEEE Std 952-1997 Annex C); null where a term does not dominate anywhere on the curve",
            "accelerometers": {ax: a.to_dict() for ax, a in acc.items()} if acc else None}


def _json_default(x):
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    raise TypeError(f"not JSON serialisable: {type(x).__name__}")


def _fmt(x, spec=".3g"):
    return "n/a" if x is None else format(x, spec)


def _report(scenario, metrics, figures) -> str:
    nv = metrics["navigation"]
    lines = [f"# {scenario.name}", "", scenario.description or "", "",
             f"- mission: {metrics['duration_s']:g} s, {metrics['mission']['trajectory']}",
             f"- unit: IMU `{scenario.imu.name}` ({scenario.imu_source}), seed {scenario.seed}",
             f"- navigation: from t = {nv['start_s']:g} s aligned to the truth, updates at {nv['update_rate_hz']:g} Hz, "
             f"`{nv['coning']}` coning, `{nv['sculling']}` sculling, vertical channel `{nv['vertical']}`, "
             f"accelerometers `{nv['accel_delay']}` to each filter's delay", "",
             "## Navigation error of the integrated solution against the truth", "",
             "| filter | horizontal final (m) | horizontal max (m) | vertical final (m) | velocity final (m/s) | "
             "attitude RMS N, E, D (arcsec) | CEP rate (nmi/h) | status |",
             "|---|---|---|---|---|---|---|---|"]
    for name, m in metrics["filters"].items():
        if "horizontal_position_error_m" not in m:
            lines.append(f"| {name} | | | | | | | {m['status']} |")
            continue
        rms = m["attitude_error_arcsec"]["rms"]
        lines.append(f"| {name} | {m['horizontal_position_error_m']['final']:.3g} | "
                     f"{m['horizontal_position_error_m']['max']:.3g} | {m['vertical_position_error_m']['final']:.3g} | "
                     f"{m['velocity_error_m_s']['final']:.3g} | {rms['north']:.3g}, {rms['east']:.3g}, {rms['down']:.3g} | "
                     f"{_fmt(m['cep_rate_nmi_h'])} | {m['status']} |")
    lines += ["", "`ideal` runs the true gyro increments through the same navigation: the algorithm's and the "
              "accelerometers' floor. Every other filter's excess over it is that filter's cost. The CEP rate is "
              f"the final horizontal error over the mission time, for missions of {CEP_RATE_MIN_S / 60:.0f} min or more.",
              "", "## What the attitude error is", ""]
    for name, m in metrics["filters"].items():
        dr = m.get("drift_deg_per_h")
        if not dr:
            continue
        parts = []
        for ax, val, ci, r2 in zip(dr["axes"], dr["value"], dr["ci95"], dr["r2"]):
            parts.append(f"{ax} {val:.3g} +- {ci:.2g} deg/h" if val is not None else f"{ax}: no ramp (R^2 {r2})")
        lines.append(f"- **{name}**: drift " + "; ".join(parts))
        for ev in m.get("events", []):
            step = ", ".join(f"{x:.3g}" for x in ev["step_arcsec"])
            extra = (f", scale-factor error {ev['scale_factor_error_ppm']:.4g} ppm"
                     if "scale_factor_error_ppm" in ev else "")
            lines.append(f"  - {ev['kind']} at {ev['start_s']:g} s: step N, E, D = {step} arcsec{extra}")
        lm = m.get("linear_model")
        if lm:
            lines.append(f"  - linear error model cross-check: horizontal error "
                         f"{lm['horizontal_position_error_final_m']:.3g} m at the end "
                         f"(integrated solution: {m['horizontal_position_error_m']['final']:.3g} m)")
    lines += ["", "Drift is reported only where a ramp explains at least 90 % of the attitude error's variance and "
              "its slope exceeds its 95 % confidence interval (residual autocorrelation taken into account); "
              "otherwise the attitude error is bounded or a step, and is reported as such.", "",
              "## Gyro-angle error of each filter (output minus truth, full rate, over the spectrum window)", "",
              "| filter | RMS x, y, z (arcsec) |", "|---|---|"]
    for name, r in metrics["gyro_error_rms_arcsec"].items():
        lines.append(f"| {name} | {', '.join(f'{x:.3g}' for x in r)} |")
    al = metrics.get("allan")
    if al:
        lines += ["", f"## Allan deviation of each filter's gyro error ({al['record_s']:.4g} s at {al['rate_hz']:.3g} Hz)",
                  "", "| filter | axis | ARW (deg/sqrt(h)) | bias instability (deg/h) | rate random walk "
                  "(deg/h/sqrt(h)) | quantisation (arcsec) |", "|---|---|---|---|---|---|"]
        for name, m in metrics["filters"].items():
            for ax, r in (m.get("allan") or {}).items():
                lines.append(f"| {name} | {ax} | {_fmt(r['arw_deg_rt_h'])} | {_fmt(r['bias_instability_deg_h'])} | "
                             f"{_fmt(r['rrw_deg_h_rt_h'])} | {_fmt(r['quantization_arcsec'])} |")
        lines += ["", "n/a: the term does not dominate anywhere on the curve of this record (a filter's own "
                  "quantisation noise, slope -1, can hide the sensor's ARW up to tens of seconds)."]
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
    lines += [""] + [f"![{f}]({f})" for f in figures] + [""]
    return "\n".join(lines)
