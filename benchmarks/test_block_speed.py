"""The sensor block on its isolators in the engine (issue 27, item 6): the coupled plant step against the rigid one.

The engine's channel path (``SideBySide``: drives, the three suspensions, readout, the six correcting filters and
the eliminators) on the bench input (``sins_sim.bench.engine``: the default unit under 1 arcmin of vibration at 100,
130 and 170 Hz), per plant step of three axes, same run:

- with the bundled preset's block (``configs/isolated-block.yaml``: a diagonal inertia, the elastic centre at the
  c.g., so the axis-decoupled kernel ``_kernels.block.run_three_block_axes``) against no block (today's rigid
  engine, ``chain.drive_plant_three``);
- with the same block on a mount whose elastic centre sits 20 mm below the c.g. (translation and rocking coupled:
  the general kernel, twelve chained states) against no block.

The issue asks for at most 1.3 times; the thresholds guard what was reached (``thresholds.json`` says why).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sins_sim.bench import median_ratio
from sins_sim.bench.engine import SideBySideRun, bench_block


def test_block_against_the_rigid_engine(benchmark, check_ratio, record, sizes):
    from sins_sim._kernels import block as kblock
    from sins_sim.config.imu import load_imu

    preset = load_imu(Path(__file__).resolve().parents[1] / "configs" / "isolated-block.yaml").block
    assert preset == bench_block()  # the bench's block is the bundled preset's
    dur = 2.0 if sizes["engine_s"] < 10 else 10.0
    rigid = SideBySideRun(dur)
    axes = SideBySideRun(dur, bench_block())
    coupled = SideBySideRun(dur, bench_block(elastic_centre_m=(0.0, 0.0, -0.02)))
    assert axes.three._step.axes and coupled.three._step.idx.size == 12
    outs = record(axes)
    # result: the axis-decoupled kernel against the general kernels on the same block, one chunk from rest
    # (tests/test_block.py bounds their difference at 1e-12 of each state's peak; the readout's quantisation
    # could only differ where a sample sits within 1e-16 rad of a step, which these inputs do not reach)
    fast, general = SideBySideRun(1.0, bench_block()), SideBySideRun(1.0, bench_block())
    general.three._step.ax = np.zeros((0, kblock.AX_SIZE))
    a, b = fast(), general()
    for i in range(3):
        for key in ("block_theta_end", "block_dth"):
            peak = np.max(np.abs(b[i][key]))
            assert peak > 0 and np.max(np.abs(a[i][key] - b[i][key])) <= 1e-12 * peak, (i, key)
        np.testing.assert_array_equal(a[i]["raw"], b[i]["raw"])
    assert all(np.all(np.isfinite(o["correcting"])) for o in outs)
    reps = max(3, sizes["repeats"] // 2)
    steps = axes.steps_per_call
    ratio_axes, ns, rigid_ns = median_ratio(axes, steps, rigid, steps, reps)
    ratio_coupled, coupled_ns, _ = median_ratio(coupled, steps, rigid, steps, reps)
    benchmark.extra_info.update(ns_per_plant_step_3axis=ns, coupled_mount_ns_per_plant_step_3axis=coupled_ns,
                                rigid_ns_per_plant_step_3axis=rigid_ns)
    check_ratio("block_engine_3axis/rigid_engine_3axis", ratio_axes)
    check_ratio("block_engine_3axis_coupled_mount/rigid_engine_3axis", ratio_coupled)
