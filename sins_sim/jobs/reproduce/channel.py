"""One channel of the paper reproduction, started on the steady dither, with every filter and the pickoff baseline.

:func:`simulate_paper_channel` runs the paper's channel (plant at 72 kHz,
fringe counter, anti-alias FIR, decimation) started on the harmonic-balance
steady dither (:func:`paper_drive`, the drive at F(a) with the eq. 17
voltage and the start kick), feeding the eliminator, the correcting filter
(eq. 5, both DC forms) and the pickoff stripper; :func:`calibrate_pickoff`
converges the pickoff's LMS gain on a stationary SINS.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sins_sim.filters.correcting import CorrectingFilter, CorrectingFilterDesign
from sins_sim.filters.eliminator import Eliminator, EliminatorDesign
from sins_sim.filters.pickoff import PickoffStripper, PickoffStripperDesign
from sins_sim.identification.afc import hb_start, kick_motion
from sins_sim.jobs.reproduce.common import FILTERS
from sins_sim.models.drive import DriveSignal
from sins_sim.models.motion import StaticMotion, SumMotion, as_motion
from sins_sim.models.pickoff import PickoffParams, PickoffSensor
from sins_sim.models.plant import Plant, PlantSettings
from sins_sim.models.readout import Decimator, Readout, ReadoutParams
from sins_sim.models.suspension import PAPER_SUSPENSION, SuspensionParams
from sins_sim.units import ARCMIN

__all__ = ["PaperChannelRun", "paper_drive", "simulate_paper_channel", "PICKOFF_TRACK_TIME_S", "calibrate_pickoff"]


@dataclass
class PaperChannelRun:
    """Outputs of :func:`simulate_paper_channel` at the filter rate.

    Attributes
    ----------
    t : ndarray
        Sample times (s).
    x : ndarray
        Decimated readout angle (rad), the correcting filter's input.
    volts : ndarray
        Drive voltage through the same anti-alias chain (V).
    outputs : dict
        ``raw``, ``eliminator``, ``correcting`` (unity DC), ``correcting_paper``, ``pickoff`` (rad).
    delays_s : dict
        How late each output is relative to ``t`` (s).
    motion : motion object
        The block motion simulated: the requested one plus the start kick.
    offset_rad : float
        The block angle the kick leaves (``-a``): subtract it to compare with the requested motion.
    fast_half_cycles : dict
        Regime counters of the plant and of the correcting filters (docs/theory/suspension.md).
    pickoff_gain : float
        LMS gain of the pickoff stripper at the end (rad per V s).
    """

    t: np.ndarray
    x: np.ndarray
    volts: np.ndarray
    outputs: dict
    delays_s: dict
    motion: object
    offset_rad: float
    fast_half_cycles: dict
    pickoff_gain: float

    def truth(self, name: str) -> np.ndarray:
        """The SINS angle at the instants output ``name`` describes (rad)."""
        angle, _ = self.motion.angle_rate(self.t - self.delays_s[name])
        return angle


def paper_drive(s: SuspensionParams = PAPER_SUSPENSION, amplitude_rad: float = 3.0 * ARCMIN,
                rate_hz: float = 72000.0) -> tuple[DriveSignal, float, object]:
    """Drive at the resonance F(a) with the eq. 17 voltage, the HB amplitude and the start kick.

    The drive is phased so that the steady dither is ``a cos(w (t - t_c))``,
    the state the kick (:func:`sins_sim.identification.afc.kick_motion`) starts.
    """
    f = s.resonance_hz(amplitude_rad)
    vm = s.drive_voltage(amplitude_rad)
    _, t_c = kick_motion(1.0, rate_hz)
    a0, phase = hb_start(s, vm, f, t_c=t_c)
    kick, _ = kick_motion(a0, rate_hz)
    return DriveSignal(frequency_hz=f, v_m=vm, dac_rate_hz=rate_hz, phase_rad=phase), a0, kick


def simulate_paper_channel(duration_s: float, motion=None, suspension: SuspensionParams = PAPER_SUSPENSION,
                           amplitude_rad: float = 3.0 * ARCMIN, readout: ReadoutParams | None = None,
                           filter_suspension: SuspensionParams | None = None,
                           eliminator: EliminatorDesign | None = None, hysteresis: str = "paper",
                           pickoff: PickoffParams | None = None, pickoff_gain0: float | None = None,
                           pickoff_adapt_time_s: float = 0.2, seed: int = 0, align_hz: float = 0.0,
                           chunk_steps: int = 72000) -> PaperChannelRun:
    """One channel like ``simulate_channel`` but started on the steady dither, with the pickoff baseline.

    The block makes a quick rotation by ``-a`` at t = 0 (``kick_motion``),
    which starts the harmonic-balance steady dither (the drive is phased to
    match), so the dither is settled from t = 0; the filters start at rest
    and settle on their own time scales. The pickoff stripper runs at the plant rate on
    ``counts * q`` and the pickoff voltage; its output is decimated by the
    readout's anti-alias chain. ``pickoff_gain0`` (rad per V s) starts its
    LMS gain at a calibrated value (default: the nominal ``1 / scale``); it
    adapts with ``pickoff_adapt_time_s`` once its band-pass has filled.
    """
    readout = readout if readout is not None else ReadoutParams()
    fs_plant = readout.input_rate_hz
    drive, a0, kick = paper_drive(suspension, amplitude_rad, fs_plant)
    motion = SumMotion((as_motion(motion), kick))
    plant = Plant(suspension, PlantSettings(rate_hz=fs_plant, hysteresis=hysteresis))
    ro = Readout(readout, np.random.default_rng(seed))
    vdec = Decimator.from_readout(readout)
    pdec = Decimator.from_readout(readout)
    fs = readout.output_rate_hz
    r_dec = readout.decimation
    fsus = filter_suspension or suspension
    designs = {form: CorrectingFilterDesign(f0_hz=fsus.f0_hz, k1=fsus.k1, k2=fsus.k2, k3=fsus.k3, k4=fsus.k4,
                                            k5=fsus.k5, fs_hz=fs, form=form, hysteresis=hysteresis)
               for form in ("unity", "paper")}
    elim_design = eliminator or EliminatorDesign.paper()
    elim = Eliminator(elim_design)
    pk = pickoff or PickoffParams(rate_hz=fs_plant)
    sensor = PickoffSensor(pk, np.random.default_rng(seed + 1))
    if pickoff_gain0 is None:
        sdesign = PickoffStripperDesign(fs_hz=fs_plant, dither_hz=drive.frequency_hz,
                                        scale_v_per_rad_s=pk.scale_v_per_rad_s, adapt_time_s=pickoff_adapt_time_s)
    else:
        sdesign = PickoffStripperDesign(fs_hz=fs_plant, dither_hz=drive.frequency_hz,
                                        scale_v_per_rad_s=1.0 / pickoff_gain0, adapt_time_s=pickoff_adapt_time_s)
    stripper = PickoffStripper(sdesign)
    h = plant.h
    n_out = int(math.floor(duration_s * fs + 1e-9))
    n_steps = n_out * r_dec
    chunk_steps = max(r_dec, (int(chunk_steps) // r_dec) * r_dec)
    phi0, rate0 = motion.angle_rate(np.zeros(1))
    plant.reset(float(phi0[0]), float(rate0[0]))
    cor = {form: None for form in designs}
    carry_phi = float(phi0[0])
    carry_delta = 0.0
    pieces = {name: [] for name in FILTERS}
    xs, vs = [], []
    for i0 in range(0, n_steps, chunk_steps):
        i1 = min(i0 + chunk_steps, n_steps)
        t_end = np.arange(i0 + 1, i1 + 1) * h
        ang, rate = motion.angle_rate(t_end)
        volts = drive.samples(i0, i1 - i0)
        delta = plant.step(ang, rate, volts)
        phi_rlg = ang + delta
        feed = np.concatenate(([carry_phi], phi_rlg[:-1]))
        dfeed = np.concatenate(([carry_delta], delta[:-1]))
        carry_phi = float(phi_rlg[-1])
        carry_delta = float(delta[-1])
        counts, x = ro.process(feed)
        vx = vdec.process(volts)
        if cor["unity"] is None:
            cor = {form: CorrectingFilter(d, x0=float(x[0])) for form, d in designs.items()}
        pv = sensor.process(dfeed)
        y72 = stripper.process(counts.astype(np.float64) * readout.quantum_rad, pv)
        pieces["raw"].append(x)
        pieces["eliminator"].append(elim.process(x))
        pieces["correcting"].append(cor["unity"].process(x, vx))
        pieces["correcting_paper"].append(cor["paper"].process(x, vx))
        pieces["pickoff"].append(pdec.process(y72))
        xs.append(x)
        vs.append(vx)
    outputs = {name: np.concatenate(p) for name, p in pieces.items()}
    d_ro = ro.delay_s
    delays = {"raw": d_ro, "eliminator": d_ro + float(elim_design.group_delay_s(align_hz)),
              "correcting": d_ro + 1.0 / fs, "correcting_paper": d_ro + 1.0 / fs, "pickoff": d_ro}
    fast = {"plant": plant.fast_half_cycles, "correcting": cor["unity"].fast_half_cycles,
            "correcting_paper": cor["paper"].fast_half_cycles}
    return PaperChannelRun(t=np.arange(n_out) / fs, x=np.concatenate(xs), volts=np.concatenate(vs),
                           outputs=outputs, delays_s=delays, motion=motion, offset_rad=-a0, fast_half_cycles=fast,
                           pickoff_gain=stripper.gain)


#: Slow LMS used once the pickoff gain is calibrated: it tracks the coil's thermal drift, not block motion.
PICKOFF_TRACK_TIME_S = 10.0


def calibrate_pickoff(s: SuspensionParams = PAPER_SUSPENSION, duration_s: float = 3.0) -> float:
    """LMS gain of the pickoff stripper (rad per V s) after ``duration_s`` on a stationary SINS.

    In operation the gain is adapted continuously with a long time constant;
    the figures start from this converged value and track slowly
    (:data:`PICKOFF_TRACK_TIME_S`), so that block motion within the
    adaptation band during a measurement cannot pull the gain (a fast LMS
    minimising the dither-band content of the output would also cancel block
    motion near the dither frequency).
    """
    return simulate_paper_channel(duration_s, StaticMotion(), s).pickoff_gain
