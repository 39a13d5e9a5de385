"""The online estimator inside a channel: estimate in operation, and feed the correcting filters.

:class:`OnlineLoop` runs one :class:`~sins_sim.filters.online_estimator.OnlineEstimator` on a
:class:`~sins_sim.simulation.channel.ChannelChain`'s decimated readout and drive (what the unit's
electronics have), at the filter rate, and every ``update_s`` (counted from t = 0 on the plant-step
grid, so results do not depend on chunking):

1. solves the estimator (``OnlineEstimator.solve``, with its guards);
2. with ``apply``: moves the values the correcting filters use (both forms of eq. 5, and the
   plug-ins that take a new design in operation: the wideband filters) toward the
   estimate by first-order smoothing, ``p += (1 - exp(-update_s / smoothing_s)) (p_est - p)``
   (``smoothing_s = 0``: the estimate itself), and loads them into the filters from the next
   sample on. Causal: the filters never see an estimate made from data after the sample they
   filter. Values the filter refuses (``CorrectingFilterDesign``'s ranges) are not loaded and the
   event is reported;
3. records the estimate, the smoothed values and the plant's truth at that instant in ``history``.

Under a temperature profile with PLL tracking the drive frequency changes at the schedule's blocks;
the loop feeds the estimator block by block with the drive frequency of each, and the schedule no
longer moves the filters' f0 (the estimate does).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from sins_sim._kernels import chain as kchain
from sins_sim.filters.online_estimator import OnlineEstimator, OnlineSettings

__all__ = ["OnlineSpec", "OnlineLoop", "history_arrays"]

_KS = ("k1", "k2", "k3", "k4", "k5")


@dataclass(frozen=True)
class OnlineSpec:
    """An online estimator on a channel.

    Parameters
    ----------
    settings : OnlineSettings
    update_s : float
        Interval between updates (s).
    smoothing_s : float
        Time constant of the smoothing of the values fed to the filters (s); 0: none.
    apply : bool
        Feed the correcting filters (False: estimate only, the filters keep their parameters).
    datasheet : dict
        ``f0_hz, k1 .. k5``: the prior, and the values before the first good estimate.
    """

    settings: OnlineSettings = field(default_factory=OnlineSettings)
    update_s: float = 0.1
    smoothing_s: float = 0.0
    apply: bool = True
    datasheet: dict | None = None

    def __post_init__(self):
        if not (isinstance(self.update_s, (int, float)) and math.isfinite(self.update_s) and self.update_s > 0.0):
            raise ValueError(f"online.update_s: must be a positive number, got {self.update_s!r}")
        if not (isinstance(self.smoothing_s, (int, float)) and math.isfinite(self.smoothing_s)
                and self.smoothing_s >= 0.0):
            raise ValueError(f"online.smoothing_s: must be >= 0, got {self.smoothing_s!r}")


class OnlineLoop:
    """One chain's estimator, its update schedule and what it feeds the filters (see module docstring)."""

    def __init__(self, chain, spec: OnlineSpec):
        cfg = chain.cfg
        self.spec = spec
        ds = spec.datasheet
        if ds is None:
            s = cfg.filter_suspension or cfg.suspension
            ds = {"f0_hz": s.f0_hz, **{k: getattr(s, k) for k in _KS}}
        self.estimator = OnlineEstimator(spec.settings, cfg.filter_rate_hz, chain.drive.frequency_hz,
                                         cfg.drive.amplitude_rad, chain.v_m0, chain.control.v_max_factor * chain.v_m0,
                                         ds)
        self.h = chain.plant.h
        self.r_dec = chain.r_dec
        self.update = self.r_dec * max(1, int(round(spec.update_s / (self.r_dec * self.h))))
        self.alpha = 1.0 if spec.smoothing_s == 0.0 else 1.0 - math.exp(-self.update * self.h / spec.smoothing_s)
        self.designs0 = {name: chain.filters[name].design for name in ("correcting", "correcting_paper")}
        self.reset(chain)

    def reset(self, chain=None):
        self.estimator.reset()
        d = self.designs0["correcting"]
        self.fed = {"f0_hz": d.f0_hz, **{k: getattr(d, k) for k in _KS}}
        self.history = []
        self.events = []
        if chain is not None and chain.thermal is not None:
            chain.thermal.filters_follow_drive = not self.spec.apply

    def run(self, chain, i0: int, angle: np.ndarray, rate: np.ndarray, inner):
        """``inner(i0, angle, rate)`` over the chunk in pieces that end at updates and temperature blocks."""
        n = angle.shape[0]
        th = chain.thermal
        pieces = []
        j = 0
        while j < n:
            g = i0 + j
            nxt = self.next_update(g)
            if th is not None:
                nxt = min(nxt, (g // th.block + 1) * th.block)
            j1 = min(n, nxt - i0)
            out = inner(g, angle[j:j1], rate[j:j1])
            out["delta"] = np.array(out["delta"])  # the fused path reuses its work buffer
            self.after_piece(chain, out, i0 + j1)
            pieces.append(out)
            j = j1
        if len(pieces) == 1:
            return pieces[0]
        return {k: np.concatenate([p[k] for p in pieces]) for k in pieces[0]}

    def next_update(self, g: int) -> int:
        """The first update at or after plant step ``g + 1`` (updates fall on multiples of ``update`` steps)."""
        return (g // self.update + 1) * self.update

    def after_piece(self, chain, out: dict, g_end: int) -> None:
        """Feed the estimator a piece's filter-rate ``raw`` and ``volts`` that ends at plant step ``g_end``, and
        update (solve, feed the filters from the next sample on) when an update falls there."""
        self.estimator.process(out["raw"], out["volts"], chain.drive_hz)
        if g_end % self.update == 0:
            self._update(chain, g_end * self.h)

    def _update(self, chain, t_s: float):
        est = self.estimator.solve()
        if self.spec.apply:
            vals = est.values
            new = {k: self.fed[k] + self.alpha * (vals[k] - self.fed[k]) for k in ("f0_hz",) + _KS}
            if all(math.isfinite(x) for x in new.values()):
                try:
                    designs = {name: dataclasses.replace(d0, f0_hz=new["f0_hz"], **{k: new[k] for k in _KS})
                               for name, d0 in self.designs0.items()}
                    self._load(chain, designs)
                except ValueError as exc:
                    self.estimator._event("filter", f"not loaded into the filters: {exc}")
                else:
                    self.fed = new
        s = chain.plant.suspension
        a_ref = chain.cfg.drive.amplitude_rad
        truth = {"f0_hz": s.f0_hz, **{k: getattr(s, k) for k in _KS}, "q": s.q_factor(a_ref)}
        self.history.append({"t_s": t_s, "estimate": dict(est.values), "std": dict(est.std), "fed": dict(self.fed),
                             "truth": truth, "applied": dict(est.applied), "locked_hz": est.locked_hz,
                             "drive_hz": chain.drive_hz, "spread": est.spread})

    @staticmethod
    def _load(chain, designs):
        """Both eq. 5 forms (objects and the fused kernel's ``cpar`` rows) and the plug-ins that can change their
        design in operation (``set_design``: the wideband filters) get the values of ``designs``."""
        d = designs["correcting"]
        for flt in chain.plugins.values():
            if hasattr(flt, "set_design"):
                flt.set_design(dataclasses.replace(flt.design, f0_hz=d.f0_hz, **{k: getattr(d, k) for k in _KS}))
        for row, (name, design) in enumerate(designs.items()):
            flt = chain.filters[name]
            flt.design = design
            flt._a2, flt._g = design.coefficients
            flt._fast_dt = 0.25 / design.f0_hz
            cp = chain.cpar[row]
            cp[kchain.C_A2], cp[kchain.C_G] = flt._a2, flt._g
            cp[kchain.C_K1:kchain.C_K1 + 5] = (design.k1, design.k2, design.k3, design.k4, design.k5)
            cp[kchain.C_FAST] = flt._fast_dt


def history_arrays(history: list) -> dict:
    """``OnlineLoop.history`` as arrays: ``t_s`` and, per parameter, ``estimate_<p>``, ``std_<p>``,
    ``fed_<p>`` and ``truth_<p>`` (``p`` in f0_hz, k1 .. k5, q; ``fed`` has no q)."""
    out = {"t_s": np.array([h["t_s"] for h in history])}
    for p in ("f0_hz",) + _KS + ("q",):
        for key in ("estimate", "std", "fed", "truth"):
            if p in history[0][key] if history else False:
                out[f"{key}_{p}"] = np.array([h[key][p] for h in history], dtype=np.float64)
    for key in ("locked_hz", "drive_hz", "spread"):
        out[key] = np.array([h[key] for h in history])
    return out
