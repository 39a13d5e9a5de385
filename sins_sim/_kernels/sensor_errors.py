"""Sensor-error kernels: the stochastic part of a sensor triad's increments, sample by sample.

Each axis ``i`` of a triad sees, over sample ``n`` of length ``h``, the integral of

* a constant bias (``bias_inc[i] = b_i h``, supplied already integrated),
* white noise of the rate / specific force (angle or velocity random walk): a Gaussian increment
  of standard deviation ``white_sd[i] = N_i sqrt(h)``,
* a random walk of the rate (rate / acceleration random walk, coefficient ``K_i``),
* a sum of first-order Gauss-Markov processes (bias instability), ``P`` per axis,

all discretised exactly (the joint Gaussian law of the state at the end of the sample and of its
integral over the sample, given the state at the start), so that the statistics of the output do
not depend on ``h``. Each term draws its standard normals from its own ``numpy.random.Generator``
(numba's implementation of ``Generator.standard_normal`` uses NumPy's algorithm on the same bit
generator state), in a fixed order per sample, so a run does not depend on how it is chunked and
switching one term off does not change the others' realisations. The caller owns every state.
"""

from __future__ import annotations

from sins_sim._kernels._config import jit


@jit
def noise_increments(g_white, g_rw, g_gm, bias_inc, white_sd, rw_coef, rw_state, gm_coef, gm_state, out):
    """Integrated bias + white + random-walk + Gauss-Markov noise per sample and axis.

    Parameters
    ----------
    g_white, g_rw, g_gm : numpy.random.Generator
        Streams of the white noise (one normal per axis and sample, axes in order), of the random
        walk (two per axis and sample) and of the Gauss-Markov processes (two per axis, process and
        sample); a stream whose term is off is not touched.
    bias_inc : ndarray, shape (3,)
        Constant bias integrated over one sample (rad or m/s).
    white_sd : ndarray, shape (3,) or (0,)
        Standard deviation of the white-noise increment per sample, ``N sqrt(h)``; size 0: off.
    rw_coef : ndarray, shape (3, 4) or (0, 4)
        Per axis ``[K sqrt(h), K h^1.5 / 2, K h^1.5 / sqrt(12), h]``: the Cholesky factor of the joint
        law of (rate step, integral of the rate over the sample) and the sample length (s);
        0 rows: off.
    rw_state : ndarray, shape (3,)
        Random-walk rate at the start of the next sample (unit/s), updated in place.
    gm_coef : ndarray, shape (3, P, 5)
        Per axis and process ``[phi, mean_gain, l11, l21, l22]``: ``x_next = phi x + l11 z1`` and
        ``integral = mean_gain x + l21 z1 + l22 z2``; ``P = 0``: off.
    gm_state : ndarray, shape (3, P)
        Gauss-Markov states at the start of the next sample (unit/s), updated in place.
    out : ndarray, shape (n, 3)
        Filled with the noise increments (unit of ``bias_inc``); ``n`` is the number of samples.
    """
    n = out.shape[0]
    has_white = white_sd.shape[0] > 0
    has_rw = rw_coef.shape[0] > 0
    n_gm = gm_coef.shape[1]
    for k in range(n):
        for i in range(3):
            acc = bias_inc[i]
            if has_white:
                acc += white_sd[i] * g_white.standard_normal()
            if has_rw:
                z1 = g_rw.standard_normal()
                z2 = g_rw.standard_normal()
                r = rw_state[i]
                acc += r * rw_coef[i, 3] + rw_coef[i, 1] * z1 + rw_coef[i, 2] * z2
                rw_state[i] = r + rw_coef[i, 0] * z1
            for p in range(n_gm):
                z1 = g_gm.standard_normal()
                z2 = g_gm.standard_normal()
                x = gm_state[i, p]
                acc += gm_coef[i, p, 1] * x + gm_coef[i, p, 3] * z1 + gm_coef[i, p, 4] * z2
                gm_state[i, p] = gm_coef[i, p, 0] * x + gm_coef[i, p, 2] * z1
            out[k, i] = acc
