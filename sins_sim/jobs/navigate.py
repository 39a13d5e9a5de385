"""``sins-sim navigate``: navigate angle and velocity increments from elsewhere against a trajectory's truth.

Increments from another simulator or a logged IMU go through sins-sim's strapdown navigator and come
out with the metrics of ``sins-sim run`` (:func:`sins_sim.jobs.run.scenario_metrics`: position,
velocity and attitude errors, the psi angle and the attitude drift per NED axis, the gyro drift per
body axis, the Allan terms where the vehicle rests).

The increments file (CSV with one header row and optional ``#`` comment lines before it, or Parquet)
has the columns :data:`INCREMENT_COLUMNS`:

- ``time_s``: end of each increment's interval, on the trajectory file's time axis (its ``time_s``
  column), uniformly spaced; the rate is taken from it; navigation starts one period before the
  first row, aligned to the truth there;
- ``dtheta_x_rad, dtheta_y_rad, dtheta_z_rad``: angle increments, body axes (x forward, y right,
  z down: the trajectory's vehicle frame), rad, raw (not coning-compensated);
- ``dv_x_m_s, dv_y_m_s, dv_z_m_s``: velocity increments (specific force integrated), body axes, m/s,
  raw (not sculling-compensated).

API: :func:`navigate_increments` (arrays and a trajectory in, metrics out), :func:`read_increments`,
:func:`navigate_file` (what the command runs).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from sins_sim.config.errors import ConfigError

__all__ = ["INCREMENT_COLUMNS", "OPTIONAL_COLUMNS", "read_increments", "write_increments", "navigate_increments", "navigate_file"]

#: The columns of an increments file, in this order when sins-sim writes one.
INCREMENT_COLUMNS = ("time_s", "dtheta_x_rad", "dtheta_y_rad", "dtheta_z_rad", "dv_x_m_s", "dv_y_m_s", "dv_z_m_s")
#: Columns an increments file may hold beside them (read by ``sins-sim identify``, passed over by navigation).
OPTIONAL_COLUMNS = ("temperature_c",)


def read_increments(path) -> tuple:
    """``(t_s, dtheta, dv)`` from an increments file (CSV or Parquet; columns :data:`INCREMENT_COLUMNS`).

    Raises
    ------
    ConfigError
        One line naming the file and the column or row: unreadable, a missing or unknown column, a cell
        that is not a finite number.
    """
    import pandas as pd

    p = Path(path)
    if not p.is_file():
        raise ConfigError(f"{p}: cannot read: no such file")
    try:
        if p.suffix.lower() in (".parquet", ".pq"):
            df = pd.read_parquet(p)
        else:
            # round_trip: the exact float64 of every written digit (pandas before 2.2 parses with a faster, inexact
            # converter by default)
            df = pd.read_csv(p, comment="#", skip_blank_lines=True, float_precision="round_trip")
    except pd.errors.EmptyDataError:
        raise ConfigError(f"{p}: line 1: no header row, the file is empty (needs the columns "
                          f"{', '.join(INCREMENT_COLUMNS)})") from None
    except Exception as exc:  # noqa: BLE001 - any reader failure is the file's fault: one line
        raise ConfigError(f"{p}: cannot read: {' '.join(str(exc).split())}") from None
    cols = [str(c).strip() for c in df.columns]
    missing = [c for c in INCREMENT_COLUMNS if c not in cols]
    if missing:
        raise ConfigError(f"{p}: column {missing[0]}: missing{' (with ' + ', '.join(missing[1:]) + ')' if missing[1:] else ''}"
                          f"; the file needs {', '.join(INCREMENT_COLUMNS)}")
    extra = [c for c in cols if c not in INCREMENT_COLUMNS + OPTIONAL_COLUMNS]
    if extra:
        import difflib

        close = difflib.get_close_matches(extra[0], INCREMENT_COLUMNS, n=1)
        raise ConfigError(f"{p}: column {extra[0]}: unknown{'; did you mean ' + repr(close[0]) + '?' if close else ''} "
                          f"(allowed: {', '.join(INCREMENT_COLUMNS + OPTIONAL_COLUMNS)})")
    df.columns = cols
    data = {}
    for c in INCREMENT_COLUMNS:
        x = pd.to_numeric(df[c], errors="coerce").to_numpy(dtype=np.float64)
        bad = np.flatnonzero(~np.isfinite(x))
        if bad.size:
            raise ConfigError(f"{p}: {c}: row {int(bad[0]) + 1} is not a finite number ({df[c].iloc[bad[0]]!r})")
        data[c] = x
    return (data["time_s"], np.stack([data[c] for c in INCREMENT_COLUMNS[1:4]], axis=1),
            np.stack([data[c] for c in INCREMENT_COLUMNS[4:7]], axis=1))


def write_increments(path, t_s, dtheta, dv) -> None:
    """Write an increments file (CSV, or Parquet for ``.parquet``/``.pq``) that :func:`read_increments` reads back."""
    import pandas as pd

    arr = np.column_stack([np.asarray(t_s, dtype=np.float64), np.asarray(dtheta), np.asarray(dv)])
    df = pd.DataFrame(arr, columns=list(INCREMENT_COLUMNS))
    p = Path(path)
    if p.suffix.lower() in (".parquet", ".pq"):
        df.to_parquet(p, index=False)
    else:
        df.to_csv(p, index=False, float_format="%.17g")


class _Context:
    """What :func:`sins_sim.jobs.run.scenario_metrics` reads from a scenario: the site latitude and the events."""

    def __init__(self, lat_rad: float):
        self.site = {"lat_rad": float(lat_rad)}
        self.events = ()


def navigate_increments(t_s, dtheta, dv, truth, *, name: str = "external", coning: str = "two_sample",
                        sculling: str = "two_sample", vertical: str = "height_aid",
                        height_aid_tau_s: float = 100.0, q0_nb=None, v0_ned_m_s=None) -> dict:
    """Navigate increments against a truth; return the metrics of ``sins-sim run`` for them.

    Parameters
    ----------
    t_s, dtheta, dv, truth, coning, sculling, vertical, height_aid_tau_s, q0_nb, v0_ned_m_s
        As :func:`sins_sim.simulation.external.navigate_increments` (times on the truth's own axis:
        seconds since its first sample; ``q0_nb``, ``v0_ned_m_s``: an alignment's start instead of the truth's).
    name : str
        The key of the result in ``filters``.

    Returns
    -------
    dict
        ``{"filters": {name: metrics}, "navigation": {...settings, start_s, end_s, rate_hz}}``; the
        metrics are those of a filter in ``metrics.json`` of ``sins-sim run``.

    Examples
    --------
    >>> from sins_sim.models.motion import Stationary, Trajectory
    >>> from sins_sim.simulation.external import ideal_increments
    >>> truth = Trajectory(0.7, 0.2, 100.0, 0.0, 0.0, [Stationary(120.0)])
    >>> t = 0.01 * np.arange(1, 6001)
    >>> dth, dv = ideal_increments(truth, t)
    >>> m = navigate_increments(t, dth, dv, truth)["filters"]["external"]
    >>> m["horizontal_position_error_m"]["final"] < 1e-6
    True
    """
    from sins_sim.jobs.run import scenario_metrics
    from sins_sim.simulation.external import navigate_increments as _navigate

    res = _navigate(t_s, dtheta, dv, truth, name=name, coning=coning, sculling=sculling, vertical=vertical,
                    height_aid_tau_s=height_aid_tau_s, q0_nb=q0_nb, v0_ned_m_s=v0_ned_m_s)
    lat0 = float(res.truth_series["lat_rad"][0]) if res.truth_series["lat_rad"].size else 0.0
    return {"filters": scenario_metrics(res, _Context(lat0)),
            "navigation": {**res.settings, "start_s": res.nav_start_s, "end_s": res.duration_s}}


def _site(meta: dict, lat_deg, lon_deg, height_m) -> tuple:
    """``(site in rad and m, notes)``: the flags over the log table's metadata; a missing latitude is refused."""
    import math

    known = dict(meta.get("site") or {})
    notes = []
    site = {}
    for key, flag, val, conv in (("lat_rad", "--site-lat-deg", lat_deg, math.radians),
                                 ("lon_rad", "--site-lon-deg", lon_deg, math.radians),
                                 ("height_m", "--site-height-m", height_m, float)):
        if val is not None:
            site[key] = conv(val)
        elif known.get(key) is not None:
            site[key] = float(known[key])
        elif key == "lat_rad":
            raise ConfigError("--site-lat-deg: the increments carry no site latitude (sins-sim import-log stores the "
                              "one its description gives); give --site-lat-deg: alignment needs the latitude")
        else:
            site[key] = 0.0
            notes.append(f"{flag.lstrip('-').replace('-', ' ')}: not given, 0 assumed")
    if not abs(site["lat_rad"]) < math.radians(89.5):
        raise ConfigError(f"--site-lat-deg: must be within +-89.5 deg (the NED mechanization and gyrocompassing are "
                          f"singular at the poles), got {math.degrees(site['lat_rad']):g}")
    return site, notes


def _imu_sensors(imu):
    if imu is None:
        return None
    from sins_sim.config.imu import load_imu

    return load_imu(imu).sensors


def _in_file_terms(message: str) -> str:
    """A message of :func:`sins_sim.simulation.external.navigate_increments` in the file's words: ``t_s`` is the
    column ``time_s``, ``dtheta[i, j]`` and ``dv[i, j]`` are row ``i + 1`` of ``dtheta_<axis>_rad`` and
    ``dv_<axis>_m_s``."""
    import re

    m = re.match(r"(dtheta|dv)\[(\d+), (\d)\]: (.*)$", message)
    if m:
        col = INCREMENT_COLUMNS[(1 if m.group(1) == "dtheta" else 4) + int(m.group(3))]
        return f"{col}: row {int(m.group(2)) + 1}: {m.group(4)}"
    if message.startswith("t_s: "):  # its rows are indices from 0; the file's data rows count from 1
        return "time_s: " + re.sub(r"\brow (\d+)", lambda r: f"row {int(r.group(1)) + 1}", message[5:])
    return message


def navigate_file(increments, truth_file, out_dir, *, name: str = "external", coning: str = "two_sample",
                  sculling: str = "two_sample", vertical: str = "height_aid", height_aid_tau_s: float = 100.0,
                  align: str = "truth", align_duration_s: float = 300.0, imu=None, site_lat_deg=None,
                  site_lon_deg=None, site_height_m=None, zupt: bool = False, force: bool = False,
                  manifest=None) -> dict:
    """``sins-sim navigate``: read the increments (and the trajectory file, if any), align, navigate, write
    ``metrics.json`` and ``manifest.json`` (the command, versions, the inputs' hashes; ``manifest`` from the CLI).

    With ``truth_file``: the errors against it, as a run's (``align="truth"`` starts from the truth one period
    before the first row; another method aligns over the first ``align_duration_s`` and starts from what it
    found, with zero velocity, and the errors then include the alignment's). With no truth (a real unit's log):
    ``align`` must be a method; the site comes from the table's metadata (``sins-sim import-log``) or the
    ``site_*`` arguments; the result is the solution itself (``solution.parquet``, its displacement from the
    start, the figures and ``report.md``). ``imu``: an IMU file whose ``sensors:`` section gives the bias bounds
    the alignment states its sigma from (without it, only the data's own scatter). ``zupt`` (no truth, an
    ``imu`` required): the log stands still; after the alignment it is navigated with zero-velocity updates
    (:func:`~sins_sim.navigation.static_kalman.navigate_zupt`), and the velocity residuals and the bias
    estimates with their sigmas (an unobservable one reported as such) go to ``metrics.json`` and
    ``zupt.parquet``.
    Returns the metrics written.
    """
    from sins_sim.io import read_trajectory
    from sins_sim.jobs.import_log import read_log_table
    from sins_sim.jobs.manifest import Manifest, result_dir
    from sins_sim.jobs.output import atomic_write_text
    from sins_sim.jobs.run import _json_default
    from sins_sim.models.motion import SampledTrajectory
    from sins_sim.models.motion.trajectory import velocity_check_in_file_terms
    from sins_sim.navigation.alignment_result import ALIGNMENT_METHODS
    from sins_sim.simulation.external import uniform_period

    if align not in ALIGNMENT_METHODS:
        raise ConfigError(f"--align: must be one of {', '.join(ALIGNMENT_METHODS)}, got {align!r}")
    if truth_file is None and align == "truth":
        raise ConfigError("--align: with no --truth the starting attitude must come from an alignment: give --align "
                          "coarse, inertial or kalman (or a trajectory file with --truth)")
    if zupt and truth_file is not None:
        raise ConfigError("--zupt: navigates a log that stood still, with no truth beside it; drop --truth (a truth "
                          "run gives the errors themselves)")
    if zupt and imu is None:
        raise ConfigError("--zupt: give --imu: the zero-velocity filter's process noise and bias priors come from the "
                          "unit's sensor-error model (its sensors: section)")
    t, dth, dv, meta = read_log_table(increments)
    from sins_sim.simulation.external import _check_physical

    try:
        dt = uniform_period(t, "t_s")  # named t_s, as the engine names it: _in_file_terms maps it to the file's
        _check_physical(dth, dv, dt)
    except ValueError as exc:
        raise ConfigError(f"{increments}: {_in_file_terms(' '.join(str(exc).split()))}") from None
    sensors = _imu_sensors(imu)
    truth = None
    if truth_file is not None:
        try:
            data = read_trajectory(truth_file)
            truth = SampledTrajectory.from_data(data)
        except ValueError as exc:
            msg = velocity_check_in_file_terms(" ".join(str(exc).split()), str(truth_file), "the tolerance (m/s)")
            raise ConfigError(f"--truth: {msg}") from None
    settings = {"name": name, "coning": coning, "sculling": sculling, "vertical": vertical,
                "height_aid_tau_s": height_aid_tau_s, "align": align}
    if manifest is None:
        manifest = Manifest("navigate", settings={**settings, "align_duration_s": align_duration_s,
                                                  "imu": None if imu is None else str(imu)})
    manifest.add_input("increments", increments)
    inputs = [increments]
    if truth_file is not None:
        manifest.add_input("truth", truth_file)
        inputs.append(truth_file)
    if imu is not None:
        manifest.add_input("imu", imu)
        inputs.append(imu)
    if align == "truth":
        metrics = _navigate_against_truth(t, dth, dv, truth, name, coning, sculling, vertical, height_aid_tau_s,
                                          source=increments)
        figures = {}
    else:
        n_w = int(round(align_duration_s / dt))
        if not (align_duration_s > 0.0 and 2 <= n_w <= t.size - 2):
            raise ConfigError(f"--align-duration: the window must hold at least 2 rows and leave 2 to navigate: the "
                              f"increments span {t.size * dt:.6g} s at {1.0 / dt:.6g} Hz, got {align_duration_s:g} s")
        if truth is not None:
            t0 = float(t[0] - dt) - truth.time_offset_s
            first = truth.evaluate([max(t0, 0.0)])
            site = {"lat_rad": float(first.lat_rad[0]), "lon_rad": float(first.lon_rad[0]), "height_m": float(first.h_m[0])}
            notes = []
        else:
            site, notes = _site(meta, site_lat_deg, site_lon_deg, site_height_m)
        result = _align(align, align_duration_s, sensors, dth[:n_w], dv[:n_w], dt, site, increments)
        if sensors is None:
            notes.append("no --imu: the stated sigma holds the data's own scatter only, no bias bound")
        if truth is not None:
            metrics = _navigate_against_truth(t[n_w:], dth[n_w:], dv[n_w:], truth, name, coning, sculling, vertical,
                                              height_aid_tau_s, q0=result.q_nb, source=increments)
            q_true = truth.evaluate([float(t[n_w - 1]) - truth.time_offset_s]).q_nv[0]
            from sins_sim.jobs.run import alignment_metrics
            from sins_sim.navigation.attitude import attitude_error

            metrics["filters"][name]["alignment"] = alignment_metrics(
                {"result": result, "error_rad": attitude_error(result.q_nb, q_true)})
            figures = {"alignment.png": ("alignment", {name: result})}
        else:
            metrics, free = _navigate_without_truth(t[n_w:], dth[n_w:], dv[n_w:], site, result, coning, sculling,
                                                    vertical, height_aid_tau_s)
            figures = {"alignment.png": ("alignment", {name: result}), "displacement.png": ("displacement", free)}
            if zupt:
                zres, metrics["zupt"] = _zupt(dth[n_w:], dv[n_w:], dt, site, result, align_duration_s, sensors,
                                              increments)
                figures["zupt.parquet"] = ("table", zres)
        if notes:
            metrics["notes"] = notes
    metrics = {"increments": str(increments), "truth": None if truth_file is None else str(truth_file),
               **({"log": {k: meta[k] for k in ("source", "site") if k in meta}} if meta else {}), **metrics}
    with result_dir(out_dir, manifest, inputs=tuple(inputs), force=force) as tmp:
        atomic_write_text(Path(tmp) / "metrics.json", json.dumps(metrics, indent=2, default=_json_default) + "\n")
        written = _write_extras(Path(tmp), metrics, figures)
        atomic_write_text(Path(tmp) / "report.md", _report(metrics, written, name))
    return metrics


def _align(method, duration_s, sensors, dth, dv, dt, site, source):
    from sins_sim.simulation.aligning import ALIGNERS, alignment_settings

    settings = alignment_settings(method, duration_s, sensors)
    try:
        return ALIGNERS[method](dth, dv, dt, {"lat_rad": site["lat_rad"], "lon_rad": site["lon_rad"],
                                              "h_m": site["height_m"]}, settings)
    except ValueError as exc:
        raise ConfigError(f"{source}: alignment ({method}): {' '.join(str(exc).split())}") from None


def _zupt(dth, dv, dt, site, start, duration_s, sensors, source):
    """Zero-velocity navigation of a still log from the alignment's attitude; ``(result, metrics section)``."""
    from sins_sim.navigation.static_kalman import navigate_zupt
    from sins_sim.simulation.aligning import alignment_settings, filter_noise
    from sins_sim.units import ARCSEC, DEG, DEG_PER_H, MICRO_G

    noise = filter_noise(alignment_settings("kalman", duration_s, sensors))
    # The alignment's sigmas are built from the same bias bounds the filter's bias priors are (tilt = b_a / g,
    # heading = eps_E / (Omega cos lat)): taking both as independent priors would count that knowledge twice and
    # make the horizontal accelerometer and east gyro biases look observable at rest. The attitude priors are
    # therefore loosened (3x, at least 1 arcmin and 0.1 deg): the updates pin the attitude, and a bias that rest
    # cannot separate from it keeps its own prior.
    try:
        res = navigate_zupt(dth, dv, dt, site["lat_rad"], site["lon_rad"], site["height_m"], start.q_nb, noise,
                            prior_tilt_sigma_rad=max(3.0 * float(max(start.sigma_rad[:2])), 60.0 * ARCSEC),
                            prior_heading_sigma_rad=max(3.0 * float(start.sigma_rad[2]), 0.1 * DEG))
    except ValueError as exc:
        raise ConfigError(f"{source}: --zupt: {' '.join(str(exc).split())}") from None
    st = res.innovation_stats()
    out = {"updates": int(res.nis.size), "velocity_residual_rms_ned_m_s": [float(x) for x in st["rms_m_s"]],
           "velocity_residual_mean_ned_m_s": [float(x) for x in st["mean_m_s"]], "nis_mean": st["nis_mean"],
           "nis_expected": 3.0, "nis_above_95_fraction": st["nis_above_95_fraction"]}
    for key, val, sig, unit, label in (("gyro_bias", res.gyro_bias_rad_s, res.gyro_bias_sigma_rad_s, DEG_PER_H, "deg_h"),
                                       ("accel_bias", res.accel_bias_m_s2, res.accel_bias_sigma_m_s2, MICRO_G, "ug")):
        for i, ax in enumerate("xyz"):
            k = f"{key}_{ax}"
            out[f"{k}_{label}"] = (float(val[i] / unit) if res.observable.get(k, True) else "not observable")
            out[f"{k}_sigma_{label}"] = float(sig[i] / unit)
    out["note"] = ("at rest the east gyro bias is not separable from the heading, nor the horizontal accelerometer "
                   "biases from the tilts: a bias whose sigma stays near its prior is reported as not observable, "
                   "never as a number (body axes: which of them is east depends on the heading)")
    return res, out


def _navigate_against_truth(t, dth, dv, truth, name, coning, sculling, vertical, tau, q0=None, source="increments"):
    offset = truth.time_offset_s
    try:
        metrics = navigate_increments(t - offset, dth, dv, truth, name=name, coning=coning, sculling=sculling,
                                      vertical=vertical, height_aid_tau_s=tau, q0_nb=q0,
                                      v0_ned_m_s=None if q0 is None else np.zeros(3))
    except ValueError as exc:
        raise ConfigError(f"{source}: {_in_file_terms(' '.join(str(exc).split()))}") from None
    nav = metrics["navigation"]
    nav["start_s"] += offset  # back on the files' time axis
    nav["end_s"] += offset
    return metrics


def _navigate_without_truth(t, dth, dv, site, result, coning, sculling, vertical, tau):
    from sins_sim.navigation.attitude import euler_from_quat
    from sins_sim.simulation.external import navigate_free

    try:
        free = navigate_free(t, dth, dv, site["lat_rad"], site["lon_rad"], site["height_m"], result.q_nb, np.zeros(3),
                             coning=coning, sculling=sculling, vertical=vertical, height_aid_tau_s=tau)
    except ValueError as exc:
        raise ConfigError(f"increments: {' '.join(str(exc).split())}") from None
    d = free.displacement_m()
    horiz = np.hypot(d[:, 0], d[:, 1])
    roll, pitch, yaw = np.degrees(euler_from_quat(free.solution.q_nb[-1]))
    metrics = {
        "navigation": {**free.settings, "start_s": free.start["t_s"], "end_s": float(t[-1]),
                       "site": {"lat_deg": float(np.degrees(site["lat_rad"])),
                                "lon_deg": float(np.degrees(site["lon_rad"])), "height_m": site["height_m"]}},
        "alignment": result.to_dict(),
        "solution": {
            "final_displacement_m": {"north": float(d[-1, 0]), "east": float(d[-1, 1]), "up": float(d[-1, 2]),
                                     "horizontal": float(horiz[-1])},
            "max_horizontal_displacement_m": float(horiz.max()),
            "final_velocity_ned_m_s": [float(x) for x in free.solution.v_ned_m_s[-1]],
            "final_attitude_deg": {"roll": float(roll), "pitch": float(pitch), "heading": float(yaw % 360.0)},
            "note": "no truth: the solution's displacement from where navigation started; for a unit that stood "
                    "still it is the navigation error (the alignment's and the sensors' together)",
        },
    }
    return metrics, free


def _write_extras(folder: Path, metrics: dict, figures: dict) -> list:
    """The solution table and the figures; returns the file names written."""
    written = []
    for fname, (kind, data) in figures.items():
        if kind == "table":
            data.to_pandas().reset_index().to_parquet(folder / fname, index=False)
        elif kind == "alignment":
            from sins_sim.plots.alignment import alignment_figure

            alignment_figure(data, folder / fname)
        else:
            from sins_sim.plots.alignment import displacement_figure

            displacement_figure(data.solution.t_s, data.displacement_m(), folder / fname,
                                note=("vertical: held at the site's height" if data.settings["vertical"] == "height_aid"
                                      else "vertical: free inertial"))
            _solution_table(data).to_parquet(folder / "solution.parquet", index=False)
            written.append("solution.parquet")
        written.append(fname)
    return written


def _solution_table(free):
    import pandas as pd

    from sins_sim.navigation.attitude import euler_from_quat

    d, sol = free.displacement_m(), free.solution
    e = np.degrees(euler_from_quat(sol.q_nb))
    return pd.DataFrame({"time_s": sol.t_s, "lat_deg": np.degrees(sol.lat_rad), "lon_deg": np.degrees(sol.lon_rad),
                         "height_m": sol.h_m, "north_m": d[:, 0], "east_m": d[:, 1], "up_m": d[:, 2],
                         "vn_m_s": sol.v_ned_m_s[:, 0], "ve_m_s": sol.v_ned_m_s[:, 1], "vd_m_s": sol.v_ned_m_s[:, 2],
                         "roll_deg": e[:, 0], "pitch_deg": e[:, 1], "heading_deg": e[:, 2] % 360.0})


def _report(metrics: dict, written: list, name: str) -> str:
    nav = metrics["navigation"]
    lines = [f"# sins-sim navigate: {metrics['increments']}", "",
             f"- navigated from {nav['start_s']:.6g} s to {nav['end_s']:.6g} s at {nav['rate_hz']:.6g} Hz; "
             f"`{nav['coning']}` coning, `{nav['sculling']}` sculling, vertical `{nav['vertical']}`"
             + (f" (held at {nav['height_held_m']:.6g} m)" if "height_held_m" in nav else ""),
             f"- truth: {metrics['truth'] or 'none (a unit log: the solution itself is the result)'}"]
    al = metrics.get("alignment") or metrics.get("filters", {}).get(name, {}).get("alignment")
    if al:
        lines += ["", "## Alignment", "",
                  f"`{al['method']}` over {al['duration_s']:g} s: heading {al['heading_deg']:.4f} deg "
                  f"(sigma {al['sigma_heading_deg']:.3g} deg), roll {al['roll_deg']:.4f} deg, pitch "
                  f"{al['pitch_deg']:.4f} deg (tilt sigma N, E {al['sigma_tilt_north_arcsec']:.3g}, "
                  f"{al['sigma_tilt_east_arcsec']:.3g} arcsec)."]
        if "error_heading_deg" in al:
            lines.append(f"Against the truth: heading error {al['error_heading_deg']:+.4g} deg, tilt N, E "
                         f"{al['error_tilt_north_arcsec']:+.3g}, {al['error_tilt_east_arcsec']:+.3g} arcsec.")
        for note in al.get("notes", []):
            lines.append(f"- {note}")
    sol = metrics.get("solution")
    if sol:
        f = sol["final_displacement_m"]
        lines += ["", "## Solution", "", sol["note"] + ".", "",
                  f"- final displacement: north {f['north']:.4g} m, east {f['east']:.4g} m, up {f['up']:.4g} m "
                  f"(horizontal {f['horizontal']:.4g} m; largest {sol['max_horizontal_displacement_m']:.4g} m)"]
    z = metrics.get("zupt")
    if z:
        rms = ", ".join(f"{x:.3g}" for x in z["velocity_residual_rms_ned_m_s"])
        lines += ["", "## Zero-velocity updates", "",
                  f"{z['updates']} updates; velocity residual RMS N, E, D {rms} m/s; mean NIS {z['nis_mean']:.3g} "
                  f"(3 for a consistent filter).", "", "| bias | x | y | z |", "|---|---|---|---|"]
        for key, label in (("gyro_bias", "deg_h"), ("accel_bias", "ug")):
            cells = []
            for ax in "xyz":
                val = z[f"{key}_{ax}_{label}"]
                sig = z[f"{key}_{ax}_sigma_{label}"]
                cells.append(val if isinstance(val, str) else f"{val:.3g} +- {sig:.2g}")
            lines.append(f"| {key.replace('_', ' ')} ({label.replace('_', '/')}) | " + " | ".join(cells) + " |")
        lines += ["", z["note"] + "."]
    m = metrics.get("filters", {}).get(name)
    if m and "horizontal_position_error_m" in m:
        lines += ["", "## Errors against the truth", "",
                  f"- horizontal {m['horizontal_position_error_m']['final']:.4g} m (largest "
                  f"{m['horizontal_position_error_m']['max']:.4g} m), velocity {m['velocity_error_m_s']['final']:.3g} m/s"]
    for note in metrics.get("notes", []):
        lines.append(f"- {note}")
    if written:
        lines += ["", "## Files", ""] + [f"- `{w}`" for w in written]
    return "\n".join(lines) + "\n"
