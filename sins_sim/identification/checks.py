"""Checks of a recording before it is judged (step 0 of the diagnosis).

A refit absorbs a lot: its noise floor estimate swallows random counts, shuffled rows or a spike,
and a delay of half a dither period is a sign flip in disguise. So the data are checked first,
per axis, on the readout angle minus the table angle; each failed check is a **finding** that names
the check, the axis and the time (rounded to the sample period), and the diagnosis gives no verdict
on data with a finding.

==================== ===================================================================================
check                rule (and why the threshold holds)
==================== ===================================================================================
``dead``             the counts never change, or their RMS swing is below :data:`DEAD_RATIO` of the one
                     the nominal model predicts for the recorded drive (a unit's parameters differ by per
                     cent, far from a factor of 20)
``saturated``        at least :data:`SATURATION_MIN` samples (and 0.5 % of them) sit in flat tops at the
                     channel's extreme value: runs of :data:`FLAT_RUN` or more equal samples. A dithered
                     angle passes its extremes in single samples (at 386 Hz and 7.2 kHz, 3 arcmin, the
                     sine moves by about 67 counts between the samples around its peak; a steady dither
                     may hit the same extreme value again every few cycles, but never twice in a row),
                     so flat tops are a clipped counter or converter
``jump``             a step between two samples larger than a gyro can turn in one sample period:
                     :data:`MAX_RATE_RAD_S` (1000 deg/s, the limit of an RLG's measuring range, as the
                     experiment format's) plus the dither's peak rate, times two for margin
``not continuous``   in a window of :data:`WINDOW_S`, the RMS of the second difference of the counts exceeds
                     that of the first: a band-limited angle dominated by content below ``fs / 6`` has a
                     ratio ``2 sin(pi f / fs) < 1`` (0.34 for the dither at 386 Hz, 7.2 kHz); white
                     counts (random or shuffled rows) give ``sqrt(3) = 1.73``; and the window is white
                     (autocorrelations at lags 1-3 below :data:`WHITE_RHO`): a structural mode above
                     ``fs / 6`` has the same ratio but is no white sequence
``sign``             the correlation of the measured angle with the nominal model's prediction for the
                     recorded drive is below :data:`SIGN_CORRELATION`: the dither runs in antiphase with the
                     header's convention (counts negated, the drive's sign flipped, or k5 of the wrong sign).
                     A unit whose resonance is off by its half width still correlates at cos 45 deg = 0.7
``noise``            the white floor of the angle (median Welch PSD over ``[0.55, 0.95] fs/2`` free of
                     lines and peaks, :func:`~sins_sim.identification.localise.noise_floor`) exceeds
                     :data:`NOISE_RATIO` times the quantisation ``q / sqrt(12)``, and is white: its level in
                     the band's bins spread no more than white noise's do (:data:`FLAT_MARGIN`). Readout noise of a
                     working counter is of the order of the quantum (the blind evaluation draws up to 2.3
                     times it); a resonance (a mount mode at 1.6 kHz, a rocking mode at 2.2 kHz) raises the
                     band unevenly and is left for the diagnosis to localise (issue 24)
==================== ===================================================================================

.. autosummary::

   check_recording
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from sins_sim.identification.localise import noise_floor
from sins_sim.io.recording import Recording, RecordingError
from sins_sim.simulation.experiment import FIT_SETTINGS, ExperimentInputs, simulate_axis, suspension_from_nominal
from sins_sim.units import ARCMIN, ARCSEC

__all__ = ["check_recording", "require_inputs", "format_findings", "MOVING_EXPERIMENTS", "MIN_BLOCKS", "DEAD_RATIO", "SATURATION_MIN", "MAX_RATE_RAD_S", "WINDOW_S",
           "SIGN_CORRELATION", "NOISE_RATIO", "FLAT_MARGIN"]

DEAD_RATIO = 0.05
SATURATION_MIN = 8
FLAT_RUN = 3
MAX_RATE_RAD_S = math.radians(1000.0)
WINDOW_S = 0.05
SIGN_CORRELATION = -0.3
NOISE_RATIO = 20.0
#: Largest autocorrelation (lags 1-3) of a window of white counts: over a 50 ms window (>= 360 samples at
#: 7.2 kHz) the sample autocorrelation of white noise scatters by 1 / sqrt(360) = 0.053, so 0.3 is 5.7 sigma.
WHITE_RHO = 0.3
#: A floor is white when the ratio of the 90 % and 10 % quantiles of its Welch bins over the noise band is at
#: most this margin times that of the chi-square law a white floor's bins follow (2.3 for the 19 degrees of
#: freedom of a 0.2 s recording, 1.7 at 1 s; the margin covers the scatter of quantiles over 36-60 bins: white
#: noise of 20 counts gave 1.9 and 1.6). A resonance fills the band unevenly: a clean 4 arcsec mode at
#: 1.6 kHz gives 4.3 at 0.5 s, one at 2.2 kHz 76.
FLAT_MARGIN = 1.3


#: Experiments whose block moves, so that the table angle (``sins_angle``) is part of what they need.
MOVING_EXPERIMENTS = ("rate_table",)
#: Fewest blocks of the held-out split a recording must hold: 4 fitted and 4 held out, so that the held-out
#: test's Student-t reference has 3 degrees of freedom (the fewest for which it has a finite variance).
MIN_BLOCKS = 8
#: The shortest block of the held-out split (``recording_inputs._masks``), s.
MIN_BLOCK_S = 0.025


def require_inputs(rec: Recording, block_s: float | None = None) -> None:
    """Refuse a recording that lacks what its experiment needs before anything is fitted.

    * a recording of a moving experiment (:data:`MOVING_EXPERIMENTS`) without ``sins_angle``: the format
      reads a missing table angle as a block at rest, so the table motion would be left in the residual and
      fitted as an effect (a rate-table recording without it got ``axis_coupling`` with every coefficient at
      its bound);
    * fewer samples than :data:`MIN_BLOCKS` blocks of the held-out split (``block_s``, default
      :data:`MIN_BLOCK_S`) hold: without them the significance test has nothing to stand on, and a
      20-sample recording got ``none``.

    Raises
    ------
    RecordingError
        Naming the recording, the key (``sins_angle``, ``counts``) and the rule.
    """
    if rec.sins_angle is None and any(e in rec.experiment for e in MOVING_EXPERIMENTS):
        raise RecordingError(f"{rec.source}: sins_angle: is required for a {rec.experiment!r} recording (the table "
                             "angle the experiment moved the block by; without it the diagnosis would read the table "
                             "motion as an effect)")
    block = block_s or MIN_BLOCK_S
    need = int(math.ceil(MIN_BLOCKS * block * rec.fs_hz)) + 1
    if rec.n_samples < need:
        raise RecordingError(f"{rec.source}: counts: must hold at least {need} samples ({MIN_BLOCKS} blocks of "
                             f"{block * 1e3:g} ms at {rec.fs_hz:g} Hz: {MIN_BLOCKS // 2} fitted and {MIN_BLOCKS // 2} "
                             f"held out, the fewest the held-out significance test stands on), got {rec.n_samples}")


def _t(i: int, fs: float) -> float:
    """A sample's time, rounded to what the sample period resolves."""
    digits = max(0, int(math.ceil(math.log10(fs))))
    return round(i / fs, digits)


def _white(x: np.ndarray) -> bool:
    """Whether a window looks white: its autocorrelations at lags 1-3 all below :data:`WHITE_RHO`.

    Random counts or shuffled rows are white. A band-limited angle above ``fs / 6`` (a structural mode at
    2.2 kHz, 7.2 kHz) also has second differences larger than first ones, but it is no white sequence: a
    narrow-band process at ``f`` has ``rho_k = cos(2 pi k f / fs)``, and no ``f`` makes the three lags'
    cosines all small (``theta``, ``2 theta`` and ``3 theta`` cannot all sit near ``pi / 2`` modulo ``pi``).
    """
    x = np.asarray(x, dtype=np.float64) - np.mean(x)
    den = float(np.dot(x, x))
    if den <= 0.0:
        return False
    return all(abs(float(np.dot(x[:-k], x[k:])) / den) < WHITE_RHO for k in (1, 2, 3))


def _finding(check: str, axis: str, t_s, message: str) -> dict:
    return {"check": check, "axis": axis, "time_s": t_s, "message": f"axis {axis}: {message}"}


def check_recording(rec: Recording, table: dict | None = None) -> list:
    """The findings on a recording (empty: fit to judge).

    Parameters
    ----------
    rec : Recording
    table : dict axis -> ndarray, optional
        The table angle at the readout instants (default: from the recording).

    Returns
    -------
    list of dict
        ``check``, ``axis``, ``time_s`` (a time or ``[t0, t1]``, rounded to the sample period),
        ``message`` (one line naming the axis).
    """
    fs = rec.fs_hz
    q = rec.quantum_rad
    n = rec.n_samples
    if table is None:
        from sins_sim.identification.recording_inputs import _table_angles

        table = _table_angles(rec)
    inputs = ExperimentInputs.from_recording(rec)
    out = []
    for i, a in enumerate(rec.axes):
        c = np.asarray(rec.counts[:, i], dtype=np.int64)
        y = c.astype(np.float64) * q - table[a]
        dur = _t(n - 1, fs)
        if np.ptp(c) == 0:
            out.append(_finding("dead", a, [0.0, dur], f"dead channel: the counts stay at {int(c[0])} from 0 to "
                                                       f"{dur:g} s"))
            continue
        # jumps: beyond what the gyro can turn in one sample period
        d1 = np.diff(c).astype(np.float64)
        sus = suspension_from_nominal(rec.nominal[a])
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                model = simulate_axis(inputs, a, sus, (), FIT_SETTINGS) - table[a]
        except (ValueError, FloatingPointError):
            model = None
        # compare in the steady state: the second half, and for a recording that starts mid-operation
        # (the model starts from rest) not before 3 time constants 2 Q / omega
        tau = 2.0 * sus.q_factor(3.0 * ARCMIN) / sus.omega0
        i0 = max(n // 2, int(3.0 * tau * fs) if rec.initial_state == "unknown" else 0)
        if i0 > n - 16:
            model = None
        amp_pred = float(np.std(model[i0:])) if model is not None else 0.0
        w_dither = 2.0 * math.pi * sus.f0_hz
        table_rate = np.max(np.abs(np.diff(table[a]))) * fs if n > 1 else 0.0
        limit = 2.0 * (MAX_RATE_RAD_S + table_rate + 3.0 * math.sqrt(2.0) * amp_pred * w_dither) / fs / q
        big = np.flatnonzero(np.abs(d1) > limit)
        if big.size:
            j = int(big[0])
            kind = "spike" if big.size >= 2 and big[1] == j + 1 and np.sign(d1[j]) != np.sign(d1[j + 1]) else "jump"
            out.append(_finding("jump", a, _t(j + 1, fs),
                                f"impossible {kind} of {d1[j]:.4g} counts ({d1[j] * q:.3g} rad) at t = "
                                f"{_t(j + 1, fs):g} s, beyond the {limit:.4g} counts a gyro can turn in one sample "
                                f"({big.size} such step(s) in all)"))
            continue
        # saturation: flat tops at the extremes
        saturated = False
        for val, word in ((c.max(), "maximum"), (c.min(), "minimum")):
            at = c == val
            # samples in flat tops: runs of >= FLAT_RUN equal samples at the extreme
            flat = at.copy()
            for k in range(1, FLAT_RUN):
                flat[:-k] &= at[k:]
            starts = np.flatnonzero(flat)
            in_runs = int(np.sum(np.convolve(flat.astype(np.int64), np.ones(FLAT_RUN, dtype=np.int64))[:n] > 0))
            if starts.size and in_runs >= max(SATURATION_MIN, 0.005 * n):
                t0, t1 = _t(int(starts[0]), fs), _t(int(starts[-1]) + FLAT_RUN - 1, fs)
                out.append(_finding("saturated", a, [t0, t1],
                                    f"saturated channel: {in_runs} samples sit in flat tops at the {word} "
                                    f"{int(val)} counts between t = {t0:g} and {t1:g} s"))
                saturated = True
                break
        if saturated:
            continue
        if amp_pred > 0.0 and float(np.std(y[i0:])) < DEAD_RATIO * amp_pred:
            out.append(_finding("dead", a, [0.0, dur],
                                f"dead channel: the angle swings by {np.std(y[i0:]) / amp_pred:.2%} of what "
                                "the nominal model predicts for the recorded drive"))
            continue
        # continuity: second differences larger than first ones (white counts)
        d2 = np.diff(y, 2)
        dy = np.diff(y)
        nw = max(16, int(round(WINDOW_S * fs)))
        bad = None
        for j0 in range(0, d2.size - nw + 1, nw):
            r1 = float(np.sqrt(np.mean(dy[j0:j0 + nw] ** 2)))
            r2 = float(np.sqrt(np.mean(d2[j0:j0 + nw] ** 2)))
            if r1 > 0 and r2 > r1 and _white(y[j0:j0 + nw + 2]):
                bad = (j0, r2 / r1)
                break
        if bad is not None:
            j0, ratio = bad
            out.append(_finding("not continuous", a, [_t(j0, fs), _t(j0 + nw, fs)],
                                f"the counts do not follow a continuous angle from t = {_t(j0, fs):g} s (second "
                                f"differences {ratio:.2f} times the first: random counts or shuffled rows)"))
            continue
        # sign convention: the dither against the nominal model's prediction
        if model is not None and amp_pred > 0.0:
            h = slice(i0, n)
            ym = y[h] - y[h].mean()
            mm = model[h] - model[h].mean()
            den = float(np.sqrt(np.sum(ym * ym) * np.sum(mm * mm)))
            corr = float(np.sum(ym * mm)) / den if den > 0 else 0.0
            if corr < SIGN_CORRELATION:
                out.append(_finding("sign", a, [_t(i0, fs), dur],
                                    f"sign convention opposite to the header's: the dither correlates at {corr:.2f} "
                                    f"with the nominal model's prediction from t = {_t(i0, fs):g} s (counts "
                                    "negated, drive sign flipped, or k5 of the wrong sign)"))
                continue
        # noise floor against the readout quantum, when the floor is white: a resonance (a structural mode
        # at 1.5-2.5 kHz) fills the band with its peak and skirts, but not evenly; it is physics for the
        # diagnosis to localise, not a noisy channel
        fl = noise_floor(y, q, fs)
        white = fl["spread"] <= FLAT_MARGIN * fl["spread_white"]
        if white and fl["white_rad"] > NOISE_RATIO * fl["quantisation_rad"]:
            out.append(_finding("noise", a, [0.0, dur],
                                f"noise floor {fl['white_rad'] / ARCSEC:.3g} arcsec RMS is "
                                f"{fl['white_rad'] / fl['quantisation_rad']:.0f} times the readout quantisation "
                                f"(limit {NOISE_RATIO:g}x): a noisy or corrupted channel"))
    return out


def format_findings(findings: list) -> str:
    """One line per finding."""
    return "\n".join(f"data check failed ({f['check']}): {f['message']}" for f in findings)
