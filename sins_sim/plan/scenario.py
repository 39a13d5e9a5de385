"""The mission resolved: a scenario's validated keys -> what the engine runs (:class:`Plan`).

Configuration (:mod:`sins_sim.config.scenario`) checks a scenario's keys, units and ranges and the IMU file's
(:func:`sins_sim.config.imu.parse_imu`), then calls :func:`resolve_plan` once. Everything that needs the physics
is decided here, in the order a reader follows it:

1. the unit (:func:`sins_sim.plan.imu.resolve_imu`: drives, filter designs, the suspension the filters believe,
   the block), then its temperature (each channel checked at the profile's extremes; the isolators' coefficients
   need a block);
2. the rates: ``navigation.rate_hz`` or ``n_sub`` (the engine's default about 400 Hz), the time series' rate;
3. the block's motion, the navigation settings and the alignment, the coning and sculling coefficients of
   ``filter_tuned`` (designed now, so that an ill-suited design is refused at load, not mid-run);
4. the vehicle (a trajectory file, segments, or at rest), the alignment window at rest, the GNSS aiding, the
   translation and the configuration-time advisories.

Two keys that do not compose are refused naming both (:class:`~sins_sim.plan.errors.PlanError`, one line).
:func:`run_plan` runs a plan on the engine (:func:`sins_sim.simulation.sins.simulate_sins`). New features
(alignment methods, aiding, logs) enter here, not the configuration's checks.
"""

from __future__ import annotations

import dataclasses
import math
import re
import warnings
from pathlib import Path

import numpy as np

from sins_sim.plan import advisories
from sins_sim.plan.errors import PlanError

__all__ = ["Plan", "resolve_plan", "run_plan", "with_unit", "ALIGNMENT_REST_SPEED_M_S"]


@dataclasses.dataclass(frozen=True)
class Plan:
    """What the engine runs: the resolved unit, the motion, the vehicle, the navigation and the seed.

    Attributes
    ----------
    imu : ImuConfig
        The unit (with its temperature, when the scenario has one).
    motion : Motion
        The block's angular motion (its parts added up).
    translation : Motion or None
        The translational vibration (mount axes), None without one.
    vehicle : Trajectory or SampledTrajectory
        The vehicle's path (a file, segments, or at rest at the site).
    nav : NavSettings
        Navigation settings with ``n_sub``, the alignment, the ``filter_tuned`` designs and the aiding resolved.
    filters : tuple of str
        The filters, each once, in the order given.
    duration_s : float
    seed : int
    site : dict
        ``lat_rad``, ``lon_rad``, ``height_m``, ``heading_rad`` at the start (a file's first row).
    temperature : ThermalModel or None
    events : list of dict
        Shocks and block turns (for the step and scale-factor metrics).
    vibration_enters, motion_enters : str
        ``chassis`` or ``block`` (with an IMU block).
    advisories : tuple of str
        Configuration-time warnings (vibration against the filters and the dithers, online estimation on a block).
    vibration_spec : SineOnRandomSpec or None
        The sine-on-random specification (``vibration.spec``) the translation was built from, for the report.
    dither_forecast : tuple of dict
        What each sine line of the motion leaves of each dither under the amplitude loop
        (:func:`~sins_sim.plan.advisories.dither_under_lines`; ``metrics.json``'s ``dither_under_vibration``).
    """

    imu: object
    motion: object
    translation: object
    vehicle: object
    nav: object
    filters: tuple
    duration_s: float
    seed: int
    site: dict
    temperature: object = None
    events: list = dataclasses.field(default_factory=list)
    vibration_enters: str = "chassis"
    motion_enters: str = "chassis"
    advisories: tuple = ()
    vibration_spec: object = None
    dither_forecast: tuple = ()


def resolve_plan(parsed: dict) -> Plan:
    """Resolve a parsed scenario (:class:`sins_sim.config.scenario.Scenario` gives it) into a :class:`Plan`.

    Parameters
    ----------
    parsed : dict
        ``c`` (the scenario validated against its schema, SI keys), ``doc`` (the mapping as written, for the keys
        given explicitly), ``imu`` (the parsed IMU file, :func:`sins_sim.config.imu.parse_imu`), ``ctx`` (how
        messages name the file), ``base_dir`` (where relative paths are taken from) and ``duration_key`` (how a
        refusal names the run's length: ``duration_s``, or ``--duration``).

    Returns
    -------
    Plan
        Configuration-time advisories are also issued as :class:`UserWarning`.

    Raises
    ------
    PlanError
        One line naming the file, the key(s) and the rule.
    """
    from sins_sim.plan.imu import resolve_imu

    c, doc, ctx, base_dir = parsed["c"], parsed["doc"], parsed["ctx"], Path(parsed["base_dir"])
    duration_key = parsed["duration_key"]
    duration_s, seed = c["duration_s"], int(c["seed"])
    imu = resolve_imu(parsed["imu"])
    temperature = None
    if c["temperature"] is not None:
        temperature = _thermal_model(c["temperature"], ctx)
        imu = _with_temperature(imu, temperature, duration_s, ctx)
        _check_block_temperature(imu, temperature, duration_s, ctx)
    fs = imu.filter_rate_hz
    nv = c["navigation"]
    if nv["rate_hz"] is not None:
        nv["n_sub"] = _n_sub_of_rate(nv["rate_hz"], fs, nv["n_sub"], ctx)
    elif nv["n_sub"] is None:  # the mission default (issue 26): about 400 Hz
        from sins_sim.simulation.sins import default_n_sub  # the IMU is valid: the engine may load now

        nv["n_sub"] = default_n_sub(fs)
    if nv["timeseries_rate_hz"] is not None and nv["timeseries_rate_hz"] > fs / nv["n_sub"]:
        raise PlanError(f"{ctx}: navigation.timeseries_rate_hz: must be <= the navigation update rate "
                        f"{fs / nv['n_sub']:g} Hz (readout.output_rate_hz / n_sub; navigation.rate_hz "
                        f"raises it), got {nv['timeseries_rate_hz']:g}")
    motion = _build_motion(c["motion"], seed, ctx)
    filters = tuple(dict.fromkeys(c["filters"]))
    nav = _nav_settings(nv, imu, filters, ctx)
    single_cone = len(c["motion"]) == 1 and c["motion"][0].get("type") == "coning"
    if nv["tuned_band_hz"] is not None and not nav.tuned and not single_cone:
        # read by filter_tuned, and by the coning table of a run whose motion is one coning part (jobs.run)
        raise PlanError(f"{ctx}: navigation.tuned_band_hz: applies only with coning or sculling: filter_tuned "
                        f"(the design band of its coefficients), got coning: {nv['coning']} and sculling: "
                        f"{nv['sculling']}, where it would be ignored: remove it or choose filter_tuned")
    site = c["site"]
    written = isinstance(doc.get("trajectory"), dict) and "velocity_tolerance_m_s" in doc["trajectory"]
    vehicle = _build_vehicle(c["site"], {**c["trajectory"], "velocity_tolerance_written": written},
                             duration_s, ctx, base_dir, duration_key, start_s=nv["start_s"])
    if c["trajectory"]["file"]:  # the mission starts where the file does: the site is its first row
        site = _site_of(vehicle)
    _check_at_rest_for_alignment(nav, vehicle, ctx)
    plan = Plan(imu=imu, motion=motion, translation=None, vehicle=vehicle, nav=nav, filters=filters,
                duration_s=duration_s, seed=seed, site=site, temperature=temperature)
    if c["aiding"] is not None:
        nav = dataclasses.replace(nav, aiding=_aiding_settings(doc.get("aiding") or {}, c["aiding"], plan, base_dir,
                                                               ctx, duration_key))
    #: configuration-time warnings (vibration against the filters' stop bands and the dithers), also issued
    forecast = tuple(advisories.dither_under_lines(imu, c["motion"], c["motion_enters"]))
    notes = tuple(advisories.vibration_advisories(imu, c["motion"], filters)
                  + advisories.online_on_block_advisories(imu) + advisories.dither_line_advisories(forecast)
                  + advisories.block_entry_advisories(imu, c["motion"], c["motion_enters"]))
    for msg in notes:
        warnings.warn(msg, UserWarning, stacklevel=3)
    spec = parsed.get("vibration_spec")
    if spec is not None:  # a sine-on-random specification (vibration.spec) resolves to the translation
        try:
            translation = spec.translation(seed)
        except ValueError as exc:
            raise PlanError(f"{ctx}: vibration.spec: {exc}") from None
    else:
        translation = _build_translation(c["linear_vibration"], seed, ctx)
    return dataclasses.replace(plan, nav=nav, events=_events(c["motion"], vehicle), translation=translation,
                               vibration_spec=spec,
                               vibration_enters=c["vibration_enters"], motion_enters=c["motion_enters"],
                               advisories=notes, dither_forecast=forecast)


def run_plan(plan, progress=None, threads: int | None = None):
    """Run a plan on the engine (:func:`sins_sim.simulation.sins.simulate_sins`).

    Parameters
    ----------
    plan : Plan
        From :func:`resolve_plan` (a :class:`sins_sim.config.scenario.Scenario` carries one as ``.plan``).
    progress : callable(fraction) or None
    threads : int, optional
        Threads for the three axes (default: the cores available, at most 3).

    Returns
    -------
    SinsResult
    """
    from sins_sim.simulation.sins import simulate_sins  # the engine, once the plan is resolved

    return simulate_sins(plan.imu, plan.motion, plan.duration_s, seed=plan.seed, nav=plan.nav, filters=plan.filters,
                         progress=progress, threads=threads, vehicle=plan.vehicle, translation=plan.translation,
                         vibration_enters=plan.vibration_enters, motion_enters=plan.motion_enters)


def with_unit(plan, imu, ctx: str = "plan"):
    """The plan on another unit: what the plan derived from the unit resolved again for ``imu``.

    A command that varies the unit (the budget switches its error sources off, compare-filters requantises its
    readout) comes here rather than handing the unit to the engine beside the old plan's designs:

    - the scenario's temperature is applied to every channel and checked at the profile's extremes (and the
      isolators' coefficients against the block), as :func:`resolve_plan` does;
    - the ``filter_tuned`` coning and sculling designs are redesigned on the new unit's filters (they are designed
      on each filter's response, which the filters' parameters set: a unit whose filters believe other parameters
      needs other coefficients).

    The navigation rate (``n_sub``) was resolved on the filter rate, so a unit with another filter rate is refused;
    the alignment keeps the settings resolved from the scenario's unit (the navigator's a-priori error model, not the
    truth the command varies).

    Parameters
    ----------
    plan : Plan
    imu : ImuConfig
    ctx : str
        How a refusal names the command.

    Returns
    -------
    Plan

    Raises
    ------
    PlanError
        One line: another filter rate, a temperature out of the unit's range, or a design that does not fit.
    """
    if imu.filter_rate_hz != plan.imu.filter_rate_hz:
        raise PlanError(f"{ctx}: readout.output_rate_hz: the plan's navigation rate was resolved for the filter rate "
                        f"{plan.imu.filter_rate_hz:g} Hz, got a unit at {imu.filter_rate_hz:g} Hz: resolve the "
                        f"scenario again (resolve_plan)")
    if plan.temperature is not None:
        imu = _with_temperature(imu, plan.temperature, plan.duration_s, ctx)
        _check_block_temperature(imu, plan.temperature, plan.duration_s, ctx)
    try:
        nav = _with_designs(plan.nav, imu, plan.filters)
    except ValueError as exc:
        raise PlanError(f"{ctx}: {exc}") from None
    return dataclasses.replace(plan, imu=imu, nav=nav)


def _with_designs(nav, imu, filters: tuple):
    """``nav`` with the ``filter_tuned`` coning and sculling designs of ``filters`` on ``imu`` (issue 28: designed
    when the plan is resolved, so that a design that does not fit is refused then, not mid-run); ValueError naming
    the key when one does not fit."""
    if not nav.tuned:
        return nav
    from sins_sim.simulation.sins import tuned_designs

    key = "navigation.coning" if nav.coning == "filter_tuned" else "navigation.sculling"
    return dataclasses.replace(nav, designs=tuned_designs(imu, filters, nav.tuned_band_hz, key))


def _nav_settings(nv: dict, imu, filters: tuple, ctx: str):
    """``navigation`` -> NavSettings with the alignment and the ``filter_tuned`` designs (:func:`_with_designs`)."""
    from sins_sim.simulation.sins import NavSettings

    try:
        nav = NavSettings(coning=nv["coning"], sculling=nv["sculling"], start_s=nv["start_s"],
                          n_sub=nv["n_sub"], vertical=nv["vertical"],
                          height_aid_tau_s=nv["height_aid_tau_s"], accel_delay=nv["accel_delay"], align_s=nv["align_s"],
                          timeseries_rate_hz=nv["timeseries_rate_hz"], spectrum_s=nv["spectrum_s"],
                          tuned_band_hz=None if nv["tuned_band_hz"] is None else tuple(nv["tuned_band_hz"]),
                          alignment=_alignment_settings(nv["alignment"], imu))
        nav = _with_designs(nav, imu, filters)
    except ValueError as exc:
        raise PlanError(f"{ctx}: {exc}") from None
    return nav


def _thermal_model(c: dict, ctx: str):
    """The scenario's ``temperature`` section -> ThermalModel (one line naming the key on a bad value)."""
    from sins_sim.simulation.temperature import K_NAMES, TemperatureProfile, ThermalModel

    kind = c["profile"]
    try:
        if kind == "table":
            rows = c["table_s_k"]
            prof = TemperatureProfile("table", start_k=rows[0][1], end_k=rows[-1][1], table=tuple(map(tuple, rows)))
        elif kind == "ramp":
            prof = TemperatureProfile("ramp", start_k=c["initial_k"], end_k=c["final_k"], start_s=c["start_s"],
                                      duration_s=c["duration_s"])
        elif kind == "step":
            prof = TemperatureProfile("step", start_k=c["initial_k"], end_k=c["initial_k"] + c["step_k"],
                                      step_k=c["step_k"], start_s=c["start_s"])
        else:
            prof = TemperatureProfile("constant", start_k=c["initial_k"], end_k=c["initial_k"])
        return ThermalModel(prof, f0_per_k=1e-6 * c["f0_ppm_per_k"],
                            k_per_k=tuple(1e-6 * c["k_ppm_per_k"][n] for n in K_NAMES),
                            reference_k=c["reference_k"], update_s=c["update_s"],
                            isolator_stiffness_per_k=1e-6 * c["isolators"]["stiffness_ppm_per_k"],
                            isolator_damping_per_k=1e-6 * c["isolators"]["damping_ppm_per_k"])
    except ValueError as exc:
        raise PlanError(f"{ctx}: {exc}") from None


def _n_sub_of_rate(rate_hz: float, fs_hz: float, n_sub_given, ctx: str) -> int:
    """``n_sub`` of ``navigation.rate_hz``: the filter samples per update, a whole number (issue 26)."""
    ratio = fs_hz / rate_hz
    n = int(round(ratio))
    if n < 1 or abs(ratio - n) > 1e-9 * ratio:
        near = sorted({fs_hz / max(1, int(math.floor(ratio))), fs_hz / max(1, int(math.ceil(ratio)))})
        raise PlanError(f"{ctx}: navigation.rate_hz: must divide the filter rate {fs_hz:g} Hz "
                          f"(readout.output_rate_hz) into a whole number of samples per update (<= {fs_hz:g} Hz), "
                          f"e.g. {' or '.join(f'{r:g}' for r in near)} Hz; got {rate_hz:g}")
    if n_sub_given is not None and n_sub_given != n:
        raise PlanError(f"{ctx}: navigation.rate_hz: {rate_hz:g} Hz is n_sub = {n}, but navigation.n_sub is "
                          f"{n_sub_given!r}: give one of them")
    return n


def _aiding_settings(written: dict, a: dict, sc, base_dir, ctx, duration_key) -> object:
    """``aiding`` -> AidingSettings; what cannot compose is refused naming both keys."""
    from sins_sim.navigation.gnss import GnssSettings
    from sins_sim.simulation.aiding import AidingSettings

    fs = sc.imu.filter_rate_hz
    start, dur = sc.nav.start_s, sc.duration_s
    rate = a["rate_hz"]
    upd = rate if a["update_rate_hz"] is None else a["update_rate_hz"]
    if upd > rate * (1.0 + 1e-12) or abs(rate / upd - round(rate / upd)) > 1e-9 * rate / upd:
        raise PlanError(f"{ctx}: aiding.update_rate_hz: must divide aiding.rate_hz = {rate:g} Hz into a whole "
                          f"number of fixes per update, got {upd:g}")
    for i, w in enumerate(a["outages_s"]):
        if not w[0] < w[1]:
            raise PlanError(f"{ctx}: aiding.outages_s[{i}]: must be [start_s, end_s] with start < end, got {w}")
        if not (start < w[0] and w[1] <= dur):
            raise PlanError(f"{ctx}: aiding.outages_s[{i}]: {w} must lie within navigation.start_s = {start:g} s "
                              f"(an update must come before it) and {duration_key} = {dur:g} s")
    groups = a["sensor_error_states"]
    dup = sorted({g for g in groups if groups.count(g) > 1})
    if dup:
        raise PlanError(f"{ctx}: aiding.sensor_error_states: each group at most once, got {', '.join(dup)} twice")
    if groups and sc.imu.sensors is None:
        raise PlanError(f"{ctx}: aiding.sensor_error_states: needs the IMU's sensors: section (its scale factors and "
                        f"misalignments are the states' priors), and the IMU has none")
    data = None
    if a["file"]:
        for key in ("markov_sigma_m", "markov_tau_s"):
            if key in written:
                raise PlanError(f"{ctx}: aiding.{key}: describes simulated fixes and would be ignored beside "
                                  f"aiding.file (a recorded solution carries its own errors): remove one of them")
        from sins_sim.io.gnss_file import read_gnss_file

        path = (Path(base_dir) / a["file"]).resolve()
        try:
            data = read_gnss_file(path)
        except ValueError as exc:
            raise PlanError(f"{ctx}: aiding.file: {exc}") from None
        if "velocity" in a["measurements"] and data.v_ned_m_s is None:
            raise PlanError(f"{ctx}: aiding.measurements: velocity needs the velocity columns (vn_m_s, ve_m_s, "
                              f"vd_m_s) of aiding.file ({a['file']}), which has none: use measurements: [position]")
        if not (data.t_s[0] <= start and data.t_s[-1] >= dur - 1.0 / rate):
            raise PlanError(f"{ctx}: aiding.file: its fixes span {data.t_s[0]:g} to {data.t_s[-1]:g} s and must "
                              f"cover navigation.start_s = {start:g} s to {duration_key} = {dur:g} s")
    else:
        ratio = fs / rate
        if abs(ratio - round(ratio)) > 1e-9 * ratio or round(ratio) < 1:
            raise PlanError(f"{ctx}: aiding.rate_hz: must divide the filter rate readout.output_rate_hz = {fs:g} Hz "
                              f"into whole samples (a fix is the truth at a filter sample), got {rate:g}")
    try:
        gnss = GnssSettings(rate_hz=rate, position_sigma_m=tuple(a["position_sigma_m"]),
                            velocity_sigma_m_s=tuple(a["velocity_sigma_m_s"]),
                            markov_sigma_m=tuple(a["markov_sigma_m"]), markov_tau_s=a["markov_tau_s"],
                            latency_s=a["latency_s"], lever_arm_b_m=tuple(a["lever_arm_m"]),
                            outages_s=tuple(tuple(w) for w in a["outages_s"]))
    except ValueError as exc:
        raise PlanError(f"{ctx}: aiding: {exc}") from None
    return AidingSettings(gnss=gnss, measurements=tuple(dict.fromkeys(a["measurements"])), update_rate_hz=upd,
                          feedback=a["feedback"], smoother=a["smoother"], file=data,
                          fix_error_states=a["fix_error_states"], sensor_error_states=tuple(groups))


def _alignment_settings(spec: dict, imu):
    """``navigation.alignment`` with the unit's bias and noise numbers (the observability bounds, the filter)."""
    from sins_sim.simulation.aligning import alignment_settings

    return alignment_settings(spec["method"], spec["duration_s"], imu.sensors)


def _check_at_rest_for_alignment(nav, vehicle, ctx):
    """An alignment window needs the vehicle at rest (it may sway): refuse a window over which it travels."""
    al = nav.alignment
    if not al.active:
        return
    t0 = nav.start_s - al.duration_s
    t = np.linspace(t0, nav.start_s, max(2, int(math.ceil(al.duration_s * 10.0)) + 1))
    speed = np.linalg.norm(vehicle.evaluate(t).v_ned_m_s, axis=1)
    worst = int(np.argmax(speed))
    if speed[worst] > ALIGNMENT_REST_SPEED_M_S:
        raise PlanError(f"{ctx}: navigation.alignment: the vehicle must be at rest over the alignment window "
                          f"[{t0:g}, {nav.start_s:g}] s (start_s - duration_s to start_s), but it moves at "
                          f"{speed[worst]:.3g} m/s at t = {t[worst]:.6g} s (at most {ALIGNMENT_REST_SPEED_M_S:g} m/s); "
                          f"start the trajectory with a stationary segment or use method: truth")


def _with_temperature(imu, model, duration_s, ctx):
    """The unit with every channel following ``model`` (checked at the profile's extremes)."""
    import dataclasses

    from sins_sim.simulation.channel import check_thermal

    channels = []
    for axis, ch in zip(("x", "y", "z"), imu.channels):
        ch = dataclasses.replace(ch, temperature=model)
        try:
            check_thermal(ch, duration_s, "temperature")
        except ValueError as exc:
            raise PlanError(f"{ctx}: {exc} (channel {axis})") from None
        channels.append(ch)
    return dataclasses.replace(imu, channels=tuple(channels))


def _check_block_temperature(imu, model, duration_s, ctx):
    """The isolators' temperature coefficients need a block (refused without one, naming both keys), and keep the
    block's linear model in range at the profile's extremes."""
    if not model.moves_isolators:
        return
    if imu.block is None:
        raise PlanError(f"{ctx}: temperature.isolators: needs an IMU block: section (the isolators it moves), but "
                          f"imu has none (a rigid block): remove temperature.isolators or add imu.block")
    try:
        model.check_block(imu.block, duration_s)
    except ValueError as exc:
        raise PlanError(f"{ctx}: {exc}") from None


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
                common = dict(psd_table=tuple(table), f_lo_hz=seg["f_lo_hz"], f_hi_hz=seg["f_hi_hz"],
                              axis_weights=tuple(seg["axes"]), seed=seed + 1000 * (i + 1))
                if seg["method"] == "filtered_noise":
                    part = m3.FilteredNoiseVibration(generator=seg["generator"], **common)
                elif seg["generator"] != m3.vibration.GENERATORS[0]:
                    raise ValueError(f"generator: {seg['generator']} applies to method: filtered_noise only "
                                     f"(method: tones has no noise generator)")
                else:
                    part = m3.RandomVibration(**common)
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
            raise PlanError(f"{ctx}: {path}: {exc}") from None
        parts.append(part)
    motion = parts[0]
    for part in parts[1:]:
        motion = motion + part
    return motion


def _build_translation(segments, seed, ctx):
    """The block's translational vibration (None when there is none)."""
    from sins_sim.models import motion as m3

    parts = []
    for i, seg in enumerate(segments):
        try:
            if seg["type"] == "sines":
                parts.append(m3.LinearSines(tuple(seg["amplitude_m_s2"]), tuple(seg["frequency_hz"]),
                                            tuple(seg["phase_rad"])))
            else:
                parts.append(m3.LinearRandomVibration(psd_table=tuple(tuple(r) for r in seg["psd_g2_per_hz"]),
                                                      f_lo_hz=seg["f_lo_hz"], f_hi_hz=seg["f_hi_hz"],
                                                      axis_weights=tuple(seg["axes"]), seed=seed + 5000 + 1000 * i,
                                                      generator=seg["generator"]))
        except ValueError as exc:
            raise PlanError(f"{ctx}: linear_vibration[{i}]: {exc}") from None
    if not parts:
        return None
    total = parts[0]
    for part in parts[1:]:
        total = total + part
    return total


def _site_of(vehicle) -> dict:
    """The site (``lat_rad``, ``lon_rad``, ``height_m``, ``heading_rad``) at a trajectory's start."""
    import math

    tr = vehicle.evaluate(np.zeros(1))
    q0, q1, q2, q3 = (float(x) for x in np.asarray(tr.q_nv).reshape(-1, 4)[0])
    return {"lat_rad": float(np.ravel(tr.lat_rad)[0]), "lon_rad": float(np.ravel(tr.lon_rad)[0]),
            "height_m": float(np.ravel(tr.h_m)[0]),
            "heading_rad": math.atan2(2.0 * (q0 * q3 + q1 * q2), 1.0 - 2.0 * (q2 * q2 + q3 * q3))}


def _shorter_run(duration_key: str, lasts_s: float, start_s: float) -> str:
    """The advice of a run past its trajectory's end: a shorter run when one fits, else the length one needs.

    A run must last longer than ``navigation.start_s`` and needs 0.1 s of trajectory past its end, so a trajectory
    of ``start_s + 0.1`` s or less carries no run at all (a negative duration is never advised).
    """
    if lasts_s - 0.1 > start_s:
        return f"set {duration_key} <= {lasts_s - 0.1:g}"
    return (f"the trajectory is too short for any run that starts navigating at navigation.start_s = {start_s:g} s: "
            f"it must last more than {start_s + 0.1:g} s (start_s + the 0.1 s past the run's end)")


def _build_vehicle(site, spec, duration_s, ctx, base_dir, duration_key="duration_s", start_s: float = 0.0):
    """The vehicle: a trajectory file, segments after the start, or at rest at the site.

    A run longer than its trajectory (``duration_s`` + 0.1 s past the end of the file or of the segments) is
    refused naming ``duration_key`` (``duration_s``, or ``--duration`` when the command line set it), unless
    the segments' ``extend`` is ``hold``. A file is checked by :func:`sins_sim.plan.advisories.trajectory_advisories`.
    """
    from sins_sim.models.motion import trajectory as tj

    need = duration_s + 0.1
    if spec["file"] and spec["extend"] != "none":
        raise PlanError(f"{ctx}: trajectory.extend: applies to segments only (a file holds what it holds), "
                          f"got {spec['extend']!r} with trajectory.file")
    try:
        if spec["file"]:
            from sins_sim.io.trajectory import read_trajectory

            path = (base_dir / spec["file"]).resolve()
            data = read_trajectory(path)
            try:
                msgs = advisories.trajectory_advisories(data, spec["file"])
            except PlanError as exc:
                raise PlanError(f"{ctx}: {exc}") from None
            for msg in msgs:
                warnings.warn(msg, UserWarning, stacklevel=3)
            if data.v_ned_m_s is None and spec.get("velocity_tolerance_written"):
                raise PlanError(f"{ctx}: trajectory.velocity_tolerance_m_s: applies to a file with velocity "
                                  f"columns; {spec['file']} has none (vn_m_s, ve_m_s, vd_m_s): remove the key")
            vehicle = tj.SampledTrajectory.from_data(data, v_tol_m_s=spec["velocity_tolerance_m_s"])
            where = f"trajectory.file ({spec['file']})"
        else:
            segs = []
            for seg in spec["segments"]:
                kind = seg["type"]
                if kind == "stationary":
                    segs.append(tj.Stationary(seg["duration_s"]))
                elif kind == "cruise":
                    segs.append(tj.Cruise(seg["duration_s"]))
                elif kind == "accelerate":
                    segs.append(tj.Accelerate(seg["duration_s"], seg["delta_speed_m_s"]))
                elif kind == "turn":
                    segs.append(tj.CoordinatedTurn(seg["duration_s"], seg["heading_change_rad"]))
                elif kind == "hover":
                    segs.append(tj.Hover(seg["duration_s"], seg["roll_rad"], seg["pitch_rad"]))
                elif kind == "sideways":
                    segs.append(tj.Sideways(seg["duration_s"], seg["lateral_speed_m_s"]))
                else:
                    segs.append(tj.Climb(seg["duration_s"], seg["delta_height_m"]))
            flown = sum(sg.duration_s for sg in segs)
            if segs and flown < need and spec["extend"] == "none":
                raise PlanError(f"{ctx}: {duration_key}: {duration_s:g} s runs past the end of the trajectory's "
                                  f"segments, which last {flown:g} s (the run needs {duration_key} + 0.1 s of "
                                  f"trajectory): {_shorter_run(duration_key, flown, start_s)}; add a segment (e.g. "
                                  f"{{type: cruise, duration_s: {math.ceil(need - flown):g}}}), or set "
                                  f"trajectory.extend: hold to hold the last state")
            tail = duration_s + 1.0 - flown  # after the last segment the vehicle holds its state
            if tail > 0:
                segs.append(tj.Stationary(tail) if _ends_at_rest(spec, segs) else tj.Cruise(tail))
            vehicle = tj.Trajectory(site["lat_rad"], site["lon_rad"], site["height_m"], spec["speed_m_s"],
                                    site["heading_rad"], tuple(segs), transition_s=spec["transition_s"])
            where = "trajectory"
            _check_latitude_reach(vehicle, min(need, vehicle.duration_s), ctx)
    except PlanError:
        raise
    except ValueError as exc:
        if spec["file"]:  # the model's names -> the file's columns and rows
            msg = tj.velocity_check_in_file_terms(str(exc), f"trajectory.file ({spec['file']})",
                                                  "trajectory.velocity_tolerance_m_s")
            raise PlanError(f"{ctx}: {msg}") from None
        turn = re.match(r"Trajectory\.segments\[(\d+)\]\.delta_heading_rad: (.*), got (\S+)$", str(exc))
        if turn:  # the model's radians -> the key the user wrote
            raise PlanError(f"{ctx}: trajectory.segments[{turn.group(1)}].heading_change_deg: {turn.group(2)}, got "
                              f"{math.degrees(float(turn.group(3))):g}") from None
        raise PlanError(f"{ctx}: trajectory: {exc}") from None
    if vehicle.duration_s < need:  # a file (segments are refused above or held to the end)
        raise PlanError(f"{ctx}: {duration_key}: {duration_s:g} s runs past the end of {where}, which lasts "
                          f"{vehicle.duration_s:g} s (the run needs {duration_key} + 0.1 s of trajectory): "
                          f"{_shorter_run(duration_key, vehicle.duration_s, start_s)}; or give a longer file")
    return vehicle


#: Longest flight (s) whose latitude reach is integrated at load (2 days of flight, about 20 s of integration);
#: beyond it the engine itself stops at the limit, in the model's words.
_LAT_CHECK_MAX_S = 2.0e5


def _check_latitude_reach(vehicle, t_end, ctx) -> None:
    """A segment flight that would pass 89.5 deg of latitude is refused now, naming the keys (it stopped the engine
    mid-run with the model's words): the position is integrated to the run's end once (RK4 at 100 Hz, the
    engine's own integration)."""
    from sins_sim.io.trajectory import MAX_ABS_LAT_DEG, POLE_REASON

    # a flight that cannot cover the distance to 89.5 deg at its fastest is not integrated (the default vehicle at
    # rest, and huge durations that the run-time estimate refuses next: the integration costs 100 steps per
    # simulated second); 110 km per degree is below the shortest meridian degree (110.57 km at the equator)
    speeds = [abs(vehicle.start_speed_m_s)]
    for sg in vehicle.segments:
        speeds.append(speeds[-1] + abs(getattr(sg, "delta_speed_m_s", 0.0)) + abs(getattr(sg, "lateral_speed_m_s", 0.0)))
    reach_m = (max(speeds) + 1e-9) * t_end
    if reach_m < (MAX_ABS_LAT_DEG - abs(math.degrees(vehicle.start_lat_rad))) * 110.0e3 or t_end > _LAT_CHECK_MAX_S:
        return
    try:
        vehicle.evaluate(np.linspace(0.0, t_end, int(min(max(t_end, 1.0), 1e5)) + 1))  # the time within ~1 s
    except ValueError as exc:
        m = re.search(r"before t = (?:np\.float64\()?([0-9.eE+-]+)", str(exc))
        when = f" before t = {float(m.group(1)):.4g} s" if m else ""
        raise PlanError(f"{ctx}: trajectory.segments: the flight from site.lat_deg "
                          f"{math.degrees(vehicle.start_lat_rad):g} passes {MAX_ABS_LAT_DEG:g} deg of latitude{when}: "
                          f"{POLE_REASON}; shorten the run, turn away from the pole or start farther from it") from None


def _ends_at_rest(spec, segs) -> bool:
    speed = spec["speed_m_s"]
    for sg in segs:
        speed += getattr(sg, "delta_speed_m_s", 0.0)
    return abs(speed) < 1e-9


def _events(motion_spec, vehicle):
    """Shocks and block turns of the motion list, for the step and scale-factor metrics."""
    out = []
    for seg in motion_spec:
        if seg["type"] == "shock":
            out.append({"kind": "shock", "start_s": seg["start_s"], "end_s": seg["start_s"] + seg["duration_s"]})
        elif seg["type"] == "turn":
            ax = np.asarray(seg["axis"], dtype=float)
            out.append({"kind": "turn", "start_s": seg["start_s"], "end_s": seg["start_s"] + seg["duration_s"],
                        "angle_rad": seg["angle_rad"], "axis_body": (ax / np.linalg.norm(ax)).tolist()})
    return out


#: The speed (m/s) above which the vehicle is not at rest for an alignment window: a still or swaying base
#: moves at millimetres per second (a 5 arcmin sway of a point 1 m off the axis at 3 Hz: 9 mm/s); a
#: vehicle taxiing moves at metres per second.
ALIGNMENT_REST_SPEED_M_S = 0.1
