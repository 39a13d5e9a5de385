"""Gyro scale factors and misalignments from a rate-table log: constant rates about each axis, both ways.

Arrays in, numbers out (SI inside; ppm and arcsec at :meth:`RateTableFit.to_dict`).

Model (the gyro error equation with scale factor and misalignment; Titterton and Weston 2004, ch. 4, and their
calibration on a rate table, ch. 8; Groves 2013, sec. 4.4.6: ``w_meas = b + (I + E) w + n``): over a window of
constant table rate ``W`` about body axis ``a`` the mean measured rate is::

    m = (I + E) W e_a + b + e + n

with ``E`` holding the scale factors ``S_i`` on its diagonal and the misalignments ``M_ij`` (sensor ``i``'s
sensitivity to body axis ``j``, the convention of :mod:`sins_sim.models.sensor_errors`) off it, ``b`` the bias
and ``e`` the Earth's rate seen in body axes, averaged over the window. A window at ``+W`` and one at ``-W``
about the same axis (the classic reversal test) give column ``a`` of ``E`` free of the bias and of the Earth's
rate along the axis::

    E[:, a] = (m+ - m-) / (2 W) - e_a

The Earth's rate across the axis turns with the table; over a turn of ``Theta`` radians its mean has the magnitude
``2 |sin(Theta / 2)| / Theta`` of it (``|int_0^Theta exp(i theta) d theta| / Theta``), zero for whole
revolutions. That bound, ``Omega_E 2 |sin(Theta / 2)| / Theta`` per window (the direction depends on where the
turn starts), enters the sigma as a uniform error (its bound over ``sqrt 3``), beside the noise of each window's mean (``std / sqrt(n)`` of the window's rate samples: white noise
over a window of seconds). A column is determined only where a reversal pair about its axis exists; the others
are "not excited".

Not covered here: accelerometer scale factors and g-sensitivity (they need the unit turned through gravity:
:mod:`sins_sim.navigation.multiposition`),
scale-factor asymmetry (it cancels in ``m+ - m-`` and shows in ``m+ + m-``), nonlinearity (several rates).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sins_sim.earth import EARTH_RATE_RAD_S
from sins_sim.units import ARCSEC

__all__ = ["RateTableFit", "fit_rate_table"]


@dataclass(frozen=True)
class RateTableFit:
    """Scale factors and misalignments read from reversal pairs.

    Attributes
    ----------
    e_matrix : ndarray, shape (3, 3)
        ``E`` (dimensionless); NaN in a column not excited.
    sigma : ndarray, shape (3, 3)
        1-sigma of each entry.
    excited : tuple of bool
        Per body axis, whether a reversal pair about it exists.
    pairs : tuple
        ``(axis, |W| rad/s, seconds +, seconds -)`` of each pair used.
    """

    e_matrix: np.ndarray
    sigma: np.ndarray
    excited: tuple
    pairs: tuple

    def to_dict(self) -> dict:
        """Scale factors (ppm) and misalignments (arcsec, keys ``xy`` ...: sensor x towards body y) with sigmas;
        ``not excited`` where no pair exists."""
        out = {"scale_factor_ppm": {}, "misalignment_arcsec": {}}
        for i, si in enumerate("xyz"):
            for j, sj in enumerate("xyz"):
                if not self.excited[j]:
                    entry = {"status": "not excited"}
                elif i == j:
                    entry = {"value": float(self.e_matrix[i, i] * 1e6), "sigma": float(self.sigma[i, i] * 1e6)}
                else:
                    entry = {"value": float(self.e_matrix[i, j] / ARCSEC), "sigma": float(self.sigma[i, j] / ARCSEC)}
                if i == j:
                    out["scale_factor_ppm"][si] = entry
                else:
                    out["misalignment_arcsec"][si + sj] = entry
        out["pairs"] = [{"axis": "xyz"[a], "rate_deg_s": math.degrees(w), "seconds": [tp, tm]}
                        for a, w, tp, tm in self.pairs]
        return out


def _turn_mean(theta: float) -> float:
    """``|mean of exp(i x) over x in [0, theta]|`` = ``2 |sin(theta / 2)| / theta`` (1 for no turn)."""
    return 1.0 if theta <= 0.0 else min(1.0, 2.0 * abs(math.sin(0.5 * theta)) / theta)


def _window_mean(rate: np.ndarray, t: np.ndarray, t0: float, t1: float) -> tuple:
    sel = (t > t0) & (t <= t1)
    n = int(np.count_nonzero(sel))
    if n < 10:
        raise ValueError(f"segments: the window {t0:g} to {t1:g} s holds {n} samples (at least 10)")
    x = rate[sel]
    return x.mean(axis=0), x.std(axis=0, ddof=1) / math.sqrt(n), (t1 - t0)


def fit_rate_table(t_s, dtheta, segments) -> RateTableFit:
    """Fit ``E`` from the reversal pairs of a rate-table log (module docstring).

    Parameters
    ----------
    t_s : array_like, shape (N,)
        End time of each interval (s), evenly spaced.
    dtheta : array_like, shape (N, 3)
        Gyro angle increments (rad), body axes.
    segments : sequence of (float, float, int, float)
        ``(start_s, end_s, axis, rate_rad_s)``: a window of constant table rate about body axis ``axis``
        (0, 1, 2); a pair is a window at ``+W`` and one at ``-W`` about the same axis (the first of each sign is
        used).

    Raises
    ------
    ValueError
        A window with fewer than 10 samples, an axis outside 0..2, a zero rate.
    """
    t = np.asarray(t_s, dtype=np.float64)
    dth = np.asarray(dtheta, dtype=np.float64)
    dt = float(t[1] - t[0])
    rate = dth / dt
    found: dict = {}
    for k, (t0, t1, axis, w) in enumerate(segments):
        if axis not in (0, 1, 2):
            raise ValueError(f"segments[{k}]: axis must be 0, 1 or 2, got {axis!r}")
        if not (math.isfinite(w) and w != 0.0):
            raise ValueError(f"segments[{k}]: the rate must be finite and non-zero, got {w!r}")
        key = (axis, round(abs(w), 12), w > 0.0)
        found.setdefault(key, (t0, t1, w))
    e_mat = np.full((3, 3), np.nan)
    sig = np.full((3, 3), np.nan)
    excited, pairs = [False] * 3, []
    for (axis, w_abs, positive), (t0, t1, w) in sorted(found.items()):
        if not positive or excited[axis]:
            continue
        neg = found.get((axis, w_abs, False))
        if neg is None:
            continue
        mp, sp, tp = _window_mean(rate, t, t0, t1)
        mm, sm, tm = _window_mean(rate, t, neg[0], neg[1])
        col = (mp - mm) / (2.0 * w_abs)
        col[axis] -= 1.0
        # the Earth's rate across the axis, turned through Theta = W T in each window: its mean has the magnitude
        # 2 |sin(Theta / 2)| / Theta of it (of unknown direction), zero for whole turns
        earth = sum(EARTH_RATE_RAD_S * _turn_mean(w_abs * d) for d in (tp, tm)) / math.sqrt(3.0)
        s = np.sqrt(sp ** 2 + sm ** 2 + np.where(np.arange(3) == axis, 0.0, earth ** 2)) / (2.0 * w_abs)
        e_mat[:, axis], sig[:, axis] = col, s
        excited[axis] = True
        pairs.append((axis, w_abs, float(tp), float(tm)))
    return RateTableFit(e_mat, sig, tuple(excited), tuple(pairs))
