"""Cascade of second-order IIR sections (transposed direct form II).

The recursion is the one of ``scipy.signal.sosfilt`` (scipy's
``_sosfilt.pyx``), written out so that a stateful filter can run inside the
simulation loop without Python overhead. Each section ``s`` holds the row
``sos[s] = [b0, b1, b2, 1, a1, a2]`` (``a0`` normalised to 1) and two state
values ``zi[s, 0], zi[s, 1]``; per input sample ``u``::

    v         = b0 * u + zi[s, 0]
    zi[s, 0]  = b1 * u - a1 * v + zi[s, 1]
    zi[s, 1]  = b2 * u - a2 * v

and ``v`` feeds the next section. The state after the last sample is the
state before the next one, so feeding a signal in chunks gives bit-identical
output to one call on the whole signal.

Kernels never validate: the public wrappers (``sins_sim.filters``) do.
"""

from __future__ import annotations

from sins_sim._kernels._config import jit


@jit
def sos_filter(sos, x, zi, y):
    """Filter ``x`` through second-order sections, in place on ``zi`` and ``y``.

    Parameters
    ----------
    sos : ndarray, shape (n_sections, 6), float64
        Sections ``[b0, b1, b2, a0, a1, a2]`` with ``a0 == 1`` (scipy's
        ``output="sos"`` layout; ``a0`` is not read).
    x : ndarray, shape (n,), float64
        Input samples.
    zi : ndarray, shape (n_sections, 2), float64
        Filter state (transposed direct form II, as ``scipy.signal.sosfilt``);
        read on entry and overwritten with the state after the last sample.
    y : ndarray, shape (n,), float64
        Output, written in full. May be the same array as ``x``.
    """
    n_sections = sos.shape[0]
    for n in range(x.shape[0]):
        u = x[n]
        for s in range(n_sections):
            v = sos[s, 0] * u + zi[s, 0]
            zi[s, 0] = sos[s, 1] * u - sos[s, 4] * v + zi[s, 1]
            zi[s, 1] = sos[s, 2] * u - sos[s, 5] * v
            u = v
        y[n] = u
