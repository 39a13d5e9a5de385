"""Close calls and the experiment that separates them (issue 24, item 5).

**Close call.** When the verdict names one effect (status ``explained``), every other significant
candidate that closes the gap as well (:func:`close_rivals`: it leaves on every axis no more excess
than the tolerance or ``close_fraction`` of the baseline's excess, the model-error allowance of
:func:`sins_sim.identification.verdict.closes`, and removes at least ``min_gap_reduction`` of the
power) is a rival the recording cannot rule out: what separates them is below the allowance the
diagnosis grants to model error, so the ranking between them is no evidence. In a dither-only
recording a first-order drive lag (``piezo_lag``) and a readout delay (``readout_delay``) are such a
pair: both delay the narrow-band dither response. So is, for a verdict ``explained`` or ``partly
explained``, every significant candidate that closes at least ``MIN_PARTIAL`` of the gap and that the
held-out test (``verdict.dm_pvalue``) does not put behind the named one at ``AHEAD_ALPHA``: the two
explain alike (issue 39). The verdict then lists the rivals in
``alternatives`` and gives ``close_call``: every effect of the close call with its explained
fraction and held-out score, and the experiment that separates them.

**The separating experiment** (:func:`design`), model-discrimination design after Box & Hill 1967
("Discrimination among mechanistic models", Technometrics 9(1), 57-71). Each model of the close call
(its refit nominal parameters and fitted effect) is simulated under every experiment of a short
feasible list (:func:`feasible_experiments`: the recorded experiment type, the dither amplitude
halved and raised by half, the default AFC sweep, and a rate table turning at 10 deg/s with one
sine of 7, 30, 80 or 230 Hz at a peak rate of 5 or 25 deg/s on one of the close call's axes, or
the default three sines). For two models with known noise variance ``sigma^2`` and no predictive
variance, Box and Hill's criterion (their eq. 13) is
``D = sum_{i<j} pi_i pi_j (eta_i - eta_j)^2 (2 / sigma^2)``, summed over the independent
observations, with equal prior weights ``pi_i``. A rival refits its parameters to any new recording,
so ``eta_i - eta_j`` is taken after model ``j``'s nominal and effect parameters are refitted to model
``i``'s prediction (the lack of fit that remains: the T-optimality of Atkinson & Fedorov 1975, "The
design of experiments for discriminating between two rival models", Biometrika 62(1), 57-70),
linearised: the difference projected off the columns of model ``j``'s Jacobian (forward
differences), and both directions averaged. ``sigma`` is the recording's noise floor per axis.

An experiment is **decisive** when, on some axis, the rival's lack of fit exceeds the diagnosis' own
allowance (the tolerance, or ``close_fraction`` of the excess a nominal refit leaves on the
prediction): only then does the rival stop closing the gap. Decisive experiments come first, then
the largest ``D``. The duration is the shortest (in steps of 0.5 s, at least 1 s) at which the
pair hardest to tell apart reaches a non-centrality of :data:`TARGET_NONCENTRALITY` (``D`` grows in
proportion to the number of samples).

:func:`experiment_yaml` writes the choice in the vocabulary of ``sins-sim simulate-recording``
(:mod:`sins_sim.config.experiment`), with the recording's header (axes, rates, quantum, nominal
parameters, dither amplitude) and no effects: the unit on the bench supplies them.

.. autosummary::

   close_rivals
   close_call
   feasible_experiments
   experiment_inputs
   design
   experiment_yaml
   close_call_lines
"""

from __future__ import annotations

import math

import numpy as np
from scipy import stats

from sins_sim.identification.refit import DiagnoseSettings, effects_of
from sins_sim.identification.verdict import AHEAD_ALPHA, MIN_PARTIAL, dm_pvalue
from sins_sim.io.recording import Recording
from sins_sim.simulation.experiment import (FIT_SETTINGS, ExperimentInputs, afc_drive, simulate_experiment,
                                            stationary_drive, suspension_from_nominal, table_motion)
from sins_sim.units import ARCMIN, ARCSEC, DEG

__all__ = ["TARGET_NONCENTRALITY", "RATE_TABLE_HZ", "RATE_TABLE_PEAK_DEG_S", "close_rivals", "close_call",
           "feasible_experiments", "experiment_inputs", "design", "experiment_yaml", "close_call_lines"]

#: Non-centrality the separating experiment must give the pair hardest to tell apart: the usual
#: normal-approximation rule ``(z_{1 - alpha/2} + z_{power})^2`` for a one-degree-of-freedom test at the
#: diagnosis' level ``alpha = 0.01`` (``verdict.ALPHA``) with power 0.99.
TARGET_NONCENTRALITY = float((stats.norm.ppf(1.0 - 0.01 / 2.0) + stats.norm.ppf(0.99)) ** 2)
#: The rate table's sine frequencies tried (Hz): the low, middle and high lines of the experiment
#: format's default table motion and one between.
RATE_TABLE_HZ = (7.0, 30.0, 80.0, 230.0)
#: The sines' peak rates tried (deg/s): the amplitude is ``peak / (2 pi f)``. At most 25 deg/s, the peak rate of each
#: sine of the experiment format's default table motion (30 arcmin at 7 Hz, 3 at 80 Hz, 1 at 230 Hz: 22-25 deg/s),
#: what a bench is taken to manage; 5 deg/s a gentler one.
RATE_TABLE_PEAK_DEG_S = (5.0, 25.0)
#: The table's constant rate in every rate-table experiment tried (deg/s), as in the format's default.
RATE_TABLE_DEG_S = 10.0
#: Shortest and longest suggested duration (s).
MIN_DURATION_S, MAX_DURATION_S = 1.0, 60.0
#: Length of the simulations the design compares (s): the recording's, at most this.
DESIGN_S = 1.0
#: Relative forward-difference step of the Jacobian columns (of ``max(|value|, the parameter's scale)``).
FD_STEP = 1e-4


def close_rivals(verdict: dict, candidates: list, settings: DiagnoseSettings) -> list:
    """The candidates the recording cannot rule out against the verdict's effect (see the module docstring).

    Only for a verdict that names one effect (``explained`` or ``partly explained``). A rival must be
    significant and either

    - explain alike: close at least ``MIN_PARTIAL`` of the gap, and the held-out test does not declare the
      verdict's effect better at ``AHEAD_ALPHA`` (``verdict.dm_pvalue``, the Newey-West Diebold-Mariano
      test; issue 39: the pair is then reported, not ranked), or
    - for ``explained``, close the gap as well and remove at least ``settings.min_gap_reduction`` of the
      excess power (within the allowance for model error, the ranking between them is no evidence).

    One whose fit lacks its effect's defining feature (``unresolved``) is a rival only of a best fit that lacks
    its own too.
    """
    status = verdict.get("status")
    if status not in ("explained", "partly explained") or len(verdict.get("effects", [])) != 1:
        return []
    best = next((c for c in candidates if c["effect"] == verdict["effect"]), None)
    if best is None:
        return []
    out = []
    for c in candidates:
        if c is best or not c.get("significant") or (c.get("unresolved") and not best.get("unresolved")):
            continue
        alike = (c["gap_reduction"] >= MIN_PARTIAL and "_losses" in c and "_losses" in best
                 and dm_pvalue(c["_losses"], best["_losses"]) >= AHEAD_ALPHA)
        closes_too = status == "explained" and c["closes_gap"] and c["gap_reduction"] >= settings.min_gap_reduction
        if alike or closes_too:
            out.append(c)
    return out


def _amplitude(rec: Recording) -> float:
    """The dither amplitude of the recording (rad): ``sqrt(2)`` times the RMS of its second half, largest axis."""
    out = 0.0
    for i, a in enumerate(rec.axes):
        d = rec.angle(a)
        if rec.sins_angle is not None:
            d = d - rec.sins_angle[:, i]
        half = d[rec.n_samples // 2:]
        out = max(out, math.sqrt(2.0) * float(np.std(half)))
    return out


def feasible_experiments(rec: Recording, axes) -> list:
    """The short list of experiments the design compares (see the module docstring).

    Each is a dict in the experiment format's vocabulary: ``experiment``, ``amplitude_arcmin`` and, for a
    rate table, ``rate_table`` (``rate_deg_s``, ``sines``, ``axes``); ``label`` names it.
    """
    amp = round(_amplitude(rec) / ARCMIN, 2)
    out = []
    if rec.experiment in ("stationary", "afc_sweep"):
        out.append({"label": f"{rec.experiment} as recorded", "experiment": rec.experiment, "amplitude_arcmin": amp})
    for fac in (0.5, 1.5):
        out.append({"label": f"stationary at {fac:g} x the dither amplitude", "experiment": "stationary",
                    "amplitude_arcmin": round(amp * fac, 2)})
    if rec.experiment != "afc_sweep":
        out.append({"label": "afc_sweep (default plan)", "experiment": "afc_sweep", "amplitude_arcmin": amp})
    for a in axes:
        for f in RATE_TABLE_HZ:
            for peak in RATE_TABLE_PEAK_DEG_S:
                s = round(math.radians(peak) / (2.0 * math.pi * f) / ARCMIN, 2)
                out.append({"label": f"rate_table on {a}: {RATE_TABLE_DEG_S:g} deg/s + {s:g} arcmin at {f:g} Hz",
                            "experiment": "rate_table", "amplitude_arcmin": amp,
                            "rate_table": {"rate_deg_s": RATE_TABLE_DEG_S, "axes": [a],
                                           "sines": [{"amplitude_arcmin": s, "frequency_hz": f}]}})
    out.append({"label": "rate_table, the format's default motion on every axis", "experiment": "rate_table",
                "amplitude_arcmin": amp, "rate_table": {"rate_deg_s": RATE_TABLE_DEG_S, "axes": list(rec.axes),
                                                        "sines": [{"amplitude_arcmin": 30.0, "frequency_hz": 7.0},
                                                                  {"amplitude_arcmin": 3.0, "frequency_hz": 80.0,
                                                                   "phase_deg": 60.0},
                                                                  {"amplitude_arcmin": 1.0, "frequency_hz": 230.0,
                                                                   "phase_deg": 120.0}]}})
    return out


def experiment_inputs(rec: Recording, spec: dict, duration_s: float) -> ExperimentInputs:
    """The engine's inputs for an experiment of the list (or a document of :func:`experiment_yaml`) on the
    recording's axes, rates and nominal parameters, built as ``simulate-recording`` builds them (from rest)."""
    fs, dfs = rec.fs_hz, rec.drive_fs_hz
    ratio = int(round(dfs / fs))
    n = int(math.floor(duration_s * fs + 1e-9)) + 1
    nominal = {a: suspension_from_nominal(rec.nominal[a]) for a in rec.axes}
    amp = spec["amplitude_arcmin"] * ARCMIN
    if spec["experiment"] == "afc_sweep":
        drive, _ = afc_drive(nominal, rec.axes, amp, [0.5, 0.75, 1.0, 1.25], [-3.0, -1.5, 0.0, 1.5, 3.0], 0.25,
                             dfs, n * ratio)
    else:
        drive = stationary_drive(nominal, rec.axes, amp, dfs, n * ratio)
    table = None
    if spec["experiment"] == "rate_table":
        rt = spec["rate_table"]
        mot = table_motion(rt["rate_deg_s"] * DEG, [(s["amplitude_arcmin"] * ARCMIN, s["frequency_hz"],
                                                     math.radians(s.get("phase_deg", 0.0))) for s in rt["sines"]])
        table = {a: mot for a in rt["axes"]}
    return ExperimentInputs(rec.axes, fs, n, dfs, drive, table)


class _Model:
    """One model of a close call: refit suspensions per axis and the fitted effects."""

    def __init__(self, cand: dict, rec: Recording):
        self.name = cand["effect"]
        self.axes = list(cand["axes"])
        self.susp = {a: cand["fits"][a].suspension for a in rec.axes}
        self.effects = {a: list(effects_of(cand["fits"][a].effect)) for a in self.axes
                        if cand["fits"][a].effect is not None}
        self.rec_axes = list(rec.axes)

    def _all_effects(self, effects=None):
        effects = self.effects if effects is None else effects
        return [e for a in effects for e in effects[a]]

    def predict(self, inputs, susp=None, effects=None) -> dict:
        return simulate_experiment(inputs, susp or self.susp, self._all_effects(effects), FIT_SETTINGS)

    def jacobian(self, inputs, y0: dict, weight: dict) -> tuple:
        """Forward-difference columns (whitened, stacked over ``weight``'s axes): nominal only, then all."""
        nominal_cols, effect_cols = [], []
        keys = ("f0_hz", "k1", "k2", "k3", "k4", "k5")
        for a in self.axes:
            s = self.susp[a]
            for k in keys:
                val = float(getattr(s, k))
                step = FD_STEP * (abs(val) or 1.0)
                y = self.predict(inputs, susp={**self.susp, a: s.replace(**{k: val + step})})
                nominal_cols.append(_stack(y, y0, weight) / step)
            for i, e in enumerate(self.effects.get(a, [])):
                cls = type(e)
                vals = e.values(a)
                for p in cls.fit_space(a, self.rec_axes):
                    val = float(vals[p.name])
                    step = FD_STEP * max(abs(val), p.scale)
                    if val + step > p.hi:
                        step = -step
                    moved = list(self.effects[a])
                    moved[i] = cls.build(a, self.rec_axes, {**vals, p.name: val + step})
                    y = self.predict(inputs, effects={**self.effects, a: moved})
                    effect_cols.append(_stack(y, y0, weight) / step)
        nom = np.column_stack(nominal_cols)
        return nom, np.column_stack(nominal_cols + effect_cols)


def _stack(y: dict, y0: dict, weight: dict) -> np.ndarray:
    return np.concatenate([(y[a] - y0[a]) / weight[a] for a in weight])


def _lack_of_fit(diff: np.ndarray, jac: np.ndarray) -> np.ndarray:
    """``diff`` less its least-squares projection on the columns of ``jac`` (columns scaled to unit norm)."""
    norms = np.linalg.norm(jac, axis=0)
    keep = norms > 0.0
    if not np.any(keep):
        return diff
    j = jac[:, keep] / norms[keep]
    coef, *_ = np.linalg.lstsq(j, diff, rcond=1e-10)
    return diff - j @ coef


def _per_axis(v: np.ndarray, axes, n: int) -> dict:
    return {a: float(np.sum(v[i * n:(i + 1) * n] ** 2)) for i, a in enumerate(axes)}


def design(rec: Recording, cands: list, floors: dict, settings: DiagnoseSettings, experiments=None) -> dict:
    """Rank the feasible experiments by how well they separate the models of a close call.

    Parameters
    ----------
    rec : Recording
    cands : list of dict
        The close call's candidates (the verdict's effect first), with their ``fits``.
    floors : dict
        The noise floor per axis (``{"floor_rad": ...}``).
    settings : DiagnoseSettings
        ``rel_tol`` and ``close_fraction`` (the allowance a rival must exceed).
    experiments : list of dict or None
        Default :func:`feasible_experiments` on the axes the candidates were fitted on.

    Returns
    -------
    dict
        ``best`` (the chosen experiment with ``duration_s``), ``ranking`` (every experiment: ``label``,
        ``box_hill_D``, ``decisive``, ``separation_ratio``), ``criterion`` (in words), ``models``.
    """
    axes = [a for a in rec.axes if any(a in c["axes"] for c in cands)]
    models = [_Model(c, rec) for c in cands]
    experiments = feasible_experiments(rec, axes) if experiments is None else experiments
    dur = min(DESIGN_S, rec.duration_s)
    weight = {a: max(floors[a]["floor_rad"], rec.quantum_rad / math.sqrt(12.0)) for a in axes}
    pi = 1.0 / len(models)
    rows = []
    for spec in experiments:
        inputs = experiment_inputs(rec, spec, dur)
        n = inputs.n_samples
        preds = [m.predict(inputs) for m in models]
        jacs = [m.jacobian(inputs, p, weight) for m, p in zip(models, preds)]
        plain = [m.predict(inputs, effects={}) for m in models]
        d_total, worst_pair, ratio = 0.0, math.inf, math.inf
        for i in range(len(models)):
            # the excess a nominal refit leaves on model i's prediction (the rival must exceed a fraction of it)
            excess_i = _per_axis(_lack_of_fit(_stack(preds[i], plain[i], weight), jacs[i][0]), axes, n)
            for j in range(len(models)):
                if i == j:
                    continue
                lof = _per_axis(_lack_of_fit(_stack(preds[i], preds[j], weight), jacs[j][1]), axes, n)
                d_total += pi * pi * 2.0 * sum(lof.values())  # ordered pairs: each unordered pair twice
                allow = {a: max(settings.rel_tol ** 2 * n, settings.close_fraction ** 2 * excess_i[a]) for a in axes}
                r = max(math.sqrt(lof[a] / allow[a]) for a in axes)
                ratio = min(ratio, r)
                worst_pair = min(worst_pair, sum(lof.values()))
        rows.append({"label": spec["label"], "spec": spec, "box_hill_D": d_total / 2.0,
                     "worst_pair_noncentrality": worst_pair, "separation_ratio": ratio, "decisive": ratio > 1.0,
                     "design_s": dur})
    rows.sort(key=lambda r: (not r["decisive"], -r["box_hill_D"]))
    best = dict(rows[0])
    need = dur * TARGET_NONCENTRALITY / max(best["worst_pair_noncentrality"], 1e-300)
    best["duration_s"] = float(min(MAX_DURATION_S, max(MIN_DURATION_S, math.ceil(need / 0.5) * 0.5)))
    crit = (f"Box & Hill 1967 divergence after the rival refits (Atkinson & Fedorov 1975, linearised), noise = the "
            f"floor; decisive when a rival's lack of fit exceeds the gap allowance; duration for a non-centrality "
            f"of {TARGET_NONCENTRALITY:.1f} on the pair hardest to tell apart")
    return {"best": best, "ranking": [{k: r[k] for k in ("label", "box_hill_D", "worst_pair_noncentrality",
                                                          "separation_ratio", "decisive")} for r in rows],
            "criterion": crit, "models": [m.name for m in models]}


def experiment_yaml(rec: Recording, chosen: dict, models) -> dict:
    """The chosen experiment as a ``simulate-recording`` document (no effects: the bench unit has them)."""
    spec = chosen["spec"]
    keys = {"f0_hz": "f0_hz", "k1": "k1", "k2": "k2_rad", "k3": "k3", "k4": "k4_per_rad", "k5": "k5_rad_per_v",
            "zeta": "zeta"}  # the header's names -> the experiment format's (config.experiment.SUSPENSION_YAML_KEYS)
    doc = {"name": "separate-" + "-".join(models), "experiment": spec["experiment"],
           "description": f"separates {', '.join(models)} (suggested by sins-sim diagnose: {chosen['label']})",
           "axes": list(rec.axes), "duration_s": chosen["duration_s"], "fs_hz": float(rec.fs_hz),
           "drive_fs_hz": float(rec.drive_fs_hz), "quantum_arcsec": float(rec.quantum_rad / ARCSEC),
           "initial_state": "rest", "amplitude_arcmin": float(spec["amplitude_arcmin"]),
           "nominal": {a: {keys[k]: float(v) for k, v in rec.nominal[a].items() if k in keys} for a in rec.axes}}
    if spec["experiment"] == "rate_table":
        doc["rate_table"] = spec["rate_table"]
    return doc


def close_call(rec: Recording, verdict: dict, candidates: list, floors: dict, settings: DiagnoseSettings) -> dict:
    """The verdict with its close call said (a copy; unchanged when there is none). See the module docstring.

    Adds the rivals to ``alternatives`` and ``close_call``: ``effects`` (each with ``explained_fraction``,
    ``score_arcsec``, ``params``), ``experiment`` (the separating experiment as a ``simulate-recording``
    document), ``why`` (the chosen experiment's label and its predicted separation) and ``ranking``.
    """
    rivals = close_rivals(verdict, candidates, settings)
    if not rivals:
        return verdict
    best = next(c for c in candidates if c["effect"] == verdict["effect"])
    group = [best] + rivals
    out = dict(verdict)
    out["alternatives"] = list(verdict.get("alternatives", [])) + [c["effect"] for c in rivals
                                                                  if c["effect"] not in verdict.get("alternatives", [])]
    des = design(rec, group, floors, settings)
    chosen = des["best"]
    out["close_call"] = {
        "effects": [{"effect": c["effect"], "explained_fraction": c["gap_reduction"], "score_arcsec": c["score"],
                     "params": c["params"]} for c in group],
        "experiment": experiment_yaml(rec, chosen, des["models"]),
        "why": (f"{chosen['label']}: Box-Hill D = {chosen['box_hill_D']:.3g} per {chosen['design_s']:g} s; the rival's "
                f"lack of fit is {chosen['separation_ratio']:.3g} x the gap allowance"
                + ("" if chosen["decisive"] else " (no experiment of the list is decisive)")),
        "criterion": des["criterion"],
        "ranking": des["ranking"][:5],
    }
    return out


def close_call_lines(cc: dict) -> list:
    """The report's section on a close call (Markdown lines): the rivals' fractions and the experiment."""
    lines = ["## Close call", "", "The recording cannot tell these apart (each closes the gap within the allowance "
             "for model error, or the held-out test does not declare one better):", "",
             "| effect | explained fraction | held-out RMS (arcsec) | parameters |",
             "|---|---|---|---|"]
    for e in cc["effects"]:
        pars = "; ".join(f"{ax}: " + ", ".join(f"{k} = {val:.4g}" for k, val in pv.items())
                         for ax, pv in e["params"].items())
        lines.append(f"| {e['effect']} | {e['explained_fraction']:.5f} | {e['score_arcsec']:.4g} | {pars} |")
    doc = cc["experiment"]
    lines += ["", f"What would separate them: {cc['why']}. As an experiment file (`sins-sim diagnose --suggest "
              f"FILE` writes it): `{doc['experiment']}`, {doc['duration_s']:g} s, dither {doc['amplitude_arcmin']:g} "
              f"arcmin" + (f", table {doc['rate_table']}" if "rate_table" in doc else "") + ".",
              f"Criterion: {cc['criterion']}.", ""]
    return lines
