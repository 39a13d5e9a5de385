"""Simulate a lab experiment on 1 to 3 dithered channels at a recording's rates, with effects.

An experiment is what a recording (``sins_sim.io.recording``) describes:
per axis a drive voltage held between updates at ``drive_fs_hz``, the
table's (block's) angle, and a fringe counter sampled at ``fs_hz`` from
``t = 0`` with the suspensions at rest. :class:`ExperimentInputs` holds it
(built from a recording, or from the generators below); :func:`simulate_axis`
and :func:`simulate_experiment` run the channel model on it and return the
RLG angle the counter sees at each sample time (rad, not quantised);
:func:`record` quantises it and writes a recording that says nothing about
the effects or the true parameters.

The same code serves both directions: writing recordings (truth, plant at
72 kHz) and fitting them (the diagnosis, plant at the lowest multiple of the
recording's rates above ``min_plant_rate_hz``, exact integrator).

Pipeline for one axis (stages of ``sins_sim.models.effects``), on the plant
grid ``t_k = k h``, ``k = 0 .. (N - 1) R``, ``R = plant rate / fs``:

1. suspension: ``effect.suspension`` (e.g. viscous damping);
2. voltage: the drive held over each plant step (zero-order hold at
   ``drive_fs_hz``), then ``effect.voltage`` (piezo lag);
3. block: the table angle and rate, then ``effect.block`` (block mode),
   then ``+ sum_j c_ij delta_j`` (axis coupling; the other axes'
   deflections come from the previous pass, or from measured data when
   fitting one axis);
4. plant: eq. 2 from rest (``sins_sim.models.plant.Plant``); with
   ``resonance_drift`` the plant is stepped in blocks of
   ``drift_block_s`` with f0 at each block's middle; an optional ``kick``
   (a fictitious block motion only the plant sees) changes the
   suspension's state at one instant (the fitted start state of a
   recording that begins mid-operation);
5. sense: ``phi_rlg = block angle + delta``, then ``effect.sense``
   (lock-in, which needs the rate: block rate plus the finite-difference
   rate of ``delta``);
6. readout: sample at ``n / fs - delay`` (cubic Hermite between grid
   points), times the scale, plus additive disturbances.

Generators: :func:`stationary_drive`, :func:`afc_drive`, :func:`table_motion`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sins_sim import _validate as v
from sins_sim.io.recording import FORMAT, NOMINAL_KEYS, Recording
from sins_sim.models.effects import Effect, rate_from_grid
from sins_sim.models.motion import ConstantRateMotion, SampledMotion, SineMotion, StaticMotion, SumMotion, as_motion
from sins_sim.models.plant import Plant, PlantSettings
from sins_sim.models.suspension import SuspensionParams
from sins_sim.simulation.site import earth_motions

__all__ = ["ExperimentSettings", "ExperimentInputs", "simulate_axis", "simulate_experiment", "quantise_angle",
           "record", "stationary_drive", "afc_drive", "table_motion", "suspension_from_nominal",
           "nominal_from_suspension", "FIT_SETTINGS", "TRUTH_SETTINGS"]


@dataclass(frozen=True)
class ExperimentSettings:
    """Numerical settings of an experiment simulation.

    Parameters
    ----------
    plant_rate_hz : float or None
        Plant rate (Hz), a multiple of ``fs_hz`` and ``drive_fs_hz``;
        ``None``: the smallest such multiple >= ``min_plant_rate_hz``.
    min_plant_rate_hz : float
        See ``plant_rate_hz``.
    integrator, hysteresis : str
        ``sins_sim.models.plant.PlantSettings``.
    coupling_passes : int
        Passes of the fixed-point iteration for ``axis_coupling`` when all
        axes are simulated together (error ``O(c^passes)``).
    drift_block_s : float
        Block length of the piecewise-constant f0 under ``resonance_drift`` (s).
    """

    plant_rate_hz: float | None = None
    min_plant_rate_hz: float = 28000.0
    integrator: str = "exact"
    hysteresis: str = "paper"
    coupling_passes: int = 3
    drift_block_s: float = 0.02

    def __post_init__(self):
        if self.plant_rate_hz is not None:
            v.positive("experiment", "plant_rate_hz", self.plant_rate_hz)
        v.positive("experiment", "min_plant_rate_hz", self.min_plant_rate_hz)
        PlantSettings(integrator=self.integrator, hysteresis=self.hysteresis)
        if int(self.coupling_passes) != self.coupling_passes or self.coupling_passes < 1:
            raise ValueError(f"experiment.coupling_passes: must be an integer >= 1, got {self.coupling_passes!r}")
        v.positive("experiment", "drift_block_s", self.drift_block_s)


#: What the diagnosis uses: exact integrator, about 28 kHz.
FIT_SETTINGS = ExperimentSettings()
#: What recordings are written with: 72 kHz (a multiple of the usual 7.2 kHz), exact integrator.
TRUTH_SETTINGS = ExperimentSettings(min_plant_rate_hz=72000.0)


def suspension_from_nominal(entry: dict) -> SuspensionParams:
    """A ``SuspensionParams`` from a recording's nominal entry (``f0_hz, k1..k5``; ``zeta`` if present)."""
    kw = {k: float(entry[k]) for k in NOMINAL_KEYS}
    if "zeta" in entry:
        kw["zeta"] = float(entry["zeta"])
    return SuspensionParams(**kw)


def nominal_from_suspension(s: SuspensionParams) -> dict:
    """The nominal entry of a suspension (``f0_hz, k1..k5``, plus ``zeta`` when not 0)."""
    out = {"f0_hz": s.f0_hz, "k1": s.k1, "k2": s.k2, "k3": s.k3, "k4": s.k4, "k5": s.k5}
    if s.zeta:
        out["zeta"] = s.zeta
    return out


@dataclass
class _Grid:
    rate_hz: float
    r: int
    n_steps: int
    h: float
    volts: dict
    angle: dict
    rate: dict


class ExperimentInputs:
    """What an experiment consists of: sample grid, drive, table motion.

    Parameters
    ----------
    axes : sequence of str
        1 to 3 axis names.
    fs_hz : float
        Readout rate (Hz).
    n_samples : int
        Readout samples ``N`` (at ``n / fs_hz``), >= 2.
    drive_fs_hz : float
        Drive update rate, an integer multiple of ``fs_hz``.
    drive_v : ndarray, shape (N * drive_fs_hz / fs_hz, A)
        Drive voltage per update (V).
    table : dict axis -> motion, or None
        The table (block) angle per axis (``sins_sim.models.motion``
        objects); ``None`` or a missing axis: at rest.
    inertial : dict axis -> motion, or None
        The block's angle with respect to inertial space that no table
        encoder sees: the Earth's rate on a bench (``sins_sim.simulation.site``);
        added to the table's angle for the plant and the readout, never
        written as ``sins_angle``.
    """

    def __init__(self, axes, fs_hz, n_samples, drive_fs_hz, drive_v, table=None, inertial=None):
        self.axes = tuple(axes)
        if not 1 <= len(self.axes) <= 3 or len(set(self.axes)) != len(self.axes):
            raise ValueError(f"experiment.axes: must be 1 to 3 distinct names, got {axes!r}")
        self.fs_hz = v.positive("experiment", "fs_hz", fs_hz)
        self.drive_fs_hz = v.positive("experiment", "drive_fs_hz", drive_fs_hz)
        self.drive_ratio = v.integer_ratio("experiment", "drive_fs_hz", self.drive_fs_hz, self.fs_hz,
                                           "drive_fs_hz / fs_hz")
        self.n_samples = int(n_samples)
        if self.n_samples < 2:
            raise ValueError(f"experiment.n_samples: must be >= 2, got {n_samples!r}")
        drive_v = np.asarray(drive_v, dtype=np.float64)
        if drive_v.shape != (self.n_samples * self.drive_ratio, len(self.axes)):
            want = (self.n_samples * self.drive_ratio, len(self.axes))
            raise ValueError(f"experiment.drive_v: must have shape {want}, got {drive_v.shape}")
        self.drive_v = drive_v
        table = dict(table or {})
        for a in table:
            if a not in self.axes:
                raise ValueError(f"experiment.table: {a!r} is not an axis of {list(self.axes)}")
        self.table = {a: as_motion(table.get(a)) for a in self.axes}
        self.moving = {a: a in table and not isinstance(self.table[a], StaticMotion) for a in self.axes}
        inertial = dict(inertial or {})
        for a in inertial:
            if a not in self.axes:
                raise ValueError(f"experiment.inertial: {a!r} is not an axis of {list(self.axes)}")
        self.inertial = {a: as_motion(inertial.get(a)) for a in self.axes}
        self._grids = {}

    def block_angle_rate(self, axis: str, t):
        """The block's angle and rate w.r.t. inertial space about ``axis``: table plus ``inertial`` (Earth)."""
        ang, rt = self.table[axis].angle_rate(t)
        if isinstance(self.inertial[axis], StaticMotion):
            return ang, rt
        ia, ir = self.inertial[axis].angle_rate(t)
        return ang + ia, rt + ir

    @classmethod
    def from_recording(cls, rec: Recording) -> "ExperimentInputs":
        """The experiment a recording describes (table angle by cubic spline of ``sins_angle``; with
        ``meta.site`` the Earth's rate about each gyro axis, :func:`sins_sim.simulation.site.earth_motions`)."""
        table = None
        if rec.sins_angle is not None:
            table = {a: SampledMotion(rec.sins_angle[:, i], rec.sins_fs_hz) for i, a in enumerate(rec.axes)}
        inertial = None
        if rec.site is not None:
            try:
                inertial = earth_motions(rec.site, rec.axes, rec.duration_s, table)
            except ValueError as exc:
                raise ValueError(f"{rec.source}: meta.{exc}") from None
        return cls(rec.axes, rec.fs_hz, rec.n_samples, rec.drive_fs_hz, np.asarray(rec.drive_v, dtype=np.float64),
                   table, inertial)

    @property
    def duration_s(self) -> float:
        return (self.n_samples - 1) / self.fs_hz

    def time(self) -> np.ndarray:
        return np.arange(self.n_samples) / self.fs_hz

    def plant_rate(self, settings: ExperimentSettings) -> float:
        """The plant rate for these inputs (a multiple of fs and drive_fs)."""
        base = self.drive_fs_hz  # a multiple of fs
        if settings.plant_rate_hz is not None:
            v.integer_ratio("experiment", "plant_rate_hz", settings.plant_rate_hz, base, "plant_rate_hz / drive_fs_hz")
            return float(settings.plant_rate_hz)
        return base * max(1, math.ceil(settings.min_plant_rate_hz / base - 1e-9))

    def grid(self, settings: ExperimentSettings) -> _Grid:
        """Plant-grid inputs (cached per rate): held volts per step, table angle/rate per grid point."""
        rate = self.plant_rate(settings)
        if rate in self._grids:
            return self._grids[rate]
        r = int(round(rate / self.fs_hz))
        rd = int(round(rate / self.drive_fs_hz))
        n_steps = (self.n_samples - 1) * r
        h = 1.0 / rate
        k = np.arange(n_steps) // rd
        t = np.arange(n_steps + 1) * h
        volts, angle, arate = {}, {}, {}
        for i, a in enumerate(self.axes):
            volts[a] = np.ascontiguousarray(self.drive_v[k, i])
            ang, rt = self.block_angle_rate(a, t)
            angle[a] = np.ascontiguousarray(ang, dtype=np.float64)
            arate[a] = np.ascontiguousarray(rt, dtype=np.float64)
        g = _Grid(rate, r, n_steps, h, volts, angle, arate)
        self._grids[rate] = g
        return g


def _integrate(s: SuspensionParams, angle, rate, volts, settings: ExperimentSettings, h: float, plant_rate: float,
               drift: float) -> np.ndarray:
    """delta on the grid (``delta[0] = 0``), eq. 2 from rest; piecewise-constant f0 under drift."""
    plant = Plant(s, PlantSettings(rate_hz=plant_rate, hysteresis=settings.hysteresis,
                                   integrator=settings.integrator))
    plant.reset(float(angle[0]), float(rate[0]))
    n = volts.shape[0]
    delta = np.empty(n + 1)
    delta[0] = 0.0
    if drift == 0.0:
        delta[1:] = plant.step(angle[1:], rate[1:], volts)
        return delta
    block = max(1, int(round(settings.drift_block_s / h)))
    for i0 in range(0, n, block):
        i1 = min(i0 + block, n)
        f0 = s.f0_hz + drift * 0.5 * (i0 + i1) * h
        if not 0.0 < f0 < plant_rate / 8.0:
            raise ValueError(f"effects.resonance_drift.rate_hz_per_s: f0 leaves (0, plant rate / 8) at "
                             f"t = {i0 * h:.4g} s, got f0 = {f0:.6g} Hz")
        # the grid's arrays are contiguous and finite (checked once); f0 for this block only
        delta[i0 + 1:i1 + 1] = plant.step(angle[i0 + 1:i1 + 1], rate[i0 + 1:i1 + 1], volts[i0:i1], check=False,
                                          f0_hz=f0)
    return delta


def _kick(g: _Grid, index: int, d_delta: float, d_rate: float):
    """Fictitious block angle and rate that change the deflection's state by (d_delta, d_rate) at ``index``.

    Over ``T = 2`` plant steps ending at ``index``, with ``u`` going 0 to 1:
    angle ``-d_delta S(u) - d_rate T Q(u)``, ``S = 3u^2 - 2u^3`` (exact for
    the plant's cubic Hermite), ``Q = u^3 - u^4 / 2`` then ``u - 1/2``; the
    deflection relative to the real block jumps by ``d_delta`` and its rate
    by ``d_rate``, and the fictitious block then turns at a constant rate,
    which the suspension does not feel.
    """
    n = g.n_steps + 1
    span = 2.0 * g.h
    t = (np.arange(n) - (int(index) - 2)) * g.h
    u = np.clip(t / span, 0.0, None)
    lo = np.minimum(u, 1.0)
    s_ = 3.0 * lo ** 2 - 2.0 * lo ** 3
    q = np.where(u <= 1.0, lo ** 3 - 0.5 * lo ** 4, u - 0.5)
    angle = -d_delta * s_ - d_rate * span * q
    rate = -d_delta * 6.0 * lo * (1.0 - lo) / span - d_rate * s_
    return angle, rate


def _sample(phi: np.ndarray, g: _Grid, n_samples: int, fs: float, delay: float) -> np.ndarray:
    """``phi`` at ``n / fs - delay`` (grid points, or the cubic Hermite between them)."""
    if delay == 0.0:
        return phi[::g.r][:n_samples].copy()
    t = np.arange(n_samples) / fs - delay
    u = t / g.h
    idx = np.floor(u).astype(np.int64)
    before = idx < 0
    idx = np.clip(idx, 0, g.n_steps - 1)
    s = np.clip(u - idx, 0.0, 1.0)
    slope = rate_from_grid(phi, g.h) * g.h
    p0, p1 = phi[idx], phi[idx + 1]
    m0, m1 = slope[idx], slope[idx + 1]
    s2 = s * s
    s3 = s2 * s
    out = (2 * s3 - 3 * s2 + 1) * p0 + (s3 - 2 * s2 + s) * m0 + (-2 * s3 + 3 * s2) * p1 + (s3 - s2) * m1
    out[before] = phi[0]
    return out


def simulate_axis(inputs: ExperimentInputs, axis: str, suspension: SuspensionParams, effects=(),
                  settings: ExperimentSettings = FIT_SETTINGS, coupled: dict | None = None,
                  return_delta: bool = False, kick: tuple | None = None):
    """Simulate one axis of an experiment; the angle the counter sees at each sample (rad).

    Parameters
    ----------
    inputs : ExperimentInputs
    axis : str
    suspension : SuspensionParams
        The axis' suspension (before effects).
    effects : sequence of Effect
        Effects (each acts on the axes it names).
    settings : ExperimentSettings
    coupled : dict source axis -> (delta, delta_rate) on the plant grid, optional
        The other axes' deflections for ``axis_coupling`` (missing: no coupling).
    return_delta : bool
        Also return ``delta`` on the plant grid.
    kick : (index, d_delta, d_rate) or None
        Change the suspension's state at plant grid point ``index`` by
        ``d_delta`` (rad) and ``d_rate`` (rad/s): a fictitious block motion
        seen by the plant only (a smooth step of ``-d_delta`` and a smooth
        change of rate by ``-d_rate``, over the two plant steps before
        ``index``). Used to fit the unknown state of a recording that starts
        mid-operation.

    Returns
    -------
    angle : ndarray, shape (N,)
        RLG angle at the counter, ``n / fs`` (rad).
    delta : ndarray, shape (n_steps + 1,), only with ``return_delta``
    """
    if axis not in inputs.axes:
        raise ValueError(f"experiment.axis: must be one of {list(inputs.axes)}, got {axis!r}")
    for e in effects:
        if not isinstance(e, Effect):
            raise ValueError(f"experiment.effects: must be Effect objects, got {type(e).__name__}")
        e.check_axes(inputs.axes)
    g = inputs.grid(settings)
    s = suspension
    for e in effects:
        s = e.suspension(axis, s)
    volts = g.volts[axis]
    for e in effects:
        volts = e.voltage(axis, volts, g.h)
    angle, rate = g.angle[axis], g.rate[axis]
    for e in effects:
        angle, rate = e.block(axis, angle, rate, g.h)
    if coupled:
        for e in effects:
            for src, c in e.coupling(axis).items():
                if src in coupled and c != 0.0:
                    d, dr = coupled[src]
                    angle = angle + c * d
                    rate = rate + c * dr
    drift = sum(e.f0_rate_hz_per_s(axis) for e in effects)
    if kick is None:
        delta = _integrate(s, angle, rate, volts, settings, g.h, g.rate_hz, drift)
    else:
        ka, kr = _kick(g, *kick)
        delta = _integrate(s, angle + ka, rate + kr, volts, settings, g.h, g.rate_hz, drift)
    phi = angle + delta
    sensing = [e for e in effects if type(e).sense is not Effect.sense and e.acts_on(axis)]
    if sensing:
        rate_rlg = rate + rate_from_grid(delta, g.h)
        for e in sensing:
            phi = e.sense(axis, phi, rate_rlg, g.h)
    delay = sum(e.delay_s(axis) for e in effects)
    out = _sample(phi, g, inputs.n_samples, inputs.fs_hz, delay)
    scale = 1.0
    for e in effects:
        scale *= e.scale(axis)
    if scale != 1.0:
        out = out * scale
    t = None
    for e in effects:
        if type(e).additive is not Effect.additive:
            t = inputs.time() if t is None else t
            add = e.additive(axis, t)
            if add is not None:
                out = out + add
    return (out, delta) if return_delta else out


def simulate_experiment(inputs: ExperimentInputs, suspensions: dict, effects=(),
                        settings: ExperimentSettings = FIT_SETTINGS) -> dict:
    """Simulate every axis; ``{axis: angle (N,)}`` (rad).

    Axes are independent unless an effect couples them (``axis_coupling``):
    then all axes are simulated ``settings.coupling_passes`` times, each pass
    feeding the previous pass' deflections into the coupling.
    """
    for a in inputs.axes:
        if a not in suspensions:
            raise ValueError(f"experiment.suspensions: missing the axis {a!r}")
    coupled_effects = any(e.coupling(a) for e in effects for a in inputs.axes)
    passes = settings.coupling_passes if coupled_effects else 1
    g = inputs.grid(settings)
    deltas = None
    out = {}
    for _ in range(passes):
        new = {}
        for a in inputs.axes:
            out[a], d = simulate_axis(inputs, a, suspensions[a], effects, settings, coupled=deltas, return_delta=True)
            new[a] = (d, rate_from_grid(d, g.h))
        deltas = new
    return out


def quantise_angle(angle: np.ndarray, quantum_rad: float, noise_rad: float = 0.0, rng=None) -> np.ndarray:
    """Accumulated counts ``floor((angle + noise) / q)`` as int64 (docs/theory/suspension.md, "Readout")."""
    q = v.positive("readout", "quantum_rad", quantum_rad)
    sigma = v.non_negative("readout", "noise_rad", noise_rad)
    x = np.asarray(angle, dtype=np.float64)
    if sigma > 0.0:
        if not isinstance(rng, np.random.Generator):
            raise ValueError("readout.rng: a numpy.random.Generator is required when noise_rad > 0")
        x = x + sigma * rng.standard_normal(x.shape)
    return np.floor(x / q).astype(np.int64)


def record(inputs: ExperimentInputs, truth: dict, nominal: dict, quantum_rad: float, effects=(),
           settings: ExperimentSettings = TRUTH_SETTINGS, noise_rad: float = 0.0, seed: int = 0,
           experiment: str = "stationary", description: str = "", preroll_samples: int = 0,
           extra_meta: dict | None = None) -> Recording:
    """Simulate an experiment and write it as a recording.

    The header holds the *nominal* parameters and nothing about the truth or
    the effects. With ``preroll_samples > 0`` the first samples of
    ``inputs`` are simulated but not recorded (the recording starts
    mid-operation: ``initial_state = "unknown"``, the readout counted from
    the first recorded sample).

    Parameters
    ----------
    inputs : ExperimentInputs
        Drive and table motion, pre-roll included.
    truth, nominal : dict axis -> SuspensionParams
    quantum_rad, noise_rad : float
        Readout quantum and white noise before quantisation (rad).
    effects : sequence of Effect
    seed : int
        Seed of the readout noise.
    """
    angles = simulate_experiment(inputs, truth, effects, settings)
    rng = np.random.default_rng(seed)
    n0 = int(preroll_samples)
    if not 0 <= n0 <= inputs.n_samples - 2:
        raise ValueError(f"record.preroll_samples: must be in [0, N - 2], got {preroll_samples!r}")
    cols = []
    for a in inputs.axes:
        x = angles[a][n0:]
        if n0:
            x = x - x[0]
        cols.append(quantise_angle(x, quantum_rad, noise_rad, rng))
    counts = np.column_stack(cols)
    r = inputs.drive_ratio
    drive = inputs.drive_v[n0 * r:]
    meta = {"format": FORMAT, "axes": list(inputs.axes), "fs_hz": inputs.fs_hz, "drive_fs_hz": inputs.drive_fs_hz,
            "quantum_rad": float(quantum_rad), "initial_state": "unknown" if n0 else "rest",
            "experiment": experiment,
            "nominal": {a: nominal_from_suspension(nominal[a]) for a in inputs.axes},
            "description": description}
    if extra_meta:
        for k, val in extra_meta.items():
            if k in meta:
                raise ValueError(f"record.extra_meta: {k!r} is a header key of the format")
            meta[k] = val
    sins = None
    if any(inputs.moving.values()):
        meta["sins_fs_hz"] = inputs.fs_hz
        t = (np.arange(inputs.n_samples - n0) + n0) / inputs.fs_hz
        sins = np.column_stack([inputs.table[a].angle_rate(t)[0] for a in inputs.axes]).astype(np.float64)
        if n0:
            sins = sins - sins[0]
    return Recording(meta, counts, np.ascontiguousarray(drive), sins)


# --- generators ----------------------------------------------------------------------------------
def stationary_drive(suspensions: dict, axes, amplitude_rad: float, drive_fs_hz: float, n_drive: int) -> np.ndarray:
    """``V_m cos(2 pi F k / drive_fs)`` per axis at the amplitude-dependent resonance F(a) of ``suspensions``.

    F by harmonic balance and V_m by eq. 17, the drive a unit's PLL and
    amplitude control would settle on for the (nominal) suspension.
    Shape ``(n_drive, A)``.
    """
    k = np.arange(n_drive, dtype=np.float64)
    cols = []
    for a in axes:
        s = suspensions[a]
        f = s.resonance_hz(amplitude_rad)
        vm = s.drive_voltage(amplitude_rad)
        cols.append(vm * np.cos(2.0 * math.pi * np.mod(f * k / drive_fs_hz, 1.0)))
    return np.column_stack(cols)


def afc_drive(suspensions: dict, axes, amplitude_rad: float, voltage_factors, frequency_offsets_hz,
              dwell_s: float, drive_fs_hz: float, n_drive: int):
    """A stepped AFC sweep: for each voltage ``V_m * factor``, frequencies ``F(a) + offset``, each ``dwell_s``.

    The phase is continuous across steps; after the last point the sweep
    starts again. Returns ``(drive (n_drive, A), points)`` where ``points``
    lists ``{"t_s": [t0, t1], "v_m": {axis: V}, "frequency_hz": {axis: f}}``.
    """
    factors = [v.positive("afc", "voltage_factor", x) for x in voltage_factors]
    offsets = [v.finite("afc", "frequency_offset_hz", x) for x in frequency_offsets_hz]
    if not factors or not offsets:
        raise ValueError("afc: voltage_factors and frequency_offsets_hz must not be empty")
    dwell = v.positive("afc", "dwell_s", dwell_s)
    n_dwell = max(1, int(round(dwell * drive_fs_hz)))
    plan = [(fa, off) for fa in factors for off in offsets]
    idx = (np.arange(n_drive) // n_dwell) % len(plan)
    cols = []
    points = []
    for a in axes:
        s = suspensions[a]
        f_res = s.resonance_hz(amplitude_rad)
        vm = s.drive_voltage(amplitude_rad)
        f = np.array([f_res + off for _, off in plan])[idx]
        amp = np.array([vm * fa for fa, _ in plan])[idx]
        if np.any(f <= 0.0):
            raise ValueError("afc.frequency_offsets_hz: a drive frequency is not > 0")
        phase = 2.0 * math.pi * np.mod(np.concatenate(([0.0], np.cumsum(f[:-1]))) / drive_fs_hz, 1.0)
        cols.append(amp * np.cos(phase))
    for j in range(int(math.ceil(n_drive / n_dwell))):
        fa, off = plan[j % len(plan)]
        points.append({"t_s": [j * n_dwell / drive_fs_hz, min((j + 1) * n_dwell, n_drive) / drive_fs_hz],
                       "v_m": {a: suspensions[a].drive_voltage(amplitude_rad) * fa for a in axes},
                       "frequency_hz": {a: suspensions[a].resonance_hz(amplitude_rad) + off for a in axes}})
    return np.column_stack(cols), points


def table_motion(rate_rad_s: float = 0.0, sines=()):
    """Table angle ``rate t + sum_i A_i sin(2 pi f_i t + p_i)``; ``sines`` = [(A rad, f Hz, phase rad)]."""
    parts = []
    if rate_rad_s:
        parts.append(ConstantRateMotion(rate_rad_s))
    for amp, f, ph in sines:
        parts.append(SineMotion(amp, f, ph))
    if not parts:
        return StaticMotion()
    return parts[0] if len(parts) == 1 else SumMotion(tuple(parts))
