"""The single-channel job: configuration in, PNG + metrics.json + timeseries.npz out."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from sins_sim.models.motion import SineMotion, StaticMotion
from sins_sim.simulation.channel import ChannelConfig, simulate_channel
from sins_sim.units import ARCMIN, ARCSEC

__all__ = ["make_motion", "default_settle_s", "run_channel_job"]

#: The start-up transient excluded from the residual RMS by default (s), at most half the run.
SETTLE_S = 1.0


def default_settle_s(duration_s: float) -> float:
    """``min(1 s, duration_s / 2)``: the default transient to skip, so that any positive duration works."""
    return min(SETTLE_S, 0.5 * float(duration_s))


def make_motion(kind: str, frequency_hz: float = 100.0, amplitude_arcmin: float = 1.0):
    """``none`` or ``sine`` (amplitude in arcmin at the edge, rad inside)."""
    if kind == "none":
        return StaticMotion()
    if kind == "sine":
        return SineMotion(amplitude_rad=amplitude_arcmin * ARCMIN, frequency_hz=frequency_hz)
    raise ValueError(f"motion: must be one of ['none', 'sine'], got {kind!r}")


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
