"""Every figure of every command is produced, and none is empty (issue 22, points 7 and 9).

Each command runs once, shortened (a few simulated seconds; the slow studies with their resolution
monkeypatched down, since only the figures are checked here, not the numbers), while
``Figure.savefig`` is wrapped so that every figure is inspected as it is written:

- every axes of it has data: a line with at least two finite points, a collection with finite
  points, or a bar/patch of finite non-zero size;
- every axes has an x and a y label (or shares the axis with one that has it, or the figure has a
  common one), each naming its unit in parentheses (or ``dB``, or a fraction by name); an axis of
  named categories (bar rows) needs none;
- no warning was raised from matplotlib or from the plotting code while the command ran (log scale
  of non-positive data, empty legends, tight_layout failures, scipy's Welch settings...).

The files are then compared with what the command says it wrote (report.md, help text).
"""

from __future__ import annotations

import dataclasses
import math
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

matplotlib = pytest.importorskip("matplotlib")
matplotlib.use("Agg")
from matplotlib.figure import Figure  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
IMU = ROOT / "configs" / "default-imu.yaml"
#: where a warning must not come from: matplotlib itself, or the plotting code (matplotlib's
#: ``warn_external`` points at the first frame outside matplotlib, i.e. the plotting module)
_PLOTTING = (f"{Path(matplotlib.__file__).parent}", str(ROOT / "sins_sim" / "plots"),
             str(ROOT / "sins_sim" / "identification" / "report.py"))
#: a unit in parentheses, dB, or a quantity that is a fraction by name
_UNIT = re.compile(r"\(.*\S.*\)|\bdB\b|^fraction\b")


def _finite_points(artist) -> int:
    from matplotlib.collections import Collection
    from matplotlib.lines import Line2D
    from matplotlib.patches import Rectangle

    if isinstance(artist, Line2D):
        x, y = (np.asarray(v, dtype=float) for v in artist.get_data())
        return int(np.sum(np.isfinite(x) & np.isfinite(y))) if x.size == y.size else 0
    if isinstance(artist, Rectangle):
        w, h = artist.get_width(), artist.get_height()
        return int(math.isfinite(w) and math.isfinite(h) and (w != 0 or h != 0)) * 2
    if isinstance(artist, Collection):
        n = 0
        offs = np.asarray(artist.get_offsets(), dtype=float)
        if offs.size and offs.ndim == 2 and len(artist.get_paths()) <= 1:
            n += int(np.sum(np.all(np.isfinite(offs), axis=1)))
        for p in artist.get_paths():
            v = np.asarray(p.vertices, dtype=float)
            n += int(np.sum(np.all(np.isfinite(v), axis=1))) if v.size else 0
        return n
    return 0


def _label_of(ax, which: str) -> str:
    """The axes' own label, one of the axes it shares that axis with, or the figure's common label."""
    get = ax.get_xlabel if which == "x" else ax.get_ylabel
    if get():
        return get()
    group = ax.get_shared_x_axes() if which == "x" else ax.get_shared_y_axes()
    for other in group.get_siblings(ax):
        lab = other.get_xlabel() if which == "x" else other.get_ylabel()
        if lab:
            return lab
    common = getattr(ax.figure, "_supxlabel" if which == "x" else "_supylabel", None)
    return common.get_text() if common is not None else ""


def _categorical(ax, which: str) -> bool:
    """An axis of named categories (bar rows, parameter names): its tick labels say what it is."""
    from matplotlib.category import StrCategoryFormatter
    from matplotlib.ticker import FixedFormatter, FuncFormatter

    fmt = (ax.xaxis if which == "x" else ax.yaxis).get_major_formatter()
    if isinstance(fmt, FuncFormatter):  # set_ticklabels(list): a partial of Axis._format_with_dict
        return getattr(getattr(fmt.func, "func", None), "__name__", "") == "_format_with_dict"
    return isinstance(fmt, (FixedFormatter, StrCategoryFormatter))


def figure_problems(fig) -> list:
    """What makes ``fig`` unfit to publish: axes without data, axes without labels or units."""
    problems = []
    axes = [ax for ax in fig.get_axes() if ax.get_visible() and ax.get_label() != "<colorbar>"]
    if not axes:
        return ["no axes"]
    for k, ax in enumerate(axes):
        name = f"axes {k} ({ax.get_title()[:40]!r})"
        artists = list(ax.lines) + list(ax.collections) + list(ax.patches)
        if max((_finite_points(a) for a in artists), default=0) < 2:
            problems.append(f"{name}: no data")
        for which in ("x", "y"):
            if _categorical(ax, which):
                continue
            lab = _label_of(ax, which)
            if not lab:
                problems.append(f"{name}: no {which} label")
            elif not _UNIT.search(lab):
                problems.append(f"{name}: {which} label {lab!r} names no unit")
    return problems


class FigureLog:
    """The figures written while it is active (name -> problems) and the warnings raised meanwhile."""

    def __init__(self):
        self.figures: dict = {}
        self.warnings: list = []

    def plotting_warnings(self) -> list:
        return [f"{w.filename}:{w.lineno}: {w.category.__name__}: {w.message}" for w in self.warnings
                if str(w.filename).startswith(_PLOTTING)]

    def check(self, expected) -> None:
        missing = sorted(set(expected) - set(self.figures))
        assert not missing, f"figures not written: {missing} (written: {sorted(self.figures)})"
        bad = {n: p for n, p in self.figures.items() if p}
        assert not bad, f"figures with problems: {bad}"
        assert not self.plotting_warnings(), self.plotting_warnings()


def _png_name(fname) -> str:
    """The final name of a figure written to a temporary sibling first (``.NAME.tmp-.png``)."""
    name = Path(str(fname)).name
    m = re.fullmatch(r"\.(.+\.png)\.tmp-\.png|\.(.+)\.tmp-\.png", name)
    return (m.group(1) or m.group(2) + ".png") if m else name


@pytest.fixture(scope="module")
def record():
    """A context manager: ``with record() as log:`` runs a command and collects its figures."""
    from contextlib import contextmanager

    @contextmanager
    def _record():
        log = FigureLog()
        original = Figure.savefig

        def savefig(self, fname, *args, **kwargs):
            log.figures[_png_name(fname)] = figure_problems(self)
            return original(self, fname, *args, **kwargs)

        with pytest.MonkeyPatch.context() as mp, warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            mp.setattr(Figure, "savefig", savefig)
            yield log
        log.warnings = list(caught)

    return _record


def _scenario(tmp: Path, filters: str, duration: float = 6.0) -> Path:
    sc = tmp / "s.yaml"
    sc.write_text(f"name: fig-test\nimu: {IMU}\nduration_s: {duration}\nseed: 3\nfilters: {filters}\n"
                  "navigation: {start_s: 1.0}\n"
                  "motion:\n  - {type: coning, amplitude_arcmin: 0.5, frequency_hz: 90, phase_deg: 90}\n")
    return sc


def _report_figures(out: Path) -> list:
    return re.findall(r"!\[[^\]]*\]\(([^)]+\.png)\)", (out / "report.md").read_text())


# --- run ---------------------------------------------------------------------------------------------
def test_run_writes_every_figure_with_data(tmp_path, record):
    """All filters plus the raw readout: the five figures of a run on a rigid block, each with data, labels and
    units (the block figures need an IMU with a block: below)."""
    from sins_sim.jobs.run import run_scenario
    from sins_sim.plots.navigation import RUN_FIGURES

    rigid = [f for f in RUN_FIGURES if not f.startswith("block_")]
    out = tmp_path / "run"
    with record() as log:
        run_scenario(_scenario(tmp_path, "[ideal, raw, eliminator, correcting, correcting_paper]"), out)
    log.check(rigid)
    assert sorted(p.name for p in out.glob("*.png")) == sorted(rigid)
    assert _report_figures(out) == rigid


def test_a_block_run_writes_its_block_figures(tmp_path, record):
    """``scenarios/block-dither-coupling.yaml`` (shortened to 6 s): every figure, the block's spectrum and its
    dither coning included, with data, labels and units."""
    from sins_sim.jobs.run import run_scenario
    from sins_sim.plots.navigation import RUN_FIGURES

    out = tmp_path / "run"
    with record() as log:
        run_scenario(Path(__file__).resolve().parents[1] / "scenarios" / "block-dither-coupling.yaml", out,
                     overrides={"duration_s": 6.0})
    log.check(RUN_FIGURES)
    assert _report_figures(out) == list(RUN_FIGURES)


def test_ideal_only_run_writes_no_empty_figure(tmp_path, record):
    """``filters: [ideal]``: the ideal increments have no gyro error, so no spectrum and no Allan figure; the
    report lists exactly the figures written."""
    from sins_sim.jobs.run import run_scenario

    out = tmp_path / "run"
    with record() as log:
        run_scenario(_scenario(tmp_path, "[ideal]", duration=4.0), out)
    expected = ["navigation_error.png", "attitude_error.png", "trajectory.png"]
    log.check(expected)
    assert sorted(log.figures) == sorted(expected)
    assert sorted(p.name for p in out.glob("*.png")) == sorted(expected)
    assert _report_figures(out) == expected


def test_attitude_figure_names_phi_and_its_scale(tmp_path):
    """The attitude figure says phi (not psi), and its symmetric-log axis states the linear half-width
    it was given from the data; the spectrum states its window and span (read back from the axes)."""
    from types import SimpleNamespace

    from sins_sim.plots.common import symlog_threshold
    from sins_sim.plots import navigation as pn

    t = np.linspace(1.0, 10.0, 91)
    rng = np.random.default_rng(1)

    def ser(scale):
        a = scale * np.column_stack([np.sin(t), np.cos(t), t / 10.0]) * 4.8e-6
        z = np.zeros_like(t)
        d = {"t_s": t, "attitude_ned_rad": a, "attitude_ned_rad_min": a - 1e-6, "attitude_ned_rad_max": a + 1e-6,
             "horizontal_m": t * scale, "horizontal_m_min": t * scale * 0.9, "horizontal_m_max": t * scale * 1.1,
             "vertical_m": np.sin(t) * scale, "vertical_m_min": np.sin(t) * scale - 1,
             "vertical_m_max": np.sin(t) * scale + 1,
             "velocity_ned_m_s": np.column_stack([t, z, z]) * scale, "north_m": t * scale, "east_m": -t * scale}
        return d

    series = {"ideal": ser(1e-3), "eliminator": ser(1.0), "correcting": ser(0.1)}
    fs = 1000.0
    spectra = {"t": 1.0 + np.arange(2000) / fs, "ideal": np.zeros((2000, 3)),
               "eliminator": rng.normal(size=(2000, 3)) * 1e-6, "correcting": rng.normal(size=(2000, 3)) * 1e-7}
    res = SimpleNamespace(series=series, spectra=spectra, filter_rate_hz=fs, drives=[], filters=tuple(series),
                          truth_series={"t_s": t, "lat_rad": 0.7 + t * 1e-7, "lon_rad": 0.1 + t * 1e-7,
                                        "h_m": np.zeros_like(t)}, allan={})
    captured = {}
    original = Figure.savefig

    def savefig(self, fname, *a, **k):
        captured[Path(fname).name] = self
        return original(self, fname, *a, **k)

    with pytest.MonkeyPatch.context() as mp, warnings.catch_warnings():
        warnings.simplefilter("error")
        mp.setattr(Figure, "savefig", savefig)
        figs = pn.plot_run(res, tmp_path, "synthetic")
    assert figs == ["navigation_error.png", "attitude_error.png", "trajectory.png", "gyro_error_spectrum.png"]
    att = captured["attitude_error.png"].get_axes()
    lin = symlog_threshold([s["attitude_ned_rad"] / 4.84813681109536e-6 for s in series.values()])
    assert [ax.get_ylabel() for ax in att] == ["phi north (arcsec)", "phi east (arcsec)", "phi down (arcsec)"]
    assert att[0].get_yscale() == "symlog" and att[0].yaxis.get_transform().linthresh == pytest.approx(lin)
    assert f"linear within +-{lin:g} arcsec" in att[0].get_title() and "psi" not in att[0].get_title()
    # ideal dashed and in front of every other filter's line; envelopes behind every mean line
    lines = {ln.get_label(): ln for ln in att[0].lines if not ln.get_label().startswith("_")}
    ideal = lines["ideal increments (algorithm floor)"]
    assert ideal.get_linestyle() != "-" and all(ideal.get_zorder() > ln.get_zorder()
                                                 for n, ln in lines.items() if ln is not ideal)
    assert max(c.get_zorder() for c in att[0].collections) < min(ln.get_zorder() for ln in lines.values())
    # one legend, outside every axes
    assert all(ax.get_legend() is None for ax in att) and captured["attitude_error.png"].legends
    title = captured["gyro_error_spectrum.png"].get_axes()[0].get_title()
    # 0.25 s at 1 kHz -> 256 samples; record 1-3 s
    assert "Hann window of 256 samples = 0.256 s, 50% overlap" in title and "t = 1-3 s, 2 s" in title
    # the ideal (zero error) has no spectrum line: a log axis of zeros would be empty
    spec_labels = [ln.get_label() for ln in captured["gyro_error_spectrum.png"].get_axes()[0].lines]
    assert "ideal increments (algorithm floor)" not in spec_labels


def test_run_help_lists_exactly_the_figures_a_run_writes(capsys):
    from sins_sim.cli import build_parser
    from sins_sim.plots.navigation import RUN_FIGURES

    with pytest.raises(SystemExit):
        build_parser().parse_args(["run", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert sorted(set(re.findall(r"[\w]+\.png", text))) == sorted(RUN_FIGURES)


# --- the other commands --------------------------------------------------------------------------------
def test_channel_figure(tmp_path, record):
    from sins_sim.cli import main

    with record() as log:
        assert main(["channel", "--duration", "0.2", "--quiet", "--out", str(tmp_path / "ch")]) == 0
    log.check(["channel.png"])


def test_budget_figure(tmp_path, record):
    from sins_sim.jobs.budget import run_budget

    sc = _scenario(tmp_path, "[ideal, correcting]", duration=3.0)
    with record() as log:
        run_budget(sc, tmp_path / "b", workers=1)
    log.check(["budget.png"])


def test_compare_filters_figures(tmp_path, record, monkeypatch):
    """The comparison at a resolution far below ``--quick`` (only the figures are checked here)."""
    from sins_sim.jobs import compare_filters as cf

    tiny = dataclasses.replace(cf.CompareSettings.quick_(), n_gain=4, mission_s=6.0, cost_samples=4000)
    monkeypatch.setattr(cf.CompareSettings, "quick_", classmethod(lambda cls: tiny))
    with record() as log:
        cf.run_compare_filters(tmp_path / "cf", tmp_path / "cf.json", quick=True)
    log.check(["gain.png", "noise_tradeoff.png"])


def test_reproduce_figures(tmp_path, record, monkeypatch):
    """The paper's figures at a resolution far below ``--quick``."""
    from sins_sim.jobs.reproduce import common, job
    from sins_sim.jobs.reproduce import run_reproduce

    tiny = dataclasses.replace(common.ReproduceSettings.quick_(), n_fig5=4, fig5_settle_s=0.4, fig5_measure_s=0.1,
                               n_mismatch=5, fig6_settle_s=0.4, fig6_measure_s=0.1, afc_truth_settle_s=0.3,
                               afc_settle_s=0.1, afc_max_nfev=8, decay_s=0.5, impact_settle_s=0.5)
    monkeypatch.setattr(job.ReproduceSettings, "quick_", classmethod(lambda cls: tiny))
    with record() as log:
        run_reproduce(tmp_path / "rep", quick=True)
    log.check(["fig1_correcting_afc.png", "fig3_resonance_vs_amplitude.png", "fig3_abel_nonl.png",
               "fig4_afc_fit.png", "fig5_end_to_end_afc.png", "fig6_mismatch.png", "fig7_impact.png"])


def test_lockin_study_figures(tmp_path, record, monkeypatch):
    """The lock-in study with every run cut to a few seconds and every sweep thinned."""
    from sins_sim.jobs import lockin_study as ls

    run, sweep = ls.run_lockin, ls.dynamic_lockin_sweep
    monkeypatch.setattr(ls, "run_lockin", lambda *a, **k: run(*a, **{**k, "duration_s": min(k.get("duration_s", 3.0),
                                                                                           3.0), "settle_s": 0.5}))
    monkeypatch.setattr(ls, "dynamic_lockin_sweep",
                        lambda ol, rates, **k: sweep(ol, np.asarray(rates)[::3], **{**k, "settle_s": 0.5,
                                                                                     "measure_s": 0.2}))
    with record() as log:
        ls.lockin_study(tmp_path / "lk", quick=True, progress=None)
    log.check(["arw_vs_lockin.png", "dynamic_lockin.png"])


def test_sweep_figures(tmp_path, record):
    """Three units at rest for 1.5 s with a drawn f0: the distribution and the sensitivity figures."""
    from sins_sim.jobs.sweep.job import run_sweep

    sw = tmp_path / "sw.yaml"
    sw.write_text(f"name: fig\nseed: 2\nunits: 3\nscenarios:\n  - {{path: {ROOT / 'scenarios' / 'stationary.yaml'}, "
                  "duration_s: 1.5}\npopulation:\n  f0_ppm: {width: 2000}\n")
    with record() as log:
        res = run_sweep(sw, tmp_path / "out", workers=1, log=lambda line: None)
    written = [f for f in res["files"] if f.endswith(".png")]
    assert "distributions.png" in written and any(f.startswith("sensitivity_") for f in written)
    log.check(written)


def test_diagnose_report_figures(tmp_path, record):
    """``diagnose --report`` on a short simulated recording with an effect: spectrum, envelope, ranking."""
    from sins_sim.jobs import recording_jobs

    spec = tmp_path / "drift.yaml"
    spec.write_text("experiment: stationary\naxes: [x]\nduration_s: 0.6\nseed: 3\nintegrator: rk4\n"
                    "effects:\n  - {name: resonance_drift, rate_hz_per_s: 0.5}\n")
    recording_jobs.simulate_recording(spec, tmp_path / "rec.npz")
    with record() as log:
        js = recording_jobs.diagnose(tmp_path / "rec.npz", None, tmp_path / "report", effects=["resonance_drift"])
    expected = ["spectrum.png", "envelope.png"] + (["ranking.png"] if js["candidates"] else [])
    log.check(expected)
    assert _report_figures(tmp_path / "report") == expected


def test_figure_check_catches_an_empty_figure():
    """The checker itself: an axes without data, labels or units is reported (so the tests above can fail)."""
    fig = Figure()
    ax = fig.add_subplot()
    ax.plot([], [])
    assert set(figure_problems(fig)) == {"axes 0 (''): no data", "axes 0 (''): no x label", "axes 0 (''): no y label"}
    ax.plot([0, 1], [1, np.nan])
    ax.set_xlabel("time")
    ax.set_ylabel("error (m)")
    assert figure_problems(fig) == ["axes 0 (''): no data", "axes 0 (''): x label 'time' names no unit"]


# --- finish_figure: one layout and one draw, the same pixels ---------------------------------------
def _figure_like_a_run(kind: str):
    """A headless figure with what the run figures use: constrained layout, shared x, log and symmetric-log
    axes with mathtext tick labels, a legend outside below the panels (``navigation_error``), or a grid of
    equal-aspect panels with a suptitle (``trajectory``)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = Figure(figsize=(8, 7), layout="constrained")
    FigureCanvasAgg(fig)
    t = np.linspace(0.0, 11.0, 200)
    if kind == "panels":
        axes = fig.subplots(3, 1, sharex=True)
        axes[0].fill_between(t, 1e-5 * (1 + t), 1e-3 * (1 + t), alpha=0.13, lw=0)
        axes[0].plot(t, 1e-4 * (1 + t), label="a filter with a long legend label")
        axes[0].set_yscale("log")
        axes[1].plot(t, 1e-3 * np.sin(t), label="another one")
        axes[1].set_yscale("symlog", linthresh=1e-4)
        axes[2].loglog(t[1:], 1e-2 / t[1:])
        for i, ax in enumerate(axes):
            ax.set_ylabel(f"error {i} (m)\n(log scale)")
        axes[0].set_title("a title\nof two lines", fontsize=10)
        fig.legend(*axes[0].get_legend_handles_labels(), loc="outside lower center", ncol=2, fontsize=8)
    else:
        gs = fig.add_gridspec(2, 3, width_ratios=[1.7, 1.0, 1.0])
        a0 = fig.add_subplot(gs[:, 0])
        a0.plot(np.cos(t), 3 * np.sin(t), label="path")
        a0.set_aspect("equal", adjustable="datalim")
        a0.legend(fontsize=8)
        for k in range(4):
            ax = fig.add_subplot(gs[k % 2, 1 + k // 2])
            ax.plot(t * 10.0 ** k, np.sin(t))
            ax.set_aspect("equal", adjustable="datalim")
            ax.set_title(f"panel {k}\nend: {k:.3g} m", fontsize=8)
        fig.suptitle("a suptitle\nof two lines", fontsize=10)
    return fig


@pytest.mark.parametrize("kind", ["panels", "grid"])
def test_finish_figure_writes_the_pixels_savefig_writes(tmp_path, kind):
    """:func:`~sins_sim.plots.common.finish_figure` lays a headless figure out once and draws it once instead of
    ``savefig``'s two draws: the PNG must be the one ``savefig`` writes, pixel for pixel (tolerance zero: the same
    renderer on the same layout gives the same pixels; only the zlib level of the file differs)."""
    from PIL import Image

    from sins_sim.plots.common import finish_figure

    ref = _figure_like_a_run(kind)
    ref.savefig(tmp_path / "ref.png", dpi=110)
    fig = _figure_like_a_run(kind)
    engine, dpi = fig.get_layout_engine(), fig.dpi
    assert finish_figure(fig, tmp_path / "fast.png") is fig
    a, b = (np.asarray(Image.open(tmp_path / n)) for n in ("ref.png", "fast.png"))
    assert a.shape == b.shape and a.shape[:2] == (770, 880)
    assert np.count_nonzero(np.any(a != b, axis=-1)) == 0
    assert fig.get_layout_engine() is engine and fig.dpi == dpi  # the figure is left as it was given


def test_finish_figure_leaves_other_formats_to_savefig(tmp_path):
    """A path that is not a PNG goes through ``savefig`` (its own layout pass for its own renderer)."""
    from sins_sim.plots.common import finish_figure

    finish_figure(_figure_like_a_run("panels"), tmp_path / "f.svg")
    assert (tmp_path / "f.svg").read_text().lstrip().startswith("<?xml")
