"""``sins-sim identify LOG --out DIR``: a unit fitted from its log at rest, and its twin run beside the log.

The log is an increments table (``sins-sim import-log``; :func:`~sins_sim.jobs.import_log.read_log_table`):
angle and velocity increments in body FRD axes. On it, for a unit at rest over the whole log:

1. **noise**: the overlapping Allan deviation of each gyro (the increments' mean rate) and accelerometer
   (specific force, each axis's mean removed) axis, the IEEE Std 952-1997 / Std 1293-1998 power-law terms
   fitted to it and screened (:mod:`sins_sim.navigation.allan`: weighted non-negative least squares on the
   Allan variance with weights from the simple, non-overlapping equivalent degrees of freedom
   ``clusters - 1``; each term read off its own slope region, with a 95 % interval from the overlapping
   estimator's simple EDF, Riley 2008, Table 7). A term with no region where it dominates is "not
   determinable", never a number;
2. **biases**: the attitude from a self-alignment over the log (coarse or inertial,
   :mod:`sins_sim.navigation.alignment`), then the residual of the means against the Earth's rate and normal
   gravity at the site (:func:`sins_sim.navigation.rest_bias.rest_biases`): the north and down gyro
   components and the down accelerometer component with their sigma; the others "not observable";
3. **spectral lines** of each axis (:mod:`sins_sim.navigation.spectral_lines`: Welch PSD, local floor, an F
   threshold for a chance of :data:`LINE_FALSE_ALARM` of a false line in the whole log; amplitudes with sigmas);
4. **bias steps** and, where the log has a ``temperature_c`` column, **temperature coefficients**
   (:mod:`sins_sim.navigation.temperature_fit`: generalised least squares with the Allan-fitted noise covariance),
   each reported only where significant (5 % over the six axes);
5. **the twin beside the log** (``twin_seeds`` > 0): the twin's ``sensors:`` (:func:`twin_sensors`) simulated on
   the log's time axis and the log's mission run on each seed and on the log (:mod:`sins_sim.simulation.twin`),
   and where the log leaves the twin's envelope (:mod:`sins_sim.identification.twin_gap`, ``twin.findings``);
6. **explain and verdict** (with the twin): the catalogue's SINS-level effects added to the twin, re-simulated and
   localised again, the gap's shrink with a held-out check, and the verdict in the channel diagnosis's words
   (:mod:`sins_sim.identification.twin_explain`; ``explain`` and ``verdict`` in the metrics);
7. **output**: ``metrics.json``, ``allan.png``, ``psd.png``, ``twin-allan.png``, ``twin-psd.png``,
   ``twin-alignment.png``, ``twin-nav.png``, ``imu-sensors.yaml`` (a ``sensors:`` section for the unit's
   twin, each value's source and sigma in a comment) and ``report.md``.

A rate-table log (``sins-sim identify LOG --rate-table SEGMENTS.csv``, :func:`identify_rate_table`) gives the gyro
scale factors and misalignments from its reversal pairs (:mod:`sins_sim.navigation.rate_table`) instead; a
multi-position log (``--positions``, :func:`identify_positions`) the accelerometers' biases, scale factors and
misalignments and the gyros' g-sensitivity (:mod:`sins_sim.navigation.multiposition`); a moving log with its
trajectory (``--truth``, :func:`identify_truth`) the terms its motion excites (:mod:`sins_sim.navigation.truth_fit`).

API: :func:`identify` (returns :class:`~sins_sim.results.identify.IdentifyResult`, the metrics as a dict with
``to_pandas()``, ``plot(kind)`` and ``files``; writes the folder when ``out_dir`` is given), :func:`twin_sensors`.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from sins_sim.config.errors import ConfigError
from sins_sim.units import ARCSEC, DEG, DEG_PER_H, MICRO_G

__all__ = ["LINE_FALSE_ALARM", "NOT_DETERMINABLE", "NOT_OBSERVABLE", "identify", "identify_rate_table",
           "identify_positions", "identify_truth", "positions_yaml", "pulse_weights", "read_positions", "read_segments", "sensors_yaml",
           "truth_yaml", "twin_sensors"]

NOT_DETERMINABLE = "not determinable"
NOT_OBSERVABLE = "not observable"
#: How far the sample intervals may scatter (relative to their median) for one sample rate.
DT_TOL = 1e-3
#: The noise readings, per sensor: (term, metrics key, factor from SI, IMU-file key or None).
_NOISE_KEYS = {
    "gyro": (("quantization", "quantization_arcsec", 1.0 / ARCSEC, None),
             ("white", "arw_deg_rt_h", 60.0 / DEG, "arw_deg_rt_h"),
             ("flicker", "bias_instability_deg_h", 1.0 / DEG_PER_H, "bias_instability_deg_h"),
             ("random_walk", "rrw_deg_h_rt_h", 60.0 / DEG_PER_H, "rrw_deg_h_rt_h"),
             ("ramp", "rate_ramp_deg_h_per_h", 3600.0 / DEG_PER_H, None)),
    "accelerometer": (("quantization", "quantization_m_s", 1.0, None),
                      ("white", "vrw_ug_rt_hz", 1.0 / MICRO_G, "vrw_ug_rt_hz"),
                      ("flicker", "bias_instability_ug", 1.0 / MICRO_G, "bias_instability_ug"),
                      ("random_walk", "rrw_ug_rt_h", 60.0 / MICRO_G, "rrw_ug_rt_h"),
                      ("ramp", "ramp_ug_per_h", 3600.0 / MICRO_G, None)),
}
_BIAS_UNIT = {"gyro": ("deg_h", 1.0 / DEG_PER_H), "accelerometer": ("ug", 1.0 / MICRO_G)}
#: Chance of one or more false spectral lines in a log (its six channels together).
LINE_FALSE_ALARM = 0.01
#: The shortest still span fitted (s): ten one-second blocks, as the log's own rest check asks
#: (``sins_sim.io.unitlog.rest_latitude``).
MIN_REST_S = 10.0
#: Significance of a temperature coefficient, over the six axes together (Bonferroni).
TEMPERATURE_ALPHA = 0.05
#: Chance of a false bias step, over the six axes together (Bonferroni).
STEP_ALPHA = 0.05
#: Most seeds of the twin.
MAX_TWIN_SEEDS = 100


def _site(meta: dict, lat_deg, lon_deg, height_m) -> dict:
    site = dict(meta.get("site") or {})
    if lat_deg is not None:
        site["lat_rad"] = math.radians(float(lat_deg))
    if lon_deg is not None:
        site["lon_rad"] = math.radians(float(lon_deg))
    if height_m is not None:
        site["height_m"] = float(height_m)
    if "lat_rad" not in site or site["lat_rad"] is None:
        raise ConfigError("--site-lat-deg: the log records no site; give its latitude (deg)")
    lat = float(site["lat_rad"])
    if not (math.isfinite(lat) and abs(lat) <= math.radians(89.5)):
        raise ConfigError(f"--site-lat-deg: must lie within +-89.5 deg (gyrocompassing), got {math.degrees(lat):.6g}")
    return {"lat_rad": lat, "lon_rad": float(site.get("lon_rad") or 0.0),
            "height_m": float(site.get("height_m") or 0.0)}


def _interval(t) -> float:
    d = np.diff(np.asarray(t, dtype=np.float64))
    if d.size < 1:
        raise ConfigError("LOG: needs at least two increments")
    dt = float(np.median(d))
    if not (dt > 0.0 and np.all(np.abs(d - dt) <= DT_TOL * dt)):
        raise ConfigError(f"LOG: the increments must be evenly spaced (intervals within {DT_TOL:g} of their "
                          f"median {dt:g} s); got {d.min():g} to {d.max():g} s")
    return dt


def _noise_entry(analysis, name, key, scale) -> dict:
    term = analysis.terms[name]
    if not term.found:
        why = analysis.rejected.get(name) or analysis.reason or "no tau range where this term dominates the fit"
        return {"status": NOT_DETERMINABLE, "reason": why}
    out = {"value": term.coefficient * scale, "tau_range_s": list(term.tau_range_s),
           "slope_measured": term.slope_measured}
    if term.ci is not None:
        out["ci95"] = [term.ci[0] * scale, term.ci[1] * scale]
    return out


def _bias_entries(values, sigmas, labels, scale, unit) -> dict:
    out = {}
    for lab, val, sig in zip(labels, values, sigmas):
        key = f"{lab}_{unit}"
        out[key] = ({"status": NOT_OBSERVABLE} if not math.isfinite(val) else
                    {"value": float(val * scale), "sigma": float(sig * scale)})
    return out


def identify(log, out_dir=None, *, lat_deg=None, lon_deg=None, height_m=None, alignment: str = "coarse",
             gyro_bias_prior_deg_h: float = 0.01, accel_bias_prior_ug: float = 100.0, twin_seeds: int = 5,
             line_false_alarm: float = LINE_FALSE_ALARM, until_s: float | None = None, force: bool = False,
             manifest=None):
    """Fit a unit's noise terms, lines, biases and temperature coefficients from its log at rest, and run its twin
    beside it (module docstring).

    Parameters
    ----------
    log : path
        The increments table (``sins-sim import-log``'s Parquet, or a plain increments CSV/Parquet).
    out_dir : path, optional
        Folder for ``metrics.json``, ``allan.png``, ``imu-sensors.yaml``, ``report.md``; None: write nothing.
    lat_deg, lon_deg, height_m : float, optional
        The site, where the log's metadata has none (or to override it).
    alignment : str
        ``coarse`` or ``inertial``.
    gyro_bias_prior_deg_h, accel_bias_prior_ug : float
        1-sigma of the biases before the log: the unobservable part that couples into the observed ones
        (the tilt from a horizontal accelerometer bias, an axis near but not in the observable span).
    twin_seeds : int
        Seeds of the twin run beside the log (0: no twin; else at least 2, for an envelope).
    line_false_alarm : float
        Chance of one or more false spectral lines in the whole log (shared by its six channels).
    until_s : float, optional
        Use the log's first ``until_s`` seconds only (a log that is still at first and then moves). A log that
        moves within the span used is refused, naming the time it starts to move.
    force : bool
        Replace an earlier result at ``out_dir`` (default: refuse it); the folder appears only once complete.
    manifest : Manifest, optional
        The command's manifest (from the CLI); by default one naming this call's settings. ``manifest.json``
        records it with the log's SHA-256.

    Returns
    -------
    IdentifyResult
        The metrics (a dict, as ``metrics.json``) with :meth:`~sins_sim.results.identify.IdentifyResult.to_pandas`,
        :meth:`~sins_sim.results.identify.IdentifyResult.plot` and ``files`` (the files written).

    Raises
    ------
    ConfigError
        One line naming the flag or the file.
    """
    from sins_sim.io.unitlog import first_motion_s
    from sins_sim.jobs.import_log import read_log_table
    from sins_sim.navigation.alignment import align_coarse, align_inertial
    from sins_sim.navigation.allan import allan_axes, screen_noise
    from sins_sim.navigation.rest_bias import rest_biases

    if alignment not in ("coarse", "inertial"):
        raise ConfigError(f"--alignment: must be one of ['coarse', 'inertial'], got {alignment!r}")
    if isinstance(twin_seeds, bool) or not isinstance(twin_seeds, int) or not (twin_seeds == 0 or
                                                                             2 <= twin_seeds <= MAX_TWIN_SEEDS):
        raise ConfigError(f"--twin-seeds: must be 0 (no twin) or an integer in [2, {MAX_TWIN_SEEDS}], got "
                          f"{twin_seeds!r}")
    if not (isinstance(line_false_alarm, float) and 0.0 < line_false_alarm < 1.0):
        raise ConfigError(f"--line-false-alarm: must be a number in (0, 1), got {line_false_alarm!r}")
    for flag, val in (("--gyro-bias-prior-deg-h", gyro_bias_prior_deg_h),
                      ("--accel-bias-prior-ug", accel_bias_prior_ug)):
        if not (isinstance(val, (int, float)) and math.isfinite(val) and val >= 0.0):
            raise ConfigError(f"{flag}: must be a finite number >= 0, got {val!r}")
    if until_s is not None and not (isinstance(until_s, (int, float)) and math.isfinite(until_s) and until_s > 0):
        raise ConfigError(f"--until-s: must be a number > 0 (seconds from the log's start), got {until_s!r}")
    t, dth, dv, meta = read_log_table(log)
    if until_s is not None:
        steps = np.diff(t)
        dt0 = float(np.median(steps[steps > 0.0])) if np.any(steps > 0.0) else 0.0
        if not dt0 > 0.0:
            raise ConfigError("LOG: its time column never advances")
        keep = int(round(until_s / dt0))
        if keep > t.size:
            raise ConfigError(f"--until-s: {until_s:g} s is beyond the log's {t.size * dt0:g} s")
        if keep * dt0 < MIN_REST_S:
            raise ConfigError(f"--until-s: {until_s:g} s leaves less than {MIN_REST_S:g} s of the log to fit")
        t, dth, dv = t[:keep], dth[:keep], dv[:keep]
    settings = {"lat_deg": lat_deg, "lon_deg": lon_deg, "height_m": height_m, "alignment": alignment,
                "gyro_bias_prior_deg_h": gyro_bias_prior_deg_h, "accel_bias_prior_ug": accel_bias_prior_ug,
                "twin_seeds": twin_seeds, "line_false_alarm": line_false_alarm, "until_s": until_s}
    refused = _invalid_data(log, t, dth, dv, meta, out_dir, settings, manifest, force)
    if refused is not None:
        return refused
    site = _site(meta, lat_deg, lon_deg, height_m)
    dt = _interval(t)
    moved = first_motion_s(dth, dv, dt)
    if moved is not None:  # the noise, the biases and the twin are all fits of a unit at rest: never of a moving one
        hint = ((f"give --until-s {moved:g} to fit its still start, or " if moved >= MIN_REST_S else "")
                + "give --truth TRAJECTORY (the trajectory it moved on) to fit it against its known motion "
                  "(--rate-table for a rate-table run, --positions for a multi-position test)")
        raise ConfigError(f"{log}: the unit moves from {moved:g} s on (its one-second mean specific force or rate "
                          f"leaves its start's): identify fits a log at rest; {hint}")
    fs = 1.0 / dt
    pulses = pulse_weights(meta, dth, dv)
    rate, spec_force = dth / dt, dv / dt
    analyses = {
        "gyro": {ax: screen_noise(a) for ax, a in allan_axes(rate - rate.mean(axis=0), fs, "gyro").items()},
        "accelerometer": {ax: screen_noise(a) for ax, a in
                          allan_axes(spec_force - spec_force.mean(axis=0), fs, "accel").items()},
    }
    noise = {s: {ax: {key: _noise_entry(a, name, key, scale) for name, key, scale, _ in _NOISE_KEYS[s]}
                 for ax, a in by_ax.items()} for s, by_ax in analyses.items()}
    for s, by_ax in analyses.items():
        for ax, a in by_ax.items():
            if a.goodness_of_fit is not None:
                noise[s][ax]["goodness_of_fit"] = dict(a.goodness_of_fit)
    t_total = dth.shape[0] * dt
    sig_g = np.array([_mean_sigma(analyses["gyro"][ax], t_total) for ax in "xyz"])
    sig_a = np.array([_mean_sigma(analyses["accelerometer"][ax], t_total) for ax in "xyz"])
    prior_g, prior_a = gyro_bias_prior_deg_h * DEG_PER_H, accel_bias_prior_ug * MICRO_G
    wander = _gyro_wander(noise, analyses, t_total)
    align = align_coarse if alignment == "coarse" else align_inertial
    kwargs = {} if alignment == "coarse" else {"h_m": site["height_m"]}
    try:
        al = align(dth, dv, dt, site["lat_rad"], gyro_bias_sigma_rad_s=prior_g, accel_bias_sigma_m_s2=prior_a,
                   gyro_wander_sigma_rad_s=wander,
                   **kwargs)
    except ValueError as exc:
        raise ConfigError(f"LOG: alignment failed: {exc}") from None
    rb = rest_biases(dth, dv, dt, site["lat_rad"], site["height_m"], al.q_nb, gyro_mean_sigma_rad_s=sig_g,
                     accel_mean_sigma_m_s2=sig_a, gyro_bias_prior_rad_s=prior_g, accel_bias_prior_m_s2=prior_a)
    bias = {}
    for s, ned, ned_sig, body, body_sig in (
            ("gyro", rb.gyro_ned_rad_s, rb.gyro_ned_sigma_rad_s, rb.gyro_body_rad_s, rb.gyro_body_sigma_rad_s),
            ("accelerometer", rb.accel_ned_m_s2, rb.accel_ned_sigma_m_s2, rb.accel_body_m_s2,
             rb.accel_body_sigma_m_s2)):
        unit, scale = _BIAS_UNIT[s]
        bias[s] = {**_bias_entries(ned, ned_sig, ("north", "east", "down"), scale, unit),
                   **_bias_entries(body, body_sig, ("x", "y", "z"), scale, unit)}
    from sins_sim.jobs.import_log import read_log_temperature
    from sins_sim.simulation.twin import rest_run

    run_kw = {"gyro_bias_sigma_rad_s": prior_g, "accel_bias_sigma_m_s2": prior_a, "gyro_wander_sigma_rad_s": wander,
              "false_alarm": line_false_alarm / 6.0}
    try:
        log_run = rest_run(t, dth, dv, site, alignment, alignment=al, **run_kw)
    except ValueError as exc:
        raise ConfigError(f"LOG: {exc}") from None
    temp = read_log_temperature(log)
    temperature = _temperature(rate, spec_force, temp, fs) if temp is not None else None
    steps = _bias_steps(rate, spec_force, fs)
    metrics = {
        "log": str(log), "duration_s": float(t_total), "rate_hz": float(fs),
        "site": {"lat_deg": math.degrees(site["lat_rad"]), "lon_deg": math.degrees(site["lon_rad"]),
                 "height_m": site["height_m"]},
        "alignment": {"method": alignment, **{k: val for k, val in al.to_dict().items()
                                               if k in ("roll_deg", "pitch_deg", "heading_deg", "sigma_tilt_north_arcsec",
                                                        "sigma_tilt_east_arcsec", "sigma_heading_deg")}},
        "priors": {"gyro_bias_deg_h": gyro_bias_prior_deg_h, "accel_bias_ug": accel_bias_prior_ug},
        "noise": noise,
        "bias": bias,
        "lines": _lines_metrics(log_run.lines, line_false_alarm),
        "bias_steps": steps,
        "pulse_weights": pulses.to_dict() if pulses is not None else {"status": "not quantised"},
        "temperature": temperature if temperature is not None else {
            "status": "no temperature column (temperature_c) in the log"},
        "notes": [
            ("the down accelerometer bias is read against normal gravity (WGS-84 at the site's latitude and "
             "height): the site's gravity anomaly (typically tens of ug) is in the reading and not in its sigma"),
            ("a bias's sigma covers the noise terms the log determines; a term too weak to show on the curve can "
             "still move the mean over the whole log"),
        ],
        "methods": {
            "allan": "overlapping Allan deviation (allantools.oadev); IEEE Std 952-1997 Annex C power-law terms by "
                     "weighted non-negative least squares on the Allan variance, weights from the non-overlapping "
                     "EDF clusters - 1 (floored at 5 %); each term read off its own slope region",
            "ci95": "chi-square interval with the overlapping ADEV's simple EDF (Riley 2008, Table 7) of the term's "
                    "noise type, bounded over the region's correlated points (conservative)",
            "bias": "residual of the log's means against the Earth's rate and normal gravity in the aligned "
                    "frame; sigma: the fitted Allan deviation at the log's length and the priors' coupling",
            "lines": "Welch PSD (Hann, 50 % overlap, 15 segments); a bin is a line where its ratio to the local "
                     "floor (median of the neighbouring bins) exceeds the F(edf, edf_floor) quantile at the "
                     "false-alarm level over the bins searched (Bonferroni); amplitude from the excess power over "
                     "+-3 bins, corrected for the increments' sinc",
            "bias_steps": "one step b0 + d H(t - t_s) per axis at every block boundary (200 blocks) by the same "
                          "generalised least squares; found where the largest |z| exceeds the Bonferroni threshold "
                          "over the boundaries and the six axes at 5 %",
            "temperature": "bias = b0 + k (T - T_mean) by generalised least squares on 200 block means with the "
                           "covariance of white noise and a rate random walk (Allan-fitted, the random walk at its "
                           "95 % upper bound); reported where |k| > z sigma at 5 % over the six axes",
        },
    }
    detail = {"analyses": analyses, "log_run": log_run}
    if twin_seeds:
        metrics["twin"], detail["twin"] = _twin(metrics, analyses, site, al, t, alignment, twin_seeds,
                                                     run_kw, log_run, pulses=pulses)
        metrics["explain"], metrics["verdict"] = _explain(metrics, analyses, site, al, t, dth, dv, alignment,
                                                          twin_seeds, run_kw, log_run, temp, pulses=pulses)
    metrics = _json_ready(metrics)
    if out_dir is not None:
        from sins_sim.jobs.manifest import Manifest, result_dir

        if manifest is None:
            manifest = Manifest("identify", settings=settings)
        manifest.add_input("log", log)
        with result_dir(out_dir, manifest, inputs=(log,), force=force) as tmp:
            names = _write(Path(tmp), metrics, detail)
        files = {name: Path(out_dir) / name for name in names}
    else:
        files = {}
    from sins_sim.results.identify import IdentifyResult

    return IdentifyResult(metrics, detail=detail, files=files)


def _invalid_data(log, t, dth, dv, meta: dict, out_dir, settings: dict, manifest, force: bool):
    """The log's checks (:func:`sins_sim.identification.log_checks.check_log`); None when it passes, else the
    result with the verdict ``invalid data`` (its folder written when ``out_dir`` is given: ``metrics.json``,
    ``report.md`` and the manifest)."""
    from sins_sim.identification.log_checks import check_log, invalid_data_summary
    from sins_sim.identification.twin_explain import invalid_data
    from sins_sim.results.identify import IdentifyResult

    nominal = ((meta.get("description") or {}).get("time") or {}).get("rate_hz")
    findings = check_log(t, dth, dv, nominal_rate_hz=nominal)
    if not findings:
        return None
    line = invalid_data_summary(findings)
    verdict = {**invalid_data(line), "checks": findings,
               "criterion": "the log's checks: time order, gaps, even steps, the nominal rate, stuck or saturated "
                            "channels (sins_sim.identification.log_checks)"}
    metrics = _json_ready({"log": str(log), "rows": int(t.size), "start_s": float(t[0]), "end_s": float(t[-1]),
                           "verdict": verdict, "summary": line})
    report = "\n".join([
        f"# identify {Path(str(log)).name}: invalid data", "",
        "The log fails the checks every fit of `identify` rests on (an even time axis at one rate, live "
        "channels), so nothing is fitted and no twin is run.", "",
        "## Verdict", "", "**invalid data**", "",
        "| check | channel | time (s) | row | finding | what to do |", "|---|---|---|---|---|---|",
        *(f"| {f['check']} | {f['channel']} | {f['time_s']:.9g} | {f['sample'] + 1} | {f['message']} | "
          f"{f['remedy']} |" for f in findings), ""])
    files = _write_fit(out_dir, metrics, {"report.md": report}, manifest, settings, {"log": log}, force)
    return IdentifyResult(metrics, detail={}, files=files)


def _gyro_wander(noise: dict, analyses: dict, window_s: float) -> float:
    """The gyros' bias wander over the alignment window (:func:`sins_sim.simulation.twin.gyro_wander_sigma`) for
    the noise the twin gets (:func:`twin_sensors`: the rate random walk reported or held by the power-law fit, the
    bias instability where reported), so that the log's alignment and its twin's state the same sigma."""
    from sins_sim.models.sensor_errors import sensor_params_from_dict
    from sins_sim.simulation.twin import gyro_wander_sigma

    no_bias = {s: {f"{c}_{_BIAS_UNIT[s][0]}": {} for c in ("north", "east", "down")} for s in _BIAS_UNIT}
    doc, _ = twin_sensors({"noise": noise, "bias": no_bias}, np.array([1.0, 0.0, 0.0, 0.0]), analyses)
    return gyro_wander_sigma(sensor_params_from_dict(doc, "the identified twin"), window_s)


def pulse_weights(meta: dict, dth, dv):
    """The readout's pulse weights of a log (:class:`~sins_sim.simulation.twin.PulseWeights`), or None.

    From the log's description (``sins-sim import-log`` stores it in the metadata): a sensor logged as ``counts``
    or ``totals`` has its ``weight_<unit>`` per channel, in the log's own axes. Otherwise read off the increments
    (:func:`~sins_sim.simulation.twin.pulse_weight_of`, per channel in the log's axes): a channel whose every
    increment is a whole number of one step has that step as its weight. None where no channel is quantised.
    """
    from sins_sim.config.log import load_log_description
    from sins_sim.simulation.twin import PulseWeights, pulse_weight_of

    desc = (meta or {}).get("description")
    layout = None
    if isinstance(desc, dict):
        try:
            layout = load_log_description({k: val for k, val in desc.items()
                                           if k not in ("source", "axes_matrix_frd")}).layout
        except ConfigError as exc:
            raise ConfigError(f"LOG: the description in its metadata does not load again: {exc}") from None
    axes = np.eye(3) if layout is None else np.asarray(layout.axes, dtype=np.float64)
    weights, sources = [], []
    for name, inc, kind, scale in (("gyro", dth, getattr(layout, "gyro_kind", None), getattr(layout, "gyro_scale", None)),
                                   ("accelerometer", dv, getattr(layout, "accel_kind", None),
                                    getattr(layout, "accel_scale", None))):
        if kind in ("counts", "totals"):
            weights.append(np.asarray(scale, dtype=np.float64))
            sources.append(f"{name}: the log's description ({kind}, weight per pulse)")
            continue
        x_log = np.asarray(inc, dtype=np.float64) @ axes.T
        w = [pulse_weight_of(x_log[:, i]) for i in range(3)]
        weights.append(np.array([0.0 if q is None else q for q in w]))
        sources.append(f"{name}: read off the increments (every one a whole number of the weight)"
                       if any(q is not None for q in w) else f"{name}: not quantised (no pulse weight)")
    if not (np.any(weights[0]) or np.any(weights[1])):
        return None
    return PulseWeights(weights[0], weights[1], axes, "; ".join(sources))


def _mean_sigma(analysis, t_total: float) -> float:
    """1-sigma of an axis's mean over the log: the Allan deviation at the log's length ``T`` of the terms
    determined (for white noise exactly ``N / sqrt(T)``; a random walk's ``K^2 T / 3`` covers the mean's wander).
    Terms not determined are left out: extrapolating the fit's small coefficients of absent terms a decade
    beyond the reliable taus would invent noise. With no term determined, the measured deviation at the
    longest tau, an upper bound for noise that falls with tau."""
    found = [n for n, term in analysis.terms.items() if term.found]
    if found:
        return float(math.sqrt(sum(float(analysis.line(n, t_total)) ** 2 for n in found)))
    adev = analysis.curve.adev
    return float(adev[-1]) if adev.size else math.nan


def _json_ready(x):
    if isinstance(x, dict):
        return {k: _json_ready(val) for k, val in x.items()}
    if isinstance(x, (list, tuple)):
        return [_json_ready(val) for val in x]
    if isinstance(x, (np.floating, float)):
        return float(x) if math.isfinite(x) else None
    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, np.ndarray):
        return _json_ready(x.tolist())
    return x


def _vector_line(key, entries, what) -> str:
    """One ``key: [x, y, z]`` line with its source in a comment, or a comment saying why it is left out."""
    vals = [e.get("value") for e in entries]
    if any(val is None for val in vals):
        missing = [ax for ax, e in zip("xyz", entries) if e.get("value") is None]
        status = entries[[e.get("value") is None for e in entries].index(True)].get("status", "")
        return f"    # {key}: left out ({status} on axis {', '.join(missing)}); the twin's default 0 applies"
    sig = [e.get("sigma") for e in entries]
    ci = [e.get("ci95") for e in entries]
    if all(s is not None for s in sig):
        note = f"{what}; 1-sigma [{', '.join(f'{s:.3g}' for s in sig)}]"
    else:
        halfw = [(c[1] - c[0]) / 2.0 / 1.96 if c else math.nan for c in ci]
        note = f"{what}; 1-sigma ~ [{', '.join(f'{s:.3g}' for s in halfw)}] (95 % CI half-width / 1.96)"
    return f"    {key}: [{', '.join(f'{val:.6g}' for val in vals)}]   # {note}"


def sensors_yaml(metrics: dict) -> str:
    """The ``sensors:`` section for the unit's twin (the keys of ``sins-sim schema imu``), from :func:`identify`'s
    metrics; each value with its source and sigma as a comment, a value not found left out with the reason."""
    lines = ["# identified by sins-sim identify from " + str(metrics["log"]), "sensors:"]
    for s in ("gyro", "accelerometer"):
        lines.append(f"  {s}:")
        unit, _ = _BIAS_UNIT[s]
        bias_key = "bias_deg_h" if s == "gyro" else "bias_ug"
        lines.append(_vector_line(bias_key, [metrics["bias"][s][f"{ax}_{unit}"] for ax in "xyz"],
                                  "rest bias against Earth rate and gravity"))
        for name, key, _, imu_key in _NOISE_KEYS[s]:
            if imu_key is None:
                continue
            entries = [metrics["noise"][s][ax][key] for ax in "xyz"]
            lines.append(_vector_line(imu_key, entries, "Allan fit over tau " + ", ".join(
                f"{e['tau_range_s'][0]:.3g}-{e['tau_range_s'][1]:.3g} s" for e in entries if "tau_range_s" in e)))
            if name == "flicker" and all("tau_range_s" in e for e in entries):
                lo = min(e["tau_range_s"][0] for e in entries)
                hi = max(e["tau_range_s"][1] for e in entries)
                lines.append(f"    bias_instability_tau_s: [{lo:.6g}, {hi:.6g}]   # the flat region read")
    return "\n".join(lines + _pulse_yaml_lines(metrics)) + "\n"


def _pulse_yaml_lines(metrics: dict) -> list:
    """The readout's pulse weights as comment lines of the IMU file (the twin quantises its increments with them;
    the IMU schema's ``readout`` is the channel-level readout before dither removal, not these)."""
    pw = metrics.get("pulse_weights") or {}
    if "gyro_weight_arcsec" not in pw:
        return ["# readout pulses: the log's increments are not quantised (no pulse weight)"]
    return ["# readout pulses of the unit's output (the twin quantises its increments with them, residue carried):",
            "#   gyro_weight_arcsec: [" + ", ".join(f"{w:.9g}" for w in pw["gyro_weight_arcsec"]) + "]",
            "#   accelerometer_weight_ug_s: [" + ", ".join(f"{w:.9g}" for w in pw["accelerometer_weight_ug_s"]) + "]",
            "#   channel axes in FRD (rows): " + str(pw["axes_frd"]), "#   source: " + pw["source"]]


def _report(metrics: dict) -> str:
    out = ["# Unit identified from its log at rest", "",
           (f"Log `{metrics['log']}`: {metrics['duration_s']:.0f} s at {metrics['rate_hz']:.6g} Hz; site "
            f"{metrics['site']['lat_deg']:.6f} deg N, {metrics['site']['height_m']:.1f} m; alignment "
            f"{metrics['alignment']['method']} (its heading; the tilt levelled from the log's mean force)."), "", "## Noise (Allan)", "",
           "| sensor | axis | term | value | 95 % CI | tau range (s) |", "|---|---|---|---|---|---|"]
    for s, by_ax in metrics["noise"].items():
        for ax, terms in by_ax.items():
            for key, e in terms.items():
                if key == "goodness_of_fit":
                    continue
                if "value" in e:
                    ci = e.get("ci95")
                    out.append(f"| {s} | {ax} | {key} | {e['value']:.4g} | "
                               f"{'-' if ci is None else f'{ci[0]:.4g} to {ci[1]:.4g}'} | "
                               f"{e['tau_range_s'][0]:.3g} to {e['tau_range_s'][1]:.3g} |")
                else:
                    out.append(f"| {s} | {ax} | {key} | {e['status']} | | |")
    out += ["", "## Biases (against the Earth's rate and normal gravity)", "",
            "| sensor | component | value | 1-sigma |", "|---|---|---|---|"]
    for s, comps in metrics["bias"].items():
        for key, e in comps.items():
            sig = ("not determinable (no noise term fitted)" if e.get("sigma") is None else f"{e['sigma']:.2g}")
            out.append(f"| {s} | {key} | {e['value']:.4g} | {sig} |" if "value" in e else
                       f"| {s} | {key} | {e['status']} | |")
    out += ["", ("Not observable at rest: the east gyro bias (inseparable from the heading) and the horizontal "
                 "accelerometer biases (inseparable from the tilts); a body axis's bias only where the axis lies in "
                 "the observable directions."), ""]
    out += [f"- {note}" for note in metrics["notes"]] + [""]
    return "\n".join(out)


def _lines_metrics(searches: dict, false_alarm: float) -> dict:
    """Per sensor and axis: the search's settings and its lines in edge units (gyro: the rate's amplitude in deg/h
    and the angle's, ``A / (2 pi f)``, in arcsec; accelerometer: ug)."""
    out = {"false_alarm_per_log": false_alarm, "gyro": {}, "accelerometer": {}}
    for (sensor, ax), srch in searches.items():
        unit, scale = _BIAS_UNIT[sensor]
        rows = []
        for ln in srch.lines:
            row = {"frequency_hz": ln.frequency_hz, f"amplitude_{unit}": ln.amplitude * scale,
                   f"amplitude_sigma_{unit}": ln.amplitude_sigma * scale, "snr": ln.snr,
                   "snr_db": 10.0 * math.log10(ln.snr)}
            if sensor == "gyro":
                w = 2.0 * math.pi * ln.frequency_hz
                row["angle_amplitude_arcsec"] = ln.amplitude / w / ARCSEC
                row["angle_amplitude_sigma_arcsec"] = ln.amplitude_sigma / w / ARCSEC
            rows.append(row)
        out[sensor][ax] = {"threshold_power_ratio": srch.threshold, "false_alarm": srch.false_alarm,
                           "band_hz": list(srch.band_hz), "resolution_hz": srch.psd.resolution_hz,
                           "edf": srch.psd.edf, "floor_edf": srch.floor_edf, "lines": rows}
    return out


def _bias_steps(rate, spec_force, fs: float) -> dict:
    """Each axis's most likely bias step (:func:`sins_sim.navigation.temperature_fit.scan_bias_step`), with its
    size only where found at :data:`STEP_ALPHA` over the six axes."""
    from sins_sim.navigation.temperature_fit import scan_bias_step

    out = {"alpha_over_axes": STEP_ALPHA}
    for sensor, x, kind in (("gyro", rate, "gyro"), ("accelerometer", spec_force, "accel")):
        unit, scale = _BIAS_UNIT[sensor]
        out[sensor] = {}
        for i, ax in enumerate("xyz"):
            try:
                r = scan_bias_step(x[:, i], fs, sensor=kind, alpha=STEP_ALPHA / 6.0)
            except np.linalg.LinAlgError:  # block means without scatter: a record constant at its quantisation
                out[sensor][ax] = {"status": "not determinable (the axis shows no noise above its pulse weight)"}
                continue
            except ValueError as exc:
                raise ConfigError(f"LOG: bias step scan: {exc}") from None
            e = {"z": r.z, "threshold": r.threshold, "resolution_s": r.resolution_s}
            out[sensor][ax] = ({"time_s": r.time_s, f"size_{unit}": r.size * scale, f"sigma_{unit}": r.sigma * scale,
                                **e} if r.found else {"status": "none found", **e})
    return out


def _temperature(rate, spec_force, temp, fs: float) -> dict:
    """Each axis's temperature coefficient (:func:`sins_sim.navigation.temperature_fit.fit_temperature_coefficient`),
    the value only where significant at :data:`TEMPERATURE_ALPHA` over the six axes."""
    from sins_sim.navigation.temperature_fit import fit_temperature_coefficient

    if temp.shape[0] != rate.shape[0]:
        raise ConfigError(f"LOG: temperature_c has {temp.shape[0]} rows, the increments {rate.shape[0]}")
    if float(np.ptp(temp)) <= 0.0:
        return {"status": "the temperature is constant over the log: no coefficient can be fitted",
                "range_c": [float(temp.min()), float(temp.max())]}
    out = {"range_c": [float(temp.min()), float(temp.max())], "alpha_over_axes": TEMPERATURE_ALPHA}
    for sensor, x, kind in (("gyro", rate, "gyro"), ("accelerometer", spec_force, "accel")):
        unit, scale = _BIAS_UNIT[sensor]
        out[sensor] = {}
        for i, ax in enumerate("xyz"):
            try:
                fit = fit_temperature_coefficient(x[:, i], temp, fs, sensor=kind, alpha=TEMPERATURE_ALPHA / 6.0)
            except ValueError as exc:
                raise ConfigError(f"LOG: temperature fit: {exc}") from None
            entry = {"sigma": fit.sigma * scale, "threshold": fit.z * fit.sigma * scale, "t_ref_c": fit.t_ref_c,
                     "corr_with_time": fit.corr_time, "ols_sigma": fit.ols_sigma * scale}
            key = f"coefficient_{unit}_per_c"
            if fit.significant:
                entry = {"value": fit.coefficient * scale, **entry}
            else:
                entry = {"status": "not significant", **entry}
            out[sensor][ax] = {key: entry}
    return out


def twin_sensors(metrics: dict, q_nb, analyses: dict | None = None) -> tuple:
    """The twin's ``sensors:`` mapping (:func:`sins_sim.models.sensor_errors.sensor_params_from_dict`) from the
    metrics, and where each noise value came from.

    Noise: each term reported; a white noise or random walk that was not reported (no decade of its own slope)
    but that the power-law fit of the curve holds (``analyses``: its coefficient ``C_k``, ``N = sqrt(C)``,
    ``K = sqrt(3 C)``, IEEE Std 952-1997, Annex C) enters too, so that the twin reproduces the curve the log shows
    and not only the terms it proves; a bias instability only where reported (its flat region is needed for the
    twin's Gauss-Markov sum). Biases: those observable at rest put back in body axes at the aligned attitude,
    ``b_body = C_nb^T (b_N, 0, b_D)`` for the gyros and ``C_nb^T (0, 0, b_D)`` for the accelerometers (the
    unobservable components are absorbed by the alignment alike in the log and its twin)."""
    from sins_sim.navigation.attitude import dcm_from_quat

    c_nb = dcm_from_quat(np.asarray(q_nb, dtype=np.float64))
    out, source = {}, {}
    from_c = {"white": lambda c: math.sqrt(c), "random_walk": lambda c: math.sqrt(3.0 * c)}
    for s in ("gyro", "accelerometer"):
        unit, _ = _BIAS_UNIT[s]
        sec = {}
        for name, key, scale, imu_key in _NOISE_KEYS[s]:
            if imu_key is None:
                continue
            vals = []
            for ax in "xyz":
                e = metrics["noise"][s][ax][key]
                c = (analyses or {}).get(s, {}).get(ax)
                c = None if c is None else float(c.coefficients.get(name, 0.0))
                if e.get("value") is not None:
                    vals.append(float(e["value"]))
                    source[f"{s}.{imu_key}.{ax}"] = "reported term"
                elif name in from_c and c is not None and c > 0.0:
                    vals.append(from_c[name](c) * scale)
                    source[f"{s}.{imu_key}.{ax}"] = "power-law fit (term not reported)"
                else:
                    vals.append(0.0)
                    source[f"{s}.{imu_key}.{ax}"] = "absent"
            sec[imu_key] = vals
            if name == "flicker":
                ranges = [metrics["noise"][s][ax][key]["tau_range_s"] for ax in "xyz"
                          if "tau_range_s" in metrics["noise"][s][ax][key]]
                if ranges:
                    lo = min(r[0] for r in ranges)
                    sec["bias_instability_tau_s"] = [lo, max(max(r[1] for r in ranges), lo)]
        b = metrics["bias"][s]
        ned = np.array([b[f"{c}_{unit}"].get("value") or 0.0 for c in ("north", "east", "down")])
        ned[1] = 0.0
        if s == "accelerometer":
            ned[0] = 0.0
        sec["bias_deg_h" if s == "gyro" else "bias_ug"] = (c_nb.T @ ned).tolist()
        out[s] = sec
    return out, source


def _step_findings(steps: dict) -> list:
    """The bias steps found, as findings: the twin's noise is stationary, so a step is where the log leaves it."""
    out = []
    for sensor in ("gyro", "accelerometer"):
        unit, _ = _BIAS_UNIT[sensor]
        for ax, e in steps[sensor].items():
            if "time_s" not in e:
                continue
            out.append({"quantity": "bias_step", "sensor": sensor, "axis": ax, "time_s": e["time_s"],
                        "time_resolution_s": e["resolution_s"], f"size_{unit}": e[f"size_{unit}"],
                        f"sigma_{unit}": e[f"sigma_{unit}"],
                        "statement": (f"{sensor} {ax}: a bias step of {e[f'size_{unit}']:.3g} +- "
                                      f"{e[f'sigma_{unit}']:.2g} {unit} at {e['time_s']:.4g} s (to "
                                      f"{e['resolution_s']:.2g} s; z = {e['z']:.3g}, threshold {e['threshold']:.3g})")})
    return out


def _twin(metrics: dict, analyses: dict, site: dict, al, t, alignment: str, seeds: int, run_kw: dict,
          log_run, pulses=None) -> tuple:
    """Run the twin beside the log and localise where they part (:mod:`sins_sim.simulation.twin`,
    :mod:`sins_sim.identification.twin_gap`)."""
    from sins_sim.identification.twin_gap import NAV_QUANTITIES, alignment_side_by_side, localise
    from sins_sim.models.sensor_errors import sensor_params_from_dict
    from sins_sim.simulation.twin import twin_runs

    doc, source = twin_sensors(metrics, al.q_nb, analyses)
    params = sensor_params_from_dict(doc, "the identified twin")
    try:
        runs = twin_runs(params, t, site, al.q_nb, alignment, range(1, seeds + 1), pulses=pulses, **run_kw)
    except ValueError as exc:
        raise ConfigError(f"--twin-seeds: the twin's run failed: {exc}") from None
    gap = localise(log_run, runs)
    gap["findings"] += _step_findings(metrics["bias_steps"])
    nav_end = {}
    for key, col, label, scale, unit in NAV_QUANTITIES:
        b = gap["nav_bands"][(key, col)]
        nav_end[label] = {f"log_{unit}": float(log_run.nav[key][min(len(b["mean"]), len(log_run.nav_t_s)) - 1, col]
                                                 * scale),
                          f"twin_mean_{unit}": float(b["mean"][-1] * scale),
                          f"twin_halfwidth_{unit}": float((b["hi"][-1] - b["mean"][-1]) * scale)}
    out = {"seeds": seeds, "sensors": doc, "sensors_source": source, "simulated_at": "increments after dither removal (sensor errors on the "
                                                          "exact increments at rest" + (
                                                              ", then the readout's pulses)" if pulses is not None
                                                              else ")"),
           "alignment": alignment_side_by_side(log_run, runs, al.q_nb), "navigation_at_end": nav_end,
           "alpha": gap["alpha"], "findings": gap["findings"],
           "summary": (f"the log stays within its twin's envelope ({seeds} seeds) in every quantity tested"
                       if not gap["findings"] else f"{len(gap['findings'])} place(s) where the log leaves its "
                                                   f"twin's envelope ({seeds} seeds)")}
    return out, {"runs": runs, "gap": gap}


def _lines_report(metrics: dict) -> list:
    lm = metrics["lines"]
    out = ["", "## Spectral lines", "",
           (f"Welch PSD, Hann window, 50 % overlap; a line is declared where a bin exceeds its local floor by the "
            f"threshold below, set for a chance of {100 * lm['false_alarm_per_log']:.3g} % of one or more false lines "
            "in the whole log (module `sins_sim.navigation.spectral_lines`). Gyro amplitudes are of the rate "
            "(deg/h) and of the angle (arcsec); all corrected for the increments' averaging (sinc)."), "",
           "| sensor | axis | frequency (Hz) | amplitude | 1-sigma | angle (arcsec) | SNR (dB) | threshold (dB) |",
           "|---|---|---|---|---|---|---|---|"]
    for sensor in ("gyro", "accelerometer"):
        unit, _ = _BIAS_UNIT[sensor]
        for ax, e in lm[sensor].items():
            thr_db = 10.0 * math.log10(e["threshold_power_ratio"])
            if not e["lines"]:
                out.append(f"| {sensor} | {ax} | none in {e['band_hz'][0]:.3g} to {e['band_hz'][1]:.4g} Hz | | | | | "
                           f"{thr_db:.1f} |")
            for ln in e["lines"]:
                ang = f"{ln['angle_amplitude_arcsec']:.3g}" if "angle_amplitude_arcsec" in ln else ""
                out.append(f"| {sensor} | {ax} | {ln['frequency_hz']:.4f} +- {e['resolution_hz']:.2g} | "
                           f"{ln[f'amplitude_{unit}']:.4g} {unit} | {ln[f'amplitude_sigma_{unit}']:.2g} | {ang} | "
                           f"{ln['snr_db']:.1f} | {thr_db:.1f} |")
    return out


def _steps_report(metrics: dict) -> list:
    st = metrics["bias_steps"]
    out = ["", "## Bias steps", "",
           ("One step per axis tried at every block boundary (generalised least squares with the noise's "
            f"correlation); found where |z| exceeds the threshold ({100 * st['alpha_over_axes']:.3g} % over the "
            "boundaries and the six axes)."), "", "| sensor | axis | step | time (s) | z | threshold |",
           "|---|---|---|---|---|---|"]
    for sensor in ("gyro", "accelerometer"):
        unit, _ = _BIAS_UNIT[sensor]
        for ax, e in st[sensor].items():
            what = (f"{e[f'size_{unit}']:.3g} +- {e[f'sigma_{unit}']:.2g} {unit}" if "time_s" in e else e["status"])
            when = f"{e['time_s']:.4g} +- {e['resolution_s']:.2g}" if "time_s" in e else ""
            z = f"{e['z']:.3g}" if "z" in e else ""
            thr = f"{e['threshold']:.3g}" if "threshold" in e else ""
            out.append(f"| {sensor} | {ax} | {what} | {when} | {z} | {thr} |")
    return out


def _temperature_report(metrics: dict) -> list:
    tm = metrics["temperature"]
    out = ["", "## Temperature coefficients", ""]
    if "status" in tm:
        return out + [tm["status"] + "."]
    out += [(f"Temperature {tm['range_c'][0]:.2f} to {tm['range_c'][1]:.2f} deg C. Model: bias = b0 + k (T - T_mean), "
             "generalised least squares with the noise's correlation (white noise and a rate random walk from the "
             "Allan fit, the random walk at its 95 % upper bound); a coefficient is given where |k| exceeds the "
             f"threshold (z sigma, {100 * tm['alpha_over_axes']:.3g} % over the six axes)."), "",
            "| sensor | axis | k | 1-sigma | threshold |", "|---|---|---|---|---|"]
    for sensor in ("gyro", "accelerometer"):
        for ax, by_key in tm[sensor].items():
            for key, e in by_key.items():
                shown = f"{e['value']:.4g}" if "value" in e else e["status"]
                out.append(f"| {sensor} | {ax} | {shown} {key.split('_', 1)[1]} | {e['sigma']:.2g} | "
                           f"{e['threshold']:.2g} |")
    return out


def _sigma_note(al: dict, seeds: int) -> list:
    """A note where the twin's alignment errors are too large for the sigma the alignment states: under that sigma
    ``seeds * (rms / sigma)^2`` is chi-square with ``seeds`` degrees of freedom; flagged below a 1 % chance."""
    from scipy.stats import chi2

    keys = ("north_arcsec", "east_arcsec", "down_deg")
    bad = [k for k in keys if al["twin_sigma_mean"][k] > 0.0
           and chi2.sf(seeds * (al["twin_error_rms"][k] / al["twin_sigma_mean"][k]) ** 2, seeds) < 0.01]
    if not bad:
        return []
    return ["", (f"The twin's actual alignment errors ({', '.join(bad)}) are too large for the sigma the alignment "
                 "states (chance below 1 % under it): that sigma is too small for this unit's noise (a rate random "
                 "walk, say, which the block-means standard error of the coarse alignment does not cover). The log's "
                 "stated sigma is then too small as well.")]


def _twin_report(metrics: dict) -> list:
    tw = metrics.get("twin")
    if not tw:
        return []
    al = tw["alignment"]
    out = ["", "## The twin beside the log", "",
           (f"The twin (the `sensors:` above, the observable biases put back in body axes) simulated {tw['seeds']} "
            f"times at the {tw['simulated_at']}, then the log's mission on each: Allan deviation, PSD, "
            f"{metrics['alignment']['method']} alignment, free navigation from it (start height held). Figures: "
            "`twin-allan.png`, `twin-psd.png`, `twin-alignment.png`, `twin-nav.png`."), "",
           "Alignment (the twin's truth is the log's aligned attitude):", "",
           "| | north (arcsec) | east (arcsec) | heading (deg) |", "|---|---|---|---|",
           "| log's stated 1-sigma | " + " | ".join(f"{al['log']['sigma'][k]:.3g}" for k in
                                                   ("north_arcsec", "east_arcsec", "down_deg")) + " |",
           "| twin's stated 1-sigma (mean) | " + " | ".join(f"{al['twin_sigma_mean'][k]:.3g}" for k in
                                                           ("north_arcsec", "east_arcsec", "down_deg")) + " |",
           "| twin's actual error (RMS over seeds) | " + " | ".join(f"{al['twin_error_rms'][k]:.3g}" for k in
                                                                   ("north_arcsec", "east_arcsec", "down_deg")) + " |",
           *_sigma_note(al, tw["seeds"]),
           "", "Free navigation at the end of the log (twin: mean and the prediction half-width):", "",
           "| quantity | log | twin |", "|---|---|---|"]
    for label, e in tw["navigation_at_end"].items():
        unit = next(k for k in e if k.startswith("log_"))[4:]
        out.append(f"| {label} ({unit}) | {e['log_' + unit]:.4g} | {e['twin_mean_' + unit]:.4g} +- "
                   f"{e['twin_halfwidth_' + unit]:.3g} |")
    out += ["", "## Where the log leaves its twin", "", tw["summary"] + ".", ""]
    out += [f"- {f['statement']}" for f in tw["findings"]]
    out += ["", (f"Tests (false alarms {100 * tw['alpha']:.3g} % per log and kind, Bonferroni): Allan variance ratio "
                 "against F(edf, seeds x edf) at each tau with >= 10 clusters; a line of the log that fewer than half "
                 "the twin's seeds show; navigation outside the twin's prediction interval "
                 "(mean +- t s sqrt(1 + 1/seeds)) from a time to the end.")]
    return out


def _write(folder: Path, metrics: dict, detail: dict) -> list:
    from sins_sim.plots.allan import plot_allan
    from sins_sim.plots.twin import plot_psd_lines

    name = Path(metrics["log"]).name
    analyses = detail["analyses"]
    (folder / "metrics.json").write_text(json.dumps(metrics, indent=2, allow_nan=False) + "\n")
    panels = {f"{'gyro' if s == 'gyro' else 'accel'} {ax}": a for s, by_ax in analyses.items()
              for ax, a in by_ax.items()}
    plot_allan(panels, folder / "allan.png", title=f"Allan deviation of {name}", ncols=3)
    plot_psd_lines(detail["log_run"].lines, folder / "psd.png", title=f"PSD and spectral lines of {name}")
    written = ["metrics.json", "allan.png", "psd.png", "imu-sensors.yaml", "report.md"]
    if "twin" in detail:
        from sins_sim.results.identify import draw_twin_figures

        written += draw_twin_figures(detail, metrics, folder)
    (folder / "imu-sensors.yaml").write_text(sensors_yaml(metrics))
    (folder / "report.md").write_text(_report(metrics) + "\n".join(_lines_report(metrics) + _steps_report(metrics) + _temperature_report(metrics)
                                                                   + _twin_report(metrics)
                                                                   + _verdict_report(metrics)) + "\n")
    return written


#: The columns of a rate table's segments file (CSV): window, body axis (x, y or z), table rate.
SEGMENT_COLUMNS = ("start_s", "end_s", "axis", "rate_deg_s")


def _windows_table(p: Path, flag: str, columns: tuple, more: str = ""):
    """A windows CSV (comments ``#``, header row) as a DataFrame with stripped column names; one line naming
    ``flag``, the file and the first missing column when it cannot be read or lacks one of ``columns``."""
    import pandas as pd

    try:
        df = pd.read_csv(p, comment="#", skipinitialspace=True)
    except Exception as exc:  # noqa: BLE001 - any reader failure is the file's fault: one line
        raise ConfigError(f"{flag}: {p}: cannot read: {' '.join(str(exc).split())}") from None
    df.columns = [str(c).strip() for c in df.columns]
    missing = [c for c in columns if c not in df.columns]
    if missing:
        raise ConfigError(f"{flag}: {p}: column {missing[0]}: missing (needs {', '.join(columns)}{more})")
    return df


def read_segments(path) -> list:
    """The windows of constant table rate from a CSV with the columns :data:`SEGMENT_COLUMNS`, as
    ``(start_s, end_s, axis 0..2, rate_rad_s)``.

    Raises
    ------
    ConfigError
        One line naming the file, the row and the column.
    """
    p = Path(path)
    df = _windows_table(p, "--rate-table", SEGMENT_COLUMNS)
    out = []
    for i, row in enumerate(df.itertuples(index=False), start=2):
        axis = str(row.axis).strip().lower()
        if axis not in ("x", "y", "z"):
            raise ConfigError(f"--rate-table: {p}: line {i}: axis must be x, y or z, got {row.axis!r}")
        try:
            t0, t1, w = float(row.start_s), float(row.end_s), float(row.rate_deg_s)
        except ValueError:
            raise ConfigError(f"--rate-table: {p}: line {i}: start_s, end_s and rate_deg_s must be numbers") from None
        if not (math.isfinite(t0) and math.isfinite(t1) and t1 > t0 and math.isfinite(w) and w != 0.0):
            raise ConfigError(f"--rate-table: {p}: line {i}: needs end_s > start_s and a finite non-zero rate_deg_s")
        out.append((t0, t1, "xyz".index(axis), math.radians(w)))
    return out


def identify_rate_table(log, segments, out_dir=None, *, force: bool = False, manifest=None):
    """Gyro scale factors and misalignments of a unit from its rate-table log (reversal pairs; module docstring).

    Parameters
    ----------
    log : path
        The increments table.
    segments : path or sequence
        The windows of constant table rate: a CSV (:func:`read_segments`) or ``(start_s, end_s, axis, rate_rad_s)``.
    out_dir : path, optional
        Folder for ``metrics.json`` and ``report.md``; None: write nothing.
    force : bool
        Replace an earlier result at ``out_dir``.
    manifest : Manifest, optional
        The command's manifest.

    Returns
    -------
    IdentifyResult
        ``motion_terms``: ``scale_factor_ppm`` and ``misalignment_arcsec`` per entry, each a value with its sigma or
        ``not excited``.

    Raises
    ------
    ConfigError
        One line naming the flag or the file.
    """
    from sins_sim.jobs.import_log import read_log_table
    from sins_sim.navigation.rate_table import fit_rate_table
    from sins_sim.results.identify import IdentifyResult

    t, dth, _, _ = read_log_table(log)
    dt = _interval(t)
    segs = read_segments(segments) if isinstance(segments, (str, Path)) else list(segments)
    try:
        fit = fit_rate_table(t, dth, segs)
    except ValueError as exc:
        raise ConfigError(f"--rate-table: {exc}") from None
    metrics = _json_ready({
        "log": str(log), "duration_s": float(t.size * dt), "rate_hz": 1.0 / dt, "motion_terms": fit.to_dict(),
        "methods": {"motion_terms": "reversal pairs: E[:, a] = (m+ - m-) / (2 W) - e_a from the mean rates of a "
                                    "window at +W and one at -W about body axis a; sigma: the windows' means "
                                    "(std / sqrt(n)) and the Earth's rate across the axis over part of a turn"}})
    files = {}
    if out_dir is not None:
        from sins_sim.jobs.manifest import Manifest, result_dir

        if manifest is None:
            manifest = Manifest("identify", settings={"rate_table": [list(s) for s in segs]})
        manifest.add_input("log", log)
        with result_dir(out_dir, manifest, inputs=(log,), force=force) as tmp:
            (Path(tmp) / "metrics.json").write_text(json.dumps(metrics, indent=2, allow_nan=False) + "\n")
            (Path(tmp) / "report.md").write_text(_rate_table_report(metrics))
        files = {name: Path(out_dir) / name for name in ("metrics.json", "report.md")}
    return IdentifyResult(metrics, files=files)


def _rate_table_report(metrics: dict) -> str:
    mt = metrics["motion_terms"]
    out = ["# Gyro scale factors and misalignments from a rate table", "",
           (f"Log `{metrics['log']}`: {metrics['duration_s']:.0f} s at {metrics['rate_hz']:.6g} Hz. Model "
            "w_meas = b + (I + E) w (Groves 2013, sec. 4.4.6): scale factors on the diagonal of E, misalignment "
            "M_ij (sensor i towards body axis j) off it; each column from a pair of windows at +W and -W."), "",
           "Pairs: " + ", ".join(f"{p['axis']} at +-{p['rate_deg_s']:.4g} deg/s ({p['seconds'][0]:.4g} s, "
                                 f"{p['seconds'][1]:.4g} s)" for p in mt["pairs"]) + ".", "",
           "| term | value | 1-sigma |", "|---|---|---|"]
    for group, unit in (("scale_factor_ppm", "ppm"), ("misalignment_arcsec", "arcsec")):
        for key, e in mt[group].items():
            name = f"S_{key}" if group == "scale_factor_ppm" else f"M_{key}"
            out.append(f"| {name} ({unit}) | {e['value']:.4g} | {e['sigma']:.2g} |" if "value" in e else
                       f"| {name} ({unit}) | {e['status']} | |")
    return "\n".join(out) + "\n"


#: The columns of a multi-position segments file (CSV): the still window; ``up`` (optional: +x, -x, ... the body
#: axis the fixture puts up) is checked against the log's force.
POSITION_COLUMNS = ("start_s", "end_s")


def read_positions(path) -> list:
    """The still windows of a multi-position log from a CSV with the columns :data:`POSITION_COLUMNS` (and
    optionally ``up``), as ``[(start_s, end_s, up or None)]``.

    Raises
    ------
    ConfigError
        One line naming the file, the row and the column.
    """
    p = Path(path)
    df = _windows_table(p, "--positions", POSITION_COLUMNS, ", optionally up")
    out = []
    for i, row in enumerate(df.itertuples(index=False), start=2):
        try:
            t0, t1 = float(row.start_s), float(row.end_s)
        except ValueError:
            raise ConfigError(f"--positions: {p}: line {i}: start_s and end_s must be numbers") from None
        if not (math.isfinite(t0) and math.isfinite(t1) and t1 > t0):
            raise ConfigError(f"--positions: {p}: line {i}: needs finite start_s < end_s")
        up = None
        if "up" in df.columns and isinstance(row.up, str) and row.up.strip():
            up = row.up.strip().lower()
            if up not in ("+x", "-x", "+y", "-y", "+z", "-z"):
                raise ConfigError(f"--positions: {p}: line {i}: up must be one of +x, -x, +y, -y, +z, -z, got "
                                  f"{row.up!r}")
        out.append((t0, t1, up))
    return out


def identify_positions(log, positions="auto", out_dir=None, *, lat_deg=None, lon_deg=None, height_m=None,
                       force: bool = False, manifest=None):
    """Accelerometer biases, scale factors and misalignments and the gyros' biases and g-sensitivity from a
    multi-position (tumble) log (:mod:`sins_sim.navigation.multiposition`).

    Parameters
    ----------
    log : path
        The increments table.
    positions : "auto", path or sequence
        The still windows: found from the log (``auto``: :func:`~sins_sim.navigation.multiposition.find_positions`),
        a CSV (:func:`read_positions`) or ``(start_s, end_s)`` pairs.
    out_dir : path, optional
        Folder for ``metrics.json``, ``imu-sensors.yaml`` and ``report.md``; None: write nothing.
    lat_deg, lon_deg, height_m : float, optional
        The site where the log has none.
    force : bool
        Replace an earlier result at ``out_dir``.
    manifest : Manifest, optional

    Returns
    -------
    IdentifyResult
        ``positions_fit``: :meth:`~sins_sim.navigation.multiposition.MultiPositionFit.to_dict`.

    Raises
    ------
    ConfigError
        One line naming the flag or the file.
    """
    from sins_sim.jobs.import_log import read_log_table
    from sins_sim.navigation.multiposition import find_positions, fit_multiposition
    from sins_sim.results.identify import IdentifyResult

    t, dth, dv, meta = read_log_table(log)
    site = _site(meta, lat_deg, lon_deg, height_m)
    _interval(t)
    if isinstance(positions, str) and positions == "auto":
        windows, given = find_positions(t, dth, dv), None
        source = "found from the log (one-second blocks between changes of force or rate)"
    else:
        rows = read_positions(positions) if isinstance(positions, (str, Path)) else [
            (float(a), float(b), None) for a, b in positions]
        windows, given = [(a, b) for a, b, _ in rows], [u for _, _, u in rows]
        source = f"given ({positions})" if isinstance(positions, (str, Path)) else "given"
    try:
        fit = fit_multiposition(t, dth, dv, windows, site["lat_rad"], site["height_m"])
    except ValueError as exc:
        raise ConfigError(f"--positions: {exc}") from None
    if given is not None:
        for (a, b), want, p in zip(windows, given, fit.positions):
            if want is not None and want != p.label:
                raise ConfigError(f"--positions: the window {a:g} to {b:g} s has {p.label} up in the log, the file "
                                  f"says {want}")
    metrics = _json_ready({
        "log": str(log), "duration_s": float(t.size * (t[1] - t[0])), "rate_hz": float(1.0 / (t[1] - t[0])),
        "site": {"lat_deg": math.degrees(site["lat_rad"]), "height_m": site["height_m"]},
        "positions_source": source, "positions_fit": fit.to_dict(),
        "methods": {"positions_fit": "weighted least squares per accelerometer row over the still positions "
                                     "(m_f - g u = b + E g u), the gyros from each axis's up/down pair less the "
                                     "Earth's vertical rate; sigmas from the standard error of each position's "
                                     "one-second block means"},
        "notes": ["the misalignments are relative to the fixture's faces: its own tilt and face errors alias into them",
                  "the scale factors are read against normal gravity: a gravity anomaly dg enters them as dg / g "
                  "(10 ug: 10 ppm), outside the sigma"]})
    settings = {"positions": positions if isinstance(positions, str) else [list(w) for w in windows]}
    files = _write_fit(out_dir, metrics, {"imu-sensors.yaml": positions_yaml(metrics),
                                          "report.md": _positions_report(metrics)},
                       manifest, settings, {"log": log}, force)
    return IdentifyResult(metrics, files=files)


def _write_fit(out_dir, metrics: dict, texts: dict, manifest, settings: dict, inputs: dict, force: bool,
               figures: dict | None = None) -> dict:
    """Write ``metrics.json``, ``texts`` (name -> text) and ``figures`` (name -> a function drawing it to a path)
    into ``out_dir`` as one result (its manifest naming ``inputs``, label -> path); the files written,
    name -> path (none without ``out_dir``)."""
    if out_dir is None:
        return {}
    from sins_sim.jobs.manifest import Manifest, result_dir

    if manifest is None:
        manifest = Manifest("identify", settings=settings)
    for label, path in inputs.items():
        manifest.add_input(label, path)
    with result_dir(out_dir, manifest, inputs=tuple(inputs.values()), force=force) as tmp:
        (Path(tmp) / "metrics.json").write_text(json.dumps(metrics, indent=2, allow_nan=False) + "\n")
        for name, text in texts.items():
            (Path(tmp) / name).write_text(text)
        for name, draw in (figures or {}).items():
            draw(Path(tmp) / name)
    return {name: Path(out_dir) / name for name in ("metrics.json", *texts, *(figures or {}))}


def _entries_line(key: str, entries: list, unit: str, what: str) -> str:
    """``key: [...]   # what; 1-sigma [...]`` or a comment saying which entry is not determined."""
    if any("value" not in e for e in entries):
        why = next(e["status"] for e in entries if "value" not in e)
        return f"    # {key}: left out ({why}); the twin's default 0 applies"
    vals = ", ".join(f"{e['value']:.6g}" for e in entries)
    sigs = ", ".join(f"{e['sigma']:.3g}" for e in entries)
    return f"    {key}: [{vals}]   # {what}; 1-sigma [{sigs}] {unit}"


def positions_yaml(metrics: dict) -> str:
    """The ``sensors:`` keys a multi-position log gives (accelerometer bias, scale factors, misalignments; gyro bias),
    each with its source and sigma; the g-sensitivity as comments (the sensor model has no such key)."""
    pf = metrics["positions_fit"]
    acc, gy = pf["accelerometer"], pf["gyro"]
    what = f"multi-position fit over {len(pf['positions'])} positions"
    mis_order = ("xy", "xz", "yx", "yz", "zx", "zy")
    lines = [f"# identified by sins-sim identify --positions from {metrics['log']}", "sensors:", "  gyro:",
             _entries_line("bias_deg_h", [gy["bias_deg_h"][a] for a in "xyz"], "deg/h", what + " (up/down pairs)"),
             "  accelerometer:",
             _entries_line("bias_ug", [acc["bias_ug"][a] for a in "xyz"], "ug", what),
             _entries_line("scale_factor_ppm", [acc["scale_factor_ppm"][a] for a in "xyz"], "ppm", what),
             _entries_line("misalignment_arcsec", [acc["misalignment_arcsec"][k] for k in mis_order], "arcsec",
                           what + "; order xy, xz, yx, yz, zx, zy, relative to the fixture's faces"),
             "# gyro g-sensitivity (deg/h/g; not a key of the twin's sensors: its model has no g-sensitivity):"]
    for k, e in gy["g_sensitivity_deg_h_per_g"].items():
        lines.append(f"#   G_{k}: {e['value']:.4g} +- {e['sigma']:.2g} (1-sigma)" if "value" in e else
                     f"#   G_{k}: {e['status']}")
    return "\n".join(lines) + "\n"


def _positions_report(metrics: dict) -> str:
    pf = metrics["positions_fit"]
    out = ["# Accelerometer terms and gyro g-sensitivity from a multi-position log", "",
           (f"Log `{metrics['log']}`: {metrics['duration_s']:.0f} s at {metrics['rate_hz']:.6g} Hz; site "
            f"{metrics['site']['lat_deg']:.6f} deg N. Models (Groves 2013, sec. 4.4.6): m_f = b_a + (I + E_a) f, "
            "m_w = b_g + w + G f; f = g u in a position with u up. Positions "
            f"({metrics['positions_source']}): " + ", ".join(
                f"{p['up']} {p['start_s']:.4g} to {p['end_s']:.4g} s" for p in pf["positions"]) + "."), "",
           "| term | value | 1-sigma |", "|---|---|---|"]
    groups = [("accelerometer", "bias_ug", "b_a", "ug"), ("accelerometer", "scale_factor_ppm", "S", "ppm"),
              ("accelerometer", "misalignment_arcsec", "M", "arcsec"), ("gyro", "bias_deg_h", "b_g", "deg/h"),
              ("gyro", "g_sensitivity_deg_h_per_g", "G", "deg/h/g")]
    for sensor, key, sym, unit in groups:
        for k, e in pf[sensor][key].items():
            out.append(f"| {sym}_{k} ({unit}) | {e['value']:.5g} | {e['sigma']:.2g} |" if "value" in e else
                       f"| {sym}_{k} ({unit}) | {e['status']} | |")
    out += [""] + [f"- {n}" for n in metrics["notes"]]
    return "\n".join(out) + "\n"


def identify_truth(log, truth_file, out_dir=None, *, twin_seeds: int = 0, force: bool = False, manifest=None):
    """Biases, scale factors and misalignments of a moving log against its known trajectory
    (:mod:`sins_sim.navigation.truth_fit`): the errors are the log's increments minus the truth's ideal increments
    (:func:`sins_sim.simulation.external.ideal_increments`, on the truth's time axis as ``sins-sim navigate --truth``
    reads it), fitted by least squares where the motion excites them, "not observable" where it does not.

    Parameters
    ----------
    log : path
        The increments table.
    truth_file : path
        A trajectory file (:func:`sins_sim.io.trajectory.read_trajectory`) covering the log's span.
    out_dir : path, optional
        Folder for ``metrics.json``, ``imu-sensors.yaml`` and ``report.md`` (and ``twin-nav.png`` with the twin);
        None: write nothing.
    twin_seeds : int
        0, or 2 to ``MAX_TWIN_SEEDS``: the twin (:func:`truth_twin_sensors`) simulated on the truth's trajectory
        that many times and navigated beside the log; its results under ``twin``.
    force : bool
        Replace an earlier result at ``out_dir``.
    manifest : Manifest, optional

    Returns
    -------
    IdentifyResult
        ``truth_fit``: :meth:`~sins_sim.navigation.truth_fit.TruthFit.to_dict`.

    Raises
    ------
    ConfigError
        One line naming the flag or the file.
    """
    from sins_sim.io.trajectory import read_trajectory
    from sins_sim.jobs.import_log import read_log_table
    from sins_sim.models.motion import SampledTrajectory
    from sins_sim.navigation.truth_fit import fit_against_truth
    from sins_sim.results.identify import IdentifyResult
    from sins_sim.simulation.external import ideal_increments

    if isinstance(twin_seeds, bool) or not isinstance(twin_seeds, int) or not (twin_seeds == 0 or
                                                                             2 <= twin_seeds <= MAX_TWIN_SEEDS):
        raise ConfigError(f"--twin-seeds: must be 0 (no twin) or an integer from 2 to {MAX_TWIN_SEEDS}, got "
                          f"{twin_seeds!r}")
    t, dth, dv, meta = read_log_table(log)
    dt = _interval(t)
    try:
        truth = SampledTrajectory.from_data(read_trajectory(truth_file))
    except ValueError as exc:
        raise ConfigError(f"--truth: {' '.join(str(exc).split())}") from None
    t_truth = t - truth.time_offset_s
    span = float(truth.duration_s)
    if t_truth[0] - dt < -1e-9 or t_truth[-1] > span + 1e-9:
        raise ConfigError(f"--truth: {truth_file} must cover the log's {t[0] - dt:g} to {t[-1]:g} s (its own times "
                          f"run from {truth.time_offset_s:g} to {truth.time_offset_s + span:g} s)")
    try:
        ideal_th, ideal_v = ideal_increments(truth, t_truth)
        fit = fit_against_truth(dt, {"gyro": dth, "accelerometer": dv}, {"gyro": ideal_th, "accelerometer": ideal_v})
    except ValueError as exc:
        raise ConfigError(f"--truth: {' '.join(str(exc).split())}") from None
    metrics = _json_ready({
        "log": str(log), "truth": str(truth_file), "duration_s": float(t.size * dt), "rate_hz": 1.0 / dt,
        "truth_fit": fit.to_dict(),
        "bias_steps": _bias_steps(*_truth_residuals(fit, dt, dth, dv, ideal_th, ideal_v), 1.0 / dt),
        "methods": {"truth_fit": "x_meas - x_ideal = b dt + E x_ideal per triad row on one-second block sums; the "
                                 "residual's Allan deviation fitted with the IEEE Std 952 terms (the twin's ARW/VRW, "
                                 "bias instability, RRW); the terms by generalised least squares with a white noise "
                                 "and a rate random walk whose levels restricted maximum likelihood fits to the block "
                                 "sums, their sigmas at the walk's one-sided 84 % likelihood bound; a column whose "
                                 "part apart from the others is below 1e-6 of its size is not observable"},
        "notes": ["the sigmas hold the residual's noise as the likelihood of the block sums reads it, a white noise "
                  "and a rate random walk (the bias instability taken as one), the walk at its one-sided 84 % bound: "
                  "where the log shows no walk, the one it cannot exclude still widens the biases' sigmas; "
                  "ols_sigma gives the ordinary least-squares sigmas (white noise over a block assumed) beside them",
                  "the truth's own errors (its attitude, its timing against the log) are in the fitted terms"]})
    detail = None
    if twin_seeds:
        metrics["twin"], metrics["explain"], metrics["verdict"], detail = _truth_twin(
            metrics, t_truth, dth, dv, ideal_th, ideal_v, truth, twin_seeds, pulse_weights(meta, dth, dv), fit)
        metrics = _json_ready(metrics)
    figures = {} if detail is None else _truth_figures(detail, metrics)
    files = _write_fit(out_dir, metrics, {"imu-sensors.yaml": truth_yaml(metrics), "report.md": _truth_report(metrics)},
                       manifest, {"truth": str(truth_file), "twin_seeds": twin_seeds}, {"log": log, "truth": truth_file},
                       force, figures)
    return IdentifyResult(metrics, detail=detail, files=files)


def _truth_figures(detail: dict, metrics: dict) -> dict:
    """The figures of a moving log beside its twin: name -> a function drawing it to a path
    (:class:`~sins_sim.results.identify.IdentifyResult`'s own)."""
    from sins_sim.results.identify import IdentifyResult, draw_figure

    kinds = [k for k in IdentifyResult(metrics, detail=detail).figures if k != "psd"]
    return {f"{kind}.png": (lambda path, kind=kind: draw_figure(detail, metrics, kind, path)) for kind in kinds}


def _truth_residuals(fit, dt: float, dth, dv, ideal_th, ideal_v) -> tuple:
    """The log's rate and specific force less the truth's and the fitted terms (``b + E x_ideal / dt``, 0 where not
    observable): what the twin's noise is fitted to, and where a bias step shows (the twin's noise is stationary)."""
    out = []
    for s, meas, ideal in (("gyro", dth, ideal_th), ("accelerometer", dv, ideal_v)):
        e = np.nan_to_num(fit.e[s])
        b = np.nan_to_num(fit.bias[s])
        out.append((meas - ideal - ideal @ e.T) / dt - b)
    return tuple(out)


def truth_twin_sensors(truth_fit: dict) -> dict:
    """The twin's ``sensors:`` mapping (:func:`sins_sim.models.sensor_errors.sensor_params_from_dict`) from a fit
    against the truth (:meth:`~sins_sim.navigation.truth_fit.TruthFit.to_dict`): the fitted biases, scale factors
    and misalignments (0 where not observable), and the noise of the fit's residual: its Allan fit's white noise
    (ARW / VRW) and random walk (RRW) whether or not their slope regions show (a term too weak to show still moves
    the log, and the fit holds it), the bias instability where its flat region shows (the twin's Gauss-Markov sum
    needs its tau range), as :func:`twin_sensors` does at rest."""
    def val(e):
        return float(e["value"]) if "value" in e else 0.0

    mis_order = ("xy", "xz", "yx", "yz", "zx", "zy")
    out = {}
    for s, bkey, keys in (("gyro", "bias_deg_h", ("arw_deg_rt_h", "bias_instability_deg_h", "rrw_deg_h_rt_h")),
                          ("accelerometer", "bias_ug", ("vrw_ug_rt_hz", "bias_instability_ug", "rrw_ug_rt_h"))):
        sec = truth_fit[s]
        out[s] = {bkey: [val(sec[bkey][a]) for a in "xyz"],
                  "scale_factor_ppm": [val(sec["scale_factor_ppm"][a]) for a in "xyz"],
                  "misalignment_arcsec": [val(sec["misalignment_arcsec"][m]) for m in mis_order]}
        for key in keys:
            entries = [sec["noise"][a][key] for a in "xyz"]
            if key.startswith("bias_instability"):
                ranges = [e["tau_range_s"] for e in entries if e["determined"]]
                if not ranges:
                    continue
                out[s][key] = [e["value"] if e["determined"] else 0.0 for e in entries]
                lo = min(r[0] for r in ranges)
                out[s]["bias_instability_tau_s"] = [lo, max(max(r[1] for r in ranges), lo)]
            else:
                out[s][key] = [e["value"] for e in entries]
    return out


def _truth_twin(metrics: dict, t_truth, dth, dv, ideal_th, ideal_v, truth, seeds: int, pulses, fit) -> tuple:
    """The twin on the truth's trajectory beside the log (:mod:`sins_sim.simulation.twin_moving`): both navigated
    from the truth's state, their errors against it, the Allan deviation and lines of their residuals against the
    truth and the fitted terms, the log's against the twin's envelope (:func:`sins_sim.identification.twin_gap.localise`),
    and the motion-excited catalogue tried on the gap (:func:`sins_sim.identification.twin_explain_moving.explain_moving`)."""
    from sins_sim.identification.twin_explain_moving import explain_moving
    from sins_sim.identification.twin_gap import NAV_QUANTITIES_TRUTH, localise
    from sins_sim.models.sensor_errors import sensor_params_from_dict
    from sins_sim.navigation.truth_fit import fit_against_truth, residual_noise_entries
    from sins_sim.simulation.twin_moving import truth_run, twin_runs_on

    doc = truth_twin_sensors(metrics["truth_fit"])
    dt = float(t_truth[1] - t_truth[0])
    ideal = {"gyro": np.asarray(ideal_th, dtype=np.float64), "accelerometer": np.asarray(ideal_v, dtype=np.float64)}
    def fitted(f):
        """The deterministic increments x_true + b dt + E x_true of a fit (0 where a term is not observable)."""
        return np.hstack([ideal[s] + np.nan_to_num(f.bias[s]) * dt + ideal[s] @ np.nan_to_num(f.e[s]).T
                          for s in ("gyro", "accelerometer")])

    def own_fit(th, v):
        """A twin seed's residual is made as the log's: against its own fit to the truth."""
        return fitted(fit_against_truth(dt, {"gyro": th, "accelerometer": v}, ideal))

    expected = fitted(fit)
    resid6 = (np.hstack([np.asarray(dth, dtype=np.float64), np.asarray(dv, dtype=np.float64)]) - expected) / dt
    fa = LINE_FALSE_ALARM / 6.0
    doc = _truth_white_noise(doc, resid6, dt, pulses, metrics["truth_fit"])
    try:
        params = sensor_params_from_dict(doc, "the twin fitted against the truth")
        log_run = truth_run(t_truth, dth, dv, truth, expected, fa)

        def run_twin(added):
            # with a candidate, the twin's white noise refitted on the residual less its fitted part (a strong
            # effect otherwise inflates the noise the twin was fitted with)
            # (all its noise terms: the Allan fit's bias instability and random walk too, which a strong effect
            # such as a clock off its rate inflates as much as the white noise)
            if added is None:
                twin = params
            else:
                rest = resid6 - added
                tf = dict(metrics["truth_fit"])
                for k, s in enumerate(("gyro", "accelerometer")):
                    tf[s] = dict(tf[s], noise=residual_noise_entries(rest[:, 3 * k:3 * k + 3] * dt, dt, s))
                twin = sensor_params_from_dict(
                    _truth_white_noise(truth_twin_sensors(tf), rest, dt, pulses, tf), "the twin, refitted")
            return twin_runs_on(twin, t_truth, ideal_th, ideal_v, truth, range(1, seeds + 1), pulses=pulses,
                                added=added, expected=own_fit, false_alarm=fa)

        runs = run_twin(None)
        gap = localise(log_run, runs, quantities=NAV_QUANTITIES_TRUTH)
        ex = explain_moving(log_run, resid6, t_truth, ideal_th, ideal_v, run_twin, seeds,
                            truth_fit=metrics["truth_fit"], base_runs=runs)
    except ValueError as exc:
        raise ConfigError(f"--twin-seeds: the twin's run on the truth failed: {' '.join(str(exc).split())}") from None
    m = min([log_run.nav_t_s.size] + [r.nav_t_s.size for r in runs])
    nav_end = {}
    for key, col, label, scale, unit in NAV_QUANTITIES_TRUTH:
        b = gap["nav_bands"][(key, col)]
        nav_end[label] = {f"log_{unit}": float(log_run.nav[key][m - 1, col] * scale),
                          f"twin_mean_{unit}": float(b["mean"][-1] * scale),
                          f"twin_halfwidth_{unit}": float((b["hi"][-1] - b["mean"][-1]) * scale)}
    # Findings of the residual alone that no moving candidate addresses (the twin's noise is stationary): the bias
    # steps its scan finds, and where its white-noise level changes over time (the first differences' variance per
    # block, as at rest; a smooth departure such as a clock's drift hardly moves first differences). A log whose
    # only departure is one of them is 'unknown' in its place, not 'none' (and an 'unknown' band lists a noise-level
    # change beside the findings no candidate shrinks). Beside findings a candidate explains they
    # stay findings but do not overturn the verdict: both are read on the residual before the candidate is taken
    # out, where a smooth departure (a clock's drift) shows as steps and shifts the blocks' noise levels.
    from sins_sim.identification.twin_explain import finding_place, noise_level_findings

    steps = _step_findings(metrics["bias_steps"])
    level = noise_level_findings(resid6, 1.0 / dt)
    findings = ex.pop("findings") + steps + level
    verdict = ex.pop("verdict")
    if (steps or level) and verdict["status"] == "none":
        verdict.update(status="unknown", effect="unknown", band=[finding_place(f) for f in steps + level],
                       remainder=[finding_place(f) for f in steps + level])
    elif level and verdict["status"] == "unknown":      # no candidate removes a noise-level change either
        verdict["band"] = list(verdict.get("band") or []) + [finding_place(f) for f in level]
    out = {"seeds": seeds, "sensors": doc,
           "simulated_at": ("the truth's exact increments with the fitted errors and the noise terms of the fit's "
                            "residual (its Allan fit's bias instability and random walk; the white noise read from "
                            "the residual's samples or blocks, whichever states it more precisely)"
                            + (", then the readout's pulses" if pulses is not None else "")),
           "navigated": "free from the truth's state one interval before the first increment, height aided by "
                        "the truth's",
           "residual": "the increments less x_true + b dt + E x_true (the fitted terms), as rate and specific force",
           "duration_s": float(log_run.nav_t_s[m - 1]), "navigation_at_end": nav_end, "alpha": gap["alpha"],
           "findings": [{k: v for k, v in f.items() if k != "excess"} for f in findings],
           "summary": (f"the log stays within its twin's envelope ({seeds} seeds)"
                       if not findings else f"{len(findings)} place(s) where the log leaves its twin's envelope "
                                            f"({seeds} seeds)")}
    return out, ex, verdict, {"log_run": log_run, "twin": {"runs": runs, "gap": gap}}


def _truth_white_noise(doc: dict, resid6, dt: float, pulses, truth_fit: dict) -> dict:
    """The twin's ``sensors:`` (:func:`truth_twin_sensors`) with its white noise read off the residual ``resid6``
    (N, 6; rate and specific force against the fitted terms), per channel from the samples or from the fit's blocks,
    whichever states it more precisely.

    A white noise of density ``N`` has a sample variance ``N^2 / dt`` and a variance ``N^2 T`` of a block sum over
    ``T`` (IEEE Std 952-1997, Annex C). A pulse readout (weight ``w``, the residue carried) adds ``w (r_{k-1} -
    r_k)`` to each increment and, the terms telescoping, the same to a block sum: ``w^2 / 6`` for a residue uniform
    and independent, taken out of both (the twin adds its own readout again). The samples give ``N^2 = (var(diff r) / 2 -
    w^2 / (4 dt^2)) dt`` (first differences, blind to a smooth departure) with a relative sd ``sqrt(3 / n)`` of the
    same ratio; the ``K`` blocks
    ``N^2 = (s^2 - w^2 / 6) / T`` with ``sqrt(2 / (K - p)) s^2 / (s^2 - w^2 / 6)`` (``s^2`` the block sums' mean
    square with the fit's ``p`` terms of the row taken out, as :func:`truth_twin_sensors`). On a float log the
    samples win (0.8 % on ``N^2`` for 30 000 samples against 8 % for 300 blocks, which left clean logs outside the
    residual's short-tau Allan band); where the readout's quantum dominates each sample (a coarse pulse weight: its
    error there fluctuates with the motion by more than the noise is worth) the blocks do."""
    r = np.asarray(resid6, dtype=np.float64)
    n = r.shape[0]
    k, block_s = int(truth_fit["blocks"]), float(truth_fit["block_s"])
    per = max(1, int(round(block_s / dt)))
    q_inc = np.zeros(6)
    if pulses is not None:
        c2 = np.asarray(pulses.axes, dtype=np.float64) ** 2
        q_inc = np.concatenate([c2.T @ (np.asarray(pulses.gyro_rad) ** 2 / 6.0),
                                c2.T @ (np.asarray(pulses.accel_m_s) ** 2 / 6.0)])
    # the samples through their first differences: a smooth departure the fitted terms leave (a clock's drift
    # before its candidate is fitted, a candidate's small misfit after) is nearly gone from them (by (2 pi f dt)^2),
    # where it inflated the sample variance (a clock 34 ppm off left the twin 12 times the log's noise at 0.01 s).
    # White noise: var(diff r) / 2 = N^2 / dt, an MA(1) with rho_1 = -1/2, so the relative sd sqrt(2 (1 + 2 rho_1^2)
    # / n) = sqrt(3 / n); the pulse residue's second difference w (r_{k-2} - 2 r_{k-1} + r_k) has variance w^2 / 2,
    # half of it per sample: 3/2 of its w^2 / 6
    var = 0.5 * np.var(np.diff(r, axis=0), axis=0, ddof=1)
    n2_s = (var - 1.5 * q_inc / dt ** 2) * dt
    rel_s = math.sqrt(3.0 / n) * var * dt / np.maximum(n2_s, 1e-300)
    sums = (r[:k * per] * dt).reshape(k, per, 6).sum(axis=1)
    p = np.array([1 + ("value" in truth_fit[s]["scale_factor_ppm"][a]) + sum(
        "value" in truth_fit[s]["misalignment_arcsec"][a + c] for c in "xyz" if c != a)
        for s in ("gyro", "accelerometer") for a in "xyz"], dtype=np.float64)
    s2 = np.mean(sums ** 2, axis=0) * k / (k - p)
    n2_b = (s2 - q_inc) / block_s
    rel_b = np.sqrt(2.0 / (k - p)) * s2 / np.maximum(n2_b * block_s, 1e-300)
    dens = np.sqrt(np.maximum(np.where((n2_s > 0.0) & (rel_s <= rel_b), n2_s, n2_b), 0.0))
    out = {s: dict(sec) for s, sec in doc.items()}
    out["gyro"]["arw_deg_rt_h"] = (dens[:3] * 60.0 / DEG).tolist()
    out["accelerometer"]["vrw_ug_rt_hz"] = (dens[3:] / MICRO_G).tolist()
    return out


def truth_yaml(metrics: dict) -> str:
    """The ``sensors:`` keys a log on a known trajectory gives, each with its source and sigma."""
    tf = metrics["truth_fit"]
    what = f"fit against the truth {Path(metrics['truth']).name}"
    mis_order = ("xy", "xz", "yx", "yz", "zx", "zy")
    lines = [f"# identified by sins-sim identify --truth from {metrics['log']}", "sensors:"]
    for s, bkey, bunit in (("gyro", "bias_deg_h", "deg/h"), ("accelerometer", "bias_ug", "ug")):
        sec = tf[s]
        lines += [f"  {s}:", _entries_line(bkey, [sec[bkey][a] for a in "xyz"], bunit, what),
                  _entries_line("scale_factor_ppm", [sec["scale_factor_ppm"][a] for a in "xyz"], "ppm", what),
                  _entries_line("misalignment_arcsec", [sec["misalignment_arcsec"][k] for k in mis_order], "arcsec",
                                what + "; order xy, xz, yx, yz, zx, zy")]
    return "\n".join(lines) + "\n"


#: The units of the noise keys, as a report writes them.
_NOISE_UNITS = {"arw_deg_rt_h": "deg/sqrt(h)", "bias_instability_deg_h": "deg/h", "rrw_deg_h_rt_h": "deg/h/sqrt(h)",
                "vrw_ug_rt_hz": "ug/sqrt(Hz)", "bias_instability_ug": "ug", "rrw_ug_rt_h": "ug/sqrt(h)"}


def _truth_report(metrics: dict) -> str:
    tf = metrics["truth_fit"]
    out = ["# Unit fitted against its known trajectory", "",
           (f"Log `{metrics['log']}` ({metrics['duration_s']:.0f} s at {metrics['rate_hz']:.6g} Hz) against the "
            f"truth `{metrics['truth']}`. Model (Groves 2013, sec. 4.4.6): x_meas = x_ideal + b dt + E x_ideal, "
            f"scale factors S on the diagonal of E, misalignments M off it; {tf['blocks']} blocks of "
            f"{tf['block_s']:g} s."), "", "| sensor | term | value | 1-sigma |", "|---|---|---|---|"]
    for s, bkey, sym in (("gyro", "bias_deg_h", "b (deg/h)"), ("accelerometer", "bias_ug", "b (ug)")):
        for group, name in ((bkey, sym), ("scale_factor_ppm", "S (ppm)"), ("misalignment_arcsec", "M (arcsec)")):
            for k, e in tf[s][group].items():
                out.append(f"| {s} | {name} {k} | {e['value']:.5g} | {e['sigma']:.2g} |" if "value" in e else
                           f"| {s} | {name} {k} | {e['status']} | |")
    out += ["", "Noise of the residual (its Allan fit; the twin's terms; * where the term's slope region shows):", "",
            "| sensor | axis | white | bias instability | random walk |", "|---|---|---|---|---|"]
    for s in ("gyro", "accelerometer"):
        for ax, terms in tf[s]["noise"].items():
            cells = [f"{e['value']:.3g} {_NOISE_UNITS[k]}{'*' if e['determined'] else ''}" for k, e in terms.items()]
            out.append(f"| {s} | {ax} | " + " | ".join(cells) + " |")
    out += [""] + [f"- {n}" for n in metrics["notes"]]
    return "\n".join(out + _truth_twin_report(metrics)) + "\n"


def _truth_twin_report(metrics: dict) -> list:
    tw = metrics.get("twin")
    if not tw:
        return []
    out = ["", "## The twin beside the log", "",
           (f"The twin ({tw['simulated_at']}; the terms above, 0 where not observable) simulated {tw['seeds']} "
            f"times on the truth's trajectory; the log and each seed "
            f"navigated {tw['navigated']}, their errors against the truth. The Allan deviation and the PSD are "
            f"those of the residual ({tw['residual']}), the log's against each seed's. Figures: `twin-nav.png`, "
            "`twin-allan.png`, `twin-psd.png`" + (", `twin-explain.png`." if metrics.get("explain", {}).get(
                "candidates") else ".")), "",
           f"Navigation error after {tw['duration_s']:.4g} s (twin: mean and the prediction half-width):", "",
           "| quantity | log | twin |", "|---|---|---|"]
    for label, e in tw["navigation_at_end"].items():
        unit = next(k for k in e if k.startswith("log_"))[4:]
        out.append(f"| {label} ({unit}) | {e['log_' + unit]:.4g} | {e['twin_mean_' + unit]:.4g} +- "
                   f"{e['twin_halfwidth_' + unit]:.3g} |")
    out += ["", tw["summary"] + ".", ""] + [f"- {f['statement']}" for f in tw["findings"]]
    out += ["", (f"Tests (false alarms {100 * tw['alpha']:.3g} % per log for the Allan deviation and for the "
                 f"navigation, {100 * LINE_FALSE_ALARM:.3g} % for the lines; Bonferroni over the points): "
                 "the residual's Allan variance against the mean of the twin's (F), a line of the log's residual "
                 "that half the twin's seeds lack, and the navigation error outside the twin's prediction interval "
                 "(mean +- t s sqrt(1 + 1/seeds)) from a time to the end. The twin's noise is white: a bias drift or "
                 "instability of the log shows as a finding.")]
    if metrics.get("explain"):
        fit = metrics["explain"]["in_the_fit"].get("pulse_weight_error")
        out += _verdict_report(metrics) + ([] if fit is None else ["", f"In the fit: {fit['statement']}."])
    return out


def _log_step_findings(steps: dict) -> list:
    """The log's bias steps as findings with the readings the gap measure needs (``z``, ``threshold``; the
    explain step's, :mod:`sins_sim.identification.twin_explain`)."""
    out = []
    for f in _step_findings(steps):
        e = steps[f["sensor"]][f["axis"]]
        out.append({**f, "z": e["z"], "threshold": e["threshold"]})
    return out


def _explain(metrics: dict, analyses: dict, site: dict, al, t, dth, dv, alignment: str, seeds: int, run_kw: dict,
             log_run, temp, pulses=None) -> tuple:
    """Explain and shrink the twin's findings with the catalogue, and the verdict
    (:func:`sins_sim.identification.twin_explain.explain_twin`); ``(explain, verdict)`` for the metrics. The twin
    with each candidate keeps the plain twin's readout ``pulses``, so that the gap is measured against the same
    kind of twin."""
    from sins_sim.identification.twin_explain import explain_twin, noise_level_findings
    from sins_sim.models.sensor_errors import sensor_params_from_dict

    dt = float(t[1] - t[0])
    doc, _ = twin_sensors(metrics, al.q_nb, analyses)
    params = sensor_params_from_dict(doc, "the identified twin")
    y6 = np.hstack([np.asarray(dth, dtype=np.float64), np.asarray(dv, dtype=np.float64)]) / dt
    tc = None if temp is None else np.asarray(temp, dtype=np.float64)[:y6.shape[0]]
    temperature = metrics["temperature"] if "status" not in metrics["temperature"] else None
    level = noise_level_findings(y6, 1.0 / dt)
    if level:    # where the log's noise level changes over time: a place where it leaves its stationary twin too
        metrics["twin"]["findings"] += level
        metrics["twin"]["summary"] = (f"{len(metrics['twin']['findings'])} place(s) where the log leaves its twin's "
                                      f"envelope ({seeds} seeds)")
    try:
        ex = explain_twin(log_run, y6, t, metrics["twin"]["findings"], _log_step_findings(metrics["bias_steps"]),
                          sensors=params, site=site, q_nb=al.q_nb, method=alignment, seeds=range(1, seeds + 1),
                          run_kw={**run_kw, "pulses": pulses}, temperature_c=tc, temperature=temperature,
                          intervals_s=np.diff(np.asarray(t, dtype=np.float64), prepend=float(t[0]) - dt),
                          step_alpha=STEP_ALPHA / 6.0, bias=metrics["bias"], lat_rad=site["lat_rad"],
                          refit=lambda resid: _refit_sensors(metrics, resid, 1.0 / dt, al.q_nb))
    except ValueError as exc:
        raise ConfigError(f"--twin-seeds: the twin's explain step failed: {exc}") from None
    verdict = ex.pop("verdict")
    return ex, verdict


def _refit_sensors(metrics: dict, resid6, fs: float, q_nb):
    """The twin's ``sensors:`` with its noise terms fitted again on ``resid6`` (the log less a candidate's fitted part,
    (N, 6) rate and specific force), the biases as identified (:func:`twin_sensors`)."""
    from sins_sim.models.sensor_errors import sensor_params_from_dict
    from sins_sim.navigation.allan import allan_axes, screen_noise

    analyses = {s: {ax: screen_noise(a) for ax, a in allan_axes(x - x.mean(axis=0), fs, kind).items()}
                for s, x, kind in (("gyro", resid6[:, :3], "gyro"), ("accelerometer", resid6[:, 3:], "accel"))}
    noise = {s: {ax: {key: _noise_entry(a, name, key, scale) for name, key, scale, _ in _NOISE_KEYS[s]}
                 for ax, a in by_ax.items()} for s, by_ax in analyses.items()}
    doc, _ = twin_sensors({**metrics, "noise": noise}, q_nb, analyses)
    return sensor_params_from_dict(doc, "the identified twin, refitted")


def _num(x, fmt: str) -> str:
    """A number of the metrics as text, ``n/a`` where it is None (not finite before JSON)."""
    return "n/a" if x is None else format(x, fmt)


def _verdict_report(metrics: dict) -> list:
    """The report's explain and verdict sections (as the channel diagnosis's verdict)."""
    v = metrics.get("verdict")
    if not v:
        return []
    ex = metrics["explain"]
    out = ["", "## Explain: candidate effects added to the twin", "",
           (f"Gap measure G = {ex['gap_measure']}; the twin's G_0 = {ex['gap']:.3g}. Each candidate is fitted on the "
            "log, added to the twin, re-simulated over its seeds and localised again; shrink = 1 - G / G_0 (sd: "
            f"bootstrap over the twin's seeds). Held-out: fitted on the {ex['heldout']['fit']} of "
            f"{ex['heldout']['blocks']}, scored on the {ex['heldout']['scored']} (Diebold-Mariano).")]
    if ex["candidates"]:
        out += ["", "| candidate | fitted | shrink | sd | held-out p | findings removed |", "|---|---|---|---|---|---|"]
        for c in ex["candidates"]:
            fitted = "; ".join(f"{ax}: " + ", ".join(f"{k} {val:.4g} +- {c['uncertainty'][ax].get(k, float('nan')):.2g}"
                                                     if k in c["uncertainty"][ax] else f"{k} {val:.4g}"
                                                     for k, val in pv.items()) for ax, pv in c["params"].items())
            out.append(f"| {c['label']} | {fitted} | {_num(c['shrink'], '.2f')} | {_num(c['shrink_sd'], '.2f')} | "
                       f"{_num(c['p_heldout'], '.2g')} | {len(c['removes'])} |")
    out += ["", "Not testable in this log:", ""]
    for k, why in ex["not_testable"].items():
        if k == "implied_at_rest":
            out += ["- implied at rest, were the whole rest bias a scale: " + ", ".join(
                f"{n} {_num(e['value'], '.3g')} +- {_num(e['sigma'], '.2g')}" for n, e in why.items())]
        else:
            out.append(f"- {k}: {why}")
    named = " + ".join(e["effect"] for e in v["effects"]) or v["effect"]
    out += ["", "## Verdict", "", f"**{v['status']}**" + (f": {named}" if v["status"] in
                                                          ("explained", "partly explained") else "")]
    if v["status"] in ("explained", "partly explained"):
        out += ["", f"Explained fraction of the gap: {_num(v['explained_fraction'], '.2f')} +- "
                    f"{_num(v['explained_fraction_sd'], '.2f')} (over the twin's seeds)."]
        out += [f"- {e['label']}: {_num(e['explained_fraction'], '.2f')} of the gap (held-out p = "
                f"{_num(e['p_heldout'], '.2g')})" for e in v["effects"]]
    if v["alternatives"]:
        out += ["", "Alternatives (explain it alike on held-out data): " + ", ".join(v["alternatives"]) + "."]
    if v["remainder"]:
        out += ["", "Remainder (still outside the envelope):"] + [f"- {f['statement']}" for f in v["remainder"]]
    if v["status"] == "unknown":
        out += ["", "No candidate shrinks these findings (the band of the unknown):"] + [
            f"- {f['statement']}" for f in v["band"]]
        if v.get("unconfirmed"):
            out += ["", v["unconfirmed"]["message"] + "."]
    out += ["", f"Criterion: {v['criterion']}."]
    return out
