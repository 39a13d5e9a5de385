"""Per-sample cost of the kernels and of the three-axis chain, against same-run baselines.

The engine behind ``sins-sim bench`` and the pytest-benchmark suite in
``benchmarks/``. Every measurement follows the same protocol: fixed,
deterministic inputs; one untimed call first (numba compiles, or loads its
on-disk cache); then ``repeats`` timed calls, of which the median is kept;
and the result is checked against an independent computation before any
number is reported (a wrong fast kernel is not a benchmark result).

Clocks: ``clock="cpu"`` (default) times with :func:`time.thread_time`, the
CPU time of the calling thread: every kernel runs single-threaded in that
thread, so this is the time the work takes on one core, and it does not
count the periods in which a shared machine runs someone else's process.
``clock="wall"`` uses :func:`time.perf_counter`. The three-axis real-time
factor is reported for both.

What is measured (``run_bench`` keys):

``ns_per_sample``
    ``correcting`` / ``correcting_paper``: eq. 5 (unity-DC and paper form,
    paper hysteresis rule) per 7.2 kHz sample, on a dithered readout record;
    ``eliminator``: the 10-pole elliptic band-stop per sample;
    ``plant_step_1axis``: one suspension (default ``"exact"`` integrator)
    per 72 kHz step, paper suspension driven at resonance under a 1 arcmin
    100 Hz block vibration; ``plant_step_1axis_rk4``: the same with the RK4
    reference integrator; ``sins_chain_per_plant_step``: the whole
    three-axis chain (below) per plant step of one axis.
``baseline_ns_per_sample``
    ``scipy_sosfilt``: ``scipy.signal.sosfilt`` on the eliminator's input;
    ``correcting_python``: eq. 5 as printed, in plain Python
    (:func:`correcting_reference`); ``plant_rk4_python``: RK4 of eq. 2 in
    plain Python (:func:`plant_rk4_reference`), on a short record;
    ``sins_chain_api``: the same three-axis chain through the public classes
    (one call per class per chunk), the reference the fused chain is checked
    against bit for bit.
``ratios``
    Same-run ratios used by the CI thresholds (``benchmarks/thresholds.json``):
    the machine's speed cancels out.
``anchors_ns``
    Figures measured elsewhere on this kind of machine (one core), quoted
    from the issue: eq. 5 in C (gcc -O3 -march=native) 21 ns (19-23),
    ``scipy.signal.sosfilt`` of the eliminator 7.7 ns, RK4 of one suspension
    in C 56 ns per step.
``realtime_factor_3axis``
    Simulated seconds per CPU second of the three-axis chain on one core
    (``realtime_factor_3axis_wall``: per wall second).

The three-axis chain
--------------------
Three channels with resonances 386, 352 and 421 Hz (the paper suspension
with ``f0`` changed), each driven at its amplitude's resonance (eq. 17
voltage), under a 1 arcmin block vibration about its axis at 100, 130 and
170 Hz. Per axis: the plant at 72 kHz (``"exact"``), the fringe counter
(1/16 fringe) and the 21-tap anti-alias FIR decimating to 7.2 kHz, the drive
through the same decimator, the correcting filter in both forms and the
eliminator at 7.2 kHz; then one attitude update per filter sample from the
three unity-form increments (:class:`~sins_sim.navigation.attitude.AttitudeIntegrator`,
two-sample coning correction). The run streams in chunks of 0.5 s.

:class:`FusedChain` runs it with the package's kernels called directly, one
call per kernel per chunk and all buffers allocated once (the three plants
in one call of ``plant_run_exact_many``, the three axes' inputs in one
compiled loop, :func:`_chain_inputs_kernel`, with its constants computed
once); :class:`ApiChain` runs the same chain through the public classes.
Both take their inputs from :func:`chain_inputs` and give identical bits
(checked by ``run_bench`` and by ``benchmarks/``).
"""

from __future__ import annotations

import json
import math
import statistics
import subprocess
import sys
import time

import numpy as np
from scipy import signal

from sins_sim._kernels import correcting as kcor
from sins_sim._kernels import fir as kfir
from sins_sim._kernels import nav as knav
from sins_sim._kernels import physics as kphys
from sins_sim._kernels import plant_exact as kexact
from sins_sim._kernels import sos as ksos
from sins_sim._kernels._config import jit
from sins_sim.filters.correcting import CorrectingFilter, CorrectingFilterDesign
from sins_sim.filters.eliminator import Eliminator, EliminatorDesign
from sins_sim.models.drive import DriveParams
from sins_sim.models.plant import Plant, PlantSettings
from sins_sim.models.readout import Decimator, Readout
from sins_sim.models.suspension import PAPER_SUSPENSION, SuspensionParams
from sins_sim.navigation.attitude import AttitudeIntegrator
from sins_sim.simulation.channel import ChannelConfig
from sins_sim.units import ARCMIN, ARCSEC, INTERPOLATED_QUANTUM_RAD

__all__ = [
    "ANCHORS_NS",
    "CHAIN_F0_HZ",
    "run_bench",
    "format_table",
    "chain_inputs",
    "FusedChain",
    "ApiChain",
    "correcting_reference",
    "plant_rk4_reference",
    "filter_input",
    "plant_input",
    "peak_memory",
    "median_time",
    "check_fused_chain",
    "SIZES",
]

#: Figures measured on this kind of machine, one core (the issue's anchors), ns per sample.
ANCHORS_NS = {"correcting_c": 21.0, "scipy_sosfilt": 7.7, "plant_rk4_c": 56.0}
#: Resonances of the three axes of the chain (Hz).
CHAIN_F0_HZ = (386.0, 352.0, 421.0)
#: Block vibration about each axis in the chain: 1 arcmin at these frequencies (Hz).
CHAIN_VIBRATION_HZ = (100.0, 130.0, 170.0)
CHAIN_VIBRATION_RAD = ARCMIN
CHAIN_CHUNK_S = 0.5

_CLOCKS = {"cpu": time.thread_time, "wall": time.perf_counter}


# --- fixed inputs -------------------------------------------------------------------------------


def filter_input(n: int, fs_hz: float = 7200.0, suspension: SuspensionParams = PAPER_SUSPENSION):
    """A decimated readout record for the filters: ``(x, volts)`` at ``fs_hz``, length ``n``.

    A 3 arcmin dither at the amplitude's resonance, a 1 arcmin 100 Hz block
    vibration and a 10 deg/h rotation, quantised to 1/16 fringe; the drive
    ``V_m cos`` of eq. 17 (phase 90 deg ahead of the deflection, as at
    resonance). Deterministic (no random numbers).
    """
    drive = DriveParams().resolve(suspension)
    k = np.arange(n, dtype=np.float64)
    ph = 2.0 * math.pi * np.mod(drive.frequency_hz * k / fs_hz, 1.0)
    angle = (3.0 * ARCMIN * np.sin(ph) + ARCMIN * np.sin(2.0 * math.pi * 100.0 * k / fs_hz)
             + (10.0 * math.pi / 180.0 / 3600.0) * k / fs_hz)
    x = np.floor(angle / INTERPOLATED_QUANTUM_RAD) * INTERPOLATED_QUANTUM_RAD
    volts = drive.v_m * np.cos(ph)
    return x, volts


def plant_input(n: int, rate_hz: float = 72000.0, suspension: SuspensionParams = PAPER_SUSPENSION):
    """Plant inputs ``(sins_angle, sins_rate, volts)`` for ``n`` steps at ``rate_hz``.

    Block angle and rate of a 1 arcmin 100 Hz vibration at the ends of the
    steps ``t_1 .. t_n``; the drive at the 3 arcmin resonance held over each
    step (DAC at the plant rate). Deterministic.
    """
    t = np.arange(1, n + 1) / rate_hz
    w = 2.0 * math.pi * 100.0
    volts = DriveParams(dac_rate_hz=rate_hz).resolve(suspension).samples(0, n)
    return ARCMIN * np.sin(w * t), ARCMIN * w * np.cos(w * t), volts


@jit
def _sine_pair(i0, n, step, amp, omega, phase, sin_out, cos_out):
    """``amp sin(omega (i0 + 1 + j) step + phase)`` and ``amp cos(...)`` for ``j < n``.

    Exact at ``j = 0`` (libm), then a rotation by ``omega step`` per sample
    (rounding drifts by ~1e-16 per sample, 4e-12 over a 0.5 s chunk; every
    chunk starts exact).
    """
    arg = omega * (i0 + 1) * step + phase
    s = amp * math.sin(arg)
    c = amp * math.cos(arg)
    cr = math.cos(omega * step)
    sr = math.sin(omega * step)
    for j in range(n):
        sin_out[j] = s
        cos_out[j] = c
        s, c = s * cr + c * sr, c * cr - s * sr


@jit
def _drive_samples(k0, n, f_hz, dac_hz, v_m, phase, out):
    """DAC samples ``v_m cos(2 pi frac(f k / dac) + phase)``, ``k = k0 .. k0 + n - 1``.

    The phase of ``k0`` is reduced exactly as ``DriveSignal.samples`` does;
    the rest follow by rotation (as :func:`_sine_pair`).
    """
    cyc = f_hz * k0 / dac_hz
    arg = 2.0 * math.pi * (cyc - math.floor(cyc)) + phase
    c = v_m * math.cos(arg)
    s = v_m * math.sin(arg)
    th = 2.0 * math.pi * f_hz / dac_hz
    cr = math.cos(th)
    sr = math.sin(th)
    for j in range(n):
        out[j] = c
        c, s = c * cr - s * sr, s * cr + c * sr


def _chain_configs():
    return [ChannelConfig(suspension=PAPER_SUSPENSION.replace(f0_hz=f)) for f in CHAIN_F0_HZ]


@jit
def _chain_inputs_kernel(i0, n, steps, omegas, amp, f_hz, dac_hz, v_m, phase, ang, rate, volts):
    """:func:`_sine_pair` (rate times ``omega``) and :func:`_drive_samples` of every axis, in one loop.

    The same arithmetic as those two, value for value (so the same bits);
    an axis' two rotations are independent recurrences, advanced in the same
    loop so that the processor overlaps them.
    """
    na = steps.shape[0]
    s = np.empty(na)
    c = np.empty(na)
    cr = np.empty(na)
    sr = np.empty(na)
    dc = np.empty(na)
    ds = np.empty(na)
    dcr = np.empty(na)
    dsr = np.empty(na)
    for i in range(na):
        arg = omegas[i] * (i0 + 1) * steps[i] + 0.0  # phase 0, as _sine_pair's
        s[i] = amp * math.sin(arg)
        c[i] = amp * math.cos(arg)
        cr[i] = math.cos(omegas[i] * steps[i])
        sr[i] = math.sin(omegas[i] * steps[i])
        cyc = f_hz[i] * i0 / dac_hz[i]
        arg = 2.0 * math.pi * (cyc - math.floor(cyc)) + phase[i]
        dc[i] = v_m[i] * math.cos(arg)
        ds[i] = v_m[i] * math.sin(arg)
        th = 2.0 * math.pi * f_hz[i] / dac_hz[i]
        dcr[i] = math.cos(th)
        dsr[i] = math.sin(th)
    for i in range(na):
        si = s[i]
        ci = c[i]
        cri = cr[i]
        sri = sr[i]
        w = omegas[i]
        vc = dc[i]
        vs = ds[i]
        vcr = dcr[i]
        vsr = dsr[i]
        for j in range(n):
            ang[i, j] = si
            rate[i, j] = ci * w
            volts[i, j] = vc
            si, ci = si * cri + ci * sri, ci * cri - si * sri
            vc, vs = vc * vcr - vs * vsr, vs * vcr + vc * vsr


def _input_params(configs):
    """Per-axis constants of :func:`chain_inputs` (plant steps, vibration and drive), as arrays."""
    drives = [cfg.drive_signal() for cfg in configs]
    return (np.array([1.0 / cfg.plant.rate_hz for cfg in configs]),
            np.array([2.0 * math.pi * CHAIN_VIBRATION_HZ[i] for i in range(len(configs))]),
            float(CHAIN_VIBRATION_RAD),
            np.array([d.frequency_hz for d in drives], dtype=np.float64),
            np.array([d.dac_rate_hz for d in drives], dtype=np.float64),
            np.array([d.v_m for d in drives], dtype=np.float64),
            np.array([d.phase_rad for d in drives], dtype=np.float64))


def chain_inputs(i0: int, n: int, ang: np.ndarray, rate: np.ndarray, volts: np.ndarray, configs=None,
                 params=None) -> None:
    """Fill the chain's inputs for plant steps ``i0 .. i0 + n - 1`` (arrays of shape ``(3, >= n)``).

    ``ang, rate``: block angle and rate about each gyro axis at the steps'
    ends; ``volts``: each axis' drive held over the step (DAC at the plant
    rate, resonance and eq. 17 voltage of the 3 arcmin dither). ``params``:
    ``_input_params(configs)``, computed once by a caller that streams.
    """
    if params is None:
        params = _input_params(_chain_configs() if configs is None else configs)
    _chain_inputs_kernel(i0, n, *params, ang, rate, volts)


# --- the three-axis chain -------------------------------------------------------------------------


@jit
def _quantise_feed(ang, delta, carry, q, feed):
    """Readout input of one chunk: the RLG angle at the start of each step, quantised.

    ``feed[i, 0]`` is the carried angle of the previous chunk's last step,
    ``feed[i, j] = ang[i, j-1] + delta[i, j-1]``; each is replaced by
    ``floor(phi / q) * q`` (``models.readout.quantise`` without noise, then
    ``counts * q``). ``carry`` is updated.
    """
    for i in range(ang.shape[0]):
        n = ang.shape[1]
        prev = carry[i]
        for j in range(n):
            feed[i, j] = math.floor(prev / q) * q
            prev = ang[i, j] + delta[i, j]
        carry[i] = prev


@jit
def _increments(y, last, dth):
    """``dth[k, i] = y[i, k] - y[i, k-1]`` with ``y[i, -1] = last[i]``; ``last`` is updated."""
    for i in range(y.shape[0]):
        p = last[i]
        for k in range(y.shape[1]):
            v = y[i, k]
            dth[k, i] = v - p
            p = v
        last[i] = p


class FusedChain:
    """The three-axis chain with the package's kernels called directly (see module docstring).

    Parameters
    ----------
    chunk_steps : int
        Plant steps per chunk, a multiple of the decimation (10).
    """

    def __init__(self, chunk_steps: int = int(CHAIN_CHUNK_S * 72000)):
        self.configs = _chain_configs()
        cfg0 = self.configs[0]
        self.h = 1.0 / cfg0.plant.rate_hz
        self.r = cfg0.readout.decimation
        if chunk_steps % self.r:
            raise ValueError(f"bench.chunk_steps: must be a multiple of {self.r}, got {chunk_steps!r}")
        n, m = chunk_steps, chunk_steps // self.r
        self.n, self.m = n, m
        self.q = cfg0.readout.quantum_rad
        self.taps = np.array(cfg0.readout.taps())
        self.input_params = _input_params(self.configs)
        na = len(self.configs)
        self.ang, self.rate, self.volts, self.delta, self.feed = (np.empty((na, n)) for _ in range(5))
        self.x, self.vx, self.y, self.yp, self.e = (np.empty((na, m)) for _ in range(5))
        self.dth = np.empty((m, 3))
        self.qout = np.empty((m, 4))
        s = [c.suspension for c in self.configs]
        self.params = np.array([[x.omega0 ** 2, x.k1, x.k2, x.k3, x.k4, x.k5, 2.0 * x.zeta / x.omega0] for x in s])
        self.rules = np.array([kphys.RULES[c.plant.hysteresis] for c in self.configs], dtype=np.int64)
        self.fast_dts = np.array([0.25 / x.f0_hz for x in s])
        self.cor = [[c.correcting_design(form) for c in self.configs] for form in ("unity", "paper")]
        self.sos = [np.array(c.eliminator_design().sos) for c in self.configs]
        self.reset()

    def reset(self) -> None:
        """Back to rest at t = 0 (block at angle 0 with the vibration's initial rate)."""
        na = len(self.configs)
        self.i0 = 0
        self.pstate = np.zeros((na, kexact.STATE_SIZE))
        self.pstate[:, kexact.X_RATE] = [CHAIN_VIBRATION_RAD * 2.0 * math.pi * f for f in CHAIN_VIBRATION_HZ]
        self.physt = np.zeros((na, kphys.HYST_SIZE))
        self.pstack = np.zeros((na, kphys.STACK_SIZE))
        for i in range(na):
            kphys.hyst_reset(self.physt[i], self.pstack[i])
        self.carry = np.zeros(na)
        self.fhist = np.zeros((na, self.taps.size - 1))
        self.vhist = np.zeros((na, self.taps.size - 1))
        self.fstate = np.zeros((2, na, kcor.STATE_SIZE))
        self.fhyst = np.zeros((2, na, kphys.HYST_SIZE))
        self.fstack = np.zeros((2, na, kphys.STACK_SIZE))
        for f in range(2):
            for i in range(na):
                kphys.hyst_reset(self.fhyst[f, i], self.fstack[f, i])
        self.zi = np.zeros((na, self.sos[0].shape[0], 2))
        self.att_q = np.array([1.0, 0.0, 0.0, 0.0])
        self.att_prev = np.zeros((2, 3))
        self.ylast = np.zeros(na)

    def run_chunk(self) -> None:
        """Advance one chunk; outputs in ``x, vx, y, yp, e`` (per axis) and ``qout`` (attitude)."""
        n, h = self.n, self.h
        chain_inputs(self.i0, n, self.ang, self.rate, self.volts, params=self.input_params)
        kexact.plant_run_exact_many(self.ang, self.rate, self.volts, h, self.params, self.rules, self.fast_dts,
                                    self.pstate, self.physt, self.pstack, self.delta)
        _quantise_feed(self.ang, self.delta, self.carry, self.q, self.feed)
        outs = (self.y, self.yp)
        for i, cfg in enumerate(self.configs):
            # every chunk starts at decimation phase 0 (chunk_steps is a multiple of R)
            kfir.fir_decimate(self.taps, self.feed[i], self.fhist[i], 0, self.x[i], self.r)
            kfir.fir_decimate(self.taps, self.volts[i], self.vhist[i], 0, self.vx[i], self.r)
            for f in range(2):
                d = self.cor[f][i]
                a2, g = d.coefficients
                kcor.correcting_run(self.x[i], self.vx[i], a2, g, d.k1, d.k2, d.k3, d.k4, d.k5, 1.0 / d.fs_hz,
                                    kphys.RULES[d.hysteresis], 0.25 / d.f0_hz, self.fstate[f, i], self.fhyst[f, i],
                                    self.fstack[f, i], outs[f][i])
            ksos.sos_filter(self.sos[i], self.x[i], self.zi[i], self.e[i])
        _increments(self.y, self.ylast, self.dth)
        knav.attitude_update(self.dth, self.att_q, knav.ALGO_TWO_SAMPLE, self.att_prev, self.qout)
        self.att_q[:] = self.qout[-1]
        self.i0 += n

    def run(self, n_chunks: int) -> None:
        """Advance ``n_chunks`` chunks."""
        for _ in range(n_chunks):
            self.run_chunk()


class ApiChain:
    """The same chain through the public classes (``Plant``, ``Readout``, ``Decimator``, filters, attitude)."""

    def __init__(self, chunk_steps: int = int(CHAIN_CHUNK_S * 72000)):
        self.configs = _chain_configs()
        self.n = chunk_steps
        self.reset()

    def reset(self) -> None:
        self.i0 = 0
        self.plants = [Plant(c.suspension, c.plant) for c in self.configs]
        for p, f in zip(self.plants, CHAIN_VIBRATION_HZ):
            p.reset(0.0, CHAIN_VIBRATION_RAD * 2.0 * math.pi * f)
        self.readouts = [Readout(c.readout) for c in self.configs]
        self.vdecs = [Decimator.from_readout(c.readout) for c in self.configs]
        self.cor = [CorrectingFilter(c.correcting_design("unity")) for c in self.configs]
        self.corp = [CorrectingFilter(c.correcting_design("paper")) for c in self.configs]
        self.elim = [Eliminator(c.eliminator_design()) for c in self.configs]
        self.att = AttitudeIntegrator(algorithm="two_sample")
        self.carry = np.zeros(3)
        self.ylast = np.zeros(3)
        na = len(self.configs)
        self.ang, self.rate, self.volts = (np.empty((na, self.n)) for _ in range(3))

    def run_chunk(self):
        """Advance one chunk; returns ``(x, vx, y, yp, e, q)`` (arrays of shape (3, m) and (m, 4))."""
        chain_inputs(self.i0, self.n, self.ang, self.rate, self.volts, self.configs)
        xs, vxs, ys, yps, es = [], [], [], [], []
        for i in range(len(self.configs)):
            delta = self.plants[i].step(self.ang[i], self.rate[i], self.volts[i])
            phi = self.ang[i] + delta
            feed = np.concatenate(([self.carry[i]], phi[:-1]))
            self.carry[i] = phi[-1]
            _, x = self.readouts[i].process(feed)
            vx = self.vdecs[i].process(self.volts[i])
            xs.append(x)
            vxs.append(vx)
            ys.append(self.cor[i].process(x, vx))
            yps.append(self.corp[i].process(x, vx))
            es.append(self.elim[i].process(x))
        y = np.array(ys)
        dth = np.diff(np.concatenate((self.ylast[:, None], y), axis=1), axis=1).T
        self.ylast = y[:, -1].copy()
        q = self.att.process(dth)
        self.i0 += self.n
        return np.array(xs), np.array(vxs), y, np.array(yps), np.array(es), q

    def run(self, n_chunks: int) -> None:
        for _ in range(n_chunks):
            self.run_chunk()


def check_fused_chain(n_chunks: int = 2, chunk_steps: int = 7200) -> None:
    """Raise ``RuntimeError`` unless :class:`FusedChain` reproduces :class:`ApiChain` bit for bit."""
    fused, api = FusedChain(chunk_steps), ApiChain(chunk_steps)
    for _ in range(n_chunks):
        fused.run_chunk()
        got = (fused.x, fused.vx, fused.y, fused.yp, fused.e, fused.qout)
        for name, a, b in zip(("x", "vx", "y", "y_paper", "eliminator", "attitude"), got, api.run_chunk()):
            if not np.array_equal(a, b):
                raise RuntimeError(f"bench: the fused chain's {name} differs from the public classes' "
                                   f"(max {np.max(np.abs(a - b))!r})")
    if not np.all(np.isfinite(fused.qout)):
        raise RuntimeError("bench: the chain's attitude is not finite")


# --- plain-Python references ----------------------------------------------------------------------


def correcting_reference(x, volts, design: CorrectingFilterDesign) -> np.ndarray:
    """Eq. 5 as printed, in plain Python (paper hysteresis rule): the slow, obvious reference.

    ``Y_n = a2 (X_n - 2 X_{n-1} + X_{n-2}) + g (X_{n-1} + Nonl(D) + Diss(D) + k5 V_{n-1})``,
    ``D = X_{n-1} - Y_{n-1}``, at rest before the first sample (``X = 0``,
    ``D = 0``). Eq. 10's amplitude is ``|D|`` at the last turning point of
    the ``D`` sequence, refined by the parabola through the three samples
    around it, and its sign that of the last increment of ``D``
    (``_kernels/correcting.py``).
    """
    if design.hysteresis != "paper":
        raise ValueError("bench.correcting_reference: the reference implements the paper rule only")
    a2, g = design.coefficients
    k1, k2, k3, k4, k5 = design.k1, design.k2, design.k3, design.k4, design.k5
    out = np.empty(len(x))
    x1 = x2 = 0.0
    v1 = 0.0
    d_hist = [0.0, 0.0, 0.0]  # D_{n-1}, D_{n-2}, D_{n-3}
    s, a = 0.0, 0.0
    for n in range(len(x)):
        d1, d2, d3 = d_hist
        inc1, inc0 = d1 - d2, d2 - d3
        if n >= 3 and inc1 * inc0 < 0.0:
            curv = d1 - 2.0 * d2 + d3
            ext = d2 - (d1 - d3) ** 2 / (8.0 * curv) if curv != 0.0 else d2
            a = abs(ext)
            s = 1.0 if inc1 > 0.0 else -1.0
        elif s == 0.0 and inc1 != 0.0:
            s = 1.0 if inc1 > 0.0 else -1.0
        bracket = x1 + kphys.nonl(d1, k1, k2) + kphys.diss(d1, s, a, 0.0, k3, k4) + k5 * v1
        y = a2 * (x[n] - 2.0 * x1 + x2) + g * bracket
        out[n] = y
        d_hist = [x[n] - y, d1, d2]
        x2, x1, v1 = x1, x[n], volts[n]
    return out


def plant_rk4_reference(sins_angle, sins_rate, volts, h: float, suspension: SuspensionParams,
                        angle0: float = 0.0, rate0: float = 0.0) -> np.ndarray:
    """RK4 of eq. 2 in plain Python, from rest: the slow, obvious reference of one plant step.

    ``delta'' = -omega0^2 (delta + Nonl + Diss + k5 V + 2 zeta delta'/omega0) - phi_sins''``
    with ``phi_sins`` the cubic Hermite interpolant of the angle and rate
    samples (as both kernels), the drive held over each step, the paper's
    hysteresis rule. ``angle0, rate0``: the block at t = 0 (the deflection
    starts at rest). A step in which ``delta'`` changes sign against the
    branch's direction is redone in two RK4 pieces split at the turning
    point (root of the cubic Hermite of ``delta'``, by bisection), where
    ``a = |delta|`` is taken. Returns ``delta`` at the ends of the steps (rad).
    """
    w0sq = suspension.omega0 ** 2
    k1, k2, k3, k4, k5 = suspension.k1, suspension.k2, suspension.k3, suspension.k4, suspension.k5
    z = 2.0 * suspension.zeta / suspension.omega0
    d, dd, s, a = 0.0, 0.0, 0.0, 0.0
    phi0, r0 = float(angle0), float(rate0)
    out = np.empty(len(volts))
    for n in range(len(volts)):
        dp, r1 = sins_angle[n] - phi0, sins_rate[n]
        pdd0 = (6.0 * dp / h - 4.0 * r0 - 2.0 * r1) / h  # second derivative of phi_sins at the start
        pddd = 6.0 * (r0 + r1 - 2.0 * dp / h) / (h * h)  # third derivative, constant over the step
        kv = k5 * volts[n]

        def acc(tau, x, v, s, a):
            f = kphys.nonl(x, k1, k2) + kphys.diss(x, s, a, 0.0, k3, k4) + kv + z * v
            return -w0sq * (x + f) - (pdd0 + pddd * tau)

        def rk4(ta, tb, x, v, s, a):
            hs, tm = tb - ta, 0.5 * (ta + tb)
            a1 = acc(ta, x, v, s, a)
            a2 = acc(tm, x + 0.5 * hs * v, v + 0.5 * hs * a1, s, a)
            a3 = acc(tm, x + 0.5 * hs * (v + 0.5 * hs * a1), v + 0.5 * hs * a2, s, a)
            a4 = acc(tb, x + hs * (v + 0.5 * hs * a2), v + hs * a3, s, a)
            return (x + hs * v + hs * hs / 6.0 * (a1 + a2 + a3),
                    v + hs / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4))

        d_new, dd_new = rk4(0.0, h, d, dd, s, a)
        if s == 0.0:
            if dd_new != 0.0:
                s = 1.0 if dd_new > 0.0 else -1.0
        elif dd_new * s < 0.0:
            g0, g1 = acc(0.0, d, dd, s, a), acc(h, d_new, dd_new, s, a)
            lo, hi = 0.0, h
            for _ in range(50):
                mid = 0.5 * (lo + hi)
                if _hermite_cubic(mid, h, dd, dd_new, g0, g1) * s > 0.0:
                    lo = mid
                else:
                    hi = mid
            d_t, dd_t = rk4(0.0, hi, d, dd, s, a)
            s, a = -s, abs(d_t)
            d_new, dd_new = rk4(hi, h, d_t, dd_t, s, a)
        d, dd, phi0, r0 = d_new, dd_new, sins_angle[n], r1
        out[n] = d
    return out


def _hermite_cubic(tau, span, f0, f1, g0, g1):
    """Cubic Hermite on ``[0, span]`` with values ``f0, f1`` and slopes ``g0, g1``, at ``tau``."""
    t = tau / span
    return ((2.0 * t - 3.0) * t * t + 1.0) * f0 + ((t - 2.0) * t + 1.0) * t * span * g0 \
        + (3.0 - 2.0 * t) * t * t * f1 + (t - 1.0) * t * t * span * g1


# --- timing -------------------------------------------------------------------------------------------


def median_time(fn, repeats: int, clock="cpu") -> float:
    """Median of ``repeats`` timed calls of ``fn`` after one untimed call (seconds).

    ``clock``: ``"cpu"`` (thread CPU time), ``"wall"``, or a callable returning seconds.
    """
    clock = _CLOCKS[clock] if isinstance(clock, str) else clock
    fn()
    times = []
    for _ in range(repeats):
        t0 = clock()
        fn()
        times.append(clock() - t0)
    return statistics.median(times)


def median_ratio(fn, n_fn: int, base_fn, n_base: int, repeats: int, clock="cpu"):
    """Per-sample cost ratio of ``fn`` (``n_fn`` samples) to ``base_fn`` (``n_base``), interleaved.

    One untimed call of each, then ``repeats`` pairs timed back to back; the
    ratio is the median of the pairs' ratios, so a change in the machine's
    load during the measurement cancels. Returns ``(ratio, ns_fn, ns_base)``
    with the medians per sample in ns.
    """
    clock = _CLOCKS[clock] if isinstance(clock, str) else clock
    fn()
    base_fn()
    ta, tb = [], []
    for _ in range(repeats):
        t0 = clock()
        fn()
        t1 = clock()
        base_fn()
        t2 = clock()
        ta.append((t1 - t0) / n_fn)
        tb.append((t2 - t1) / n_base)
    ratio = statistics.median([a / b for a, b in zip(ta, tb)])
    return ratio, statistics.median(ta) * 1e9, statistics.median(tb) * 1e9


def _check(cond: bool, what: str) -> None:
    if not cond:
        raise RuntimeError(f"bench: result check failed: {what}")


SIZES = {
    # filter samples, plant steps, chain chunks of 0.5 s, python references (filter samples, plant steps)
    False: dict(n_filter=1_440_000, n_plant=720_000, chain_chunks=20, n_ref_filter=20_000, n_ref_plant=3_000, repeats=9),
    True: dict(n_filter=360_000, n_plant=144_000, chain_chunks=4, n_ref_filter=2_000, n_ref_plant=400, repeats=7),
}


def run_bench(quick: bool = False, repeats: int | None = None, clock: str = "cpu", memory: bool | None = None,
              memory_durations_s=(60.0, 600.0)) -> dict:
    """Measure the per-sample costs and the three-axis real-time factor (see module docstring).

    Parameters
    ----------
    quick : bool
        Short inputs and fewer repeats (CI): about 20 s instead of about 2 minutes.
    repeats : int, optional
        Timed calls per measurement (median kept); default 5, or 3 when quick.
    clock : {"cpu", "wall"}
        ``time.thread_time`` or ``time.perf_counter`` for the per-sample costs.
    memory : bool, optional
        Also measure the peak resident memory of chain runs of ``memory_durations_s``
        in fresh processes (:func:`peak_memory`); default: when not quick.
    memory_durations_s : tuple of float
        Simulated durations of the memory runs (s).

    Returns
    -------
    dict
        ``ns_per_sample``, ``baseline_ns_per_sample``, ``ratios``, ``anchors_ns``,
        ``realtime_factor_3axis``, ``realtime_factor_3axis_wall``, ``chain``
        (simulated seconds, chunk), ``memory`` (if measured), ``sizes``,
        ``clock``, ``quick``, ``repeats``.
    """
    if clock not in _CLOCKS:
        raise ValueError(f"bench.clock: must be one of {sorted(_CLOCKS)}, got {clock!r}")
    tick = _CLOCKS[clock]
    sz = dict(SIZES[bool(quick)])
    reps = int(repeats) if repeats is not None else sz["repeats"]
    if reps < 1:
        raise ValueError(f"bench.repeats: must be >= 1, got {repeats!r}")
    memory = (not quick) if memory is None else bool(memory)
    ns, base = {}, {}

    # --- filters at 7.2 kHz
    x, volts = filter_input(sz["n_filter"])
    nf = x.size
    for key, form in (("correcting", "unity"), ("correcting_paper", "paper")):
        design = CorrectingFilterDesign(form=form)
        filt = CorrectingFilter(design)

        def run_filter(filt=filt):
            filt.reset()
            return filt.process(x, volts)

        ns[key] = median_time(run_filter, reps, tick) / nf * 1e9
        nr = sz["n_ref_filter"]
        ref = correcting_reference(x[:nr], volts[:nr], design)
        got = run_filter()[:nr]
        _check(np.max(np.abs(got - ref)) <= 1e-12, f"{key} vs the plain-Python eq. 5 ({np.max(np.abs(got - ref))!r} rad)")
        if key == "correcting":
            base["correcting_python"] = median_time(
                lambda: correcting_reference(x[:nr], volts[:nr], design), max(1, reps // 2), tick) / nr * 1e9
    sos = np.array(EliminatorDesign.paper().sos)
    elim = Eliminator(EliminatorDesign.paper())

    def run_elim():
        elim.reset()
        return elim.process(x)

    ns["eliminator"] = median_time(run_elim, reps, tick) / nf * 1e9
    base["scipy_sosfilt"] = median_time(lambda: signal.sosfilt(sos, x), reps, tick) / nf * 1e9
    _check(np.array_equal(run_elim(), signal.sosfilt(sos, x)), "eliminator equals scipy.signal.sosfilt bit for bit")

    # --- one plant at 72 kHz
    ang, rate, pv = plant_input(sz["n_plant"])
    npl = pv.size
    r_rest = ARCMIN * 2.0 * math.pi * 100.0  # the vibration's rate at t = 0
    for key, integ in (("plant_step_1axis", "exact"), ("plant_step_1axis_rk4", "rk4")):
        plant = Plant(PAPER_SUSPENSION, PlantSettings(integrator=integ))

        def run_plant(plant=plant):
            plant.reset(0.0, r_rest)
            return plant.step(ang, rate, pv)

        ns[key] = median_time(run_plant, reps, tick) / npl * 1e9
        nr = sz["n_ref_plant"]
        if integ == "exact":
            ref = plant_rk4_reference(ang[:nr], rate[:nr], pv[:nr], 1.0 / 72000.0, PAPER_SUSPENSION, 0.0, r_rest)
            err = np.max(np.abs(run_plant()[:nr] - ref)) / ARCSEC
            _check(err < 0.01, f"plant vs the plain-Python RK4 ({err!r} arcsec)")
            base["plant_rk4_python"] = median_time(
                lambda: plant_rk4_reference(ang[:nr], rate[:nr], pv[:nr], 1.0 / 72000.0, PAPER_SUSPENSION, 0.0, r_rest),
                max(1, reps // 2), tick) / nr * 1e9

    # --- the three-axis chain
    check_fused_chain()
    n_chunks = sz["chain_chunks"]
    fused = FusedChain()
    api = ApiChain()
    sim_s = n_chunks * fused.n * fused.h

    def run_fused():
        fused.reset()
        fused.run(n_chunks)

    def run_api():
        api.reset()
        api.run(n_chunks)

    t_cpu = median_time(run_fused, reps, time.thread_time)
    t_wall = median_time(run_fused, reps, time.perf_counter)
    steps = 3 * n_chunks * fused.n
    ns["sins_chain_per_plant_step"] = (t_cpu if clock == "cpu" else t_wall) / steps * 1e9
    base["sins_chain_api"] = median_time(run_api, max(1, reps // 2), tick) / steps * 1e9
    _check(bool(np.all(np.isfinite(fused.qout))), "chain attitude finite")

    ratios = {
        "correcting/scipy_sosfilt": ns["correcting"] / base["scipy_sosfilt"],
        "correcting_paper/scipy_sosfilt": ns["correcting_paper"] / base["scipy_sosfilt"],
        "eliminator/scipy_sosfilt": ns["eliminator"] / base["scipy_sosfilt"],
        "plant_step_1axis/scipy_sosfilt": ns["plant_step_1axis"] / base["scipy_sosfilt"],
        "plant_step_1axis/plant_step_1axis_rk4": ns["plant_step_1axis"] / ns["plant_step_1axis_rk4"],
        "sins_chain_per_plant_step/scipy_sosfilt": ns["sins_chain_per_plant_step"] / base["scipy_sosfilt"],
        "sins_chain_per_plant_step/sins_chain_api": ns["sins_chain_per_plant_step"] / base["sins_chain_api"],
        "correcting_python/correcting": base["correcting_python"] / ns["correcting"],
        "plant_rk4_python/plant_step_1axis": base["plant_rk4_python"] / ns["plant_step_1axis"],
    }
    result = {
        "ns_per_sample": ns,
        "baseline_ns_per_sample": base,
        "ratios": ratios,
        "anchors_ns": dict(ANCHORS_NS),
        "realtime_factor_3axis": sim_s / t_cpu,
        "realtime_factor_3axis_wall": sim_s / t_wall,
        "chain": {"simulated_s": sim_s, "chunk_s": fused.n * fused.h, "axes_f0_hz": list(CHAIN_F0_HZ)},
        "sizes": sz,
        "clock": clock,
        "quick": bool(quick),
        "repeats": reps,
    }
    if memory:
        result["memory"] = {f"{d:g}s": peak_memory(d) for d in memory_durations_s}
    return result


# --- memory ------------------------------------------------------------------------------------


def _peak_rss_mib() -> float:
    """The process's peak resident set size (MiB): ``VmHWM`` (Linux), else ``ru_maxrss``.

    ``VmHWM`` belongs to the process image, so it starts afresh at ``exec``;
    ``ru_maxrss`` also counts the forking parent's size before the ``exec``.
    """
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return float(line.split()[1]) / 1024.0
    except OSError:
        pass
    import resource

    # ru_maxrss is in bytes on macOS, in KiB elsewhere
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / (2.0**20 if sys.platform == "darwin" else 1024.0)


def _memory_probe(duration_s: float) -> dict:
    """Run the fused chain for ``duration_s`` in this process; peak memory figures (MiB)."""
    import tracemalloc

    chain = FusedChain()
    chain.run(1)  # compiled and loaded
    chain.reset()
    rss0 = _peak_rss_mib()
    tracemalloc.start()
    n_chunks = int(round(duration_s / (chain.n * chain.h)))
    t0 = time.perf_counter()
    chain.run(n_chunks)
    wall = time.perf_counter() - t0
    _, traced_peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return {"simulated_s": n_chunks * chain.n * chain.h, "max_rss_mib": _peak_rss_mib(),
            "max_rss_before_run_mib": rss0, "traced_peak_mib": traced_peak / 2**20, "wall_s": wall}


def peak_memory(duration_s: float) -> dict:
    """Peak memory of a three-axis chain run of ``duration_s`` simulated seconds, in a fresh process.

    Returns the process's peak resident set size (``VmHWM`` of
    ``/proc/self/status``, or ``resource.getrusage``; MiB, interpreter,
    numpy, scipy, numba and the compiled kernels included) after the run and
    before it (chain built and compiled), the peak of the Python
    allocations during the run (``tracemalloc``; numpy buffers included) and
    the run's wall time. The chain streams in 0.5 s chunks, so neither grows
    with the duration.
    """
    code = ("import json, sys; from sins_sim.benchmarking import _memory_probe; "
            f"print(json.dumps(_memory_probe({float(duration_s)!r})))")
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


# --- report ---------------------------------------------------------------------------------------


def format_table(result: dict) -> str:
    """A plain-text table of a :func:`run_bench` result."""
    ns, base, anchors = result["ns_per_sample"], result["baseline_ns_per_sample"], result["anchors_ns"]
    rows = [
        ("correcting (eq. 5, unity)", ns["correcting"], "C eq. 5", anchors["correcting_c"]),
        ("correcting_paper (eq. 5, paper)", ns["correcting_paper"], "C eq. 5", anchors["correcting_c"]),
        ("eliminator (10-pole SOS)", ns["eliminator"], "sosfilt", anchors["scipy_sosfilt"]),
        ("plant_step_1axis (exact)", ns["plant_step_1axis"], "C RK4", anchors["plant_rk4_c"]),
        ("plant_step_1axis_rk4", ns["plant_step_1axis_rk4"], "C RK4", anchors["plant_rk4_c"]),
        ("sins_chain_per_plant_step", ns["sins_chain_per_plant_step"], "", None),
    ]
    lines = [f"clock: {result['clock']}, {'quick' if result['quick'] else 'full'}, median of {result['repeats']}",
             "", f"{'kernel':34s} {'ns/sample':>10s}   {'anchor':>14s}   {'ratio':>6s}"]
    for name, val, aname, aval in rows:
        anc = f"{aname} {aval:5.1f}" if aval is not None else ""
        ratio = f"{val / aval:6.2f}" if aval is not None else ""
        lines.append(f"{name:34s} {val:10.2f}   {anc:>14s}   {ratio:>6s}")
    lines += ["", f"{'baseline (same run)':34s} {'ns/sample':>10s}"]
    for name, val in base.items():
        lines.append(f"{name:34s} {val:10.2f}")
    lines += ["", "same-run ratios:"]
    for name, val in result["ratios"].items():
        lines.append(f"  {name:48s} {val:10.3f}")
    lines += ["", f"three-axis chain: {result['realtime_factor_3axis']:.1f}x real time on one core (CPU time), "
                  f"{result['realtime_factor_3axis_wall']:.1f}x by wall clock, "
                  f"{result['chain']['simulated_s']:g} s simulated"]
    if "memory" in result:
        for key, m in result["memory"].items():
            lines.append(f"memory, {m['simulated_s']:g} s simulated: max RSS {m['max_rss_mib']:.1f} MiB "
                         f"(before the run {m['max_rss_before_run_mib']:.1f}), traced peak "
                         f"{m['traced_peak_mib']:.2f} MiB, {m['wall_s']:.1f} s wall")
    return "\n".join(lines)
