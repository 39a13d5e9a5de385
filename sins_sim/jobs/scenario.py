"""Scenario files (``scenarios/*.yaml``): validate, run the three-axis SINS, write results.

A scenario names an IMU configuration, the block's motion as a list of
segments that add up, the filters to compare, navigation settings and a
seed. ``run_scenario`` writes ``metrics.json``, ``timeseries.npz``,
``attitude_error.png``, ``spectrum.png`` and ``report.md``. A run is
reproducible from the YAML and the seed.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from sins_sim.jobs.imu import imu_from_dict, load_yaml
from sins_sim.jobs.schema import Bool, ConfigError, ListOf, Map, Num, OneOf, Str, Vec, validate
from sins_sim.simulation.sins import SINS_FILTERS, NavSettings, simulate_sins
from sins_sim.units import ARCMIN, ARCSEC, DEG_PER_H

__all__ = ["SCENARIO_SCHEMA", "MOTION_SCHEMA", "load_scenario", "run_scenario", "Scenario"]

_POS = dict(min=0.0, min_exclusive=True)

MOTION_SCHEMA = OneOf({
    "static": Map({}),
    "constant_rate": Map({"rate": Vec(3, unit="deg_s", required=True)}),
    "turn": Map({"axis": Vec(3, required=True), "angle": Num(unit="deg", required=True),
                 "duration": Num(unit="s", required=True, **_POS), "start": Num(unit="s", min=0.0, default=0.0)}),
    "sines": Map({"amplitude": Vec(3, unit="arcmin", required=True, min=0.0),
                  "frequency": Vec(3, unit="hz", required=True, min=0.0),
                  "phase": Vec(3, unit="deg", default=[0.0, 0.0, 0.0])}),
    "coning": Map({"amplitude": Num(unit="arcmin", required=True, **_POS),
                   "frequency": Num(unit="hz", required=True, **_POS),
                   "phase": Num(unit="deg", default=90.0)}),
    "random_vibration": Map({"psd_deg2_s2_per_hz": ListOf(Vec(2, min=0.0), required=True, min_len=2,
                                           doc="[[f_hz, rate PSD (deg/s)^2/Hz], ...]"),
                             "f_lo": Num(unit="hz", required=True, **_POS),
                             "f_hi": Num(unit="hz", required=True, **_POS),
                             "axes": Vec(3, default=[1.0, 1.0, 1.0], min=0.0)}),
    "shock": Map({"axis": Vec(3, required=True), "peak_rate": Num(unit="deg_s", required=True),
                  "duration": Num(unit="ms", required=True, **_POS), "start": Num(unit="s", min=0.0, default=0.0),
                  "ring_frequency": Num(unit="hz", min=0.0, default=0.0),
                  "ring_amplitude": Num(unit="deg_s", default=0.0),
                  "ring_decay": Num(unit="ms", min=0.0, min_exclusive=True, default=5.0)}),
    "sweep": Map({"axis": Vec(3, required=True), "amplitude": Num(unit="arcmin", required=True, **_POS),
                  "f_start": Num(unit="hz", required=True, **_POS), "f_stop": Num(unit="hz", required=True, **_POS),
                  "duration": Num(unit="s", required=True, **_POS), "start": Num(unit="s", min=0.0, default=0.0),
                  "kind": Str(choices=("linear", "log"), default="linear")}),
})

SCENARIO_SCHEMA = Map({
    "name": Str(required=True),
    "description": Str(default=""),
    "seed": Num(integer=True, min=0, default=0),
    "duration": Num(unit="s", required=True, **_POS),
    "imu": None,  # path or mapping: checked by load_scenario
    "motion": ListOf(MOTION_SCHEMA, required=True, min_len=1),
    "filters": ListOf(Str(choices=SINS_FILTERS), default=list(SINS_FILTERS), min_len=1),
    "navigation": Map({
        "coning": Str(choices=("none", "two_sample", "three_sample"), default="two_sample"),
        "start": Num(unit="s", min=0.0, default=1.0),
        "timeseries_rate": Num(unit="hz", **_POS, default=720.0),
        "spectrum": Num(unit="s", min=0.0, default=2.0),
    }, default={}),
    "outputs": Map({"plots": Bool(default=True), "timeseries": Bool(default=True)}, default={}),
})


class _Any:
    """Placeholder schema entry for ``imu`` (a path or a mapping, checked separately)."""

    unit = None
    default = None
    required = True

    def check(self, value, ctx, path):
        if not isinstance(value, (str, dict)):
            raise ConfigError(f"{ctx}: {path}: must be a path to an IMU file or an IMU mapping, got {value!r}")
        return value


SCENARIO_SCHEMA.fields["imu"] = _Any()


class Scenario:
    """A validated scenario: IMU, motion, filters, navigation settings, seed."""

    def __init__(self, doc: dict, ctx: str, base_dir: Path):
        c = validate(doc, SCENARIO_SCHEMA, ctx)
        self.name = c["name"]
        self.description = c["description"]
        self.seed = int(c["seed"])
        self.duration_s = c["duration_s"]
        imu = c["imu"]
        if isinstance(imu, str):
            imu_path = (base_dir / imu).resolve()
            if not imu_path.exists():
                raise ConfigError(f"{ctx}: imu: file not found: {imu_path}")
            self.imu_source = str(imu)
            self.imu = imu_from_dict(load_yaml(imu_path), f"{ctx} -> {imu_path.name}")
        else:
            self.imu_source = "inline"
            self.imu = imu_from_dict(imu, ctx, "imu")
        self.motion_spec = c["motion"]
        self.motion = _build_motion(c["motion"], self.seed, ctx)
        self.filters = tuple(dict.fromkeys(c["filters"]))
        nv = c["navigation"]
        try:
            self.nav = NavSettings(coning=nv["coning"], start_s=nv["start_s"],
                                   timeseries_rate_hz=nv["timeseries_rate_hz"], spectrum_s=nv["spectrum_s"])
        except ValueError as exc:
            raise ConfigError(f"{ctx}: {exc}") from None
        if self.nav.start_s >= self.duration_s:
            raise ConfigError(f"{ctx}: navigation.start_s: must be < duration_s = {self.duration_s:g}, "
                              f"got {self.nav.start_s:g}")
        self.outputs = c["outputs"]


def _build_motion(segments, seed, ctx):
    from sins_sim.models import motion as m3

    parts = []
    for i, seg in enumerate(segments):
        kind = seg["type"]
        path = f"motion[{i}]"
        try:
            if kind == "static":
                part = m3.Static()
            elif kind == "constant_rate":
                part = m3.ConstantRate(rate_rad_s=np.array(seg["rate_rad_s"]))
            elif kind == "turn":
                part = m3.Turn(axis=np.array(seg["axis"]), angle_rad=seg["angle_rad"],
                               duration_s=seg["duration_s"], start_s=seg["start_s"])
            elif kind == "sines":
                part = m3.AxisSines(amplitude_rad=np.array(seg["amplitude_rad"]),
                                    frequency_hz=np.array(seg["frequency_hz"]), phase_rad=np.array(seg["phase_rad"]))
            elif kind == "coning":
                part = m3.Coning(amplitude_rad=seg["amplitude_rad"], frequency_hz=seg["frequency_hz"],
                                 phase_rad=seg["phase_rad"])
            elif kind == "random_vibration":
                table = [(f, p * (math.pi / 180.0) ** 2) for f, p in seg["psd_deg2_s2_per_hz"]]  # (deg/s)^2/Hz -> (rad/s)^2/Hz
                part = m3.RandomVibration(psd_table=tuple(table), f_lo_hz=seg["f_lo_hz"], f_hi_hz=seg["f_hi_hz"],
                                          axis_weights=tuple(seg["axes"]), seed=seed + 1000 * (i + 1))
            elif kind == "shock":
                part = m3.Shock(axis=np.array(seg["axis"]), peak_rate_rad_s=seg["peak_rate_rad_s"],
                                duration_s=seg["duration_s"], start_s=seg["start_s"],
                                ring_frequency_hz=seg["ring_frequency_hz"] or None,
                                ring_amplitude_rad_s=seg["ring_amplitude_rad_s"], ring_decay_s=seg["ring_decay_s"])
            else:  # sweep (the schema admits no other type)
                part = m3.RateTableSweep(axis=np.array(seg["axis"]), amplitude_rad=seg["amplitude_rad"],
                                         f_start_hz=seg["f_start_hz"], f_stop_hz=seg["f_stop_hz"],
                                         duration_s=seg["duration_s"], start_s=seg["start_s"], kind=seg["kind"])
        except ValueError as exc:
            raise ConfigError(f"{ctx}: {path}: {exc}") from None
        parts.append(part)
    motion = parts[0]
    for part in parts[1:]:
        motion = motion + part
    return motion


def load_scenario(path) -> Scenario:
    """Read and validate a scenario file (errors name the file, the key path and the rule)."""
    path = Path(path)
    return Scenario(load_yaml(path), str(path), path.parent)


def _metrics(res, scenario) -> dict:
    from sins_sim.navigation.error import equivalent_position_error_1h, position_error_from_attitude_error

    out = {}
    for name, st in res.full_stats.items():
        drift = np.asarray(st["drift_rad_s"])
        # the run's own navigation consequence: its attitude-error history through the INS error equations
        # (Schuler loop, local-level frame, navigation frame taken as NED)
        nav_err = position_error_from_attitude_error(res.t - res.t[0], res.attitude_error[name])
        out[name] = {
            "drift_deg_per_h": [float(x) / DEG_PER_H for x in drift],
            "drift_norm_deg_per_h": float(np.linalg.norm(drift)) / DEG_PER_H,
            "attitude_error_rms_arcsec": [float(x) / ARCSEC for x in st["rms_rad"]],
            "attitude_error_final_arcsec": [float(x) / ARCSEC for x in st["final_rad"]],
            # a horizontal (roll/pitch) drift tilts the platform and feeds the Schuler loop; a yaw drift
            # does not to first order for a vehicle at rest (navigation/error.py)
            "position_error_1h_m": abs(float(equivalent_position_error_1h(float(np.hypot(drift[0], drift[1]))))),
            "velocity_error_final_m_s": float(np.hypot(*nav_err.velocity_m_s[-1])),
            "position_error_final_m": float(nav_err.horizontal_m[-1]),
        }
    return out


def run_scenario(path, out_dir, progress=None) -> dict:
    """Run a scenario file end to end; return the metrics dictionary."""
    scenario = load_scenario(path)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    res = simulate_sins(scenario.imu, scenario.motion, scenario.duration_s, seed=scenario.seed, nav=scenario.nav,
                        filters=scenario.filters, progress=progress)
    metrics = {
        "scenario": scenario.name,
        "description": scenario.description,
        "seed": scenario.seed,
        "duration_s": scenario.duration_s,
        "navigation": {"coning": scenario.nav.coning, "start_s": scenario.nav.start_s},
        "imu": scenario.imu.name,
        "filters": _metrics(res, scenario),
        "alignment_samples": {k: v for k, v in res.delays.items() if k != "residual_eliminator"},
        "drives": [{**d, "amplitude_measured_arcmin": d["amplitude_measured_rad"] / ARCMIN,
                    "amplitude_target_arcmin": d["amplitude_target_rad"] / ARCMIN} for d in res.drives],
        "warnings": res.warnings,
    }
    (out / "metrics.json").write_text(json.dumps(metrics, indent=2) + "\n")
    if scenario.outputs["timeseries"]:
        np.savez_compressed(out / "timeseries.npz", t=res.t,
                            **{f"attitude_error_{k}": v for k, v in res.attitude_error.items()},
                            **{f"spectrum_{k}": v for k, v in res.spectra.items()})
    figures = []
    if scenario.outputs["plots"]:
        from sins_sim.plots.common import plot_attitude_error, plot_output_spectra

        plot_attitude_error(res, out / "attitude_error.png",
                            title=f"{scenario.name}: attitude error per dither filter ({scenario.nav.coning} coning "
                                  f"correction)")
        plot_output_spectra(res, out / "spectrum.png", title=f"{scenario.name}: filter outputs vs the true angle")
        figures = ["attitude_error.png", "spectrum.png"]
    (out / "report.md").write_text(_report(scenario, metrics, figures))
    return metrics


def _report(scenario, metrics, figures) -> str:
    lines = [f"# {scenario.name}", "", scenario.description or "", "",
             f"- duration {scenario.duration_s:g} s, seed {scenario.seed}, IMU `{scenario.imu.name}` "
             f"({scenario.imu_source}), navigation from t = {scenario.nav.start_s:g} s with "
             f"`{scenario.nav.coning}` coning correction",
             "", "| filter | drift x, y, z (deg/h) | drift norm (deg/h) | attitude error RMS (arcsec) | "
                 "final error (arcsec) | position error 1 h (m) | velocity / position error at the end (m/s, m) |",
             "|---|---|---|---|---|---|---|"]
    for name, m in metrics["filters"].items():
        f3 = lambda xs: ", ".join(f"{x:.3g}" for x in xs)  # noqa: E731
        lines.append(f"| {name} | {f3(m['drift_deg_per_h'])} | {m['drift_norm_deg_per_h']:.3g} | "
                     f"{f3(m['attitude_error_rms_arcsec'])} | {f3(m['attitude_error_final_arcsec'])} | "
                     f"{m['position_error_1h_m']:.3g} | {m['velocity_error_final_m_s']:.3g} / "
                     f"{m['position_error_final_m']:.3g} |")
    lines += ["", "Drift: least-squares slope of the attitude error over the navigation interval. Position error "
              "1 h: the Schuler-loop response to the horizontal (roll, pitch) drift held for an hour. Velocity / "
              "position at the end: this run's attitude-error history through the INS error equations "
              "(local-level frame, Earth rate neglected).", "",
              "Drives (closed-loop amplitude at the amplitude-dependent resonance):", "",
              "| axis | f0 (Hz) | drive (Hz) | V_m start -> end (V) | amplitude (arcmin) |", "|---|---|---|---|---|"]
    for d in metrics["drives"]:
        lines.append(f"| {d['axis']} | {d['f0_hz']:g} | {d['frequency_hz']:.3f} | {d['v_m_initial']:.4g} -> "
                     f"{d['v_m_final']:.4g} | {d['amplitude_measured_arcmin']:.4g} |")
    if metrics["warnings"]:
        lines += ["", "Warnings:", ""] + [f"- {w}" for w in metrics["warnings"]]
    lines += [""] + [f"![{f}]({f})" for f in figures] + [""]
    return "\n".join(lines)
