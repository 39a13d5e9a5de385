"""Figures of the paper reproduction (``sins_sim.jobs.reproduce``); matplotlib imported lazily (Agg)."""

from __future__ import annotations

import numpy as np

from sins_sim.plots.common import COLORS, LABELS, _pyplot
from sins_sim.units import ARCMIN, ARCSEC

__all__ = ["plot_fig1", "plot_fig3", "plot_fig4", "plot_fig5", "plot_fig6", "plot_fig7"]

_LABELS = {**LABELS, "pickoff": "pickoff stripping (LMS gain)", "raw": "raw RLG readout (mechanical filter)"}
_COLORS = COLORS


def _db(x):
    return 20.0 * np.log10(np.maximum(np.abs(x), 1e-12))


def plot_fig1(d: dict, path) -> None:
    """Fig. 1: mechanical filter, analog and digital correcting filters; their product."""
    plt = _pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(13, 6.0), constrained_layout=True)
    f, fs, f0 = d["f"], d["fs"], d["f0"]
    ax = axes[0]
    ax.semilogy(f, d["mech"], color="k", lw=1.4, label=f"1: mechanical filter, kinematic input (Q = {d['q']:.0f})")
    ax.semilogy(f, d["analog"], color="tab:orange", lw=1.4,
                label=r"2: analog correcting filter $|1-(f/f_0)^2|$ (eq. 3)")
    ax.semilogy(f, d["digital_paper"], color="tab:cyan", lw=1.4,
                label="3: digital correcting filter, eq. 4 (paper form)")
    ax.semilogy(f, d["digital_unity"], color="tab:blue", lw=1.0, ls="--", label="3': eq. 4, unity-DC form")
    ax.axvline(fs / 2, color="0.5", lw=0.8, ls=":")
    ax.text(fs / 2, 400.0, " Nyquist", color="0.4", fontsize=8)
    ax.set_xlim(0, fs)
    ax.set_ylim(1e-3, 2e3)
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("|gain| (ratio)")
    ax.set_title(f"AFCs at f0 = {f0:g} Hz, dT = 0.139 ms (fs = {fs:.0f} Hz)")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2, fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    ax = axes[1]
    sel = f <= fs / 2
    mech = d["mech"][sel]
    ff = f[sel]
    ax.semilogx(ff, _db(mech * d["analog"][sel]), color="tab:orange",
                label="mechanical x analog correcting (= 1 off resonance)")
    ax.semilogx(ff, _db(mech * d["digital_paper"][sel]), color="tab:cyan", label="mechanical x digital, paper form")
    ax.semilogx(ff, _db(mech * d["digital_unity"][sel]), color="tab:blue", ls="--",
                label="mechanical x digital, unity-DC")
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set_xlim(10, fs / 2)
    ax.set_ylim(-12, 3)
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("gain (dB)")
    ax.set_title("Mechanical x correcting, linear parts only\n(Diss left out: hence the dip at f0; eq. 5 adds it)",
                 fontsize=10)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2, fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_fig3(d: dict, path_f, path_nonl) -> None:
    """Fig. 3: resonance vs amplitude (simulation, HB, exact) and the Abel-inverted nonlinearity."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8, 5.2), constrained_layout=True)
    ax.plot(d["decay_amp"] / ARCMIN, d["decay_freq"], ".", ms=3, color="tab:blue",
            label="plant simulation: free decay, one point per cycle (paper damping)")
    ax.plot(d["grid"] / ARCMIN, d["hb"], color="tab:red", lw=1.5, label="harmonic balance of eq. 9 (resonance_hz)")
    ax.plot(d["grid"] / ARCMIN, d["exact"], color="k", lw=1.0, ls="--", label="exact period of eq. 2 without losses")
    ax.plot(d["samples_a"] / ARCMIN, d["samples_f"], "o", mfc="none", color="tab:green", ms=7,
            label="the 10 samples used for the Abel inversion")
    ax.axvline(3.0, color="0.6", lw=0.8, ls=":")
    shift = d["f_sim_3"] - d["f0"]
    ax.annotate(f"3 arcmin: F = {d['f_sim_3']:.2f} Hz ({shift:+.2f} Hz, {shift / d['f0'] * 100:+.3f} %)",
                xy=(3.0, d["f_sim_3"]), xytext=(3.3, d["f_sim_3"] + 1.0), arrowprops={"arrowstyle": "->"}, fontsize=9)
    ax.set_xlabel("dither amplitude (arcmin)")
    ax.set_ylabel("resonance frequency F(a) (Hz)")
    ax.set_title(f"Resonance vs amplitude implied by eq. 9\n(k1 = {d['k1']:.3g}, k2 = {d['k2']:.3g} rad, "
                 f"f0 = {d['f0']:g} Hz)", fontsize=11)
    ax.legend(loc="lower left", fontsize=8)
    ax.grid(True, alpha=0.3)
    fig.savefig(path_f, dpi=120)
    plt.close(fig)

    from sins_sim.models.suspension import nonl_array

    fig, axes = plt.subplots(1, 2, figsize=(13, 5.2), constrained_layout=True)
    ax = axes[0]
    r, fit = d["abel_sim"], d["fit_sim"]
    phi = r.phi
    ax.plot(phi / ARCMIN, nonl_array(phi, d["k1"], d["k2"]) / ARCSEC, color="k", lw=2.5, alpha=0.35,
            label="eq. 9 with the paper's k1, k2 (truth)")
    step = max(1, phi.size // 25)
    ax.plot(phi[::step] / ARCMIN, r.nonl[::step] / ARCSEC, "o", color="tab:blue", ms=4,
            label="eq. 7-8 from the 10 simulated samples")
    ax.plot(phi / ARCMIN, nonl_array(phi, fit.k1, fit.k2) / ARCSEC, color="tab:red", lw=1.2,
            label=f"eq. 9 fit: k1 = {fit.k1:.3g} ({fit.k1 / d['k1'] - 1:+.1%}), "
                  f"k2 = {fit.k2:.3g} ({fit.k2 / d['k2'] - 1:+.1%})")
    rp, fp = d["abel_paper"], d["fit_paper"]
    ax.plot(rp.phi / ARCMIN, rp.nonl / ARCSEC, color="tab:orange", lw=1.0, ls="--",
            label=f"paper's procedure (F0 by linear extrapolation): k1 {fp.k1 / d['k1'] - 1:+.0%}, "
                  f"k2 {fp.k2 / d['k2'] - 1:+.0%}")
    ax.set_xlabel(r"deflection $\varphi$ (arcmin)")
    ax.set_ylabel(r"Nonl($\varphi$) (arcsec)")
    ax.set_title("Elastic nonlinearity by Abel inversion (eq. 7-8) and the eq. 9 fit")
    ax.legend(loc="lower left", fontsize=8)
    ax.grid(True, alpha=0.3)
    ax = axes[1]
    truth = nonl_array(phi, d["k1"], d["k2"])
    ax.plot(phi / ARCMIN, (r.nonl - truth) / ARCSEC, color="tab:blue", lw=1.4,
            label="eq. 7-8, simulated samples, F0 refined by the fit")
    re = d["abel_exact"]
    ax.plot(re.phi / ARCMIN, (re.nonl - nonl_array(re.phi, d["k1"], d["k2"])) / ARCSEC, color="k", ls="--",
            label="eq. 7-8, exact F(a) samples, F0 refined")
    ax.plot(rp.phi / ARCMIN, (rp.nonl - nonl_array(rp.phi, d["k1"], d["k2"])) / ARCSEC, color="tab:orange",
            label="paper's procedure: F0 by linear extrapolation, samples as energy amplitudes")
    ax.plot(phi / ARCMIN, (nonl_array(phi, fit.k1, fit.k2) - truth) / ARCSEC, color="tab:red", lw=1.0, ls=":",
            label="eq. 9 fitted to the simulated samples")
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set_xlabel(r"deflection $\varphi$ (arcmin)")
    ax.set_ylabel(r"recovered Nonl minus eq. 9 truth (arcsec)")
    ax.set_title("Errors of the inversion: the F0 extrapolation dominates")
    ax.legend(loc="upper left", fontsize=8)
    ax.grid(True, alpha=0.3)
    fig.savefig(path_nonl, dpi=120)
    plt.close(fig)


def plot_fig4(d: dict, paper: dict, path) -> None:
    """Fig. 4: AFC set (synthetic measurement vs fitted model) and the sensitivity table."""
    plt = _pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(14, 5.6), constrained_layout=True, gridspec_kw={"width_ratios": [1.4, 1]})
    ax = axes[0]
    colors = ["tab:blue", "tab:orange", "tab:green", "tab:red"]
    for i, (vm, c) in enumerate(zip(d["volts"], colors)):
        ax.plot(d["freqs"], d["measured"][i] / ARCMIN, "o", color=c, ms=5,
                label=f"V_m = {vm:.3f} V: 'measured' (simulated, perturbed + noise)")
        ax.plot(d["freqs"], d["fit"].model[i] / ARCMIN, "x", color=c, ms=7)
        ax.plot(d["fdense"], d["hb"][i] / ARCMIN, "-", color=c, lw=0.9)
    ax.plot([], [], "kx", label="fitted model (eq. 2 simulated at the same points)")
    ax.plot([], [], "k-", lw=0.9, label="fitted model, harmonic balance (dense)")
    ax.set_xlabel("drive frequency (Hz)")
    ax.set_ylabel("steady dither amplitude (arcmin)")
    ax.set_title(f"AFC set, 4 voltages x 10 frequencies: fit RMS {d['fit'].rms / ARCSEC:.2f} arcsec "
                 f"(injected noise {np.std(d['measured'] - d['clean']) / ARCSEC:.2f} arcsec; paper 4 arcsec)",
                 fontsize=10)
    ax.set_ylim(0.0, 5.4)
    ax.legend(loc="upper left", fontsize=7.5)
    ax.grid(True, alpha=0.3)
    ax = axes[1]
    names = ["f0", "k1", "k2", "k3", "k4", "k5"]
    ours = [d["sens"][k]["rms_increase"] / ARCMIN for k in names]
    change = [d["sens"][k]["model_change_rms"] / ARCMIN for k in names]
    pap = [paper["sensitivity_arcmin_per_pct"][k] for k in names]
    x = np.arange(len(names))
    ax.bar(x - 0.27, pap, 0.27, color="0.6", label="paper (table)")
    ax.bar(x, ours, 0.27, color="tab:blue", label="sins-sim: RMS increase (paper's definition)")
    ax.bar(x + 0.27, change, 0.27, color="tab:cyan", label="sins-sim: RMS of the model change")
    ax.set_yscale("log")
    ax.set_xticks(x)
    ax.set_xticklabels([r"$\omega_0$", "k1", "k2", "k3", "k4", "k5"])
    ax.set_ylabel("sensitivity (arcmin per +1 %)")
    ax.set_title("Sensitivity of the AFC RMS to +1 % of each parameter")
    ax.legend(loc="upper right", fontsize=8)
    ax.grid(True, axis="y", which="both", alpha=0.3)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_fig5(d: dict, a: dict, path, masing: dict | None = None) -> None:
    """Fig. 5: end-to-end gain, simulated (markers) and linear analytic (lines)."""
    plt = _pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(14, 5.6), constrained_layout=True)
    f = d["freqs"]
    for ax, zoom in zip(axes, (False, True)):
        ax.semilogx(a["f"], _db(a["mech"]), color=_COLORS["raw"], lw=1.0,
                    label="linear: mechanical filter x FIR (curve 1)")
        ax.semilogx(a["f"], _db(a["eliminator"]), color=_COLORS["eliminator"], lw=1.0, alpha=0.7,
                    label="linear: mechanical x eliminator x FIR (curve 2)")
        ax.semilogx(a["f"], _db(a["correcting"]), color=_COLORS["correcting"], lw=1.0, alpha=0.7,
                    label="linear: mechanical x correcting (unity) x FIR (curve 3)")
        ax.semilogx(a["f"], _db(a["correcting_paper"]), color=_COLORS["correcting_paper"], lw=1.0, ls="--",
                    label="linear: mechanical x correcting (paper form) x FIR")
        ax.semilogx(a["f"], _db(a["pickoff"]), color=_COLORS["pickoff"], lw=1.0, alpha=0.7,
                    label="linear: pickoff stripping x FIR")
        ax.semilogx(a["f"], _db(a["fir"]), color="0.3", lw=0.8, ls=":", label="anti-alias FIR alone")
        for name, mk in (("raw", "s"), ("eliminator", "o"), ("correcting", "^"), ("correcting_paper", "v"),
                         ("pickoff", "D")):
            ax.semilogx(f, d["gains_db"][name], mk, color=_COLORS[name], ms=5, mfc="none" if name == "raw" else None,
                        label=f"simulated: {_LABELS[name]}")
        if masing is not None:
            ax.semilogx(masing["freqs"], masing["gains_db"]["correcting"], "+", color="k", ms=7,
                        label="simulated: correcting (unity), Masing hysteresis in plant and filter")
        ax.axhline(0.0, color="k", lw=0.5)
        ax.axvline(d["fd"], color="0.6", lw=0.6, ls=":")
        ax.set_xlabel("SINS rotation frequency (Hz)")
        ax.set_ylabel("gain from SINS angle to output (dB)")
        ax.grid(True, which="both", alpha=0.3)
        ax.set_xlim(70, 3700)
        if zoom:
            ax.set_ylim(-10, 4)
            ax.set_title("zoom: the correcting filter and the pickoff (dither 3 arcmin at "
                         f"{d['fd']:.2f} Hz)", fontsize=10)
        else:
            ax.set_ylim(-70, 40)
            ax.set_title("1 arcmin SINS sine to filter output, nonlinear plant, 1/16-fringe readout", fontsize=10)
            ax.legend(loc="lower left", fontsize=7)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_fig6(d: dict, paper: dict, implied: float, path) -> None:
    """Fig. 6: residual dither RMS after the correcting filter vs relative mismatch."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(9, 5.6), constrained_layout=True)
    m = d["m"]
    styles = {("quantised", "paper"): ("tab:cyan", "-", "paper form, 1/16-fringe quantum"),
              ("unquantised", "paper"): ("tab:cyan", ":", "paper form, no quantisation"),
              ("quantised", "unity"): ("tab:blue", "--", "unity-DC form, 1/16-fringe quantum"),
              ("quantised", "linear"): ("tab:purple", "-.", "paper form without Nonl (k1 = 0), quantised")}
    for key, (c, ls, lab) in styles.items():
        r = d[key]
        ax.semilogy(m, r["rms"] / ARCSEC, color=c, ls=ls, lw=1.4,
                    label=f"{lab}: min {r['rms_opt'] / ARCSEC:.2g} arcsec at {r['m_opt']:.5f}")
    ax.axvline(implied, color="tab:red", lw=1.0, ls="--", label=f"f0 / F(3 arcmin) - 1 by eq. 9 = {implied:.5f}")
    ax.axvline(paper["mismatch_optimum_calculated"], color="0.4", lw=1.0, ls="--", label="paper: calculated 0.0025")
    ax.plot([paper["mismatch_optimum_measured"]], [paper["residual_rms_at_optimum_arcsec"]], "k*", ms=12,
            label="paper: measured minimum 0.7 arcsec at 0.002")
    ax.set_xlabel("relative mismatch m: filter f0 = F_drive (1 + m)")
    ax.set_ylabel("residual RMS about the mean (arcsec)")
    ax.set_title(f"Stationary SINS: dither left after the correcting filter (F_drive = {d['fd']:.2f} Hz, 3 arcmin)")
    ax.legend(loc="lower left", fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_fig7(d: dict, path) -> None:
    """Fig. 7: impact on the SINS; outputs against the time they describe."""
    plt = _pyplot()
    run = d["runs"]["paper"]
    t_imp = d["t_imp"]
    off = run.offset_rad  # the start kick's block angle, constant long before the impact
    fig, axes = plt.subplots(3, 1, figsize=(11, 11), sharex=True, constrained_layout=True)
    ax = axes[0]
    tt = run.t
    for name in ("truth", "eliminator", "correcting", "pickoff"):
        if name == "truth":
            tw = np.linspace(t_imp - 0.005, t_imp + 0.03, 3000)
            y, _ = run.motion.angle_rate(tw)
            ax.plot((tw - t_imp) * 1e3, (y - off) / ARCMIN, color="k", lw=2.4, alpha=0.35,
                    label="1: true SINS rotation")
            continue
        ts = tt - run.delays_s[name]
        m = (ts >= t_imp - 0.005) & (ts <= t_imp + 0.03)
        ax.plot((ts[m] - t_imp) * 1e3, (run.outputs[name][m] - off) / ARCMIN, color=_COLORS[name], lw=1.2,
                label=_LABELS[name] + (" (aligned by its DC group delay)" if name == "eliminator" else " (aligned)"))
    ax.set_ylabel("SINS angle (arcmin)")
    ax.set_title(f"Impact: 3 arcmin step in 0.3 ms, then a 1.6 kHz block vibration; eliminator rings at "
                 f"{d['ring_hz']:.0f} Hz (period {d['ring_period_ms']:.2f} ms)", fontsize=10)
    ax.legend(loc="lower right", fontsize=8)
    ax.grid(True, alpha=0.3)
    panels = ((axes[1], ("eliminator", "correcting", "correcting_paper", "pickoff")),
              (axes[2], ("correcting", "correcting_paper", "pickoff")))
    for ax, names in panels:
        for name in names:
            ts = tt - run.delays_s[name]
            m = (ts >= t_imp - 0.005) & (ts <= t_imp + 0.03)
            err = run.outputs[name] - run.truth(name)
            pre = (ts >= t_imp - 0.005) & (ts < t_imp)
            err = err - err[pre].mean()
            ax.plot((ts[m] - t_imp) * 1e3, err[m] / ARCSEC, color=_COLORS[name], lw=1.0,
                    label=f"{_LABELS[name]}: RMS {d['err_rms'][name] / ARCSEC:.3g} arcsec over 0-30 ms")
        ax.set_ylabel("output - truth, less its\npre-impact mean (arcsec)")
        ax.axhline(0.0, color="k", lw=0.5)
        ax.legend(loc="upper right", fontsize=8)
        ax.grid(True, alpha=0.3)
    axes[2].set_title("zoom on the errors of the correcting filter and the pickoff baseline", fontsize=10)
    axes[2].set_xlabel("time from the impact (ms)")
    fig.savefig(path, dpi=120)
    plt.close(fig)
