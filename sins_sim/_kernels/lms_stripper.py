"""The three-axis LMS dither stripper (after US 7,440,109), the per-sample loop.

See :mod:`sins_sim.filters.lms_stripper` for the method, its stability bound and its sources.
Kernels never validate: the public wrapper does.
"""

from __future__ import annotations

import math

import numpy as np

from sins_sim._kernels._config import jit

# state layout (float64[STATE_SIZE])
U = 0  # leaky integrals of the three pickoff voltages, u_n (V s)
UP = 3  # u_{n-1}
UHP = 6  # HP(u)_{n-1}
P = 9  # running mean of the regressor power
K = 10  # samples processed
DIV = 11  # sample (1-based) at which the gains left their bound; 0: not diverged
STATE_SIZE = 12


@jit
def lms3_run(x, volts, h, lam, bank, mu, kappa, reg, hold, limit, stride, state, zx, zu, gains, out, hist):
    """Strip a chunk of the three axes; ``state``, ``gains`` updated in place.

    Parameters
    ----------
    x, volts : float64[3, m]
        Counts as angle (rad) and pickoff voltages (V) of axes x, y, z.
    h, lam : float
        Sample interval (s) and leak factor of the pickoff integrators.
    bank : float64[nb, 5]
        The adaptation filter ``HP``: biquads ``b0, b1, b2, a1, a2`` (``a0 = 1``) whose outputs are *summed* (a
        parallel bank: one high-pass, or one band-pass per dither frequency).
    mu, kappa, reg : float
        NLMS step, weight of the running power mean, regularisation (fraction of that mean).
    hold : float
        Samples after a reset before adaptation starts.
    limit : float
        Bound on every gain's magnitude; beyond it (or not finite) the stripper has diverged and
        its output is NaN from that sample on.
    stride : int
        Every ``stride``-th sample (counted from the reset) the gains are copied to ``hist``.
    state : float64[STATE_SIZE]
    zx, zu : float64[3, nb, 2]
        Bank state (transposed direct form II) on the counts and on the integrals, per axis and biquad.
    gains : float64[2, 3, 3]
        ``E`` and ``F`` (rad per V s).
    out : float64[3, m]
    hist : float64[rows, 18]
        Gain snapshots, ``E`` then ``F`` row-major; rows >= m // stride + 1.

    Returns
    -------
    int
        Snapshots written.
    """
    nb = bank.shape[0]
    n_hist = 0
    uh = np.zeros(3)
    xh = np.zeros(3)
    e = np.zeros(3)
    for n in range(x.shape[1]):
        k = state[K] + 1.0
        state[K] = k
        for i in range(3):
            state[U + i] = lam * state[U + i] + h * volts[i, n]
        diverged = state[DIV] > 0.0
        for i in range(3):
            est = 0.0
            for j in range(3):
                est += gains[0, i, j] * state[U + j] + gains[1, i, j] * state[UP + j]
            out[i, n] = math.nan if diverged else x[i, n] - est
        # high-pass (transposed direct form II) of the counts and of the integrals, separately:
        # no filter delay inside the adaptation loop
        for i in range(3):
            xi = x[i, n]
            ui = state[U + i]
            xs = 0.0
            us = 0.0
            for s in range(nb):
                b0, b1, b2, a1, a2 = bank[s, 0], bank[s, 1], bank[s, 2], bank[s, 3], bank[s, 4]
                v = b0 * xi + zx[i, s, 0]
                zx[i, s, 0] = b1 * xi - a1 * v + zx[i, s, 1]
                zx[i, s, 1] = b2 * xi - a2 * v
                xs += v
                w = b0 * ui + zu[i, s, 0]
                zu[i, s, 0] = b1 * ui - a1 * w + zu[i, s, 1]
                zu[i, s, 1] = b2 * ui - a2 * w
                us += w
            xh[i] = xs
            uh[i] = us
        inst = 0.0
        for j in range(3):
            inst += uh[j] * uh[j] + state[UHP + j] * state[UHP + j]
        state[P] = (1.0 - kappa) * state[P] + kappa * inst
        if k > hold and not diverged:
            norm = inst + reg * state[P]
            if norm > 0.0:
                g = mu / norm
                for i in range(3):
                    ei = xh[i]
                    for j in range(3):
                        ei -= gains[0, i, j] * uh[j] + gains[1, i, j] * state[UHP + j]
                    e[i] = ei
                big = 0.0
                for i in range(3):
                    for j in range(3):
                        gains[0, i, j] += g * e[i] * uh[j]
                        gains[1, i, j] += g * e[i] * state[UHP + j]
                        a = max(abs(gains[0, i, j]), abs(gains[1, i, j]))
                        if not a <= big:  # NaN compares false: counted as beyond the bound
                            big = a if a == a else math.inf
                if not big <= limit:
                    state[DIV] = k
        for j in range(3):
            state[UHP + j] = uh[j]
            state[UP + j] = state[U + j]
        if int(k) % stride == 0 and n_hist < hist.shape[0]:
            for i in range(3):
                for j in range(3):
                    hist[n_hist, 3 * i + j] = gains[0, i, j]
                    hist[n_hist, 9 + 3 * i + j] = gains[1, i, j]
            n_hist += 1
    return n_hist
