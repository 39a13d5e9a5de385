"""An error budget as a Python object (:class:`BudgetResult`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sins_sim.results._folder import read_json

__all__ = ["BudgetResult"]

_NED = ("north", "east", "down")


class BudgetResult(dict):
    """The error budget of a scenario (:func:`sins_sim.jobs.budget.run_budget`): the content of ``budget.json``
    as a dict, with :meth:`to_pandas` and :meth:`plot`.

    Each term (``total``, every source, ``dither_residual``, ``floor``, ``remainder``) holds per filter the
    final north/east position error vector (m) and NED attitude error vector (arcsec) and their magnitudes
    (``note`` says how each is formed).
    """

    def terms(self) -> list:
        """The rows in the order of ``budget.png``: total, the sources, floor, remainder."""
        return ["total", *self["sources"], "floor", "remainder"]

    def _term(self, term) -> dict:
        return self["sources"][term] if term in self["sources"] else self[term]

    def to_pandas(self):
        """One row per (term, filter): ``horizontal_position_error_m``, ``position_north_m``,
        ``position_east_m``, ``attitude_error_arcsec`` and ``attitude_<north|east|down>_arcsec``
        (NaN where the budget has no entry)."""
        import pandas as pd

        rows, index = [], []
        for term in self.terms():
            for f in self["filters"]:
                e = self._term(term).get(f) or {}
                pos = e.get("position_ne_m") or [np.nan, np.nan]
                att = e.get("attitude_ned_arcsec") or [np.nan] * 3
                rows.append({"horizontal_position_error_m": e.get("horizontal_position_error_m", np.nan),
                             "position_north_m": pos[0], "position_east_m": pos[1],
                             "attitude_error_arcsec": e.get("attitude_error_arcsec", np.nan),
                             **{f"attitude_{a}_arcsec": x for a, x in zip(_NED, att)}})
                index.append((term, f))
        df = pd.DataFrame(rows, index=pd.MultiIndex.from_tuples(index, names=["term", "filter"]))
        return df.astype(float)

    def plot(self):
        """``budget.png``'s figure, returned (not written)."""
        from sins_sim.plots.budget import plot_budget

        return plot_budget(self, None, f"{self['scenario']}: error budget after {self['duration_s']:g} s")

    @classmethod
    def from_folder(cls, folder) -> "BudgetResult":
        """The budget of a ``sins-sim budget`` folder (its ``budget.json``)."""
        return cls(read_json(Path(folder) / "budget.json", "budget"))
