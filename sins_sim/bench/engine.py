"""The engine's speed on the path users run: ``simulate_sins``, against its bare kernels.

The bench case is the default three-axis unit (the paper suspension at 386, 352 and 421 Hz,
closed-loop drives, every filter) under a 1 arcmin block vibration about each axis at 100,
130 and 170 Hz, at rest at 45 deg N.

* :func:`engine_run`: ``simulate_sins`` without navigation (``nav=None``: truth at the
  plant rate, the three fused channel kernels, every filter) or with the full INS loop
  (every filter navigated by its own strapdown against the truth, at a mission's default
  rate: :func:`~sins_sim.simulation.sins.default_n_sub`);
* :class:`BareKernels`: the same three channels' kernels (side by side, as the one-thread
  engine runs them) called directly on precomputed inputs, nothing else: the floor the engine
  is compared with (a same-run ratio in CI, so the user path cannot fall behind the kernels
  again);
* :func:`peak_memory`: peak resident memory of engine runs of given lengths, each in a fresh
  process.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
import time

import numpy as np

from sins_sim.models.block import BlockParams
from sins_sim.models.motion import AxisSines
from sins_sim.models.suspension import PAPER_SUSPENSION
from sins_sim.simulation.channel import ChannelChain, ChannelConfig
from sins_sim.simulation.unit import SideBySide
from sins_sim.simulation.sins import ImuConfig, NavSettings, default_n_sub, simulate_sins
from sins_sim.units import ARCMIN

__all__ = ["CHAIN_F0_HZ", "CHAIN_VIBRATION_HZ", "bench_imu", "bench_motion", "bench_block", "engine_run",
           "BareKernels", "SideBySideRun", "peak_memory"]

#: Resonances of the three axes (Hz).
CHAIN_F0_HZ = (386.0, 352.0, 421.0)
#: Block vibration about each axis: 1 arcmin at these frequencies (Hz).
CHAIN_VIBRATION_HZ = (100.0, 130.0, 170.0)


def bench_imu() -> ImuConfig:
    """The default three-axis unit (``configs/default-imu.yaml``), built in code."""
    return ImuConfig(channels=tuple(ChannelConfig(suspension=PAPER_SUSPENSION.replace(f0_hz=f)) for f in CHAIN_F0_HZ))


def bench_motion() -> AxisSines:
    return AxisSines(amplitude_rad=np.full(3, ARCMIN), frequency_hz=np.array(CHAIN_VIBRATION_HZ),
                     phase_rad=np.zeros(3))


def bench_block(elastic_centre_m=(0.0, 0.0, 0.0)) -> BlockParams:
    """The sensor block of ``configs/isolated-block.yaml`` (3 kg, rocking modes at 100 Hz, translation at 80 Hz,
    5 % damping; its comments give the sources), built in code; ``elastic_centre_m`` moves the isolators' elastic
    centre off the c.g. (a mount that couples translation and rocking: the general, 12-state kernel)."""
    return BlockParams(mass_kg=3.0, inertia_kg_m2=np.diag([0.012, 0.013, 0.015]), gyro_inertia_kg_m2=[2.0e-4] * 3,
                       k_trans_n_per_m=[7.58e5] * 3, k_rot_n_m_per_rad=[4737.0, 5132.0, 5922.0],
                       c_trans_n_s_per_m=[151.0] * 3, c_rot_n_m_s_per_rad=[0.754, 0.817, 0.942],
                       elastic_centre_m=np.asarray(elastic_centre_m, dtype=float))


def engine_run(duration_s: float, navigation: bool, threads: int = 1, imu=None, motion=None):
    """One ``simulate_sins`` run of the bench case; returns the result."""
    imu = imu or bench_imu()
    # navigated at a mission's default rate (400 Hz: the coning and sculling sums at the filter rate, the
    # update every 18 filter samples; issue 26), as ``sins-sim run`` navigates a scenario
    nav = (NavSettings(start_s=min(0.5, 0.25 * duration_s), n_sub=default_n_sub(imu.filter_rate_hz))
           if navigation else None)
    return simulate_sins(imu, motion or bench_motion(), duration_s, seed=0, nav=nav, threads=threads)


class BareKernels:
    """The three channels' fused kernels over precomputed inputs: the engine minus everything else."""

    def __init__(self, duration_s: float, chunk_s: float = 1.0):
        imu = bench_imu()
        self.cfgs = imu.channels
        self.control = imu.drive_control
        fp = imu.plant_rate_hz
        self.n = int(round(chunk_s * fp))
        self.n_chunks = max(1, int(round(duration_s / chunk_s)))
        t = np.arange(1, self.n + 1) / fp
        w = 2.0 * math.pi * np.array(CHAIN_VIBRATION_HZ)
        # the same input every chunk (the cost does not depend on the values' history), axis-major as the
        # truth delivers it
        self.ang = np.asfortranarray(ARCMIN * np.sin(w[None, :] * t[:, None]))
        self.rate = np.asfortranarray(ARCMIN * w[None, :] * np.cos(w[None, :] * t[:, None]))
        self.simulated_s = self.n_chunks * self.n / fp

    def chains(self) -> list:
        """The three channel chains at rest, each moving with its axis's vibration."""
        chains = [ChannelChain(c, self.control, np.random.default_rng(i)) for i, c in enumerate(self.cfgs)]
        for ch, w in zip(chains, CHAIN_VIBRATION_HZ):
            ch.reset(0.0, ARCMIN * 2.0 * math.pi * w)
        return chains

    def run(self) -> None:
        three = SideBySide(self.chains())  # the kernels of the engine's one-thread path
        for k in range(self.n_chunks):
            three.run(k * self.n, self.ang, self.rate)


class SideBySideRun:
    """The engine's one-thread channel path (``SideBySide``: the three suspensions, with or without the sensor
    block, then readout and filters) on :class:`BareKernels`' input, built once: each call advances
    ``n_chunks`` more chunks of ``n`` plant steps and returns the last chunk's outputs. The per-chunk cost users
    pay in a long run, without the one-off construction (the block's matrix exponential, the filter designs)."""

    def __init__(self, duration_s: float, block=None, chunk_s: float = 1.0):
        self.inputs = BareKernels(duration_s, chunk_s)
        self.three = SideBySide(self.inputs.chains(), block=block)
        self.n, self.n_chunks = self.inputs.n, self.inputs.n_chunks
        self.steps_per_call = self.n * self.n_chunks
        self._i0 = 0

    def __call__(self) -> list:
        outs = None
        for _ in range(self.n_chunks):
            outs = self.three.run(self._i0, self.inputs.ang, self.inputs.rate)
            self._i0 += self.n
        return outs


def _peak_rss_mib() -> float:
    """The process's peak resident set size (MiB): ``VmHWM`` (Linux), else ``ru_maxrss``."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return float(line.split()[1]) / 1024.0
    except OSError:
        pass
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / (2.0**20 if sys.platform == "darwin" else 1024.0)


def _memory_probe(duration_s: float, navigation: bool) -> dict:
    engine_run(1.0, navigation)  # compiled and loaded
    rss0 = _peak_rss_mib()
    t0 = time.perf_counter()
    engine_run(duration_s, navigation, threads=1)
    wall = time.perf_counter() - t0
    return {"simulated_s": duration_s, "navigation": navigation, "max_rss_mib": _peak_rss_mib(),
            "max_rss_before_run_mib": rss0, "wall_s": wall, "realtime_factor_wall": duration_s / wall}


def peak_memory(duration_s: float, navigation: bool = True) -> dict:
    """Peak memory (MiB) and wall time of an engine run of ``duration_s`` in a fresh process (one thread)."""
    code = ("import json; from sins_sim.bench.engine import _memory_probe; "
            f"print(json.dumps(_memory_probe({float(duration_s)!r}, {bool(navigation)!r})))")
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True)
    return json.loads(out.stdout.strip().splitlines()[-1])
