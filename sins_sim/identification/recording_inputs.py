"""What the model simulates for a recording: pre-roll, truncation, fit masks and coupling sources.

A recording with ``initial_state = "unknown"`` is simulated from rest 6 time
constants ``2 Q / omega`` before its start (:func:`_tau`), the drive (and
table motion) before ``t = 0`` continued as it starts (:func:`_model_inputs`,
:func:`_sine_extension`, :class:`_ShiftedMotion`); its first half time
constant is left out of the fit (:func:`_masks`, which also cuts the
recording into fit and held-out blocks). :func:`_coupling_sources` gives the
measured deflections that ``axis_coupling`` feeds to the other axes;
:func:`_truncate` the first window of a long recording. See
:mod:`sins_sim.identification.diagnose`.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import optimize
from scipy.interpolate import CubicSpline

from sins_sim.identification.refit import DiagnoseSettings
from sins_sim.io.recording import Recording
from sins_sim.simulation.experiment import ExperimentInputs, ExperimentSettings
from sins_sim.units import ARCMIN


def _sine_extension(x: np.ndarray, fs_hz: float, n_pre: int, block_s: float = 0.05) -> np.ndarray:
    """``n_pre`` samples before ``x[0]``: the sinusoid plus constant fitted to the first ``block_s`` of ``x``.

    Used when a recording starts mid-operation: the drive (and a coupled
    axis' deflection) before ``t = 0`` is taken to have continued as it
    started.
    """
    x = np.asarray(x, dtype=np.float64)
    nb = int(min(x.size, max(16, round(block_s * fs_hz))))
    seg = x[:nb]
    t = np.arange(nb) / fs_hz
    spec = np.abs(np.fft.rfft((seg - seg.mean()) * np.hanning(nb), 16 * nb))
    f = float(np.fft.rfftfreq(16 * nb, 1.0 / fs_hz)[int(np.argmax(spec))])

    def design(freq, tt):
        w = 2.0 * math.pi * freq
        return np.column_stack([np.cos(w * tt), np.sin(w * tt), np.ones_like(tt)])

    if f > 0.0:
        sol = optimize.least_squares(
            lambda p: design(p[0], t) @ np.linalg.lstsq(design(p[0], t), seg, rcond=None)[0] - seg, [f],
            method="lm", max_nfev=60)
        f = float(sol.x[0])
    coef = np.linalg.lstsq(design(f, t), seg, rcond=None)[0]
    t_pre = np.arange(-n_pre, 0) / fs_hz
    return design(f, t_pre) @ coef


class _ShiftedMotion:
    """A recording's table motion delayed by ``t_shift`` (a model pre-roll), continued linearly before it."""

    def __init__(self, base, t_shift: float):
        self.base = base
        self.t_shift = float(t_shift)
        a0, r0 = base.angle_rate(np.zeros(1))
        self.a0, self.r0 = float(a0[0]), float(r0[0])

    def angle_rate(self, t):
        tt = np.asarray(t, dtype=np.float64) - self.t_shift
        a, r = self.base.angle_rate(np.maximum(tt, 0.0))
        before = tt < 0.0
        return np.where(before, self.a0 + self.r0 * tt, a), np.where(before, self.r0, r)


def _model_inputs(rec: Recording, n_pre: int) -> ExperimentInputs:
    """The experiment to simulate: the recording's, preceded by ``n_pre`` samples of extrapolated drive."""
    inputs = ExperimentInputs.from_recording(rec)
    if n_pre == 0:
        return inputs
    r = rec.drive_ratio
    drive = np.asarray(rec.drive_v, dtype=np.float64)
    ext = np.column_stack([_sine_extension(drive[:, i], rec.drive_fs_hz, n_pre * r) for i in range(rec.n_axes)])
    table = inertial = None
    if rec.sins_angle is not None:
        table = {a: _ShiftedMotion(inputs.table[a], n_pre / rec.fs_hz) for a in rec.axes}
    if rec.site is not None:  # the Earth's rate (meta.site), before t = 0 continued at its start rate
        inertial = {a: _ShiftedMotion(inputs.inertial[a], n_pre / rec.fs_hz) for a in rec.axes}
    return ExperimentInputs(rec.axes, rec.fs_hz, rec.n_samples + n_pre, rec.drive_fs_hz,
                            np.concatenate([ext, drive]), table, inertial)


def _truncate(rec: Recording, n: int) -> Recording:
    """The first ``n`` samples of a recording (drive and table angle cut to match)."""
    sins = None
    if rec.sins_angle is not None:
        k = min(rec.sins_angle.shape[0], int(math.ceil((n - 1) * rec.sins_fs_hz / rec.fs_hz)) + 9)
        sins = rec.sins_angle[:k]
    return Recording(rec.meta, rec.counts[:n], rec.drive_v[:n * rec.drive_ratio], sins, {}, rec.source)


def _table_angles(rec: Recording) -> dict:
    """The block's angle w.r.t. inertial space at the readout instants, per axis: the table angle (0 without
    ``sins_angle``) plus, with ``meta.site``, the Earth's (what the readout holds beside the deflection)."""
    if rec.sins_angle is None and rec.site is None:
        return {a: np.zeros(rec.n_samples) for a in rec.axes}
    inputs = ExperimentInputs.from_recording(rec)
    return {a: inputs.block_angle_rate(a, rec.time())[0] for a in rec.axes}


def _tau(nominal: dict) -> float:
    """Longest amplitude time constant ``2 Q / omega`` of the axes at 3 arcmin (s)."""
    return max(2.0 * s.q_factor(3.0 * ARCMIN) / s.omega0 for s in nominal.values())


def _masks(rec: Recording, settings: DiagnoseSettings, nominal: dict):
    n = rec.n_samples
    fs = rec.fs_hz
    used = np.ones(n, dtype=bool)
    if rec.initial_state == "unknown":
        # the model starts from a pre-roll (see diagnose_recording); its first instants still carry
        # what the extrapolated drive could not know
        used[: int(round(min(0.5 * _tau(nominal), 0.2 * rec.duration_s) * fs))] = False
    block = settings.block_s or min(0.5, max(0.025, rec.duration_s / 20.0))
    nb = max(2, int(round(block * fs)))
    train = used & ((np.arange(n) // nb) % 2 == 0)
    return used, train


def _coupling_sources(rec: Recording, inputs: ExperimentInputs, settings: ExperimentSettings, n_pre: int) -> dict:
    """Measured deflections of every axis on the plant grid of ``inputs``: ``(delta, rate)``.

    For ``axis_coupling``: the readout minus the table angle, by cubic
    spline; before the recording (a model pre-roll of ``n_pre`` samples)
    continued as the sinusoid it starts with.
    """
    g = inputs.grid(settings)
    t = np.arange(g.n_steps + 1) * g.h
    out = {}
    tt = np.arange(rec.n_samples + n_pre) / rec.fs_hz
    for a in rec.axes:
        y = rec.angle(a) + 0.5 * rec.quantum_rad
        if rec.sins_angle is not None or rec.site is not None:
            y = y - inputs.block_angle_rate(a, tt[n_pre:])[0]
        if n_pre:
            y = np.concatenate([_sine_extension(y, rec.fs_hz, n_pre), y])
        spl = CubicSpline(tt, y)
        out[a] = (spl(t), spl(t, 1))
    return out
