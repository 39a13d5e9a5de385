"""How far apart must the resonances be? Two dithers on one block, brought together (issues 27 and 38).

``sins-sim separation-study IMU.yaml --out DIR [--scenario FILE]`` takes a unit whose IMU file has a ``block:``
section and moves the second axis's resonance (``--pair``, default ``x,y``) so that its drive, at its coupled
resonance on the block (:func:`~sins_sim.models.block.coupled_dither_frequencies`), runs ``Delta`` below the
first's, for each ``Delta`` of ``--separations-hz``. Each point is a mission of the full engine (block, three
suspensions, drives, readouts, filters, navigation), at rest or under the vibration of ``--scenario`` (its
``motion`` and ``linear_vibration``, entering where the scenario says), and four things are measured:

- **dither coning**: the block's counter-rotation at each dither (about ``(J_g / J_b) a``, two-body closed form
  :func:`~sins_sim.models.block.counter_rotation`) rocks it about both axes; two rocking axes make a coning angle
  about the third that beats at ``Delta`` with amplitude ``a_x a_y (w_x + w_y) / (4 |w_x - w_y|)``
  (:func:`~sins_sim.models.block.coning_beat_amplitude`; docs/user-guide/block.md). The ideal navigation follows it;
  a filter that removes the rocking but keeps the slow coning rate (the eliminator notches each dither line)
  carries it into the heading. Measured: each filter's error about the third axis (psi; the heading when the pair
  is x, y), its RMS at the filter rate and the amplitude of its beat at the separation, by a Hann-weighted
  lock-in (:func:`series_line`) on 2.5 ms means of the attitude error with the dither lines the means alias fitted
  beside it, from the record's resolution ``2 / T`` up to 100 Hz; with the record's floor beside it
  (:func:`series_floor`);
- **intermodulation**: a vibration line (a ``sines`` part of the scenario's motion) turns the block at ``f_v``; it
  cones with the counter-rotation at each dither ``f_d`` about another axis and puts lines at ``|f_d - f_v|`` and
  ``f_d + f_v`` into the third gyro (closed forms in :func:`_intermodulation`); the difference line is measured in
  each filter's attitude error about that gyro's axis, as the beat. The eliminator's carries the truth's coning
  less that of its own increments (:func:`_navigated_difference`): the rocking its stop band leaves, coned with its
  output at ``f_v``, which the vibration axis's own gyro (its dither suspension excited below resonance) makes
  several times the block's line when ``f_v`` nears that gyro's resonance;
- **cross-axis drive**: the second gyro's deflection at the first's drive frequency, relative to its own dither
  (fitted on the raw readout's error over the navigated span, both lines at once). It comes from the block's
  coupling of the axes: products of inertia, and each gyro's input-axis offset (``--axis-offset-mrad`` tilts the
  second gyro's axis towards the first, 2 mrad by default: "a few mrad", issue 27); the study flags an
  entrainment risk where the ratio reaches :data:`LOCK_RATIO` (0.1 rad of phase disturbance at the beat);
- **live PLLs**: each drive on its own phase-locked loop on the coupled plant
  (:func:`~sins_sim.simulation.drive_pll.simulate_pll_drives`, ``--pll-bandwidth-hz``), run at rest. Reported:
  the separation the PLLs hold, the pull of the first drive against a run with the resonances
  :data:`PLL_REFERENCE_HZ` apart, beside the pull of the passive coupled modes (exact, linearised) and its
  weak-coupling closed form (:func:`~sins_sim.models.block.mode_pulling_hz`), the frequency modulation of each
  drive at the beat, and whether the two locked together. Under a scenario whose vibration enters at the chassis,
  the PLLs run again under it (:func:`~sins_sim.simulation.drive_pll.pll_line_response`): for each drive and each
  vibration line, the FM at the offset ``|f_d - f_v|`` against its closed form from the loop's transfer function
  (the line's response read by the detector as a phase disturbance), the line's response relative to the dither,
  Adler's lock range for it, and whether the line captures the PLL (``pll_vibration.csv``).

The answer, per filter: the smallest tested separation above which the beat in its heading error stays within
``--budget-arcsec`` (0.05 arcsec by default, :data:`BUDGET_ARCSEC`); and the smallest separation with neither an
entrainment risk nor live PLLs locked together.
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
#: Rate of the stored attitude-error series (means over 2.5 ms). A line is measured up to a quarter of it (100 Hz,
#: the largest separation the study takes, where the means pass 0.9 of it) and down to the record's resolution
#: ``2 / T``; the dither lines (300-450 Hz) alias into it and are fitted with the line (:func:`series_line`).
SERIES_HZ = 400.0
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

    from sins_sim.config.errors import ConfigError

    f0 = imu.channels[a].suspension.f0_hz - delta_hz
    for _ in range(8):
        unit = _with_f0(imu, b, f0)
        drv = drives_on_block(unit)
        got = drv[a].drive.frequency_hz - drv[b].drive.frequency_hz
        if abs(got - delta_hz) < 1e-9 * drv[a].drive.frequency_hz:
            return unit
        f0 -= delta_hz - got
    raise ConfigError(f"--separations-hz: the drives cannot be placed {delta_hz:g} Hz apart on this block (got "
                      f"{got:.4g} Hz): the coupled modes repel, and no two modes come closer than their coupling "
                      "allows (a smaller --axis-offset-mrad, or a larger separation)")


def _alias(f_hz: float, rate_hz: float) -> float:
    """Where a line at ``f_hz`` lands in a series of means at ``rate_hz`` (folded into [0, rate / 2])."""
    return abs(f_hz - rate_hz * round(f_hz / rate_hz))


def series_line(t_s, y, f_hz: float, others_hz=(), rate_hz: float = SERIES_HZ) -> float | None:
    """Amplitude of the line at ``f_hz`` in a stored series of means over ``1 / rate_hz`` (the lock-in of
    :func:`sins_sim.simulation.responses.line_amplitudes` fitted together with the known lines ``others_hz``
    where the means alias them, with an offset and a trend, on Hann-weighted samples), divided by the means' gain
    ``|sinc(f / rate)|``. The Hann weight keeps the leakage of any line left out of the fit below ``1 / (N_bins^3)``
    of it, ``N_bins`` its distance in record bins ``1 / T`` (Harris 1978, Proc. IEEE 66(1), table I: -31 dB
    sidelobes falling at 18 dB/octave). None when the record cannot resolve the line: ``f`` below ``2 / T`` (the
    Hann main lobe), above ``rate / 4``, or within ``2 / T`` of an alias of a known line."""
    t = np.asarray(t_s, dtype=np.float64)
    span = float(t[-1] - t[0]) if t.size > 1 else 0.0
    res = 2.0 / span if span > 0 else math.inf
    if not (res <= f_hz <= rate_hz / 4):
        return None
    al = []
    for f in others_hz:
        a = _alias(float(f), rate_hz)
        if abs(a - f_hz) < res:
            return None
        if a >= res and all(abs(a - b) >= res for b in al):
            al.append(a)
    w = np.abs(np.sin(np.pi * (t - t[0]) / span))  # the square root of the Hann weight, per sample
    cols = [np.ones_like(t), t - t.mean()]
    for f in [f_hz] + al:
        cols += [np.cos(2 * np.pi * f * t), np.sin(2 * np.pi * f * t)]
    c, *_ = np.linalg.lstsq(np.column_stack(cols) * w[:, None], np.asarray(y, dtype=np.float64) * w, rcond=None)
    return float(math.hypot(c[2], c[3])) / abs(float(np.sinc(f_hz / rate_hz)))


def series_floor(t_s, y, f_hz: float, others_hz=(), rate_hz: float = SERIES_HZ) -> float | None:
    """The record's floor near ``f_hz``: the RMS of :func:`series_line` at six frequencies beside it, ``f +- k 3 /
    T`` (k = 1, 2, 3: outside the Hann main lobe of the line and of each other). A line's measured amplitude
    departs from its true one by about this much; a Gaussian floor's amplitude at one frequency is Rayleigh
    distributed with this RMS, and exceeds three times it with probability ``exp(-9)``, about 1e-4."""
    t = np.asarray(t_s, dtype=np.float64)
    span = float(t[-1] - t[0]) if t.size > 1 else 0.0
    if span <= 0:
        return None
    got = [series_line(t, y, f_hz + k * 3.0 / span, others_hz, rate_hz) for k in (-3, -2, -1, 1, 2, 3)]
    got = [g for g in got if g is not None]
    return float(np.sqrt(np.mean(np.square(got)))) if got else None


def vibration_lines(scenario) -> list:
    """The angular sine lines of a scenario's motion, ``(axis, f_hz, amplitude_rad, phase_rad)`` (the profile's
    angle ``A sin(2 pi f t + p)``), amplitude > 0 and f > 0."""
    out = []
    for part in getattr(scenario, "motion_spec", None) or ():
        if part.get("type") != "sines":
            continue
        for ax in range(3):
            a, f = float(part["amplitude_rad"][ax]), float(part["frequency_hz"][ax])
            if a > 0 and f > 0:
                out.append((ax, f, a, float(part.get("phase_rad", (0.0, 0.0, 0.0))[ax])))
    return out


def _block_line(block_rec, axis: int, f_hz: float, amp: float, phase: float) -> float | None:
    """The block's absolute rotation about ``axis`` at a profile line (rad, amplitude), as simulated: the profile
    ``A sin(2 pi f t + p)`` plus the block's own rotation relative to its frame at that frequency (the run's
    ``block`` record, a lock-in), added with their phases. The profile is part of the frame whether it enters at
    the chassis or at the block (:func:`sins_sim.simulation.unit.block_base_excitation`). None without a record
    of at least two periods."""
    if not block_rec:
        return None
    t = np.asarray(block_rec["t_s"], dtype=float)
    th = np.asarray(block_rec["theta_rad"], dtype=float)
    if t.size < 2 or (t[-1] - t[0]) * f_hz < 2:
        return None
    w = 2 * np.pi * f_hz
    cols = np.column_stack([np.ones_like(t), np.sin(w * t), np.cos(w * t)])
    c, *_ = np.linalg.lstsq(cols, th[:, axis], rcond=None)
    return float(abs(complex(amp * math.cos(phase) + c[1], amp * math.sin(phase) + c[2])))


def _phasor(t_s, y, f_hz: float) -> complex:
    """Complex amplitude ``A`` of the line ``Re(A exp(i 2 pi f t))`` in ``y`` (least squares with an offset and a
    trend; ``t`` absolute, so that phasors of one run compare)."""
    t = np.asarray(t_s, dtype=float)
    w = 2 * np.pi * f_hz
    c, *_ = np.linalg.lstsq(np.column_stack([np.ones_like(t), t - t.mean(), np.cos(w * t), np.sin(w * t)]),
                            np.asarray(y, dtype=float), rcond=None)
    return complex(c[2], -c[3])


def _navigated_difference(block_rec, spectra, d: int, v: int, fd: float, fv: float, amp: float, phase: float):
    """The difference line the eliminator's attitude carries (rad), with its two inputs: ``(line, |R_n|, |B_n|)``.

    The navigation integrates the coning of the increments it is given, so its error at ``|f_d - f_v|`` is the
    truth's coning of the rocking ``R`` (at ``f_d`` about ``d``) with the block's line ``B`` (at ``f_v`` about
    ``v``) less the coning of the eliminator's own lines there, ``R_n`` and ``B_n``: each the difference-frequency
    term of two lines in Bortz's rate, ``(w_d + w_v) / (4 |w_d - w_v|)`` times ``R conj(B)`` (as
    :func:`~sins_sim.models.block.coning_beat_amplitude`; Bortz 1971, IEEE Trans. AES-7(1), eq. 27), so
    ``(w_d + w_v) / (4 |w_d - w_v|) |R conj(B) - R_n conj(B_n)|``. ``R``, ``B``: the run's block record (the
    profile ``A sin(2 pi f t + p)`` added to the block's own rotation about ``v``); ``R_n = R + e_d``,
    ``B_n = B + e_v`` with ``e`` the eliminator's angle error at the line (``spectra``: output minus truth).
    ``R_n`` is the rocking the eliminator's stop band leaves (about 1 % of it); ``B_n`` departs from ``B`` by the
    vibration axis's own gyro: its dither suspension, base-excited below its resonance, deflects by
    ``(f_v / f_0)^2 / (1 - (f_v / f_0)^2)`` of ``B`` (``f_0`` its resonance at that swing: 5.5 times for 384 Hz
    under a 421 Hz gyro, whose resonance is 417.7 Hz at the 300 arcsec it swings), and the eliminator's phase
    there. Their coning takes ``|R_n| |B_n|`` (8 % of ``|R| |B|`` in that case) from the
    closed form. None without a block record or spectra."""
    if not block_rec or not spectra or "eliminator" not in spectra:
        return None
    tb, th = np.asarray(block_rec["t_s"]), np.asarray(block_rec["theta_rad"])
    ts, err = np.asarray(spectra["t"]), np.asarray(spectra["eliminator"])
    if tb.size < 2 or ts.size < 2 or min(tb[-1] - tb[0], ts[-1] - ts[0]) * min(fv, fd) < 2:
        return None
    r = _phasor(tb, th[:, d], fd)
    b = _phasor(tb, th[:, v], fv) + amp * np.exp(1j * (phase - np.pi / 2))
    rn = r + _phasor(ts, err[:, d], fd)
    bn = b + _phasor(ts, err[:, v], fv)
    wd, wv = 2 * np.pi * fd, 2 * np.pi * fv
    line = (wd + wv) / (4 * abs(wd - wv)) * abs(r * np.conj(b) - rn * np.conj(bn))
    return float(line), float(abs(rn)), float(abs(bn))


def _intermodulation(unit, drives_hz, rock, lines, motion_enters: str) -> list:
    """Closed forms of the lines a vibration line makes with each dither in the third gyro (module docstring):
    the block's rotation ``b`` at ``f_v`` about ``v`` cones with its counter-rotation ``rho`` at the dither
    ``f_d`` about ``d``; the body rate's ``-(1/2) theta x theta'`` puts into gyro ``c`` (the third axis) the
    difference line ``rho b (w_d + w_v) / (4 |w_d - w_v|)`` and the sum line ``rho b |w_d - w_v| / (4 (w_d + w_v))``
    (angle amplitudes; the product ``rho sin(w_d t) b sin(w_v t + phi)`` in Bortz's rate, as for
    :func:`~sins_sim.models.block.coning_beat_amplitude`). ``b``: the scenario's amplitude when the motion is the
    block's own, else the chassis amplitude times :func:`~sins_sim.models.block.block_rotation_from_chassis`."""
    from sins_sim.models.block import block_rotation_from_chassis, coning_beat_amplitude

    sus = [c.suspension for c in unit.channels]
    amp = [c.drive.amplitude_rad for c in unit.channels]
    om = [2 * np.pi * s.resonance_hz(a) for s, a in zip(sus, amp)]
    q = [s.q_factor(a) for s, a in zip(sus, amp)]
    out = []
    for v, fv, av, _ in lines:
        if motion_enters == "block":
            b = av
        else:
            b = av * abs(complex(block_rotation_from_chassis(unit.block, om, q, v, fv)[v]))
        for d in range(3):
            if d == v or rock[d] is None:
                continue
            fd = drives_hz[d]
            wd, wv = 2 * np.pi * fd, 2 * np.pi * fv
            if wd == wv:
                continue
            out.append({"vibration_axis": _AXES[v], "vibration_hz": fv, "vibration_block_arcsec": b / ARCSEC,
                        "dither_axis": _AXES[d], "dither_hz": fd, "counter_rotation_arcsec": rock[d] / ARCSEC,
                        "gyro": _AXES[3 - d - v], "difference_hz": abs(fd - fv), "sum_hz": fd + fv,
                        "difference_closed_form_arcsec": coning_beat_amplitude(rock[d], b, wd, wv) / ARCSEC,
                        "sum_closed_form_arcsec": rock[d] * b * abs(wd - wv) / (4 * (wd + wv)) / ARCSEC})
    return out


def _rock(unit, drives_hz, amp, axis: int) -> float:
    """The block's counter-rotation about ``axis`` at its dither (rad): the two-body closed form times the
    measured dither amplitude."""
    from sins_sim.models.block import counter_rotation

    blk = unit.block
    j = float(blk.input_axes[axis] @ blk.inertia_kg_m2 @ blk.input_axes[axis])
    ratio = abs(complex(counter_rotation(blk.gyro_inertia_kg_m2[axis], j, blk.k_rot_n_m_per_rad[axis],
                                         blk.c_rot_n_m_s_per_rad[axis], drives_hz[axis])))
    return ratio * amp[_AXES[axis]]


def _point(imu, a: int, b: int, delta_hz: float, duration_s: float, start_s: float, seed: int,
           vibration=None) -> dict:
    from sins_sim.models.block import coning_beat_amplitude
    from sins_sim.simulation.responses import line_amplitudes
    from sins_sim.models.motion.rotations import Static
    from sins_sim.simulation.sins import NavSettings, simulate_sins
    from sins_sim.simulation.unit import drives_on_block

    unit = _place(imu, a, b, delta_hz)
    drives = drives_on_block(unit)
    f_all = [d.drive.frequency_hz for d in drives]
    fa, fb = f_all[a], f_all[b]
    nav = NavSettings(start_s=start_s, spectrum_s=duration_s - start_s, timeseries_rate_hz=SERIES_HZ)
    vib = vibration or {}
    res = simulate_sins(unit, vib.get("motion") or Static(), duration_s, seed=seed, nav=nav, filters=_RUN,
                        translation=vib.get("translation"), vibration_enters=vib.get("vibration_enters", "chassis"),
                        motion_enters=vib.get("motion_enters", "chassis"))
    amp = {d["axis"]: d["amplitude_measured_rad"] for d in res.drives}
    rock = [_rock(unit, f_all, amp, i) for i in range(3)]
    beat = coning_beat_amplitude(rock[a], rock[b], 2 * np.pi * fa, 2 * np.pi * fb)
    lines = vib.get("lines", [])
    inter = _intermodulation(unit, f_all, rock, lines, vib.get("motion_enters", "chassis"))
    for x in inter:
        # the block's rotation at the line as the engine has it, and the closed form with it (as the beat's takes
        # the measured dither amplitudes)
        v = _AXES.index(x["vibration_axis"])
        line = next(ln for ln in lines if ln[0] == v and ln[1] == x["vibration_hz"])
        b_sim = _block_line(res.block, v, line[1], line[2], line[3])
        x["vibration_block_simulated_arcsec"] = None if b_sim is None else b_sim / ARCSEC
        x["difference_closed_form_simulated_block_arcsec"] = (
            None if b_sim is None else x["difference_closed_form_arcsec"] * b_sim / (x["vibration_block_arcsec"] * ARCSEC))
        # the eliminator's own coning: the rocking it leaves at f_d cones with its output at f_v (module docstring)
        d = _AXES.index(x["dither_axis"])
        nav_cf = _navigated_difference(res.block, res.spectra, d, v, x["dither_hz"], line[1], line[2], line[3])
        for key, i in (("difference_closed_form_navigated_arcsec", 0), ("eliminator_rocking_left_arcsec", 1),
                       ("eliminator_line_arcsec", 2)):
            x[key] = None if nav_cf is None else nav_cf[i] / ARCSEC
    # every line the attitude error can hold, so that the lock-in fits the ones the means alias near the one it
    # measures: the dithers, their sums, the vibration lines and the intermodulation lines
    known = list(f_all) + [fi + fj for fi in f_all for fj in f_all] + [ln[1] for ln in lines] + [
        x[k] for x in inter for k in ("difference_hz", "sum_hz")]
    c = 3 - a - b  # the third axis: the coning's
    heading = {}
    for name in FILTERS:
        if name in res.diverged or name not in res.series:
            heading[name] = {"rms_arcsec": None, "beat_arcsec": None, "beat_floor_arcsec": None}
            continue
        st = res.stats[name]
        ser = res.series[name]
        tt = np.asarray(ser["t_s"])
        att = np.asarray(ser["attitude_ned_rad"])
        others = [f for f in known if abs(f - (fa - fb)) > 1e-9]
        beat_meas = series_line(tt, att[:, c], fa - fb, others)
        floor = series_floor(tt, att[:, c], fa - fb, others + [fa - fb])
        heading[name] = {"rms_arcsec": float(np.sqrt(st.att_sum2[c] / st.n) / ARCSEC),
                         "beat_arcsec": None if beat_meas is None else beat_meas / ARCSEC,
                         "beat_floor_arcsec": None if floor is None else floor / ARCSEC}
        for x in inter:
            g = _AXES.index(x["gyro"])
            fdiff = x["difference_hz"]
            oth = [f for f in known + [fa - fb] if abs(f - fdiff) > 1e-9]
            m = series_line(tt, att[:, g], fdiff, oth)
            fl = series_floor(tt, att[:, g], fdiff, oth + [fdiff])
            x[f"difference_arcsec_{name}"] = None if m is None else m / ARCSEC
            x[f"difference_floor_arcsec_{name}"] = None if fl is None else fl / ARCSEC
    t = np.asarray(res.spectra["t"])
    raw = np.asarray(res.spectra["raw"])[:, b]
    cross, own = line_amplitudes(t, raw, (fa, fb))
    return {"separation_hz": delta_hz, "drive_hz": {_AXES[a]: fa, _AXES[b]: fb},
            "f0_hz": {_AXES[a]: unit.channels[a].suspension.f0_hz, _AXES[b]: unit.channels[b].suspension.f0_hz},
            "counter_rotation_arcsec": {_AXES[a]: rock[a] / ARCSEC, _AXES[b]: rock[b] / ARCSEC},
            "coning_beat_closed_form_arcsec": beat / ARCSEC,
            "heading_error": heading, "intermodulation": inter,
            "cross_axis_arcsec": cross / ARCSEC, "own_dither_arcsec": own / ARCSEC,
            "cross_axis_ratio": cross / own if own > 0 else float("nan"),
            "entrainment_risk": bool(own > 0 and cross / own >= LOCK_RATIO),
            "diverged": sorted(res.diverged), "warnings": list(res.warnings)}, unit


#: Separation of the PLL runs' reference (Hz): the second resonance this far below the first, where the pulling
#: is below 1e-3 of its value at 1 Hz (it falls as 1 / separation).
PLL_REFERENCE_HZ = 100.0
#: The PLLs settle over this many envelope time constants ``2 Q / w`` (and at least PLL_SETTLE_MIN_S) before their
#: frequencies are averaged: exp(-10) of the start transient is left.
PLL_SETTLE_TAUS = 10.0
PLL_SETTLE_MIN_S = 1.0
#: The averaging window of the PLLs' frequencies: a whole number of beat periods, at least PLL_WINDOW_MIN_BEATS of
#: them and at least PLL_WINDOW_MIN_S long.
PLL_WINDOW_MIN_S = 4.0
PLL_WINDOW_MIN_BEATS = 4


def _pll_run(unit, a: int, b: int, delta_hz: float, pll) -> dict:
    """The live PLLs on ``unit`` (drives ``delta_hz`` apart): each drive's mean frequency over whole beat periods
    after the settling, and the frequency modulation at the beat."""
    from sins_sim.simulation.drive_pll import simulate_pll_drives
    from sins_sim.simulation.responses import line_amplitudes

    sus = unit.channels[a].suspension
    am = unit.channels[a].drive.amplitude_rad
    tau = 2 * sus.q_factor(am) / (2 * np.pi * sus.resonance_hz(am))
    settle = max(PLL_SETTLE_MIN_S, PLL_SETTLE_TAUS * tau)
    window = max(PLL_WINDOW_MIN_BEATS, math.ceil(PLL_WINDOW_MIN_S * delta_hz)) / delta_hz
    r = simulate_pll_drives(unit, settle + window, pll)
    t, f = r["t_s"], r["frequency_hz"]
    keep = t > t[-1] - window
    mean = f[:, keep].mean(axis=1)
    fm = [line_amplitudes(t[keep], f[i, keep], (delta_hz,), trend=True)[0] for i in (a, b)]
    return {"mean_hz": mean, "start_hz": r["start_hz"], "fm_hz": fm, "window_s": window}


def _pll_vibration(unit, a: int, lines, pll, vib) -> dict | None:
    """The live PLLs of ``unit`` under the scenario's vibration where it enters at the chassis (the profile that
    enters at the block is its frame, not an input through the isolators: not run), against the same at rest."""
    from sins_sim.simulation.drive_pll import pll_line_response

    motion = vib["motion"] if vib.get("motion_enters") == "chassis" else None
    translation = vib.get("translation") if vib.get("vibration_enters") == "chassis" else None
    if not lines or (motion is None and translation is None):
        return None
    sus = unit.channels[a].suspension
    am = unit.channels[a].drive.amplitude_rad
    tau = 2 * sus.q_factor(am) / (2 * np.pi * sus.resonance_hz(am))
    settle = max(PLL_SETTLE_MIN_S, PLL_SETTLE_TAUS * tau)
    r = pll_line_response(unit, settle + PLL_WINDOW_MIN_S, settle, sorted({ln[1] for ln in lines}), pll,
                          motion=motion, translation=translation)
    return {"lines": r["lines"], "mean_shift_hz": {_AXES[i]: float(r["mean_hz"][i] - r["rest_mean_hz"][i])
                                                   for i in range(3)}}


def _answer(points: list, budget_arcsec: float) -> dict:
    """Per filter (not the ideal, whose heading follows the block) the smallest tested separation above which the
    heading error's beat at the separation (the dither coning it carries) stays within ``budget_arcsec``; and the
    smallest separation above which no point has entrainment risk nor live PLLs locked together. A separation the record cannot resolve (below
    ``2 / T``) counts as within the budget when its closed form is."""
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
        if p["entrainment_risk"] or p["pll"]["entrained"]:
            break
        lock = p["separation_hz"]
    out["no_entrainment_risk_down_to_hz"] = lock
    return out


def separation_study(imu, out, *, pair=("x", "y"), separations_hz=DEFAULT_SEPARATIONS_HZ, duration_s: float = 30.0,
                     start_s: float = 2.0, axis_offset_mrad: float = 2.0, budget_arcsec: float = BUDGET_ARCSEC,
                     seed: int = 1, scenario=None, pll=None, force: bool = False, manifest=None, inputs=(),
                     progress=None) -> dict:
    """Run the study (module docstring); write ``separation.json``, ``separation.csv``, ``intermodulation.csv``,
    ``pll_vibration.csv``, ``separation.png`` and ``report.md`` into ``out`` and return the results.

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
    scenario : Scenario or None
        The mission whose vibration the unit is under (its ``motion`` and ``linear_vibration``, where they enter);
        None: at rest.
    pll : PllSettings or None
        The drives' PLLs of the live-PLL runs (:mod:`sins_sim.simulation.drive_pll`); None: the defaults.
    """
    from sins_sim.config.errors import ConfigError
    from sins_sim.jobs.manifest import Manifest, result_dir
    from sins_sim.models.block import mode_pulling_hz
    from sins_sim.simulation.drive_pll import PllSettings

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
    if pll is None:
        pll = PllSettings()
    elif not isinstance(pll, PllSettings):
        raise ConfigError(f"--pll-bandwidth-hz: expected PLL settings, got {type(pll).__name__}")
    a, b = (_AXES.index(p) for p in pair)
    _check_offset(imu, a, b, axis_offset_mrad)
    base = _tilted(imu, a, b, axis_offset_mrad * 1e-3)
    vibration = None
    if scenario is not None:
        vibration = {"motion": scenario.motion, "translation": scenario.translation,
                     "vibration_enters": scenario.vibration_enters, "motion_enters": scenario.motion_enters,
                     "lines": vibration_lines(scenario)}
    ref_unit = _place(base, a, b, PLL_REFERENCE_HZ)
    ref = _pll_run(ref_unit, a, b, PLL_REFERENCE_HZ, pll)
    ref_drive = _drives_hz(ref_unit)
    ref_pull = mode_pulling_hz(ref_unit.block, ref_drive, a, b)
    points = []
    for k, d in enumerate(seps):
        p, unit = _point(base, a, b, d, duration_s, start_s, seed, vibration)
        live = _pll_run(unit, a, b, d, pll)
        f_lin = _drives_hz(unit)
        p["pll"] = {
            "mean_hz": {_AXES[a]: float(live["mean_hz"][a]), _AXES[b]: float(live["mean_hz"][b])},
            "separation_held_hz": float(live["mean_hz"][a] - live["mean_hz"][b]),
            "pull_hz": float(live["mean_hz"][a] - ref["mean_hz"][a]),
            "pull_linear_modes_hz": float(f_lin[a] - ref_drive[a]),
            "pull_closed_form_hz": float(mode_pulling_hz(unit.block, f_lin, a, b) - ref_pull),
            "fm_at_beat_hz": {_AXES[a]: live["fm_hz"][0], _AXES[b]: live["fm_hz"][1]},
            "window_s": live["window_s"],
            "entrained": bool(abs(live["mean_hz"][a] - live["mean_hz"][b]) < 0.5 * d)}
        p["pll_vibration"] = None if vibration is None else _pll_vibration(unit, a, vibration["lines"], pll,
                                                                           vibration)
        points.append(p)
        if progress is not None:
            progress((k + 1) / len(seps))
    res = {"settings": {"pair": list(pair), "separations_hz": seps, "duration_s": duration_s, "start_s": start_s,
                        "axis_offset_mrad": axis_offset_mrad, "seed": seed, "lock_ratio": LOCK_RATIO,
                        "budget_arcsec": budget_arcsec, "series_rate_hz": SERIES_HZ,
                        "resolution_hz": 2.0 / (duration_s - start_s),
                        "beat_periods_at_smallest": (duration_s - start_s) * min(seps),
                        "scenario": getattr(scenario, "name", None),
                        "vibration_lines": [{"axis": _AXES[v], "frequency_hz": f, "amplitude_arcsec": x / ARCSEC,
                                             "phase_rad": ph} for v, f, x, ph in (vibration or {}).get("lines", [])],
                        "pll": {"bandwidth_hz": pll.bandwidth_hz, "damping": pll.damping,
                                "update_hz": pll.update_hz, "reference_separation_hz": PLL_REFERENCE_HZ}},
           "points": points, "answer": _answer(points, budget_arcsec)}
    if manifest is None:  # called from Python: the record of what produced the folder is the call's settings
        manifest = Manifest("separation-study", None, settings=res["settings"])
    with result_dir(out, manifest, "--out", inputs=inputs, force=force) as tmp:
        tmp = Path(tmp)
        (tmp / "separation.json").write_text(json.dumps(res, indent=1) + "\n")
        (tmp / "separation.csv").write_text(_csv(points))
        (tmp / "intermodulation.csv").write_text(_csv_inter(points))
        (tmp / "pll_vibration.csv").write_text(_csv_pll_vib(points))
        from sins_sim.plots.block import plot_separation_study

        plot_separation_study(res, tmp / "separation.png")
        (tmp / "report.md").write_text(_report(res))
    return res


def _drives_hz(unit) -> list:
    from sins_sim.simulation.unit import drives_on_block

    return [d.drive.frequency_hz for d in drives_on_block(unit)]


def _fmt(v, digits: int = 6) -> str:
    return "" if v is None else (f"{v:.{digits}g}" if isinstance(v, float) else str(v))


def _csv(points) -> str:
    cols = ["separation_hz"] + [f"heading_rms_arcsec_{n}" for n in FILTERS] + [
        f"heading_beat_arcsec_{n}" for n in FILTERS] + [f"heading_beat_floor_arcsec_{n}" for n in FILTERS] + [
        "coning_beat_closed_form_arcsec", "cross_axis_arcsec", "own_dither_arcsec", "cross_axis_ratio",
        "entrainment_risk", "pll_separation_held_hz", "pll_pull_hz", "pll_pull_linear_modes_hz",
        "pll_pull_closed_form_hz", "pll_fm_at_beat_hz_first", "pll_fm_at_beat_hz_second", "pll_entrained",
        "pll_vibration_fm_hz_first", "pll_vibration_fm_hz_second", "pll_vibration_captured"]
    rows = [",".join(cols)]
    for p in points:
        q = p["pll"]
        fm = list(q["fm_at_beat_hz"].values())
        vals = [p["separation_hz"]] + [p["heading_error"][n]["rms_arcsec"] for n in FILTERS] + [
            p["heading_error"][n]["beat_arcsec"] for n in FILTERS] + [
            p["heading_error"][n]["beat_floor_arcsec"] for n in FILTERS] + [
            p["coning_beat_closed_form_arcsec"], p["cross_axis_arcsec"], p["own_dither_arcsec"],
            p["cross_axis_ratio"], p["entrainment_risk"], q["separation_held_hz"], q["pull_hz"],
            q["pull_linear_modes_hz"], q["pull_closed_form_hz"], fm[0], fm[1], q["entrained"]] + _vib_cells(p)
        rows.append(",".join(_fmt(v) for v in vals))
    return "\n".join(rows) + "\n"


def _vib_cells(p) -> list:
    """The largest FM over the vibration lines of the pair's two drives, and whether any line captured a PLL."""
    v = p.get("pll_vibration")
    if v is None:
        return [None, None, None]
    a, b = p["drive_hz"]
    fm = [max((x["fm_hz"] for x in v["lines"] if x["axis"] == k), default=None) for k in (a, b)]
    return fm + [any(x["locked_to_line"] for x in v["lines"])]


_PLL_VIB_COLS = ("axis", "line_hz", "drive_hz", "offset_hz", "phase_disturbance_rad", "line_to_dither", "fm_hz",
                 "fm_closed_form_hz", "adler_range_hz", "within_adler", "captured", "mean_shift_hz", "locked_to_line")


def _csv_pll_vib(points) -> str:
    rows = [",".join(("separation_hz",) + _PLL_VIB_COLS)]
    for p in points:
        for x in (p.get("pll_vibration") or {}).get("lines", []):
            rows.append(",".join(_fmt(v) for v in [p["separation_hz"]] + [x[c] for c in _PLL_VIB_COLS]))
    return "\n".join(rows) + "\n"


_INTER_COLS = ("vibration_axis", "vibration_hz", "vibration_block_arcsec", "dither_axis", "dither_hz",
               "counter_rotation_arcsec", "gyro", "difference_hz", "difference_closed_form_arcsec",
               "vibration_block_simulated_arcsec", "difference_closed_form_simulated_block_arcsec",
               "eliminator_rocking_left_arcsec", "eliminator_line_arcsec",
               "difference_closed_form_navigated_arcsec") + tuple(
    f"difference_arcsec_{n}" for n in FILTERS) + tuple(f"difference_floor_arcsec_{n}" for n in FILTERS) + (
    "sum_hz", "sum_closed_form_arcsec")


def _csv_inter(points) -> str:
    rows = [",".join(("separation_hz",) + _INTER_COLS)]
    for p in points:
        for x in p["intermodulation"]:
            rows.append(",".join(_fmt(v) for v in [p["separation_hz"]] + [x.get(c) for c in _INTER_COLS]))
    return "\n".join(rows) + "\n"


def _report_pll_vibration(res) -> list:
    """The report's section on the live PLLs under the scenario's vibration (empty at rest)."""
    if not res["settings"]["scenario"]:
        return []
    rows = [(p["separation_hz"], x) for p in res["points"] for x in (p.get("pll_vibration") or {}).get("lines", [])]
    out = ["", "## The drives' PLLs under the vibration", ""]
    if not rows:
        return out + ["Not run: the scenario has no angular line entering at the chassis nor a translational "
                      "vibration entering there (a profile that enters at the block is the block's frame, not an "
                      "input through the isolators).", ""]
    out += ["Each PLL run again with the vibration entering at the chassis, the loop open and closed, each against "
            "the same run at rest (the difference is the vibration's part alone). A line at `f_v` reaches a drive's "
            "deflection as a forced response `d_v` beside its dither `a`; the detector reads it as a phase "
            "disturbance of `d_v / a` rad at the offset `|f_d - f_v|`, `e_o` through its own mean. The closed "
            "form of the FM is `|W| e_o / (2 pi)` with `W = C H / (1 + C H D tau / (1 + s tau))` (the loop's "
            "filter C, the held command H, the detector's mean D and the resonator's phase), at the offset. "
            "Adler's range `(f_d / 2 Q) (d_v / a)` is the lock range of an oscillator under that injection; "
            "'captured': `d_v / a >= 1`; 'locked to the line': the PLL's mean within a tenth of the offset from "
            "the line (measured).", "",
            "| separation (Hz) | drive | line (Hz) | offset (Hz) | d_v / a | FM (Hz) | closed form (Hz) | "
            "Adler range (Hz) | mean shift (Hz) | locked to the line |", "|---|---|---|---|---|---|---|---|---|---|"]
    for sep, x in rows:
        out.append(f"| {sep:g} | {x['axis']} {x['drive_hz']:.6g} Hz | {x['line_hz']:g} | {x['offset_hz']:.4g} | "
                   f"{x['line_to_dither']:.3g} | {x['fm_hz']:.3g} | {x['fm_closed_form_hz']:.3g} | "
                   f"{x['adler_range_hz']:.3g} | {x['mean_shift_hz']:.3g} | "
                   + ("yes" if x["locked_to_line"] else "no") + " |")
    return out


def _report(res) -> str:
    s = res["settings"]
    a, b = s["pair"]
    ans = res["answer"]
    under = (f"under the vibration of scenario `{s['scenario']}`" if s["scenario"] else "at rest")
    lines = ["# How far apart must the resonances be?", "",
             f"Axis {b}'s resonance is moved so that its drive runs each separation below axis {a}'s, on the block "
             f"of the IMU file (its drives at their coupled resonances), with axis {b}'s input axis tilted "
             f"{s['axis_offset_mrad']:g} mrad towards {a}. Each point: a mission of {s['duration_s']:g} s {under}, "
             f"navigation from {s['start_s']:g} s, seed {s['seed']} "
             f"({s['beat_periods_at_smallest']:.3g} beat periods at the smallest separation).", "",
             f"Error about {'xyz'[3 - 'xyz'.index(a) - 'xyz'.index(b)]} (the coning axis) per filter: its beat at the "
             f"separation (amplitude, arcsec; a Hann-weighted lock-in on {1e3 / s['series_rate_hz']:g} ms means, "
             f"the aliased dither lines fitted with it, measured from the record's resolution "
             f"{s['resolution_hz']:.3g} Hz up to {s['series_rate_hz'] / 4:g} Hz; after +-, the record's floor "
             "there: the RMS of the same lock-in at six frequencies beside it) and, in brackets, its RMS at the "
             "filter rate.", "",
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
            beat = ("below resolution" if h["beat_arcsec"] is None
                    else f"{h['beat_arcsec']:.3g} +- {_fmt(h['beat_floor_arcsec'], 2)}")
            cells.append(f"{beat} ({h['rms_arcsec']:.3g})")
        cells += [f"{p['coning_beat_closed_form_arcsec']:.3g}", f"{p['cross_axis_ratio']:.3g}",
                  "yes" if p["entrainment_risk"] else "no"]
        lines.append("| " + " | ".join(cells) + " |")
    pl = s["pll"]
    lines += ["", "## The drives' PLLs, live", "",
              f"Each drive on its own PLL ({pl['bandwidth_hz']:g} Hz natural frequency, damping {pl['damping']:g}, "
              f"{pl['update_hz']:g} Hz updates) on the coupled plant (three nonlinear suspensions on the block). "
              f"Frequencies are averaged over whole beat periods after the settling; the pull of {a}'s drive is "
              f"against the run with the resonances {pl['reference_separation_hz']:g} Hz apart. Closed form: the "
              "weak-coupling repulsion of two modes, `kappa^2 f^3 / (2 (f_a^2 - f_b^2))` with `kappa^2 = C_ab C_ba / "
              "((1 + C_aa)(1 + C_bb))` from the free block's coupling; 'linear modes': the same from the exact "
              "coupled modes of the linearised block.", "",
              f"| separation (Hz) | held by the PLLs (Hz) | pull of {a} (Hz) | linear modes (Hz) | closed form (Hz) "
              f"| FM of {a} at the beat (Hz) | FM of {b} at the beat (Hz) | entrained |", "|---|---|---|---|---|---|---|---|"]
    for p in res["points"]:
        q = p["pll"]
        fm = [("n/a" if v is None else f"{v:.3g}") for v in q["fm_at_beat_hz"].values()]
        lines.append(f"| {p['separation_hz']:g} | {q['separation_held_hz']:.6g} | {q['pull_hz']:.3g} | "
                     f"{q['pull_linear_modes_hz']:.3g} | {q['pull_closed_form_hz']:.3g} | {fm[0]} | {fm[1]} | "
                     + ("yes" if q["entrained"] else "no") + " |")
    lines += _report_pll_vibration(res)
    inter = [(p["separation_hz"], x) for p in res["points"] for x in p["intermodulation"]]
    if inter:
        lines += ["", "## Intermodulation of the vibration lines with the dithers", "",
                  "A vibration line turns the block by `b` at `f_v` about its axis; the block's counter-rotation `rho` "
                  "at a dither `f_d` about another axis cones with it. The body rate's `-(1/2) theta x theta'` puts "
                  "into the third gyro a line at `|f_d - f_v|` of angle amplitude `rho b (w_d + w_v) / (4 |w_d - w_v|)` "
                  "and one at `f_d + f_v` of `rho b |w_d - w_v| / (4 (w_d + w_v))`. A filter that notches the dither "
                  "(the eliminator) keeps the difference line in its attitude, as it keeps the dither coning's beat, "
                  "less the coning of its own increments: the rocking its stop band leaves at `f_d` (`R_n`, about 1 % "
                  "of it) with its output at `f_v` (`B_n`), which departs from the block's line by the vibration "
                  "axis's own gyro (its dither suspension, excited below its resonance, deflects by "
                  "`(f_v / f_0)^2 / (1 - (f_v / f_0)^2)` of the line) and by the eliminator's phase there. "
                  "'eliminator, navigated' is `(w_d + w_v) / (4 |w_d - w_v|) |R conj(B) - R_n conj(B_n)|` with the "
                  "four lines from the run; measured (the same lock-in) about the third gyro's axis.", "",
                  "`b` is the line's amplitude on the block from the scenario (at the block) or the chassis times "
                  "the block's transmissibility; 'simulated block' takes `b` from the run's block record instead "
                  "(near a gyro's resonance the engine's block departs from the profile that enters at it, by the "
                  "suspension's dynamic load).", "",
                  "| separation (Hz) | line | dither | gyro | f_d - f_v (Hz) | closed form (arcsec) | "
                  "with the simulated block (arcsec) | eliminator, navigated (arcsec) | " + " | ".join(FILTERS)
                  + " | f_d + f_v (Hz) | closed form (arcsec) |",
                  "|" + "---|" * (10 + len(FILTERS))]
        for sep, x in inter:
            meas = [("below resolution" if x.get(f"difference_arcsec_{n}") is None
                     else f"{x[f'difference_arcsec_{n}']:.3g} +- {_fmt(x[f'difference_floor_arcsec_{n}'], 2)}")
                    for n in FILTERS]
            lines.append(f"| {sep:g} | {x['vibration_axis']} {x['vibration_hz']:g} Hz, "
                         f"{x['vibration_block_arcsec']:.3g} arcsec on the block | {x['dither_axis']} "
                         f"{x['dither_hz']:.6g} Hz, {x['counter_rotation_arcsec']:.3g} arcsec | {x['gyro']} | "
                         f"{x['difference_hz']:.4g} | {x['difference_closed_form_arcsec']:.3g} | "
                         f"{_fmt(x['difference_closed_form_simulated_block_arcsec'], 3)} | "
                         f"{_fmt(x['difference_closed_form_navigated_arcsec'], 3)} (rocking left "
                         f"{_fmt(x['eliminator_rocking_left_arcsec'], 2)}, line {_fmt(x['eliminator_line_arcsec'], 3)})"
                         " | " + " | ".join(meas)
                         + f" | {x['sum_hz']:.5g} | {x['sum_closed_form_arcsec']:.3g} |")
    lines += ["", "## Answer", "",
              f"Smallest tested separation above which the beat in a filter's heading error stays within "
              f"{ans['budget_arcsec']:g} arcsec:", ""]
    lines += [f"- {n}: " + ("not even the largest tested" if v is None else f"{v:g} Hz")
              for n, v in ans["required_separation_hz"].items()]
    lock = ans["no_entrainment_risk_down_to_hz"]
    lines += ["", f"No entrainment risk (cross-axis line below {s['lock_ratio']:g} of the own dither) down to "
                  + ("no tested separation" if lock is None else f"{lock:g} Hz") + "; the live PLLs "
                  + ("held every tested separation." if not any(p["pll"]["entrained"] for p in res["points"])
                     else "locked together at " + ", ".join(f"{p['separation_hz']:g}" for p in res["points"]
                                                            if p["pll"]["entrained"]) + " Hz."), "",
              "The coning beat's closed form is `a_x a_y (w_x + w_y) / (4 |w_x - w_y|)` with each axis's rocking from "
              "the two-body counter-rotation and the measured dither amplitude; a filter that notches the dither "
              "lines (the eliminator) keeps the slow coning rate but not the rocking that cancels it, so its heading "
              "error follows the beat.", "", "Figure: `separation.png`.", ""]
    return "\n".join(lines)
