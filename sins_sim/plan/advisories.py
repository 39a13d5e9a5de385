"""Warnings an engineer needs: one line each, naming the axis, the frequency, the filter and the number.

Three families (issue 22, points 7 and 8):

* **Vibration against the filters and the dithers** (:func:`vibration_advisories`, before the engine
  runs): a sine line or a random-vibration band of the scenario's block motion that lies inside a
  filter's stop band on the axis it acts on (the filter removes real motion with the dither, and the
  navigation integrates what is left), or within :data:`N_BANDWIDTHS` resonance bandwidths ``f0 / Q``
  of that axis's dither (the suspension amplifies the block's motion there, and the drive's amplitude
  beats with it).
* **Drives off their operating point** (:func:`drive_advisories`, after the run): a measured dither
  amplitude off its target by more than :data:`AMPLITUDE_TOLERANCE` (plus the drive's own amplitude
  modulation), or a final drive voltage ``V_m`` away from the eq. 17 voltage of the unit's parameters
  by more than :data:`VOLTAGE_TOLERANCE`.
* **Vibration lines that take the dither from the amplitude loop** (:func:`dither_line_advisories`, before the
  engine runs): a line whose forced response at a suspension reaches that drive's synchronous detector, which the
  loop then holds in the dither's place (the drive reports its target while the dither at the drive frequency is
  smaller: the lock-in margin shrinks); :func:`dither_under_lines` gives the numbers for ``metrics.json``.
* **Trajectory files whose attitude does not fit their ground track** (:func:`trajectory_advisories`):
  the radians-for-degrees slip. A file that fits only when its angle columns are read as radians is
  refused (:class:`~sins_sim.config.schema.PlanError`); one whose yaw strays far from its track is
  warned about.

Each check is a small function returning the messages; :func:`sins_sim.config.scenario.load_scenario`
issues the configuration-time ones as :class:`UserWarning` and :func:`sins_sim.jobs.run.run_scenario`
stores every warning in ``metrics.json`` and the report.
"""

from __future__ import annotations

import math

import numpy as np

from sins_sim import earth
from sins_sim.plan.errors import PlanError
from sins_sim.units import ARCMIN, ARCSEC

__all__ = ["N_BANDWIDTHS", "AMPLITUDE_TOLERANCE", "VOLTAGE_TOLERANCE", "vibration_advisories", "drive_advisories",
           "trajectory_advisories", "motion_content", "online_on_block_advisories", "dither_under_lines",
           "dither_line_advisories", "block_entry_advisories", "BLOCK_ENTRY_TOLERANCE"]

AXES = ("x", "y", "z")

# --- vibration -------------------------------------------------------------------------------------------
#: "A few resonance bandwidths": a line within ``N_BANDWIDTHS * f0 / Q`` of a dither is warned about. The
#: dither mode (eq. 2 linearised at the dither amplitude, Q from eq. 16) answers a block motion at a
#: distance ``df`` from its resonance with ``|H| = r^2 / |1 - r^2 + j r / Q|`` (``r = f / f_dither``), about
#: ``f0 / (2 df) = Q / (2 N)`` at N bandwidths: at N = 10 the mode still amplifies the line ``Q / 20``
#: times (9x, 19 dB at the paper's Q = 187), the correcting filters must invert that gain through the f0
#: and Q they believe (a relative f0 error eps becomes an error of about ``eps Q / N`` of the line), and the
#: amplitude loop sees the dither beat at ``df``. Beyond it the magnification falls below ~10 and the
#: line is ordinary block motion.
N_BANDWIDTHS = 10.0


def _loglog(table, f):
    """The PSD table interpolated linearly in log(f)-log(psd) (the scenario schema's rule), 0 outside it."""
    fr, ps = table[:, 0], table[:, 1]
    out = np.exp(np.interp(np.log(f), np.log(fr), np.log(ps)))
    return np.where((f >= fr[0]) & (f <= fr[-1]), out, 0.0)


def _angle_rms_rad(table_rad, weight, f_lo, f_hi):
    """RMS angle (rad) of a rate PSD ``weight^2 S(f)`` ((rad/s)^2/Hz) between f_lo and f_hi: sqrt(int S/(2 pi f)^2)."""
    if not f_hi > f_lo:
        return 0.0
    f = np.geomspace(f_lo, f_hi, 2001)
    dens = weight ** 2 * _loglog(table_rad, f) / (2.0 * math.pi * f) ** 2
    from scipy.integrate import trapezoid  # (lazy: a scenario's errors come before scipy is imported)

    return float(math.sqrt(max(float(trapezoid(dens, f)), 0.0)))


def motion_content(motion_spec):
    """Per axis, the sine lines and random bands of the block's angular motion.

    Parameters
    ----------
    motion_spec : list of dict
        The validated ``motion`` list of a scenario (SI units, rad).

    Returns
    -------
    dict
        ``{"lines": [(axis, f_hz, amplitude_rad, label)], "bands": [(axis, f_lo, f_hi, table, weight, label)]}``;
        ``table`` is the rate PSD in (rad/s)^2/Hz (rows f_hz, psd). Sines and coning give lines (coning about z
        moves x and y); shocks ring and sweeps pass through every frequency by design, so they give neither.
    """
    lines, bands = [], []
    for i, seg in enumerate(motion_spec):
        kind = seg["type"]
        label = f"motion[{i}] {kind}"
        if kind == "sines":
            for ax, f, a in zip(AXES, seg["frequency_hz"], seg["amplitude_rad"]):
                if f > 0.0 and a > 0.0:
                    lines.append((ax, float(f), float(a), label))
        elif kind == "coning":
            for ax in ("x", "y"):
                lines.append((ax, float(seg["frequency_hz"]), float(seg["amplitude_rad"]), label))
        elif kind == "random_vibration":
            table = np.array([(f, p * (math.pi / 180.0) ** 2) for f, p in seg["psd_deg2_s2_per_hz"]])
            for ax, w in zip(AXES, seg["axes"]):
                if w > 0.0:
                    bands.append((ax, float(seg["f_lo_hz"]), float(seg["f_hi_hz"]), table, float(w), label))
    return {"lines": lines, "bands": bands}


def _run_channels(imu):
    """The channels with the drives the engine builds its filters on (a block moves them to its coupled resonances:
    :func:`sins_sim.simulation.unit.run_channels`)."""
    if getattr(imu, "block", None) is None:
        return list(imu.channels)
    from sins_sim.simulation.unit import run_channels

    return run_channels(imu)


def _stop_bands(imu, filters):
    """Per axis, ``(filter, lo_hz, hi_hz, what, gain_db(f))`` of every filter in ``filters`` that removes a band.

    The eliminator: its band handed to ``scipy.signal.ellip``, called its stop band in the messages (where its
    gain leaves the pass-band ripple; the part ``rs_db`` down lies inside it, and the whole band alters the
    motion's amplitude or phase). A plug-in whose design has an equaliser band edge (``correcting_wideband``,
    ``correcting_lownoise``): everything above its pass band, which it rolls off towards its stop band.
    """
    from sins_sim.filters import registry as filter_registry

    out = {ax: [] for ax in AXES}
    fs = imu.filter_rate_hz
    for ax, ch in zip(AXES, _run_channels(imu)):
        if "eliminator" in filters:
            d = ch.eliminator_design()

            def gain_db(f, d=d):
                return 20.0 * math.log10(max(abs(complex(d.frequency_response(f))), 1e-300))
            out[ax].append(("eliminator", d.band_hz[0], d.band_hz[1], "band", gain_db))
        for name in filters:
            if name not in filter_registry.plugin_names():  # built-in filters have no band edge of their own
                continue
            if filter_registry.is_three_axis(name):  # built for the unit, not per axis; no band edge of its own
                continue
            design = getattr(filter_registry.build(name, ch.filter_context(ax)), "design", None)
            if getattr(design, "kind", None) == "equalised" and hasattr(design, "pass_hz"):
                out[ax].append((name, float(design.pass_hz), 0.5 * fs,
                                f"flat to {design.pass_hz:.0f} Hz, rolled off from {design.stop_hz:.0f} Hz", None))
    return out


def vibration_advisories(imu, motion_spec, filters) -> list[str]:
    """Lines and bands of the block motion inside a filter's stop band or near a dither, one message each.

    Parameters
    ----------
    imu : ImuConfig
        The unit (each channel's dither frequency, Q at the dither amplitude, eliminator design, readout quantum).
    motion_spec : list of dict
        The scenario's validated ``motion`` list.
    filters : sequence of str
        The filters the scenario runs (a stop band matters only for a filter that runs).

    Returns
    -------
    list of str
        A line or band is reported only where its angle amplitude (a line's, or a band's RMS inside the
        stop band or the dither zone) is at least one readout quantum of that axis: below it the motion
        is under what the readout resolves.
    """
    content = motion_content(motion_spec)
    stops = _stop_bands(imu, tuple(filters))
    chan = dict(zip(AXES, _run_channels(imu)))
    out = []
    for ax, f, amp, label in content["lines"]:
        ch = chan[ax]
        if amp < ch.readout.quantum_rad:
            continue
        reasons = []
        for name, lo, hi, what, gain_db in stops[ax]:
            if lo <= f <= hi:
                if what == "band":
                    reasons.append(f"lies inside the {ax} {name}'s stop band ({lo:.0f}-{hi:.0f} Hz; gain "
                                   f"{gain_db(f):.0f} dB at {f:g} Hz): the {name} removes it with the dither")
                else:
                    reasons.append(f"lies above {name}'s pass band on {ax} ({what}): {name} attenuates it")
        near = _dither_zone(ch, ax, f)
        if near:
            reasons.append(near)
        if reasons:
            out.append(f"vibration line {f:g} Hz on {ax} ({label}, {amp / ARCMIN:.3g} arcmin) "
                       + "; and ".join(reasons) + "; expect a large navigation error from it")
    for ax, f_lo, f_hi, table, w, label in content["bands"]:
        ch = chan[ax]
        q = ch.readout.quantum_rad
        reasons = []
        for name, lo, hi, what, _ in stops[ax]:
            a, b = max(f_lo, lo), min(f_hi, hi)
            rms = _angle_rms_rad(table, w, a, b)
            if b > a and rms >= q:
                where = f"the {ax} {name}'s stop band ({lo:.0f}-{hi:.0f} Hz)" if what == "band" else \
                    f"the band above {name}'s pass band on {ax} ({what})"
                does = "removes it with the dither" if what == "band" else "attenuates it"
                reasons.append(f"puts {rms / ARCSEC:.3g} arcsec RMS into {where}, which {does}")
        fd, bw = _dither(ch)
        a, b = max(f_lo, fd - N_BANDWIDTHS * bw), min(f_hi, fd + N_BANDWIDTHS * bw)
        rms = _angle_rms_rad(table, w, a, b)
        if b > a and rms >= q:
            reasons.append(f"{rms / ARCSEC:.3g} arcsec RMS within {N_BANDWIDTHS:g} resonance bandwidths of the {ax} "
                           f"dither ({fd:.4g} Hz +- {N_BANDWIDTHS * bw:.3g} Hz, f0/Q = {bw:.3g} Hz), which the "
                           f"suspension amplifies up to Q = {fd / bw:.0f} times")
        if reasons:
            out.append(f"random vibration {f_lo:g}-{f_hi:g} Hz on {ax} ({label}) " + ", and ".join(reasons)
                       + f" (each at least one readout quantum, {q / ARCSEC:.3g} arcsec)")
    return out


def _dither(ch):
    """(dither frequency Hz, resonance bandwidth f0 / Q Hz) of a channel at its dither amplitude (eq. 16 Q)."""
    a = ch.drive.amplitude_rad
    q = ch.suspension.q_factor(a)
    return ch.drive_signal().frequency_hz, ch.suspension.f0_hz / q


def _dither_zone(ch, ax, f):
    """Why a line at ``f`` Hz near the dither of axis ``ax`` matters ("" when it is farther than N bandwidths)."""
    fd, bw = _dither(ch)
    df = abs(f - fd)
    if df > N_BANDWIDTHS * bw:
        return ""
    r = f / fd  # the mode as the drive sees it: resonant at the dither frequency, Q of eq. 16
    q = ch.suspension.f0_hz / bw
    mag = r * r / math.hypot(1.0 - r * r, r / q)
    return (f"lies {df:.3g} Hz (= {df / bw:.2g} resonance bandwidths f0/Q = {bw:.3g} Hz; warned within "
            f"{N_BANDWIDTHS:g}) from the {ax} dither at {fd:.4g} Hz: the suspension amplifies it {mag:.3g} "
            f"times and the drive's amplitude beats at {df:.3g} Hz")


def _lock_in_threshold(imu, ax):
    """The ``lock_in`` effect's threshold on axis ``ax`` (rad/s), or None."""
    for e in getattr(imu, "effects", ()) or ():
        if getattr(e, "name", "") == "lock_in" and (e.axes is None or ax in e.axes):
            return float(e.params["threshold_rad_s"])
    return None


def dither_under_lines(imu, motion_spec, motion_enters: str = "chassis") -> list[dict]:
    """What each sine line of the angular motion leaves of each dither under the closed amplitude loop.

    For a line at ``f`` (amplitude ``p`` about axis ``k``) and gyro ``i``:

    1. the block's rotation about ``u_i`` at ``f``, ``b``: ``p`` on a rigid block; entering at the block, ``p``
       plus the engine's departure from it (:func:`~sins_sim.models.block.block_entry_departure`); entering at the
       chassis, through the isolators (:func:`~sins_sim.models.block.block_rotation_from_chassis`);
    2. the suspension's forced deflection, ``d = |H| b`` with ``H = w^2 / (w_l^2 - w^2 + i w w_l / Q)``: the dither
       mode base-excited by the block (Rao, *Mechanical Vibrations*, sec. 3.6), ``w_l`` its resonance for a line
       superposed on the dither (:meth:`~sins_sim.models.suspension.SuspensionParams.line_resonance_hz`), ``Q`` of
       eq. 16;
    3. what the detector reads of it, ``c = d L`` (:func:`~sins_sim.models.drive.detector_leakage`: a Hann window of
       the control block, main lobe ``+- 2 f_d / block_cycles``);
    4. the dither the loop leaves at the drive frequency, ``a`` with ``M(a, c) = a_t``
       (:func:`~sins_sim.models.drive.held_dither_amplitude`), its peak rate ``a w_d`` (what sweeps the lock-in band)
       against the ``lock_in`` effect's threshold where the unit has one, and the control block that puts the line
       at the window's first null (``block_cycles >= 2 f_d / |f - f_d|``).

    One dict per line and gyro whose ``c`` is at least one readout quantum; none in open loop (the drive then
    does not read its deflection).
    """
    if getattr(imu.drive_control, "mode", "closed_loop") != "closed_loop":
        return []
    from sins_sim.models.drive import detector_leakage, held_dither_amplitude

    block = getattr(imu, "block", None)
    chans = _run_channels(imu)
    amp = [c.drive.amplitude_rad for c in imu.channels]
    sus = [c.suspension for c in imu.channels]
    w_line = np.array([2.0 * math.pi * s.line_resonance_hz(a) for s, a in zip(sus, amp)])
    q = np.array([s.q_factor(a) for s, a in zip(sus, amp)])
    axes = np.eye(3) if block is None else block.input_axes
    cycles = int(imu.drive_control.block_cycles)
    out = []
    for ax, f, p, label in motion_content(motion_spec)["lines"]:
        k = AXES.index(ax)
        if block is None:
            rot = np.eye(3)[k] * p
        elif motion_enters == "block":
            from sins_sim.models.block import block_entry_departure
            rot = (np.eye(3)[k] + block_entry_departure(block, w_line, q, k, f)) * p
        else:
            from sins_sim.models.block import block_rotation_from_chassis
            rot = block_rotation_from_chassis(block, w_line, q, k, f) * p
        w = 2.0 * math.pi * f
        for i, ch in enumerate(chans):
            b = abs(complex(axes[i] @ rot))
            h = w * w / abs(complex(w_line[i] ** 2 - w * w, w * w_line[i] / q[i]))
            fd = ch.drive_signal().frequency_hz
            rate = ch.plant.rate_hz
            steps = max(1, int(round(cycles * rate / fd)))
            leak = b * h * detector_leakage(steps, rate, f - fd)
            if leak < ch.readout.quantum_rad:
                continue
            held = held_dither_amplitude(amp[i], leak)
            thr = _lock_in_threshold(imu, AXES[i])
            out.append({"axis": AXES[i], "line_axis": ax, "line": label, "line_hz": float(f), "drive_hz": float(fd),
                        "block_rotation_arcsec": b / ARCSEC, "transmissibility": h,
                        "deflection_line_arcsec": b * h / ARCSEC, "detector_reads_arcsec": leak / ARCSEC,
                        "dither_target_arcsec": amp[i] / ARCSEC, "dither_held_arcsec": held / ARCSEC,
                        "dither_peak_rate_deg_s": math.degrees(held * 2.0 * math.pi * fd),
                        "lock_in_threshold_deg_s": None if thr is None else math.degrees(thr),
                        "block_cycles_for_null": int(math.ceil(2.0 * fd / abs(f - fd))) if f != fd else None})
    return out


def dither_line_advisories(forecast) -> list[str]:
    """One line per entry of :func:`dither_under_lines` whose held dither is short of its target by more than
    :data:`AMPLITUDE_TOLERANCE`: the axis, the line, what the detector reads of it, the dither left at the drive
    frequency against its target and its peak rate against the lock-in threshold."""
    out = []
    for d in forecast:
        if d["dither_held_arcsec"] >= (1.0 - AMPLITUDE_TOLERANCE) * d["dither_target_arcsec"]:
            continue
        thr = d["lock_in_threshold_deg_s"]
        vs = (f"the lock-in threshold {thr:.3g} deg/s" if thr is not None else "no lock_in effect on the unit to "
              "compare with")
        null = d["block_cycles_for_null"]
        out.append(f"drive {d['axis']}: the vibration line {d['line_hz']:g} Hz on {d['line_axis']} ({d['line']}) "
                   f"forces {d['axis']}'s suspension to {d['deflection_line_arcsec']:.3g} arcsec "
                   f"({d['transmissibility']:.3g} times the block's {d['block_rotation_arcsec']:.3g} arcsec), "
                   f"{abs(d['line_hz'] - d['drive_hz']):.3g} Hz from its drive at {d['drive_hz']:.5g} Hz; the "
                   f"amplitude loop's detector reads {d['detector_reads_arcsec']:.3g} arcsec of it and holds the "
                   f"total, leaving a dither of {d['dither_held_arcsec']:.3g} arcsec at the drive frequency against "
                   f"its {d['dither_target_arcsec']:.3g} arcsec target (the drive reports the target): peak dither "
                   f"rate {d['dither_peak_rate_deg_s']:.3g} deg/s against {vs}"
                   + (f"; drive_control.block_cycles >= {null} puts the line at the detector's first null" if null
                      else ""))
    return out


#: A profile entering at the block is warned about where the engine's block departs from it by more than this
#: (relative): far from the gyros' resonances the departure is ``(J_g / J_b) (w / w0)^2 w^2 / (w_r^2 - w^2)``, 1e-5
#: to 1e-4 of the profile for vehicle motion; 1 % is where it enters the navigation's scale-factor budget.
BLOCK_ENTRY_TOLERANCE = 0.01


def block_entry_advisories(imu, motion_spec, motion_enters: str) -> list[str]:
    """Sine lines of a profile entering at the block where the engine's block departs from the profile by more than
    :data:`BLOCK_ENTRY_TOLERANCE` (:func:`~sins_sim.models.block.block_entry_departure`: the dither mode's reaction,
    amplified near a gyro's resonance by its transmissibility). One line each; none without a block or with the
    motion entering at the chassis."""
    block = getattr(imu, "block", None)
    if block is None or motion_enters != "block":
        return []
    from sins_sim.models.block import block_entry_departure

    amp = [c.drive.amplitude_rad for c in imu.channels]
    sus = [c.suspension for c in imu.channels]
    w_line = np.array([2.0 * math.pi * s.line_resonance_hz(a) for s, a in zip(sus, amp)])
    q = np.array([s.q_factor(a) for s, a in zip(sus, amp)])
    out = []
    for ax, f, p, label in motion_content(motion_spec)["lines"]:
        k = AXES.index(ax)
        dep = abs(complex(block_entry_departure(block, w_line, q, k, f)[k]))
        if dep > BLOCK_ENTRY_TOLERANCE:
            near = int(np.argmax(np.abs(block.input_axes[:, k])))  # the gyro whose input axis the line turns
            out.append(f"motion line {f:g} Hz on {ax} ({label}) enters at the block within reach of the {AXES[near]} "
                       f"gyro's resonance ({w_line[near] / (2.0 * math.pi):.4g} Hz): the block departs from the "
                       f"profile by {100.0 * dep:.3g} % of it (the dither modes' reaction, amplified by their "
                       f"transmissibility; a measured block profile already holds it, so the run counts it twice; "
                       f"warned above {100.0 * BLOCK_ENTRY_TOLERANCE:g} %)")
    return out


# --- drives ----------------------------------------------------------------------------------------------
#: Amplitude tolerance (relative). Once settled, the closed loop holds the block-measured amplitude on its
#: target to about 1e-6 on the bundled unit (scenarios/stationary.yaml, 3 s: |measured / target - 1| =
#: 3e-7, 8e-7, 3e-7 on x, y, z), and the measurement itself resolves a readout quantum in ~3 arcmin (0.15 /
#: 180 = 0.08 %). 1 % is far above what the loop achieves undisturbed and a third of the 3 % (3.1 against
#: 3.0 arcmin) an engineer must hear about; the drive's own random amplitude modulation
#: (``drive.modulation_depth``) is added on top, since the loop then follows a target that moves on purpose.
AMPLITUDE_TOLERANCE = 0.01
#: Voltage tolerance (relative): V_m at the end of the run against eq. 17 (``V_m = -a_m / (Q k5)``, Q from
#: eq. 16 at the target amplitude) for the unit's parameters (at the run's final temperature when a
#: temperature profile is set). Eq. 17 holds at the harmonic-balance resonance the drive sits on; undisturbed,
#: the bundled unit's loop ends 0.04 % from it (scenarios/stationary.yaml: 0.38962 V against 0.38979 V). 3 %
#: is well above that and above the 1 % amplitude tolerance, and half the 6 % an engineer must be told of.
VOLTAGE_TOLERANCE = 0.03


#: The drives are judged only after this many amplitude-loop periods: the loop pulls the dither in from its start
#: within about ten (default unit at rest, loop 0.1 s: +12.5 % off target after 3 periods, +3 % after 6, within
#: 1 % after 10), and a shorter run's drive is still on its way, not off its target.
DRIVE_SETTLE_LOOPS = 10


def _block_voltage_factor(imu) -> list:
    """Eq. 17's voltage scales by this on a block on isolators (``sins_sim.models.block.dither_voltage_factor``:
    the isolators' damping loads the dither); 1 on a rigid block."""
    block = getattr(imu, "block", None)
    if block is None:
        return [1.0, 1.0, 1.0]
    from sins_sim.models.block import dither_voltage_factor

    try:
        om = [2.0 * math.pi * c.drive_signal().frequency_hz for c in imu.channels]
        q = [c.suspension.q_factor(c.drive.amplitude_rad) for c in imu.channels]
        return list(dither_voltage_factor(block, om, q))
    except ValueError:
        return [1.0, 1.0, 1.0]


def online_on_block_advisories(imu) -> list[str]:
    """An online estimator on a block on isolators learns the drive-to-readout response of each gyro as the block
    presents it: the readout's dither line holds the block's counter-rotation ``u_i . theta``
    (:func:`~sins_sim.models.block.block_rotation_per_deflection`: about ``-J_g / J_b`` of the deflection, in
    phase) and the drive sits on the coupled mode, ``sqrt(1 + J_g / J_b)`` above the suspension's own. The
    estimate then describes the coupled system, and the eq. 5 filters it feeds take the counter-rotation, a real
    rotation of the block, out with the dither, as the eliminator does (docs/user-guide/combinations.md). One line
    with each axis's counter-rotation at its drive; none without a block or an online estimator."""
    block = getattr(imu, "block", None)
    if block is None or not any(getattr(c, "online", None) is not None for c in imu.channels):
        return []
    from sins_sim.models.block import block_rotation_per_deflection, coupled_dither_frequencies

    om = [2.0 * math.pi * c.drive_signal().frequency_hz for c in imu.channels]
    f = coupled_dither_frequencies(block, om)
    rot = [abs(block.input_axes[i] @ block_rotation_per_deflection(block, i, f[i])) * c.drive.amplitude_rad
           for i, c in enumerate(imu.channels)]
    shift = [100.0 * (fi / (w / (2.0 * math.pi)) - 1.0) for fi, w in zip(f, om)]
    return [("filter_parameters.source: online with imu.block: each estimator learns the gyro as the block presents "
             "it, its readout carrying the block's counter-rotation ("
             + ", ".join(f"{a} {r / ARCSEC:.3g} arcsec" for a, r in zip(AXES, rot))
             + ") and its drive on the coupled mode (+" + ", +".join(f"{s:.2g}" for s in shift)
             + " %); the filters it feeds then remove that real rotation with the dither, as the eliminator does "
               "(docs/user-guide/combinations.md)")]


def drive_advisories(drives, imu, duration_s: float) -> list[str]:
    """Drives off their amplitude target, or with V_m away from eq. 17, one message each (none for a run
    shorter than :data:`DRIVE_SETTLE_LOOPS` amplitude-loop periods; the voltage is not judged on a drive whose
    amplitude is modulated, ``drive.modulation_depth > 0``, whose loop never settles on one target).

    Parameters
    ----------
    drives : list of dict
        ``SinsResult.drives``: per axis ``amplitude_measured_rad``, ``amplitude_target_rad``, ``v_m_final``.
    imu : ImuConfig
        The unit (its suspensions, drive control and temperature model).
    duration_s : float
        When the run ended (for the temperature at the end).
    """
    out = []
    loop_s = getattr(imu.drive_control, "loop_time_s", 0.1)
    if duration_s < DRIVE_SETTLE_LOOPS * loop_s:  # the loop is still pulling the dither in: nothing to judge
        return out
    depth = getattr(imu.drive_control, "modulation_depth", 0.0)
    closed = getattr(imu.drive_control, "mode", "closed_loop") == "closed_loop"
    factor = _block_voltage_factor(imu)
    for i, (d, ch) in enumerate(zip(drives, imu.channels)):
        ax = d["axis"]
        target, meas = d["amplitude_target_rad"], d["amplitude_measured_rad"]
        tol = AMPLITUDE_TOLERANCE + depth
        if target > 0.0 and math.isfinite(meas) and abs(meas / target - 1.0) > tol:
            out.append(f"drive {ax}: dither amplitude {meas / ARCMIN:.4g} arcmin against its target "
                       f"{target / ARCMIN:.4g} arcmin ({100.0 * (meas / target - 1.0):+.1f} %, tolerance "
                       f"{100.0 * tol:.3g} %): the amplitude loop does not hold the dither (block motion near the "
                       f"resonance, or a disturbance faster than the loop)"
                       + ("" if closed else " (drive control is open loop)"))
        sus = ch.suspension
        temp = getattr(ch, "temperature", None)
        if temp is not None:
            sus = temp.suspension_at(sus, temp.profile.at(duration_s))
        try:
            expected = sus.drive_voltage(target) * factor[i]
        except ValueError:
            continue
        vm = d["v_m_final"]
        # With amplitude modulation the target jumps at every control block (a few dither periods) by up to
        # +-depth, faster than the amplitude loop settles (loop_time_s): V_m at the end is the loop's state on its
        # way to a moving target, not the equilibrium eq. 17 describes (the bundled 5 % modulated units end 6-12 %
        # off it with nothing wrong), so the voltage is not judged then.
        if closed and depth == 0.0 and expected != 0.0 and math.isfinite(vm) and abs(vm / expected - 1.0) > VOLTAGE_TOLERANCE:
            out.append(f"drive {ax}: V_m = {vm:.4g} V is {100.0 * (vm / expected - 1.0):+.1f} % off the eq. 17 "
                       f"voltage{' on the isolated block' if factor[i] != 1.0 else ''} {expected:.4g} V of the unit's parameters at {target / ARCMIN:.3g} arcmin (tolerance "
                       f"{100.0 * VOLTAGE_TOLERANCE:g} %): the suspension's loss or tuning is not what the unit's "
                       f"parameters say (block motion near the resonance, or moving the turning points of the "
                       f"hysteretic loss; extra damping; a drive off the resonance)")
    return out


# --- trajectory files ------------------------------------------------------------------------------------
#: Track over windows of this length (s): long enough that position rounding does not steer the heading.
TRACK_WINDOW_S = 1.0
#: A window counts as moving when the vehicle travels at least this far in it (m).
MIN_TRAVEL_M = 0.5
#: Moving time (s) needed before the yaw and the track are compared.
MIN_MOVING_S = 10.0
#: Largest median |track - yaw| (deg) accepted without a warning: crab angles of aircraft in strong cross
#: winds reach 20-30 deg; more is a sideways-flying helicopter or, far more often, a wrong unit or convention.
MAX_CRAB_DEG = 30.0
#: With the angles read as radians, the track must follow the yaw within this (deg) for a refusal: exact
#: files match within a few tenths; the latitude's cos() changes when lat/lon are rescaled, which bends a
#: track by at most a few degrees at mid latitudes.
RADIANS_FIT_DEG = 10.0
#: Turns whose coordinated bank atan(v yaw_rate / g) exceeds this (deg) are used for the roll check.
MIN_BANK_DEG = 10.0


def _local_track(t, lat, lon, h):
    """North, east (m) of the positions, accumulated step by step (lat, lon in rad)."""
    r_n, r_e = earth.radii(lat[:-1])
    dn = np.diff(lat) * (r_n + h[:-1])
    de = (np.diff(lon) + math.pi) % (2.0 * math.pi) - math.pi
    de = de * np.cos(lat[:-1]) * (r_e + h[:-1])
    return np.r_[0.0, np.cumsum(dn)], np.r_[0.0, np.cumsum(de)]


def _wrap_deg(x):
    return (x + 180.0) % 360.0 - 180.0


def _track_vs_yaw(t, lat, lon, h, yaw):
    """(median |track - yaw| deg, moving seconds, speed m/s, track rate rad/s, mid times) over moving windows."""
    n_, e_ = _local_track(t, lat, lon, h)
    j = np.searchsorted(t, t + TRACK_WINDOW_S)
    ok = j < t.size
    i = np.flatnonzero(ok)
    j = j[ok]
    dn, de = n_[j] - n_[i], e_[j] - e_[i]
    dist = np.hypot(dn, de)
    moving = dist >= MIN_TRAVEL_M
    i, j, dn, de, dist = i[moving], j[moving], dn[moving], de[moving], dist[moving]
    if i.size == 0:
        return None
    dt = t[j] - t[i]
    tm = 0.5 * (t[i] + t[j])
    moving_s = float(np.sum(np.diff(t)[i])) if i.size else 0.0
    track = np.arctan2(de, dn)
    yaw_mid = np.interp(tm, t, np.unwrap(yaw))
    diff = np.degrees(np.angle(np.exp(1j * (track - yaw_mid))))
    return {"median_deg": float(np.median(np.abs(diff))), "moving_s": moving_s, "speed": dist / dt,
            "track": np.unwrap(track), "t_mid": tm, "v_ne": np.stack((dn / dt, de / dt), axis=1)}


def _roll_fit(cmp, t, lat, h, roll):
    """Roll against the coordinated-turn bank ``atan(v psi_dot / g)`` (a level coordinated turn: lift balances
    gravity and the centripetal force) over the turns: (relative misfit as written, misfit read as radians,
    median |roll| deg, median |bank| deg), or None without :data:`MIN_MOVING_S` / 2 of turning."""
    tm, trk, v = cmp["t_mid"], cmp["track"], cmp["speed"]
    if tm.size < 3:
        return None
    rate = np.gradient(trk, tm)
    g = float(earth.gravity_down(float(np.mean(lat)), float(np.mean(h))))  # Somigliana normal gravity
    bank = np.arctan(v * rate / g)
    turning = np.abs(bank) >= math.radians(MIN_BANK_DEG)
    if turning.sum() * float(np.median(np.diff(t))) < MIN_MOVING_S / 2.0:
        return None
    r = np.interp(tm[turning], t, roll)
    b = bank[turning]
    scale = 180.0 / math.pi
    size = float(np.median(np.abs(b)))
    return (float(np.median(np.abs(r - b))) / size, float(np.median(np.abs(r * scale - b))) / size,
            math.degrees(float(np.median(np.abs(r)))), math.degrees(size))


def trajectory_advisories(data, name: str) -> list[str]:
    """Check a trajectory file's attitude against its ground track; refuse the radians-for-degrees slip.

    Parameters
    ----------
    data : TrajectoryData
        The file as read (angles in rad, converted from the file's degree columns).
    name : str
        How the file is named in messages (the scenario's ``trajectory.file``).

    Returns
    -------
    list of str
        Warnings (the yaw strays from the ground track; the positions disagree with the velocity columns).

    Raises
    ------
    PlanError
        When the file fits only with angle columns read as radians: the yaw column follows the ground track
        within :data:`RADIANS_FIT_DEG` once multiplied by 180/pi but not as written (lat_deg, lon_deg named too
        when rescaling them makes the fit better, roll_deg when it then is the coordinated bank in radians);
        the roll column alone is the coordinated-turn bank in radians; or the positions move at pi/180 of the
        velocity columns.
    """
    t = np.asarray(data.t_s)
    lat, lon, h = np.asarray(data.lat_rad), np.asarray(data.lon_rad), np.asarray(data.h_m)
    roll, yaw = np.asarray(data.roll_rad), np.asarray(data.yaw_rad)
    # what the file holds (deg): a column can be in radians only if every value lies within one turn in rad
    bound = {"lat_deg": math.pi / 2.0, "lon_deg": 2.0 * math.pi, "roll_deg": 2.0 * math.pi, "yaw_deg": 2.0 * math.pi}
    radians_ok = {c for c, f in (("lat_deg", lat), ("lon_deg", lon), ("roll_deg", roll), ("yaw_deg", yaw))
                  if np.all(np.abs(np.degrees(f)) <= bound[c])}
    scale = 180.0 / math.pi
    head = f"trajectory.file ({name}): "
    out = []
    cmp = _track_vs_yaw(t, lat, lon, h, yaw)
    moving = cmp is not None and cmp["moving_s"] >= MIN_MOVING_S
    if moving and cmp["median_deg"] > MAX_CRAB_DEG:
        fit, cols, pos = None, [], 1.0
        if "yaw_deg" in radians_ok:
            fit, cols = _track_vs_yaw(t, lat, lon, h, yaw * scale), ["yaw_deg"]
            if {"lat_deg", "lon_deg"} <= radians_ok:
                both = _track_vs_yaw(t, lat * scale, lon * scale, h, yaw * scale)
                if both is not None and (fit is None or both["median_deg"] < fit["median_deg"] - 0.5):
                    fit, cols, pos = both, ["lat_deg", "lon_deg", "yaw_deg"], scale
        if fit is not None and fit["moving_s"] >= MIN_MOVING_S and fit["median_deg"] <= RADIANS_FIT_DEG:
            if "roll_deg" in radians_ok:
                rf = _roll_fit(fit, t, lat * pos, h, roll)
                if rf is not None and rf[1] <= 0.25:
                    cols.insert(-1, "roll_deg")
            raise PlanError(f"{head}columns {', '.join(cols)} look like radians, not degrees: the ground track "
                              f"from lat_deg/lon_deg differs from yaw_deg by {cmp['median_deg']:.3g} deg (median "
                              f"over {cmp['moving_s']:.4g} s moving) but by {fit['median_deg']:.2g} deg with "
                              f"{', '.join(cols)} read as radians; write every angle column in degrees (multiply "
                              f"radians by 180/pi)")
        out.append(f"{head}yaw_deg differs from the ground track (from lat_deg/lon_deg) by {cmp['median_deg']:.3g} "
                   f"deg (median over {cmp['moving_s']:.4g} s moving), more than the {MAX_CRAB_DEG:g} deg of a crab "
                   f"in a strong cross wind: check the yaw column's unit and convention (deg, from north towards "
                   f"east, body x forward)")
    elif moving and "roll_deg" in radians_ok:
        rf = _roll_fit(cmp, t, lat, h, roll)
        if rf is not None and rf[1] <= 0.25 and rf[0] > 0.5:
            raise PlanError(f"{head}columns roll_deg look like radians, not degrees: in the turns roll_deg is "
                              f"{rf[2]:.3g} deg where the coordinated bank atan(v yaw_rate / g) is {rf[3]:.3g} deg, "
                              f"and it matches that within {100 * rf[1]:.2g} % read as radians; write degrees "
                              f"(multiply by 180/pi)")
    if data.v_ned_m_s is not None and moving and {"lat_deg", "lon_deg"} <= radians_ok:
        def misfit(c):  # median |position rate - velocity columns| / median |velocity columns|, horizontal
            v_col = np.stack([np.interp(c["t_mid"], t, data.v_ned_m_s[:, k]) for k in (0, 1)], axis=1)
            size = float(np.median(np.hypot(v_col[:, 0], v_col[:, 1])))
            return float(np.median(np.hypot(*(c["v_ne"] - v_col).T))) / size if size >= 1.0 else 0.0

        as_rad = _track_vs_yaw(t, lat * scale, lon * scale, h, yaw)
        if misfit(cmp) > 0.5 and as_rad is not None and misfit(as_rad) <= 0.1:
            raise PlanError(f"{head}columns lat_deg, lon_deg look like radians, not degrees: the positions move "
                              f"at {np.median(cmp['speed']):.3g} m/s where the velocity columns (vn_m_s, ve_m_s) "
                              f"say {np.median(as_rad['speed']):.4g} m/s, and match them within "
                              f"{100 * misfit(as_rad):.2g} % read as radians; write degrees (multiply by 180/pi)")
    return out
