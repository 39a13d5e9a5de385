"""Three-axis motion of the SINS block with exact truth: the library's overview and its registry.

The block motions (frozen dataclasses, SI units, ``+`` builds a
:class:`~sins_sim.models.motion.base.SumMotion3D`) live one kind per module;
this module holds :data:`MOTION_TYPES` and :func:`build_motion`, which build
them from dictionaries, and re-exports every public name of the library so
that ``from sins_sim.models.motion.body import ...`` keeps working:

* :mod:`~sins_sim.models.motion.base`: the interface :class:`Motion3D`
  (body rate, exact gyro angles, closed-form or Magnus-4 attitude),
  :class:`GyroAxis`, :class:`AttitudeStream`, :class:`SumMotion3D`, and the
  helpers every motion shares (frames and signals are described there);
* :mod:`~sins_sim.models.motion.rotations`: :class:`Static`,
  :class:`ConstantRate`, :class:`Turn`;
* :mod:`~sins_sim.models.motion.sines`: :class:`AxisSines`, :class:`Coning`,
  :class:`RandomVibration` (sums of sinusoids);
* :mod:`~sins_sim.models.motion.shocks`: :class:`Shock`;
* :mod:`~sins_sim.models.motion.sweeps`: :class:`RateTableSweep`;
* :mod:`~sins_sim.models.motion.specific_force`: :func:`specific_force_body`,
  :data:`STANDARD_GRAVITY`.

.. autosummary::

   Static
   ConstantRate
   Turn
   AxisSines
   Coning
   RandomVibration
   Shock
   RateTableSweep
   SumMotion3D
   specific_force_body
   build_motion

References
----------
The modules cite these by number.

.. [1] J. E. Bortz, "A new mathematical formulation for strapdown inertial
   navigation", IEEE Trans. Aerosp. Electron. Syst. AES-7(1), 61-66, 1971.
.. [2] P. G. Savage, "Strapdown inertial navigation integration algorithm
   design, Part 1: attitude algorithms", J. Guid. Control Dyn. 21(1), 19-28,
   1998 (coning motion and the two-sample coning algorithm).
.. [3] L. E. Goodman, A. R. Robinson, "Effect of finite rotations on
   gyroscopic sensing devices", J. Appl. Mech. 25, 210-213, 1958 (coning drift).
.. [4] S. Blanes, F. Casas, J. A. Oteo, J. Ros, "The Magnus expansion and
   some of its applications", Phys. Rep. 470, 151-238, 2009.
.. [5] M. Shinozuka, C.-M. Jan, "Digital simulation of random processes and
   its applications", J. Sound Vib. 25(1), 111-128, 1972 (spectral
   representation of a random process by a sum of cosines).
"""

from __future__ import annotations

from sins_sim.models.motion._registry import build_typed
from sins_sim.models.motion.base import DEFAULT_SUBSTEPS, AttitudeStream, GyroAxis, Motion3D, SumMotion3D
from sins_sim.models.motion.rotations import ConstantRate, Static, Turn
from sins_sim.models.motion.shocks import Shock
from sins_sim.models.motion.sines import AxisSines, Coning, RandomVibration
from sins_sim.models.motion.specific_force import STANDARD_GRAVITY, specific_force_body
from sins_sim.models.motion.sweeps import RateTableSweep

__all__ = [
    "Motion3D",
    "GyroAxis",
    "AttitudeStream",
    "Static",
    "ConstantRate",
    "Turn",
    "AxisSines",
    "Coning",
    "RandomVibration",
    "Shock",
    "RateTableSweep",
    "SumMotion3D",
    "MOTION_TYPES",
    "build_motion",
    "specific_force_body",
    "STANDARD_GRAVITY",
    "DEFAULT_SUBSTEPS",
]

# --- registry -----------------------------------------------------------------

MOTION_TYPES = {
    "static": Static,
    "constant_rate": ConstantRate,
    "turn": Turn,
    "sines": AxisSines,
    "coning": Coning,
    "random_vibration": RandomVibration,
    "shock": Shock,
    "sweep": RateTableSweep,
}
"""Motion type names (the ``type`` key of :func:`build_motion`) and their classes."""


def build_motion(specs):
    """Build a :class:`SumMotion3D` from a list of dictionaries.

    Parameters
    ----------
    specs : list of dict
        Each ``{"type": name, **keyword arguments in SI units}`` with
        ``name`` a key of :data:`MOTION_TYPES`; the keywords are the class's
        fields. Unit conversion (arcmin, deg/s, ...) belongs to the YAML layer
        above.

    Returns
    -------
    SumMotion3D

    Raises
    ------
    ValueError
        An entry that is not a dict, lacks ``type``, names an unknown type,
        has an unknown key or misses a required one, or fails the class's
        validation; the message names the entry and the key.

    Examples
    --------
    >>> from sins_sim.models.motion import build_motion
    >>> from sins_sim.units import ARCMIN
    >>> m = build_motion([{"type": "coning", "amplitude_rad": ARCMIN, "frequency_hz": 100.0},
    ...                   {"type": "shock", "axis": "x", "peak_rate_rad_s": 0.1, "duration_s": 1e-3}])
    >>> m.body_rate([0.0, 1e-3]).shape
    (2, 3)
    """
    if isinstance(specs, dict) or not isinstance(specs, (list, tuple)):
        raise ValueError(f"motion: must be a list of {{'type': ..., ...}} entries, got {type(specs).__name__}")
    parts = []
    for i, spec in enumerate(specs):
        parts.append(build_typed(spec, MOTION_TYPES, f"motion[{i}]", "motion type"))
    return SumMotion3D(tuple(parts))
