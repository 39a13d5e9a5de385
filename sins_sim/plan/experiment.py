"""The bench experiment resolved: an experiment file's checked keys -> the recording engine's inputs.

Configuration (:func:`sins_sim.config.experiment.experiment_from_dict`) checks an experiment file's keys, units and
ranges and maps its suspension keys to the model's fields, then calls :func:`resolve_experiment` once. Here, with the
physics: the nominal and the true (perturbed) suspensions, the drive the engineer would set up (eq. 17's voltage at the
nominal amplitude-dependent resonance, or the AFC plan), the rate table's motion, the site's Earth rate, the
engine's inputs (:class:`sins_sim.simulation.experiment.ExperimentInputs`) and the plant's resolution; what does not
fit is refused with one :class:`~sins_sim.plan.errors.PlanError` line naming the key.
"""

from __future__ import annotations

import math

import numpy as np

from sins_sim.io.recording import SITE_AXES
from sins_sim.models.plant import check_resolution
from sins_sim.models.suspension import SuspensionParams
from sins_sim.plan.errors import PlanError
from sins_sim.simulation.experiment import (
    ExperimentInputs,
    ExperimentSettings,
    afc_drive,
    stationary_drive,
    table_motion,
)
from sins_sim.simulation.site import earth_motions, table_on_axes

__all__ = ["resolve_experiment"]


def _suspension(base: SuspensionParams, fields: dict | None) -> SuspensionParams:
    return base.replace(**fields) if fields else base


def resolve_experiment(c: dict, overrides: dict, f0_default_hz: dict, raw_site: dict | None, max_steps: float,
                       ctx: str) -> dict:
    """Build everything :func:`sins_sim.jobs.recording_jobs.simulate_recording` needs from a checked experiment.

    Parameters
    ----------
    c : dict
        The experiment validated against its schema (SI keys).
    overrides : dict
        ``nominal`` and ``truth``: axis -> {SuspensionParams field: value}, the file's overrides mapped to the model.
    f0_default_hz : dict
        axis -> the nominal f0 (Hz) where the file gives none.
    raw_site : dict or None
        The ``site`` mapping as written (degrees, for the recording's header).
    max_steps : float
        Most plant steps x axes the record may hold (the format's memory rule).
    ctx : str
        How messages name the file.

    Returns
    -------
    dict
        ``inputs`` (ExperimentInputs, pre-roll included), ``truth`` and ``nominal`` (axis -> SuspensionParams),
        ``effects``, ``settings``, ``quantum_rad``, ``noise_rad``, ``seed``, ``preroll_samples``, ``experiment``,
        ``description``, ``points`` (AFC plan), ``name`` and ``site``.

    Raises
    ------
    PlanError
        Naming ``ctx``, the key path and the rule.
    """
    axes = list(c["axes"])
    try:
        nominal = {}
        for a in axes:
            nominal[a] = _suspension(SuspensionParams(f0_hz=f0_default_hz[a]), overrides["nominal"].get(a))
        rng = np.random.default_rng([int(c["seed"]), 7])
        truth = {}
        for a in axes:
            s = nominal[a]
            pf, pk = c["perturb"]["f0"], c["perturb"]["k"]
            if pf or pk:
                z = rng.standard_normal(6)
                s = s.replace(f0_hz=s.f0_hz * (1 + pf * z[0]), k1=s.k1 * (1 + pk * z[1]), k2=s.k2 * (1 + pk * z[2]),
                              k3=s.k3 * (1 + pk * z[3]), k4=s.k4 * (1 + pk * z[4]), k5=s.k5 * (1 + pk * z[5]))
            truth[a] = _suspension(s, overrides["truth"].get(a))
        fs = c["fs_hz"]
        dfs = c["drive_fs_hz"] or fs
        settings = ExperimentSettings(plant_rate_hz=c["plant_rate_hz"], integrator=c["integrator"],
                                      hysteresis=c["hysteresis"])
        pre = int(round(c["preroll_s"] * fs)) if c["initial_state"] == "unknown" else 0
        n = int(math.floor(c["duration_s"] * fs + 1e-9)) + 1 + pre
        ratio = int(round(dfs / fs))
        if ratio < 1 or abs(dfs / fs - ratio) > 1e-9:
            raise ValueError(f"drive_fs_hz: drive_fs_hz / fs_hz must be an integer >= 1, got {dfs / fs!r}")
        amp = c["amplitude_rad"]
        points = []
        if c["experiment"] == "afc_sweep":
            afc = c["afc"]
            drive, points = afc_drive(nominal, axes, amp, afc["voltage_factors"], afc["frequency_offsets_hz"],
                                      afc["dwell_s"], dfs, n * ratio)
        else:
            drive = stationary_drive(nominal, axes, amp, dfs, n * ratio)
        table = None
        if c["experiment"] == "rate_table":
            rt = c["rate_table"]
            for i, sn in enumerate(rt["sines"]):
                if not sn["frequency_hz"] < fs / 2.0:
                    raise ValueError(f"rate_table.sines[{i}].frequency_hz: must be < fs_hz / 2 = {fs / 2.0:g} Hz, "
                                     f"got {sn['frequency_hz']:g}")
                peak = math.degrees(2.0 * math.pi * sn["frequency_hz"] * sn["amplitude_rad"])
                if peak > 1000.0:
                    raise ValueError(f"rate_table.sines[{i}].amplitude_arcmin: gives a peak rate of {peak:.4g} deg/s, "
                                     "beyond the 1000 deg/s an RLG measures")
            mot = table_motion(rt["rate_rad_s"], [(s["amplitude_rad"], s["frequency_hz"], s["phase_rad"])
                                                  for s in rt["sines"]])
            on = rt["axes"] or axes
            for a in on:
                if a not in axes:
                    raise ValueError(f"rate_table.axes: {a!r} is not one of axes {axes}")
            table = {a: mot for a in on}
        site = _site(raw_site, c.get("site"), axes, c["experiment"], pre)
        inertial = None
        if site is not None:
            if table is not None:
                table = table_on_axes(site, axes, mot)
            inertial = earth_motions(site, axes, (n - 1) / fs, table)
        inputs = ExperimentInputs(axes, fs, n, dfs, drive, table, inertial)
        effects = c["effects"] or []
        for e in effects:
            e.check_axes(axes)
        rate = inputs.plant_rate(settings)
        steps = n * rate / fs * len(axes)
        if steps > max_steps:
            raise ValueError(f"duration_s: {c['duration_s']:g} s (+ preroll) at plant_rate_hz {rate:g} on {len(axes)} "
                             f"axis/axes is {steps:.3g} plant steps held in memory (the limit is "
                             f"{max_steps:.3g}, about 4 GB): shorten duration_s")
        for a in axes:
            check_resolution(truth[a], rate)
    except ValueError as exc:
        raise PlanError(f"{ctx}: {exc}") from None
    return {"inputs": inputs, "truth": truth, "nominal": nominal, "effects": effects, "settings": settings,
            "quantum_rad": c["quantum_rad"], "noise_rad": c["noise_rad"], "seed": int(c["seed"]),
            "preroll_samples": pre, "experiment": c["experiment"], "description": c["description"],
            "points": points, "name": c["name"], "site": site}


def _site(raw: dict | None, checked: dict | None, axes, experiment: str, preroll: int) -> dict | None:
    """The recording header's ``site`` from the experiment's (degrees as the YAML gives them), checked against
    the format's rules (``sins_sim.io.recording``)."""
    if not raw or not checked:
        return None
    ori = raw.get("orientation_ned") or {}
    site = {"latitude_deg": float(raw["latitude_deg"]),
            "orientation_ned": {k: float(ori.get(k, 0.0)) for k in ("heading_deg", "pitch_deg", "roll_deg")}}
    if checked.get("table_axis_ned") is not None:
        u = np.asarray(checked["table_axis_ned"], dtype=np.float64)
        if not np.linalg.norm(u) > 0.0:
            raise ValueError(f"site.table_axis_ned: must be a unit vector [n, e, d], got {list(u)}")
        site["table_axis_ned"] = [float(x) for x in u / np.linalg.norm(u)]
        if experiment == "rate_table" and preroll:
            raise ValueError("site: a rate_table with a site needs initial_state: rest (the recording's table angle "
                             "starts at 0 where the site orients the unit)")
    elif experiment == "rate_table":
        raise ValueError("site.table_axis_ned: is required for a rate_table with a site (the axis the table turns "
                         "about)")
    for a in axes:
        if a not in SITE_AXES:
            raise ValueError(f"axes: must be named from {list(SITE_AXES)} with a site (the triad it orients), "
                             f"got {a!r}")
    return site
