"""What learning the parameters in operation buys (issue 29, item 3).

Runs one scenario whose ``filter_parameters`` is ``{source: online, ...}`` four times, with the filters'
parameters from ``online`` (as written), ``true`` (the unit's own at t = 0, f0 tracked by the PLL),
``nominal`` (the datasheet, f0 from the PLL at t = 0) and ``nominal + track`` (the datasheet, f0 following
the PLL), and reports:

- per axis and parameter (f0, k1, k2, k3, k5, Q) the estimator's convergence time and steady error against
  the unit's truth at each update: the steady error is the RMS relative error over the last quarter of the
  run; the convergence time is the first update after which the relative error stays within
  ``max(3 x steady error, 1e-4)``;
- per variant the correcting filter's residual (``gyro_error_rms_arcsec`` of ``metrics.json``: the gyro angle
  error about its mean, per axis) and the navigation errors (final horizontal position, attitude RMS).

Usage::

    python -m sins_sim.jobs.online_study scenarios/online-estimation-ramp.yaml --out online-study

writes ``online-study.json``, ``online-study.md`` and ``online-estimates.png`` (estimates against truth over
time, per axis).
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np

__all__ = ["VARIANTS", "convergence", "online_study", "main"]

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


def online_study(scenario_path, out_dir, duration_s: float | None = None, threads: int | None = None) -> dict:
    """Run the four variants (module docstring); write the JSON, the markdown table and the figure."""
    from sins_sim.config.scenario import load_scenario
    from sins_sim.jobs.run import compute_run, prepare_run
    from sins_sim.simulation.online import history_arrays

    scenario_path = Path(scenario_path)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    base = load_scenario(scenario_path)
    if base.filter_spec["source"] != "online":
        raise ValueError(f"{scenario_path}: filter_parameters.source must be online, got {base.filter_spec['source']!r}")
    online_fp = {"source": "online", "track": bool(base.filter_spec["track"]),
                 "online": {f"{k}": v for k, v in base.filter_spec["online"].items()}}
    overrides = {} if duration_s is None else {"duration_s": float(duration_s)}
    result = {"scenario": base.name, "variants": {}, "estimator": {}}
    histories = {}
    for name, fp in VARIANTS(online_fp).items():
        scenario, warn = prepare_run(scenario_path, overrides=dict(overrides, filter_parameters=fp))
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
    (out / "online-study.json").write_text(json.dumps(result, indent=2, default=float))
    (out / "online-study.md").write_text(markdown(result))
    if histories:
        from sins_sim.plots.online import plot_online_estimates

        plot_online_estimates(histories, out / "online-estimates.png")
    return result


def markdown(result: dict) -> str:
    """The study's tables."""
    lines = [f"# Online estimation: {result['scenario']}", "",
             "## Estimator: convergence time and steady relative error (RMS over the last quarter)", "",
             "| axis | " + " | ".join(PARAMS) + " |", "|---" * (len(PARAMS) + 1) + "|"]
    for axis, row in result["estimator"].items():
        cells = [f"{row[p]['convergence_s']:.1f} s / {100 * row[p]['steady_rel_error_rms']:.3g} %" for p in PARAMS]
        lines.append(f"| {axis} | " + " | ".join(cells) + " |")
    lines += ["", "## Residual and navigation error per parameter source (filter `correcting`, unity-DC eq. 5)", "",
              "| source | gyro error RMS x, y, z (arcsec) | horizontal position, final (m) | attitude RMS N, E, D "
              "(arcsec) |", "|---|---|---|---|"]
    for name, row in result["variants"].items():
        g = row["gyro_error_rms_arcsec"].get("correcting", [math.nan] * 3)
        c = row.get("correcting", {})
        att = c.get("attitude_error_rms_arcsec", {})
        lines.append(f"| {name} | {', '.join(f'{x:.3f}' for x in g)} | "
                     f"{c.get('horizontal_position_error_final_m', math.nan):.4g} | "
                     f"{', '.join(f'{att.get(k, math.nan):.3g}' for k in ('north', 'east', 'down'))} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m sins_sim.jobs.online_study", description=__doc__.split("\n\n")[0])
    ap.add_argument("scenario")
    ap.add_argument("--out", required=True)
    ap.add_argument("--duration", type=float, default=None)
    ap.add_argument("--threads", type=int, default=None)
    a = ap.parse_args(argv)
    res = online_study(a.scenario, a.out, a.duration, a.threads)
    print(markdown(res))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
