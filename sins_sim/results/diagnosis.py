"""A recording's diagnosis as a Python object (:class:`DiagnosisResult`)."""

from __future__ import annotations

__all__ = ["DiagnosisResult"]


class DiagnosisResult(dict):
    """A recording's diagnosis (:func:`sins_sim.jobs.recording_jobs.diagnose`): its JSON as a dict, with
    :meth:`to_pandas` of its tables and :meth:`plot` of the report's figures.

    Parameters
    ----------
    data : mapping
        The diagnosis' JSON (``Diagnosis.to_json``).
    diagnosis : Diagnosis, optional
        The diagnosis itself (:class:`sins_sim.identification.report.Diagnosis`: the recording, the fits, the
        localisation), which the figures are drawn from. ``diagnose`` keeps it; the results of
        ``diagnose_many`` (made in worker processes) and a JSON read back hold the JSON only.

    Attributes
    ----------
    diagnosis : Diagnosis or None
    """

    def __init__(self, data=(), diagnosis=None):
        super().__init__(data)
        self.diagnosis = diagnosis

    @property
    def figures(self) -> list:
        """The figures :meth:`plot` can draw (the report's ``<kind>.png``); empty without the diagnosis."""
        if self.diagnosis is None:
            return []
        from sins_sim.identification.report import figure_kinds

        return figure_kinds(self.diagnosis)

    def plot(self, kind: str | None = None):
        """One figure of ``sins-sim diagnose --report``, returned (not written): a
        :class:`matplotlib.figure.Figure` drawn by the report's own function
        (:func:`sins_sim.identification.report.diagnosis_figure`).

        Parameters
        ----------
        kind : str, optional
            ``spectrum``, ``envelope`` or ``ranking`` after a refit, ``angle`` after data the checks refused
            (:attr:`figures`); default the first of :attr:`figures`.

        Raises
        ------
        ValueError
            No diagnosis in memory (the JSON only), or a kind this diagnosis has no data for.
        """
        if self.diagnosis is None:
            raise ValueError("plot: this result holds the diagnosis' JSON only; the figures need the recording and "
                             "the fits: diagnose(path) keeps them")
        from sins_sim.identification.report import diagnosis_figure
        from sins_sim.plots.common import _pyplot

        kinds = self.figures
        return diagnosis_figure(self.diagnosis, kinds[0] if kind is None else kind, _pyplot(headless=False))

    def __reduce__(self):
        """Pickled as its JSON alone (the diagnosis holds the recording: too heavy between processes)."""
        return (DiagnosisResult, (dict(self),))

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
