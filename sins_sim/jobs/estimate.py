"""What a run will cost, before it starts: simulated seconds, samples, wall time and memory.

``sins-sim run`` and ``sins-sim channel`` call :func:`check_run` / :func:`check_channel` before the engine
starts: a run whose estimate exceeds :data:`MAX_WALL_S` (48 h) or :data:`MAX_MEMORY_BYTES` (8 GiB) is
refused with one line naming the key to change, e.g.::

    s.yaml: duration_s: 1e+09 s would take about 238 days of wall time at 48.6x real time (3 gyro chains at
    72 kHz, 4 filter(s) navigated at 7.2 kHz, one core); the limit is 48 h: shorten duration_s

and the progress bar shows the estimate (a progress object with an ``estimate(dict)`` method is told it;
the ``progress(fraction)`` callback is unchanged).

Cost model
----------
Per-sample costs, measured on the development machine (2 shared cores, numba, one thread, process CPU
time; ``simulate_sins`` on the bench case of ``sins_sim.bench.engine``: the default IMU under 1 arcmin
of 100/130/170 Hz vibration; each cost is the slope between 4 s and 16 s runs, so start-up is excluded;
measured on the engine of commit d6a14b4, block attitude on the plant grid):

=============================  ==========  ========================================================
constant                       value       source
=============================  ==========  ========================================================
``PLANT_STEP_AXIS_S``          57 ns       gyro chains only (``nav=None``): 12.35 ms per simulated s
                                           for 3 axes x 72 kHz = 81x real time (plant, drive, readout,
                                           every filter, the block truth at the plant rate)
``NAV_SAMPLE_FILTER_S``        0.26 us     full loop with four filters: 20.6 ms per simulated s =
                                           49x real time; one filter: 15.0 ms (67x); the difference
                                           per navigated filter and filter sample, updating at every
                                           filter sample; with ``n_sub`` samples per update it scales by
                                           ``0.17 + 0.83 / n_sub`` (``NAV_ACCUMULATE_SHARE``)
``TRUTH_SAMPLE_S``             0.105 us    the navigation truth per filter sample beside the chains
                                           (one filter's 15.0 ms minus chains and its navigation)
``TRUTH_ONLY_SAMPLE_S``        0.97 us     an ``ideal``-only run (no gyro chains): 8.9 ms per
                                           simulated s = 112x, 1.23 us per filter sample with its
                                           navigation (the filter-rate truth path without the chains)
``TONE_STEP_AXIS_S``           2.15 ns     ``random_vibration`` with ``method: tones``: 1000 tones
                                           cost 476 ms per simulated s at 72 kHz on 3 axes
``FILTERED_NOISE_STEP_AXIS_S`` 33 ns       ``method: filtered_noise`` (20-2000 Hz): 19.4 ms per
                                           simulated s against 12.35 ms without
``CHANNEL_PLANT_STEP_S``       60 ns       ``simulate_channel``: 4.3 ms per simulated s at 72 kHz (233x)
``CHANNEL_OUTPUT_SAMPLE_S``    2.8 us      the ``channel`` job's residuals, ``timeseries.npz`` and plot:
                                           24.5 ms per simulated s in all (41x)
``FIXED_S``                    3 s         start-up (cached machine code), plots and report
=============================  ==========  ========================================================

The brief quoted 60x real time without navigation and 42x with four filters for the engine before the block
attitude moved onto the plant grid (measured here then: 64x and 43x); the README's bench quotes 72x and 46x.
An ``ideal``-only run was quoted at 5 us per filter sample and measures 1.2-1.3 us here. The model is
linear in the simulated time and ignores the axes running on threads (up to 3x faster on 3 cores), so
it errs long. Memory: one 1 s chunk at the plant rate (about 480 B per plant step for 3 axes), the
stored error series (360 B per block and filter), the spectra (48 B per filter sample and filter over
``spectrum_s``), and for the ``channel`` job its whole record (about 120 B per filter sample).

Calibration on the machine that runs
-------------------------------------
The constants above decide what is refused (a deterministic rule). What the progress bar shows is
calibrated on the machine that runs it (:func:`calibrate`): every finished run's speed is measured
between its first and its last progress report (compilation and start-up excluded) as a ratio to the
model, with the time from the last report to the job's end (analyses, figures, report), and the
medians of the last :data:`CALIBRATION_KEEP` of each per job kind are kept in
``calibration.json`` under the user cache folder (:func:`cache_dir`: ``$XDG_CACHE_HOME/sins-sim`` or
``~/.cache/sins-sim``). Before the first run has been measured the built-in costs are used, and the
display says so. The first run after an install or an upgrade compiles the numba kernels (about
:data:`COMPILE_S` here); :func:`kernels_cold` tells whether that is due, so the display shows a
"compiling (first run only)" phase with its own estimate (the last measured compile time).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import statistics
import sys
from pathlib import Path

from sins_sim.config.errors import ConfigError

__all__ = ["estimate_run", "check_run", "estimate_channel", "check_channel", "announce", "format_duration",
           "MAX_WALL_S", "MAX_MEMORY_BYTES", "PLANT_STEP_AXIS_S", "NAV_SAMPLE_FILTER_S", "NAV_ACCUMULATE_SHARE",
           "TRUTH_SAMPLE_S",
           "TRUTH_ONLY_SAMPLE_S", "TONE_STEP_AXIS_S", "FILTERED_NOISE_STEP_AXIS_S", "CHANNEL_PLANT_STEP_S",
           "CHANNEL_OUTPUT_SAMPLE_S", "FIXED_S", "COMPILE_S", "CALIBRATION_KEEP", "cache_dir", "kernels_cold",
           "calibrate", "record_timing", "load_calibration", "RemainingTime"]

#: Longest estimated wall time a run may take (s): 48 h.
MAX_WALL_S = 48 * 3600.0
#: Largest estimated memory a run may take (bytes): 8 GiB.
MAX_MEMORY_BYTES = 8 * 2 ** 30

PLANT_STEP_AXIS_S = 57e-9
NAV_SAMPLE_FILTER_S = 0.26e-6
#: The share of :data:`NAV_SAMPLE_FILTER_S` that runs at every filter sample whatever the navigation rate (the
#: coning and sculling sums); the rest is the attitude, velocity and position update, once per ``n_sub`` samples.
#: From issue 26's profile of nav-stationary-1h (four filters): the navigators took 5.1 ms per simulated second
#: updating at every filter sample and 1.1 ms at 400 Hz (n_sub 18): ``a + (1 - a) / 18 = 1.1 / 5.1`` gives 0.17.
NAV_ACCUMULATE_SHARE = 0.17
TRUTH_SAMPLE_S = 0.105e-6
TRUTH_ONLY_SAMPLE_S = 0.97e-6
TONE_STEP_AXIS_S = 2.15e-9
FILTERED_NOISE_STEP_AXIS_S = 33e-9
CHANNEL_PLANT_STEP_S = 60e-9
CHANNEL_OUTPUT_SAMPLE_S = 2.8e-6
FIXED_S = 3.0

#: Compilation of the numba kernels of a run, first run after an install or an upgrade (s): 20-30 s on the
#: development machine (``sins-sim run scenarios/nav-trajectory-file.yaml`` with an empty cache: 49 s in all,
#: 8-9 s with the cache warm). Replaced by the last compile time measured on this machine.
COMPILE_S = 30.0
#: Ratios of measured to modelled speed kept per job kind (their median calibrates the display).
CALIBRATION_KEEP = 5
#: Least modelled time (s) between the first and the last progress report for a run's speed to be measured.
_MIN_MEASURED_S = 0.5

#: Memory per plant step of one 1 s chunk (3 axes), per stored block and filter, per spectrum sample and
#: filter, per channel-job filter sample (bytes).
_CHUNK_B_PER_STEP = 480.0
_SERIES_B_PER_BLOCK = 360.0
_SPECTRUM_B_PER_SAMPLE = 48.0
_CHANNEL_B_PER_SAMPLE = 120.0


def format_duration(seconds: float) -> str:
    """``12 s``, ``4.5 min``, ``3.2 h``, ``276 days``, ``3.2e+16 years``."""
    s = float(seconds)
    if s < 90.0:
        return f"{s:.2g} s" if s < 10 else f"{s:.0f} s"
    if s < 5400.0:
        return f"{s / 60.0:.2g} min"
    if s < 3 * 86400.0:
        return f"{s / 3600.0:.2g} h"
    if s < 1000 * 86400.0:
        return f"{s / 86400.0:.3g} days"
    return f"{s / (365.25 * 86400.0):.3g} years"


def _bytes(b: float) -> str:
    for unit, size in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6)):
        if b >= size:
            return f"{b / size:.3g} {unit}"
    return f"{b / 1e3:.3g} kB"


def _tones(part) -> int:
    """Sine tones a block motion part evaluates per time (a ``tones`` random vibration: 3 K per time)."""
    freqs = getattr(part, "frequencies_hz", None)
    if freqs is not None and type(part).__name__ == "RandomVibration":
        return int(len(freqs))
    return 0


def _parts(motion):
    parts = getattr(motion, "parts", None)
    if parts:
        out = []
        for p in parts:
            out.extend(_parts(p))
        return out
    return [motion]


def estimate_run(scenario) -> dict:
    """The cost of a ``sins-sim run`` of ``scenario`` (a :class:`~sins_sim.config.scenario.Scenario`).

    Returns
    -------
    dict
        ``simulated_s``; ``plant_rate_hz``, ``filter_rate_hz``; ``plant_steps`` and ``filter_samples``
        (per axis); ``filters`` (navigated); ``tones`` (sine tones evaluated per time);
        ``wall_s`` (estimated wall time, one core) with ``breakdown`` (s per term) and ``x_real_time``;
        ``memory_bytes`` with ``memory_breakdown``; ``limits`` (``wall_s``, ``memory_bytes``);
        ``text``: one line for a person.
    """
    imu = scenario.imu
    T = float(scenario.duration_s)
    fp, fs = float(imu.plant_rate_hz), float(imu.filter_rate_hz)
    filters = tuple(scenario.filters)
    chains = any(name != "ideal" for name in filters)
    steps = T * fp
    samples = T * fs
    tones = sum(_tones(p) for p in _parts(scenario.motion))
    n_noise = sum(1 for p in _parts(scenario.motion) if type(p).__name__ == "FilteredNoiseVibration")
    nav = scenario.nav
    breakdown = {
        "gyro_chains_s": PLANT_STEP_AXIS_S * 3 * steps if chains else 0.0,
        "truth_s": (TRUTH_SAMPLE_S if chains else TRUTH_ONLY_SAMPLE_S) * samples,
        "navigation_s": NAV_SAMPLE_FILTER_S * (NAV_ACCUMULATE_SHARE + (1.0 - NAV_ACCUMULATE_SHARE) / nav.n_sub)
                        * samples * len(filters),
        # tones are evaluated at the plant rate (chains) and at the filter rate (navigation truth)
        "motion_tones_s": TONE_STEP_AXIS_S * 3 * tones * ((steps if chains else 0.0) + samples),
        "motion_filtered_noise_s": FILTERED_NOISE_STEP_AXIS_S * 3 * n_noise * (steps if chains else samples),
        "fixed_s": FIXED_S,
    }
    wall = float(sum(breakdown.values()))
    mission = max(T - nav.start_s, 0.0)
    series_rate = nav.series_rate_hz(T)
    every = max(1, int(round(fs / nav.n_sub / series_rate)))
    blocks = mission * fs / nav.n_sub / every
    spectrum = min(nav.spectrum_s, mission) * fs
    memory = {
        "chunk_bytes": _CHUNK_B_PER_STEP * fp if chains else _CHUNK_B_PER_STEP * fs,
        "series_bytes": _SERIES_B_PER_BLOCK * blocks * len(filters),
        "spectra_bytes": _SPECTRUM_B_PER_SAMPLE * spectrum * len(filters),
    }
    what = (f"3 gyro chains at {fp / 1e3:g} kHz, " if chains else "no gyro chains, ") + \
        f"{len(filters)} filter(s) navigated at {fs / 1e3:g} kHz"
    if tones:
        what += f", {tones} motion tones"
    out = {
        "simulated_s": T, "plant_rate_hz": fp, "filter_rate_hz": fs, "plant_steps": int(steps),
        "filter_samples": int(samples), "filters": list(filters), "tones": tones,
        "wall_s": wall, "breakdown": breakdown, "x_real_time": T / max(wall - FIXED_S, 1e-12),
        "memory_bytes": float(sum(memory.values())), "memory_breakdown": memory, "stored_blocks": blocks,
        "limits": {"wall_s": MAX_WALL_S, "memory_bytes": MAX_MEMORY_BYTES}, "what": what, "kind": "run",
    }
    out["text"] = (f"{T:g} s simulated ({out['filter_samples']:.3g} filter samples x {len(filters)} filter(s)): "
                   f"about {format_duration(wall)} of wall time ({what}, one core)")
    return out


def _refuse_wall(ctx: str, est: dict, key: str = "duration_s") -> None:
    b = dict(est["breakdown"])
    b.pop("fixed_s", None)
    main = max(b, key=b.get)
    hint = ""
    if main == "motion_tones_s":
        hint = " (mostly the random vibration's sine tones: method: filtered_noise costs O(1) per time)"
    raise ConfigError(
        f"{ctx + ': ' if ctx else ''}{key}: {est['simulated_s']:g} s would take about "
        f"{format_duration(est['wall_s'])} of wall time at {est['x_real_time']:.3g}x real time ({est['what']}, one "
        f"core){hint}; the limit is {MAX_WALL_S / 3600:g} h: shorten {key}")


def check_run(scenario, progress=None) -> dict:
    """Estimate ``scenario`` (:func:`estimate_run`), refuse what cannot finish, tell ``progress``; the estimate.

    Raises
    ------
    ConfigError
        One line naming the scenario file and the key to change: ``duration_s`` when the estimated wall
        time exceeds 48 h; ``navigation.timeseries_rate_hz`` or ``navigation.spectrum_s`` when the stored
        series or spectra would not fit in 8 GiB.
    """
    est = estimate_run(scenario)
    ctx = getattr(scenario, "ctx", "")
    if est["wall_s"] > MAX_WALL_S:
        _refuse_wall(ctx, est)
    if est["memory_bytes"] > MAX_MEMORY_BYTES:
        mem = est["memory_breakdown"]
        p = f"{ctx}: " if ctx else ""
        if mem["series_bytes"] >= mem["spectra_bytes"] and mem["series_bytes"] >= mem["chunk_bytes"]:
            raise ConfigError(
                f"{p}navigation.timeseries_rate_hz: {scenario.nav.series_rate_hz(est['simulated_s']):g} Hz over "
                f"{est['simulated_s']:g} s stores {est['stored_blocks']:.3g} blocks per filter (about "
                f"{_bytes(est['memory_bytes'])} in memory, the limit is {_bytes(MAX_MEMORY_BYTES)}): lower "
                "timeseries_rate_hz")
        if mem["spectra_bytes"] >= mem["chunk_bytes"]:
            raise ConfigError(
                f"{p}navigation.spectrum_s: {scenario.nav.spectrum_s:g} s of full-rate gyro errors for "
                f"{len(est['filters'])} filter(s) take about {_bytes(est['memory_bytes'])} in memory (the limit is "
                f"{_bytes(MAX_MEMORY_BYTES)}): shorten spectrum_s")
        raise ConfigError(f"{p}plant.rate_hz: one chunk at {est['plant_rate_hz']:g} Hz takes about "
                          f"{_bytes(est['memory_bytes'])} (the limit is {_bytes(MAX_MEMORY_BYTES)})")
    announce(progress, est)
    return est


def estimate_channel(config, duration_s: float) -> dict:
    """The cost of a ``sins-sim channel`` run (``config``: a ChannelConfig): same keys as :func:`estimate_run`."""
    T = float(duration_s)
    fp, fs = float(config.plant.rate_hz), float(config.filter_rate_hz)
    steps, samples = T * fp, T * fs
    breakdown = {"channel_s": CHANNEL_PLANT_STEP_S * steps, "outputs_s": CHANNEL_OUTPUT_SAMPLE_S * samples,
                 "fixed_s": FIXED_S}
    wall = float(sum(breakdown.values()))
    what = f"one channel at {fp / 1e3:g} kHz, 4 outputs at {fs / 1e3:g} kHz kept whole"
    out = {"simulated_s": T, "plant_rate_hz": fp, "filter_rate_hz": fs, "plant_steps": int(steps),
           "filter_samples": int(samples), "filters": ["raw", "eliminator", "correcting", "correcting_paper"],
           "tones": 0, "wall_s": wall, "breakdown": breakdown, "x_real_time": T / max(wall - FIXED_S, 1e-12),
           "memory_bytes": _CHANNEL_B_PER_SAMPLE * samples, "limits": {"wall_s": MAX_WALL_S,
                                                                       "memory_bytes": MAX_MEMORY_BYTES},
           "what": what, "kind": "channel"}
    out["memory_breakdown"] = {"record_bytes": out["memory_bytes"]}
    out["text"] = f"{T:g} s simulated: about {format_duration(wall)} of wall time ({what}, one core)"
    return out


def check_channel(config, duration_s: float, progress=None) -> dict:
    """Estimate a channel run; refuse what cannot finish or does not fit in memory (naming ``duration_s``)."""
    est = estimate_channel(config, duration_s)
    if est["wall_s"] > MAX_WALL_S:
        _refuse_wall("", est)
    if est["memory_bytes"] > MAX_MEMORY_BYTES:
        raise ConfigError(
            f"duration_s: {est['simulated_s']:g} s keeps {est['filter_samples']:.3g} samples of every output in "
            f"memory (about {_bytes(est['memory_bytes'])}, the limit is {_bytes(MAX_MEMORY_BYTES)}): shorten "
            "duration_s")
    announce(progress, est)
    return est


def announce(progress, est: dict) -> None:
    """Hand the estimate, calibrated on this machine (:func:`calibrate`), to a progress display that takes one
    (``progress.estimate(est)``); others are left alone."""
    hook = getattr(progress, "estimate", None)
    if callable(hook):
        hook(calibrate(est))


# --- calibration on the machine that runs ----------------------------------------------------------
def cache_dir() -> Path:
    """The user cache folder of sins-sim: ``$XDG_CACHE_HOME/sins-sim``, else ``~/.cache/sins-sim``."""
    base = os.environ.get("XDG_CACHE_HOME", "").strip()
    return (Path(base) if base else Path.home() / ".cache") / "sins-sim"


def _calibration_path() -> Path:
    return cache_dir() / "calibration.json"


def load_calibration() -> dict:
    """What earlier runs measured on this machine (empty when nothing was measured or the file is unreadable)."""
    try:
        doc = json.loads(_calibration_path().read_text())
    except (OSError, ValueError):
        return {}
    return doc if isinstance(doc, dict) else {}


def _save_calibration(doc: dict) -> None:
    """Write ``calibration.json`` atomically; a cache that cannot be written is skipped (it only calibrates)."""
    path = _calibration_path()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
        tmp.write_text(json.dumps(doc, indent=1) + "\n")
        os.replace(tmp, path)
    except OSError:
        pass


def _kernel_sources() -> list:
    """The kernel modules that hold numba functions (``sins_sim/_kernels/*.py`` but ``_config``/``__init__``)."""
    root = Path(__file__).resolve().parents[1] / "_kernels"
    return sorted(p for p in root.glob("*.py") if not p.name.startswith("_"))


def _kernel_stamp() -> str:
    """What decides whether numba's cached machine code is valid: the kernels' sources, numba, Python."""
    try:
        from importlib.metadata import version

        nb = version("numba")
    except Exception:  # noqa: BLE001 - no metadata: the stamp only changes less often
        nb = "?"
    h = hashlib.sha1(f"{nb} {sys.version_info[:3]} {os.environ.get('NUMBA_CACHE_DIR', '')}".encode())
    for p in _kernel_sources():
        st = p.stat()
        h.update(f"{p.name} {st.st_size} {st.st_mtime_ns}".encode())
    return h.hexdigest()


def _index_fresh(src: Path) -> bool:
    """Whether numba's cache holds an index (``.nbi``) for a function of module ``src`` written after it."""
    base = os.environ.get("NUMBA_CACHE_DIR", "").strip()
    if base:  # numba mirrors the source folder under NUMBA_CACHE_DIR
        folder = Path(base) / src.parent.resolve().relative_to(src.parent.resolve().anchor)
    else:
        folder = src.parent / "__pycache__"
    try:
        mtime = src.stat().st_mtime
        return any(p.stat().st_mtime >= mtime for p in folder.glob(f"{src.stem}.*.nbi"))
    except OSError:
        return False


def kernels_cold(kind: str = "run") -> bool:
    """Whether the next job of ``kind`` compiles the numba kernels (first run after an install, an upgrade or a
    cleared cache).

    Warm when a job of that kind finished with the same kernel sources, numba and Python (recorded in
    the calibration file) or when numba's cache holds a fresh index for every kernel module; cold otherwise.
    """
    stamps = load_calibration().get("kernels_stamp")
    if isinstance(stamps, dict) and stamps.get(kind) == _kernel_stamp():
        return False
    return not all(_index_fresh(p) for p in _kernel_sources())


def calibrate(est: dict) -> dict:
    """``est`` with what the display shows: the wall time calibrated on this machine, and the compile phase.

    Adds ``wall_display_s`` (the model's variable part times the median measured ratio of this job kind,
    plus the median measured time after the last progress report, or the model's fixed part),
    ``calibration`` (``ratio``, ``runs`` measured, ``text``) and ``compile_s`` (the estimated
    compilation, 0 when the kernels' cache is warm).
    """
    cal = load_calibration()
    kind = est.get("kind", "run")
    ratios = [float(r) for r in (cal.get("ratios") or {}).get(kind, []) if isinstance(r, (int, float)) and r > 0]
    ratio = statistics.median(ratios) if ratios else 1.0
    tails = [float(x) for x in (cal.get("tails") or {}).get(kind, []) if isinstance(x, (int, float)) and x >= 0]
    model_fixed = float(est.get("breakdown", {}).get("fixed_s", FIXED_S))
    fixed = statistics.median(tails) if tails else model_fixed
    out = dict(est)
    out["wall_display_s"] = fixed + ratio * max(float(est["wall_s"]) - model_fixed, 0.0)
    out["calibration"] = {"ratio": ratio, "runs": len(ratios),
                          "text": f"calibrated on this machine ({len(ratios)} run(s))" if ratios
                          else "built-in costs, not yet calibrated on this machine"}
    cold = kernels_cold(kind)
    out["compile_s"] = float(cal.get("compile_s", COMPILE_S)) if cold else 0.0
    return out


def record_timing(est: dict, t_start: float, t_first: float, f_first: float, t_last: float, f_last: float,
                  t_end: float | None = None) -> dict:
    """Remember what a run measured: its speed against the model and, on a cold cache, the compile time.

    Parameters
    ----------
    est : dict
        The calibrated estimate handed to the display (:func:`calibrate`).
    t_start : float
        When the estimate was announced (s, ``time.perf_counter``), just before the engine starts.
    t_first, f_first : float
        Time and fraction of the first progress report (the first chunk done, compilation included).
    t_last, f_last : float
        Time and fraction of the last report.
    t_end : float, optional
        When the job finished (its analyses, figures and report written after the last report).

    Returns
    -------
    dict
        The calibration file's new content (also written; unchanged when nothing could be measured).
    """
    cal = load_calibration()
    kind = est.get("kind", "run")
    fixed = float(est.get("breakdown", {}).get("fixed_s", FIXED_S))
    variable = max(float(est["wall_s"]) - fixed, 0.0)  # the model's time for the whole simulation
    between = (f_last - f_first) * variable
    measured_ratio = None
    if f_last >= 1.0 - 1e-9 and between >= _MIN_MEASURED_S and t_last > t_first:
        measured_ratio = (t_last - t_first) / between
        ratios = dict(cal.get("ratios") or {})
        ratios[kind] = ([r for r in ratios.get(kind, []) if isinstance(r, (int, float))] + [measured_ratio])[
            -CALIBRATION_KEEP:]
        cal["ratios"] = ratios
    if f_last >= 1.0 - 1e-9 and t_end is not None and t_end >= t_last:
        tails = dict(cal.get("tails") or {})
        tails[kind] = ([x for x in tails.get(kind, []) if isinstance(x, (int, float))] + [t_end - t_last])[
            -CALIBRATION_KEEP:]
        cal["tails"] = tails
    if f_last >= 1.0 - 1e-9:
        if est.get("compile_s", 0.0) > 0.0:
            # the first chunk's own computing time at the measured (or the model's) speed, taken off
            per_fraction = variable * (measured_ratio or float(est.get("calibration", {}).get("ratio", 1.0)))
            cal["compile_s"] = max(t_first - t_start - f_first * per_fraction, 0.0)
        stamps = cal.get("kernels_stamp") if isinstance(cal.get("kernels_stamp"), dict) else {}
        cal["kernels_stamp"] = {**stamps, kind: _kernel_stamp()}
        _save_calibration(cal)
    return cal


# --- the time left while a run goes ----------------------------------------------------------------------
class RemainingTime:
    """The time left of a running job, from its own measured throughput.

    The estimate made before the run (the cost model, calibrated on earlier runs) can be off several times on a
    loaded machine or for a mission unlike the calibrating ones (a 30-minute flight shown as 52 s ran 2 min 44
    s), so the display does not count down from it. From the first progress report on (the first chunk done:
    start-up and compilation are behind it), each report gives the throughput, fraction per wall second between
    the first report and the latest; once :attr:`MIN_INTERVALS` chunks have run after the first and
    :attr:`MIN_MEASURED_S` wall seconds have passed, the time left is ``(1 - f) / throughput`` plus the job's
    tail after its last report (analyses, figures: the median measured on this machine, else the model's
    fixed part). Before that the text says it is still estimating, and names the model's figure as the model's.

    Parameters
    ----------
    est : dict or None
        The calibrated estimate (:func:`calibrate`), or None (no model: only the measurement).
    clock : callable, optional
        Wall clock in seconds (default ``time.perf_counter``; a test passes a fake one).
    """

    #: Chunks after the first before the throughput is trusted: the first interval can carry a second kernel's
    #: compilation or a cold file cache; three intervals average it down.
    MIN_INTERVALS = 3
    #: Wall seconds after the first report before the throughput is trusted (short chunks time poorly).
    MIN_MEASURED_S = 2.0

    def __init__(self, est: dict | None = None, clock=None):
        import time

        self.clock = clock or time.perf_counter
        self.est = est
        self.first = None  # (t, fraction) of the first report
        self.last = None
        self.reports = 0
        tails = [float(x) for x in ((load_calibration().get("tails") or {}).get((est or {}).get("kind", "run"), []))
                 if isinstance(x, (int, float)) and x >= 0] if est is not None else []
        fixed = float((est or {}).get("breakdown", {}).get("fixed_s", FIXED_S)) if est is not None else 0.0
        self.tail_s = statistics.median(tails) if tails else fixed

    def update(self, fraction: float) -> None:
        """Record a progress report (the fraction of the run done, 0 to 1) at the clock's time."""
        now = (float(self.clock()), min(max(float(fraction), 0.0), 1.0))
        if self.first is None:
            self.first = now
        self.last = now
        self.reports += 1

    def seconds_left(self) -> float | None:
        """The measured time left (s), or None while too little has run to measure it."""
        if self.first is None or self.reports - 1 < self.MIN_INTERVALS:
            return None
        (t1, f1), (t2, f2) = self.first, self.last
        if t2 - t1 < self.MIN_MEASURED_S or f2 <= f1:
            return None
        return (1.0 - f2) * (t2 - t1) / (f2 - f1) + self.tail_s

    def text(self) -> str:
        """What the display shows: ``about 2.7 min left`` or ``estimating the time left (model: 52 s)``."""
        left = self.seconds_left()
        if left is not None:
            return f"about {format_duration(left)} left (measured)"
        if self.est is None:
            return "estimating the time left"
        model = format_duration(self.est.get("wall_display_s", self.est["wall_s"]))
        cal = "" if (self.est.get("calibration") or {}).get("runs") else ", not yet calibrated"
        return f"estimating the time left (model: {model}{cal})"
