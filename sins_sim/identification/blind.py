"""Blind evaluation of the sim-to-real diagnosis (``sins-sim diagnose-eval``).

:func:`evaluate` generates recordings whose content only this module knows:
every catalogue effect at a random strength and operating point, ``none``
cases, and cases with a disturbance outside the catalogue; the unit's true
parameters differ from the nominal ones in the header as a real unit's
would (f0 by 0.2 %, k1..k5 by 5 %, one sigma), and the recordings differ
from the diagnosis' own model in ways that are no effect (the truth is
integrated at 72 kHz, by the exact or the RK4 integrator, with or without
white readout noise, starting at rest or, for clean and off-catalogue
cases, mid-operation). The diagnosis sees
the recording only; its verdict is compared with the hidden label:
``none`` for clean cases, ``unknown`` for off-catalogue ones, the effect's
name otherwise.

Which experiment each label is recorded in (:data:`EXPERIMENTS`) follows
what the experiment can show. Without table motion, ``piezo_lag`` and
``readout_delay`` are the same thing to within a gain (both delay a narrow
band response; the diagnosis lists the other as an alternative), and
``viscous_damping`` is absorbed exactly by a refit of ``k3, k4`` (for a
sinusoidal deflection the hysteretic and the viscous loss are the same
ellipse): these are recorded on the rate table, whose vibration lines tell
them apart. ``block_mode`` and ``scale_factor`` need table motion by nature.

The result holds the confusion matrix (true label -> verdict), the
accuracy (strict, and up to the alternatives the diagnosis names), the
statistics of ``gap_reduction``, and one row per case.
"""

from __future__ import annotations

import math
import time

import numpy as np

from sins_sim.identification.diagnose import DiagnoseSettings, diagnose_recording
from sins_sim.models.effects import EFFECTS, make_effect
from sins_sim.models.suspension import SuspensionParams
from sins_sim.simulation.experiment import (ExperimentInputs, ExperimentSettings, afc_drive,
                                            nominal_from_suspension, record, stationary_drive, table_motion)
from sins_sim.units import ARCMIN, ARCSEC, DEG, INTERPOLATED_QUANTUM_RAD

__all__ = ["LABELS", "EXPERIMENTS", "make_case", "evaluate", "format_result"]

#: Hidden labels: every catalogue effect, clean cases and off-catalogue disturbances.
LABELS = tuple(EFFECTS) + ("none", "off_catalogue")
#: The experiments a label is recorded in (see the module docstring).
EXPERIMENTS = {
    "piezo_lag": ("rate_table",),
    "axis_coupling": ("stationary",),
    "block_mode": ("rate_table",),
    "viscous_damping": ("rate_table",),
    "resonance_drift": ("stationary", "afc_sweep", "rate_table"),
    "readout_delay": ("rate_table",),
    "scale_factor": ("rate_table",),
    "lock_in": ("stationary", "rate_table"),
    "none": ("stationary", "afc_sweep", "rate_table"),
    "off_catalogue": ("stationary", "afc_sweep", "rate_table"),
}
#: The verdict that counts as right for a label.
EXPECTED = {**{name: name for name in EFFECTS}, "none": "none", "off_catalogue": "unknown"}
FS = 7200.0


def _log_uniform(rng, lo, hi):
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def _draw_effect(label: str, rng, axes) -> tuple:
    """The disturbance for a label: (Effect or None, description)."""
    sign = 1.0 if rng.uniform() < 0.5 else -1.0
    target = axes[0]
    if label == "none":
        return None, "clean"
    if label == "off_catalogue":
        if rng.uniform() < 0.5:
            amp = _log_uniform(rng, 0.3, 2.0) * ARCSEC
            f = 50.0 if rng.uniform() < 0.5 else 60.0
            e = make_effect("mains_pickup", amplitude_rad=amp, frequency_hz=f, phase_rad=rng.uniform(0, 2 * math.pi))
            return e, f"mains_pickup {amp / ARCSEC:.2f} arcsec {f:g} Hz"
        c2 = sign * _log_uniform(rng, 0.5, 2.0)
        return make_effect("drive_harmonic", c2_per_v=c2), f"drive_harmonic c2 = {c2:.3g} 1/V"
    if label == "piezo_lag":
        p = {"tau_s": _log_uniform(rng, 3e-5, 3e-4)}
    elif label == "readout_delay":
        p = {"delay_s": _log_uniform(rng, 5e-6, 5e-5)}
    elif label == "viscous_damping":
        p = {"zeta": _log_uniform(rng, 4e-4, 3e-3)}
    elif label == "resonance_drift":
        p = {"rate_hz_per_s": sign * _log_uniform(rng, 0.1, 1.0)}
    elif label == "scale_factor":
        p = {"error": sign * _log_uniform(rng, 5e-5, 2e-3)}
    elif label == "block_mode":
        p = {"frequency_hz": _log_uniform(rng, 300.0, 1500.0), "zeta": _log_uniform(rng, 0.02, 0.2),
             "gain": rng.uniform(0.2, 1.0)}
    elif label == "lock_in":
        p = {"threshold_rad_s": _log_uniform(rng, 1.5e-3, 5e-3), "phase_rad": rng.uniform(0, 2 * math.pi)}
    elif label == "axis_coupling":
        src = axes[1]
        c = sign * _log_uniform(rng, 3e-3, 2e-2)
        return make_effect("axis_coupling", coefficients={target: {src: c}}), f"axis_coupling {target}<-{src} {c:.3g}"
    else:
        raise ValueError(f"blind: label: must be one of {list(LABELS)}, got {label!r}")
    e = make_effect(label, axes=[target], **p)
    return e, label + " " + ", ".join(f"{k} = {v:.3g}" for k, v in p.items())


def make_case(label: str, rng: np.random.Generator, duration_s: float = 1.0, experiment: str | None = None):
    """Generate one recording with a hidden label.

    Returns
    -------
    (Recording, info) : info describes the truth (never shown to the diagnosis).
    """
    experiment = experiment or EXPERIMENTS[label][int(rng.integers(len(EXPERIMENTS[label])))]
    axes = ["x", "y"] if label == "axis_coupling" else ["x"]
    base = {"x": 386.0, "y": 352.0}
    nominal = {a: SuspensionParams(f0_hz=base[a] * (1.0 + 0.03 * rng.uniform(-1, 1))) for a in axes}
    truth = {}
    for a in axes:
        s = nominal[a]
        z = rng.standard_normal(6)
        truth[a] = s.replace(f0_hz=s.f0_hz * (1 + 0.002 * z[0]), k1=s.k1 * (1 + 0.05 * z[1]),
                             k2=s.k2 * (1 + 0.05 * z[2]), k3=s.k3 * (1 + 0.05 * z[3]),
                             k4=s.k4 * (1 + 0.05 * z[4]), k5=s.k5 * (1 + 0.05 * z[5]))
    amp = rng.uniform(2.5, 3.5) * ARCMIN
    # a recording that starts mid-operation (the drive running 13 time constants before it), for the
    # clean and the off-catalogue cases (with an effect, the start state the diagnosis fits trades against
    # slow effects such as a drift over a 1 s recording)
    unknown = label in ("none", "off_catalogue") and rng.uniform() < 0.3
    pre = int(2.0 * FS) if unknown else 0  # 13 time constants: the unit is in steady operation
    n = int(round(duration_s * FS)) + 1 + pre
    table = None
    points = []
    if experiment == "afc_sweep":
        factors = [0.6, 1.0, 1.3]
        offsets = [-2.0, 0.0, 2.0]
        dwell = (n / FS) / (len(factors) * len(offsets))
        drive, points = afc_drive(nominal, axes, amp, factors, offsets, dwell, FS, n)
    else:
        drive = stationary_drive(nominal, axes, amp, FS, n)
    if experiment == "rate_table":
        rate = (1.0 if rng.uniform() < 0.5 else -1.0) * rng.uniform(5.0, 20.0) * DEG
        sines = [(30 * ARCMIN, 7.0 * rng.uniform(0.8, 1.2), rng.uniform(0, 6.3)),
                 (3 * ARCMIN, 80.0 * rng.uniform(0.8, 1.2), rng.uniform(0, 6.3)),
                 (1 * ARCMIN, 230.0 * rng.uniform(0.8, 1.2), rng.uniform(0, 6.3))]
        mot = table_motion(rate, sines)
        table = {a: mot for a in axes}
    inputs = ExperimentInputs(axes, FS, n, FS, drive, table)
    effect, desc = _draw_effect(label, rng, axes)
    integrator = "rk4" if rng.uniform() < 0.3 else "exact"
    noise = rng.uniform(0.02, 0.1) * ARCSEC if rng.uniform() < 0.4 else 0.0
    settings = ExperimentSettings(plant_rate_hz=72000.0, integrator=integrator)
    rec = record(inputs, truth, nominal, INTERPOLATED_QUANTUM_RAD, [effect] if effect else [], settings,
                 noise_rad=noise, seed=int(rng.integers(2 ** 31)), experiment=experiment,
                 description="blind evaluation case", preroll_samples=pre)
    info = {"label": label, "experiment": experiment, "effect": desc, "integrator": integrator,
            "noise_arcsec": noise / ARCSEC, "initial_state": rec.initial_state, "axes": axes,
            "params": effect.to_dict() if effect else None,
            "truth": {a: nominal_from_suspension(truth[a]) for a in axes}}
    return rec, info


def evaluate(n: int, seed: int, duration_s: float = 1.0, labels=None, settings: DiagnoseSettings | None = None,
             progress=None) -> dict:
    """Run ``n`` blind cases; return the confusion matrix, accuracies, gap-reduction statistics and cases.

    Labels cycle through a seeded permutation of :data:`LABELS` (or of
    ``labels``), so ``n = len(LABELS)`` covers each once.
    """
    n = int(n)
    if n < 1:
        raise ValueError(f"diagnose_eval.n: must be >= 1, got {n!r}")
    pool = list(labels or LABELS)
    for lab in pool:
        if lab not in LABELS:
            raise ValueError(f"diagnose_eval.labels: must be in {list(LABELS)}, got {lab!r}")
    order = [pool[i] for i in np.random.default_rng([int(seed), 1]).permutation(len(pool))]
    settings = settings or DiagnoseSettings()
    cases = []
    t_all = time.perf_counter()
    for i in range(n):
        label = order[i % len(order)]
        rng = np.random.default_rng([int(seed), 2, i])
        rec, info = make_case(label, rng, duration_s)
        t0 = time.perf_counter()
        js = diagnose_recording(rec, settings).to_json()  # the recording alone: the label stays hidden
        dt = time.perf_counter() - t0
        verdict = js["verdict"]["effect"]
        expected = EXPECTED[label]
        alts = js["verdict"].get("alternatives", [])
        true_red = next((c["gap_reduction"] for c in js["candidates"] if c["effect"] == label), None)
        row = {**info, "verdict": verdict, "expected": expected, "correct": verdict == expected,
               "equivalent": verdict == expected or expected in alts, "alternatives": alts,
               "gap_significant": js["gap"]["significant"],
               "excess_arcsec": max(js["gap"]["excess_rms_arcsec"].values()),
               "verdict_gap_reduction": js["verdict"]["gap_reduction"], "true_effect_gap_reduction": true_red,
               "noise_floor_arcsec": js["noise_floor_arcsec"], "diagnosis_s": dt}
        cases.append(row)
        if progress is not None:
            progress(f"case {i + 1}/{n}: {info['effect']} ({info['experiment']}) -> {verdict}"
                     f" [{'ok' if row['correct'] else 'WRONG'}] {dt:.1f} s")
    predicted = sorted({c["verdict"] for c in cases} | {"none", "unknown"})
    true_labels = [lab for lab in LABELS if any(c["label"] == lab for c in cases)]
    confusion = {t: {p: sum(1 for c in cases if c["label"] == t and c["verdict"] == p) for p in predicted}
                 for t in true_labels}
    eff = [c for c in cases if c["label"] in EFFECTS]
    reds = [c["true_effect_gap_reduction"] for c in eff if c["true_effect_gap_reduction"] is not None]
    vreds = [c["verdict_gap_reduction"] for c in eff if c["correct"]]
    return {
        "n": n, "seed": int(seed), "duration_s": float(duration_s),
        "accuracy": sum(c["correct"] for c in cases) / n,
        "accuracy_up_to_alternatives": sum(c["equivalent"] for c in cases) / n,
        "confusion": confusion,
        "gap_reduction": {
            "true_effect_median": float(np.median(reds)) if reds else None,
            "true_effect_min": float(np.min(reds)) if reds else None,
            "true_effect_mean": float(np.mean(reds)) if reds else None,
            "correct_verdict_mean": float(np.mean(vreds)) if vreds else None,
        },
        "cases": cases,
        "runtime_s": time.perf_counter() - t_all,
    }


def format_result(res: dict) -> str:
    """The confusion matrix and the statistics as text (rows: hidden label, columns: verdict)."""
    cols = sorted({p for row in res["confusion"].values() for p in row})
    w = max([len(c) for c in cols] + [16])
    lines = ["true \\ verdict".ljust(w) + "".join(c[:12].rjust(13) for c in cols)]
    for t, row in res["confusion"].items():
        lines.append(t.ljust(w) + "".join(str(row.get(c, 0)).rjust(13) for c in cols))
    g = res["gap_reduction"]
    lines += ["", f"accuracy {res['accuracy']:.3f} (up to named alternatives {res['accuracy_up_to_alternatives']:.3f})"
              f" over {res['n']} recordings of {res['duration_s']:g} s, seed {res['seed']}"]
    if g["true_effect_median"] is not None:
        lines.append(f"gap reduction of the true effect: median {g['true_effect_median']:.3f}, "
                     f"min {g['true_effect_min']:.3f}, mean {g['true_effect_mean']:.3f}")
    lines.append(f"runtime {res['runtime_s']:.1f} s")
    return "\n".join(lines)
