"""One dithered RLG channel end to end: drive -> suspension -> readout -> filters.

The engine connects the models (suspension, drive, plant, readout, motion)
with the filters (correcting eq. 5 in both forms, elliptic eliminator). It
streams in chunks, so memory does not grow with the duration; the result is
a pure function of (configuration, motion, duration, seed).

Time alignment (docs/theory/suspension.md, "The correcting filter (eq. 5)"): the decimated
readout lags the RLG by the anti-alias FIR's delay; eq. 5's output lags by
one more filter sample; the eliminator lags by its group delay at the
alignment frequency. ``ChannelResult.truth(name)`` is the SINS angle at the
time each output describes.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from sins_sim import _validate as v
from sins_sim._kernels import chain as kchain
from sins_sim._kernels import drive as kdrive
from sins_sim.filters.correcting import CorrectingFilter, CorrectingFilterDesign
from sins_sim.filters.eliminator import Eliminator, EliminatorDesign
from sins_sim.filters import registry as filter_registry
from sins_sim.models.drive import DriveParams, DriveSignal
from sins_sim.models.effects import EFFECTS, Effect
from sins_sim.models.motion import as_motion
from sins_sim.models.plant import Plant, PlantSettings
from sins_sim.models.readout import Decimator, Readout, ReadoutParams
from sins_sim.models.suspension import PAPER_SUSPENSION, SuspensionParams
from sins_sim.simulation.online import OnlineLoop, OnlineSpec
from sins_sim.simulation.temperature import ThermalModel

__all__ = ["EliminatorSettings", "ChannelConfig", "ChannelResult", "DriveControl", "ChannelChain",
           "simulate_channel", "FILTER_NAMES", "check_engine_effects", "check_thermal"]

#: Outputs of a channel run, in plotting order.
FILTER_NAMES = ("raw", "eliminator", "correcting", "correcting_paper")
#: The correcting filters (eq. 5) of a channel, in the order of its ``cpar`` rows: unity-DC form, then paper form.
CORRECTING_FORMS = ("correcting", "correcting_paper")


@dataclass(frozen=True)
class EliminatorSettings:
    """How a channel's eliminator is designed (docs/theory/suspension.md, "The elliptic eliminator").

    ``band_hz=None`` centres a band of ``width_hz`` on the channel's drive frequency.
    """

    band_hz: tuple | None = None
    width_hz: float = 40.0
    order: int = 5
    rp_db: float = 0.1
    rs_db: float = 60.0

    def __post_init__(self):
        v.positive("eliminator", "width_hz", self.width_hz)

    def design(self, dither_hz: float, fs_hz: float) -> EliminatorDesign:
        if self.band_hz is not None:
            return EliminatorDesign(fs_hz=fs_hz, band_hz=tuple(self.band_hz), order=self.order,
                                    rp_db=self.rp_db, rs_db=self.rs_db)
        return EliminatorDesign.centred(dither_hz, self.width_hz, fs_hz, self.order, self.rp_db, self.rs_db)


@dataclass(frozen=True)
class ChannelConfig:
    """Everything that defines one channel.

    Parameters
    ----------
    suspension : SuspensionParams
        The true suspension.
    drive : DriveParams
    plant : PlantSettings
        Integration rate and hysteresis rule of the plant.
    readout : ReadoutParams
        Quantum, noise, sampling and decimation; its input rate must equal the plant rate.
    filter_suspension : SuspensionParams or None
        What the correcting filter believes (None: the truth).
    filter_hysteresis : {"paper", "masing"}
        Hysteresis rule inside the correcting filter.
    eliminator : EliminatorSettings
    temperature : ThermalModel or None
        The unit's temperature over the mission and the suspension's temperature coefficients
        (:mod:`sins_sim.simulation.temperature`): the plant's f0 and k's follow it in blocks.
        None: the suspension stays as given.
    pll_tracking : bool
        The dither PLL follows the unit's current resonance ``F(a)`` (the drive frequency, phase
        continuous) and the correcting filters' f0 follows the drive (``f0_filter = f_drive f0_b /
        F_b(a)``, as ``filter_parameters: {f0: pll}`` at t = 0). False: drive and filters stay where
        they were at t = 0.
    online : OnlineSpec or None
        An online estimator on this channel (:mod:`sins_sim.simulation.online`), feeding the
        correcting filters when its ``apply`` is set. None: no estimator.
    """

    suspension: SuspensionParams = PAPER_SUSPENSION
    drive: DriveParams = field(default_factory=DriveParams)
    plant: PlantSettings = field(default_factory=PlantSettings)
    readout: ReadoutParams = field(default_factory=ReadoutParams)
    filter_suspension: SuspensionParams | None = None
    filter_hysteresis: str = "paper"
    eliminator: EliminatorSettings = field(default_factory=EliminatorSettings)
    temperature: ThermalModel | None = None
    pll_tracking: bool = False
    online: OnlineSpec | None = None

    def __post_init__(self):
        if self.temperature is not None and not isinstance(self.temperature, ThermalModel):
            raise ValueError(f"channel.temperature: must be a ThermalModel or None, got {self.temperature!r}")
        if not isinstance(self.pll_tracking, bool):
            raise ValueError(f"channel.pll_tracking: must be true or false, got {self.pll_tracking!r}")
        if self.online is not None and not isinstance(self.online, OnlineSpec):
            raise ValueError(f"channel.online: must be an OnlineSpec or None, got {self.online!r}")
        if abs(self.readout.input_rate_hz - self.plant.rate_hz) > 1e-9 * self.plant.rate_hz:
            raise ValueError(
                f"readout.input_rate_hz: must equal plant.rate_hz = {self.plant.rate_hz!r}, "
                f"got {self.readout.input_rate_hz!r}"
            )
        v.integer_ratio("drive", "dac_rate_hz", self.plant.rate_hz, self.drive.dac_rate_hz,
                        "plant.rate_hz / drive.dac_rate_hz")
        fs = self.readout.output_rate_hz
        f0 = (self.filter_suspension or self.suspension).f0_hz
        if fs <= 2.0 * f0:
            raise ValueError(
                f"readout.output_rate_hz: the filter rate must be > 2 x f0 = {2 * f0:.6g} Hz "
                f"(eq. 5 needs w = omega0 dT < pi), got {fs!r}"
            )
        # checks that need the resolved drive (Q > 0 at the amplitude, frequency below DAC Nyquist)
        self.drive.resolve(self.suspension)
        self.correcting_design("unity")

    @property
    def filter_rate_hz(self) -> float:
        return self.readout.output_rate_hz

    def drive_signal(self) -> DriveSignal:
        return self.drive.resolve(self.suspension)

    def correcting_design(self, form: str) -> CorrectingFilterDesign:
        s = self.filter_suspension or self.suspension
        return CorrectingFilterDesign(f0_hz=s.f0_hz, k1=s.k1, k2=s.k2, k3=s.k3, k4=s.k4, k5=s.k5,
                                      fs_hz=self.filter_rate_hz, form=form, hysteresis=self.filter_hysteresis)

    def eliminator_design(self) -> EliminatorDesign:
        return self.eliminator.design(self.drive_signal().frequency_hz, self.filter_rate_hz)

    def filter_context(self, axis: str = "x") -> filter_registry.FilterContext:
        """What a plug-in filter of this channel is built from (the parameters the filters believe)."""
        s = self.filter_suspension or self.suspension
        return filter_registry.FilterContext(f0_hz=s.f0_hz, k1=s.k1, k2=s.k2, k3=s.k3, k4=s.k4, k5=s.k5,
                                             fs_hz=self.filter_rate_hz, dither_hz=self.drive_signal().frequency_hz,
                                             hysteresis=self.filter_hysteresis, quantum_rad=self.readout.quantum_rad,
                                             axis=axis)


@dataclass
class ChannelResult:
    """Outputs of one channel at the filter rate.

    Attributes
    ----------
    t : ndarray
        Sample times of the decimated stream (s): sample k at k / fs.
    outputs : dict of ndarray
        ``raw`` (decimated readout angle), ``eliminator``, ``correcting``
        (unity-DC eq. 5), ``correcting_paper`` (eq. 5 as printed), in rad.
    delays_s : dict of float
        How late each output is relative to ``t`` (s).
    volts : ndarray
        The drive through the same anti-alias chain (V).
    drive : DriveSignal
    motion : motion object
    """

    t: np.ndarray
    outputs: dict
    delays_s: dict
    volts: np.ndarray
    drive: DriveSignal
    motion: object
    config: ChannelConfig

    def truth(self, name: str) -> np.ndarray:
        """The SINS angle at the instants output ``name`` describes (rad)."""
        angle, _ = self.motion.angle_rate(self.t - self.delays_s[name])
        return angle

    def residual(self, name: str) -> np.ndarray:
        """Output minus the time-aligned truth (rad)."""
        return self.outputs[name] - self.truth(name)

    def residual_rms(self, settle_s: float = 0.0, remove_mean: bool = False) -> dict:
        """RMS of each residual after ``settle_s`` (rad); optionally about its mean."""
        mask = self.t >= settle_s
        out = {}
        for name in self.outputs:
            r = self.residual(name)[mask]
            if remove_mean:
                r = r - r.mean()
            out[name] = float(np.sqrt(np.mean(r * r))) if r.size else math.nan
        return out


#: Amplitude-modulation schedules of :class:`DriveControl` (the target of control block ``b`` is
#: ``a_m (1 + depth u_b)``): ``random``: ``u_b`` uniform in [-1, 1] (the randomised modulation against
#: dynamic lock-in); ``steps``: a square wave of period ``modulation_period_s`` (+1 in its first half);
#: ``sine``: ``sin(2 pi t_b / modulation_period_s)``, ``t_b`` the block's end.
MODULATIONS = ("random", "steps", "sine")


@dataclass(frozen=True)
class DriveControl:
    """Amplitude control of the three drives (see module docstring).

    ``modulation`` and ``modulation_period_s`` choose the schedule of the target amplitude
    (:data:`MODULATIONS`); ``modulation_depth`` its size.
    """

    mode: str = "closed_loop"
    loop_time_s: float = 0.1
    block_cycles: int = 10
    modulation_depth: float = 0.0
    v_max_factor: float = 4.0
    modulation: str = "random"
    modulation_period_s: float = 2.0

    def __post_init__(self):
        v.choice("drive_control", "mode", self.mode, ("open_loop", "closed_loop"))
        v.choice("drive_control", "modulation", self.modulation, MODULATIONS)
        v.positive("drive_control", "modulation_period_s", self.modulation_period_s)
        v.positive("drive_control", "loop_time_s", self.loop_time_s)
        if int(self.block_cycles) != self.block_cycles or self.block_cycles < 1:
            raise ValueError(f"drive_control.block_cycles: must be an integer >= 1, got {self.block_cycles!r}")
        d = v.non_negative("drive_control", "modulation_depth", self.modulation_depth)
        if d >= 1.0:
            raise ValueError(f"drive_control.modulation_depth: must be < 1, got {d!r}")
        if v.positive("drive_control", "v_max_factor", self.v_max_factor) < 1.0:
            raise ValueError(f"drive_control.v_max_factor: must be >= 1, got {self.v_max_factor!r}")


class ChannelChain:
    """One channel's plant, readout, drive control and filters, streamed: the engine's inner loop.

    Used by the single-channel engine (open loop) and by each axis of the SINS engine.
    ``run`` advances a chunk of plant steps and returns the filter-rate outputs and, under
    ``volts``, the drive through the readout's anti-alias chain.

    Two paths give the same bits:

    * ``fused`` (the default with the exact plant integrator): per chunk one call of
      :func:`sins_sim._kernels.chain.drive_plant` and one of
      :func:`~sins_sim._kernels.chain.readout_filters` (``nogil``, so the SINS engine can run
      its three axes on threads; or it steps the three side by side, :class:`SideBySide`);
    * ``reference``: the straightforward composition of the public classes
      (:class:`~sins_sim.models.plant.Plant`, :class:`~sins_sim.models.readout.Readout`,
      :class:`~sins_sim.models.readout.Decimator`, the filters), block by block in
      Python; used for the RK4 integrator and by the tests as the reference.

    Parameters
    ----------
    cfg : ChannelConfig
    control : DriveControl
    rng : numpy.random.Generator
        Source of the readout noise (one standard normal per plant step, in order).
    rng_modulation : numpy.random.Generator, optional
        Source of the amplitude-modulation draws (one uniform per control block);
        a separate stream so that results do not depend on chunking.
    path : {"auto", "fused", "reference"}
    plugins : sequence of str
        Plug-in filters (:mod:`sins_sim.filters.registry`) run on this chain's decimated readout
        and drive after each chunk, on the same thread.
    axis : str
        The axis name given to the plug-ins, and the axis the ``effects`` act on.
    effects : sequence of Effect
        Catalogue effects (:mod:`sins_sim.models.effects`, see :class:`_EffectStages`). The
        suspension stage (viscous damping) changes the plant at construction and keeps the fused
        path; any other stage acting on ``axis`` runs the reference composition with the effect
        stages inserted (``path="fused"`` is then refused).
    deflection : bool
        Also return the deflection at the filter rate under ``deflection`` (through an anti-alias
        chain of its own, identical to the readout's and in step with it): what the SINS engine
        hands the three-axis pickoff model (:class:`~sins_sim.models.pickoff.PickoffTriad`).
    """

    def __init__(self, cfg: ChannelConfig, control: DriveControl, rng: np.random.Generator,
                 rng_modulation: np.random.Generator | None = None, path: str = "auto", plugins=(),
                 axis: str = "x", effects=(), deflection: bool = False):
        v.choice("channel", "path", path, ("auto", "fused", "reference"))
        self.cfg = cfg
        self.control = control
        self.rng = rng
        self.rng_mod = rng_modulation if rng_modulation is not None else np.random.default_rng(0)
        self.effects = check_engine_effects(effects)
        plant_suspension = cfg.suspension
        for e in self.effects:
            plant_suspension = e.suspension(axis, plant_suspension)
        self.plant = Plant(plant_suspension, cfg.plant)
        self._fx = _EffectStages.build(self.effects, axis, self.plant)
        self.readout = Readout(cfg.readout, rng)
        self.vdec = Decimator.from_readout(cfg.readout)
        self.ddec = Decimator.from_readout(cfg.readout) if deflection else None
        self.drive = cfg.drive_signal()
        self.v_m0 = self.drive.v_m
        self.r_dac = int(round(cfg.plant.rate_hz / cfg.drive.dac_rate_hz))
        self.r_dec = cfg.readout.decimation
        self.block = max(1, int(round(control.block_cycles * cfg.plant.rate_hz / self.drive.frequency_hz)))
        self.block_s_time = self.block / cfg.plant.rate_hz
        # eq. 15: amplitude time constant 2 Q / omega at the target amplitude
        self.tau = 2.0 * cfg.suspension.q_factor(cfg.drive.amplitude_rad) / (2.0 * math.pi * self.drive.frequency_hz)
        self.filters = {
            "eliminator": Eliminator(cfg.eliminator_design()),
            "correcting": CorrectingFilter(cfg.correcting_design("unity")),
            "correcting_paper": CorrectingFilter(cfg.correcting_design("paper")),
        }
        ctx = cfg.filter_context(axis) if plugins else None
        self.plugins = {name: filter_registry.build(name, ctx) for name in plugins}
        if self._fx is not None and cfg.plant.integrator != "exact":
            raise ValueError("effects: the effect stages of the engine need the exact plant integrator "
                             "(plant rate of d delta/dt), got integrator 'rk4'")
        if path == "auto":
            path = "fused" if cfg.plant.integrator == "exact" and self._fx is None else "reference"
        if path == "fused" and cfg.plant.integrator != "exact":
            raise ValueError("channel.path: the fused kernel runs the exact plant integrator only")
        if path == "fused" and self._fx is not None:
            raise ValueError(f"channel.path: the fused kernel has no effect stages; effects "
                             f"{[e.name for e in self._fx.effects]} on axis {axis!r} run on the reference path")
        self.path = path
        self._pack()
        self.dstate = np.zeros(kchain.N_DSTATE)
        self._thermal = _ThermalSchedule.build(self)
        self._online = OnlineLoop(self, cfg.online) if cfg.online is not None else None
        self.reset(0.0, 0.0)

    # -- parameters of the fused kernel -------------------------------------------------------
    def _pack(self):
        cfg, c, s = self.cfg, self.control, self.plant.suspension  # the plant's (viscous damping added)
        fp = np.zeros(kchain.N_FPAR)
        fp[kchain.P_H] = self.plant.h
        fp[kchain.P_W0SQ] = s.omega0 ** 2
        fp[kchain.P_K1:kchain.P_K5 + 1] = (s.k1, s.k2, s.k3, s.k4, s.k5)
        fp[kchain.P_Z] = 2.0 * s.zeta / s.omega0
        fp[kchain.P_FAST] = 0.25 / s.f0_hz
        fp[kchain.P_CYC_DAC] = self.drive.frequency_hz / cfg.drive.dac_rate_hz
        fp[kchain.P_PHASE] = self.drive.phase_rad
        fp[kchain.P_CYC_STEP] = self.drive.frequency_hz / cfg.plant.rate_hz
        fp[kchain.P_Q] = cfg.readout.quantum_rad
        fp[kchain.P_SIGMA] = cfg.readout.noise_rad
        fp[kchain.P_AM] = cfg.drive.amplitude_rad
        fp[kchain.P_VM0] = self.v_m0
        fp[kchain.P_TAU] = self.tau
        fp[kchain.P_KP] = self.tau / c.loop_time_s
        fp[kchain.P_BLOCK_S] = self.block_s_time
        fp[kchain.P_VMAX] = c.v_max_factor
        fp[kchain.P_DEPTH] = c.modulation_depth
        fp[kchain.P_CLOSED] = 1.0 if c.mode == "closed_loop" else 0.0
        self.fpar = fp
        self.ipar = np.array([self.r_dac, self.block, self.plant._rule, self.r_dec], dtype=np.int64)
        cp = np.zeros((2, kchain.N_CPAR))
        for f, name in enumerate(CORRECTING_FORMS):
            flt = self.filters[name]
            d = flt.design
            cp[f, kchain.C_A2], cp[f, kchain.C_G] = flt._a2, flt._g
            cp[f, kchain.C_K1:kchain.C_K1 + 5] = (d.k1, d.k2, d.k3, d.k4, d.k5)
            cp[f, kchain.C_DT] = 1.0 / d.fs_hz
            cp[f, kchain.C_FAST] = flt._fast_dt
            cp[f, kchain.C_RULE] = flt._rule
        self.cpar = cp
        self.taps = np.array(self.vdec._taps)

    def reset(self, angle0: float, rate0: float):
        """Back to rest at t = 0 with the block at ``angle0`` (rad) moving at ``rate0`` (rad/s)."""
        if self._thermal is not None:  # the t = 0 suspension, drive and filters, then their packed copies
            self._thermal.restore(self)
            self._pack()
        self.plant.reset(angle0, rate0)
        self.readout.reset()
        self.vdec.reset()
        if self.ddec is not None:
            self.ddec.reset()
        for name in CORRECTING_FORMS:
            self.filters[name].reset(0.0)
        self.filters["eliminator"].reset()
        for flt in self.plugins.values():
            flt.reset()
        d = self.dstate
        d[:] = 0.0
        d[kchain.D_VM] = self.v_m0
        d[kchain.D_TARGET] = self.cfg.drive.amplitude_rad
        d[kchain.D_LEFT] = self.block
        d[kchain.D_CARRY] = angle0
        self._blocks_done = 0
        self._chunk_n = -1
        if self._fx is not None:
            self._fx.reset(angle0, rate0)
        if getattr(self, "_online", None) is not None:  # the estimator forgets; the filters are back at t = 0
            self._online.reset(self)
            self._online._load(self, self._online.designs0)

    # -- drive state, readable on both paths --------------------------------------------------
    @property
    def v_m(self) -> float:
        """Current drive amplitude (V)."""
        return float(self.dstate[kchain.D_VM])

    @property
    def drive_hz(self) -> float:
        """Current drive frequency (Hz): the t = 0 value unless ``pll_tracking`` moved it."""
        return self._thermal.f_drive if self._thermal is not None else self.drive.frequency_hz

    @property
    def thermal(self):
        """The temperature / PLL schedule (:class:`_ThermalSchedule`), or None."""
        return self._thermal

    @property
    def online(self):
        """The online estimator loop (:class:`~sins_sim.simulation.online.OnlineLoop`), or None."""
        return self._online

    @property
    def amp_meas(self) -> float:
        """Dither amplitude measured at the last block's end (rad)."""
        return float(self.dstate[kchain.D_AMP])

    def _uniforms(self, i0: int, n: int) -> np.ndarray:
        """One draw per control block ending in steps ``i0 + 1 .. i0 + n`` (blocks end at multiples of ``block``)."""
        nb = (i0 + n) // self.block - i0 // self.block
        c = self.control
        if c.modulation_depth <= 0.0:
            return np.zeros(nb)
        if c.modulation == "random":
            return self.rng_mod.uniform(-1.0, 1.0, size=nb)
        t_end = (i0 // self.block + 1 + np.arange(nb)) * self.block_s_time  # each block's end (s)
        phase = t_end / c.modulation_period_s
        if c.modulation == "sine":
            return np.sin(2.0 * np.pi * phase)
        return np.where(phase - np.floor(phase) < 0.5, 1.0, -1.0)

    def _buffers(self, n: int):
        if self._chunk_n != n:
            m = n // self.r_dec
            self._work = tuple(np.empty(n) for _ in range(3))
            self._chunk_n = n
            self._m = m
        return self._work

    def run(self, i0: int, angle: np.ndarray, rate: np.ndarray):
        """Advance ``len(angle)`` plant steps starting at step ``i0``; return filter-rate outputs.

        ``angle`` and ``rate`` are the block's angle about the sensitive axis (rad) and its rate
        (rad/s) at the ends of the steps; ``len(angle)`` must be a multiple of the decimation.
        Returns a dict of ``raw``, ``eliminator``, ``correcting``, ``correcting_paper`` and
        ``volts`` (filter rate), and the plant-rate deflection under ``delta``.
        """
        n = angle.shape[0]
        if n % self.r_dec:
            raise ValueError(f"channel.chunk: must be a multiple of the decimation {self.r_dec}, got {n}")
        if self._fx is None and self.path == "fused":
            out = self.run_kernel(i0, angle, rate)
            self.check_chunk(out)
            return out
        if self._online is not None:
            return self._online.run(self, i0, angle, rate,
                                    lambda k0, a, r: self._in_blocks(k0, a, r, self._run_python))
        return self._in_blocks(i0, angle, rate, self._run_python)

    def _run_python(self, i0: int, angle: np.ndarray, rate: np.ndarray):
        uniforms = self._uniforms(i0, angle.shape[0])
        if self._fx is not None:
            return self._run_effects(i0, angle, rate, uniforms)
        return self._run_reference(i0, angle, rate, uniforms)

    def _in_blocks(self, i0: int, angle: np.ndarray, rate: np.ndarray, fn):
        """``fn(i0, angle, rate)`` over the chunk, split at the temperature / PLL blocks (if any).

        Each block's parameters are loaded (:meth:`_ThermalSchedule.enter`) before the piece of
        the chunk inside it runs; blocks are counted from step 0, so results do not depend on
        chunking. The pieces' outputs are concatenated.
        """
        th = self._thermal
        if th is None or angle.shape[0] == 0:
            return fn(i0, angle, rate)
        if i0 % self.r_dec:
            raise ValueError(f"channel.chunk: with a temperature profile or PLL tracking a chunk must start at a "
                             f"multiple of the decimation {self.r_dec}, got step {i0}")
        n = angle.shape[0]
        pieces = []
        j = 0
        while j < n:
            b = (i0 + j) // th.block
            j1 = min(n, (b + 1) * th.block - i0)
            th.enter(self, b)
            out = fn(i0 + j, angle[j:j1], rate[j:j1])
            out["delta"] = np.array(out["delta"])  # the fused path's work buffer is reused by the next piece
            pieces.append(out)
            j = j1
        if len(pieces) == 1:
            return pieces[0]
        return {k: np.concatenate([p[k] for p in pieces]) for k in pieces[0]}

    def run_kernel(self, i0: int, angle: np.ndarray, rate: np.ndarray, uniforms: np.ndarray | None = None):
        """The fused kernel over one chunk, without the Python-side warning checks.

        Thread-safe across chains (each chain owns its state and random streams; the kernel
        releases the GIL). Call :meth:`check_chunk` on the result afterwards, in the thread
        that collects warnings. With a temperature profile or PLL tracking the chunk runs as one
        kernel call per parameter block (``fpar`` and ``cpar`` updated between the calls); with an
        online estimator, in pieces that end at its updates.
        """
        if self._online is not None and uniforms is None:
            return self._online.run(self, i0, angle, rate, self._kernel_blocks)
        return self._kernel_blocks(i0, angle, rate, uniforms)

    def _kernel_blocks(self, i0: int, angle: np.ndarray, rate: np.ndarray, uniforms: np.ndarray | None = None):
        if self._thermal is None:
            return self._kernel_once(i0, angle, rate, uniforms)
        if uniforms is None:
            return self._in_blocks(i0, angle, rate, self._kernel_once)
        parts = np.asarray(uniforms)

        def with_given(k0, a, r):  # hand each piece the draws of the blocks that end inside it
            nonlocal parts
            nb = (k0 + a.shape[0]) // self.block - k0 // self.block
            u, parts = parts[:nb], parts[nb:]
            return self._kernel_once(k0, a, r, u)

        return self._in_blocks(i0, angle, rate, with_given)

    def _kernel_once(self, i0: int, angle: np.ndarray, rate: np.ndarray, uniforms: np.ndarray | None = None):
        n = angle.shape[0]
        noise, uniforms = self._kernel_draws(i0, n, uniforms)
        delta, volts, feed = self._buffers(n)
        angle = np.ascontiguousarray(angle)
        p = self.plant
        kchain.drive_plant(i0, angle, np.ascontiguousarray(rate), uniforms, self.fpar, self.ipar, self.dstate,
                           p.state, p.hyst, p.stack, delta, volts)
        return self._kernel_readout(angle, noise, delta, volts, feed)

    def _kernel_draws(self, i0: int, n: int, uniforms: np.ndarray | None = None):
        """The chunk's random draws, in stream order: readout noise and amplitude-modulation uniforms."""
        if uniforms is None:
            uniforms = self._uniforms(i0, n)
        sigma = self.cfg.readout.noise_rad
        noise = self.rng.standard_normal(n) if sigma > 0.0 else np.zeros(0)
        return noise, uniforms

    def _kernel_readout(self, angle, noise, delta, volts, feed) -> dict:
        """Readout and filters of a chunk whose deflection and drive are in ``delta`` and ``volts``."""
        m = angle.shape[0] // self.r_dec
        out = {k: np.empty(m) for k in ("raw", "volts", "correcting", "correcting_paper", "eliminator")}
        el = self.filters["eliminator"]
        kchain.readout_filters(angle, noise, self.fpar, self.ipar, self.dstate, self.taps,
                               self.readout.decimator._hist, self.vdec._hist, self.cpar,
                               self._fstate(), self._fhyst(), self._fstack(), el._sos, el._zi,
                               delta, volts, feed, out["raw"], out["volts"], out["correcting"],
                               out["correcting_paper"], out["eliminator"])
        self._sync_filters()
        self._run_plugins(out)
        self._keep_deflection(out, delta)
        return out

    def _keep_deflection(self, out, delta) -> None:
        """``out["delta"]`` (plant rate) and, when asked for, ``out["deflection"]`` (filter rate, a fresh array)."""
        out["delta"] = delta
        if self.ddec is not None:
            out["deflection"] = self.ddec.process(delta)

    def _run_plugins(self, out) -> None:
        for name, flt in self.plugins.items():
            out[name] = np.asarray(flt.process(out["raw"], out["volts"]), dtype=np.float64)

    def check_chunk(self, out) -> None:
        """Raise the plant's and the correcting filters' once-per-run warnings for a fused chunk."""
        self.plant._check_regime()
        self.filters["correcting"].check_output(out["raw"], out["correcting"])
        self.filters["correcting_paper"].check_output(out["raw"], out["correcting_paper"])
        for name, flt in self.plugins.items():
            if hasattr(flt, "check_output"):
                flt.check_output(out["raw"], out[name])

    # the correcting filters' state lives in the filter objects (so warnings and resets work on
    # both paths); the fused kernel reads and writes stacked copies
    def _fstate(self):
        self._fs = np.stack([self.filters["correcting"].state, self.filters["correcting_paper"].state])
        return self._fs

    def _fhyst(self):
        self._fh = np.stack([self.filters["correcting"].hyst, self.filters["correcting_paper"].hyst])
        return self._fh

    def _fstack(self):
        self._fk = np.stack([self.filters["correcting"].stack, self.filters["correcting_paper"].stack])
        return self._fk

    def _sync_filters(self):
        for f, name in enumerate(CORRECTING_FORMS):
            flt = self.filters[name]
            flt.state[:] = self._fs[f]
            flt.hyst[:] = self._fh[f]
            flt.stack[:] = self._fk[f]

    def _drive_blocks(self, i0: int, n: int, uniforms: np.ndarray, plant_piece):
        """The amplitude-control blocks of a chunk on the Python paths (same arithmetic as the kernel).

        Per block: the DAC cosine held over ``r_dac`` steps (``drive.dac_cosine``), the plant over
        the block's piece (``plant_piece(j, m, volts)`` writes the deflection of steps ``j .. j+m``),
        the synchronous detector (``drive.demod_accumulate``) and, at the block's end, the PI
        amplitude loop (``chain.end_block``). Returns the deflection and the commanded voltage.
        """
        d = self.dstate
        delta = np.empty(n)
        volts = np.empty(n)
        used = 0
        j = 0
        while j < n:
            left = int(d[kchain.D_LEFT])
            m = min(left, n - j)
            vv = np.empty(m)
            kdrive.dac_cosine(i0 + j, self.r_dac, self.fpar[kchain.P_CYC_DAC], self.fpar[kchain.P_PHASE],
                              float(d[kchain.D_VM]), vv)
            plant_piece(j, m, vv, delta)
            volts[j:j + m] = vv
            acc = d[kchain.D_ACC:kchain.D_ACC + 3]
            kdrive.demod_accumulate(delta[j:j + m], i0 + j, self.fpar[kchain.P_CYC_STEP], self.block - left,
                                    self.block, acc, self.fpar[kchain.P_DPHASE])
            left -= m
            j += m
            if left == 0:
                kchain.end_block(self.fpar, d, uniforms[used])
                used += 1
                left = self.block
            d[kchain.D_LEFT] = left
        return delta, volts

    def _readout_and_filters(self, feed: np.ndarray, volts: np.ndarray, delta: np.ndarray) -> dict:
        """Quantise, decimate and filter the angle the counter sees (``feed``, grid points of the chunk)."""
        _, x = self.readout.process(feed)
        vx = self.vdec.process(volts)
        out = {"raw": x}
        out["eliminator"] = self.filters["eliminator"].process(x)
        out["correcting"] = self.filters["correcting"].process(x, vx)
        out["correcting_paper"] = self.filters["correcting_paper"].process(x, vx)
        out["volts"] = vx
        self._run_plugins(out)
        self._keep_deflection(out, delta)
        return out

    def _run_reference(self, i0: int, angle: np.ndarray, rate: np.ndarray, uniforms: np.ndarray):
        """The chain composed of the public classes, block by block (same arithmetic as the kernel)."""
        def piece(j, m, vv, delta):
            delta[j:j + m] = self.plant.step(angle[j:j + m], rate[j:j + m], vv, check=False)

        delta, volts = self._drive_blocks(i0, angle.shape[0], uniforms, piece)
        d = self.dstate
        phi = angle + delta
        feed = np.concatenate(([d[kchain.D_CARRY]], phi[:-1]))
        d[kchain.D_CARRY] = float(phi[-1])
        return self._readout_and_filters(feed, volts, delta)

    def _run_effects(self, i0: int, angle: np.ndarray, rate: np.ndarray, uniforms: np.ndarray):
        """:meth:`_run_reference` with the effect stages inserted (:class:`_EffectStages`).

        Stages in the order of the experiment simulator (``sins_sim.simulation.experiment``): block
        (block mode) on the block's angle and rate; per amplitude-control block the commanded DAC
        voltage, then voltage (piezo lag) into the plant, which runs in drift blocks under
        resonance drift and returns ``d delta/dt`` too; sense (lock-in) on ``phi_rlg = block +
        delta`` with the RLG rate ``block rate + d delta/dt``; readout (delay, scale) on the angle
        the counter sees, which is then quantised, filtered and decimated as on the reference path.
        The drive control and the filters see the commanded voltage (what the electronics know).

        Extra outputs at the plant rate: ``sensed`` (the angle the counter sees at grid points
        ``i0 .. i0 + n - 1``, before quantisation: delay and scale included, rad) and
        ``lock_in_error`` (``e = phi_meas - phi_rlg`` at ``i0 + 1 .. i0 + n``, rad).
        """
        fx = self._fx
        n = angle.shape[0]
        angle, rate = fx.block(angle, rate)
        ddelta = np.empty(n)

        def piece(j, m, vv, delta):
            fx.plant_run(self.plant, i0 + j, angle[j:j + m], rate[j:j + m], fx.voltage(vv), delta[j:j + m],
                         ddelta[j:j + m])

        delta, volts = self._drive_blocks(i0, n, uniforms, piece)
        d = self.dstate
        self.plant._check_regime()
        phi_meas, rate_meas, err = fx.sense(angle + delta, rate + ddelta)
        feed = fx.readout(i0, phi_meas, rate_meas)
        d[kchain.D_CARRY] = float(phi_meas[-1]) if n else d[kchain.D_CARRY]
        out = self._readout_and_filters(feed, volts, delta)
        out["sensed"] = feed
        out["lock_in_error"] = err
        return out


def check_engine_effects(effects) -> tuple:
    """The effects a SINS engine can run, as a tuple; one line naming the rule otherwise.

    Catalogue effects only (:data:`sins_sim.models.effects.EFFECTS`; the off-catalogue disturbances
    exist for the blind evaluation of recordings). ``axis_coupling`` is refused as an effect: in a
    mission the axes couple through the block as a body (an IMU ``block:`` section,
    :mod:`sins_sim.models.block`), of which ``axis_coupling`` is the cross-axis part well above the
    isolator modes (:func:`~sins_sim.models.block.free_block_coupling`;
    :func:`~sins_sim.models.block.inertia_for_coupling` turns a diagnosed set of coefficients into the
    block's products of inertia). Running the effect's bare kinematic coupling as well would count the
    coupling twice with a block, and without one it is not a body: it moves the block without a
    reaction.
    """
    if effects is None:
        return ()
    if isinstance(effects, Effect) or not isinstance(effects, (tuple, list)):
        raise ValueError(f"effects: must be a list of catalogue Effect objects, got {effects!r}")
    out = []
    for i, e in enumerate(effects):
        if not isinstance(e, Effect) or EFFECTS.get(e.name) is not type(e):
            raise ValueError(f"effects[{i}]: must be a catalogue effect ({', '.join(EFFECTS)}), got {e!r}")
        if e.name == "axis_coupling":
            raise ValueError("effects[%d]: axis_coupling is not a mission effect: in a mission the axes couple "
                             "through the block as a body (an IMU block: section, e.g. configs/isolated-block.yaml), "
                             "whose cross-axis terms above the isolator modes are axis_coupling's coefficients; "
                             "models.block.inertia_for_coupling gives the products of inertia that reproduce a set "
                             "(simulate-recording runs the effect itself)" % i)
        out.append(e)
    return tuple(out)


class _EffectStages:
    """The streaming state of the effects acting on one axis of a :class:`ChannelChain`.

    Each stage does what ``sins_sim.simulation.experiment.simulate_axis`` does on a whole
    recording, chunk by chunk with its state carried (``Effect.voltage_stream``,
    ``block_stream``, ``sense_stream``; the plant's own ``d delta/dt`` instead of a finite
    difference of ``delta``, which would need the next chunk):

    * voltage: piezo lags in order, each with its ``V_eff``;
    * block: block modes in order, each with its mode state;
    * plant: under ``resonance_drift`` the plant steps in blocks of ``drift_block_s`` (the
      experiment's default, 0.02 s) counted from t = 0, with f0 at each block's middle
      (``f0 + rate t_mid``); the drive stays at its frequency, as a recording's drive does;
    * sense: lock-ins in order, each on the previous one's output with the RLG rate;
    * readout: the angle the counter sees at ``t - delay`` (cubic Hermite between grid points with
      the sensed angle's rate, the rest angle before t = 0), times the product of the scales.
    """

    DRIFT_BLOCK_S = 0.02

    def __init__(self, effects, axis, plant):
        self.effects = tuple(effects)
        self.axis = axis
        self.h = plant.h
        self.base = plant.suspension
        self.lags = [e for e in effects if e.name == "piezo_lag" and e.acts_on(axis)]
        self.modes = [e for e in effects if e.name == "block_mode" and e.acts_on(axis)]
        self.locks = [e for e in effects if e.name == "lock_in" and e.acts_on(axis)]
        self.drift = sum(e.f0_rate_hz_per_s(axis) for e in effects)
        self.delay = sum(e.delay_s(axis) for e in effects)
        self.scale = 1.0
        for e in effects:
            self.scale *= e.scale(axis)
        self.drift_block = max(1, int(round(self.DRIFT_BLOCK_S / self.h)))
        self.plant_rate = 1.0 / self.h
        self.n_hist = int(math.ceil(self.delay / self.h)) + 3

    @classmethod
    def build(cls, effects, axis, plant):
        """The stages, or None when no effect beyond the suspension stage acts on ``axis``."""
        acting = [e for e in effects if e.acts_on(axis) and e.stage not in ("suspension",)]
        return cls(acting, axis, plant) if acting else None

    def reset(self, angle0, rate0):
        self.lag_state = [np.zeros(1) for _ in self.lags]
        self.mode_state = [np.array([angle0, rate0, angle0, rate0], dtype=np.float64) for _ in self.modes]
        self.lock_state = [np.array([angle0, rate0, 0.0]) for _ in self.locks]
        self.rest = float(angle0)
        # sensed angle and rate at grid points hist_g0 .. (the last: the chunk's start)
        self.hist_phi = np.array([float(angle0)])
        self.hist_rate = np.array([float(rate0)])
        self.hist_g0 = 0

    def voltage(self, volts):
        for e, st in zip(self.lags, self.lag_state):
            volts = e.voltage_stream(self.axis, volts, self.h, st)
        return np.ascontiguousarray(volts)

    def block(self, angle, rate):
        for e, st in zip(self.modes, self.mode_state):
            angle, rate = e.block_stream(self.axis, angle, rate, self.h, st)
        return np.ascontiguousarray(angle), np.ascontiguousarray(rate)

    def plant_run(self, plant, g0, angle, rate, volts, out_delta, out_ddelta):
        """Steps ``g0 .. g0 + len - 1`` of the plant (drift blocks counted from step 0)."""
        n = volts.shape[0]
        j = 0
        while j < n:
            if self.drift == 0.0:
                j1, s = n, self.base
            else:
                b = (g0 + j) // self.drift_block
                j1 = min(n, (b + 1) * self.drift_block - g0)
                f0 = self.base.f0_hz + self.drift * 0.5 * (2 * b + 1) * self.drift_block * self.h
                if not 0.0 < f0 < self.plant_rate / 8.0:
                    raise ValueError(f"effects.resonance_drift.rate_hz_per_s: f0 leaves (0, plant rate / 8) at "
                                     f"t = {(g0 + j) * self.h:.4g} s, got f0 = {f0:.6g} Hz")
                s = self.base.replace(f0_hz=f0)
            w0 = s.omega0
            kchain.plant_run_rate(angle[j:j1], rate[j:j1], volts[j:j1], self.h, w0 * w0, s.k1, s.k2, s.k3, s.k4,
                                  s.k5, 2.0 * s.zeta / w0, plant._rule, plant._fast_dt, plant.state, plant.hyst,
                                  plant.stack, out_delta[j:j1], out_ddelta[j:j1])
            j = j1

    def sense(self, phi, rate):
        err = np.zeros_like(phi)
        for e, st in zip(self.locks, self.lock_state):
            phi, de, dr = e.sense_stream(self.axis, phi, rate, self.h, st)
            err = err + de
            rate = rate + dr
        return phi, rate, err

    def readout(self, g0, phi, rate):
        """The counter's input at grid points ``g0 .. g0 + n - 1`` (``phi``: grid ``g0 + 1 .. g0 + n``)."""
        n = phi.shape[0]
        p = np.concatenate((self.hist_phi, phi))
        r = np.concatenate((self.hist_rate, rate))
        base = self.hist_g0
        if self.delay == 0.0:
            out = p[g0 - base:g0 - base + n].copy()
        else:
            u = np.arange(g0, g0 + n) - self.delay / self.h
            idx = np.floor(u).astype(np.int64)
            before = idx < 0
            idx = np.maximum(idx, base)
            s = np.clip(u - idx, 0.0, 1.0)
            k = idx - base
            p0, p1 = p[k], p[k + 1]
            m0, m1 = r[k] * self.h, r[k + 1] * self.h
            s2 = s * s
            s3 = s2 * s
            out = (2 * s3 - 3 * s2 + 1) * p0 + (s3 - 2 * s2 + s) * m0 + (-2 * s3 + 3 * s2) * p1 + (s3 - s2) * m1
            out[before] = self.rest
        keep = min(self.n_hist, p.shape[0])
        self.hist_phi = p[-keep:].copy()
        self.hist_rate = r[-keep:].copy()
        self.hist_g0 = base + p.shape[0] - keep
        return out * self.scale if self.scale != 1.0 else out


class _ThermalSchedule:
    """The plant, drive and filter parameters of one chain over the mission, block by block.

    Blocks of ``block`` plant steps (``ThermalModel.update_s`` rounded to whole multiples of the
    decimation and the DAC period; 0.02 s under resonance drift alone) are counted from step 0.
    Entering block ``b`` (:meth:`enter`, before any step of it runs):

    * the plant gets the suspension at the temperature of the block's middle
      (:meth:`ThermalModel.suspension_at`: ``p (1 + c_p (T - T_ref))``): ``Plant.suspension``
      (reference path), ``fpar`` (fused kernel), the effect stages' base (their resonance drift
      adds on top);
    * with ``pll_tracking`` the drive moves to the resonance the plant has at the block's middle,
      ``F(a_m)`` by harmonic balance (eq. 9, :meth:`SuspensionParams.resonance_hz`, as
      ``DriveParams.resolve`` at t = 0; temperature and resonance drift both included). The PLL is
      ideal: locked at every block, no loop dynamics. The DAC cosine and the synchronous detector
      keep their instantaneous phase at the block's first sample (``phase += 2 pi (frac(c_old k) -
      frac(c_new k))``, ``c`` the cycles per DAC sample or per plant step, ``k`` the absolute
      index), so the waveform is continuous. Both correcting filters move their f0 with the drive,
      ``f0_filter = f0_filter(0) f_drive / f_drive(0)``: the PLL inversion
      ``f_drive f0_b / F_b(a)`` of :mod:`sins_sim.config.filter_params` with the believed k1, k2
      held (for ``f0: pll`` the same number; for ``unit`` and ``given`` the t = 0 value carried
      along). The eliminator (a 40 Hz-wide stop band) and plug-in filters keep their t = 0 design.

    Without tracking the drive frequency and the filters stay at their t = 0 values.
    """

    def __init__(self, chain: "ChannelChain"):
        cfg = chain.cfg
        self.model = cfg.temperature
        self.track = cfg.pll_tracking
        self.drift = chain._fx.drift if chain._fx is not None else 0.0
        self.base = chain.plant.suspension
        self.h = chain.plant.h
        self.r_dac = chain.r_dac
        unit = chain.r_dec * chain.r_dac // math.gcd(chain.r_dec, chain.r_dac)
        upd = self.model.update_s if self.model is not None else _EffectStages.DRIFT_BLOCK_S
        self.block = unit * max(1, int(round(upd / (unit * self.h))))
        self.a_m = cfg.drive.amplitude_rad
        self.dac_rate = cfg.drive.dac_rate_hz
        self.plant_rate = cfg.plant.rate_hz
        self.f_drive0 = chain.drive.frequency_hz
        self.designs0 = {name: chain.filters[name].design for name in CORRECTING_FORMS}
        self.history = None  # a list of (block, t_mid_s, temp_k, plant f0_hz, drive_hz, filter f0_hz) when set
        self.filters_follow_drive = True  # False while an online estimator feeds the filters
        self.loaded = -1
        self.f_drive = self.f_drive0
        self.temp_k = self.model.profile.at(0.0) if self.model is not None else math.nan

    @classmethod
    def build(cls, chain):
        cfg = chain.cfg
        drift = chain._fx.drift if chain._fx is not None else 0.0
        if cfg.temperature is None and not (cfg.pll_tracking and drift != 0.0):
            return None
        return cls(chain)

    @property
    def filter_f0_hz(self) -> float:
        return self.designs0["correcting"].f0_hz * (self.f_drive / self.f_drive0)

    def restore(self, chain):
        """The t = 0 suspension, drive and filters (``ChannelChain.reset`` packs them again)."""
        self._set_plant(chain, self.base, pack=False)
        for name in CORRECTING_FORMS:
            self._set_filter(chain.filters[name], self.designs0[name])
        self.loaded = -1
        self.f_drive = self.f_drive0
        if self.history is not None:
            self.history = []

    def plan(self, b: int) -> tuple:
        """Block ``b``'s ``(t_mid_s, temp_k, suspension, f_lock_hz)``: the time and temperature of its middle, the
        plant's suspension there and, with tracking, the resonance ``F(a_m)`` the PLL locks to on a rigid fixture
        (resonance drift included; None without tracking). Nothing is loaded."""
        t_mid = (b + 0.5) * self.block * self.h
        temp = self.model.profile.at(t_mid) if self.model is not None else math.nan
        s = self.model.suspension_at(self.base, temp) if self.model is not None else self.base
        f = None
        if self.track:
            now = s if self.drift == 0.0 else s.replace(f0_hz=s.f0_hz + self.drift * t_mid)
            f = now.resonance_hz(self.a_m)
        return t_mid, temp, s, f

    def enter(self, chain, b: int, drive_hz: float | None = None) -> None:
        """Load block ``b``'s parameters (a no-op when they are loaded).

        ``drive_hz``: with tracking, where the PLL locks instead of the rigid-fixture ``F(a_m)`` of :meth:`plan`
        (on a block on isolators: the coupled dither mode, :class:`~sins_sim.simulation.unit.SideBySide`)."""
        if b == self.loaded:
            return
        t_mid, temp, s, f = self.plan(b)
        if self.model is not None:
            self.temp_k = temp
        self._set_plant(chain, s)
        if self.track:
            f = f if drive_hz is None else float(drive_hz)
            if f != self.f_drive:
                self._set_drive(chain, b * self.block, f)
        self.loaded = b
        if self.history is not None:
            self.history.append((b, t_mid, self.temp_k, s.f0_hz, self.f_drive, self.filter_f0_hz))

    @staticmethod
    def _set_filter(flt, design):
        flt.design = design
        flt._a2, flt._g = design.coefficients
        flt._fast_dt = 0.25 / design.f0_hz

    def _set_plant(self, chain, s, pack: bool = True):
        p = chain.plant
        if p.suspension == s and pack:
            return
        p.suspension = s
        p._fast_dt = 0.25 / s.f0_hz
        if chain._fx is not None:
            chain._fx.base = s
        if pack:
            fp = chain.fpar
            fp[kchain.P_W0SQ] = s.omega0 ** 2
            fp[kchain.P_K1:kchain.P_K5 + 1] = (s.k1, s.k2, s.k3, s.k4, s.k5)
            fp[kchain.P_Z] = 2.0 * s.zeta / s.omega0
            fp[kchain.P_FAST] = 0.25 / s.f0_hz

    def _set_drive(self, chain, i_b: int, f: float):
        """Drive at ``f`` from plant step ``i_b`` on (a multiple of the DAC period), phase continuous."""
        fp = chain.fpar
        c_dac, c_step = f / self.dac_rate, f / self.plant_rate
        k = i_b // self.r_dac  # the first DAC sample of the block
        fp[kchain.P_PHASE] = _wrapped(fp[kchain.P_PHASE] + 2.0 * math.pi * (_frac(fp[kchain.P_CYC_DAC] * k)
                                                                            - _frac(c_dac * k)))
        k = i_b + 1  # the detector's first sample of the block (delta at the end of step i_b)
        fp[kchain.P_DPHASE] = _wrapped(fp[kchain.P_DPHASE] + 2.0 * math.pi * (_frac(fp[kchain.P_CYC_STEP] * k)
                                                                              - _frac(c_step * k)))
        fp[kchain.P_CYC_DAC] = c_dac
        fp[kchain.P_CYC_STEP] = c_step
        self.f_drive = f
        if not self.filters_follow_drive:
            return
        ratio = f / self.f_drive0
        for row, name in enumerate(CORRECTING_FORMS):
            d0 = self.designs0[name]
            flt = chain.filters[name]
            self._set_filter(flt, dataclasses.replace(d0, f0_hz=d0.f0_hz * ratio))
            chain.cpar[row, kchain.C_A2], chain.cpar[row, kchain.C_G] = flt._a2, flt._g
            chain.cpar[row, kchain.C_FAST] = flt._fast_dt


def _frac(x: float) -> float:
    return x - math.floor(x)


def _wrapped(phase: float) -> float:
    return phase - 2.0 * math.pi * math.floor(phase / (2.0 * math.pi))


def check_thermal(cfg: ChannelConfig, duration_s: float, where: str = "temperature") -> None:
    """A channel's temperature profile stays physical over ``duration_s``; one line naming the key otherwise.

    At the profile's coldest and hottest points: the suspension's own ranges, the plant's steps per
    dither period, the drive (Q in range, the voltage a piezo takes) and, with PLL tracking, the
    correcting filter's f0 below the filter Nyquist (eq. 5 needs ``w = omega0 dT < pi``).
    """
    from sins_sim.models.plant import check_resolution

    model = cfg.temperature
    if model is None:
        return
    for s in model.check(cfg.suspension, duration_s, where):
        try:
            check_resolution(s, cfg.plant.rate_hz)
            cfg.drive.resolve(s)
            if cfg.pll_tracking:
                d0 = cfg.correcting_design("unity")
                ratio = s.resonance_hz(cfg.drive.amplitude_rad) / cfg.drive_signal().frequency_hz
                dataclasses.replace(d0, f0_hz=d0.f0_hz * ratio)
        except ValueError as exc:
            raise ValueError(f"{where}: at f0 = {s.f0_hz:.6g} Hz (the profile's extreme): {exc}") from None


def simulate_channel(config: ChannelConfig, duration_s: float, motion=None, seed: int = 0,
                     align_hz: float = 0.0, chunk_steps: int = 72000, progress=None, plugins=()) -> ChannelResult:
    """Simulate one channel from rest for ``duration_s`` seconds.

    Parameters
    ----------
    config : ChannelConfig
    duration_s : float
        Length of the run (s), > 0.
    motion : None, motion object or callable
        Block angle about the sensitive axis (``sins_sim.models.motion``).
    seed : int
        Seed of the readout noise (the only random element of a channel).
    align_hz : float
        Frequency at which the eliminator's group delay is taken for alignment.
    chunk_steps : int
        Plant steps per chunk (memory bound; results do not depend on it).
    progress : callable(done_fraction) or None
    plugins : sequence of str
        Plug-in filters (:mod:`sins_sim.filters.registry`) to run beside the built-in ones;
        their outputs and delays appear in the result under their names.
    """
    duration_s = v.positive("run", "duration_s", duration_s)
    plugins = tuple(dict.fromkeys(p for p in plugins if p not in FILTER_NAMES))
    v.non_negative("run", "align_hz", align_hz)
    motion = as_motion(motion)
    fs = config.filter_rate_hz
    r_dec = config.readout.decimation
    n_out = int(math.floor(duration_s * fs + 1e-9))
    n_steps = n_out * r_dec
    if n_out < 4:
        raise ValueError(f"run.duration_s: must cover at least 4 filter samples, got {duration_s!r}")
    chunk_steps = max(r_dec, (int(chunk_steps) // r_dec) * r_dec)
    # open loop: V_m from eq. 17 at the amplitude-dependent resonance, never changed
    chain = ChannelChain(config, DriveControl(mode="open_loop"), np.random.default_rng(seed), plugins=plugins)
    h = chain.plant.h
    phi0, rate0 = motion.angle_rate(np.zeros(1))
    chain.reset(float(phi0[0]), float(rate0[0]))
    names = FILTER_NAMES + plugins + ("volts",)
    pieces = {name: [] for name in names}
    for i0 in range(0, n_steps, chunk_steps):
        i1 = min(i0 + chunk_steps, n_steps)
        ang, rate = motion.angle_rate(np.arange(i0 + 1, i1 + 1) * h)
        out = chain.run(i0, np.ascontiguousarray(ang, dtype=np.float64), np.ascontiguousarray(rate, dtype=np.float64))
        for name in names:
            pieces[name].append(out[name])
        if progress is not None:
            progress(i1 / n_steps)
    outputs = {name: np.concatenate(pieces[name]) for name in FILTER_NAMES + plugins}
    d_ro = chain.readout.delay_s
    delays = {
        "raw": d_ro,
        "eliminator": d_ro + float(chain.filters["eliminator"].design.group_delay_s(align_hz)),
        "correcting": d_ro + 1.0 / fs,
        "correcting_paper": d_ro + 1.0 / fs,
    }
    for name, flt in chain.plugins.items():
        delays[name] = d_ro + float(flt.delay_samples) / fs
    return ChannelResult(t=np.arange(n_out) / fs, outputs=outputs, delays_s=delays,
                         volts=np.concatenate(pieces["volts"]), drive=chain.drive, motion=motion, config=config)
