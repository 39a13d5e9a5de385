"""Per-sample cost of the kernels and the engine's real-time factor, against same-run baselines.

The engine behind ``sins-sim bench`` and the pytest-benchmark suite in ``benchmarks/``. Every
measurement follows the same protocol (:mod:`~sins_sim.bench.timing`): fixed, deterministic
inputs (:mod:`~sins_sim.bench.inputs`); one untimed call first (numba compiles, or loads its
on-disk cache); then ``repeats`` timed calls, of which the median is kept; and the result is
checked against an independent computation (:mod:`~sins_sim.bench.references`) before any
number is reported.

Clocks: ``cpu`` times with :func:`time.thread_time` (the calling thread's CPU time: one core's
work, blind to other processes on a shared machine); ``wall`` with :func:`time.perf_counter`.

What is measured (:func:`run_bench` keys):

``ns_per_sample``
    ``correcting`` / ``correcting_paper`` (eq. 5 per 7.2 kHz sample), ``eliminator``,
    ``plant_step_1axis`` (exact integrator) and ``plant_step_1axis_rk4`` per 72 kHz step;
    ``engine_3axis_per_plant_step``: ``simulate_sins`` without navigation per plant step of
    one axis; ``scenario_per_plant_step``: with the full INS loop.
``baseline_ns_per_sample``
    ``scipy_sosfilt`` (the machine's yardstick), ``correcting_python`` and
    ``plant_rk4_python`` (plain-Python references), ``bare_kernels_per_plant_step`` (the three
    channels' fused kernels on precomputed inputs, suspensions side by side as the one-thread
    engine runs them, :class:`~sins_sim.bench.engine.BareKernels`).
``ratios``
    Same-run ratios checked by CI (``benchmarks/thresholds.json``).
``realtime_factor_3axis``
    Simulated seconds per CPU second of ``simulate_sins`` on one core, every filter, closed-loop
    drives, no navigation (``..._wall_2threads``: per wall second with the axes on 2 threads).
``realtime_factor_scenario``
    The same with the full navigation loop (every filter navigated against the truth).
``memory``
    Peak resident memory of 10 min and 1 h runs with navigation (full mode only).
"""

from __future__ import annotations

import math
import time

import numpy as np
from scipy import signal

from sins_sim.bench.engine import CHAIN_F0_HZ, BareKernels, engine_run, peak_memory
from sins_sim.bench.inputs import filter_input, plant_input
from sins_sim.bench.references import correcting_reference, plant_rk4_reference
from sins_sim.bench.timing import CLOCKS, check as _check, median_ratio, median_time
from sins_sim.filters.correcting import CorrectingFilter, CorrectingFilterDesign
from sins_sim.filters.eliminator import Eliminator, EliminatorDesign
from sins_sim.models.plant import Plant, PlantSettings
from sins_sim.models.suspension import PAPER_SUSPENSION
from sins_sim.units import ARCMIN, ARCSEC

__all__ = ["ANCHORS_NS", "SIZES", "run_bench", "format_table", "filter_input", "plant_input",
           "correcting_reference", "plant_rk4_reference", "median_time", "median_ratio", "peak_memory"]

#: Figures measured on this kind of machine, one core (the per-sample issue's anchors), ns per sample.
ANCHORS_NS = {"correcting_c": 21.0, "scipy_sosfilt": 7.7, "plant_rk4_c": 56.0}

SIZES = {
    # filter samples, plant steps, engine seconds, python references (filter samples, plant steps)
    False: dict(n_filter=1_440_000, n_plant=720_000, engine_s=20.0, n_ref_filter=20_000, n_ref_plant=3_000, repeats=7),
    True: dict(n_filter=360_000, n_plant=144_000, engine_s=4.0, n_ref_filter=2_000, n_ref_plant=400, repeats=5),
}


def run_bench(quick: bool = False, repeats: int | None = None, clock: str = "cpu", memory: bool | None = None,
              memory_durations_s=(600.0, 3600.0)) -> dict:
    """Measure the per-sample costs and the engine's real-time factors (see module docstring).

    Parameters
    ----------
    quick : bool
        Short inputs and fewer repeats (CI).
    repeats : int, optional
        Timed calls per measurement (median kept).
    clock : {"cpu", "wall"}
        Clock of the per-sample costs.
    memory : bool, optional
        Also measure peak memory of engine runs of ``memory_durations_s`` in fresh processes;
        default: when not quick.
    memory_durations_s : tuple of float
        Simulated durations of the memory runs (s).
    """
    if clock not in CLOCKS:
        raise ValueError(f"bench.clock: must be one of {sorted(CLOCKS)}, got {clock!r}")
    tick = CLOCKS[clock]
    sz = dict(SIZES[bool(quick)])
    reps = int(repeats) if repeats is not None else sz["repeats"]
    if reps < 1:
        raise ValueError(f"bench.repeats: must be >= 1, got {repeats!r}")
    memory = (not quick) if memory is None else bool(memory)
    ns, base = {}, {}

    # --- filters at 7.2 kHz
    x, volts = filter_input(sz["n_filter"])
    nf = x.size
    for key, form in (("correcting", "unity"), ("correcting_paper", "paper")):
        design = CorrectingFilterDesign(form=form)
        filt = CorrectingFilter(design)

        def run_filter(filt=filt):
            filt.reset()
            return filt.process(x, volts)

        ns[key] = median_time(run_filter, reps, tick) / nf * 1e9
        nr = sz["n_ref_filter"]
        ref = correcting_reference(x[:nr], volts[:nr], design)
        got = run_filter()[:nr]
        _check(np.max(np.abs(got - ref)) <= 1e-12, f"{key} vs the plain-Python eq. 5 ({np.max(np.abs(got - ref))!r} rad)")
        if key == "correcting":
            base["correcting_python"] = median_time(
                lambda: correcting_reference(x[:nr], volts[:nr], design), max(1, reps // 2), tick) / nr * 1e9
    sos = np.array(EliminatorDesign.paper().sos)
    elim = Eliminator(EliminatorDesign.paper())

    def run_elim():
        elim.reset()
        return elim.process(x)

    ns["eliminator"] = median_time(run_elim, reps, tick) / nf * 1e9
    base["scipy_sosfilt"] = median_time(lambda: signal.sosfilt(sos, x), reps, tick) / nf * 1e9
    _check(np.array_equal(run_elim(), signal.sosfilt(sos, x)), "eliminator equals scipy.signal.sosfilt bit for bit")

    # --- one plant at 72 kHz
    ang, rate, pv = plant_input(sz["n_plant"])
    npl = pv.size
    r_rest = ARCMIN * 2.0 * math.pi * 100.0  # the vibration's rate at t = 0
    for key, integ in (("plant_step_1axis", "exact"), ("plant_step_1axis_rk4", "rk4")):
        plant = Plant(PAPER_SUSPENSION, PlantSettings(integrator=integ))

        def run_plant(plant=plant):
            plant.reset(0.0, r_rest)
            return plant.step(ang, rate, pv)

        ns[key] = median_time(run_plant, reps, tick) / npl * 1e9
        nr = sz["n_ref_plant"]
        if integ == "exact":
            ref = plant_rk4_reference(ang[:nr], rate[:nr], pv[:nr], 1.0 / 72000.0, PAPER_SUSPENSION, 0.0, r_rest)
            err = np.max(np.abs(run_plant()[:nr] - ref)) / ARCSEC
            _check(err < 0.01, f"plant vs the plain-Python RK4 ({err!r} arcsec)")
            base["plant_rk4_python"] = median_time(
                lambda: plant_rk4_reference(ang[:nr], rate[:nr], pv[:nr], 1.0 / 72000.0, PAPER_SUSPENSION, 0.0, r_rest),
                max(1, reps // 2), tick) / nr * 1e9

    # --- the engine, through the public entry point
    dur = sz["engine_s"]
    bare = BareKernels(dur)
    steps = 3 * bare.n_chunks * bare.n
    sim_s = bare.simulated_s
    res = engine_run(sim_s, navigation=True)
    _check(bool(res.stats) and all(st.n > 0 for st in res.stats.values()), "every filter navigated")
    _check(res.stats["ideal"].last["horizontal_m"] < 1e-3, "ideal increments stay at the truth")
    t_engine = median_time(lambda: engine_run(sim_s, navigation=False), reps, time.thread_time)
    t_scen = median_time(lambda: engine_run(sim_s, navigation=True), max(3, reps // 2), time.thread_time)
    t_bare = median_time(bare.run, reps, time.thread_time)
    t_wall2 = median_time(lambda: engine_run(sim_s, navigation=False, threads=2), max(3, reps // 2), time.perf_counter)
    t_wall1 = median_time(lambda: engine_run(sim_s, navigation=False, threads=1), max(3, reps // 2), time.perf_counter)
    t_scen_wall2 = median_time(lambda: engine_run(sim_s, navigation=True, threads=2), max(3, reps // 2),
                               time.perf_counter)
    ns["engine_3axis_per_plant_step"] = t_engine / steps * 1e9
    ns["scenario_per_plant_step"] = t_scen / steps * 1e9
    base["bare_kernels_per_plant_step"] = t_bare / steps * 1e9

    ratios = {
        "correcting/scipy_sosfilt": ns["correcting"] / base["scipy_sosfilt"],
        "correcting_paper/scipy_sosfilt": ns["correcting_paper"] / base["scipy_sosfilt"],
        "eliminator/scipy_sosfilt": ns["eliminator"] / base["scipy_sosfilt"],
        "plant_step_1axis/scipy_sosfilt": ns["plant_step_1axis"] / base["scipy_sosfilt"],
        "plant_step_1axis/plant_step_1axis_rk4": ns["plant_step_1axis"] / ns["plant_step_1axis_rk4"],
        "correcting_python/correcting": base["correcting_python"] / ns["correcting"],
        "plant_rk4_python/plant_step_1axis": base["plant_rk4_python"] / ns["plant_step_1axis"],
        "engine_3axis/bare_kernels": t_engine / t_bare,
        "scenario/engine_3axis": t_scen / t_engine,
        "engine_3axis_per_plant_step/scipy_sosfilt": ns["engine_3axis_per_plant_step"] / base["scipy_sosfilt"],
    }
    result = {
        "ns_per_sample": ns,
        "baseline_ns_per_sample": base,
        "ratios": ratios,
        "anchors_ns": dict(ANCHORS_NS),
        "realtime_factor_3axis": sim_s / t_engine,
        "realtime_factor_3axis_wall_1thread": sim_s / t_wall1,
        "realtime_factor_3axis_wall_2threads": sim_s / t_wall2,
        "speedup_2threads": t_wall1 / t_wall2,
        "realtime_factor_scenario": sim_s / t_scen,
        "realtime_factor_scenario_wall_2threads": sim_s / t_scen_wall2,
        "realtime_factor_bare_kernels": sim_s / t_bare,
        "engine": {"simulated_s": sim_s, "axes_f0_hz": list(CHAIN_F0_HZ), "filters": list(res.filters),
                   "entry_point": "sins_sim.simulation.sins.simulate_sins"},
        "sizes": sz,
        "clock": clock,
        "quick": bool(quick),
        "repeats": reps,
    }
    if memory:
        result["memory"] = {f"{d:g}s": peak_memory(d) for d in memory_durations_s}
    return result


def format_table(result: dict) -> str:
    """A plain-text table of a :func:`run_bench` result."""
    ns, base, anchors = result["ns_per_sample"], result["baseline_ns_per_sample"], result["anchors_ns"]
    rows = [
        ("correcting (eq. 5, unity)", ns["correcting"], "C eq. 5", anchors["correcting_c"]),
        ("correcting_paper (eq. 5, paper)", ns["correcting_paper"], "C eq. 5", anchors["correcting_c"]),
        ("eliminator (10-pole SOS)", ns["eliminator"], "sosfilt", anchors["scipy_sosfilt"]),
        ("plant_step_1axis (exact)", ns["plant_step_1axis"], "C RK4", anchors["plant_rk4_c"]),
        ("plant_step_1axis_rk4", ns["plant_step_1axis_rk4"], "C RK4", anchors["plant_rk4_c"]),
        ("engine_3axis_per_plant_step", ns["engine_3axis_per_plant_step"], "", None),
        ("scenario_per_plant_step", ns["scenario_per_plant_step"], "", None),
    ]
    lines = [f"clock: {result['clock']}, {'quick' if result['quick'] else 'full'}, median of {result['repeats']}",
             "", f"{'kernel':34s} {'ns/sample':>10s}   {'anchor':>14s}   {'ratio':>6s}"]
    for name, val, aname, aval in rows:
        anc = f"{aname} {aval:5.1f}" if aval is not None else ""
        ratio = f"{val / aval:6.2f}" if aval is not None else ""
        lines.append(f"{name:34s} {val:10.2f}   {anc:>14s}   {ratio:>6s}")
    lines += ["", f"{'baseline (same run)':34s} {'ns/sample':>10s}"]
    for name, val in base.items():
        lines.append(f"{name:34s} {val:10.2f}")
    lines += ["", "same-run ratios:"]
    for name, val in result["ratios"].items():
        lines.append(f"  {name:48s} {val:10.3f}")
    r = result
    lines += ["", f"simulate_sins, every filter, closed-loop drives, {r['engine']['simulated_s']:g} s simulated:",
              f"  without navigation: {r['realtime_factor_3axis']:.1f}x real time on one core (CPU time); "
              f"{r['realtime_factor_3axis_wall_2threads']:.1f}x by wall clock on 2 threads "
              f"(speed-up {r['speedup_2threads']:.2f}x over 1 thread)",
              f"  with the full INS loop: {r['realtime_factor_scenario']:.1f}x on one core; "
              f"{r['realtime_factor_scenario_wall_2threads']:.1f}x by wall clock on 2 threads",
              f"  bare channel kernels: {r['realtime_factor_bare_kernels']:.1f}x on one core"]
    if "memory" in r:
        for key, m in r["memory"].items():
            lines.append(f"memory, {m['simulated_s']:g} s simulated with navigation: max RSS {m['max_rss_mib']:.1f} MiB "
                         f"(before the run {m['max_rss_before_run_mib']:.1f}), {m['wall_s']:.1f} s wall "
                         f"({m['realtime_factor_wall']:.1f}x)")
    return "\n".join(lines)
