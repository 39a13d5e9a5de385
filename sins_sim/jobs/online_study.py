"""What learning the parameters in operation buys (issue 29, item 3).

Runs one scenario whose ``filter_parameters`` is ``{source: online, ...}`` four times, with the filters'
parameters from ``online`` (as written), ``true`` (the unit's own at t = 0, f0 tracked by the PLL),
``nominal`` (the datasheet, f0 from the PLL at t = 0) and ``nominal + track`` (the datasheet, f0 following
the PLL), and reports:

- per axis and parameter (f0, k1, k2, k3, k5, Q) the estimator's convergence time and steady error against
  the unit's truth at each update: the steady error is the RMS relative error over the last quarter of the
  run; the convergence time is the first update after which the relative error stays within
  ``max(3 x steady error, 1e-4)``;
- per variant and per filter that takes parameters (:func:`sins_sim.filters.registry.parameter_filters`: both
  forms of eq. 5 and the wideband designs, by default every one; ``ideal`` beside them as the floor) the residual
  (``gyro_error_rms_arcsec`` of ``metrics.json``: the gyro angle error about its mean, per axis) and the navigation
  errors (final horizontal position, attitude RMS).

Usage::

    sins-sim online-study scenarios/online-estimation-ramp.yaml --out online-study [--filters correcting ...]

writes ``online-study.json``, ``online-study.md`` and ``online-estimates.png`` (estimates against truth over
time, per axis).

The cross-check (issue 29, item 4): :func:`estimate_recording` runs the same estimator offline over a
``sins-sim-recording/1`` file made with the amplitude modulated (e.g. an ``afc_sweep`` experiment stepping the
voltage at one frequency), and :func:`crosscheck` sets its estimate beside the ``sins-sim diagnose`` refit of the
same recording::

    sins-sim online-study --crosscheck REC.npz DIAGNOSIS.json

(``python -m sins_sim.jobs.online_study`` takes the same arguments.)
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

__all__ = ["VARIANTS", "convergence", "online_study", "study_filters", "estimate_recording", "crosscheck", "markdown",
           "add_arguments", "main"]

PARAMS = ("f0_hz", "k1", "k2", "k3", "k5", "q")


def VARIANTS(online_fp: dict) -> dict:  # noqa: N802 - a table built from the scenario's own online settings
    """The four parameter sources compared, as ``filter_parameters`` overrides."""
    return {"online": dict(online_fp), "true": {"source": "true", "track": True},
            "nominal": {"source": "nominal", "track": False}, "nominal_track": {"source": "nominal", "track": True}}


def convergence(t_s, estimate, truth, floor: float = 1e-4) -> dict:
    """Convergence time and steady relative error of one parameter's estimate (module docstring)."""
    t = np.asarray(t_s, dtype=float)
    err = np.asarray(estimate, dtype=float) / np.asarray(truth, dtype=float) - 1.0
    tail = t >= t[0] + 0.75 * (t[-1] - t[0])
    steady = float(np.sqrt(np.mean(err[tail] ** 2)))
    bound = max(3.0 * steady, floor)
    outside = np.nonzero(np.abs(err) > bound)[0]
    conv = float(t[0]) if outside.size == 0 else (float(t[outside[-1] + 1]) if outside[-1] + 1 < t.size else math.nan)
    return {"steady_rel_error_rms": steady, "steady_rel_error_mean": float(np.mean(err[tail])),
            "convergence_s": conv, "bound_rel": bound, "final_rel_error": float(err[-1])}


def study_filters(filters=None) -> tuple:
    """The filters the study compares: ``filters`` (each known and taking parameters, else a one-line error
    naming ``--filters``), default every filter that takes parameters; ``ideal`` first, as the floor."""
    from sins_sim.filters import registry

    names = registry.parameter_filters() if filters is None else tuple(dict.fromkeys(filters))
    for n in names:
        if not registry.is_known(n):
            raise ValueError(f"--filters: unknown filter {n!r}; the filters that take parameters: "
                             f"{', '.join(registry.parameter_filters())}")
        if not registry.takes_parameters(n):
            raise ValueError(f"--filters: {n} takes no suspension parameters (its output does not depend on "
                             f"filter_parameters); the filters that do: {', '.join(registry.parameter_filters())}")
    if not names:
        raise ValueError("--filters: give at least one filter that takes parameters")
    return ("ideal",) + tuple(n for n in names if n != "ideal")


def online_study(scenario_path, out_dir, duration_s: float | None = None, threads: int | None = None,
                 filters=None, progress=None) -> dict:
    """Run the four variants (module docstring) over ``filters`` (:func:`study_filters`); write the JSON, the
    markdown table and the figure. ``progress``: callable(fraction) or None."""
    from sins_sim.config.errors import ConfigError
    from sins_sim.config.scenario import load_scenario, scenario_document
    from sins_sim.jobs.run import compute_run, prepare_run
    from sins_sim.simulation.online import history_arrays

    scenario_path = Path(scenario_path)
    out = Path(out_dir)
    names = study_filters(filters)
    base = load_scenario(scenario_path)
    if base.filter_spec["source"] != "online":
        raise ConfigError(f"{scenario_path}: filter_parameters.source: the online study needs online (it compares "
                          f"it with true, nominal and nominal + track), got {base.filter_spec['source']!r}")
    out.mkdir(parents=True, exist_ok=True)
    online_fp = {"source": "online", "track": bool(base.filter_spec["track"]),
                 "online": {f"{k}": v for k, v in base.filter_spec["online"].items()}}
    overrides = {} if duration_s is None else {"duration_s": float(duration_s)}
    doc = dict(scenario_document(scenario_path), filters=list(names))
    result = {"scenario": base.name, "filters": list(names), "variants": {}, "estimator": {}}
    histories = {}
    variants = VARIANTS(online_fp)
    for k, (name, fp) in enumerate(variants.items()):
        scenario, warn = prepare_run(doc, overrides=dict(overrides, filter_parameters=fp),
                                     base_dir=scenario_path.parent)
        res, metrics = compute_run(scenario, warn, threads=threads)
        row = {"filter_parameters": fp, "gyro_error_rms_arcsec": metrics["gyro_error_rms_arcsec"]}
        for flt, m in metrics["filters"].items():
            if m.get("status") != "ok":
                row[flt] = {"status": m.get("status")}
                continue
            row[flt] = {"horizontal_position_error_final_m": m["horizontal_position_error_m"]["final"],
                        "attitude_error_rms_arcsec": m["attitude_error_arcsec"]["rms"],
                        "velocity_error_final_m_s": m["velocity_error_m_s"]["final"]}
        result["variants"][name] = row
        if name == "online":
            for axis, d in res.online.items():
                h = history_arrays(d["history"])
                histories[axis] = h
                result["estimator"][axis] = {p: convergence(h["t_s"], h[f"estimate_{p}"], h[f"truth_{p}"])
                                             for p in PARAMS}
                kinds = {}
                for _, kind, _ in d["events"]:
                    kinds[kind] = kinds.get(kind, 0) + 1
                result["estimator"][axis]["events"] = kinds
        if progress is not None:
            progress((k + 1) / len(variants))
    (out / "online-study.json").write_text(json.dumps(result, indent=2, default=float))
    (out / "online-study.md").write_text(markdown(result))
    if histories:
        from sins_sim.plots.online import plot_online_estimates

        plot_online_estimates(histories, out / "online-estimates.png")
    return result


def _drive_frequency(v: np.ndarray, fs_hz: float) -> float:
    """The drive's frequency (Hz): the peak of its Hann-windowed spectrum (zero-padded 8 x), refined by the parabola
    through the log magnitudes of the three bins around it (a recording does not store the PLL's frequency; a
    unit's electronics know it)."""
    n = v.size
    spec = np.abs(np.fft.rfft((v - v.mean()) * np.hanning(n), 8 * n))
    k = int(np.argmax(spec[1:-1])) + 1
    a, b, c = np.log(spec[k - 1:k + 2])
    return (k + 0.5 * (a - c) / (a - 2.0 * b + c)) * fs_hz / (8 * n)


def estimate_recording(path, settings=None, amplitude_rad: float | None = None) -> dict:
    """The online estimator run offline over a recording, per axis (``OnlineEstimate`` of its end).

    The prior and the units are the header's nominal parameters; ``amplitude_rad`` (default: the median of the
    amplitude seen in the readout) is the reference amplitude; the drive frequency is read off the drive
    (:func:`_drive_frequency`). Forgetting defaults to 1000 s: a batch estimate over the whole record.
    """
    from sins_sim.filters.online_estimator import OnlineEstimator, OnlineSettings
    from sins_sim.io.recording import read_recording

    rec = read_recording(path)
    meta = rec.meta
    fs = float(meta["fs_hz"])
    ratio = int(round(float(meta.get("drive_fs_hz", fs)) / fs))
    settings = settings or OnlineSettings(forgetting_s=1e3)
    out = {}
    for i, axis in enumerate(meta["axes"]):
        x = rec.counts[:, i].astype(np.float64) * float(meta["quantum_rad"])
        v = np.asarray(rec.drive_v[::ratio, i], dtype=np.float64)[:x.size]
        x = x[:v.size]
        f = _drive_frequency(v, fs)
        nom = meta["nominal"][axis]
        ds = {k: float(nom[k]) for k in ("f0_hz", "k1", "k2", "k3", "k4", "k5")}
        if amplitude_rad is None:  # the dither amplitude seen, from the readout's own spectrum line
            t = np.arange(x.size) / fs
            z = np.diff(x) * np.exp(-2j * np.pi * f * t[1:])
            m = int(round(fs / f))
            env = np.abs(np.convolve(z, np.ones(m) / m, mode="valid")) * 2.0 / abs(1.0 - np.exp(-2j * np.pi * f / fs))
            a_ref = float(np.median(env))
        else:
            a_ref = float(amplitude_rad)
        v_ref = float(np.sqrt(2.0) * np.std(v))
        est = OnlineEstimator(settings, fs, f, a_ref, v_ref, 1e3 * v_ref, ds)
        est.process(x, v)
        out[axis] = {"estimate": est.solve(), "drive_hz": f, "a_ref_rad": a_ref, "events": list(est.events)}
    return out


def crosscheck(recording, diagnosis_json) -> dict:
    """The online estimate of a recording beside the offline refit (``baseline.params``) of its diagnosis, per axis
    and parameter: both values, their relative difference and the online sigma."""
    diag = json.loads(Path(diagnosis_json).read_text())["baseline"]["params"]
    online = estimate_recording(recording)
    out = {}
    for axis, row in online.items():
        e = row["estimate"]
        out[axis] = {p: {"diagnose": float(diag[axis][p]), "online": float(e.values[p]),
                         "online_sigma": (float(e.std[p]) if math.isfinite(e.std.get(p, math.nan)) else None),
                         "relative_difference": float(e.values[p] / diag[axis][p] - 1.0)}
                     for p in ("f0_hz", "k1", "k2", "k3", "k4", "k5")}
    return out


def markdown(result: dict) -> str:
    """The study's tables."""
    lines = [f"# Online estimation: {result['scenario']}", "",
             "## Estimator: convergence time and steady relative error (RMS over the last quarter)", "",
             "| axis | " + " | ".join(PARAMS) + " |", "|---" * (len(PARAMS) + 1) + "|"]
    for axis, row in result["estimator"].items():
        cells = [f"{row[p]['convergence_s']:.1f} s / {100 * row[p]['steady_rel_error_rms']:.3g} %" for p in PARAMS]
        lines.append(f"| {axis} | " + " | ".join(cells) + " |")
    lines += ["", "## Residual and navigation error per parameter source and filter", "",
              "Every filter that takes parameters (`ideal`: the floor, no parameters). Gyro error RMS: the gyro "
              "angle error about its mean, per axis.", "",
              "| source | filter | gyro error RMS x, y, z (arcsec) | horizontal position, final (m) | attitude RMS "
              "N, E, D (arcsec) |", "|---|---|---|---|---|"]
    names = result.get("filters") or ["correcting"]
    for name, row in result["variants"].items():
        for flt in names:
            g = row["gyro_error_rms_arcsec"].get(flt, [math.nan] * 3)
            c = row.get(flt, {})
            if "status" in c:
                lines.append(f"| {name} | {flt} | {c['status']} | | |")
                continue
            att = c.get("attitude_error_rms_arcsec", {})
            lines.append(f"| {name} | {flt} | {', '.join(f'{x:.3f}' for x in g)} | "
                         f"{c.get('horizontal_position_error_final_m', math.nan):.4g} | "
                         f"{', '.join(f'{att.get(k, math.nan):.3g}' for k in ('north', 'east', 'down'))} |")
    return "\n".join(lines) + "\n"


def add_arguments(ap) -> None:
    """The study's arguments (``sins-sim online-study`` and ``python -m sins_sim.jobs.online_study``)."""
    ap.add_argument("scenario", nargs="?", help="a scenario with filter_parameters: {source: online, ...}")
    ap.add_argument("--out", help="result folder")
    ap.add_argument("--crosscheck", nargs=2, metavar=("RECORDING", "DIAGNOSIS_JSON"),
                    help="the online estimate of a recording beside its diagnosis' refit (issue 29, item 4)")
    ap.add_argument("--duration", type=float, default=None, help="replaces the scenario's duration_s (s)")
    ap.add_argument("--filters", nargs="+", default=None, metavar="NAME",
                    help="the filters compared, each one that takes parameters [every one: correcting, "
                         "correcting_paper and the wideband designs]")
    ap.add_argument("--threads", type=int, default=None, help="threads per run [the engine's default]")


def print_crosscheck(rows_by_axis: dict) -> None:
    for axis, rows in rows_by_axis.items():
        print(f"axis {axis}: parameter, diagnose (offline refit), online, online sigma, online / diagnose - 1")
        for p, r in rows.items():
            print(f"  {p:6} {r['diagnose']:12.6g} {r['online']:12.6g} {r['online_sigma'] or float('nan'):10.3g} "
                  f"{100 * r['relative_difference']:+8.2f} %")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m sins_sim.jobs.online_study", description=__doc__.split("\n\n")[0])
    add_arguments(ap)
    a = ap.parse_args(argv)
    if a.crosscheck:
        print_crosscheck(crosscheck(*a.crosscheck))
        return 0
    if not a.scenario or not a.out:
        ap.error("a scenario and --out are required (or --crosscheck RECORDING DIAGNOSIS_JSON)")
    from sins_sim.config.errors import ConfigError

    try:
        res = online_study(a.scenario, a.out, a.duration, a.threads, filters=a.filters)
    except (ConfigError, ValueError) as exc:  # a scenario the study cannot run: one line, no traceback
        print(f"online_study: {exc}", file=sys.stderr)
        return 2
    print(markdown(res))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
