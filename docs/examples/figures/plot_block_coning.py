"""
Dither coning on one block
==========================

Two gyros 0.1 Hz apart on one block (``scenarios/block-dither-coupling.yaml``, here 14 s): the block
rocks about x and about y at nearly one frequency, and the two rockings make a coning angle about z that
beats at the separation with amplitude ``a_x a_y (w_x + w_y) / (4 |w_x - w_y|)``. ``block_coning.png``
shows each filter's attitude error about z (means over each stored interval: the dither lines average
out, the beat stays) beside that closed form. The eliminator removes the rocking and keeps the slow
coning rate; eq. 5 keeps the rocking and the coning cancels in its navigation.
"""

from pathlib import Path

import sins_sim

ROOT = next(p for p in (Path.cwd(), *Path.cwd().parents) if (p / "scenarios").is_dir())
r = sins_sim.run(ROOT / "scenarios" / "block-dither-coupling.yaml", duration_s=14.0)
fig = r.plot("block_coning")
