"""Drive-side loops of the engine: the DAC sine and the amplitude loop's synchronous detector.

Both run once per plant step and per axis, so they are kernels rather than numpy
expressions (which allocate several temporaries per sample).
"""

from __future__ import annotations

import math

from sins_sim._kernels._config import jit

_RESYNC = 128


@jit
def dac_cosine(i0, r_dac, cycles_per_dac, phase, scale, out):
    """``out[j] = scale * cos(2 pi frac(f k / dac_rate) + phase)`` with ``k = (i0 + j) // r_dac``.

    The DAC sample of plant step ``i0 + j`` (zero-order hold over ``r_dac`` plant steps). The
    phase advances by rotation from one DAC sample to the next and is recomputed exactly from
    the integer index every 128 samples, so long runs do not drift (rotation error ~1e-14).
    """
    d = 2.0 * math.pi * cycles_per_dac
    cd = math.cos(d)
    sd = math.sin(d)
    k_prev = -1
    n_rot = 0
    c = 0.0
    s = 0.0
    for j in range(out.shape[0]):
        k = (i0 + j) // r_dac
        if k != k_prev:
            if k_prev < 0 or k != k_prev + 1 or n_rot >= _RESYNC:
                x = cycles_per_dac * k
                ph = 2.0 * math.pi * (x - math.floor(x)) + phase
                c = math.cos(ph)
                s = math.sin(ph)
                n_rot = 0
            else:
                c, s = c * cd - s * sd, s * cd + c * sd
                n_rot += 1
            k_prev = k
        out[j] = scale * c


@jit
def demod_accumulate(delta, i0, cycles_per_step, pos, block, acc):
    """Hann-windowed synchronous detection of ``delta`` at the drive frequency.

    ``delta[j]`` is the deflection at plant step ``i0 + 1 + j`` and sits at position
    ``pos + j`` of a block of ``block`` steps. Adds ``sum w delta cos``, ``sum w delta sin``
    and ``sum w`` to ``acc[0:3]``. Phase and window advance by rotation, re-synchronised
    exactly every 128 samples (the detector needs ~1e-12, the rotation keeps ~1e-14).
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
    a0 = 0.0
    a1 = 0.0
    a2 = 0.0
    for j in range(n):
        if j % _RESYNC == 0:
            x = cycles_per_step * (i0 + 1 + j)
            ph = 2.0 * math.pi * (x - math.floor(x))
            c = math.cos(ph)
            s = math.sin(ph)
            arg = dwin * (pos + j + 0.5)
            wc = math.cos(arg)
            ws = math.sin(arg)
        w = 0.5 * (1.0 - wc)  # sin^2(pi (m + 1/2) / block)
        wd = w * delta[j]
        a0 += wd * c
        a1 += wd * s
        a2 += w
        c, s = c * cd - s * sd, s * cd + c * sd
        wc, ws = wc * cw - ws * sw, ws * cw + wc * sw
    acc[0] += a0
    acc[1] += a1
    acc[2] += a2
