"""A unit identified from its log, beside its twin, as a Python object (:class:`IdentifyResult`)."""

from __future__ import annotations

from pathlib import Path

__all__ = ["FIGURES", "IdentifyResult", "draw_figure", "draw_twin_figures"]

#: The figures :meth:`IdentifyResult.plot` draws (``<kind>.png`` in the result folder); ``twin-*`` need the twin.
FIGURES = ("psd", "twin-allan", "twin-psd", "twin-alignment", "twin-nav", "twin-explain")


def _figure(detail: dict, metrics: dict, kind: str, path=None):
    from sins_sim.identification.twin_gap import NAV_QUANTITIES, NAV_QUANTITIES_TRUTH
    from sins_sim.plots import twin as tp

    name = Path(metrics["log"]).name
    log_run = detail["log_run"]
    moving = "truth" in metrics          # a log on a known trajectory: its residual against the truth
    of = f"the residual of {name} against the truth" if moving else name
    if kind == "psd":
        return tp.plot_psd_lines(log_run.lines, path, title=f"PSD and spectral lines of {of}")
    if "twin" not in detail:
        raise ValueError(f"plot: {kind!r} needs the twin (identify with twin_seeds >= 2)")
    runs, gap = detail["twin"]["runs"], detail["twin"]["gap"]
    seeds = f"{len(runs)} seeds of its twin"
    if kind == "twin-allan":
        twin_curves = {k: [r.allan[k] for r in runs] for k in log_run.allan}
        return tp.plot_twin_allan(log_run.allan, twin_curves, gap["allan_bands"], path,
                                  title=f"Allan deviation of {of} and {seeds}")
    if kind == "twin-psd":
        return tp.plot_twin_psd(log_run.lines, {k: [r.lines[k] for r in runs] for k in log_run.lines}, path,
                                title=f"PSD of {of} and {seeds}")
    if kind == "twin-alignment":
        if moving:
            raise ValueError("plot: 'twin-alignment' is for a log at rest; a moving log starts from its truth's "
                             "state")
        return tp.plot_twin_alignment(metrics["twin"]["alignment"], path,
                                      title=f"{metrics['alignment']['method']} alignment: the twin's errors against the "
                                            "stated sigmas")
    if kind == "twin-nav":
        if moving:
            return tp.plot_twin_nav(log_run.nav_t_s, log_run.nav, [r.nav for r in runs], gap["nav_bands"],
                                    NAV_QUANTITIES_TRUTH, path,
                                    title=f"Navigation error against the truth: {name} and {seeds}")
        return tp.plot_twin_nav(log_run.nav_t_s, log_run.nav, [r.nav for r in runs], gap["nav_bands"], NAV_QUANTITIES,
                                path, title=f"Free navigation of {name} at rest and of {seeds}")
    if kind == "twin-explain":
        return tp.plot_twin_shrink(metrics["explain"], metrics["verdict"], path,
                                   title=f"Candidate effects added to the twin of {name}")
    raise ValueError(f"plot: kind must be one of {list(FIGURES)}, got {kind!r}")


def draw_figure(detail: dict, metrics: dict, kind: str, path=None):
    """One figure of :data:`FIGURES` from an identify's ``detail`` and ``metrics`` (at rest, or on a known
    trajectory: then of the residual against the truth), written to ``path`` or returned open."""
    return _figure(detail, metrics, kind, path)


def draw_twin_figures(detail: dict, metrics: dict, folder) -> list:
    """Write ``twin-*.png`` into ``folder``; returns their names."""
    names = []
    for kind in FIGURES[1:]:
        if kind == "twin-explain" and not (metrics.get("explain") or {}).get("candidates"):
            continue                              # no finding, or none a candidate was tried on
        _figure(detail, metrics, kind, Path(folder) / f"{kind}.png")
        names.append(f"{kind}.png")
    return names


class IdentifyResult(dict):
    """What :func:`sins_sim.jobs.identify.identify` found: its metrics (``metrics.json``) as a dict, with
    :meth:`to_pandas` of its tables, :meth:`plot` of its figures and :attr:`files`.

    Parameters
    ----------
    data : mapping
        The metrics.
    detail : dict, optional
        The analyses, the log's run and the twin's (what the figures are drawn from).
    files : dict, optional
        Name -> path of each file written (empty when nothing was written).
    """

    def __init__(self, data=(), detail=None, files=None):
        super().__init__(data)
        self.detail = detail
        self.files = dict(files or {})

    def __reduce__(self):
        """Pickled as its metrics and files (the runs hold the records)."""
        return (IdentifyResult, (dict(self), None, self.files))

    @property
    def verdict(self) -> dict | None:
        """The verdict beside the twin (``status``: ``none``, ``explained``, ``partly explained``, ``unknown``,
        ``invalid data``; :mod:`sins_sim.identification.twin_explain`), or None without the twin."""
        return self.get("verdict")

    @property
    def figures(self) -> list:
        """The kinds :meth:`plot` can draw."""
        if self.detail is None or self.invalid:
            return []
        return [k for k in FIGURES if (k == "psd" or "twin" in self.detail)
                and not (k == "twin-alignment" and "truth" in self)
                and not (k == "twin-explain" and not (self.get("explain") or {}).get("candidates"))]

    @property
    def invalid(self) -> bool:
        """The log failed its checks (verdict ``invalid data``): the metrics hold the findings, no fit."""
        return (self.get("verdict") or {}).get("status") == "invalid data"

    def plot(self, kind: str = "psd"):
        """One figure, returned open (:data:`FIGURES`: ``psd``, ``twin-allan``, ``twin-psd``, ``twin-alignment``,
        ``twin-nav``, ``twin-explain``).

        Raises
        ------
        ValueError
            The metrics only (read back from JSON), or a twin figure without the twin.
        """
        if self.invalid:
            raise ValueError(f"plot: no figures: the log is invalid data ({self['summary']})")
        if self.detail is None:
            raise ValueError("plot: this result holds the metrics only; identify(log) keeps the runs the figures need")
        return _figure(self.detail, self, kind)

    def to_pandas(self) -> dict:
        """The tables: ``noise`` (sensor, axis, term, value, ci95 low/high), ``bias`` (sensor, component, value,
        sigma), ``lines`` (sensor, axis and each line's readings), ``temperature`` (sensor, axis, coefficient,
        sigma, significant) and ``findings`` (one row per place the log leaves its twin), with the twin ``candidates``
        (label, effect, shrink, shrink_sd, p_heldout, findings_removed: :mod:`sins_sim.identification.twin_explain`); for a rate-table result
        ``motion_terms`` (term, unit, value, sigma, status); for a moving log against its truth ``truth_fit``
        (sensor, term, axis, value, sigma, status) with the twin's ``findings`` and ``candidates``; for a log that is
        invalid data ``checks`` only (check, channel, time_s, sample, message, remedy:
        :mod:`sins_sim.identification.log_checks`)."""
        import pandas as pd

        if self.invalid:                            # the log's checks: one row per finding, nothing fitted
            return {"checks": pd.DataFrame(self["verdict"]["checks"],
                                           columns=["check", "channel", "time_s", "sample", "message", "remedy"])}
        if "truth_fit" in self:                      # a moving log fitted against its truth
            tf = self["truth_fit"]
            rows = [{"sensor": sen, "term": group, "axis": k, "value": e.get("value"), "sigma": e.get("sigma"),
                     "status": e.get("status", "observable")}
                    for sen in ("gyro", "accelerometer") for group, by_k in tf[sen].items() if isinstance(by_k, dict)
                    for k, e in by_k.items() if isinstance(e, dict) and ("value" in e or "status" in e)]
            return self._twin_tables({"truth_fit": pd.DataFrame(rows)})
        if "motion_terms" in self:                   # a rate-table result
            mt = self["motion_terms"]
            rows = [{"term": f"{'S' if g == 'scale_factor_ppm' else 'M'}_{k}", "unit": g.rsplit("_", 1)[1],
                     "value": e.get("value"), "sigma": e.get("sigma"), "status": e.get("status", "excited")}
                    for g in ("scale_factor_ppm", "misalignment_arcsec") for k, e in mt[g].items()]
            return {"motion_terms": pd.DataFrame(rows)}
        noise = [{"sensor": s, "axis": ax, "term": key, "value": e.get("value"),
                  "ci95_low": (e.get("ci95") or [None, None])[0], "ci95_high": (e.get("ci95") or [None, None])[1],
                  "status": e.get("status", "determined")}
                 for s, by_ax in self["noise"].items() for ax, terms in by_ax.items() for key, e in terms.items()
                 if key != "goodness_of_fit"]
        bias = [{"sensor": s, "component": key, "value": e.get("value"), "sigma": e.get("sigma"),
                 "status": e.get("status", "observable")} for s, comps in self["bias"].items()
                for key, e in comps.items()]
        lines = [{"sensor": s, "axis": ax, **ln} for s in ("gyro", "accelerometer")
                 for ax, e in self["lines"][s].items() for ln in e["lines"]]
        temp = []
        tm = self.get("temperature") or {}
        for s in ("gyro", "accelerometer"):
            for ax, by_key in (tm.get(s) or {}).items():
                for key, e in by_key.items():
                    temp.append({"sensor": s, "axis": ax, "quantity": key, "value": e.get("value"),
                                 "sigma": e["sigma"], "significant": "value" in e})
        out = {"noise": pd.DataFrame(noise), "bias": pd.DataFrame(bias), "lines": pd.DataFrame(lines),
               "temperature": pd.DataFrame(temp)}
        return self._twin_tables(out)

    def _twin_tables(self, out: dict) -> dict:
        """``out`` with the twin's ``findings`` and the explain step's ``candidates``."""
        import pandas as pd

        out["findings"] = pd.DataFrame([dict(f) for f in (self.get("twin") or {}).get("findings", [])])
        if "explain" in self:
            out["candidates"] = pd.DataFrame(
                [{"label": c["label"], "effect": c["effect"], "shrink": c["shrink"], "shrink_sd": c["shrink_sd"],
                  "p_heldout": c["p_heldout"], "findings_removed": len(c["removes"])}
                 for c in self["explain"]["candidates"]], columns=["label", "effect", "shrink", "shrink_sd",
                                                                   "p_heldout", "findings_removed"])
        return out
