"""Streaming FIR low-pass followed by decimation.

Output sample ``k`` of the whole stream is::

    y[k] = sum_{j=0}^{M-1} taps[j] * x[k*R - j]        (x[i] = 0 for i < 0)

i.e. ``scipy.signal.lfilter(taps, 1, x)[::R]``: the filter output is kept at
input indices ``0, R, 2R, ...``. Only the kept outputs are computed.

State between chunks:

- ``hist`` (length ``M - 1``) holds the most recent inputs, newest first:
  ``hist[m] = x[start - 1 - m]`` where ``start`` is the global index of the
  chunk's first sample (zeros before the stream starts);
- ``phase`` is the number of inputs consumed so far, modulo ``R``.

Each output is summed over ``j = 0 .. M-1`` in the same order whether its
inputs come from ``hist`` or from the chunk, so chunks of any length give
bit-identical results to one call on the whole stream. The loop is split:
the first outputs of a chunk (window reaching into ``hist``) take each input
from where it lies; the others read the chunk only, four outputs at a time
(four independent sums, so the processor overlaps their addition chains),
with unsigned indices (no negative-index wraparound on every load).

The decimation factor ``R`` is the kernel's last argument (the state alone
does not determine it). Kernels never validate: the public wrappers
(``sins_sim.models.readout``) do, and size ``y`` with the number of outputs
the chunk produces.
"""

from __future__ import annotations

import numpy as np

from sins_sim._kernels._config import jit


@jit
def fir_decimate(taps, x, hist, phase, y, decimation):
    """Filter ``x`` with ``taps`` and keep every ``decimation``-th output.

    Parameters
    ----------
    taps : ndarray, shape (M,), float64
        FIR coefficients, ``M >= 1``.
    x : ndarray, shape (n,), float64
        Input chunk.
    hist : ndarray, shape (M - 1,), float64
        The ``M - 1`` most recent inputs before this chunk, newest first;
        updated in place to the ``M - 1`` most recent inputs after it.
    phase : int
        Inputs consumed before this chunk, modulo ``decimation``.
    y : ndarray, float64
        Output buffer with room for every output this chunk produces:
        ``ceil((n - i0) / R)`` with ``i0 = (R - phase) % R`` when ``i0 < n``,
        else 0; written from index 0.
    decimation : int
        Decimation factor ``R >= 1``.

    Returns
    -------
    n_out : int
        Number of outputs written to ``y``.
    new_phase : int
        ``(phase + n) % R``, the ``phase`` for the next chunk.
    """
    r = decimation
    n = x.shape[0]
    m_taps = taps.shape[0]
    n_hist = m_taps - 1
    i = (r - phase) % r
    n_out = 0
    # Outputs whose window reaches back before the chunk: inputs from hist and x.
    while i < n and i < n_hist:
        acc = 0.0
        for j in range(m_taps):
            idx = i - j
            if idx >= 0:
                acc += taps[j] * x[idx]
            else:
                acc += taps[j] * hist[-idx - 1]
        y[n_out] = acc
        n_out += 1
        i += r
    # The rest read only the chunk: four outputs at a time (independent sums, each in the
    # same order j = 0 .. M-1 as above, so the bits do not depend on the chunking).
    # Unsigned indices (all >= 0 here): no negative-index wraparound per load.
    ur = np.uint64(r)
    ur2 = np.uint64(2 * r)
    ur3 = np.uint64(3 * r)
    one = np.uint64(1)
    while i + 3 * r < n:
        a0 = 0.0
        a1 = 0.0
        a2 = 0.0
        a3 = 0.0
        k = np.uint64(i)  # i - j
        for j in range(m_taps):
            t = taps[j]
            a0 += t * x[k]
            a1 += t * x[k + ur]
            a2 += t * x[k + ur2]
            a3 += t * x[k + ur3]
            k -= one
        y[n_out] = a0
        y[n_out + 1] = a1
        y[n_out + 2] = a2
        y[n_out + 3] = a3
        n_out += 4
        i += 4 * r
    while i < n:
        acc = 0.0
        for j in range(m_taps):
            acc += taps[j] * x[i - j]
        y[n_out] = acc
        n_out += 1
        i += r
    # Keep the M - 1 newest inputs, newest first.
    if n >= n_hist:
        for m in range(n_hist):
            hist[m] = x[n - 1 - m]
    else:
        # Shift the old history back by n (descending, so no source is
        # overwritten before it is read), then put the chunk in front.
        for m in range(n_hist - 1, n - 1, -1):
            hist[m] = hist[m - n]
        for m in range(n):
            hist[m] = x[n - 1 - m]
    return n_out, (phase + n) % r
