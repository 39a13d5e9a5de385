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
from sins_sim.io.recording import NOMINAL_KEYS, Recording
from sins_sim.models.suspension import SuspensionParams
from sins_sim.units import ARCSEC

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

    def to_json(self) -> dict:
        a = ARCSEC
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
            },
            "gap": _json_clean(self.gap),
            "candidates": [{"effect": c["effect"], "residual_rms_arcsec": c["rms_rad"] / a,
                            "gap_reduction": c["gap_reduction"], "score": c["score"],
                            "closes_gap": c["closes_gap"], "remaining_excess_arcsec": c["remaining_excess_arcsec"],
                            "params": c["params"], "uncertainty": c["uncertainty"],
                            "nominal": {ax: _susp_dict(f.suspension) for ax, f in c["fits"].items()}}
                           for c in self.candidates],
            "verdict": dict(self.verdict),
            "skipped_effects": dict(self.skipped),
            "timing_s": dict(self.timing),
        }
        return _json_clean(out)


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


# --- report ----------------------------------------------------------------------------------------------
def write_report(diag: Diagnosis, report_dir, json_path=None) -> dict:
    """Write ``report.md`` with ``spectrum.png``, ``envelope.png``, ``ranking.png`` (and the JSON if asked).

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
    axis = diag.gap["axis"] or max(rec.axes, key=lambda a: diag.baseline["fits"][a].rms)
    best = diag.candidates[0] if diag.candidates else None
    floor = diag.floors[axis]["floor_rad"]
    # spectrum before / after the best effect
    fig, ax = plt.subplots(figsize=(8, 4.5))
    loc = diag.localisation[axis]
    ax.semilogy(loc["spectrum"]["f"], np.sqrt(loc["spectrum"]["psd"]) / ARCSEC, label="baseline refit")
    if best is not None:
        lb = localise(best["fits"][axis].residual, floor, fs)
        ax.semilogy(lb["spectrum"]["f"], np.sqrt(lb["spectrum"]["psd"]) / ARCSEC, label=f"with {best['effect']}")
    ax.axhline(math.sqrt(loc["spectrum"]["floor_psd"]) / ARCSEC, color="k", ls="--", label="noise floor")
    if diag.gap["band_hz"]:
        ax.axvspan(*diag.gap["band_hz"], color="orange", alpha=0.2, label="band with the excess")
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("residual ASD (arcsec/sqrt(Hz))")
    ax.set_title(f"axis {axis}: residual spectrum")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "spectrum.png", dpi=110)
    plt.close(fig)
    # envelope over time, every axis
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for a in rec.axes:
        env = diag.localisation[a]["envelope"]
        ax.plot(env["t"], env["rms"] / ARCSEC, label=f"{a} baseline")
        if best is not None and a in best["fits"] and best["fits"][a] is not diag.baseline["fits"][a]:
            eb = localise(best["fits"][a].residual, diag.floors[a]["floor_rad"], fs)["envelope"]
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
    fig.savefig(out / "envelope.png", dpi=110)
    plt.close(fig)
    # ranking
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(9, 4))
    names = [c["effect"] for c in diag.candidates]
    if names:
        a1.barh(names[::-1], [c["gap_reduction"] for c in diag.candidates][::-1])
        a1.axvline(0.6, color="k", ls="--")
        a2.barh(names[::-1], [c["score"] for c in diag.candidates][::-1])
        if diag.verdict.get("baseline_score"):
            a2.axvline(diag.verdict["baseline_score"], color="k", ls="--", label="baseline")
            a2.legend()
    a1.set_xlabel("gap reduction")
    a2.set_xlabel("held-out residual RMS (arcsec)")
    a1.set_title("candidates")
    fig.tight_layout()
    fig.savefig(out / "ranking.png", dpi=110)
    plt.close(fig)
    lines = [f"# Sim-to-real diagnosis: {rec.source}", "",
             f"- experiment `{rec.experiment}`, axes {', '.join(rec.axes)}, {rec.n_samples} samples at "
             f"{fs:g} Hz ({rec.duration_s:.3g} s), initial state `{rec.initial_state}`",
             f"- noise floor {js['noise_floor_arcsec']:.4g} arcsec RMS "
             f"(quantisation {rec.quantum_rad / ARCSEC / math.sqrt(12):.4g})",
             f"- verdict: **{js['verdict']['effect']}** (gap reduction {js['verdict']['gap_reduction']:.3f}"
             + (f"; the data cannot tell it from {', '.join(js['verdict']['alternatives'])}"
                if js["verdict"].get("alternatives") else "") + ")", "",
             "## Baseline refit", "",
             "| axis | residual RMS (arcsec) | excess (arcsec) | f0 (Hz) | k1 | k2 | k3 | k4 | k5 |",
             "|---|---|---|---|---|---|---|---|---|"]
    for a in rec.axes:
        p = js["baseline"]["params"][a]
        lines.append(f"| {a} | {js['baseline']['residual_rms_axes_arcsec'][a]:.4g} | "
                     f"{js['gap']['excess_rms_arcsec'][a]:.4g} | {p['f0_hz']:.5f} | {p['k1']:.4g} | {p['k2']:.4g} | "
                     f"{p['k3']:.4g} | {p['k4']:.4g} | {p['k5']:.4g} |")
    g = js["gap"]
    lines += ["", "## Gap", "", f"- significant: {g['significant']}, axis {g['axis']}, band {g['band_hz']} Hz, "
              f"peaks {g['peaks_hz']} Hz, time window {g['time_s']} s"]
    if g["operating_points"]:
        lines += ["", "| operating point t (s) | V_m (V) | f (Hz) | excess RMS (arcsec) |", "|---|---|---|---|"]
        for p in g["operating_points"][:10]:
            lines.append(f"| {p['t_s'][0]:.3f}-{p['t_s'][1]:.3f} | {p['v_m']:.4g} | {p['frequency_hz']:.3f} | "
                         f"{p['excess_rms_arcsec']:.4g} |")
    lines += ["", "## Candidates (best first)", "", "| effect | residual RMS (arcsec) | gap reduction | "
              "score (held-out RMS, arcsec) | parameters |", "|---|---|---|---|---|"]
    for c in js["candidates"]:
        lines.append(f"| {c['effect']} | {c['residual_rms_arcsec']:.4g} | {c['gap_reduction']:.3f} | "
                     f"{c['score']:.4g} | {json.dumps(c['params'])} |")
    for name, why in js["skipped_effects"].items():
        lines.append(f"| {name} | - | - | - | skipped: {why} |")
    lines += ["", "![spectrum](spectrum.png)", "", "![envelope](envelope.png)", "", "![ranking](ranking.png)", ""]
    (out / "report.md").write_text("\n".join(lines))
    return js
