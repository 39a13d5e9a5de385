"""``report.md`` of the paper reproduction: paper vs sins-sim for every headline number, with the reasons."""

from __future__ import annotations

import math

import numpy as np

from sins_sim.filters.eliminator import EliminatorDesign
from sins_sim.jobs.reproduce.channel import PICKOFF_TRACK_TIME_S
from sins_sim.jobs.reproduce.common import PAPER
from sins_sim.models.suspension import PAPER_SUSPENSION
from sins_sim.units import ARCMIN, ARCSEC


def _report(n: dict, f4) -> str:
    """report.md: paper vs sins-sim for every headline number, with the reasons for each difference."""
    P = PAPER
    sens, sensc = n["sensitivity_arcmin_per_pct"], n["sensitivity_model_change_arcmin_per_pct"]
    others = max(v for k, v in sens.items() if k != "f0")
    others_c = max(v for k, v in sensc.items() if k != "f0")
    dev = n["afc_max_dev_db"]
    fit_rel = n["afc_fit_relative_error"]
    t = n["timings_s"]
    ab, abp, abx = n["abel_fit"], n["abel_fit_paper_procedure"], n["abel_fit_exact_samples"]
    lin = n["linear_correction_db"]
    sinc = n["sinc2_db"]
    fir = n["fir_gain_db"]
    ie = n["impact_error_rms_arcsec"]
    ratios = [sensc[k] / P["sensitivity_arcmin_per_pct"][k] - 1.0 for k in ("k1", "k2", "k3", "k4", "k5")]
    worst = max(abs(r) for r in ratios) * 100.0
    poles = EliminatorDesign.paper().poles()
    poles = poles[np.imag(poles) > 0]
    poles = poles[np.argsort(-np.abs(poles))]
    pole_txt = ", ".join(f"{np.angle(p) * 7200.0 / (2 * math.pi):.0f} Hz (|p| = {abs(p):.4f})" for p in poles)
    s = PAPER_SUSPENSION
    a3 = 3.0 * ARCMIN
    shift_hz = s.f0_hz - s.resonance_hz(a3)
    decay_offset_hz = (n["resonance_shift_at_3arcmin_free_decay"] - n["resonance_shift_at_3arcmin_exact"]) * s.f0_hz
    b_step = (1.0 - n["dc_gain_paper_form"]) * 3.0 * ARCMIN / ARCSEC
    mech_1600 = (1600.0 / s.f0_hz) ** 2 - 1.0

    def pct(x, ref):
        return f"{(x / ref - 1.0) * 100.0:+.1f} %"

    rows = [
        ("Q at 3 arcmin from k3, k4 (eq. 16)", "about 10^2 (187 from the formulas)", f"{n['q_at_3arcmin']:.1f}",
         "agree", "1/Q = k3 (1 + k4 a) = 4.4e-3 x (1 + 250 x 8.727e-4) = 5.36e-3."),
        ("model vs measured AFC, 4 voltages x 10 frequencies", "4 arcsec RMS",
         f"{n['afc_fit_rms_arcsec']:.2f} arcsec RMS (start {n['afc_start_rms_arcsec']:.1f})",
         "not comparable", "No measurement exists here: the 'measured' set is eq. 2 itself with parameters "
         "offset by 0.1 % (omega0) and 2 % (k1..k5) plus "
         f"{n['afc_noise_arcsec']:g} arcsec of reading noise, so the fit can only reach the noise "
         f"({n['afc_noise_arcsec']:g} x sqrt(1 - 6/40) = {n['afc_noise_arcsec'] * math.sqrt(34 / 40):.2f}). "
         "The paper's 4 arcsec includes model error (eq. 13 neglects the piezo antiresonance, which the paper "
         "puts at a few to tens of arcsec)."),
        ("sensitivity, arcmin per +1 %: omega0", "2.65", f"{sens['f0']:.3g} (model change {sensc['f0']:.3g})",
         "same order; omega0 dominates",
         f"omega0 dominates the others by {sens['f0'] / others:.0f}x (paper: 2.65 / 1.9e-2 = 139x); by the "
         f"model-change measure {sensc['f0'] / others_c:.0f}x. See 'Sensitivity' below for why, and why "
         f"{sens['f0']:.2g} is not 2.65."),
        ("sensitivity: k1, k2, k3, k4, k5", "1.05e-2, 1.9e-2, 1.0e-2, 2e-3, 1.7e-2",
         ", ".join(f"{sens[k]:.2g}" for k in ("k1", "k2", "k3", "k4", "k5"))
         + " (model change: " + ", ".join(f"{sensc[k]:.2g}" for k in ("k1", "k2", "k3", "k4", "k5")) + ")",
         f"model-change measure within {worst:.0f} % of the table",
         "The paper's definition (increase of the RMS from its minimum) is second order in the change when the "
         "minimum has a residual floor: sqrt(floor^2 + d^2) - floor. Our floor is the injected noise; the RMS of "
         "the model change itself (d) reproduces the paper's table for k1..k5 closely, k4 smallest as printed."),
        ("correcting filter, 1 arcmin SINS sine, 80-3600 Hz", "flat except near Nyquist",
         f"max |dev| {dev['correcting']['80-1000']:.2f} dB to 1 kHz, {dev['correcting']['80-2000']:.2f} dB to "
         f"2 kHz, {dev['correcting']['80-3000']:.2f} dB to 3 kHz "
         f"(paper form: {dev['correcting_paper']['80-1000']:.2f}, "
         f"{dev['correcting_paper']['80-2000']:.2f}, {dev['correcting_paper']['80-3000']:.2f})",
         "qualitatively; the droop starts well below Nyquist",
         "Eq. 4 replaces s^2 by a second difference, whose gain is (2 - 2 cos theta)/dT^2 = omega^2 sinc^2(f/fs): "
         "above resonance the product with the mechanical 1/omega^2 is sinc^2(f/fs) = "
         f"{sinc['1000']:.2f} / {sinc['2000']:.2f} / {sinc['3000']:.2f} dB at 1 / 2 / 3 kHz "
         f"(linear analytic with the mechanical filter: {lin['1000']:.2f} / {lin['2000']:.2f} / {lin['3000']:.2f} dB), "
         f"plus the anti-alias FIR ({fir['1000']:.3f} / {fir['2000']:.3f} / {fir['3000']:.3f} dB). "
         "The simulated points on the nonlinear plant lie on that curve."),
        ("elliptic eliminator, same", "rises near resonance, rolls off above about 500 Hz, passband limited",
         f"max +{n['eliminator_max_gain_db']:.1f} dB near resonance; "
         f"slope {n['eliminator_slope_db_per_octave_1000_3000']:.1f} "
         f"dB/octave from 1 to 3 kHz; max |dev| {dev['eliminator']['80-1000']:.1f} dB to 1 kHz",
         "agree (except the printed slope)",
         "The roll-off is the mechanical filter's 1/omega^2, i.e. 12 dB/octave (the paper's own text says 1/omega^2; "
         "its '6 dB/octave' contradicts that). Inside 370-410 Hz the eliminator also removes the SINS motion."),
        ("stationary SINS: optimum relative mismatch", "about 0.002 measured, 0.0025 calculated",
         f"{n['mismatch_optimum']:.5f} (eq. 9 implies f0/F(a) - 1 = {n['mismatch_implied_eq9']:.5f})",
         "disagree by 2.2x",
         "With Nonl inside eq. 5 the filter's omega0 must be the suspension's own small-amplitude omega0, i.e. "
         f"f0/F(3 arcmin) - 1 = {n['mismatch_implied_eq9']:.5f} with the printed k1, k2. 0.0025 is what eq. 9 "
         f"gives at a = {n['amplitude_for_paper_mismatch_arcmin']:.2f} arcmin, not 3; a filter without Nonl "
         f"has its optimum at {n['mismatch_optimum_linear_filter']:.5f}. The printed k1, k2 and the printed 0.0025 "
         "cannot both hold at 3 arcmin; nothing was tuned."),
        ("stationary SINS: residual at the optimum", "about 0.7 arcsec RMS",
         f"{n['residual_rms_at_optimum_arcsec']:.2f} arcsec (1/16-fringe quantum); "
         f"{n['residual_rms_at_optimum_unquantised_arcsec']:.3f} without quantisation",
         "same order, ours lower",
         "The floor is the readout quantum amplified by eq. 5: q/sqrt(12) x sqrt(sum FIR taps^2) x "
         "sqrt(a2^2 + (g - 2 a2)^2 + a2^2) = "
         f"{n['quantisation_floor_estimate_arcsec']:.2f} arcsec. The paper's 0.7 includes sources not modelled "
         "(ADC noise, PLL jitter, drive noise). At the paper's m = 0.0025 the model leaves "
         f"{n['residual_rms_at_paper_mismatch_arcsec']:.2f} arcsec."),
        ("impact: eliminator ringing period", "about 2 ms",
         f"{n['eliminator_ring_period_ms']:.2f} ms ({n['eliminator_ring_hz']:.0f} Hz)", "longer than printed",
         f"The ringing is the eliminator's own: its pole pairs, slowest-decaying first, lie at {pole_txt}. "
         "The two slowest, at the band edges near 372 and 408 Hz (periods 2.7 and 2.5 ms, time constants "
         "~70 ms), ring longest and beat; the mean period from the zero crossings 5-55 ms after the impact is "
         "the number given. A 2 ms period would be 500 Hz, outside every pole of a 370-410 Hz design; the "
         "paper's 'about 2 ms' is a rough reading (its Fig. 7 shows few periods)."),
        ("impact: correcting filter follows the step and the 1.6 kHz vibration", "yes",
         f"error RMS over 0-30 ms: correcting {ie['correcting']:.2f} arcsec (paper form {ie['correcting_paper']:.2f}), "
         f"eliminator {ie['eliminator']:.1f}, pickoff {ie['pickoff']:.2f}", "agree",
         "The correcting filter's error is mostly the sinc^2 droop at 1.6 kHz acting on the vibration; the paper "
         f"form adds (1 - B) x the 3 arcmin step = {b_step:.1f} arcsec."),
    ]
    extra = [
        ("DC gain of eq. 5 as printed (B)", "0.99058 (spec)",
         f"{n['dc_gain_paper_form']:.5f}; unity form {n['dc_gain_unity_form']:.5f}",
         "agree", "B = 2 (1 - cos w)/w^2 with w = 2 pi 386 / 7200: a -0.94 % scale error on every steady rotation."),
        ("Nyquist gain of eq. 5 as printed", "about 34 (spec)", f"{n['nyquist_gain_paper_form']:.2f}", "agree",
         "(2 + 2 cos w)/w^2; it amplifies readout quantisation (see the residual floor)."),
        ("Fig. 1 sampling", "dT = 0.139 ms", f"fs = {n['fig1_fs_hz']:.1f} Hz (B = {n['fig1_dc_gain_paper_form']:.5f})",
         "noted", "0.139 ms is 1/7200 s rounded (0.13889 ms); Fig. 1 uses 0.139 ms as printed, everything else "
         "7.2 kHz."),
        ("resonance shift at 3 arcmin, F(a)/F0 - 1", "(from Fig. 2/3)",
         f"{n['resonance_shift_at_3arcmin']:.5f} (harmonic balance), {n['resonance_shift_at_3arcmin_exact']:.5f} "
         f"(exact period), {n['resonance_shift_at_3arcmin_free_decay']:.5f} (free-decay simulation)", "consistent",
         f"The free decay with the paper's hysteresis sits {decay_offset_hz:.3f} Hz higher: the half-cycle amplitude "
         "is taken at the previous turning point while the oscillation decays, so eq. 10 keeps a small in-phase part."),
        ("Abel inversion + eq. 9 fit (10 samples of F(a), 0.5-5 arcmin)", "k1 = 1.75e-4, k2 = 1.05e-3",
         f"k1 {ab['k1']:.4g} ({pct(ab['k1'], P['k1'])}), k2 {ab['k2']:.4g} ({pct(ab['k2'], P['k2'])}); exact samples "
         f"{pct(abx['k1'], P['k1'])}, {pct(abx['k2'], P['k2'])}; the paper's procedure {pct(abp['k1'], P['k1'])}, "
         f"{pct(abp['k2'], P['k2'])}", "agree with F0 refined",
         "The paper's linear extrapolation of F to zero amplitude misses F0 (F(a) of eq. 9 is curved near 0); "
         "a relative F0 error eps adds -2 eps phi to Nonl, as large as Nonl itself at small phi. Fitting that "
         "linear term (and reading it as an F0 correction) fixes it."),
        ("Fig. 5 caption: dither amplitude", "'3 arcsec' (caption) vs 3 arcmin (text)", "3 arcmin",
         "caption slip", "The text, the Fig. 6 experiment and the spec all say 3 arcmin; 3 arcsec would be a dither "
         "60 times smaller than every other statement in the paper."),
        ("AFC fit: parameter recovery", "-", ", ".join(f"{k} {v * 100:+.2g} %" for k, v in fit_rel.items()),
         "-", "omega0 is pinned to ~1e-4 by the peaks. k1 and k2 are strongly correlated in an AFC set: over "
         "1.5-3.75 arcmin the resonance shift is nearly linear in amplitude, which fixes mainly k1/k2^2 (Nonl ~ "
         "-k1 d|d|/(8 k2^2) for small d); the curvature that separates them is within the noise. The Abel route, "
         "over 0.5-5 arcmin without drive or noise, separates them."),
    ]

    def table(rs):
        lines = ["| what | paper | sins-sim | verdict | why |", "| --- | --- | --- | --- | --- |"]
        for r in rs:
            lines.append("| " + " | ".join(str(c).replace("|", "/") for c in r) + " |")
        return "\n".join(lines)

    masing = n.get("afc_max_dev_db_masing")
    masing_txt = ""
    if masing:
        masing_txt = (f" With the Masing rule in plant and filter the correcting filter's max deviations are "
                      f"{masing['correcting']['80-1000']:.2f} / {masing['correcting']['80-2000']:.2f} / "
                      f"{masing['correcting']['80-3000']:.2f} dB (paper rule: {dev['correcting']['80-1000']:.2f} / "
                      f"{dev['correcting']['80-2000']:.2f} / {dev['correcting']['80-3000']:.2f} dB).")
    fast = n["fig5_fast_half_cycles"]
    pts = n["afc_points"]
    pk = np.abs(np.array(pts["pickoff"]))
    kmax = int(np.argmax(pk))
    pk_f = pts["freqs_hz"][kmax]
    pk_df = pk_f - n["drive_frequency_hz"]
    pk_raw = pts["raw"][kmax]
    pk_rest = float(np.max(np.delete(pk, kmax))) if pk.size > 1 else 0.0
    return f"""# Paper reproduction with sins-sim ({n['mode']} run)

Source: "A Correcting Filter for a Mechanically Dithered Single-Axis Ring Laser Gyro"; equation numbers
are the paper's; conventions from the documentation's Theory pages. Everything below comes from the project's own
models and filters with the paper's parameters (f0 = 386 Hz, k1 = 1.75e-4, k2 = 1.05e-3 rad, k3 = 4.4e-3,
k4 = 250 1/rad, dither 3 arcmin driven at F(3 arcmin) = {n['drive_frequency_hz']:.3f} Hz by the eq. 17
voltage, 72 kHz plant, 1/16-fringe readout, 21-tap anti-alias FIR, 7.2 kHz filters, 370-410 Hz 10th-order
elliptic eliminator). No parameter was tuned to a printed number. Runtime {t['total_s']:.0f} s.

## Headline numbers (docs/user-guide/paper.md)

{table(rows)}

## Further numbers and printed details

{table(extra)}

## Explanations

**Sensitivity (Fig. 4 table).** Raising omega0 by 1 % moves every resonance by 3.86 Hz, while the half-width
of a resonance is F/(2Q) = {n['afc_half_width_hz']:.2f} Hz: the peaks leave the ten-frequency window and each
amplitude changes by an amount of the order of itself (RMS of the measured amplitudes:
{n['afc_amplitude_rms_arcmin']:.2f} arcmin). k3 and k5 scale the peak amplitudes by about 1 % per 1 %, k1 and
k2 move the resonance by 1 % of its {shift_hz:.1f} Hz nonlinear shift ({shift_hz / 100:.2f} Hz, about 2 % of a
half-width), k4 enters 1/Q only through k4 a = {s.k4 * a3:.2f}. The ratio omega0 : others is therefore about
(1 % x f0 / half-width) : 1 %, i.e. of order
2Q ~ 10^2. The absolute value for omega0 depends on where the 4 x 10 points sit relative to the peaks and on the
peak amplitudes; the paper's set is not tabulated, ours (peaks 1.5 to 3.75 arcmin, 381.5 to 387 Hz) gives
{sens['f0']:.2f} arcmin per % against 2.65.

**Correcting filter flatness (Fig. 5).** The linear part of eq. 5 times the mechanical filter is exactly 1 for
the analog filter (eq. 3); the digital second difference makes it sinc^2(f/fs) above resonance (Fig. 1, right).
The simulated gains on the nonlinear plant follow the linear analytic curve; the paper form adds
20 log10(B) = {20 * math.log10(n['dc_gain_paper_form']):.3f} dB everywhere. The top point is
{n['fig5_top_hz']:.0f} Hz rather than 3600 Hz: a sine at exactly fs/2 is sampled with a phase-dependent amplitude.
Block motion of 1 arcmin above about 1.15 kHz moves faster than the dither, so the paper's turning-point rule
for eq. 10 is outside its domain (docs/theory/suspension.md): the plant counted {fast['plant']} such half-cycles over
the Fig. 5 runs, the correcting filter {fast['correcting']}.{masing_txt}

**Pickoff baseline.** Dither stripping from an electrodynamic pickoff (3 % scale error, 2 us lag, noise;
illustrative values, not the paper's) with an LMS gain, calibrated on a stationary SINS first
({n['pickoff_calibrated_gain']:.5f} rad/(V s) against 1/(scale (1 + error)) = {n['pickoff_gain_ideal']:.5f}) and then
tracking with a {PICKOFF_TRACK_TIME_S:g} s time constant, as in operation (a fast LMS would also cancel block
motion within its band around the dither): max deviation {dev['pickoff']['80-1000']:.3f} /
{dev['pickoff']['80-2000']:.3f} / {dev['pickoff']['80-3000']:.3f} dB in the three bands, the largest at
{pk_f:.0f} Hz ({pk_df:+.1f} Hz from the dither, where the suspension amplifies the block motion to {pk_raw:+.0f} dB
in the RLG angle and even the slow LMS is pulled; elsewhere below {pk_rest:.2f} dB), residual dither
{n['residual_rms_stationary_pickoff_arcsec']:.2f} arcsec RMS on a stationary SINS, set by the part of the
dither in quadrature with the pickoff (a x 2 pi F x lag). It is flat because it measures the deflection instead
of inverting the suspension; its costs are the coil, its drift and its phase error (the paper's introduction).

**Mismatch (Fig. 6).** The correcting filter with the full eq. 5 removes the dither exactly when its omega0 is
the suspension's; relative to the drive frequency that is f0/F(a) - 1. Eq. 9 with the printed k1, k2 puts F(3
arcmin) {shift_hz:.2f} Hz below f0, i.e. {n['mismatch_implied_eq9']:.5f}; the simulated optimum
({n['mismatch_optimum']:.5f}) sits there within the harmonic content of the dither. Without quantisation the
minimum is {n['residual_rms_at_optimum_unquantised_arcsec']:.3f} arcsec (eq. 5's second difference is exact
only at omega0 and mis-weights the dither's harmonics; D's turning points are tracked at 18.75 samples per
cycle), with the 1/16-fringe quantum
{n['residual_rms_at_optimum_arcsec']:.2f} arcsec (quantisation amplified by eq. 5's second difference, estimate
{n['quantisation_floor_estimate_arcsec']:.2f}).

**Impact (Fig. 7).** A 3 arcmin step in 0.3 ms followed by a 0.5 arcmin, 1.6 kHz block vibration decaying in
4 ms. The eliminator cannot pass the 1.6 kHz vibration (the mechanical filter has divided it by
(1600/386)^2 - 1 = {mech_1600:.1f} and the eliminator does not restore it) and its band-edge poles ring for tens of
ms; the correcting filter follows the
step and the vibration, within the sinc^2 droop at 1.6 kHz.

## Files

fig1_correcting_afc.png, fig3_resonance_vs_amplitude.png, fig3_abel_nonl.png, fig4_afc_fit.png,
fig5_end_to_end_afc.png, fig6_mismatch.png, fig7_impact.png, numbers.json (all numbers above, more digits).
"""
