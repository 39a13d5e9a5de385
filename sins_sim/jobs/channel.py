"""The single-channel job: configuration in, PNG + metrics.json + timeseries.npz out."""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path

import numpy as np

from sins_sim.models.motion import SineMotion, StaticMotion
from sins_sim.simulation.channel import ChannelConfig, simulate_channel
from sins_sim.units import ARCMIN, ARCSEC

__all__ = ["make_motion", "check_motion", "default_settle_s", "run_channel_job"]

#: The start-up transient excluded from the residual RMS by default (s), at most half the run.
SETTLE_S = 1.0


def default_settle_s(duration_s: float) -> float:
    """``min(1 s, duration_s / 2)``: the default transient to skip, so that any positive duration works."""
    return min(SETTLE_S, 0.5 * float(duration_s))


#: Largest sine motion amplitude (arcmin): the scenario's limit (a block on its mounts moves by arcminutes).
MAX_MOTION_ARCMIN = 600.0
#: Largest peak rate of the motion (deg/s): the input range of navigation-grade RLGs.
MAX_MOTION_RATE_DEG_S = 1000.0
#: Above this fraction of the filter Nyquist a motion draws a warning.
NEAR_NYQUIST = 0.8


def make_motion(kind: str, frequency_hz: float = 100.0, amplitude_arcmin: float = 1.0):
    """``none`` or ``sine`` (amplitude in arcmin at the edge, rad inside)."""
    if kind == "none":
        return StaticMotion()
    if kind == "sine":
        if not 0.0 <= amplitude_arcmin <= MAX_MOTION_ARCMIN:
            raise ValueError(f"motion_arcmin: must be in [0, {MAX_MOTION_ARCMIN:g}] arcmin, got {amplitude_arcmin!r}")
        return SineMotion(amplitude_rad=amplitude_arcmin * ARCMIN, frequency_hz=frequency_hz)
    raise ValueError(f"motion: must be one of ['none', 'sine'], got {kind!r}")


def check_motion(config: ChannelConfig, motion) -> None:
    """A sine motion below the filter Nyquist (a warning near it) and within an RLG's rate range.

    The filters, the truth they are compared with and the plots run at the filter rate: a motion above
    its Nyquist aliases (above the plant's Nyquist it is not even represented: ``--motion-hz 1e6`` gave
    ``correcting nan``).
    """
    f = float(getattr(motion, "frequency_hz", 0.0) or 0.0)
    if f <= 0.0:
        return
    nyq = 0.5 * config.filter_rate_hz
    if not f < nyq:
        raise ValueError(f"motion_hz: must be < the filter Nyquist {nyq:g} Hz (output_rate_hz / 2; above it the "
                         f"motion aliases, above input_rate_hz / 2 = {0.5 * config.plant.rate_hz:g} Hz it is not "
                         f"even sampled), got {f:g}")
    rate = math.degrees(2.0 * math.pi * f * float(getattr(motion, "amplitude_rad", 0.0)))
    if rate > MAX_MOTION_RATE_DEG_S:
        raise ValueError(f"motion_arcmin: the sine's peak rate {rate:.4g} deg/s is beyond the "
                         f"{MAX_MOTION_RATE_DEG_S:g} deg/s an RLG measures")
    if f > NEAR_NYQUIST * nyq:
        warnings.warn(f"motion_hz: {f:g} Hz is near the filter Nyquist {nyq:g} Hz (above {NEAR_NYQUIST:.0%} of it the "
                      "motion is barely resolved at the filter rate)", UserWarning, stacklevel=2)


def run_channel_job(config: ChannelConfig, duration_s: float, motion, out_dir, settle_s: float | None = None,
                    seed: int = 0, progress=None) -> dict:
    """Simulate one channel and write ``channel.png``, ``metrics.json``, ``timeseries.npz``.

    ``residual_rms_arcsec`` holds the RMS of each output minus the time-aligned
    true SINS angle over ``t >= settle_s`` (the start-up transient excluded;
    default :func:`default_settle_s`). Returns the metrics dictionary.
    """
    from sins_sim.plots.common import plot_channel

    if not (isinstance(duration_s, (int, float)) and math.isfinite(duration_s) and duration_s > 0.0):
        raise ValueError(f"duration_s: must be a finite number > 0, got {duration_s!r}")
    if settle_s is None:
        settle_s = default_settle_s(duration_s)
    if not 0.0 <= settle_s < duration_s:
        raise ValueError(f"settle_s: must be in [0, duration_s = {duration_s!r}), got {settle_s!r}")
    from sins_sim.jobs.estimate import check_channel
    from sins_sim.models.plant import check_resolution

    check_resolution(config.suspension, config.plant.rate_hz)
    check_motion(config, motion)
    check_channel(config, duration_s, progress)  # refuse what cannot finish, before the engine starts
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    align_hz = getattr(motion, "frequency_hz", 0.0)
    result = simulate_channel(config, duration_s, motion, seed=seed, align_hz=align_hz, progress=progress)
    rms = result.residual_rms(settle_s)
    s = config.suspension
    a = config.drive.amplitude_rad
    metrics = {
        "residual_rms_arcsec": {k: val / ARCSEC for k, val in rms.items()},
        "settle_s": settle_s,
        "duration_s": duration_s,
        "seed": seed,
        "drive": {"frequency_hz": result.drive.frequency_hz, "v_m": result.drive.v_m,
                  "amplitude_arcmin": a / ARCMIN},
        "suspension": {"f0_hz": s.f0_hz, "k1": s.k1, "k2": s.k2, "k3": s.k3, "k4": s.k4, "k5": s.k5,
                       "zeta": s.zeta, "q_at_amplitude": s.q_factor(a),
                       "relative_mismatch_f0_over_drive": s.relative_mismatch(a)},
        "filters": {"fs_hz": config.filter_rate_hz,
                    "dc_gain_paper_form": config.correcting_design("paper").dc_gain,
                    "eliminator_band_hz": list(config.eliminator_design().band_hz)},
        "delays_s": result.delays_s,
        "motion": repr(motion),
    }
    (out / "metrics.json").write_text(json.dumps(metrics, indent=2) + "\n")
    np.savez_compressed(out / "timeseries.npz", t=result.t, volts=result.volts,
                        truth=result.truth("raw"),
                        **{name: arr for name, arr in result.outputs.items()},
                        **{f"delay_s_{k}": np.float64(val) for k, val in result.delays_s.items()})
    title = (f"One dithered RLG channel: f0 = {s.f0_hz:g} Hz, dither {a / ARCMIN:g} arcmin at "
             f"{result.drive.frequency_hz:.2f} Hz, {config.filter_rate_hz:g} Hz filters")
    plot_channel(result, out / "channel.png", settle_s=settle_s, title=title)
    return metrics
