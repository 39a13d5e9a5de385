"""The paper reproduction job: :func:`run_reproduce` runs every figure and gathers the numbers.

It writes the PNGs (through ``sins_sim.plots.paper``, imported lazily),
``numbers.json`` and ``report.md`` (:mod:`~sins_sim.jobs.reproduce.report`).
"""

from __future__ import annotations

import json
import math
import time
import warnings
from pathlib import Path

import numpy as np
from scipy import optimize
from scipy.integrate import IntegrationWarning

from sins_sim.errors import HysteresisRegimeWarning
from sins_sim.filters.correcting import CorrectingFilterDesign
from sins_sim.identification.afc import PARAM_NAMES, params_vector
from sins_sim.jobs.reproduce.afc_fit import _fig4
from sins_sim.jobs.reproduce.channel import calibrate_pickoff
from sins_sim.jobs.reproduce.common import FILTERS, PAPER, ReproduceSettings
from sins_sim.jobs.reproduce.flatness import _fig5, _fig5_analytic, _slope_db_per_octave
from sins_sim.jobs.reproduce.impact import _fig7
from sins_sim.jobs.reproduce.mismatch import _fig6, _quantisation_floor
from sins_sim.jobs.reproduce.report import _report
from sins_sim.jobs.reproduce.resonance import _fig3
from sins_sim.jobs.reproduce.responses import _fig1, fir_response, mechanical_response
from sins_sim.models.pickoff import PickoffParams
from sins_sim.models.readout import ReadoutParams
from sins_sim.models.suspension import PAPER_SUSPENSION
from sins_sim.units import ARCMIN, ARCSEC

__all__ = ["run_reproduce"]


def _finite_tree(x):
    if isinstance(x, dict):
        return all(_finite_tree(v) for v in x.values())
    if isinstance(x, (list, tuple)):
        return all(_finite_tree(v) for v in x)
    if isinstance(x, (int, float)):
        return math.isfinite(x)
    return True


def run_reproduce(out_dir, quick: bool = False, progress=None) -> dict:
    """Reproduce the paper's figures and headline numbers; write PNGs, ``numbers.json`` and ``report.md``.

    Parameters
    ----------
    out_dir : path
        Output directory (created).
    quick : bool
        Reduced resolution (every number, fewer points, shorter runs; < 90 s).
    progress : callable(fraction) or None

    Returns
    -------
    dict
        The content of ``numbers.json``.
    """
    with warnings.catch_warnings():
        # the regime counters are reported in numbers.json (fig5_fast_half_cycles, impact_fast_half_cycles);
        # quad's round-off notes come from resonance_hz_exact at the smallest amplitudes of Fig. 3
        warnings.simplefilter("ignore", HysteresisRegimeWarning)
        warnings.simplefilter("ignore", IntegrationWarning)
        return _run_reproduce(out_dir, quick, progress)


def _run_reproduce(out_dir, quick: bool, progress) -> dict:
    from sins_sim.plots import paper as pp

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    st = ReproduceSettings.quick_() if quick else ReproduceSettings.full()
    s = PAPER_SUSPENSION
    a3 = 3.0 * ARCMIN
    timings = {}
    weights = {"fig1": 0.01, "fig3": 0.04, "fig4": 0.45 if quick else 0.55, "fig5": 0.3, "fig6": 0.05,
               "fig7": 0.05, "report": 0.01}
    total = sum(weights.values())
    done = [0.0]

    def stage(name):
        def sub(frac):
            if progress is not None:
                progress(min(1.0, (done[0] + weights[name] * frac) / total))
        return sub

    def finish(name, t0):
        timings[name] = time.perf_counter() - t0
        done[0] += weights[name]
        if progress is not None:
            progress(min(1.0, done[0] / total))

    t_all = time.perf_counter()
    t0 = time.perf_counter()
    f1 = _fig1(s)
    pp.plot_fig1(f1, out / "fig1_correcting_afc.png")
    finish("fig1", t0)

    t0 = time.perf_counter()
    f3 = _fig3(s, st)
    pp.plot_fig3(f3, out / "fig3_resonance_vs_amplitude.png", out / "fig3_abel_nonl.png")
    finish("fig3", t0)

    t0 = time.perf_counter()
    f4 = _fig4(s, st)
    pp.plot_fig4(f4, PAPER, out / "fig4_afc_fit.png")
    finish("fig4", t0)

    t0 = time.perf_counter()
    g_cal = calibrate_pickoff(s)
    f5 = _fig5(s, st, stage("fig5"), pickoff_gain=g_cal)
    f5_masing = _fig5(s, st, None, hysteresis="masing", pickoff_gain=g_cal) if not quick else None
    f5a = _fig5_analytic(s, f5["fd"])
    pp.plot_fig5(f5, f5a, out / "fig5_end_to_end_afc.png", masing=f5_masing)
    finish("fig5", t0)

    t0 = time.perf_counter()
    f6 = _fig6(s, st, pickoff_gain=g_cal)
    implied = s.relative_mismatch(a3)
    pp.plot_fig6(f6, PAPER, implied, out / "fig6_mismatch.png")
    finish("fig6", t0)

    t0 = time.perf_counter()
    f7 = _fig7(s, st, pickoff_gain=g_cal)
    pp.plot_fig7(f7, out / "fig7_impact.png")
    finish("fig7", t0)

    paper_design = CorrectingFilterDesign(f0_hz=s.f0_hz, fs_hz=7200.0, form="paper")
    unity_design = CorrectingFilterDesign(f0_hz=s.f0_hz, fs_hz=7200.0, form="unity")
    q6 = f6[("quantised", "paper")]
    sens = f4["sens"]
    fit = f4["fit"]
    fast5 = {k: int(sum(d[k] for d in f5["fast"])) for k in f5["fast"][0]}
    numbers = {
        "quick": quick,
        "mode": "quick" if quick else "full",
        "q_at_3arcmin": s.q_factor(a3),
        "dc_gain_paper_form": paper_design.dc_gain,
        "dc_gain_unity_form": unity_design.dc_gain,
        "nyquist_gain_paper_form": paper_design.nyquist_gain,
        "nyquist_gain_unity_form": unity_design.nyquist_gain,
        "fig1_fs_hz": f1["fs"],
        "fig1_dc_gain_paper_form": f1["dc_gain_paper_0139"],
        "fig1_nyquist_gain_paper_form": f1["nyquist_gain_paper_0139"],
        "drive_frequency_hz": f5["fd"],
        "resonance_shift_at_3arcmin": s.resonance_hz(a3) / s.f0_hz - 1.0,
        "resonance_shift_at_3arcmin_exact": s.resonance_hz_exact(a3) / s.f0_hz - 1.0,
        "resonance_shift_at_3arcmin_free_decay": f3["f_sim_3"] / s.f0_hz - 1.0,
        "mismatch_implied_eq9": implied,
        "mismatch_optimum": q6["m_opt"],
        "residual_rms_at_optimum_arcsec": q6["rms_opt"] / ARCSEC,
        "mismatch_optimum_unquantised": f6[("unquantised", "paper")]["m_opt"],
        "residual_rms_at_optimum_unquantised_arcsec": f6[("unquantised", "paper")]["rms_opt"] / ARCSEC,
        "mismatch_optimum_unity_form": f6[("quantised", "unity")]["m_opt"],
        "residual_rms_at_optimum_unity_form_arcsec": f6[("quantised", "unity")]["rms_opt"] / ARCSEC,
        "mismatch_optimum_linear_filter": f6[("quantised", "linear")]["m_opt"],
        "residual_rms_at_m0_arcsec": float(np.interp(0.0, f6["m"], q6["rms"])) / ARCSEC,
        "residual_rms_at_paper_mismatch_arcsec": float(np.interp(PAPER["mismatch_optimum_calculated"], f6["m"],
                                                                 q6["rms"])) / ARCSEC,
        "quantisation_floor_estimate_arcsec": _quantisation_floor(paper_design) / ARCSEC,
        "residual_rms_stationary_eliminator_arcsec": f6[("quantised", "others")]["eliminator"] / ARCSEC,
        "residual_rms_stationary_pickoff_arcsec": f6[("quantised", "others")]["pickoff"] / ARCSEC,
        "amplitude_for_paper_mismatch_arcmin": optimize.brentq(
            lambda a: s.relative_mismatch(a * ARCMIN) - PAPER["mismatch_optimum_calculated"], 0.05, 3.0),
        "afc_max_dev_db": {k: f5["max_dev"][k] for k in ("correcting", "correcting_paper", "eliminator", "pickoff")},
        "afc_max_dev_db_masing": ({k: f5_masing["max_dev"][k] for k in ("correcting", "correcting_paper",
                                                                         "eliminator", "pickoff")}
                                  if f5_masing else None),
        "afc_points": {"freqs_hz": f5["freqs"].tolist(),
                       **{k: f5["gains_db"][k].tolist() for k in FILTERS}},
        "eliminator_slope_db_per_octave_1000_3000": _slope_db_per_octave(f5["freqs"], f5["gains_db"]["eliminator"],
                                                                         1000.0, 3000.0),
        "fig5_fast_half_cycles": fast5,
        "pickoff_calibrated_gain": g_cal,
        "pickoff_gain_ideal": 1.0 / PickoffParams().sensitivity,
        "fig5_top_hz": float(f5["freqs"][-1]),
        "fir_gain_db": {f"{f:g}": float(20.0 * np.log10(abs(fir_response(ReadoutParams(), [f])[0])))
                        for f in (1000.0, 2000.0, 3000.0, 3580.0)},
        "linear_correction_db": {f"{f:g}": float(20.0 * np.log10(abs(
            mechanical_response(f, s.f0_hz, s.q_factor(a3))
            * CorrectingFilterDesign(f0_hz=s.f0_hz, fs_hz=7200.0, form="unity").frequency_response(f))))
            for f in (1000.0, 2000.0, 3000.0, 3580.0)},
        "sinc2_db": {f"{f:g}": float(20.0 * np.log10((math.sin(math.pi * f / 7200.0) / (math.pi * f / 7200.0)) ** 2))
                     for f in (1000.0, 2000.0, 3000.0, 3580.0)},
        "eliminator_max_gain_db": float(np.max(f5["gains_db"]["eliminator"])),
        "afc_amplitude_rms_arcmin": float(np.sqrt(np.mean(f4["measured"] ** 2))) / ARCMIN,
        "afc_half_width_hz": s.resonance_hz(a3) / (2.0 * s.q_factor(a3)),
        "sensitivity_arcmin_per_pct": {k: sens[k]["rms_increase"] / ARCMIN for k in PARAM_NAMES},
        "sensitivity_model_change_arcmin_per_pct": {k: sens[k]["model_change_rms"] / ARCMIN for k in PARAM_NAMES},
        "afc_fit_rms_arcsec": fit.rms / ARCSEC,
        "afc_start_rms_arcsec": fit.start_rms / ARCSEC,
        "afc_noise_arcsec": st.afc_noise_arcsec,
        "afc_fit_nfev": fit.nfev,
        "afc_fit_success": fit.success,
        "afc_fit_relative_error": dict(zip(PARAM_NAMES, (params_vector(fit.params) / params_vector(f4["truth"])
                                                         - 1.0).tolist())),
        "afc_truth_relative_offset": dict(zip(PARAM_NAMES, f4["rel"].tolist())),
        "abel_fit": {"k1": f3["fit_sim"].k1, "k2": f3["fit_sim"].k2, "f0_hz": f3["abel_sim"].curve.f0_hz},
        "abel_fit_exact_samples": {"k1": f3["fit_exact"].k1, "k2": f3["fit_exact"].k2,
                                   "f0_hz": f3["abel_exact"].curve.f0_hz},
        "abel_fit_paper_procedure": {"k1": f3["fit_paper"].k1, "k2": f3["fit_paper"].k2,
                                     "f0_hz": f3["abel_paper"].curve.f0_hz},
        "eliminator_ring_period_ms": f7["ring_period_ms"],
        "eliminator_ring_hz": f7["ring_hz"],
        "impact_error_rms_arcsec": {k: val / ARCSEC for k, val in f7["err_rms"].items()},
        "impact_error_rms_masing_arcsec": {k: val / ARCSEC for k, val in f7["err_rms_masing"].items()},
        "impact_fast_half_cycles": f7["runs"]["paper"].fast_half_cycles,
    }
    timings["total_s"] = time.perf_counter() - t_all
    numbers["timings_s"] = dict(timings)
    if not _finite_tree({k: val for k, val in numbers.items() if k != "afc_max_dev_db_masing"}):
        numbers["warning"] = "some numbers are not finite"
    t0 = time.perf_counter()
    (out / "numbers.json").write_text(json.dumps(numbers, indent=2) + "\n")
    (out / "report.md").write_text(_report(numbers, f4))
    finish("report", t0)
    return numbers
