"""A recording's diagnosis as a Python object (:class:`DiagnosisResult`)."""

from __future__ import annotations

__all__ = ["DiagnosisResult"]


class DiagnosisResult(dict):
    """A recording's diagnosis (:func:`sins_sim.jobs.recording_jobs.diagnose`): its JSON as a dict, with
    :meth:`to_pandas` of its tables. Its figures are those of the report folder (``report_dir``)."""

    def to_pandas(self) -> dict:
        """``candidates``: one row per effect tried (index ``effect``), in the diagnosis' order (best first):
        ``residual_rms_arcsec``, ``gap_reduction``, ``score``, ``closes_gap``, ``remaining_excess_arcsec``,
        ``p_heldout``, ``p_f``, ``significant``, ``unresolved``; ``axes``: per axis (index ``axis``) the
        ``noise_floor_arcsec`` and the nominal refit's ``baseline_residual_rms_arcsec`` (empty when the
        data failed the checks: see ``findings``)."""
        import pandas as pd

        cols = ["residual_rms_arcsec", "gap_reduction", "score", "closes_gap", "remaining_excess_arcsec",
                "p_heldout", "p_f", "significant", "unresolved"]
        cand = pd.DataFrame([{k: c.get(k) for k in cols} for c in self.get("candidates") or []], columns=cols,
                            index=pd.Index([c["effect"] for c in self.get("candidates") or []], name="effect"))
        floors = self.get("noise_floor_axes_arcsec") or {}
        base = (self.get("baseline") or {}).get("residual_rms_axes_arcsec") or {}
        axes = pd.DataFrame({"noise_floor_arcsec": pd.Series(floors, dtype=float),
                             "baseline_residual_rms_arcsec": pd.Series(base, dtype=float)})
        axes.index.name = "axis"
        return {"candidates": cand, "axes": axes}
