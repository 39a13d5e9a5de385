"""``sins-sim budget``: the navigation error budget of a scenario, source by source (issue 11, item 6).

The scenario runs once with everything on, once with each error source switched off in turn,
and once with every source off (the floor). Every run navigates every filter of the scenario
with the same seed, and the random streams of the sources are independent (switching one off
leaves the others' realisations unchanged, :mod:`sins_sim.models.sensor_errors`), so each
difference is that source's own contribution in this realisation.

Quantities, per filter ``F`` (vectors: the final horizontal position error ``(north, east)`` in m
and the final attitude error ``(N, E, D)`` in arcsec, both against the truth; the attitude error
is the mean over the last :data:`ATTITUDE_WINDOW_S` of the stored series, because a single final
sample carries the filter's white output noise, a snapshot that no budget can apportion):

``total``
    ``e_F(all on)``.
``sources[S]``
    ``e_F(all on) - e_F(all on but S)``: the error that source ``S`` adds; reported as the
    magnitude of that vector (its share of the total).
``sources["dither_residual"]``
    ``e_F(all off) - e_ideal(all off)``: what the filter itself leaves of the dither when the
    readout is exact and it knows the true parameters (zero for ``ideal``).
``floor``
    ``e_ideal(all off)``: the navigation algorithm (coning, sculling, the vertical channel) on
    exact increments, the floor every filter shares.
``remainder``
    ``total - floor - sum of the sources``: zero where the errors superpose linearly (small
    errors); its size says how far the budget's parts add up.

Sources are found in the scenario: each non-zero term of the gyro and accelerometer error
models (``gyro.bias``, ``accel.scale_factor``, ...), the readout (its quantisation and its noise
together: the quantum set to 1e-12 rad and the noise to zero; apart they do not superpose, the
noise dithers the quantiser), the accelerometer pulse quantisation, the filters' parameter
mismatch (``filter_parameters`` other than the truth) and each catalogue effect of the IMU.
The runs go in parallel on worker processes (one thread each).

Outputs: ``budget.json`` (keys above, magnitudes in ``horizontal_position_error_m`` and
``attitude_error_arcsec``, plus the vectors), ``budget.png`` (a bar chart of each source's share
per filter, log scale) and ``report.md`` (the table).
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np

from sins_sim.units import ARCSEC

__all__ = ["budget_sources", "run_budget", "apply_off", "READOUT_QUANTUM_OFF_RAD", "ATTITUDE_WINDOW_S"]

#: Readout quantum that stands for "no quantisation" (rad): far below any error of interest, and
#: 2^53 counts of it still span 9000 rad of gyro angle in float64.
READOUT_QUANTUM_OFF_RAD = 1e-12
#: The attitude error of a run is its mean over this last stretch (s) of the stored series (at most a
#: tenth of the navigated time).
ATTITUDE_WINDOW_S = 10.0

_GYRO_TERMS = {
    "bias_deg_h": "gyro.bias", "turn_on_bias_deg_h": "gyro.turn_on_bias", "arw_deg_rt_h": "gyro.arw",
    "bias_instability_deg_h": "gyro.bias_instability", "rrw_deg_h_rt_h": "gyro.rrw",
    "scale_factor_ppm": "gyro.scale_factor", "scale_factor_asymmetry_ppm": "gyro.scale_factor_asymmetry",
    "scale_factor_nonlinearity_ppm": "gyro.scale_factor_nonlinearity", "misalignment_arcsec": "gyro.misalignment",
}
_ACCEL_TERMS = {
    "bias_ug": "accel.bias", "turn_on_bias_ug": "accel.turn_on_bias", "vrw_ug_rt_hz": "accel.vrw",
    "bias_instability_ug": "accel.bias_instability", "rrw_ug_rt_h": "accel.rrw",
    "scale_factor_ppm": "accel.scale_factor", "scale_factor_asymmetry_ppm": "accel.scale_factor_asymmetry",
    "nonlinearity_ug_g2": "accel.nonlinearity", "misalignment_arcsec": "accel.misalignment",
}


def _nonzero(x) -> bool:
    return any(float(v) != 0.0 for v in np.ravel(np.asarray(x, dtype=float)))


def budget_sources(imu) -> list:
    """The error sources present in a unit (names for :func:`apply_off`), in a stable order."""
    out = []
    sens = imu.sensors
    if sens is not None:
        for attr, terms in (("gyro", _GYRO_TERMS), ("accelerometer", _ACCEL_TERMS)):
            p = getattr(sens, attr)
            for field, name in terms.items():
                if hasattr(p, field) and _nonzero(getattr(p, field)):
                    out.append(name)
    out.append("readout")
    if imu.accelerometer.quantum_m_s > 0.0:
        out.append("accelerometer_quantization")
    if any(c.filter_suspension is not None for c in imu.channels):
        out.append("filter_mismatch")
    for e in getattr(imu, "effects", ()) or ():
        out.append(f"effect.{e.name}")
    return out


def apply_off(imu, off):
    """The unit with the sources named in ``off`` switched off."""
    off = set(off)
    unknown = off - set(budget_sources(imu))
    if unknown:
        raise ValueError(f"budget.sources: not in this unit: {sorted(unknown)}")
    sens = imu.sensors
    if sens is not None:
        changes = {}
        for attr, terms in (("gyro", _GYRO_TERMS), ("accelerometer", _ACCEL_TERMS)):
            p = getattr(sens, attr)
            zero = {f: (tuple(0.0 for _ in np.ravel(getattr(p, f))) if np.ndim(getattr(p, f)) else 0.0)
                    for f, name in terms.items() if name in off}
            if zero:
                changes[attr] = dataclasses.replace(p, **zero)
        if changes:
            sens = dataclasses.replace(sens, **changes)
    chans = []
    for c in imu.channels:
        ro = c.readout
        if "readout" in off:
            ro = dataclasses.replace(ro, quantum_rad=READOUT_QUANTUM_OFF_RAD, noise_rad=0.0)
        c = dataclasses.replace(c, readout=ro)
        if "filter_mismatch" in off:
            c = dataclasses.replace(c, filter_suspension=None)
        chans.append(c)
    kw = {"channels": tuple(chans), "sensors": sens}
    if "accelerometer_quantization" in off:
        kw["accelerometer"] = dataclasses.replace(imu.accelerometer, quantum_m_s=0.0)
    if hasattr(imu, "effects"):
        kw["effects"] = tuple(e for e in imu.effects if f"effect.{e.name}" not in off)
    return dataclasses.replace(imu, **kw)


def _one_run(path: str, overrides: dict, off: tuple) -> dict:
    """One budget run in a worker: the final error vectors of every filter."""
    from sins_sim.config.scenario import load_scenario
    from sins_sim.plan import run_plan, with_unit

    sc = load_scenario(path, overrides)
    # the scenario's plan on the unit with those sources off (its filter-tuned designs redesigned on that unit)
    plan = with_unit(sc.plan, apply_off(sc.imu, off), f"budget ({', '.join(off) or 'all on'})")
    res = run_plan(plan, threads=1)
    out = {}
    for name in plan.filters:
        st = res.stats.get(name)
        if st is None or st.n == 0 or name in res.diverged:
            out[name] = None
            continue
        last = st.last
        ser = res.series[name]
        t = ser["t_s"]
        window = min(ATTITUDE_WINDOW_S, 0.1 * (t[-1] - res.nav_start_s)) if t.size else 0.0
        sel = t >= t[-1] - window if t.size else slice(None)
        att = ser["attitude_ned_rad"][sel].mean(axis=0) if t.size else last["attitude_ned_rad"]
        out[name] = {"position_ne_m": [last["north_m"], last["east_m"]],
                     "attitude_ned_arcsec": [float(x) / ARCSEC for x in att]}
    return out


def _mag(v) -> float:
    return float(math.sqrt(sum(float(x) ** 2 for x in v)))


def _entry(pos, att) -> dict:
    return {"horizontal_position_error_m": _mag(pos), "attitude_error_arcsec": _mag(att),
            "position_ne_m": [float(x) for x in pos], "attitude_ned_arcsec": [float(x) for x in att]}


def _assemble(runs: dict, sources: list, filters) -> dict:
    """budget.json from the run results (keys: ``all``, ``off:SOURCE``, ``floor``)."""
    total, contrib, floor, remainder = {}, {s: {} for s in ["dither_residual"] + sources}, {}, {}
    fl = runs["floor"]
    ideal_floor = fl.get("ideal") if fl.get("ideal") is not None else None
    for f in filters:
        a = runs["all"].get(f)
        if a is None or ideal_floor is None:
            total[f] = None
            continue
        pa, aa = np.array(a["position_ne_m"]), np.array(a["attitude_ned_arcsec"])
        total[f] = _entry(pa, aa)
        p_sum, a_sum = np.zeros(2), np.zeros(3)
        for s in sources:
            r = runs[f"off:{s}"].get(f)
            if r is None:
                contrib[s][f] = None
                continue
            dp, da = pa - np.array(r["position_ne_m"]), aa - np.array(r["attitude_ned_arcsec"])
            contrib[s][f] = _entry(dp, da)
            p_sum += dp
            a_sum += da
        pf, af = np.array(ideal_floor["position_ne_m"]), np.array(ideal_floor["attitude_ned_arcsec"])
        fo = fl.get(f)
        if fo is not None:
            dp, da = np.array(fo["position_ne_m"]) - pf, np.array(fo["attitude_ned_arcsec"]) - af
        else:
            dp, da = np.full(2, np.nan), np.full(3, np.nan)
        contrib["dither_residual"][f] = _entry(dp, da)
        floor[f] = _entry(pf, af)
        remainder[f] = _entry(pa - pf - dp - p_sum, aa - af - da - a_sum)
    return {"total": total, "sources": contrib, "floor": floor, "remainder": remainder}


def run_budget(path, out_dir, overrides: dict | None = None, workers: int = 2, progress=None) -> dict:
    """Run the budget of a scenario and write ``budget.json``, ``budget.png`` and ``report.md``.

    Parameters
    ----------
    path : path
        The scenario YAML.
    out_dir : path
        Output folder (the CLI passes a temporary folder of :func:`sins_sim.jobs.output.atomic_output_dir`).
    overrides : dict, optional
        As :func:`sins_sim.config.scenario.load_scenario` (seed, duration_s, imu, filter_parameters).
    workers : int
        Worker processes (runs in parallel, one thread each).
    progress : callable(done, total) or None

    Returns
    -------
    BudgetResult
        The content of ``budget.json`` (a dict, with ``to_pandas()`` and ``plot()``).
    """
    from sins_sim.config.scenario import load_scenario

    sc = load_scenario(path, overrides)
    sources = budget_sources(sc.imu)
    tasks = {"all": (), "floor": tuple(sources)}
    tasks.update({f"off:{s}": (s,) for s in sources})
    results = _run_tasks(str(path), overrides or {}, tasks, workers, progress)
    budget = _assemble(results, sources, sc.filters)
    budget.update({"scenario": sc.name, "duration_s": sc.duration_s, "seed": sc.seed, "imu": sc.imu.name,
                   "filters": list(sc.filters), "runs": len(tasks),
                   # the attitude's averaging window (as _finals takes it; the series ends within a block of the run)
                   "attitude_window_s": min(ATTITUDE_WINDOW_S, 0.1 * (sc.duration_s - sc.nav.start_s)),
                   "note": "sources[S] = |e(all on) - e(all on but S)|, dither_residual = |e_F(all off) - "
                           "e_ideal(all off)|, floor = |e_ideal(all off)|, remainder = |total - floor - sum of "
                           "sources| (vectors: final north/east position error in m, final NED attitude error in "
                           "arcsec)"})
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)  # the CLI hands a temporary folder moved into place when complete
    (out / "budget.json").write_text(json.dumps(budget, indent=2, allow_nan=True) + "\n")
    from sins_sim.plots.budget import plot_budget

    plot_budget(budget, out / "budget.png", f"{sc.name}: error budget after {sc.duration_s:g} s")
    (out / "report.md").write_text(_report(budget))
    from sins_sim.results import BudgetResult

    return BudgetResult(budget)


def _run_tasks(path, overrides, tasks: dict, workers: int, progress) -> dict:
    if workers <= 1:
        out = {}
        for i, (key, off) in enumerate(tasks.items()):
            out[key] = _one_run(path, overrides, off)
            if progress is not None:
                progress(i + 1, len(tasks))
        return out
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    out = {}
    with ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn")) as ex:
        futs = {ex.submit(_one_run, path, overrides, off): key for key, off in tasks.items()}
        for i, fut in enumerate(as_completed(futs)):
            out[futs[fut]] = fut.result()
            if progress is not None:
                progress(i + 1, len(tasks))
    return out


def _fmt(x) -> str:
    return "n/a" if x is None or not np.isfinite(x) else f"{x:.3g}"


def _report(b: dict) -> str:
    filters = [f for f in b["filters"] if b["total"].get(f)]
    lines = [f"# Error budget: {b['scenario']}", "",
             f"- {b['duration_s']:g} s mission, IMU `{b['imu']}`, seed {b['seed']}, {b['runs']} runs",
             f"- {b['note']}", "", "## Final horizontal position error (m)", "",
             "| source | " + " | ".join(filters) + " |", "|---|" + "---|" * len(filters)]

    def row(label, d, key):
        return f"| {label} | " + " | ".join(_fmt((d.get(f) or {}).get(key)) for f in filters) + " |"

    for key, title in (("horizontal_position_error_m", None), ("attitude_error_arcsec", "Final attitude error (arcsec)")):
        if title:
            lines += ["", f"## {title}", "", "| source | " + " | ".join(filters) + " |", "|---|" + "---|" * len(filters)]
        lines.append(row("**total**", b["total"], key))
        for s, d in b["sources"].items():
            lines.append(row(s, d, key))
        lines.append(row("floor (ideal increments, no source)", b["floor"], key))
        lines.append(row("remainder (parts do not add up by)", b["remainder"], key))
    lines += ["", "![budget](budget.png)", ""]
    return "\n".join(lines)
