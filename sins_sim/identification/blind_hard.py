"""A harder blind set for ``sins-sim diagnose-eval --hard`` (issue 24, item 7).

Every case draws its unit afresh: each axis' nominal resonance log-uniform in 300-450 Hz (the
reference model's range for the three axes) and the dither amplitude uniform in 1.8-4.2 arcmin,
instead of the standard set's 386 / 352 Hz at about 3 arcmin; the true parameters differ from the
header's as in :mod:`sins_sim.identification.blind` (f0 by 0.2 %, k1..k5 by 5 %, one sigma), the
truth is integrated at 72 kHz by the exact or the RK4 integrator, with white readout noise in 40 % of
the cases. The classes (:data:`HARD_LABELS`) and what counts as right (:func:`judge_hard`):

==================== ============================================================ ==========================
class                the recording                                                right when
==================== ============================================================ ==========================
``time_gap``         rate table; 1-120 samples (log-uniform) dropped from every    ``invalid data`` naming
                     array at a random instant in the middle 30-70 % (the header   ``time continuity``
                     claims a continuous record)
``sign_flip``        rate table; the counts negated (``counts``) or the table      ``invalid data`` naming
                     angle ``sins_angle`` negated (``table``)                      ``sign``
``bias_drift``       stationary; a readout bias drift (0.5-10 deg/h, a ramp of     ``none`` (``alone``), the
                     up to the bias over the record and a random walk of 1-10 %    effect's name
                     of it per sqrt(s)), ``alone`` or ``with_effect``              (``with_effect``, as in
                     (``resonance_drift`` or ``lock_in`` at moderate strength)     the standard set)
``structural_mode``  stationary or rate table; a clean mount mode                  ``unknown`` (never
                     (``mount_mode``) at 1.5-2.5 kHz, damping ratio 0.01-0.05,     ``invalid data``)
                     0.2-4 arcsec RMS
``near_degenerate``  stationary (the dither only); a drive lag (``piezo_lag``,     the verdict names one of
                     50-300 us) or a readout delay (20-150 us); then the           the pair and lists the
                     experiment the verdict suggests is recorded on the same unit  other as an alternative
                     with the same effect and diagnosed (:func:`follow_up`)        (the close call is said),
                                                                                   and the suggested
                                                                                   experiment's recording is
                                                                                   diagnosed as the true
                                                                                   effect, ``explained``, the
                                                                                   other not an alternative
                                                                                   (the round trip)
``earth_rate``       three axes at a random site (latitude -70..70 deg, heading   ``still_site`` and
                     0-360 deg): ``still_site`` a level still bench, the site in  ``table_site``: ``none``;
                     the header; ``still_no_site`` the same without it;           ``still_no_site``: ``none``
                     ``table_site`` a rate table (5-20 deg/s and a 7 Hz swing)    with the steady-rate
                     about an axis 0-40 deg from the vertical, the unit tilted by finding ``earth_rate``;
                     up to 2 deg, with the site; ``table_no_site`` the same       ``table_no_site``:
                     without it                                                   ``unknown``, or the
                                                                                  steady-rate finding
                                                                                  ``earth_rate`` beside the
                                                                                  effect named
``randomised``       a catalogue effect (in the experiments of                     as in the standard set
                     :data:`~sins_sim.identification.blind.EXPERIMENTS`) or a
                     clean case, made by the standard generator with the
                     randomised unit
==================== ============================================================ ==========================

Seeds: the development seeds are :data:`DEV_SEEDS`; :data:`HOLDOUT_SEEDS` are kept unlooked-at
(``diagnose-eval --hard --holdout``) until a change is final, so that the accuracy they give is not
tuned to.

.. autosummary::

   make_hard_case
   follow_up
   judge_hard
   evaluate_seeds
   format_seeds
"""

from __future__ import annotations

import math
import zlib

import numpy as np

from sins_sim.identification.blind import (FS, _draw_effect, _judge, _log_uniform, evaluate, make_case,
                                           perturbed_unit)
from sins_sim.io.recording import Recording
from sins_sim.models.effects import EFFECTS, make_effect
from sins_sim.models.suspension import SuspensionParams
from sins_sim.simulation.experiment import (ExperimentInputs, ExperimentSettings, nominal_from_suspension, record,
                                            stationary_drive, table_motion)
from sins_sim.units import ARCMIN, ARCSEC, DEG, DEG_PER_H, INTERPOLATED_QUANTUM_RAD

__all__ = ["HARD_LABELS", "HARD_FORMS", "HARD_EXPECTED", "EARTH_EXPECTED", "DEV_SEEDS", "HOLDOUT_SEEDS",
           "make_hard_case", "follow_up",
           "judge_hard",
           "evaluate_seeds", "format_seeds"]

#: The classes of the hard set.
HARD_LABELS = ("time_gap", "sign_flip", "bias_drift", "structural_mode", "near_degenerate", "earth_rate",
               "randomised")
#: The forms a class is drawn in.
HARD_FORMS = {"time_gap": ("rate_table",), "sign_flip": ("counts", "table"), "bias_drift": ("alone", "with_effect"),
              "structural_mode": ("stationary", "rate_table"), "near_degenerate": ("piezo_lag", "readout_delay"),
              "earth_rate": ("still_site", "still_no_site", "table_site", "table_no_site"),
              "randomised": tuple(EFFECTS) + ("none",)}
#: The verdict expected per class (``randomised`` and ``bias_drift/with_effect``: the effect drawn).
HARD_EXPECTED = {"time_gap": "invalid_data", "sign_flip": "invalid_data", "bias_drift": "none",
                 "structural_mode": "unknown", "near_degenerate": "close call", "earth_rate": None,
                 "randomised": None}
#: The verdict expected per form of the ``earth_rate`` class.
EARTH_EXPECTED = {"still_site": "none", "still_no_site": "none (earth_rate)", "table_site": "none",
                  "table_no_site": "unknown"}
#: The seeds the hard set is developed on (accuracy reported per class over these).
DEV_SEEDS = (0, 1, 2)
#: The seeds kept unlooked-at until the end (``diagnose-eval --hard --holdout``).
HOLDOUT_SEEDS = (2401, 2402)
#: Range of the randomised nominal resonance (Hz) and dither amplitude (arcmin).
F0_RANGE_HZ = (300.0, 450.0)
AMPLITUDE_RANGE_ARCMIN = (1.8, 4.2)


def _unit(rng, axes):
    """Randomised nominal and true suspensions per axis and the dither amplitude (rad)."""
    nominal = {a: SuspensionParams(f0_hz=_log_uniform(rng, *F0_RANGE_HZ)) for a in axes}
    return nominal, perturbed_unit(nominal, axes, rng), rng.uniform(*AMPLITUDE_RANGE_ARCMIN) * ARCMIN


def _table(rng):
    rate = (1.0 if rng.uniform() < 0.5 else -1.0) * rng.uniform(5.0, 20.0) * DEG
    return table_motion(rate, [(30 * ARCMIN, 7.0 * rng.uniform(0.8, 1.2), rng.uniform(0, 6.3)),
                               (3 * ARCMIN, 80.0 * rng.uniform(0.8, 1.2), rng.uniform(0, 6.3)),
                               (1 * ARCMIN, 230.0 * rng.uniform(0.8, 1.2), rng.uniform(0, 6.3))])


def _drop(rec: Recording, i0: int, m: int) -> Recording:
    """The recording with samples ``i0 .. i0 + m - 1`` removed from every array (the header unchanged)."""
    r = int(round(rec.drive_fs_hz / rec.fs_hz))
    counts = np.delete(np.asarray(rec.counts), np.s_[i0:i0 + m], axis=0)
    drive = np.delete(np.asarray(rec.drive_v), np.s_[i0 * r:(i0 + m) * r], axis=0)
    sins = None if rec.sins_angle is None else np.delete(np.asarray(rec.sins_angle), np.s_[i0:i0 + m], axis=0)
    return Recording(dict(rec.meta), counts, drive, sins)


def make_hard_case(label: str, rng: np.random.Generator, duration_s: float = 1.0, form: str | None = None):
    """One recording of the hard set with its hidden truth: ``(Recording, info)`` (see the module docstring)."""
    if label not in HARD_LABELS:
        raise ValueError(f"blind_hard: label: must be one of {list(HARD_LABELS)}, got {label!r}")
    forms = HARD_FORMS[label]
    if form is None:
        form = forms[int(rng.integers(len(forms)))]
    elif form not in forms:
        raise ValueError(f"blind_hard: form: must be one of {list(forms)} for {label!r}, got {form!r}")
    axes = ["x"]
    if label == "earth_rate":
        return _earth_case(form, rng, duration_s)
    nominal, truth, amp = _unit(rng, axes)
    if label == "randomised":
        f0 = {"x": nominal["x"].f0_hz, "y": _log_uniform(rng, *F0_RANGE_HZ)}  # y: for axis_coupling
        rec, info = make_case(form, rng, duration_s, weak=False, f0_hz=f0, amplitude_rad=amp)
        return rec, {**info, "label": "randomised", "form": form, "inner": form,
                     "expected": "none" if form == "none" else form, "amplitude_arcmin": amp / ARCMIN,
                     "f0_hz": {a: info["truth"][a]["f0_hz"] for a in info["axes"]}}
    m = 0
    experiment = "rate_table" if label in ("time_gap", "sign_flip") else "stationary"
    if label == "structural_mode":
        experiment = form
    if label == "time_gap":
        m = int(round(_log_uniform(rng, 1.0, 120.0)))
    n = int(round(duration_s * FS)) + 1 + m
    drive = stationary_drive(nominal, axes, amp, FS, n)
    table = {a: _table(rng) for a in axes} if experiment == "rate_table" else None
    inputs = ExperimentInputs(axes, FS, n, FS, drive, table)
    effects, desc, expected, inner, defect = [], label, HARD_EXPECTED[label], None, None
    if label == "bias_drift":
        bias = (1.0 if rng.uniform() < 0.5 else -1.0) * _log_uniform(rng, 0.5, 10.0) * DEG_PER_H
        ramp = bias * rng.uniform(-1.0, 1.0) / duration_s
        walk = abs(bias) * _log_uniform(rng, 0.01, 0.1)
        effects.append(make_effect("bias_drift", axes=axes, bias_rad_s=bias, bias_rate_rad_s2=ramp,
                                   walk_rad_s_rt_s=walk, seed=float(rng.integers(2 ** 31))))
        desc = (f"bias_drift {bias / DEG_PER_H:.3g} deg/h, ramp {ramp * duration_s / DEG_PER_H:.3g} deg/h over the "
                f"record, walk {walk / DEG_PER_H:.3g} deg/h/rt(s)")
        if form == "with_effect":
            inner = "resonance_drift" if rng.uniform() < 0.5 else "lock_in"
            e, d = _draw_effect(inner, rng, axes)
            effects.append(e)
            desc += " & " + d
            expected = inner
    elif label == "structural_mode":
        f, z, rms = rng.uniform(1500.0, 2500.0), rng.uniform(0.01, 0.05), _log_uniform(rng, 0.2, 4.0) * ARCSEC
        effects.append(make_effect("mount_mode", frequency_hz=f, zeta=z, rms_rad=rms,
                                   seed=float(rng.integers(2 ** 31))))
        desc = f"mount_mode {f:.0f} Hz, zeta {z:.3f}, {rms / ARCSEC:.2f} arcsec RMS"
    elif label == "near_degenerate":
        if form == "piezo_lag":
            p = {"tau_s": _log_uniform(rng, 5e-5, 3e-4)}
        else:
            p = {"delay_s": _log_uniform(rng, 2e-5, 1.5e-4)}
        effects.append(make_effect(form, axes=axes, **p))
        desc = form + " " + ", ".join(f"{k} = {v:.3g}" for k, v in p.items())
        inner = form
    integrator = "rk4" if rng.uniform() < 0.3 else "exact"
    noise = rng.uniform(0.02, 0.1) * ARCSEC if rng.uniform() < 0.4 else 0.0
    rec = record(inputs, truth, nominal, INTERPOLATED_QUANTUM_RAD, effects,
                 ExperimentSettings(plant_rate_hz=72000.0, integrator=integrator), noise_rad=noise,
                 seed=int(rng.integers(2 ** 31)), experiment=experiment, description="blind evaluation case (hard)")
    if label == "time_gap":
        i0 = int(rng.uniform(0.3, 0.7) * (n - m))
        rec = _drop(rec, i0, m)
        desc = f"{m} samples dropped at {i0 / FS:.3f} s"
        defect = {"first_sample": i0, "samples": m}
    elif label == "sign_flip" and form == "counts":
        rec = Recording(dict(rec.meta), -np.asarray(rec.counts), np.asarray(rec.drive_v), rec.sins_angle)
        desc = "counts negated"
    elif label == "sign_flip":
        rec = Recording(dict(rec.meta), np.asarray(rec.counts), np.asarray(rec.drive_v), -np.asarray(rec.sins_angle))
        desc = "table angle (sins_angle) negated"
    info = {"label": label, "form": form, "weak": False, "experiment": experiment, "effect": desc,
            "integrator": integrator, "noise_arcsec": noise / ARCSEC, "initial_state": rec.initial_state,
            "axes": axes, "params": [e.to_dict() for e in effects] or None, "pair": None, "inner": inner,
            "defect": defect,
            "expected": expected, "amplitude_arcmin": amp / ARCMIN, "f0_hz": {a: truth[a].f0_hz for a in axes},
            "truth": {a: nominal_from_suspension(truth[a]) for a in axes}}
    return rec, info


def _earth_case(form: str, rng, duration_s: float):
    """A three-axis recording at a random site (``earth_rate`` class; see the module docstring)."""
    from sins_sim.simulation.site import earth_motions, table_on_axes

    axes = ["x", "y", "z"]
    nominal, truth, amp = _unit(rng, axes)
    table_form = form.startswith("table")
    site = {"latitude_deg": float(rng.uniform(-70.0, 70.0)),
            "orientation_ned": {"heading_deg": float(rng.uniform(0.0, 360.0)),
                                "pitch_deg": float(rng.uniform(-2.0, 2.0)) if table_form else 0.0,
                                "roll_deg": float(rng.uniform(-2.0, 2.0)) if table_form else 0.0}}
    n = int(round(duration_s * FS)) + 1
    drive = stationary_drive(nominal, axes, amp, FS, n)
    table, desc = None, "still bench"
    if table_form:
        tilt, az = math.radians(rng.uniform(0.0, 40.0)), rng.uniform(0.0, 2.0 * math.pi)
        site["table_axis_ned"] = [math.sin(tilt) * math.cos(az), math.sin(tilt) * math.sin(az), math.cos(tilt)]
        rate = (1.0 if rng.uniform() < 0.5 else -1.0) * rng.uniform(5.0, 20.0) * DEG
        table = table_on_axes(site, axes, table_motion(rate, [(30 * ARCMIN, 7.0, rng.uniform(0.0, 6.3))]))
        desc = (f"rate table {rate / DEG:.3g} deg/s about an axis {math.degrees(tilt):.0f} deg from the vertical")
    inputs = ExperimentInputs(axes, FS, n, FS, drive, table, earth_motions(site, axes, (n - 1) / FS, table))
    integrator = "rk4" if rng.uniform() < 0.3 else "exact"
    noise = rng.uniform(0.02, 0.1) * ARCSEC if rng.uniform() < 0.4 else 0.0
    given = form.endswith("_site") and not form.endswith("no_site")
    rec = record(inputs, truth, nominal, INTERPOLATED_QUANTUM_RAD, [],
                 ExperimentSettings(plant_rate_hz=72000.0, integrator=integrator), noise_rad=noise,
                 seed=int(rng.integers(2 ** 31)), experiment="rate_table" if table_form else "stationary",
                 description="blind evaluation case (hard)", extra_meta={"site": site} if given else None)
    o = site["orientation_ned"]
    desc = (f"Earth's rate, latitude {site['latitude_deg']:.1f} deg, heading {o['heading_deg']:.0f} deg, {desc}, "
            f"site {'in' if given else 'not in'} the header")
    info = {"label": "earth_rate", "form": form, "weak": False, "experiment": rec.experiment, "effect": desc,
            "integrator": integrator, "noise_arcsec": noise / ARCSEC, "initial_state": rec.initial_state,
            "axes": axes, "params": None, "pair": None, "inner": None, "defect": None, "site": site,
            "expected": EARTH_EXPECTED[form], "amplitude_arcmin": amp / ARCMIN,
            "f0_hz": {a: truth[a].f0_hz for a in axes},
            "truth": {a: nominal_from_suspension(truth[a]) for a in axes}}
    return rec, info


def follow_up(info: dict, verdict: dict, rec: Recording, settings) -> dict:
    """The round trip of a ``near_degenerate`` case whose verdict is a close call (else ``{}``).

    The experiment the verdict suggests (``verdict["close_call"]["experiment"]``, built as
    ``simulate-recording`` builds it: :func:`sins_sim.identification.discriminate.experiment_inputs`) is
    recorded on the same true unit with the same effect, integrator and readout noise, and diagnosed. Returns
    ``round_trip`` (the experiment's label), ``round_trip_verdict``, ``round_trip_alternatives`` and
    ``round_trip_right`` (the true effect named, ``explained``, the rival not among the alternatives).
    """
    cc = verdict.get("close_call")
    if info["label"] != "near_degenerate" or not cc:
        return {}
    from sins_sim.identification.diagnose import diagnose_recording
    from sins_sim.identification.discriminate import experiment_inputs
    from sins_sim.simulation.experiment import suspension_from_nominal

    doc = cc["experiment"]
    inputs = experiment_inputs(rec, doc, doc["duration_s"])
    truth = {a: suspension_from_nominal(info["truth"][a]) for a in info["axes"]}
    nominal = {a: suspension_from_nominal(rec.nominal[a]) for a in rec.axes}
    p = dict(info["params"][0])
    effect = make_effect(p.pop("name"), **p)
    seed = zlib.crc32(info["effect"].encode())  # the readout noise's seed: fixed by the case, apart from its own
    rec2 = record(inputs, truth, nominal, rec.quantum_rad, [effect],
                  ExperimentSettings(plant_rate_hz=72000.0, integrator=info["integrator"]),
                  noise_rad=info["noise_arcsec"] * ARCSEC, seed=seed, experiment=doc["experiment"],
                  description="blind evaluation case (hard): round trip")
    v2 = diagnose_recording(rec2, settings).verdict
    rival = ({"piezo_lag", "readout_delay"} - {info["inner"]}).pop()
    return {"round_trip": doc["description"], "round_trip_verdict": f"{v2['effect']} ({v2['status']})",
            "round_trip_alternatives": list(v2.get("alternatives", [])),
            "round_trip_right": bool(v2["effect"] == info["inner"] and v2["status"] == "explained"
                                     and rival not in v2.get("alternatives", []))}


def judge_hard(info: dict, verdict: dict) -> tuple:
    """``(predicted, right)`` for a hard case (the rules of the module docstring's table)."""
    label = info["label"]
    status = verdict.get("status")
    if label in ("time_gap", "sign_flip"):
        check = "time continuity" if label == "time_gap" else "sign"
        named = [f.get("check") for f in verdict.get("findings") or []]
        pred = "invalid_data: " + ", ".join(sorted(set(named))) if status == "invalid data" else verdict["effect"]
        return pred, status == "invalid data" and check in named
    if label == "near_degenerate":
        pair = {"piezo_lag", "readout_delay"}
        pred = verdict["effect"] + (" | " + ", ".join(verdict["alternatives"]) if verdict.get("alternatives") else "")
        said = {verdict["effect"], *verdict.get("alternatives", [])}
        if info.get("round_trip_verdict"):
            pred += " -> " + info["round_trip_verdict"]
        return pred, (status == "explained" and verdict["effect"] in pair and pair <= said
                      and bool(info.get("round_trip_right")))
    if label == "structural_mode":
        return verdict["effect"], status == "unknown"
    if label == "earth_rate":
        sr = verdict.get("steady_rate") or {}
        pred = verdict["effect"] + (f" ({sr['finding']})" if sr.get("finding") else "")
        if info["form"] == "still_no_site":
            return pred, status == "none" and sr.get("finding") == "earth_rate"
        if info["form"] == "table_no_site":
            # a gap no catalogue effect explains, or the Earth's rate named beside what explains it
            return pred, status == "unknown" or sr.get("finding") == "earth_rate"
        return pred, status == "none" and not sr
    if label == "bias_drift" and info["form"] == "alone":
        return verdict["effect"], verdict["effect"] == "none"
    inner = info.get("inner")
    # randomised, and bias_drift with an effect: the standard set's rule for the effect (or clean case) drawn
    return _judge({**info, "label": inner if inner else "none"}, verdict)


def evaluate_seeds(n: int, seeds, duration_s: float = 1.0, suite: str = "hard", progress=None, jobs: int = 1,
                   labels=None) -> dict:
    """:func:`~sins_sim.identification.blind.evaluate` over several seeds, pooled per class.

    Returns ``per_seed`` (each seed's result), ``per_class`` (pooled: ``n``, ``correct``, ``accuracy``),
    ``accuracy`` (pooled), ``seeds`` and ``suite``. ``labels``: only these classes (default all).
    """
    seeds = [int(s) for s in seeds]
    if not seeds:
        raise ValueError("diagnose_eval.seeds: needs at least one seed")
    runs = [evaluate(n, s, duration_s=duration_s, labels=labels, progress=progress, jobs=jobs, suite=suite)
            for s in seeds]
    classes = []
    for r in runs:
        classes += [c for c in r["per_class"] if c not in classes]
    pooled = {}
    for c in classes:
        k = sum(r["per_class"].get(c, {}).get("n", 0) for r in runs)
        ok = sum(r["per_class"].get(c, {}).get("correct", 0) for r in runs)
        pooled[c] = {"n": k, "correct": ok, "accuracy": ok / k if k else math.nan}
    forms = []
    for r in runs:
        forms += [f for f in r["per_form"] if f not in forms]
    per_form = {}
    for f in sorted(forms):
        k = sum(r["per_form"].get(f, {}).get("n", 0) for r in runs)
        ok = sum(r["per_form"].get(f, {}).get("correct", 0) for r in runs)
        per_form[f] = {"n": k, "correct": ok, "accuracy": ok / k if k else math.nan}
    total = sum(r["n"] for r in runs)
    return {"suite": suite, "seeds": seeds, "n_per_seed": int(n), "duration_s": float(duration_s),
            "per_class": pooled, "per_form": per_form, "accuracy": sum(p["correct"] for p in pooled.values()) / total,
            "per_seed": runs}


def format_seeds(res: dict) -> str:
    """The pooled accuracy per class, then each seed's, as text."""
    w = max([len(k) for k in res["per_class"]] + [len("class")]) + 2
    lines = [f"{res['suite']} set, seeds {', '.join(map(str, res['seeds']))}: {res['n_per_seed']} recordings of "
             f"{res['duration_s']:g} s each", "", "class".ljust(w) + "right / cases  accuracy"]
    for k, a in res["per_class"].items():
        lines.append(k.ljust(w) + f"{a['correct']:>5d} / {a['n']:<5d}  {a['accuracy']:8.3f}")
    forms = res.get("per_form") or {}
    if forms:
        wf = max([len(k) for k in forms] + [len("form")]) + 2
        lines += ["", "form".ljust(wf) + "right / cases  accuracy"]
        for k, a in forms.items():
            lines.append(k.ljust(wf) + f"{a['correct']:>5d} / {a['n']:<5d}  {a['accuracy']:8.3f}")
    lines.append("")
    for r in res["per_seed"]:
        lines.append(f"seed {r['seed']}: accuracy {r['accuracy']:.3f} ({r['n']} recordings, {r['runtime_s']:.0f} s)")
    lines.append(f"pooled accuracy {res['accuracy']:.3f}")
    return "\n".join(lines)
