"""Plots (matplotlib, imported lazily with the Agg backend so no display is needed)."""

from __future__ import annotations


import numpy as np

from sins_sim.units import ARCMIN, ARCSEC

#: One label per filter (and the truth), used by every figure.
FILTER_LABELS = {
    "ideal": "ideal increments (algorithm floor)",
    "raw": "raw readout",
    "eliminator": "elliptic eliminator",
    "correcting": "correcting eq. 5, unity DC",
    "correcting_paper": "correcting eq. 5, paper form",
    "correcting_aligned": "time-aligned eq. 5 (delay 1)",
    "correcting_wideband": "equalised, flat to 2.6 kHz (delay 16)",
    "correcting_lownoise": "equalised, flat to 1.5 kHz (delay 20)",
    "pickoff": "pickoff stripping (LMS gain)",
    "truth": "true SINS angle",
}
#: One colour per filter, the same in every figure: the colour-blind-safe palette of Okabe & Ito (2008),
#: "Color Universal Design" (black, orange #E69F00, sky blue #56B4E9, bluish green #009E73, yellow
#: #F0E442 (left out: unreadable on white), blue #0072B2, vermillion #D55E00, reddish purple #CC79A7),
#: with grey for the raw readout. ``ideal`` and the truth are black and drawn dashed on top.
FILTER_COLORS = {
    "ideal": "#000000",
    "truth": "#000000",
    "raw": "#999999",
    "eliminator": "#D55E00",
    "correcting": "#0072B2",
    "correcting_paper": "#009E73",
    "correcting_aligned": "#E69F00",
    "correcting_wideband": "#CC79A7",
    "correcting_lownoise": "#56B4E9",
    "pickoff": "#E69F00",
}
#: Colours for filters without an entry (plug-ins): Tol's "muted" scheme (colour-blind safe), picked by
#: a stable hash of the name so a plug-in has the same colour in every figure.
_EXTRA_COLORS = ("#882255", "#44AA99", "#999933", "#AA4499", "#332288", "#117733")
#: Transparency of a min/max envelope: light, so the mean lines in front stay readable.
ENVELOPE_ALPHA = 0.13
#: zlib level of the PNGs :func:`finish_figure` writes (lossless; 6, the default, packs about 8 % tighter for
#: about 15 ms more a figure of ``sins-sim run``).
PNG_COMPRESS_LEVEL = 3
#: Backwards-compatible names (the figures of the channel and the paper use these).
LABELS = FILTER_LABELS
COLORS = FILTER_COLORS


def filter_color(name: str) -> str:
    """The colour of filter ``name`` (:data:`FILTER_COLORS`, else a stable pick for a plug-in)."""
    if name in FILTER_COLORS:
        return FILTER_COLORS[name]
    import zlib

    return _EXTRA_COLORS[zlib.crc32(name.encode()) % len(_EXTRA_COLORS)]


def filter_label(name: str) -> str:
    """The legend label of filter ``name`` (its name when it has none)."""
    return FILTER_LABELS.get(name, name)


def line_style(name: str) -> dict:
    """Keyword arguments of a filter's mean line: its colour; ``ideal``/truth dashed and on top of the rest."""
    if name in ("ideal", "truth"):
        return {"color": filter_color(name), "lw": 1.3, "ls": (0, (4, 2)), "zorder": 5}
    # the unity-DC correcting filter (the recommended one) in front of the other filters
    return {"color": filter_color(name), "lw": 1.1, "zorder": 4 if name == "correcting" else 3}


def draw_envelope(ax, x, lo, hi, name: str) -> None:
    """The min/max band of filter ``name`` behind every mean line: a light fill (:data:`ENVELOPE_ALPHA`) with
    thin edges of the filter's colour, so overlapping bands can still be told apart."""
    c = filter_color(name)
    ax.fill_between(x, lo, hi, color=c, alpha=ENVELOPE_ALPHA, lw=0, zorder=1)
    for edge in (lo, hi):
        ax.plot(x, edge, color=c, lw=0.5, alpha=0.45, zorder=2)


def symlog_threshold(values, quantile: float = 0.5, floor: float = 1e-12) -> float:
    """The linear half-width of a symmetric-log axis chosen from the data.

    The ``quantile`` (default: the median) of the non-zero finite magnitudes of ``values`` (the plotted
    means), rounded down to a power of ten. Values that change sign around zero at a level below it are
    drawn linearly (a symmetric-log axis with a tiny linear part spreads such values over decades), and
    the larger half of the data lies on the logarithmic part.
    """
    a = np.abs(np.concatenate([np.ravel(np.asarray(v, dtype=float)) for v in values])) if len(values) else np.zeros(0)
    a = a[np.isfinite(a) & (a > floor)]
    if a.size == 0:
        return 1.0
    return float(10.0 ** np.floor(np.log10(np.quantile(a, quantile))))


def _pyplot(headless: bool = True):
    """pyplot; ``headless`` (figures written to files) selects Agg when pyplot is not loaded yet (a command
    line run opens no window). A session that already has pyplot (a notebook, whose inline backend shows
    the figures :meth:`sins_sim.results.MissionResult.plot` returns) keeps its backend: switching it
    would close the session's open figures."""
    import sys

    import matplotlib

    if headless and "matplotlib.pyplot" not in sys.modules:
        matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


_MATHTEXT_PARSERS: dict = {}


def _shared_mathtext_parser(own):
    """The first mathtext parser an Agg renderer made for itself, kept for every later figure of the process.

    Keyed by the parser's class and output type, so each renderer gets one of the kind it made: matplotlib
    3.7's Agg renderer makes ``MathTextParser("Agg")`` (raster output, six values from ``parse``), 3.8 and later
    ``MathTextParser("path")`` (vector output, five); handing one the other's breaks the layout.
    """
    return _MATHTEXT_PARSERS.setdefault((type(own), getattr(own, "_output_type", None)), own)


def finish_figure(fig, path, dpi: int = 110):
    """Write ``fig`` to ``path`` and close it, or, with ``path`` None, leave it open for the caller; returns it.

    A PNG of a headless figure (an Agg canvas: every command line run) is laid out once and drawn once:
    ``savefig`` on a figure with a layout engine first draws it with rendering disabled, only to run the
    layout, then draws it again. Here the layout engine runs by itself at the saving resolution and is
    switched off for the one real draw, which gives the same pixels (checked by
    ``tests/test_figures.py``) without the extra pass. PNGs are written with zlib level 3 instead of 6
    (lossless either way; the files of ``sins-sim run`` about 8 % larger, about 15 ms less each). With
    the shared mathtext parser below, the five figures of an 11 s ``nav-stationary-1h`` run took
    2.2-2.4 s of CPU instead of 2.7-2.95 s (measured 2026-11-27, one core, same session).
    """
    if path is None:
        return fig
    import matplotlib.pyplot as plt
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    engine = fig.get_layout_engine()
    if type(fig.canvas) is not FigureCanvasAgg or not str(path).lower().endswith(".png"):
        fig.savefig(path, dpi=dpi)
    else:
        dpi0 = fig.dpi
        try:
            fig.set_dpi(dpi)
            # The renderer the layout and the draw use (the canvas keeps it for this size and dpi) parses its
            # mathtext (the log axes' tick labels) with one parser shared by every figure: matplotlib caches
            # parses per parser, and each renderer makes its own, so every figure parsed "10^{-4}" afresh.
            renderer = fig.canvas.get_renderer()
            renderer.mathtext_parser = _shared_mathtext_parser(renderer.mathtext_parser)
            if engine is not None:
                engine.execute(fig)
                fig.set_layout_engine(None)
            fig.savefig(path, dpi=dpi, pil_kwargs={"compress_level": PNG_COMPRESS_LEVEL})
        finally:
            if fig.get_layout_engine() is not engine:
                fig.set_layout_engine(engine)
            fig.set_dpi(dpi0)
    plt.close(fig)
    return fig


def plot_channel(result, path, window_s: float = 0.03, settle_s: float = 0.0, title: str = "") -> None:
    """Three panels: raw readout vs truth, filter outputs vs truth, residuals; last ``window_s`` seconds."""
    plt = _pyplot()
    t = result.t
    sel = t >= max(t[-1] - window_s, settle_s)
    tm = (t[sel] - t[sel][0]) * 1e3
    fig, axes = plt.subplots(3, 1, figsize=(12.5, 9), sharex=True, constrained_layout=True)
    side = {"loc": "upper left", "bbox_to_anchor": (1.01, 1.0), "fontsize": 8}  # legends beside the data, not on it
    # eq. 5's two forms differ by their DC gain only: the paper form dashed on top, the unity form shows through
    style = {n: {**line_style(n), "lw": 1.0, **({"ls": (0, (4, 2)), "zorder": 5} if n == "correcting_paper" else {})}
             for n in ("eliminator", "correcting", "correcting_paper")}
    ax = axes[0]
    ax.plot(tm, result.outputs["raw"][sel] / ARCMIN, color=COLORS["raw"], lw=1.0, label=LABELS["raw"])
    ax.plot(tm, result.truth("raw")[sel] / ARCMIN, color="k", lw=1.2, ls="--", label=LABELS["truth"])
    ax.set_ylabel("angle (arcmin)")
    ax.set_title("RLG readout: dither on top of the SINS motion")
    ax.legend(**side)
    ax = axes[1]
    ax.plot(tm, result.truth("correcting")[sel] / ARCSEC, color="k", lw=2.2, alpha=0.35,
            label=LABELS["truth"] + " (aligned)")
    for name in ("eliminator", "correcting", "correcting_paper"):
        ax.plot(tm, result.outputs[name][sel] / ARCSEC, label=LABELS[name], **style[name])
    ax.set_ylabel("angle (arcsec)")
    ax.set_title("Dither removed: filter outputs and the true SINS angle")
    ax.legend(**side)
    ax = axes[2]
    rms = result.residual_rms(settle_s)
    for name in ("eliminator", "correcting", "correcting_paper"):
        ax.plot(tm, result.residual(name)[sel] / ARCSEC, label=f"{LABELS[name]}:\nRMS {rms[name] / ARCSEC:.3g} arcsec",
                **style[name])
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set_ylabel("output - truth (arcsec)")
    ax.set_xlabel(f"time from t = {t[sel][0]:.3f} s (ms)")
    ax.set_title("Residual after time alignment (RMS over the whole run after settling)")
    ax.legend(**side)
    if title:
        fig.suptitle(title)
    fig.savefig(path, dpi=120)
    plt.close(fig)
