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
``time continuity``  the dither's phase steps within a sample (:func:`_phase_step`): the dither, at its
                     measured frequency, fitted with the record's other lines (the table's motion seen
                     through the suspension) to windows of :data:`STEP_PERIODS` periods, steps in phase
                     between adjacent windows by more than :data:`STEP_MIN_RAD` against its neighbours:
                     samples lost or inserted while the header claims a continuous record (each step may
                     stay within the ``jump`` limit). The finding gives the drive's step at the same
                     instant (equal when every array lost the samples) and the samples lost modulo a
                     dither period. A gap of a whole number of periods (within 10 deg) leaves the phase
                     alone and is not seen. The arrays' lengths are the reader's
                     (``sins_sim.io.recording``: ``drive_v`` and ``sins_angle`` must cover ``counts``)
``sign`` (table)     with table motion (``sins_angle`` swinging by more than 100 quanta), the measured
                     angle regressed on the table angle has a negative slope: the gyro measures the block's
                     angle (slope +1), so the counts are negated or ``sins_angle`` has the opposite sign or
                     runs backwards; the dither test below cannot see this (it subtracts the table first)
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
           "SIGN_CORRELATION", "NOISE_RATIO", "FLAT_MARGIN",
           "STEP_PERIODS", "STEP_SEARCH", "STEP_TONE_FRACTION", "STEP_TONES", "STEP_AMP_FRACTION", "STEP_CONFIRM", "STEP_CANDIDATES", "STEP_MIN_RAD", "WHITE_RHO"]

DEAD_RATIO = 0.05
SATURATION_MIN = 8
FLAT_RUN = 3
MAX_RATE_RAD_S = math.radians(1000.0)
WINDOW_S = 0.05
SIGN_CORRELATION = -0.3
NOISE_RATIO = 20.0
#: Dither periods of the windows whose fitted dither phases are compared (:func:`_phase_step`).
STEP_PERIODS = 10
#: The dither is sought within this fraction of the nominal f0 (:func:`_tones`).
STEP_SEARCH = 0.15
#: Lines of at least this fraction of the dither's spectral peak are fitted beside it (:func:`_tones`); a Hann
#: window's largest sidelobe is 0.028 of its line (-31 dB), so a sidelobe is never taken for a line.
STEP_TONE_FRACTION = 0.05
#: The most lines fitted beside the dither.
STEP_TONES = 4
#: Steps are sought only where the dither's fitted amplitude is at least this fraction of its median over the
#: record, in all four windows: a dither building up from rest beats with its free response (a unit's resonance
#: and its drive differ by per cent), and its phase then turns by tens of degrees within a window (up to 127 deg
#: in the blind set's rate-table records, where its amplitude was below a fifth of the median).
STEP_AMP_FRACTION = 0.5
#: A step is confirmed when the lines' annihilated residual at it exceeds this many robust standard deviations
#: of the residual around it (:func:`_phase_step`).
STEP_CONFIRM = 6.0
#: Candidate events examined, the largest first.
STEP_CANDIDATES = 4
#: Smallest phase step reported (rad): 10 deg. A dither whose frequency the fit before the step misjudges by
#: 0.5 % drifts by 0.05 cycles = 18 deg over 10 periods, half that at the middle of the fit after it.
STEP_MIN_RAD = math.radians(10.0)
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


def _sine_at(seg: np.ndarray, w: float) -> complex:
    """Least-squares ``c cos(w k) + s sin(w k)`` on a segment (``k`` its sample index, a mean removed): the
    complex amplitude ``c - i s``, whose argument is the phase at ``k = 0``."""
    k = np.arange(seg.size, dtype=np.float64)
    d = np.column_stack([np.cos(w * k), np.sin(w * k), np.ones_like(k)])
    cc, ss, _ = np.linalg.lstsq(d, seg, rcond=None)[0]
    return complex(cc, -ss)


def _local_phase_jump(x: np.ndarray, j: int, w: float, m: int) -> float | None:
    """The phase step at sample ``j`` of a sine of ``w`` rad/sample: the sine fitted to the ``m`` samples
    before, with its frequency refined on them, continued to the ``m`` samples after and compared with the sine
    fitted there (rad, in ``(-pi, pi]``); ``None`` without room on both sides."""
    if j - m < 0 or j + m > x.size:
        return None
    before, after = x[j - m:j], x[j:j + m]
    # refine the frequency on the samples before: the phase advance between their two halves
    h = m // 2
    a1, a2 = _sine_at(before[:h], w), _sine_at(before[h:2 * h], w)
    if abs(a1) == 0.0 or abs(a2) == 0.0:
        return None
    w = w + float(np.angle(a2 / (a1 * np.exp(1j * w * h)))) / h  # the phase advance beyond w's over h samples
    pb = _sine_at(before, w)
    pa = _sine_at(after, w)
    if abs(pb) == 0.0 or abs(pa) == 0.0:
        return None
    return float(np.angle(pa / (pb * np.exp(1j * w * m))))


def _tones(x: np.ndarray, fs: float, f0: float, window: int):
    """The dither's frequency, measured, and the other lines the window fits must hold (rad per sample).

    The dither is the largest peak of the Hann-windowed spectrum within :data:`STEP_SEARCH` of the nominal ``f0``
    (a unit's resonance differs from its nominal by per cent; under a rate table the dither is driven where the
    drive puts it), its frequency refined by the parabola through the log magnitudes of the peak's bin and its
    neighbours (Gasior & Gonzalez 2004; a residual error of a fraction of a bin turns the phase by the same
    angle in every window, which the step statistic of :func:`_phase_step` cancels).
    The other lines are the spectrum's local maxima of at least :data:`STEP_TONE_FRACTION` of the dither's peak
    (the table's motion seen through the suspension: 80 and 230 Hz lines as large as half the dither), at least
    ``1.5 fs / window`` from the dither and from each other (closer, a window cannot tell them apart), the
    strongest :data:`STEP_TONES` of them. Returns ``[w_dither, w_1, ..]`` or ``None`` without a dither peak.
    """
    n = x.size
    spec = np.abs(np.fft.rfft(x * np.hanning(n)))
    f = np.fft.rfftfreq(n, 1.0 / fs)

    def refine(k):
        if 0 < k < spec.size - 1 and spec[k - 1] > 0.0 and spec[k + 1] > 0.0:
            la, lb, lc = np.log(spec[k - 1]), np.log(spec[k]), np.log(spec[k + 1])
            den = la - 2.0 * lb + lc
            d = 0.5 * (la - lc) / den if den < 0.0 else 0.0
            return 2.0 * math.pi * (k + d) / n
        return 2.0 * math.pi * k / n

    band = np.flatnonzero((f >= (1.0 - STEP_SEARCH) * f0) & (f <= (1.0 + STEP_SEARCH) * f0))
    if band.size == 0 or not spec[band].max() > 0.0:
        return None
    kd = int(band[np.argmax(spec[band])])
    tones = [refine(kd)]
    sep = 2.0 * math.pi * 1.5 / window
    peaks = np.flatnonzero((spec[1:-1] > spec[:-2]) & (spec[1:-1] >= spec[2:])) + 1
    peaks = peaks[spec[peaks] >= STEP_TONE_FRACTION * spec[kd]]
    for k in peaks[np.argsort(spec[peaks])[::-1]]:
        if len(tones) > STEP_TONES:
            break
        w = 2.0 * math.pi * k / n
        # (below sep a window's offset and slope fit the slow motion)
        if w >= sep and all(abs(w - v) >= sep for v in tones):
            tones.append(refine(int(k)))
    return tones


def _dither_phases(x: np.ndarray, tones, window: int) -> np.ndarray:
    """The dither's complex amplitude fitted to every window ``[j, j + window)`` (phase at ``j``), all ``j``.

    Least squares of ``x`` on ``cos(w k), sin(w k)`` for every tone (the dither first) and a line ``a + b k`` in
    the window's own sample index ``k`` (:func:`_tones`): the normal equations' right-hand sides from running
    sums of ``x`` times the basis in the record's index, turned to the window's index by the angle addition
    theorems; the Gram matrix is the same for every window. Returns ``c - i s`` of the dither per window start.
    """
    n = x.size
    l = np.arange(n, dtype=np.float64)
    k = np.arange(window, dtype=np.float64)
    j = np.arange(n - window + 1)

    def run(v):  # sums of v over every window
        c = np.concatenate([[0.0], np.cumsum(v)])
        return c[j + window] - c[j]

    cols, basis = [], []
    for w in tones:
        bc, bs = run(x * np.cos(w * l)), run(x * np.sin(w * l))
        cw, sw = np.cos(w * j), np.sin(w * j)
        cols += [cw * bc + sw * bs, cw * bs - sw * bc]  # sums of x cos(w k), x sin(w k)
        basis += [np.cos(w * k), np.sin(w * k)]
    s0, s1 = run(x), run(x * l)
    cols += [s0, s1 - j * s0]
    basis += [np.ones(window), k]
    b = np.stack(cols, axis=1)
    g = np.stack(basis, axis=1)
    coef = np.linalg.solve(g.T @ g, b.T).T
    return coef[:, 0] - 1j * coef[:, 1]


def _phase_step(y: np.ndarray, fs: float, f0: float):
    """A step of the dither's phase: ``(sample, step rad)`` or ``None``.

    The dither's phase is tracked by fitting it, with the other lines of the record and an offset and slope
    (:func:`_tones`, :func:`_dither_phases`), to windows of :data:`STEP_PERIODS` periods of its measured
    frequency ``w``. ``D(j)``, the phase of the window starting at ``j`` against that of the window before it
    continued by ``w`` per sample, is zero on a continuous dither, and constant when ``w`` is misjudged; a
    frequency that drifts (an AFC sweep) makes it a slow ramp. Samples lost at ``j0`` make it a tent of height
    ``w`` times the samples lost (modulo a period), zero where both windows lie on one side of ``j0``: so the
    step at ``j`` is ``((D(j) - D(j - W)) - (D(j + W) - D(j))) / 2`` (``W`` the window), which a constant or a
    ramp of ``D`` leave at zero (a dither building up from rest beats with its free response; the first and
    last two windows are not tested, nor where the dither is below :data:`STEP_AMP_FRACTION` of its median). The
    largest step beyond :data:`STEP_MIN_RAD` is reported. A line of the table's motion beside the dither (the
    recursion residual of the nominal frequency, the test before, counted it as noise and missed a 9-sample
    gap under table motion) is fitted, not left in the window.
    """
    x = y - np.mean(y)
    win = int(round(STEP_PERIODS * fs / f0))
    if x.size < 4 * win + 3 or not 0.0 < 2.0 * math.pi * f0 / fs < math.pi:
        return None
    tones = _tones(x, fs, f0, win)
    if tones is None:
        return None
    a = _dither_phases(x, tones, win)
    if not np.all(np.isfinite(a)) or np.any(a == 0.0):
        return None
    # D(j) at j = win .. n - win: the window at j against the one at j - win, continued
    r = a[win:] * np.conj(a[:-win]) * np.exp(-1j * tones[0] * win)
    r = r / np.abs(r)
    # the step at j = 2 win .. n - 2 win: (D(j) - D(j - win)) - (D(j + win) - D(j)), halved
    step = 0.5 * (np.angle(r[win:-win] * np.conj(r[:-2 * win])) - np.angle(r[2 * win:] * np.conj(r[win:-win])))
    # only where the dither has built up: in all four windows at least STEP_AMP_FRACTION of its median
    amp = np.abs(a)
    low = amp < STEP_AMP_FRACTION * float(np.median(amp))
    weak = low[:-3 * win] | low[win:-2 * win] | low[2 * win:-win] | low[3 * win:]
    step[weak[:step.size]] = 0.0
    for _ in range(STEP_CANDIDATES):  # the largest steps first, each a distinct event
        i = int(np.argmax(np.abs(step)))
        if not abs(step[i]) > STEP_MIN_RAD:
            return None
        found = _confirm_step(x, step, i, win, tones)
        if found is not None:
            return found
        step[max(0, i - 2 * win):i + 2 * win] = 0.0
    return None


def _confirm_step(x, step, i, win, tones):
    """``(sample, step rad)`` of the candidate at ``step[i]`` (sample ``i + 2 win``), or ``None`` (see
    :func:`_phase_step`)."""
    # where: a step near half a turn makes the statistic a plateau a window wide (the fitted phase of a window
    # holding the step switches from one side's to the other's where the step crosses its middle), so the
    # sample is the largest residual of the sine recursion at the measured frequency, x[k] - 2 cos(w) x[k-1] +
    # x[k-2], which vanishes on the dither and is of its amplitude at the step, within a window of the plateau
    b = i + 2 * win
    w = tones[0]
    lo, hi = max(2, b - win), min(x.size, b + win)
    e = x[lo:hi] - 2.0 * math.cos(w) * x[lo - 1:hi - 1] + x[lo - 2:hi - 2]
    j = lo + int(np.argmax(np.abs(e)))
    if 2 * win <= j < x.size - 2 * win and abs(step[j - 2 * win]) > STEP_MIN_RAD:
        i = j - 2 * win
    # and a step, not a phase that turns smoothly (a dither still beating with its free response): with every
    # line annihilated by its recursion (a cascade of 1 - 2 cos(w) z^-1 + z^-2), a step leaves a transient as
    # long as the cascade, of the dither's amplitude, above STEP_CONFIRM robust standard deviations of the
    # cascade's output over the four windows around it
    j = i + 2 * win
    lo, hi = j - 2 * win, min(x.size, j + 2 * win)
    c = x[lo:hi]
    for v in tones:
        c = c[2:] - 2.0 * math.cos(v) * c[1:-1] + c[:-2]
    k0 = j - lo - 2 * len(tones)  # c[k] holds x[lo + k .. lo + k + 2 len(tones)]
    peak = float(np.max(np.abs(c[max(0, k0):k0 + 2 * len(tones) + 1])))
    sd = 1.4826 * float(np.median(np.abs(c - np.median(c))))
    if not peak > STEP_CONFIRM * sd:
        return None
    return j, float(step[i])


def _phase_step_at(drive: np.ndarray, drive_fs: float, f0: float, t0: float) -> float | None:
    """The drive's phase step at time ``t0`` (rad), or ``None`` when it does not step there."""
    w = 2.0 * math.pi * f0 / drive_fs
    m = int(round(STEP_PERIODS * drive_fs / f0))
    j = int(round(t0 * drive_fs))
    best = None
    for jj in range(max(m, j - 2), min(drive.size - m, j + 3)):
        d = _local_phase_jump(drive - np.mean(drive), jj, w, m)
        if d is not None and (best is None or abs(d) > abs(best)):
            best = d
    return best if best is not None and abs(best) > STEP_MIN_RAD else None


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
    # the table moves when its angle swings by more than 100 quanta (the sign test then has a witness far
    # above the readout's resolution)
    table_moves = {a: rec.sins_angle is not None and float(np.std(table[a])) > 100.0 * q for a in rec.axes}
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
        # time continuity: a step of the dither's phase (samples lost or inserted)
        step = _phase_step(y, fs, float(rec.nominal[a].get("f0_hz", sus.f0_hz)))
        if step is not None:
            j, dphi = step
            t0 = _t(j, fs)
            dd = _phase_step_at(np.asarray(rec.drive_v[:, i], dtype=np.float64), rec.drive_fs_hz,
                                float(rec.nominal[a].get("f0_hz", sus.f0_hz)), t0)
            drive = (f"the drive's by {math.degrees(dd):.0f} deg there" if dd is not None else
                     "the drive's does not step there")
            lost = (dphi % (2.0 * math.pi)) / (2.0 * math.pi * sus.f0_hz) * fs  # n lost: the phase advances by w n
            out.append(_finding("time continuity", a, t0,
                                f"the dither's phase steps by {math.degrees(dphi):.0f} deg at t = {t0:g} s and "
                                f"{drive}: samples lost or inserted (e.g. {lost:.0f} samples, modulo a dither "
                                f"period of {fs / sus.f0_hz:.1f}) although the header claims a continuous record "
                                f"at {fs:g} Hz; a dither cannot change its phase within a sample"))
            continue
        # sign convention against the table angle: the gyro measures the block's angle (slope +1)
        if table_moves[a]:
            ang = c.astype(np.float64) * q
            tt = table[a] - table[a].mean()
            slope = float(np.dot(ang - ang.mean(), tt) / np.dot(tt, tt))
            if slope < 0.0:
                out.append(_finding("sign", a, [0.0, dur],
                                    f"sign convention opposite to the table's: the measured angle follows the table "
                                    f"angle (sins_angle) with slope {slope:.3g} instead of +1 from 0 to {dur:g} s "
                                    "(counts negated, or sins_angle of the opposite sign or reversed in time)"))
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
