"""Three-axis SINS in the loop: three dithered channels, their filters, attitude and navigation error.

Each body axis x, y, z carries one single-axis RLG on its own suspension
(reference-model.md, "Three axes"): its own resonance, drive, readout,
correcting filters (unity-DC and paper form) and eliminator centred on its
own dither. The block's motion (``sins_sim.models.motion``) gives each gyro
its SINS angle (the time integral of the body rate along its axis) and the
true attitude. For every filter the three outputs are differenced into angle
increments and integrated into an attitude (``sins_sim.navigation``), which
is compared with the truth after aligning each filter's delay.

Filters compared:
- ``ideal``: the true angle increments through the same navigation
  algorithm (the algorithm's own error floor);
- ``raw``: the decimated readout, dither included;
- ``eliminator``, ``correcting``, ``correcting_paper``.

Alignment: outputs are shifted by a whole number of filter samples
(``delay_samples``): the anti-alias FIR's delay plus one sample for eq. 5
(exact), plus the eliminator's DC group delay rounded to the nearest sample
(mean over the three axes; the rounding residual is reported).

Drive: open loop at the amplitude-dependent resonance with V_m from eq. 17,
or closed loop, as a unit's amplitude-stabilisation loop does (the paper: "k5
was determined by a system of amplitude stabilization"). The loop measures
the dither amplitude every ``block_cycles`` dither periods by synchronous
demodulation of the deflection at the drive frequency, and sets
``V_m = V_ff + (V_m0 / a_m) kp (e + (1/tau) int e dt)`` with ``e`` the
amplitude error. The amplitude obeys eq. 15, ``da/dt = -(a - a_m V/V_m0)/tau``
with ``tau = 2 Q / omega``; the PI zero cancels that pole, so the closed loop
is first order with time constant ``loop_time_s = tau / kp``.
Optional random amplitude modulation draws a new target
``a_m (1 + depth u)``, ``u`` uniform in [-1, 1], every block (seeded), as real
units do against dynamic lock-in.

A run is a pure function of (configuration, motion, duration, seed) and
streams in chunks: memory does not grow with the duration except for the
stored time series (decimated to ``timeseries_rate_hz``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from sins_sim import _validate as v
from sins_sim.models.motion import AttitudeStream
from sins_sim.navigation.attitude import AttitudeIntegrator, attitude_error
from sins_sim.simulation.channel import ChannelChain, ChannelConfig, DriveControl

__all__ = ["DriveControl", "ImuConfig", "NavSettings", "SinsResult", "simulate_sins", "SINS_FILTERS"]

#: Every filter a SINS run can compare.
SINS_FILTERS = ("ideal", "raw", "eliminator", "correcting", "correcting_paper")
AXES = ("x", "y", "z")


@dataclass(frozen=True)
class ImuConfig:
    """Three channels on orthogonal axes x, y, z plus their drive control."""

    channels: tuple
    drive_control: DriveControl = field(default_factory=DriveControl)
    name: str = "imu"

    def __post_init__(self):
        if len(self.channels) != 3 or not all(isinstance(c, ChannelConfig) for c in self.channels):
            raise ValueError("imu.channels: must be three ChannelConfig (x, y, z)")
        rates = {(c.plant.rate_hz, c.readout.output_rate_hz) for c in self.channels}
        if len(rates) != 1:
            raise ValueError(f"imu.channels: all axes must share plant and filter rates, got {sorted(rates)}")
        f0 = [c.suspension.f0_hz for c in self.channels]
        if len(set(f0)) < 3:
            raise ValueError(
                f"imu.channels: the three resonances must differ so the dithers do not lock together "
                f"(reference-model.md, 'Three axes'), got {f0}"
            )

    @property
    def plant_rate_hz(self) -> float:
        return self.channels[0].plant.rate_hz

    @property
    def filter_rate_hz(self) -> float:
        return self.channels[0].readout.output_rate_hz


@dataclass(frozen=True)
class NavSettings:
    """Navigation settings.

    Parameters
    ----------
    coning : str
        Coning correction of the attitude update (``sins_sim.navigation.attitude``).
    start_s : float
        Navigation starts (attitude aligned to the truth) at this time, after the
        dithers have built up from rest.
    timeseries_rate_hz : float
        Rate of the stored attitude-error time series.
    spectrum_s : float
        Length of filter output kept at full rate for spectra (from ``start_s``).
    """

    coning: str = "two_sample"
    start_s: float = 1.0
    timeseries_rate_hz: float = 720.0
    spectrum_s: float = 2.0

    def __post_init__(self):
        v.non_negative("navigation", "start_s", self.start_s)
        v.positive("navigation", "timeseries_rate_hz", self.timeseries_rate_hz)
        v.non_negative("navigation", "spectrum_s", self.spectrum_s)


@dataclass
class SinsResult:
    """What a SINS run produced (all SI / rad).

    Attributes
    ----------
    t : ndarray
        Times of the stored attitude-error series (s).
    attitude_error : dict name -> (N, 3) ndarray
        Attitude error per filter (rad), about the navigation axes (roll, pitch, yaw).
    nav_t : ndarray
        Times of all navigation samples (s), for metrics.
    metrics_data : dict name -> dict
        Drift and error statistics computed on the full-rate error.
    spectra : dict
        ``t`` and per-filter (N, 3) outputs at the filter rate plus ``truth``, over ``spectrum_s``.
    delays : dict name -> int
        Alignment shift in filter samples.
    drives : list of dict
        Per axis: frequency, initial and final V_m, measured amplitude.
    """

    t: np.ndarray
    attitude_error: dict
    final_error: dict
    full_stats: dict
    spectra: dict
    delays: dict
    drives: list
    filter_rate_hz: float
    duration_s: float
    nav_start_s: float
    warnings: list


def simulate_sins(imu: ImuConfig, motion, duration_s: float, seed: int = 0, nav: NavSettings = NavSettings(),
                  filters=SINS_FILTERS, chunk_s: float = 0.5, progress=None) -> SinsResult:
    """Run the three-axis SINS for ``duration_s`` seconds under ``motion`` (a Motion3D)."""
    import warnings as _warnings

    duration_s = v.positive("run", "duration_s", duration_s)
    for name in filters:
        v.choice("run", "filters", name, SINS_FILTERS)
    if nav.start_s >= duration_s:
        raise ValueError(f"navigation.start_s: must be < duration_s = {duration_s!r}, got {nav.start_s!r}")
    fs = imu.filter_rate_hz
    fp = imu.plant_rate_hz
    r_dec = imu.channels[0].readout.decimation
    h = 1.0 / fp
    n_out = int(math.floor(duration_s * fs + 1e-9))
    n_steps = n_out * r_dec
    chunk = max(r_dec, int(round(chunk_s * fs)) * r_dec)
    axis_rngs = [np.random.default_rng([seed, i]) for i in range(3)]  # one independent stream per axis
    chains = [ChannelChain(c, imu.drive_control, axis_rngs[i]) for i, c in enumerate(imu.channels)]
    a0 = motion.gyro_angle(np.zeros(1))[0]
    r0 = motion.body_rate(np.zeros(1))[0]
    for i, ch in enumerate(chains):
        ch.reset(float(a0[i]), float(r0[i]))

    # alignment shifts (filter samples)
    ro_delay = chains[0].readout.delay_s * fs
    elim_gd = float(np.mean([float(ch.filters["eliminator"].design.group_delay_s(0.0)) for ch in chains])) * fs
    delays = {"ideal": 0, "raw": int(round(ro_delay)), "correcting": int(round(ro_delay)) + 1,
              "correcting_paper": int(round(ro_delay)) + 1,
              "eliminator": int(round(ro_delay + elim_gd))}
    residual_delay = {"eliminator": ro_delay + elim_gd - delays["eliminator"]}
    max_delay = max(delays.values())

    k_start = int(round(nav.start_s * fs))
    ts_every = max(1, int(round(fs / nav.timeseries_rate_hz)))
    n_spec = int(round(nav.spectrum_s * fs))

    # truth attitude on the filter grid, streamed
    attitude_truth = AttitudeStream(motion)

    def truth_stream(t_f):
        if t_f[0] <= attitude_truth.t:  # t = 0: the initial attitude itself
            return np.concatenate((attitude_truth.q[None, :], attitude_truth.advance(t_f[1:])))
        return attitude_truth.advance(t_f)
    tq_hist = np.zeros((0, 4))
    out_hist = {name: np.zeros((0, 3)) for name in filters}  # filter outputs not yet consumed
    prev_angle = {name: None for name in filters}
    integrators = {name: None for name in filters}
    pos = {name: 0 for name in filters}  # next filter-output index to consume
    errs_ts = {name: [] for name in filters}
    t_ts = []
    stats = {name: {"sum": np.zeros(3), "sum2": np.zeros(3), "n": 0, "st": 0.0, "stt": 0.0,
                    "ste": np.zeros(3), "se": np.zeros(3), "last": np.zeros(3)} for name in filters}
    spectra = {name: [] for name in filters}
    spectra["truth"] = []
    spec_t = []
    tq_base = 0  # filter index of tq_hist[0]

    caught = []
    for i0 in range(0, n_steps, chunk):
        i1 = min(i0 + chunk, n_steps)
        t_end = np.arange(i0 + 1, i1 + 1) * h
        ang = motion.gyro_angle(t_end)
        rate = motion.body_rate(t_end)
        outs = []
        for i, ch in enumerate(chains):
            with _warnings.catch_warnings(record=True) as axis_w:
                _warnings.simplefilter("always")
                outs.append(ch.run(i0, ang[:, i].copy(), rate[:, i].copy()))
            caught.extend(f"axis {AXES[i]}: {w.message}" for w in axis_w)
        k0, k1 = i0 // r_dec, i1 // r_dec
        t_f = np.arange(k0, k1) / fs
        ideal = motion.gyro_angle(t_f)
        tq = truth_stream(t_f)
        tq_hist = np.concatenate((tq_hist, tq))
        new = {name: (ideal if name == "ideal" else np.stack([o[name] for o in outs], axis=1))
               for name in filters}
        for name in filters:
            out_hist[name] = np.concatenate((out_hist[name], new[name]))
        # spectra: keep outputs aligned with truth from k_start for n_spec samples
        for name in filters:
            d = delays[name]
            lo = max(k_start + d, k0)
            hi = min(k_start + d + n_spec, k1)
            if hi > lo:
                spectra[name].append(new[name][lo - k0:hi - k0])
        lo, hi = max(k_start, k0), min(k_start + n_spec, k1)
        if hi > lo:
            spectra["truth"].append(ideal[lo - k0:hi - k0])
            spec_t.append(t_f[lo - k0:hi - k0])
        # navigation for each filter
        for name in filters:
            d = delays[name]
            buf = out_hist[name]
            base = pos[name]  # filter-output index of buf[0]
            if integrators[name] is None:
                j0 = k_start + d
                if j0 < base + buf.shape[0] and j0 - d >= tq_base:
                    q0 = tq_hist[j0 - d - tq_base]
                    integrators[name] = AttitudeIntegrator(q0=q0, algorithm=nav.coning)
                    prev_angle[name] = buf[j0 - base]
                    buf = buf[j0 - base + 1:]
                    base = j0 + 1
                else:  # navigation has not started for this filter yet
                    continue
            if buf.shape[0] == 0:
                out_hist[name] = buf
                pos[name] = base
                continue
            ang_seq = np.concatenate((prev_angle[name][None, :], buf))
            dtheta = np.diff(ang_seq, axis=0)
            q_est = integrators[name].process(dtheta)
            truth_idx = np.arange(base, base + buf.shape[0]) - d - tq_base
            err = attitude_error(q_est, tq_hist[truth_idx])
            tk = (np.arange(base, base + buf.shape[0]) - d) / fs
            st = stats[name]
            st["sum"] += err.sum(axis=0)
            st["sum2"] += (err * err).sum(axis=0)
            st["n"] += err.shape[0]
            st["st"] += tk.sum()
            st["stt"] += (tk * tk).sum()
            st["ste"] += tk @ err
            st["last"] = err[-1]
            sel = ((np.arange(base, base + buf.shape[0]) - d) % ts_every) == 0
            errs_ts[name].append(err[sel])
            if name == filters[0]:
                t_ts.append(tk[sel])
            prev_angle[name] = buf[-1]
            pos[name] = base + buf.shape[0]
            out_hist[name] = buf[:0]
        # drop truth no longer needed
        need = min(pos[name] - delays[name] for name in filters) - 1
        drop = max(0, need - tq_base - max_delay)
        if drop:
            tq_hist = tq_hist[drop:]
            tq_base += drop
        if progress is not None:
            progress(i1 / n_steps)

    full_stats = {}
    for name in filters:
        st = stats[name]
        n = st["n"]
        if n < 2:
            raise ValueError("run.duration_s: too short for navigation after navigation.start_s")
        mean = st["sum"] / n
        rms = np.sqrt(st["sum2"] / n)
        tm = st["st"] / n
        var_t = st["stt"] / n - tm * tm
        slope = (st["ste"] / n - tm * mean) / var_t if var_t > 0 else np.zeros(3)
        full_stats[name] = {"drift_rad_s": slope, "rms_rad": rms, "final_rad": st["last"], "n": n}
    n_ts = min(len(np.concatenate(errs_ts[name])) for name in filters)
    t_arr = np.concatenate(t_ts)[:n_ts]
    att = {name: np.concatenate(errs_ts[name])[:n_ts] for name in filters}
    spec = {name: (np.concatenate(spectra[name]) if spectra[name] else np.zeros((0, 3))) for name in spectra}
    n_sp = min(s.shape[0] for s in spec.values())
    spec = {name: s[:n_sp] for name, s in spec.items()}
    spec["t"] = np.concatenate(spec_t)[:n_sp] if spec_t else np.zeros(0)
    drives = [{"axis": AXES[i], "f0_hz": ch.cfg.suspension.f0_hz, "frequency_hz": ch.drive.frequency_hz,
               "v_m_initial": ch.v_m0, "v_m_final": ch.v_m, "amplitude_measured_rad": ch.amp_meas,
               "amplitude_target_rad": ch.cfg.drive.amplitude_rad} for i, ch in enumerate(chains)]
    res = SinsResult(t=t_arr, attitude_error=att, final_error={k: s["final_rad"] for k, s in full_stats.items()},
                     full_stats=full_stats, spectra=spec, delays=dict(delays, residual_eliminator=residual_delay),
                     drives=drives, filter_rate_hz=fs, duration_s=duration_s, nav_start_s=nav.start_s,
                     warnings=list(dict.fromkeys(caught)))
    return res
