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
from dataclasses import replace

import numpy as np

from sins_sim.identification.diagnose import DiagnoseSettings, diagnose_recording
from sins_sim.identification.refit import in_processes
from sins_sim.models.effects import EFFECTS, make_effect
from sins_sim.models.suspension import SuspensionParams
from sins_sim.simulation import alt_effects as alt
from sins_sim.simulation.experiment import (ExperimentInputs, ExperimentSettings, afc_drive,
                                            nominal_from_suspension, record, stationary_drive, table_motion)
from sins_sim.units import ARCMIN, ARCSEC, DEG, INTERPOLATED_QUANTUM_RAD

__all__ = ["LABELS", "EXPERIMENTS", "FORMS", "PAIRS", "make_case", "evaluate", "format_result", "perturbed_unit"]

#: Hidden labels: every catalogue effect, clean cases, off-catalogue disturbances and pairs of effects.
LABELS = tuple(EFFECTS) + ("none", "off_catalogue", "pair")
#: The forms a label's effect is generated in: the catalogue's own and the alternatives of
#: ``sins_sim.simulation.alt_effects``, which the diagnosis does not share.
FORMS = {**{name: ("catalogue",) + alt.ALT_FORMS[name] for name in EFFECTS}, "none": ("clean",),
         "off_catalogue": ("mains_pickup", "drive_harmonic"), "pair": ("catalogue", "alternative")}
#: Pairs of effects recorded together on the rate table (the first is the stronger by construction).
PAIRS = (("resonance_drift", "piezo_lag"), ("block_mode", "resonance_drift"), ("piezo_lag", "block_mode"),
         ("resonance_drift", "scale_factor"))
#: Fraction of the effect cases drawn near the detection limit (strength x 0.05-0.2 of the moderate range).
WEAK_FRACTION = 0.2
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
    "pair": ("rate_table",),
}
#: The verdict that counts as right for a label.
EXPECTED = {**{name: name for name in EFFECTS}, "none": "none", "off_catalogue": "unknown", "pair": "pair"}
FS = 7200.0


def _log_uniform(rng, lo, hi):
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def _draw_effect(label: str, rng, axes, k: float = 1.0) -> tuple:
    """The disturbance for a label: (Effect or None, description); ``k`` scales the strength."""
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
        p = {"tau_s": k * _log_uniform(rng, 3e-5, 3e-4)}
    elif label == "readout_delay":
        p = {"delay_s": k * _log_uniform(rng, 5e-6, 5e-5)}
    elif label == "viscous_damping":
        p = {"zeta": k * _log_uniform(rng, 4e-4, 3e-3)}
    elif label == "resonance_drift":
        p = {"rate_hz_per_s": k * sign * _log_uniform(rng, 0.1, 1.0)}
    elif label == "scale_factor":
        p = {"error": k * sign * _log_uniform(rng, 5e-5, 2e-3)}
    elif label == "block_mode":
        p = {"frequency_hz": _log_uniform(rng, 300.0, 1500.0), "zeta": _log_uniform(rng, 0.02, 0.2),
             "gain": k * rng.uniform(0.2, 1.0)}
    elif label == "lock_in":
        # sqrt(k) rather than k (a choice, not a measurement): k x 1.5e-3 rad/s reaches 7.5e-5 rad/s, which
        # would put the weak lock-in cases far below the detection limit rather than near it
        p = {"threshold_rad_s": math.sqrt(k) * _log_uniform(rng, 1.5e-3, 5e-3),
             "phase_rad": rng.uniform(0, 2 * math.pi)}
    elif label == "axis_coupling":
        src = axes[1]
        c = k * sign * _log_uniform(rng, 3e-3, 2e-2)
        return make_effect("axis_coupling", coefficients={target: {src: c}}), f"axis_coupling {target}<-{src} {c:.3g}"
    else:
        raise ValueError(f"blind: label: must be one of {list(LABELS)}, got {label!r}")
    e = make_effect(label, axes=[target], **p)
    return e, label + " " + ", ".join(f"{k} = {v:.3g}" for k, v in p.items())


def _draw_alt(label: str, rng, axes, k: float, truth: dict, sines, duration_s: float, amp: float) -> tuple:
    """An alternative form (``sins_sim.simulation.alt_effects``) of a catalogue effect: (Effect, description)."""
    sign = 1.0 if rng.uniform() < 0.5 else -1.0
    tgt = axes[0]
    if label == "piezo_lag":
        t1 = k * _log_uniform(rng, 3e-5, 3e-4)
        p = {"tau1_s": t1, "tau2_s": t1 * rng.uniform(0.3, 1.0)}
        e = alt.TwoPoleDrive([tgt], **p)
    elif label == "axis_coupling":
        p = {"c": k * sign * _log_uniform(rng, 3e-3, 2e-2), "fc_hz": rng.uniform(700.0, 2000.0)}
        e = alt.LowpassCoupling([tgt], axes[1], **p)
    elif label == "block_mode":
        p = {"frequency_hz": _log_uniform(rng, 300.0, 1500.0), "eta": 2.0 * _log_uniform(rng, 0.02, 0.2),
             "gain": k * rng.uniform(0.2, 1.0)}
        e = alt.StructuralMode([tgt], sines, **p)
    elif label == "viscous_damping":
        p = {"zeta_eq": k * _log_uniform(rng, 4e-4, 3e-3), "amplitude_rad": amp}
        e = alt.QuadraticDamping([tgt], truth[tgt], **p)
    elif label == "resonance_drift":
        tau = duration_s * rng.uniform(0.3, 1.0)
        p = {"df_hz": k * sign * _log_uniform(rng, 0.1, 1.0) * duration_s, "tau_s": tau}
        e = alt.ThermalDrift([tgt], truth[tgt], **p)
    elif label == "readout_delay":
        p = {"tau_s": k * _log_uniform(rng, 5e-6, 5e-5)}
        e = alt.ReadoutLowpass([tgt], **p)
    elif label == "scale_factor":
        p = {"error": k * sign * _log_uniform(rng, 5e-5, 2e-3), "duration_s": duration_s}
        e = alt.WarmingScale([tgt], **p)
    elif label == "lock_in":
        p = {"threshold_rad_s": math.sqrt(k) * _log_uniform(rng, 1.5e-3, 5e-3), "phase_rad": rng.uniform(0, 6.28)}
        e = alt.TurnaroundKicks([tgt], **p)
    else:
        raise ValueError(f"blind: label: no alternative form for {label!r}")
    return e, e.name + " " + ", ".join(f"{key} = {val:.3g}" for key, val in p.items())


def perturbed_unit(nominal: dict, axes, rng) -> dict:
    """The true unit: per axis the nominal suspension with f0 off by 0.2 % and k1..k5 by 5 % (one sigma, normal)."""
    truth = {}
    for a in axes:
        s = nominal[a]
        z = rng.standard_normal(6)
        truth[a] = s.replace(f0_hz=s.f0_hz * (1 + 0.002 * z[0]), k1=s.k1 * (1 + 0.05 * z[1]),
                             k2=s.k2 * (1 + 0.05 * z[2]), k3=s.k3 * (1 + 0.05 * z[3]),
                             k4=s.k4 * (1 + 0.05 * z[4]), k5=s.k5 * (1 + 0.05 * z[5]))
    return truth


def make_case(label: str, rng: np.random.Generator, duration_s: float = 1.0, experiment: str | None = None,
              form: str | None = None, weak: bool | None = None, f0_hz: dict | None = None,
              amplitude_rad: float | None = None):
    """Generate one recording with a hidden label.

    Parameters
    ----------
    label : str
        One of :data:`LABELS`.
    rng : numpy.random.Generator
    duration_s : float
    experiment : str, optional
        Default: drawn from :data:`EXPERIMENTS`.
    form : str, optional
        One of ``FORMS[label]`` (default: drawn; ``catalogue`` or an alternative with equal chance).
    weak : bool, optional
        Strength near the detection limit (default: drawn, :data:`WEAK_FRACTION`).
    f0_hz : dict, optional
        Axis -> the nominal resonance (default 386 / 352 Hz, each moved by up to 3 %).
    amplitude_rad : float, optional
        The dither amplitude (default: drawn, 2.5-3.5 arcmin).

    Returns
    -------
    (Recording, info) : info describes the truth (never shown to the diagnosis).
    """
    experiment = experiment or EXPERIMENTS[label][int(rng.integers(len(EXPERIMENTS[label])))]
    forms = FORMS[label]
    if form is None:
        form = forms[0] if len(forms) == 1 or rng.uniform() < 0.5 else forms[1 + int(rng.integers(len(forms) - 1))]
    elif form not in forms and not (label == "off_catalogue"):
        raise ValueError(f"blind: form: must be one of {list(forms)} for {label!r}, got {form!r}")
    if weak is None:
        weak = label in EFFECTS and rng.uniform() < WEAK_FRACTION
    k = rng.uniform(0.05, 0.2) if weak else 1.0
    axes = ["x", "y"] if label == "axis_coupling" else ["x"]
    if f0_hz is None:
        base = {"x": 386.0, "y": 352.0}
        f0_hz = {a: base[a] * (1.0 + 0.03 * rng.uniform(-1, 1)) for a in axes}
    nominal = {a: SuspensionParams(f0_hz=f0_hz[a]) for a in axes}
    truth = perturbed_unit(nominal, axes, rng)
    amp = rng.uniform(2.5, 3.5) * ARCMIN if amplitude_rad is None else float(amplitude_rad)
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
    sines = []
    if experiment == "rate_table":
        rate = (1.0 if rng.uniform() < 0.5 else -1.0) * rng.uniform(5.0, 20.0) * DEG
        sines = [(30 * ARCMIN, 7.0 * rng.uniform(0.8, 1.2), rng.uniform(0, 6.3)),
                 (3 * ARCMIN, 80.0 * rng.uniform(0.8, 1.2), rng.uniform(0, 6.3)),
                 (1 * ARCMIN, 230.0 * rng.uniform(0.8, 1.2), rng.uniform(0, 6.3))]
        mot = table_motion(rate, sines)
        table = {a: mot for a in axes}
    inputs = ExperimentInputs(axes, FS, n, FS, drive, table)
    if label == "pair":
        pair = PAIRS[int(rng.integers(len(PAIRS)))]
        effects, descs = [], []
        for j, name in enumerate(pair):
            kk = 1.0 if j == 0 else rng.uniform(0.4, 0.7)
            if form == "alternative":
                e, d = _draw_alt(name, rng, axes, kk, truth, sines, duration_s, amp)
            else:
                e, d = _draw_effect(name, rng, axes, kk)
            effects.append(e)
            descs.append(d)
        desc = " & ".join(descs)
    elif label in EFFECTS and form != "catalogue":
        e, desc = _draw_alt(label, rng, axes, k, truth, sines, duration_s, amp)
        effects = [e]
    else:
        e, desc = _draw_effect(label, rng, axes, k)
        effects = [e] if e is not None else []
        if label == "off_catalogue":
            form = e.name
    integrator = "rk4" if rng.uniform() < 0.3 else "exact"
    noise = rng.uniform(0.02, 0.1) * ARCSEC if rng.uniform() < 0.4 else 0.0
    settings = ExperimentSettings(plant_rate_hz=72000.0, integrator=integrator)
    rec = alt.record_alternative(inputs, truth, nominal, INTERPOLATED_QUANTUM_RAD, effects, settings,
                                 noise_rad=noise, seed=int(rng.integers(2 ** 31)), experiment=experiment,
                                 description="blind evaluation case", preroll_samples=pre)
    info = {"label": label, "form": form, "weak": bool(weak), "experiment": experiment, "effect": desc,
            "integrator": integrator, "noise_arcsec": noise / ARCSEC, "initial_state": rec.initial_state,
            "axes": axes, "params": [e.to_dict() for e in effects] or None,
            "pair": list(pair) if label == "pair" else None,
            "truth": {a: nominal_from_suspension(truth[a]) for a in axes}}
    return rec, info


def _judge(info: dict, verdict: dict) -> tuple:
    """(predicted label, correct) for a case: see :func:`evaluate`."""
    label = info["label"]
    named = [e["effect"] for e in verdict.get("effects", [])]
    status = verdict.get("status")
    if label == "pair":
        pred = "+".join(named) if named else verdict["effect"]
        return pred, set(named[:2]) == set(info["pair"]) and len(named) >= 2
    pred = verdict["effect"]
    if label in EFFECTS:
        right = pred == label and status in ("explained", "partly explained")
        if info.get("weak"):
            right = right or pred in ("none", "unknown")
        return pred, right
    return pred, pred == EXPECTED[label]


def _run_case(task) -> dict:
    """Generate and diagnose one blind case: ``(label, seed, index, duration_s, form, settings, suite)`` -> row.

    ``suite`` ``hard``: the case comes from :mod:`sins_sim.identification.blind_hard`."""
    label, seed, i, duration_s, form, settings, suite = task
    rng = np.random.default_rng([int(seed), 2, i])
    judge = _judge
    if suite == "hard":
        from sins_sim.identification import blind_hard

        rec, info = blind_hard.make_hard_case(label, rng, duration_s, form=form)
        judge = blind_hard.judge_hard
    else:
        rec, info = make_case(label, rng, duration_s, form=form)
    t0 = time.perf_counter()
    js = diagnose_recording(rec, settings).to_json()  # the recording alone: the label stays hidden
    dt = time.perf_counter() - t0
    v = js["verdict"]
    if suite == "hard":
        info = {**info, **blind_hard.follow_up(info, v, rec, settings)}  # the round trip of a close call
    pred, right = judge(info, v)
    expected = info.get("expected") or EXPECTED[label]
    alts = v.get("alternatives", [])
    true_red = next((c["gap_reduction"] for c in js["candidates"] if c["effect"] == label), None)
    return {**info, "verdict": pred, "status": v.get("status"), "expected": expected, "correct": bool(right),
            "equivalent": bool(right) or expected in alts, "alternatives": alts,
            "gap_significant": bool(js["gap"] and js["gap"]["significant"]),
            "excess_arcsec": max(js["gap"]["excess_rms_arcsec"].values()) if js["gap"] else None,
            "explained_fraction": v.get("explained_fraction"),
            "verdict_gap_reduction": v.get("gap_reduction"), "true_effect_gap_reduction": true_red,
            "noise_floor_arcsec": js["noise_floor_arcsec"], "diagnosis_s": dt}


def evaluate(n: int, seed: int, duration_s: float = 1.0, labels=None, settings: DiagnoseSettings | None = None,
             progress=None, forms=None, jobs: int = 1, suite: str = "standard") -> dict:
    """Run ``n`` blind cases; the confusion matrix, accuracies per class and per form, and the cases.

    Labels cycle through a seeded permutation of :data:`LABELS` (or of ``labels``), so
    ``n = len(LABELS)`` covers each once; each case's form (catalogue or alternative) and strength
    (moderate, or near the detection limit for :data:`WEAK_FRACTION` of the effect cases) are drawn.

    A case is right when: ``none`` -> verdict ``none``; ``off_catalogue`` -> ``unknown``; an effect
    at moderate strength -> that effect, status ``explained`` or ``partly explained``; near the
    detection limit -> that effect, ``none`` or ``unknown`` (never another effect); a pair -> both
    effects among the first two the verdict names.

    ``jobs`` > 1 diagnoses that many recordings at once, in separate processes (each case's
    recording and result are the same as with ``jobs = 1``: every case has its own seed).

    ``suite`` ``hard`` draws the cases of :mod:`sins_sim.identification.blind_hard` (its classes and
    rules of what is right) instead.
    """
    n = int(n)
    if n < 1:
        raise ValueError(f"diagnose_eval.n: must be >= 1, got {n!r}")
    if suite not in ("standard", "hard"):
        raise ValueError(f"diagnose_eval.suite: must be 'standard' or 'hard', got {suite!r}")
    if suite == "hard":
        from sins_sim.identification.blind_hard import HARD_FORMS, HARD_LABELS
        all_labels, all_forms = HARD_LABELS, HARD_FORMS
    else:
        all_labels, all_forms = LABELS, FORMS
    pool = list(labels or all_labels)
    for lab in pool:
        if lab not in all_labels:
            raise ValueError(f"diagnose_eval.labels: must be in {list(all_labels)}, got {lab!r}")
    order = [pool[i] for i in np.random.default_rng([int(seed), 1]).permutation(len(pool))]
    settings = settings or DiagnoseSettings()
    jobs = int(jobs)
    if jobs < 1:
        raise ValueError(f"diagnose_eval.jobs: must be >= 1, got {jobs!r}")
    t_all = time.perf_counter()
    tasks = []
    for i in range(n):
        label = order[i % len(order)]
        form = None if forms is None else forms[i % len(forms)]
        if form is not None and form not in all_forms[label]:
            form = None
        tasks.append((label, int(seed), i, float(duration_s), form, settings, suite))
    cases = [None] * n

    def report(i, row):
        cases[i] = row
        if progress is not None:
            progress(f"case {i + 1}/{n}: {row['effect']} [{row['form']}{', weak' if row['weak'] else ''}] "
                     f"({row['experiment']}) -> {row['verdict']} ({row['status']}) "
                     f"[{'ok' if row['correct'] else 'WRONG'}] {row['diagnosis_s']:.1f} s")

    if jobs == 1 or n == 1:
        for i, task in enumerate(tasks):
            report(i, _run_case(task))
    else:
        # recordings are independent: one process per recording at a time (the kernels inside a
        # diagnosis use threads too, so each process gets one thread)
        one = [(lab, sd, i, dur, form, replace(sett, threads=1), st) for lab, sd, i, dur, form, sett, st in tasks]
        in_processes(_run_case, one, jobs, report)
    predicted = sorted({c["verdict"] for c in cases} | {"none", "unknown"})
    true_labels = [lab for lab in all_labels if any(c["label"] == lab for c in cases)]
    confusion = {t: {p: sum(1 for c in cases if c["label"] == t and c["verdict"] == p) for p in predicted}
                 for t in true_labels}

    def acc(group):
        return {"n": len(group), "correct": sum(c["correct"] for c in group),
                "accuracy": sum(c["correct"] for c in group) / len(group)}

    per_class = {t: acc([c for c in cases if c["label"] == t]) for t in true_labels}
    keys = sorted({(c["label"], c["form"]) for c in cases}, key=lambda k: (all_labels.index(k[0]), k[1]))
    per_form = {f"{lab}/{form}": acc([c for c in cases if c["label"] == lab and c["form"] == form])
                for lab, form in keys}
    strength = {w: acc([c for c in cases if c["weak"] == (w == "weak") and c["label"] in EFFECTS])
                for w in ("moderate", "weak") if any(c["weak"] == (w == "weak") and c["label"] in EFFECTS
                                                     for c in cases)}
    eff = [c for c in cases if c["label"] in EFFECTS]
    reds = [c["true_effect_gap_reduction"] for c in eff if c["true_effect_gap_reduction"] is not None]
    vreds = [c["verdict_gap_reduction"] for c in eff if c["correct"] and c["verdict_gap_reduction"] is not None]
    return {
        "n": n, "seed": int(seed), "duration_s": float(duration_s), "suite": suite,
        "accuracy": sum(c["correct"] for c in cases) / n,
        "accuracy_up_to_alternatives": sum(c["equivalent"] for c in cases) / n,
        "per_class": per_class, "per_form": per_form, "per_strength": strength,
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
    """Accuracy per class and per form, and the confusion matrix (rows: hidden label, columns: verdict).

    Column names are written in full (the columns are as wide as their names).
    """
    lines = []
    for title, table in (("class", res.get("per_class", {})), ("form", res.get("per_form", {})),
                         ("strength", res.get("per_strength", {}))):
        if not table:
            continue
        w = max(len(k) for k in list(table) + [title]) + 2
        lines.append(f"{title}".ljust(w) + "right / cases  accuracy")
        for k, a in table.items():
            lines.append(k.ljust(w) + f"{a['correct']:>5d} / {a['n']:<5d}  {a['accuracy']:8.3f}")
        lines.append("")
    cols = sorted({p for row in res["confusion"].values() for p in row})
    w = max([len(c) for c in res["confusion"]] + [len("true \\ verdict")]) + 2
    widths = [max(len(c), 3) + 2 for c in cols]
    lines.append("true \\ verdict".ljust(w) + "".join(c.rjust(cw) for c, cw in zip(cols, widths)))
    for t, row in res["confusion"].items():
        lines.append(t.ljust(w) + "".join(str(row.get(c, 0)).rjust(cw) for c, cw in zip(cols, widths)))
    g = res["gap_reduction"]
    lines += ["", f"accuracy {res['accuracy']:.3f} (up to named alternatives {res['accuracy_up_to_alternatives']:.3f})"
              f" over {res['n']} recordings of {res['duration_s']:g} s, seed {res['seed']}"]
    if g["true_effect_median"] is not None:
        lines.append(f"gap reduction of the true effect: median {g['true_effect_median']:.3f}, "
                     f"min {g['true_effect_min']:.3f}, mean {g['true_effect_mean']:.3f}")
    lines.append(f"runtime {res['runtime_s']:.1f} s")
    return "\n".join(lines)
