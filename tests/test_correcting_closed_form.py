"""The correcting filter's turning-point refinement against its closed form (eq. 10 inside eq. 5).

The filter tracks the turning points of its own deflection estimate ``D`` and refines each by the parabola through
the three samples around it (``sins_sim._kernels.correcting``). For samples ``y(-1), y(0), y(1)`` the parabola's
vertex lies at the offset ``(y(-1) - y(1)) / (2 (y(-1) - 2 y(0) + y(1)))`` and has the value

    y(0) - (y(-1) - y(1))^2 / (8 (y(-1) - 2 y(0) + y(1))).

For a sinusoid ``A cos(theta (k - delta))`` sampled at ``k = -1, 0, 1`` (``theta`` rad per sample, the peak
``delta`` samples after the middle one) this is, with ``y(-1) - 2 y(0) + y(1) = -2 (1 - cos theta) cos(theta delta)``
and ``y(-1) - y(1) = -2 sin(theta) sin(theta delta)``::

    vertex = A [cos(theta delta) + (1 + cos theta) sin^2(theta delta) / (4 cos(theta delta))]
    offset = tan(theta delta) / (2 tan(theta / 2))

and ``vertex - A = -A theta^4 delta^2 / 8 + O(theta^6)``: the raw sample understates ``A`` by
``1 - cos(theta delta)`` (0.51 % here), the vertex by 0.013 %.

The filter is fed an RLG angle ``X`` built so that its ``D`` is exactly that sinusoid (eq. 5 inverted; with
``k1 = k5 = 0`` and no turning point yet, ``D_n = dX_n - a2 (dX_n - dX_{n-1})``, unity form). The first turning
point is seen at sample 6 (``D_4`` is the largest sample); there eq. 10 switches on with ``a`` = the vertex value,
and the output moves by exactly ``Diss = -k3 a (1 + k4 a) sqrt(1 - (D_5 / a)^2)`` (the paper's rule: centre 0,
the branch now falling). Every copy of the arithmetic is checked: the streaming filter, the lanes kernel and the
plain-Python reference (``sins_sim.bench.references``).

Tolerances: ``X`` is built from ``D`` by a recursion of gain ``a2 / (a2 - 1) = 1.13`` over seven samples and the
filter forms ``D`` back with the weight ``a2 = 8.9``: relative errors of a few 1e-15 on ``D``, amplified by
``1 / curvature ~ 10`` in the vertex: 1e-12 relative covers them by two orders. The ``Diss`` difference is taken
between two outputs of size ~1e-3 rad (rounding ~1e-19 rad) against a ``Diss`` of ~1e-6 rad: 1e-9 relative.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sins_sim._kernels import correcting as kcor
from sins_sim._kernels import physics as kphys
from sins_sim.bench.references import correcting_reference
from sins_sim.filters.correcting import CorrectingFilter, CorrectingFilterDesign

FS, F0 = 7200.0, 386.0
THETA = 2.0 * math.pi * F0 / FS      # rad per sample of the D sinusoid (a dither at f0)
AMP = 3.0 * math.pi / 10800.0        # 3 arcmin, the paper's dither amplitude
PEAK = 4.3                           # the peak sits 0.3 samples after sample 4
DELTA = PEAK - 4.0
TURN = 6                             # the sample at which the turning point at D_4 is recognised


def _design(k3=4.4e-3):
    return CorrectingFilterDesign(f0_hz=F0, k1=0.0, k3=k3, k4=250.0, k5=0.0, fs_hz=FS, form="unity",
                                  hysteresis="paper")


def _d_wanted(n=TURN + 1):
    return AMP * np.cos(THETA * (np.arange(n) - PEAK))


def _x_for(d, a2):
    """The angles X_0.. (X_{-1} = X_{-2} = 0) whose eq.-5 deflection estimate is ``d`` while eq. 9 and 10 are off."""
    x = np.empty(d.size)
    x_prev, dx_prev = 0.0, 0.0
    for n, dn in enumerate(d):
        dx = (dn - a2 * dx_prev) / (1.0 - a2)
        x[n] = x_prev + dx
        x_prev, dx_prev = x[n], dx
    return x


def _vertex_closed_form():
    c, s = math.cos(THETA * DELTA), math.sin(THETA * DELTA)
    return AMP * (c + (1.0 + math.cos(THETA)) * s * s / (4.0 * c))


def _diss(a, d1, k3=4.4e-3, k4=250.0):
    return -k3 * a * (1.0 + k4 * a) * math.sqrt(1.0 - (d1 / a) ** 2)


def test_the_closed_forms_are_the_parabola_through_three_sinusoid_samples():
    """The brief's vertex formulas on the samples D_3, D_4, D_5 against the sinusoid's closed forms (a check of
    the expectations below), and the size of the refinement: the vertex is within A theta^4 delta^2 / 8 (+2 %
    for the next order) of A (0.013 %), the raw sample 0.5 % below it."""
    ym, y0, yp = _d_wanted()[3:6]
    curv = ym - 2.0 * y0 + yp
    assert (ym - yp) / (2.0 * curv) == pytest.approx(math.tan(THETA * DELTA) / (2.0 * math.tan(THETA / 2.0)),
                                                     rel=1e-12)
    vertex = y0 - (ym - yp) ** 2 / (8.0 * curv)
    assert vertex == pytest.approx(_vertex_closed_form(), rel=1e-12)
    assert abs(vertex / AMP - 1.0) <= 1.02 * THETA ** 4 * DELTA ** 2 / 8.0
    assert 1.0 - y0 / AMP == pytest.approx(1.0 - math.cos(THETA * DELTA), rel=1e-9)
    assert 1.0 - y0 / AMP > 30 * abs(vertex / AMP - 1.0)


def test_streaming_filter_takes_the_vertex_as_the_amplitude_and_its_output_moves_by_diss():
    design = _design()
    a2, g = design.coefficients
    assert g == 1.0
    d = _d_wanted()
    x = _x_for(d, a2)
    with_diss = CorrectingFilter(design)
    y = with_diss.process(x)
    y0 = CorrectingFilter(_design(k3=0.0)).process(x)
    # the filter's own D is the sinusoid (eq. 5 inverted), up to rounding
    assert np.allclose(x[:TURN] - y[:TURN], d[:TURN], rtol=0.0, atol=1e-15 * AMP * 100)
    a = _vertex_closed_form()
    # the amplitude of eq. 10's branch is the vertex, not the sample D_4 (0.5 % lower)
    assert with_diss.hyst[1] == pytest.approx(a, rel=1e-12)
    # before the turning point eq. 10 is off: identical outputs
    assert np.array_equal(y[:TURN], y0[:TURN])
    assert y[TURN] - y0[TURN] == pytest.approx(_diss(a, d[TURN - 1]), rel=1e-9)


def test_lanes_kernel_and_python_reference_take_the_same_vertex():
    """The two other copies of the refinement: the lanes kernel (the engine's fused path) and the plain-Python
    reference of the benchmarks."""
    design = _design()
    a2, g = design.coefficients
    d = _d_wanted()
    x = _x_for(d, a2)
    a = _vertex_closed_form()
    # lanes: one lane, the single filter's parameters and rest state
    f = CorrectingFilter(design)
    par = np.array([[a2, g, design.k1, design.k2, design.k3, design.k4, design.k5, 1.0 / FS, 0.25 / F0]])
    state = np.zeros((1, kcor.STATE_SIZE))
    hyst = f.hyst[None, :].copy()
    stack = f.stack[None, :].copy()
    out = np.empty((1, x.size))
    kcor.correcting_lanes(x[None, :], np.zeros((1, x.size)), np.zeros(1, dtype=np.int64), par,
                          np.array([kphys.RULES["paper"]], dtype=np.int64), state, hyst, stack, out)
    assert hyst[0, 1] == pytest.approx(a, rel=1e-12)
    # reference: its output at the turning sample moves by Diss with the vertex amplitude
    ref = correcting_reference(x, np.zeros(x.size), design)
    ref0 = correcting_reference(x, np.zeros(x.size), _design(k3=0.0))
    assert ref[TURN] - ref0[TURN] == pytest.approx(_diss(a, d[TURN - 1]), rel=1e-9)
    assert out[0, TURN] - ref0[TURN] == pytest.approx(_diss(a, d[TURN - 1]), rel=1e-9)
