"""The result of a diagnosis and its report: :class:`Diagnosis` (JSON keys) and :func:`write_report`.

:func:`write_report` writes ``report.md`` with the residual spectrum, the
residual envelope and the candidate ranking as PNG figures (matplotlib,
imported lazily with the Agg backend). See
:mod:`sins_sim.identification.diagnose`.

.. autosummary::

   Diagnosis
   write_report
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sins_sim.identification.localise import localise
from sins_sim.identification.refit import DiagnoseSettings
from sins_sim.io.recording import NOMINAL_KEYS, Recording
from sins_sim.models.suspension import SuspensionParams
from sins_sim.units import ARCSEC, DEG_PER_H

__all__ = ["Diagnosis", "write_report"]


@dataclass
class Diagnosis:
    """Everything a diagnosis found; :meth:`to_json` gives the issue's JSON keys."""

    recording: Recording
    floors: dict
    baseline: dict
    gap: dict
    candidates: list
    verdict: dict
    localisation: dict = field(default_factory=dict)
    timing: dict = field(default_factory=dict)
    skipped: dict = field(default_factory=dict)
    steps: list = field(default_factory=list)
    findings: list = field(default_factory=list)

    def to_json(self) -> dict:
        a = ARCSEC
        if self.findings:
            return _json_clean({"noise_floor_arcsec": None, "baseline": None, "gap": None, "candidates": [],
                                "verdict": dict(self.verdict), "findings": list(self.findings),
                                "skipped_effects": {}, "timing_s": dict(self.timing)})
        floor_all = math.sqrt(np.mean([fl["floor_rad"] ** 2 for fl in self.floors.values()]))
        base = self.baseline
        out = {
            "noise_floor_arcsec": floor_all / a,
            "noise_floor_axes_arcsec": {ax: fl["floor_rad"] / a for ax, fl in self.floors.items()},
            "baseline": {
                "residual_rms_arcsec": base["rms_rad"] / a,
                "residual_rms_axes_arcsec": {ax: f.rms / a for ax, f in base["fits"].items()},
                "params": {ax: _susp_dict(f.suspension) for ax, f in base["fits"].items()},
                "uncertainty": {ax: {k: f.sigma[k] for k in NOMINAL_KEYS} for ax, f in base["fits"].items()},
                "bias_drift": {ax: {"bias_deg_h": f.drift[0] / DEG_PER_H, "bias_rate_deg_h_per_h":
                                    f.drift[1] / DEG_PER_H * 3600.0}
                               for ax, f in base["fits"].items() if f.drift is not None},
            },
            "gap": _json_clean(self.gap),
            "candidates": [{"effect": c["effect"], "residual_rms_arcsec": c["rms_rad"] / a,
                            "gap_reduction": c["gap_reduction"], "score": c["score"],
                            "closes_gap": c["closes_gap"], "remaining_excess_arcsec": c["remaining_excess_arcsec"],
                            "p_heldout": c.get("p_heldout"), "p_f": c.get("p_f"),
                            "significant": c.get("significant"), "unresolved": c.get("unresolved"),
                            "plausibility": c.get("plausibility"),
                            "params": c["params"], "uncertainty": c["uncertainty"],
                            "nominal": {ax: _susp_dict(f.suspension) for ax, f in c["fits"].items()}}
                           for c in self.candidates],
            "verdict": dict(self.verdict),
            "skipped_effects": dict(self.skipped),
            "findings": list(self.findings),
            "flags": plausibility_flags(self.recording, base["fits"]),
            "timing_s": dict(self.timing),
        }
        return _json_clean(out)


#: A refit parameter this many times its nominal value (or this fraction of it) is flagged as implausible:
#: a unit's k1..k5 differ from the data sheet by tens of per cent (the refit's prior is 30 %), not by a factor.
IMPLAUSIBLE_FACTOR = 3.0


def plausibility_flags(rec: Recording, fits: dict) -> list:
    """Flags on refit parameters a unit cannot plausibly have, with the likely reason.

    A parameter at the physical limit the model declares (the refit clips its trials there,
    ``refit.physical_clip``), a sign flip of any ``k`` against the header's nominal value, or a ``k`` beyond
    :data:`IMPLAUSIBLE_FACTOR` times (or below 1 / that) its nominal value, or ``f0`` at the refit's
    bound (3 % off).
    """
    from sins_sim.identification.refit import physical_limits

    limits = physical_limits()
    out = []
    for a, f in fits.items():
        nom = rec.nominal[a]
        for k in NOMINAL_KEYS:
            val = float(getattr(f.suspension, k))
            ref = float(nom.get(k, 0.0))
            lo, hi = limits[k]
            if k == "k1":
                hi = min(hi, 2.0 * float(f.suspension.k2) * (1.0 - 1e-6))  # eq. 9 needs k1 < 2 k2
            mag = abs(val) if k == "k5" else val
            if any(math.isclose(mag, b, rel_tol=1e-5, abs_tol=0.0) for b in (lo, hi) if b != 0.0):
                out.append({"axis": a, "parameter": k, "value": val, "nominal": ref,
                            "ratio": val / ref if ref else None,
                            "message": f"axis {a}: {k} = {val:.4g} sits at the model's physical limit [{lo:g}, "
                                       f"{hi:g}]: the fit is implausible; likely cause: a header that does not "
                                       "describe the data (nominal values, fs_hz, quantum_rad, the axes' order, "
                                       "sins_angle)"})
                continue
            if ref == 0.0:
                continue
            ratio = val / ref
            why = None
            if k == "f0_hz":
                if abs(ratio - 1.0) > 0.029:
                    why = "f0 at the refit's bound (3 % from nominal): a header for another unit, or a drift"
            elif ratio < 0.0:
                why = (f"sign flip of {k} against the nominal value: the refit bends it to absorb an unmodelled "
                       "effect (see the candidates), or the header's sign convention differs")
            elif ratio > IMPLAUSIBLE_FACTOR or ratio < 1.0 / IMPLAUSIBLE_FACTOR:
                why = (f"{k} at {ratio:.2g} times nominal: the refit bends a weakly resolved parameter to absorb an "
                       "unmodelled effect, or the nominal value is wrong")
            if why:
                out.append({"axis": a, "parameter": k, "value": val, "nominal": ref, "ratio": ratio,
                            "message": f"axis {a}: {why}"})
    return out


def _pm(val: float, sd: float | None) -> str:
    """``value +- sigma`` with the value rounded to the uncertainty's second significant digit."""
    if sd is None or not math.isfinite(sd) or sd <= 0.0:
        return f"{val:.4g}"
    digits = max(0, 1 - int(math.floor(math.log10(sd))))
    if abs(val) >= 1e4 or abs(val) < 1e-3:
        e = int(math.floor(math.log10(abs(val)))) if val != 0 else 0
        m = max(0, e - int(math.floor(math.log10(sd))) + 1)
        return f"{val:.{m}e} +- {sd:.1e}"
    return f"{val:.{digits}f} +- {sd:.2g}"


def _susp_dict(s: SuspensionParams) -> dict:
    return {k: float(getattr(s, k)) for k in NOMINAL_KEYS}


def _json_clean(x):
    if isinstance(x, dict):
        return {k: _json_clean(val) for k, val in x.items() if not k.startswith("_")}
    if isinstance(x, (list, tuple)):
        return [_json_clean(val) for val in x]
    if isinstance(x, np.ndarray):
        return _json_clean(x.tolist())
    if isinstance(x, (np.floating, float)):
        return None if not math.isfinite(float(x)) else float(x)
    if isinstance(x, np.integer):
        return int(x)
    return x


# --- figures ---------------------------------------------------------------------------------------------
#: The figures of a diagnosis, each ``<kind>.png`` of the report folder (:func:`write_report`): after a refit
#: ``spectrum`` (the worst axis' residual spectrum before and after the best effect), ``envelope`` (the residual
#: RMS over time, every axis) and ``ranking`` (gap closed and held-out error per candidate, when one was fitted);
#: after data the checks refused, ``angle`` (measured minus table angle with the failures marked).
DIAGNOSIS_FIGURES = ("spectrum", "envelope", "ranking", "angle")


def figure_kinds(diag: Diagnosis) -> list:
    """The figures ``diag`` has data for, in the report's order (no empty figure)."""
    if diag.findings:
        return ["angle"]
    return ["spectrum", "envelope"] + (["ranking"] if diag.candidates else [])


def diagnosis_figure(diag: Diagnosis, kind: str, plt=None):
    """One figure of the report (:data:`DIAGNOSIS_FIGURES`) as a :class:`matplotlib.figure.Figure`, left open.

    Parameters
    ----------
    diag : Diagnosis
    kind : str
        One of :func:`figure_kinds` of ``diag``.
    plt : module, optional
        ``matplotlib.pyplot`` as the caller set it up (the report forces Agg; a notebook keeps its backend).

    Raises
    ------
    ValueError
        A kind ``diag`` has no data for.
    """
    if kind not in figure_kinds(diag):
        raise ValueError(f"diagnosis figure {kind!r}: this diagnosis has {', '.join(figure_kinds(diag))} "
                         f"(of {', '.join(DIAGNOSIS_FIGURES)})")
    if plt is None:
        import matplotlib.pyplot as plt
    return {"spectrum": _spectrum_figure, "envelope": _envelope_figure, "ranking": _ranking_figure,
            "angle": _angle_figure}[kind](diag, plt)


def _spectrum_figure(diag: Diagnosis, plt):
    """The worst axis' residual spectrum before and after the best effect, with the floor and the excess band."""
    rec = diag.recording
    axis = diag.gap["axis"] or max(rec.axes, key=lambda a: diag.baseline["fits"][a].rms)
    best = diag.candidates[0] if diag.candidates else None
    floor = diag.floors[axis]["floor_rad"]
    fig, ax = plt.subplots(figsize=(8, 4.5))
    loc = diag.localisation[axis]
    ax.semilogy(loc["spectrum"]["f"], np.sqrt(loc["spectrum"]["psd"]) / ARCSEC, label="baseline refit")
    if best is not None:
        lb = localise(best["fits"][axis].residual, floor, rec.fs_hz)
        ax.semilogy(lb["spectrum"]["f"], np.sqrt(lb["spectrum"]["psd"]) / ARCSEC, label=f"with {best['effect']}")
    ax.axhline(math.sqrt(loc["spectrum"]["floor_psd"]) / ARCSEC, color="k", ls="--", label="noise floor")
    if diag.gap["band_hz"]:
        ax.axvspan(*diag.gap["band_hz"], color="orange", alpha=0.2, label="band with the excess")
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("residual ASD (arcsec/sqrt(Hz))")
    ax.set_title(f"axis {axis}: residual spectrum")
    ax.legend()
    fig.tight_layout()
    return fig


def _envelope_figure(diag: Diagnosis, plt):
    """The residual RMS over time on every axis, before and after the best effect."""
    rec = diag.recording
    axis = diag.gap["axis"] or max(rec.axes, key=lambda a: diag.baseline["fits"][a].rms)
    best = diag.candidates[0] if diag.candidates else None
    floor = diag.floors[axis]["floor_rad"]
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for a in rec.axes:
        env = diag.localisation[a]["envelope"]
        ax.plot(env["t"], env["rms"] / ARCSEC, label=f"{a} baseline")
        if best is not None and a in best["fits"] and best["fits"][a] is not diag.baseline["fits"][a]:
            eb = localise(best["fits"][a].residual, diag.floors[a]["floor_rad"], rec.fs_hz)["envelope"]
            ax.plot(eb["t"], eb["rms"] / ARCSEC, ls=":", label=f"{a} with {best['effect']}")
    ax.axhline(floor / ARCSEC, color="k", ls="--", label="noise floor")
    if diag.gap["time_s"]:
        ax.axvspan(*diag.gap["time_s"], color="orange", alpha=0.15, label="window with the excess")
    ax.set_yscale("log")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("residual RMS (arcsec)")
    ax.set_title("residual envelope")
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def _ranking_figure(diag: Diagnosis, plt):
    """Per candidate effect the gap it closed and its held-out error (best first, from the top)."""
    from sins_sim.identification.verdict import MIN_PARTIAL

    names = [c["effect"] for c in diag.candidates]
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(9, 4))
    a1.barh(names[::-1], [c["gap_reduction"] for c in diag.candidates][::-1])
    a1.axvline(MIN_PARTIAL, color="0.5", ls=":", label=f"partly explained ({MIN_PARTIAL:g})")
    g_min = DiagnoseSettings().min_gap_reduction
    a1.axvline(g_min, color="k", ls="--", label=f"explained ({g_min:g}, default)")
    a1.legend(fontsize=7)
    a2.barh(names[::-1], [c["score"] for c in diag.candidates][::-1])
    if diag.verdict.get("baseline_score"):
        a2.axvline(diag.verdict["baseline_score"], color="k", ls="--", label="baseline")
        a2.legend()
    a1.set_xlabel("gap reduction (fraction of the excess power)")
    a2.set_xlabel("held-out residual RMS (arcsec)")
    a1.set_title("candidates: gap closed")
    a2.set_title("candidates: held-out error")
    fig.tight_layout()
    return fig


def _angle_figure(diag: Diagnosis, plt):
    """Each axis' measured angle minus the table angle over time, with the time of each finding marked."""
    from sins_sim.identification.recording_inputs import _table_angles

    rec = diag.recording
    t = np.arange(rec.n_samples) / rec.fs_hz
    table = _table_angles(rec)
    fig, axs = plt.subplots(len(rec.axes), 1, figsize=(8, 2.2 + 1.6 * len(rec.axes)), sharex=True, squeeze=False)
    for ax, a in zip(axs[:, 0], rec.axes):
        ax.plot(t, (rec.angle(a) - table[a]) / ARCSEC, lw=0.5)
        for f in diag.findings:
            if f["axis"] != a or f["time_s"] is None:
                continue
            if isinstance(f["time_s"], (list, tuple)):
                ax.axvspan(f["time_s"][0], f["time_s"][1], color="red", alpha=0.15)
            else:
                ax.axvline(f["time_s"], color="red", ls="--")
        ax.set_ylabel(f"{a} (arcsec)")
    axs[-1, 0].set_xlabel("time (s)")
    axs[0, 0].set_title("measured angle minus table angle; red: where a data check failed")
    fig.tight_layout()
    return fig


# --- report ----------------------------------------------------------------------------------------------
def write_report(diag: Diagnosis, report_dir, json_path=None) -> dict:
    """Write ``report.md`` with ``spectrum.png``, ``envelope.png``, ``ranking.png`` (and the JSON if asked).

    ``ranking.png`` is written only when at least one effect was fitted (no empty figure); ``report.md``
    links exactly the figures written.

    Returns the JSON dictionary.
    """
    out = Path(report_dir)
    out.mkdir(parents=True, exist_ok=True)
    js = diag.to_json()
    if json_path is not None:
        Path(json_path).parent.mkdir(parents=True, exist_ok=True)
        Path(json_path).write_text(json.dumps(js, indent=2) + "\n")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rec = diag.recording
    fs = rec.fs_hz
    if diag.findings:
        _write_findings_report(diag, js, out, plt)
        return js
    figures = []
    for kind in figure_kinds(diag):
        fig = diagnosis_figure(diag, kind, plt)
        fig.savefig(out / f"{kind}.png", dpi=110)
        plt.close(fig)
        figures.append(f"{kind}.png")
    v = js["verdict"]
    lines = [f"# Sim-to-real diagnosis: {rec.source}", "",
             f"- experiment `{rec.experiment}`, axes {', '.join(rec.axes)}, {rec.n_samples} samples at "
             f"{fs:g} Hz ({rec.duration_s:.3g} s), initial state `{rec.initial_state}`",
             f"- noise floor {js['noise_floor_arcsec']:.4g} arcsec RMS "
             f"(quantisation {rec.quantum_rad / ARCSEC / math.sqrt(12):.4g})",
             f"- verdict: **{v['effect']}**, status **{v['status']}**, explained fraction "
             f"{v['explained_fraction'] or 0.0:.3f}"
             + (f"; the data cannot tell it from {', '.join(v['alternatives'])}" if v.get("alternatives") else ""),
             f"- criterion: {v.get('criterion', '')}", ""]
    if v.get("steady_rate"):
        lines += [f"- steady rate ({v['steady_rate']['finding']}): {v['steady_rate']['message']}", ""]
    if v.get("unconfirmed"):
        lines += [f"- in-sample only: {v['unconfirmed']['message']}", ""]
    if v.get("effects"):
        lines += ["## Selected effects (in order)", "", "| effect | axes | share of the gap | parameters "
                  "(+- 1 sigma) | p held-out | p F-test |", "|---|---|---|---|---|---|"]
        for e in v["effects"]:
            pars = "; ".join(f"{ax}: " + ", ".join(f"{k} = {_pm(val, e['uncertainty'].get(ax, {}).get(k))}"
                                                    for k, val in pv.items()) for ax, pv in e["params"].items())
            axes = ", ".join(e.get("axes") or e["params"])
            lines.append(f"| {e['effect']} | {axes} | {e['explained_fraction']:.3f} | {pars} | {e['p_heldout']:.2g} | "
                         f"{e['p_f']:.2g} |")
        lines.append("")
    if v.get("remainder"):
        r = v["remainder"]
        lines += [f"- what remains sits on axis {r['axis']}, band {r['band_hz']} Hz, time window {r['time_s']} s", ""]
    if v.get("close_call"):
        from sins_sim.identification.discriminate import close_call_lines

        lines += close_call_lines(v["close_call"])
    if js.get("flags"):
        lines += ["## Implausible refit values", ""] + [f"- {f['message']}" for f in js["flags"]] + [""]
    lines += ["## Baseline refit (+- 1 sigma)", "",
              "| axis | residual RMS (arcsec) | excess (arcsec) | f0 (Hz) | k1 | k2 (rad) | k3 | k4 (1/rad) | "
              "k5 (rad/V) |", "|---|---|---|---|---|---|---|---|---|"]
    for a in rec.axes:
        p = js["baseline"]["params"][a]
        sd = js["baseline"]["uncertainty"][a]
        lines.append(f"| {a} | {js['baseline']['residual_rms_axes_arcsec'][a]:.4g} | "
                     f"{js['gap']['excess_rms_arcsec'][a]:.4g} | "
                     + " | ".join(_pm(p[k], sd[k]) for k in NOMINAL_KEYS) + " |")
    if js["baseline"].get("bias_drift"):
        lines += ["", "Readout bias drift, a nuisance profiled out of every fit (`b t + c t^2` of the angle): "
                  + "; ".join(f"{a}: bias {d['bias_deg_h']:.3g} deg/h, changing at {d['bias_rate_deg_h_per_h']:.3g} "
                              "deg/h per hour" for a, d in js["baseline"]["bias_drift"].items())]
    g = js["gap"]
    lines += ["", "## Gap", "", f"- significant: {g['significant']}, axis {g['axis']}, band {g['band_hz']} Hz, "
              f"peaks {g['peaks_hz']} Hz, time window {g['time_s']} s"]
    if g["operating_points"]:
        lines += ["", "| operating point t (s) | V_m (V) | f (Hz) | excess RMS (arcsec) |", "|---|---|---|---|"]
        for p in g["operating_points"][:10]:
            lines.append(f"| {p['t_s'][0]:.3f}-{p['t_s'][1]:.3f} | {p['v_m']:.4g} | {p['frequency_hz']:.3f} | "
                         f"{p['excess_rms_arcsec']:.4g} |")
    lines += ["", "## Candidates (best first)", "", "| effect | residual RMS (arcsec) | gap reduction | "
              "score (held-out RMS, arcsec) | p held-out | parameters (+- 1 sigma) |", "|---|---|---|---|---|---|"]
    for c in js["candidates"]:
        pars = "; ".join(f"{ax}: " + ", ".join(f"{k} = {_pm(val, c['uncertainty'].get(ax, {}).get(k))}"
                                                for k, val in pv.items()) for ax, pv in c["params"].items())
        ph = f"{c['p_heldout']:.2g}" if c.get("p_heldout") is not None else "-"
        lines.append(f"| {c['effect']} | {c['residual_rms_arcsec']:.4g} | {c['gap_reduction']:.3f} | "
                     f"{c['score']:.4g} | {ph} | {pars} |")
    for name, why in js["skipped_effects"].items():
        lines.append(f"| {name} | - | - | - | - | skipped: {why} |")
    unres = [c for c in js["candidates"] if c.get("unresolved")]
    if unres:
        lines += [""] + [f"- {c['effect']} comes after the other candidates: {c['unresolved']}" for c in unres]
    lines += _plausibility_lines(v)
    for f in figures:
        lines += ["", f"![{f[:-4]}]({f})"]
    lines.append("")
    (out / "report.md").write_text("\n".join(lines))
    return js


def _plausibility_lines(v: dict) -> list:
    """The report's account of implausible fits: the named effects' reasons and the candidates ranked after
    the plausible ones (``verdict.plausibility``, ``sins_sim.identification.plausibility``)."""
    pl = v.get("plausibility") or {}
    named = {k: p for k, p in (pl.get("named") or {}).items() if not p.get("plausible", True)}
    aside = pl.get("ranked_after") or []
    if not named and not aside:
        return []
    lines = ["", "## Plausibility", ""]
    for name, p in named.items():
        lines += [f"- the named effect {name} is implausible (no plausible candidate explains the gap): "
                  + "; ".join(p["reasons"])]
    for c in aside:
        lines += [f"- {c['effect']} is ranked after the plausible candidates: " + "; ".join(c["reasons"])]
    return lines


def _write_findings_report(diag: Diagnosis, js: dict, out: Path, plt) -> None:
    """``report.md`` and ``angle.png`` for a recording the data checks refused (no refit, no verdict).

    The figure shows each axis' measured angle minus the table angle over time, with the time of each
    finding marked, so that the user sees where the data went wrong.
    """
    rec = diag.recording
    fig = diagnosis_figure(diag, "angle", plt)
    fig.savefig(out / "angle.png", dpi=110)
    plt.close(fig)
    v = js["verdict"]
    lines = [f"# Sim-to-real diagnosis: {rec.source}", "",
             f"- experiment `{rec.experiment}`, axes {', '.join(rec.axes)}, {rec.n_samples} samples at "
             f"{rec.fs_hz:g} Hz ({rec.duration_s:.3g} s), initial state `{rec.initial_state}`",
             f"- verdict: **{v['effect']}**, status **{v['status']}**: the data checks refused the recording, "
             "so there is no refit and no verdict", "",
             "## Data check findings", "", "| check | axis | time (s) | finding |", "|---|---|---|---|"]
    for f in js["findings"]:
        ts = f["time_s"]
        when = f"{ts[0]:g}-{ts[1]:g}" if isinstance(ts, (list, tuple)) else ("-" if ts is None else f"{ts:g}")
        lines.append(f"| {f['check']} | {f['axis']} | {when} | {f['message']} |")
    lines += ["", "![angle](angle.png)", ""]
    (out / "report.md").write_text("\n".join(lines))
