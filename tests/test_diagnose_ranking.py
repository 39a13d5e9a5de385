"""Issue 24 items 4 and 6: implausible fits rank after plausible ones; a dominant effect is named with the
remainder localised when the greedy selection stops early.

The statistics are exercised on hand-made candidates (what ``explain`` and ``assess`` produce), the whole
chain on short recordings of the bench unit of ``tests/test_diagnose.py`` (RK4 at 72 kHz against the
diagnosis' exact integrator, slow).
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from sins_sim.identification.diagnose import DiagnoseSettings, diagnose_recording
from sins_sim.identification.plausibility import (SWITCH_SIGMA, assess_plausibility, candidate_plausibility,
                                                  plausible_first)
from sins_sim.identification.report import _plausibility_lines
from sins_sim.identification.verdict import AHEAD_ALPHA, DOMINANT, dm_pvalue, first_step, give_verdict
from sins_sim.models.effects import EFFECTS, make_effect
from sins_sim.units import ARCMIN, ARCSEC

from test_diagnose import NOM, _recording  # noqa: E402  (the shared bench unit)
from test_diagnose_verdict import _cand  # noqa: E402  (hand-made candidates)

FLOOR = {"floor_rad": 0.3 * ARCSEC}


def _fit(rms_arcsec):
    return SimpleNamespace(rms=rms_arcsec * ARCSEC)


# --- plausibility ------------------------------------------------------------------------------------
def _pcand(effect, params, sd, rms_after):
    return {"effect": effect, "params": params, "uncertainty": sd, "fits": {a: _fit(r) for a, r in rms_after.items()}}


def test_an_effect_switched_on_where_it_explains_no_gap_is_implausible():
    """A lock-in threshold of 4.2e-3 rad/s, 40 sigma from 0, on an axis whose excess it lowers by 0.01 arcsec
    RMS (tolerance 0.05): implausible, the reason naming the axis and the value. On the axis where it removes
    0.5 arcsec of excess it is plausible; a threshold within SWITCH_SIGMA of 0 (switched off) is no reason."""
    ref = {"x": _fit(0.8), "y": _fit(0.31)}
    floors = {"x": FLOOR, "y": FLOOR}
    tol = {"x": 0.05 * ARCSEC, "y": 0.05 * ARCSEC}
    ok = _pcand("lock_in", {"x": {"threshold_rad_s": 4.2e-3, "phase_rad": 1.0}},
                {"x": {"threshold_rad_s": 1e-4, "phase_rad": 0.1}}, {"x": 0.35, "y": 0.31})
    assert candidate_plausibility(ok, ref, floors, tol, ["x", "y"], ["x", "y"])["plausible"]
    bad = _pcand("lock_in", {"y": {"threshold_rad_s": 4.2e-3, "phase_rad": 1.0}},
                 {"y": {"threshold_rad_s": 1e-4, "phase_rad": 0.1}}, {"x": 0.8, "y": 0.3098})
    p = candidate_plausibility(bad, ref, floors, tol, ["x", "y"], ["x", "y"])
    assert not p["plausible"] and "axis y" in p["reasons"][0] and "threshold_rad_s = 0.0042" in p["reasons"][0]
    off = _pcand("lock_in", {"y": {"threshold_rad_s": 0.9 * SWITCH_SIGMA * 1e-4, "phase_rad": 1.0}},
                 {"y": {"threshold_rad_s": 1e-4, "phase_rad": 0.1}}, {"x": 0.8, "y": 0.3098})
    assert candidate_plausibility(off, ref, floors, tol, ["x", "y"], ["x", "y"])["plausible"]
    # fitted on an axis without a significant gap at all
    p = candidate_plausibility(ok, ref, floors, tol, ["y"], ["x", "y"])
    assert not p["plausible"] and "shows no gap" in p["reasons"][0]


def test_a_parameter_at_the_end_of_its_declared_range_is_implausible():
    """A block mode pressed to damping ratio 1.0, the top of the range ``BlockMode.PARAMS`` declares: implausible;
    a piezo lag at 0 (the end of its range where the effect vanishes) is not."""
    hi = next(p.hi for p in EFFECTS["block_mode"].PARAMS if p.name == "zeta")
    ref = {"x": _fit(0.8)}
    tol = {"x": 0.05 * ARCSEC}
    c = _pcand("block_mode", {"x": {"frequency_hz": 650.0, "zeta": hi, "gain": 0.3}}, {"x": {}}, {"x": 0.35})
    p = candidate_plausibility(c, ref, {"x": FLOOR}, tol, ["x"], ["x"])
    assert not p["plausible"] and "zeta = 1" in p["reasons"][0] and "[0.0001, 1]" in p["reasons"][0]
    c = _pcand("piezo_lag", {"x": {"tau_s": 0.0}}, {"x": {"tau_s": 1e-6}}, {"x": 0.35})
    assert candidate_plausibility(c, ref, {"x": FLOOR}, tol, ["x"], ["x"])["plausible"]


def test_a_nominal_refit_bent_to_a_limit_only_with_the_effect_is_a_reason():
    """Flags the candidate's nominal refit has and the baseline's lacks are reasons; shared ones are not."""
    ref = {"x": _fit(0.8)}
    c = _pcand("viscous_damping", {"x": {"zeta": 1e-3}}, {"x": {"zeta": 1e-5}}, {"x": 0.35})
    flag = {"axis": "x", "parameter": "k2", "message": "axis x: k2 at 4.1 times nominal"}

    def flags(fits):
        return [flag] if fits["x"] is c["fits"]["x"] else []

    assess_plausibility([c], ref, {"x": FLOOR}, {"x": 0.05 * ARCSEC}, ["x"], ["x"], flags)
    assert not c["plausibility"]["plausible"] and "k2 at 4.1 times nominal" in c["plausibility"]["reasons"][0]
    assess_plausibility([c], ref, {"x": FLOOR}, {"x": 0.05 * ARCSEC}, ["x"], ["x"], lambda fits: [flag])
    assert c["plausibility"]["plausible"]


def test_an_implausible_candidate_is_ranked_after_a_plausible_one_and_the_verdict_says_why():
    """An implausible candidate that scores best (and halves every held-out block against the next) is not
    named: the plausible one is, the implausible one is listed with its reason in ``verdict.plausibility`` and
    in the report's lines. With no plausible significant candidate the implausible one is still named, its
    reasons given."""
    rng = np.random.default_rng(5)
    base = np.exp(rng.normal(0.0, 1.0, 10))
    bad = _cand("lock_in", 2, 0.25 * base, 0.05)
    bad["closes_gap"], bad["gap_reduction"] = True, 0.95
    bad["plausibility"] = {"plausible": False, "reasons": ["lock_in needs threshold_rad_s = 0.0042 on axis y"]}
    good = _cand("piezo_lag", 1, 0.5 * base, 0.08)
    good["closes_gap"], good["gap_reduction"] = True, 0.9
    good["plausibility"] = {"plausible": True, "reasons": []}
    ranked = plausible_first([bad, good])
    assert [c["effect"] for c in ranked] == ["piezo_lag", "lock_in"]
    fits = {"x": SimpleNamespace(heldout_rms=0.5 * ARCSEC, rms=0.5 * ARCSEC)}
    v = give_verdict(fits, ["x"], ranked, DiagnoseSettings())
    assert v["effect"] == "piezo_lag" and v["status"] == "explained"
    assert v["plausibility"]["ranked_after"] == [{"effect": "lock_in", "reasons": bad["plausibility"]["reasons"]}]
    lines = "\n".join(_plausibility_lines(v))
    assert "lock_in is ranked after the plausible candidates: lock_in needs threshold_rad_s" in lines
    v = give_verdict(fits, ["x"], plausible_first([bad, {**good, "significant": False}]), DiagnoseSettings())
    assert v["effect"] == "lock_in" and not v["plausibility"]["named"]["lock_in"]["plausible"]
    assert "the named effect lock_in is implausible" in "\n".join(_plausibility_lines(v))


# --- dominant effect plus remainder --------------------------------------------------------------------
def _tied(frac):
    """A best candidate closing ``frac`` of the gap (not all) and a runner-up the held-out data cannot tell from
    it (block losses scattered by 5 %), both significant."""
    rng = np.random.default_rng(6)
    base = np.exp(rng.normal(0.0, 1.0, 10))
    best = _cand("piezo_lag", 1, 0.3 * base, 0.30)
    rival = _cand("readout_delay", 1, 0.3 * base * np.exp(rng.normal(0.0, 0.05, 10)), 0.301)
    for c in (best, rival):
        c["gap_reduction"] = frac
    assert dm_pvalue(rival["_losses"], best["_losses"]) >= AHEAD_ALPHA
    return [best, rival]


def test_a_dominant_first_effect_not_clearly_ahead_is_partly_explained_with_its_rival():
    """A first effect closing 0.89 of the gap, tied with its runner-up, no second effect: ``partly explained``
    naming it (0.89) with the runner-up as alternative (was ``unknown``); closing less than DOMINANT it stays
    ``unknown``."""
    fits = {"x": SimpleNamespace(heldout_rms=0.5 * ARCSEC, rms=0.5 * ARCSEC)}
    settings = DiagnoseSettings()
    cands = _tied(0.89)
    steps = first_step(cands, 0.5, settings)
    assert steps[0]["tentative"] and steps[0]["rival"] == "readout_delay"
    v = give_verdict(fits, ["x"], cands, settings, remainder={"axis": "x"})
    assert v["status"] == "partly explained" and v["effect"] == "piezo_lag"
    assert v["explained_fraction"] == pytest.approx(0.89) and v["alternatives"] == ["readout_delay"]
    assert v["remainder"] == {"axis": "x"}
    v = give_verdict(fits, ["x"], _tied(0.9 * DOMINANT), settings)
    assert v["status"] == "unknown" and v["effects"] == []


@pytest.mark.slow
@pytest.mark.parametrize("experiment", ["stationary", "rate_table"])
def test_piezo_lag_plus_a_weak_axis_coupling_is_partly_explained_with_the_remainder_localised(experiment):
    """A piezo lag of 120 us on both axes (the dominant effect) plus a coupling of y into x of 0.0008, the
    greedy selection stopped after the first effect (``max_effects = 1``; on the issue's independent
    recording the coupling's step failed the held-out test): ``partly explained``, the lag named with the
    share it closes, the remainder on axis x at y's dither line and in time. In a dither-only recording a
    drive lag and a readout delay are nearly the same phase shift, so there the pair is named (one as the
    effect, the other as alternative); on the rate table the lag alone."""
    effects = [make_effect("piezo_lag", tau_s=1.2e-4), make_effect("axis_coupling", coefficients={"x": {"y": 0.0008}})]
    rec = _recording(experiment, effects, duration=0.8 if experiment == "stationary" else 0.6, axes=("x", "y"))
    v = diagnose_recording(rec, DiagnoseSettings(max_effects=1)).to_json()["verdict"]
    assert v["status"] == "partly explained", v
    if experiment == "stationary":
        assert {v["effect"], *v["alternatives"]} == {"piezo_lag", "readout_delay"}
    else:
        assert v["effect"] == "piezo_lag"
    assert DOMINANT <= v["explained_fraction"] < 0.99  # the coupling's share is left
    r = v["remainder"]
    f_y = NOM["y"].resonance_hz(3 * ARCMIN)
    assert r["axis"] == "x" and r["band_hz"][0] - 3 <= f_y <= r["band_hz"][1] + 3
    assert r["excess_rms_arcsec"]["x"] > 5 * r["excess_rms_arcsec"]["y"]
    assert 0.0 <= r["time_s"][0] < r["time_s"][1] <= rec.duration_s
