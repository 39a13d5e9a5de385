"""Lock-in in the loop: dynamic lock-in of a dithered RLG and the random walk dithered lock-in leaves.

``sins-sim lockin-study --out DIR [--quick]`` runs the SINS engine's per-axis chain
(:class:`~sins_sim.simulation.channel.ChannelChain`, the one every axis of ``simulate_sins`` runs)
with the catalogue's ``lock_in`` effect (the Adler equation on the Sagnac phase,
:mod:`sins_sim.models.effects`) on the default unit's x axis (386 Hz, paper suspension, closed-loop
drive), and writes ``lockin.json``, ``arw_vs_lockin.png``, ``dynamic_lockin.png`` and ``report.md``.

Physics and the analytic results it is set beside (Sagnac phase ``psi``, ``K = 2 pi / fringe``
rad of phase per rad of rotation, lock-in rate ``Omega_L``, dither angle ``a sin(w_D t)``, peak
dither rate ``Omega_D = a w_D``):

* Adler equation ``dpsi/dt = K (Omega_in + a w_D cos w_D t) - K Omega_L sin psi``
  (Aronowitz 1971, "The laser gyro", Laser Applications vol. 1, ch. 4; Chow et al. 1985,
  Rev. Mod. Phys. 57, 61, sec. II-III).
* Dynamic lock-in (constant dither amplitude): with ``psi = phi + K a sin w_D t`` and the
  Jacobi-Anger expansion, near ``K Omega_in = n w_D`` the slow phase obeys
  ``dphi/dt = K Omega_in - n w_D - K Omega_L (-1)^n J_n(K a) sin phi``: the output rate is stuck
  at ``n w_D / K = n f_D fringe`` for ``|Omega_in - n f_D fringe| <= Omega_L |J_n(K a)|``
  (zone ``n``; zone 0 is the residual lock-in band around zero rate). Same averaging as
  Aronowitz 1971 and Chow et al. 1985 (the "dynamic lock-in" zones of a dithered gyro); derived in
  ``report.md``.
* Random walk with random dither amplitude: at each dither reversal the rate passes zero with
  slope ``dOmega/dt = a w_D^2``; the stationary-phase (Fresnel) integral of the Adler term gives
  an angle error ``dtheta = -Omega_L sqrt(2 pi / (K a w_D^2)) sin(psi_c + pi/4)``. With the
  reversal phase ``psi_c`` uniform and independent from reversal to reversal (what the random
  amplitude modulation is for), ``2 f_D`` reversals per second give the angle random walk
  ``N = Omega_L / sqrt(K Omega_D)`` (rad/sqrt(s)), i.e. ``N^2 = Omega_L^2 / (K a w_D)``: the
  classic result that the random walk is proportional to the lock-in rate and inversely to the
  square root of the dither rate and the scale factor (Aronowitz 1971; Killpatrick 1967, IEEE
  Spectrum 4(10), 44, who introduced the random dither; Chow et al. 1985 sec. III; the
  Fokker-Planck treatment of Tehrani and Soltanieh 2020, arXiv:2005.09749, finds the same
  proportionality to the lock-in rate and to 1/sqrt(dither frequency)). The printed equations of
  these sources were not available to this project; the formula above is derived in
  ``report.md`` and is what the study compares with.

Measurements. ``lock_in_error`` of the chain (``e = phi_meas - phi_rlg``, the angle the lock-in adds)
at the filter rate gives the random walk without the readout's quantisation: the Allan deviation
(``sins_sim.navigation.allan``, allantools ``oadev``) is read at its slope -1/2 (``fit_allan``), and
``N`` also as ``sqrt(Var[e(t + T) - e(t)] / T)`` over whole dither periods. The correcting filter's
output error (the full readout: quantum, FIR, eq. 5) gives the same through the whole chain at the
reference point.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
from scipy import special

from sins_sim.models.effects import make_effect
from sins_sim.navigation.allan import allan_deviation, fit_allan
from sins_sim.simulation.channel import ChannelChain, DriveControl
from sins_sim.units import ARCMIN, ARCSEC, DEG, FRINGE_RAD

__all__ = ["LockinRun", "arw_analytic_rad_rt_s", "zone_half_width_rad_s", "run_lockin", "measure_arw",
           "dynamic_lockin_sweep", "lockin_study", "RAD_RT_S_TO_DEG_RT_H"]

#: 1 rad/sqrt(s) in deg/sqrt(h).
RAD_RT_S_TO_DEG_RT_H = 60.0 / DEG
K_PHASE = 2.0 * math.pi / FRINGE_RAD


def arw_analytic_rad_rt_s(omega_l: float, amplitude_rad: float, dither_hz: float, fringe_rad: float = FRINGE_RAD):
    """``N = Omega_L / sqrt(K a w_D)`` (rad/sqrt(s)), ``K = 2 pi / fringe`` (module docstring)."""
    k = 2.0 * math.pi / fringe_rad
    return omega_l / math.sqrt(k * amplitude_rad * 2.0 * math.pi * dither_hz)


def zone_half_width_rad_s(n: int, omega_l: float, amplitude_rad: float, fringe_rad: float = FRINGE_RAD):
    """Half-width ``Omega_L |J_n(K a)|`` of dynamic lock-in zone ``n`` (rad/s)."""
    return omega_l * abs(float(special.jv(n, 2.0 * math.pi / fringe_rad * amplitude_rad)))


@dataclasses.dataclass
class LockinRun:
    """What :func:`run_lockin` returns (SI, rad)."""

    fs_hz: float
    dither_hz: float
    amplitude_rad: float
    error: np.ndarray  # lock-in angle error e at the filter rate (rad)
    correcting_error: np.ndarray  # correcting filter (unity DC) output minus the time-aligned truth (rad)
    chain: object


def _imu():
    from sins_sim.config.imu import load_imu

    return load_imu(Path(__file__).resolve().parents[2] / "configs" / "default-imu.yaml")


def _chain(omega_l, amplitude_rad, depth, seed, phase_rad=0.0):
    cfg = _imu().channels[0]
    cfg = dataclasses.replace(cfg, drive=dataclasses.replace(cfg.drive, amplitude_rad=amplitude_rad),
                              filter_suspension=None)
    control = DriveControl(mode="closed_loop", modulation_depth=depth)
    eff = () if omega_l <= 0.0 else (make_effect("lock_in", threshold_rad_s=omega_l, phase_rad=phase_rad),)
    ch = ChannelChain(cfg, control, np.random.default_rng([seed, 0]), np.random.default_rng([seed, 1]), axis="x",
                      effects=eff, path="reference")
    ch.reset(0.0, 0.0)
    return ch


def _advance(ch, i0, n_steps, rate_in, t_ref, chunk=72000):
    """Run ``n_steps`` plant steps with the block turning at ``rate_in`` from ``t_ref``; decimated e and truth."""
    h = ch.plant.h
    r = ch.r_dec
    errs, cors, truth = [], [], []
    i = i0
    end = i0 + n_steps
    while i < end:
        j = min(end, i + chunk)
        t = np.arange(i + 1, j + 1) * h
        ang = rate_in * (t - t_ref)
        out = ch.run(i, np.ascontiguousarray(ang), np.full(j - i, float(rate_in)))
        errs.append(out["lock_in_error"][r - 1::r] if "lock_in_error" in out else np.zeros((j - i) // r))
        cors.append(out["correcting"])
        k = np.arange(i // r, j // r)
        # correcting output k describes the block at t_k - (FIR delay + one filter sample)
        tk = k / (ch.cfg.filter_rate_hz) - (ch.readout.delay_s + 1.0 / ch.cfg.filter_rate_hz)
        truth.append(rate_in * (tk - t_ref))
        i = j
    return np.concatenate(errs), np.concatenate(cors) - np.concatenate(truth), i


def run_lockin(omega_l: float, amplitude_rad: float = 3.0 * ARCMIN, depth: float = 0.05, duration_s: float = 60.0,
               settle_s: float = 1.5, rate_in: float = 0.0, seed: int = 0) -> LockinRun:
    """The x chain of the default unit with lock-in, from rest; records after ``settle_s`` (s)."""
    ch = _chain(omega_l, amplitude_rad, depth, seed)
    fp = ch.cfg.plant.rate_hz
    r = ch.r_dec
    n_settle = int(round(settle_s * fp / r)) * r
    n_run = int(round(duration_s * fp / r)) * r
    _, _, i = _advance(ch, 0, n_settle, rate_in, 0.0)
    e, c, _ = _advance(ch, i, n_run, rate_in, 0.0)
    return LockinRun(ch.cfg.filter_rate_hz, ch.drive.frequency_hz, ch.amp_meas, e, c, ch)


def measure_arw(x: np.ndarray, fs_hz: float, dither_hz: float, window_s: float = 0.25) -> dict:
    """ARW of an angle record (rad at ``fs_hz``): Allan fit and increment variance, rad/sqrt(s).

    ``increment``: ``sqrt(Var[x(t + T) - x(t)] / T)`` over non-overlapping windows ``T`` of whole
    dither periods (about ``window_s``), the mean removed. ``allan``: ``fit_allan``'s ARW term
    (slope -1/2 of the overlapping Allan deviation), NaN if the fit finds none.
    """
    periods = max(1, int(round(window_s * dither_hz)))
    m = int(round(periods / dither_hz * fs_hz))
    nw = (x.size - 1) // m
    d = x[m * np.arange(1, nw + 1)] - x[m * np.arange(nw)]
    t_w = m / fs_hz
    inc = math.sqrt(np.var(d) / t_w) if nw >= 4 else math.nan
    curve = allan_deviation(x, fs_hz, data="angle", per_decade=8)
    fit = fit_allan(curve, "gyro")
    arw_deg = fit.readings().get("arw_deg_rt_h", math.nan)
    allan = arw_deg / RAD_RT_S_TO_DEG_RT_H if arw_deg == arw_deg else math.nan
    return {"increment_rad_rt_s": inc, "allan_rad_rt_s": allan, "windows": nw, "window_s": t_w,
            "curve": curve}


def dynamic_lockin_sweep(omega_l: float, rates_rad_s, amplitude_rad: float = 3.0 * ARCMIN, settle_s: float = 1.5,
                         measure_s: float = 0.4, seed: int = 0) -> dict:
    """Output rate vs input rate with a constant-amplitude dither (``modulation_depth`` 0).

    The chain settles at rest, then for each input rate a copy of it turns at that rate; the
    output rate is the input plus the slope of the lock-in error (least squares over the last
    ``measure_s`` minus a 0.1 s transient).
    """
    out = []
    for w in rates_rad_s:
        ch = _chain(omega_l, amplitude_rad, 0.0, seed)  # the same settled state each time (deterministic)
        fp = ch.cfg.plant.rate_hz
        r = ch.r_dec
        n_settle = int(round(settle_s * fp / r)) * r
        _, _, i = _advance(ch, 0, n_settle, 0.0, 0.0)
        n_run = int(round((measure_s + 0.1) * fp / r)) * r
        e, _, _ = _advance(ch, i, n_run, float(w), i / fp)
        fs = ch.cfg.filter_rate_hz
        k0 = int(round(0.1 * fs))
        t = np.arange(e.size - k0) / fs
        slope = np.polyfit(t, e[k0:], 1)[0]
        out.append(float(w) + float(slope))
    return {"input_rad_s": [float(w) for w in rates_rad_s], "output_rad_s": out,
            "dither_hz": ch.drive.frequency_hz, "amplitude_rad": ch.amp_meas, "omega_l_rad_s": omega_l}


def _slope(x, y):
    lx, ly = np.log(np.asarray(x)), np.log(np.asarray(y))
    return float(np.polyfit(lx, ly, 1)[0])


def _arw_point(omega_l, amplitude_rad, depth, duration_s, seed):
    run = run_lockin(omega_l, amplitude_rad=amplitude_rad, depth=depth, duration_s=duration_s, seed=seed)
    m = measure_arw(run.error, run.fs_hz, run.dither_hz)
    an = arw_analytic_rad_rt_s(omega_l, run.amplitude_rad, run.dither_hz)
    c = RAD_RT_S_TO_DEG_RT_H
    return {"omega_l_rad_s": omega_l, "omega_l_deg_h": omega_l / DEG * 3600.0,
            "amplitude_arcmin": amplitude_rad / ARCMIN, "amplitude_measured_arcmin": run.amplitude_rad / ARCMIN,
            "modulation_depth": depth, "dither_hz": run.dither_hz, "duration_s": duration_s,
            "arw_increment_deg_rt_h": m["increment_rad_rt_s"] * c, "arw_allan_deg_rt_h": m["allan_rad_rt_s"] * c,
            "arw_analytic_deg_rt_h": an * c, "ratio_increment_to_analytic": m["increment_rad_rt_s"] / an,
            "windows": m["windows"]}


def lockin_study(out, quick: bool = False, seed: int = 0, progress=print, force: bool = False, manifest=None) -> dict:
    """Run the study and write ``lockin.json``, two figures and ``report.md`` into ``out``.

    Parameters
    ----------
    out : path
        Result folder (written atomically).
    quick : bool
        Shorter runs and fewer points (about 1 min instead of about 5).
    seed : int
        Seed of the amplitude-modulation draws.
    progress : callable(str) or None
    force : bool
        Replace an existing result folder ``out`` (default: refuse it).
    manifest : sins_sim.jobs.manifest.Manifest, optional
        Written into the folder as ``manifest.json`` (default: one without a command line).

    Returns
    -------
    dict
        What ``lockin.json`` holds.
    """
    from sins_sim.jobs.manifest import Manifest, result_dir
    from sins_sim.plots.lockin import plot_arw_vs_lockin, plot_dynamic_lockin

    if manifest is None:
        manifest = Manifest("lockin-study", settings={"quick": quick, "seed": seed})

    say = progress or (lambda s: None)
    dur = 20.0 if quick else 120.0
    ref_a, ref_d, ref_l = 3.0 * ARCMIN, 0.05, 4e-3
    lockins = [1e-3, 4e-3, 1.6e-2] if quick else [5e-4, 1e-3, 2e-3, 4e-3, 8e-3, 1.6e-2, 3.2e-2]
    res = {"formula": {"arw": "N = Omega_L / sqrt(K a w_D), K = 2 pi / fringe, w_D = 2 pi f_D",
                       "zones": "|Omega_in - n f_D fringe| <= Omega_L |J_n(K a)|",
                       "fringe_rad": FRINGE_RAD},
           "settings": {"quick": quick, "duration_s": dur, "seed": seed, "reference": {
               "amplitude_arcmin": 3.0, "modulation_depth": ref_d, "omega_l_rad_s": ref_l}}}
    say("ARW vs lock-in rate")
    res["vs_lockin"] = [_arw_point(ol, ref_a, ref_d, dur, seed) for ol in lockins]
    small = [p for p in res["vs_lockin"] if p["omega_l_rad_s"] <= 1.6e-2]
    res["slope_vs_lockin"] = _slope([p["omega_l_rad_s"] for p in small], [p["arw_increment_deg_rt_h"] for p in small])
    say("ARW vs dither amplitude")
    res["vs_amplitude"] = [_arw_point(ref_l, a * ARCMIN, ref_d, dur, seed) for a in ((2.0, 4.0) if quick else
                                                                                    (2.0, 2.5, 3.5, 4.0))]
    amps = res["vs_amplitude"] + [p for p in res["vs_lockin"] if p["omega_l_rad_s"] == ref_l]
    res["slope_vs_amplitude"] = _slope([p["amplitude_measured_arcmin"] for p in amps],
                                       [p["arw_increment_deg_rt_h"] for p in amps])
    say("ARW vs modulation depth")
    res["vs_depth"] = [_arw_point(ref_l, ref_a, d, dur, seed) for d in ((0.005, 0.2) if quick else
                                                                          (0.002, 0.005, 0.02, 0.1, 0.2))]
    say("in the loop: the correcting filter's output")
    run = run_lockin(ref_l, amplitude_rad=ref_a, depth=ref_d, duration_s=dur, seed=seed)
    m = measure_arw(run.correcting_error, run.fs_hz, run.dither_hz)
    base = run_lockin(0.0, amplitude_rad=ref_a, depth=ref_d, duration_s=dur, seed=seed)
    mb = measure_arw(base.correcting_error, base.fs_hz, base.dither_hz)
    c = RAD_RT_S_TO_DEG_RT_H
    res["correcting_filter"] = {
        "omega_l_rad_s": ref_l, "arw_allan_deg_rt_h": m["allan_rad_rt_s"] * c,
        "arw_allan_without_lock_in_deg_rt_h": mb["allan_rad_rt_s"] * c,
        "arw_analytic_deg_rt_h": arw_analytic_rad_rt_s(ref_l, run.amplitude_rad, run.dither_hz) * c}
    say("dynamic lock-in (constant amplitude)")
    ol_dyn = 2e-2
    probe = run_lockin(ol_dyn, amplitude_rad=ref_a, depth=0.0, duration_s=0.2)
    f_d, a_meas = probe.dither_hz, probe.amplitude_rad
    sweeps = []
    npt = 13 if quick else 31
    for n in (0, 1):
        w = zone_half_width_rad_s(n, ol_dyn, a_meas)
        centre = n * f_d * FRINGE_RAD
        rates = centre + np.linspace(-2.5 * w, 2.5 * w, npt)
        sw = dynamic_lockin_sweep(ol_dyn, rates, amplitude_rad=ref_a, seed=seed)
        out_r = np.array(sw["output_rad_s"])
        stuck = np.abs(out_r - centre) < 1e-7
        inside = np.array(sw["input_rad_s"])[stuck]
        sweeps.append({"n": n, "omega_l_rad_s": ol_dyn, "zone_center_rad_s": centre, "half_width_analytic_rad_s": w,
                       "half_width_measured_rad_s": (float(np.max(np.abs(inside - centre))) if inside.size else 0.0),
                       "grid_step_rad_s": float(rates[1] - rates[0]), **sw})
    res["dynamic_lockin"] = sweeps

    with result_dir(out, manifest, force=force) as tmp:
        tmp = Path(tmp)
        ols = np.geomspace(min(lockins) / 1.5, max(lockins) * 1.5, 50)
        f_ref = res["vs_lockin"][0]
        an = [arw_analytic_rad_rt_s(o, f_ref["amplitude_measured_arcmin"] * ARCMIN, f_ref["dither_hz"]) * c
              for o in ols]
        plot_arw_vs_lockin(res["vs_lockin"], {"omega_l_deg_h": ols / DEG * 3600.0, "arw_deg_rt_h": an,
                                              "label": "analytic N = Omega_L / sqrt(K a w_D)"},
                           tmp / "arw_vs_lockin.png",
                           title=f"ARW vs lock-in rate: a = 3 arcmin, f_D = {f_ref['dither_hz']:.1f} Hz, "
                                 f"modulation depth {ref_d:g}")
        k = 3600.0 / DEG
        plot_dynamic_lockin([{"input_deg_h": np.array(s["input_rad_s"]) * k,
                              "output_deg_h": np.array(s["output_rad_s"]) * k,
                              "zone_center_deg_h": s["zone_center_rad_s"] * k,
                              "half_width_deg_h": s["half_width_analytic_rad_s"] * k,
                              "label": f"zone n = {s['n']}, Omega_L = {ol_dyn / DEG * 3600:.0f} deg/h"}
                             for s in sweeps], tmp / "dynamic_lockin.png")
        (tmp / "lockin.json").write_text(json.dumps(res, indent=1))
        (tmp / "report.md").write_text(_report(res))
    return res


def _ratio_rows(points, vs_lockin, key, fmt) -> list:
    """Table rows (``key``, measured ARW, analytic, ratio) of one series plus the reference point of the
    lock-in series (Omega_L = 4e-3 rad/s), sorted by ``key``."""
    ref = [q for q in vs_lockin if q["omega_l_rad_s"] == 4e-3]
    return [f"| {format(p[key], fmt)} | {p['arw_increment_deg_rt_h']:.4g} | {p['arw_analytic_deg_rt_h']:.4g} | "
            f"{p['ratio_increment_to_analytic']:.3f} |" for p in sorted(points + ref, key=lambda q: q[key])]


def _report(res) -> str:
    c = res["correcting_filter"]
    lines = ["# Lock-in in the loop", "",
             "The SINS engine's x chain (default unit, 386 Hz paper suspension, closed-loop drive) with the "
             "catalogue's `lock_in` effect (Adler equation on the Sagnac phase), produced by "
             "`sins-sim lockin-study`" + (" --quick" if res["settings"]["quick"] else "") + ".", "",
             "## Analytic results compared", "",
             "Adler: `dpsi/dt = K Omega(t) - K Omega_L sin psi`, `K = 2 pi / fringe` (fringe = 2.42 arcsec), "
             "dither rate `a w_D cos w_D t` (Aronowitz 1971, *The laser gyro*, Laser Applications vol. 1; Chow et "
             "al. 1985, Rev. Mod. Phys. 57, 61).", "",
             "* Dynamic lock-in (constant amplitude): `psi = phi + K a sin w_D t`, Jacobi-Anger, keep the resonant "
             "term: `dphi/dt = K Omega_in - n w_D - K Omega_L (-1)^n J_n(K a) sin phi`, so the output is stuck at "
             "`n f_D fringe` while `|Omega_in - n f_D fringe| <= Omega_L |J_n(K a)|`.",
             "* Random walk (random amplitude): near a reversal `Omega = a w_D^2 (t - t_c)`; the Fresnel integral "
             "of the Adler term gives `dtheta = -Omega_L sqrt(2 pi / (K a w_D^2)) sin(psi_c + pi/4)` per reversal; "
             "with `psi_c` uniform and independent, `E[dtheta^2] = pi Omega_L^2 / (K a w_D^2)`, and with `w_D / pi` "
             "reversals per second `N^2 = Omega_L^2 / (K a w_D)`: **N = Omega_L / sqrt(K Omega_D)**, `Omega_D = a w_D` "
             "the peak dither rate. This is the classic form (proportional to the lock-in rate, inversely to the "
             "square root of scale factor and peak dither rate; Aronowitz 1971, Killpatrick 1967 IEEE Spectrum 4(10) "
             "44, Chow et al. 1985; Tehrani & Soltanieh 2020 arXiv:2005.09749 find the same dependence on lock-in "
             "rate and dither frequency). The printed equations of those sources were not available here: the "
             "formula is derived above and the comparison is with it.", "",
             "## ARW vs lock-in rate (a = 3 arcmin, depth %.3g)" % res["settings"]["reference"]["modulation_depth"], "",
             "| Omega_L (rad/s) | Omega_L (deg/h) | ARW increment (deg/rt h) | ARW Allan (deg/rt h) | analytic | ratio |",
             "|---|---|---|---|---|---|"]
    for p in res["vs_lockin"]:
        lines.append(f"| {p['omega_l_rad_s']:.3g} | {p['omega_l_deg_h']:.0f} | {p['arw_increment_deg_rt_h']:.4g} | "
                     f"{p['arw_allan_deg_rt_h']:.4g} | {p['arw_analytic_deg_rt_h']:.4g} | "
                     f"{p['ratio_increment_to_analytic']:.3f} |")
    lines += ["", f"Log-log slope (Omega_L <= 1.6e-2 rad/s): **{res['slope_vs_lockin']:.3f}** (analytic 1).", "",
              "## ARW vs dither amplitude (Omega_L = 4e-3 rad/s)", "",
              "| a measured (arcmin) | ARW increment | analytic | ratio |", "|---|---|---|---|"]
    lines += _ratio_rows(res["vs_amplitude"], res["vs_lockin"], "amplitude_measured_arcmin", ".3f")
    lines += ["", f"Log-log slope vs amplitude: **{res['slope_vs_amplitude']:.3f}** (analytic -0.5).", "",
              "## ARW vs modulation depth (Omega_L = 4e-3 rad/s, a = 3 arcmin)", "",
              "| depth | ARW increment | analytic | ratio |", "|---|---|---|---|"]
    lines += _ratio_rows(res["vs_depth"], res["vs_lockin"], "modulation_depth", "g")
    lines += ["", "## Through the whole chain", "",
              f"Correcting filter (eq. 5, unity DC) output minus truth, Allan ARW term: {c['arw_allan_deg_rt_h']:.4g} "
              f"deg/rt h with lock-in Omega_L = {c['omega_l_rad_s']:g} rad/s (analytic {c['arw_analytic_deg_rt_h']:.4g}); "
              f"without lock-in {c['arw_allan_without_lock_in_deg_rt_h']:.4g} (NaN: no slope -1/2 term found).", "",
              "## Dynamic lock-in (constant amplitude, Omega_L = 2e-2 rad/s)", "",
              "| zone n | centre n f_D fringe (rad/s) | half-width analytic Omega_L J_n(K a) | half-width measured "
              "(largest stuck input offset; grid step) |", "|---|---|---|---|"]
    for s in res["dynamic_lockin"]:
        lines.append(f"| {s['n']} | {s['zone_center_rad_s']:.5g} | {s['half_width_analytic_rad_s']:.3g} | "
                     f"{s['half_width_measured_rad_s']:.3g} ({s['grid_step_rad_s']:.2g}) |")
    lines += ["", "Figures: `arw_vs_lockin.png`, `dynamic_lockin.png`.", ""]
    return "\n".join(lines)
