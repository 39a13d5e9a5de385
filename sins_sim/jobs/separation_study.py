"""How far apart must the resonances be? Two dithers on one block, brought together (issue 27).

``sins-sim separation-study IMU.yaml --out DIR`` takes a unit whose IMU file has a ``block:`` section and moves
the second axis's resonance (``--pair``, default ``x,y``) so that its drive, at its coupled resonance on the block
(:func:`~sins_sim.models.block.coupled_dither_frequencies`), runs ``Delta`` below the first's, for each
``Delta`` of ``--separations-hz``. Each point is a stationary mission of the full engine (block, three
suspensions, drives, readouts, filters, navigation), and three things are measured:

- **dither coning**: the block's counter-rotation at each dither (about ``(J_g / J_b) a``, two-body closed form
  :func:`~sins_sim.models.block.counter_rotation`) rocks it about both axes; two rocking axes make a coning angle
  about the third that beats at ``Delta`` with amplitude ``a_x a_y (w_x + w_y) / (4 |w_x - w_y|)``
  (:func:`~sins_sim.models.block.coning_beat_amplitude`; docs/user-guide/block.md). The ideal navigation follows it;
  a filter that removes the rocking but keeps the slow coning rate (the eliminator notches each dither line)
  carries it into the heading. Measured: each filter's error about the third axis (psi; the heading when the pair
  is x, y), its RMS at the filter rate (which also holds the block's counter-rotation at the third gyro's own
  dither) and the amplitude of its beat at the separation (fitted on 25 ms means, where the dither lines average
  out), beside the closed-form beat of the two counter-rotations;
- **cross-axis drive**: the second gyro's deflection at the first's drive frequency, relative to its own dither
  (fitted on the raw readout's error over the navigated span, both lines at once). It comes from the block's
  coupling of the axes: products of inertia, and each gyro's input-axis offset (``--axis-offset-mrad`` tilts the
  second gyro's axis towards the first, 2 mrad by default: "a few mrad", issue 27);
- **entrainment risk**: a phase-locked drive holds its own line while the interfering line it sees is small; the
  study flags a separation where the cross-axis ratio reaches :data:`LOCK_RATIO` (0.1: a phase disturbance of
  up to 0.1 rad, 6 deg, at the beat, which a drive PLL with a bandwidth above ``Delta`` follows). This is a
  criterion on the simulated ratio, not a simulation of two PLLs pulling each other (the engine's drives run at
  fixed frequencies on the block).

The answer, per filter: the smallest tested separation above which the beat in its heading error stays within
``--budget-arcsec`` (0.05 arcsec by default, :data:`BUDGET_ARCSEC`); and the smallest separation with no
entrainment risk.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np

from sins_sim.units import ARCSEC

__all__ = ["separation_study", "DEFAULT_SEPARATIONS_HZ", "LOCK_RATIO", "FILTERS"]

#: Separations tried by default (Hz): from well apart down to a tenth of a hertz.
DEFAULT_SEPARATIONS_HZ = (40.0, 20.0, 10.0, 5.0, 2.0, 1.0, 0.5, 0.2, 0.1)
#: Cross-axis line relative to a gyro's own dither at which the study flags a risk of entrainment (module docstring).
LOCK_RATIO = 0.1
#: Filters compared (``raw``, the readout with its dither, is run for the cross-axis line only).
FILTERS = ("ideal", "eliminator", "correcting", "correcting_paper")
_RUN = ("ideal", "raw", "eliminator", "correcting", "correcting_paper")
#: Rate of the stored attitude-error series (block means over 25 ms: the dither lines, 300-450 Hz, average out).
SERIES_HZ = 40.0
#: The beat is measured up to this separation (a quarter of the series rate); above it the closed form is below
#: 1e-3 arcsec for the bundled block and the stored series cannot resolve it.
MAX_BEAT_HZ = 10.0
#: Default budget of the dither coning in a filter's heading error (arcsec, amplitude of the beat): a tenth of the
#: residual eq. 5 leaves at rest (0.4-0.5 arcsec RMS on this unit), so that the coning stays below the filter's
#: own floor (an assumption of this study; set ``--budget-arcsec``).
BUDGET_ARCSEC = 0.05
_AXES = ("x", "y", "z")


def _with_f0(imu, axis: int, f0_hz: float):
    chs = list(imu.channels)
    chs[axis] = dataclasses.replace(chs[axis], suspension=dataclasses.replace(chs[axis].suspension, f0_hz=f0_hz))
    return dataclasses.replace(imu, channels=tuple(chs))


def _tilted(imu, a: int, b: int, offset_rad: float):
    """The unit with gyro ``b``'s input axis tilted by ``offset_rad`` towards axis ``a``."""
    if offset_rad == 0.0:
        return imu
    axes = np.array(imu.block.input_axes, dtype=float)
    axes[b, a] += offset_rad
    return dataclasses.replace(imu, block=dataclasses.replace(imu.block, input_axes=axes))


def _check_offset(imu, a: int, b: int, offset_mrad: float) -> None:
    """``--axis-offset-mrad`` and the tilt it makes with the file's own offset within the block's misalignment bound."""
    from sins_sim.config.block_schema import AXIS_OFFSET_MAX_MRAD as lim
    from sins_sim.config.errors import ConfigError

    rule = (f"must lie in [-{lim:g}, {lim:g}] mrad (an input-axis offset beyond {lim:g} mrad, 3 deg, is not a "
            "misalignment but another design)")
    if not (math.isfinite(offset_mrad) and abs(offset_mrad) <= lim):
        raise ConfigError(f"--axis-offset-mrad: {rule}, got {offset_mrad:g}")
    total = 1e3 * float(imu.block.input_axes[b][a]) + offset_mrad
    if abs(total) > lim:
        raise ConfigError(f"--axis-offset-mrad: {rule} together with the IMU file's gyro_axes_mrad.{_AXES[b]}"
                          f"[{a}], got {total:g} mrad in all")


def _place(imu, a: int, b: int, delta_hz: float):
    """The unit with axis ``b``'s resonance moved so that its drive on the block runs ``delta_hz`` below axis
    ``a``'s (a few secant steps: the coupled frequency is nearly linear in f0)."""
    from sins_sim.simulation.unit import drives_on_block

    target = drives_on_block(imu)[a].drive.frequency_hz - delta_hz
    f0 = imu.channels[a].suspension.f0_hz - delta_hz
    for _ in range(6):
        unit = _with_f0(imu, b, f0)
        got = drives_on_block(unit)[b].drive.frequency_hz
        if abs(got - target) < 1e-9 * target:
            break
        f0 += target - got
    return unit


def _point(imu, a: int, b: int, delta_hz: float, duration_s: float, start_s: float, seed: int) -> dict:
    from sins_sim.models.block import coning_beat_amplitude, counter_rotation
    from sins_sim.simulation.metrics import stored_line
    from sins_sim.simulation.responses import line_amplitudes
    from sins_sim.models.motion.rotations import Static
    from sins_sim.simulation.sins import NavSettings, simulate_sins
    from sins_sim.simulation.unit import drives_on_block

    unit = _place(imu, a, b, delta_hz)
    drives = drives_on_block(unit)
    fa, fb = drives[a].drive.frequency_hz, drives[b].drive.frequency_hz
    nav = NavSettings(start_s=start_s, spectrum_s=duration_s - start_s, timeseries_rate_hz=SERIES_HZ)
    res = simulate_sins(unit, Static(), duration_s, seed=seed, nav=nav, filters=_RUN)
    blk = unit.block
    amp = {d["axis"]: d["amplitude_measured_rad"] for d in res.drives}
    rock = []
    for i, f in ((a, fa), (b, fb)):
        j = float(blk.input_axes[i] @ blk.inertia_kg_m2 @ blk.input_axes[i])
        ratio = abs(complex(counter_rotation(blk.gyro_inertia_kg_m2[i], j, blk.k_rot_n_m_per_rad[i],
                                             blk.c_rot_n_m_s_per_rad[i], f)))
        rock.append(ratio * amp[_AXES[i]])
    beat = coning_beat_amplitude(rock[0], rock[1], 2 * np.pi * fa, 2 * np.pi * fb)
    c = 3 - a - b  # the third axis: the coning's
    heading = {}
    for name in FILTERS:
        if name in res.diverged or name not in res.series:
            heading[name] = {"rms_arcsec": None, "beat_arcsec": None}
            continue
        st = res.stats[name]
        # the series holds means over 1 / SERIES_HZ: the dither lines average out, a beat at delta is attenuated
        # by sinc(delta / SERIES_HZ), which stored_line undoes
        ser = res.series[name]
        beat_meas = None
        if delta_hz <= MAX_BEAT_HZ:
            tt = np.asarray(ser["t_s"])
            yy = np.asarray(ser["attitude_ned_rad"])[:, c]
            beat_meas = stored_line(tt, yy, fb - fa, SERIES_HZ) / ARCSEC
        heading[name] = {"rms_arcsec": float(np.sqrt(st.att_sum2[c] / st.n) / ARCSEC), "beat_arcsec": beat_meas}
    t = np.asarray(res.spectra["t"])
    raw = np.asarray(res.spectra["raw"])[:, b]
    cross, own = line_amplitudes(t, raw, (fa, fb))
    return {"separation_hz": delta_hz, "drive_hz": {_AXES[a]: fa, _AXES[b]: fb},
            "f0_hz": {_AXES[a]: unit.channels[a].suspension.f0_hz, _AXES[b]: unit.channels[b].suspension.f0_hz},
            "counter_rotation_arcsec": {_AXES[a]: rock[0] / ARCSEC, _AXES[b]: rock[1] / ARCSEC},
            "coning_beat_closed_form_arcsec": beat / ARCSEC,
            "heading_error": heading,
            "cross_axis_arcsec": cross / ARCSEC, "own_dither_arcsec": own / ARCSEC,
            "cross_axis_ratio": cross / own if own > 0 else float("nan"),
            "entrainment_risk": bool(own > 0 and cross / own >= LOCK_RATIO),
            "diverged": sorted(res.diverged), "warnings": list(res.warnings)}


def _answer(points: list, budget_arcsec: float) -> dict:
    """Per filter (not the ideal, whose heading follows the block) the smallest tested separation above which the
    heading error's beat at the separation (the dither coning it carries) stays within ``budget_arcsec``; and the
    smallest separation above which no point has entrainment risk. Separations above :data:`MAX_BEAT_HZ`, where
    the beat is not measured, count as within the budget when its closed form is."""
    pts = sorted(points, key=lambda p: -p["separation_hz"])  # largest first
    out = {"budget_arcsec": budget_arcsec, "required_separation_hz": {}}
    for name in FILTERS[1:]:
        need = None
        for p in pts:
            v = p["heading_error"][name]["beat_arcsec"]
            if v is None:
                v = p["coning_beat_closed_form_arcsec"]
            if v > budget_arcsec:
                break
            need = p["separation_hz"]
        out["required_separation_hz"][name] = need
    lock = None
    for p in pts:
        if p["entrainment_risk"]:
            break
        lock = p["separation_hz"]
    out["no_entrainment_risk_down_to_hz"] = lock
    return out


def separation_study(imu, out, *, pair=("x", "y"), separations_hz=DEFAULT_SEPARATIONS_HZ, duration_s: float = 30.0,
                     start_s: float = 2.0, axis_offset_mrad: float = 2.0, budget_arcsec: float = BUDGET_ARCSEC,
                     seed: int = 1, force: bool = False, manifest=None, inputs=(), progress=None) -> dict:
    """Run the study (module docstring); write ``separation.json``, ``separation.csv``, ``separation.png`` and
    ``report.md`` into ``out`` and return the results.

    Parameters
    ----------
    imu : ImuConfig
        A unit with a ``block`` (:mod:`sins_sim.models.block`).
    pair : (str, str)
        The axis whose resonance stays, and the one brought towards it.
    separations_hz : sequence of float
        Drive-frequency separations to try (Hz, > 0).
    duration_s, start_s : float
        Each mission's length and its navigation start (s); the duration should cover a few beats of the
        smallest separation.
    axis_offset_mrad : float
        Tilt of the second gyro's input axis towards the first (mrad).
    budget_arcsec : float
        Largest beat amplitude (arcsec) the coning may put into a filter's heading error: the answer's criterion.
    """
    from sins_sim.config.errors import ConfigError
    from sins_sim.jobs.manifest import Manifest, result_dir

    if getattr(imu, "block", None) is None:
        raise ConfigError("imu: a separation study needs a block: section (the sensor block on its isolators); "
                          "without it the dithers never meet")
    if len(pair) != 2 or pair[0] == pair[1] or any(p not in _AXES for p in pair):
        raise ConfigError(f"--pair: two different axes of x, y, z, got {','.join(pair)}")
    seps = sorted({float(s) for s in separations_hz}, reverse=True)
    if not seps or any(not (s > 0 and math.isfinite(s)) for s in seps):
        raise ConfigError(f"--separations-hz: separations must be finite and > 0 Hz, got {separations_hz}")
    if max(seps) > 100.0:
        raise ConfigError(f"--separations-hz: at most 100 Hz (dither resonances lie in 300-450 Hz), got {max(seps):g}")
    if not (budget_arcsec > 0 and math.isfinite(budget_arcsec)):
        raise ConfigError(f"--budget-arcsec: must be a finite number > 0, got {budget_arcsec!r}")
    if not (start_s > 0 and duration_s > start_s + 1.0):
        raise ConfigError(f"--duration-s: must exceed the navigation start {start_s:g} s by at least 1 s, "
                          f"got {duration_s:g}")
    a, b = (_AXES.index(p) for p in pair)
    _check_offset(imu, a, b, axis_offset_mrad)
    base = _tilted(imu, a, b, axis_offset_mrad * 1e-3)
    points = []
    for k, d in enumerate(seps):
        points.append(_point(base, a, b, d, duration_s, start_s, seed))
        if progress is not None:
            progress((k + 1) / len(seps))
    res = {"settings": {"pair": list(pair), "separations_hz": seps, "duration_s": duration_s, "start_s": start_s,
                        "axis_offset_mrad": axis_offset_mrad, "seed": seed, "lock_ratio": LOCK_RATIO,
                        "budget_arcsec": budget_arcsec,
                        "beat_periods_at_smallest": (duration_s - start_s) * min(seps)},
           "points": points, "answer": _answer(points, budget_arcsec)}
    if manifest is None:  # called from Python: the record of what produced the folder is the call's settings
        manifest = Manifest("separation-study", None, settings=res["settings"])
    with result_dir(out, manifest, "--out", inputs=inputs, force=force) as tmp:
        tmp = Path(tmp)
        (tmp / "separation.json").write_text(json.dumps(res, indent=1) + "\n")
        (tmp / "separation.csv").write_text(_csv(points))
        from sins_sim.plots.block import plot_separation_study

        plot_separation_study(res, tmp / "separation.png")
        (tmp / "report.md").write_text(_report(res))
    return res


def _csv(points) -> str:
    cols = ["separation_hz"] + [f"heading_rms_arcsec_{n}" for n in FILTERS] + [
        f"heading_beat_arcsec_{n}" for n in FILTERS] + [
        "coning_beat_closed_form_arcsec", "cross_axis_arcsec", "own_dither_arcsec", "cross_axis_ratio",
        "entrainment_risk"]
    rows = [",".join(cols)]
    for p in points:
        vals = [p["separation_hz"]] + [p["heading_error"][n]["rms_arcsec"] for n in FILTERS] + [
            p["heading_error"][n]["beat_arcsec"] for n in FILTERS] + [
            p["coning_beat_closed_form_arcsec"], p["cross_axis_arcsec"], p["own_dither_arcsec"],
            p["cross_axis_ratio"], p["entrainment_risk"]]
        rows.append(",".join("" if v is None else (f"{v:.6g}" if isinstance(v, float) else str(v)) for v in vals))
    return "\n".join(rows) + "\n"


def _report(res) -> str:
    s = res["settings"]
    a, b = s["pair"]
    ans = res["answer"]
    lines = ["# How far apart must the resonances be?", "",
             f"Axis {b}'s resonance is moved so that its drive runs each separation below axis {a}'s, on the block "
             f"of the IMU file (its drives at their coupled resonances), with axis {b}'s input axis tilted "
             f"{s['axis_offset_mrad']:g} mrad towards {a}. Each point: a stationary mission of {s['duration_s']:g} s, "
             f"navigation from {s['start_s']:g} s, seed {s['seed']} "
             f"({s['beat_periods_at_smallest']:.3g} beat periods at the smallest separation).", "",
             f"Error about {'xyz'[3 - 'xyz'.index(a) - 'xyz'.index(b)]} (the coning axis) per filter: its beat at the "
             "separation (amplitude, arcsec; fitted on 25 ms means, measured up to "
             f"{MAX_BEAT_HZ:g} Hz) and, in brackets, its RMS at the filter rate.", "",
             "| separation (Hz) | " + " | ".join(f"{n}" for n in FILTERS)
             + " | coning beat, closed form (arcsec) | cross-axis / own dither | entrainment risk |",
             "|" + "---|" * (len(FILTERS) + 4)]
    for p in res["points"]:
        cells = [f"{p['separation_hz']:g}"]
        for n in FILTERS:
            h = p["heading_error"][n]
            if h["rms_arcsec"] is None:
                cells.append("diverged")
                continue
            beat = "n/a" if h["beat_arcsec"] is None else f"{h['beat_arcsec']:.3g}"
            cells.append(f"{beat} ({h['rms_arcsec']:.3g})")
        cells += [f"{p['coning_beat_closed_form_arcsec']:.3g}", f"{p['cross_axis_ratio']:.3g}",
                  "yes" if p["entrainment_risk"] else "no"]
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", "## Answer", "",
              f"Smallest tested separation above which the beat in a filter's heading error stays within "
              f"{ans['budget_arcsec']:g} arcsec:", ""]
    lines += [f"- {n}: " + ("not even the largest tested" if v is None else f"{v:g} Hz")
              for n, v in ans["required_separation_hz"].items()]
    lock = ans["no_entrainment_risk_down_to_hz"]
    lines += ["", f"No entrainment risk (cross-axis line below {s['lock_ratio']:g} of the own dither) down to "
                  + ("no tested separation" if lock is None else f"{lock:g} Hz") + ".", "",
              "The coning beat's closed form is `a_x a_y (w_x + w_y) / (4 |w_x - w_y|)` with each axis's rocking from "
              "the two-body counter-rotation and the measured dither amplitude; a filter that notches the dither "
              "lines (the eliminator) keeps the slow coning rate but not the rocking that cancels it, so its heading "
              "error follows the beat. The entrainment flag is a criterion on the simulated cross-axis ratio, not a "
              "simulation of two drive PLLs pulling each other.", "", "Figure: `separation.png`.", ""]
    return "\n".join(lines)
