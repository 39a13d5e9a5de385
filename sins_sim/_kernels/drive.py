"""Drive-side loops of the engine: the DAC sine and the amplitude loop's synchronous detector.

Both run once per plant step and per axis, so they are kernels rather than numpy
expressions (which allocate several temporaries per sample).
"""

from __future__ import annotations

import math

from sins_sim._kernels._config import jit

_RESYNC = 128


@jit
def _rotated_phase(index, cycles, phase, cd, sd):
    """cos and sin of ``2 pi frac(cycles * index) + phase``, computed exactly at the last multiple
    of 128 at or below ``index`` and rotated forward from there: a function of ``index`` alone,
    so chunked and whole-array runs give the same bits."""
    base = (index // _RESYNC) * _RESYNC
    x = cycles * base
    ph = 2.0 * math.pi * (x - math.floor(x)) + phase
    c = math.cos(ph)
    s = math.sin(ph)
    for _ in range(index - base):
        c, s = c * cd - s * sd, s * cd + c * sd
    return c, s


@jit
def dac_cosine(i0, r_dac, cycles_per_dac, phase, scale, out):
    """``out[j] = scale * cos(2 pi frac(f k / dac_rate) + phase)`` with ``k = (i0 + j) // r_dac``.

    The DAC sample of plant step ``i0 + j`` (zero-order hold over ``r_dac`` plant steps). The
    phase advances by rotation from one DAC sample to the next and is recomputed exactly from
    the integer index at every multiple of 128, so long runs do not drift (rotation error
    ~1e-14) and the result does not depend on how the run is chunked.
    """
    d = 2.0 * math.pi * cycles_per_dac
    cd = math.cos(d)
    sd = math.sin(d)
    k_prev = -1
    c = 0.0
    s = 0.0
    k = i0 // r_dac  # DAC sample of step i0 + j, kept by a counter (no integer division per step)
    rem = i0 - k * r_dac
    for j in range(out.shape[0]):
        if k != k_prev:
            if k_prev < 0 or k % _RESYNC == 0:
                c, s = _rotated_phase(k, cycles_per_dac, phase, cd, sd)
            else:
                c, s = c * cd - s * sd, s * cd + c * sd
            k_prev = k
        out[j] = scale * c
        rem += 1
        if rem == r_dac:
            rem = 0
            k += 1


@jit
def demod_accumulate(delta, i0, cycles_per_step, pos, block, acc, phase):
    """Hann-windowed synchronous detection of ``delta`` at the drive frequency.

    The reference is ``exp(i (2 pi frac(cycles_per_step k) + phase))`` at plant step ``k``; ``phase``
    is 0 unless a tracking PLL changed the frequency (it then keeps the reference continuous).

    ``delta[j]`` is the deflection at plant step ``i0 + 1 + j`` and sits at position
    ``pos + j`` of a block of ``block`` steps. Adds ``sum w delta cos``, ``sum w delta sin``
    and ``sum w`` to ``acc[0:3]``. Phase and window advance by rotation; the phase is
    re-synchronised on absolute step indices and the window on block positions (multiples of
    128), so the result does not depend on how the block is split into calls.
    """
    n = delta.shape[0]
    dph = 2.0 * math.pi * cycles_per_step
    dwin = 2.0 * math.pi / block
    cd = math.cos(dph)
    sd = math.sin(dph)
    cw = math.cos(dwin)
    sw = math.sin(dwin)
    c = 0.0
    s = 0.0
    wc = 0.0
    ws = 0.0
    a0 = acc[0]  # continue the running sums in order: the same bits however the block is split
    a1 = acc[1]
    a2 = acc[2]
    j = 0
    while j < n:
        # resync where an absolute index or a block position is a multiple of 128 (or at the start), then
        # rotate up to the next such point without a test per step
        if j == 0 or (i0 + 1 + j) % _RESYNC == 0:  # resync on absolute indices: chunking-invariant
            c, s = _rotated_phase(i0 + 1 + j, cycles_per_step, phase, cd, sd)
        if j == 0 or (pos + j) % _RESYNC == 0:  # the window, likewise on its position in the block
            base = ((pos + j) // _RESYNC) * _RESYNC
            arg = dwin * (base + 0.5)
            wc = math.cos(arg)
            ws = math.sin(arg)
            for _ in range(pos + j - base):
                wc, ws = wc * cw - ws * sw, ws * cw + wc * sw
        stop = min(n, j + _RESYNC - (i0 + 1 + j) % _RESYNC, j + _RESYNC - (pos + j) % _RESYNC)
        for k in range(j, stop):
            w = 0.5 * (1.0 - wc)  # sin^2(pi (m + 1/2) / block)
            wd = w * delta[k]
            a0 += wd * c
            a1 += wd * s
            a2 += w
            c, s = c * cd - s * sd, s * cd + c * sd
            wc, ws = wc * cw - ws * sw, ws * cw + wc * sw
        j = stop
    acc[0] = a0
    acc[1] = a1
    acc[2] = a2
