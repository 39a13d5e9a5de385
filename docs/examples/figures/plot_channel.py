"""
One gyro channel
================

``sins-sim channel`` simulates one dithered RLG channel (the paper's suspension at 386 Hz, 3 arcmin
dither, the 9 kHz FIR and decimation to 7.2 kHz) and both dither filters. ``channel.png``: the raw
readout against the truth, the filter outputs against the truth, and the residuals, over the
last 30 ms. The block vibrates at 100 Hz with 1 arcmin, as in::

    sins-sim channel --f0 386 --dither-arcmin 3 --duration 2 --motion sine --motion-hz 100 --motion-arcmin 1 --out out/ch
"""

import tempfile
from pathlib import Path

from sins_sim import ChannelConfig, simulate_channel
from sins_sim.jobs.channel import default_settle_s, make_motion
from sins_sim.plots.common import plot_channel

duration_s = 1.0
result = simulate_channel(ChannelConfig(), duration_s, make_motion("sine", frequency_hz=100.0, amplitude_arcmin=1.0))
out = Path(tempfile.mkdtemp())
plot_channel(result, out / "channel.png", settle_s=default_settle_s(duration_s),  # the start-up transient left out, as the CLI does
             title="one channel, 100 Hz block vibration of 1 arcmin")
