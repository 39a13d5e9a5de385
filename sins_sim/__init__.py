"""sins-sim: a strapdown INS on mechanically dithered ring laser gyros, down to the suspension physics.

Frames and signals (reference-model.md): for each gyro channel,
``phi_sins`` is the block's angle about the gyro's sensitive axis,
``phi_rlg`` the RLG body's angle w.r.t. inertial space, and
``delta = phi_rlg - phi_sins`` the dither suspension's deflection.

Units: SI inside, angles in rad, rates in rad/s, frequencies in Hz
(``omega`` in rad/s), voltages in V. arcsec / arcmin / deg and deg/h appear
only at the edges (configuration, plots, reports); see :mod:`sins_sim.units`.

Layers (imports point one way): ``cli -> jobs -> identification -> simulation ->
{models, filters, navigation} -> _kernels -> units``.
"""

__version__ = "0.1.0"
