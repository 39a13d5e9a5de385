"""The ``block:`` section of IMU files: the sensor block as a body on its isolators (issue 27).

Without the section the block is rigid and its motion prescribed (the nominal model). With it, the block is a rigid
body on linear isolators, loaded by the three gyros' suspension torques (:mod:`sins_sim.models.block`,
docs/user-guide/block.md)::

    block:
      mass_kg: 3.0
      inertia_kg_m2: {xx: 0.012, yy: 0.013, zz: 0.015, xy: 0.0, xz: 0.0, yz: 0.0}
      gyro_inertia_kg_m2: [2.0e-4, 2.0e-4, 2.0e-4]
      gyro_axes_mrad: {x: [0, 0.5, 0], y: [0, 0, 0], z: [0, 0, 0]}   # input-axis offsets, optional
      isolators:
        stiffness_n_per_m: [7.6e5, 7.6e5, 7.6e5]
        damping_n_s_per_m: [150, 150, 150]
        rotational_stiffness_n_m_per_rad: [4740, 5100, 5900]
        rotational_damping_n_m_s_per_rad: [0.75, 0.8, 0.95]
        elastic_centre_mm: [0, 0, 0]

Products of inertia are the tensor's off-diagonal entries (``J_xy = -int x y dm``). ``gyro_axes_mrad.<axis>`` is
the offset of that gyro's input axis from the block axis (its own component must be 0): it orients the gyro's
dither torque on the block and the block rotation the gyro feels. The chassis motion the gyro senses through a
misaligned axis is the sensor-error model's ``sensors.gyro.misalignment``.
"""

from __future__ import annotations

from sins_sim.config.schema import Map, Num, Vec

__all__ = ["BLOCK_SCHEMA"]

#: Physical ranges. Mass: a MEMS board (0.1 kg) to a large marine RLG unit's sensor assembly (50 kg). Inertia
#: about any axis: 1e-5 kg m^2 (a 0.1 kg, 3 cm block) to 5 kg m^2. A dithered gyro body: 1e-6 kg m^2 (a 10 cm
#: perimeter RLG) to 1e-2 kg m^2. Stiffness: up to a hard mount (1e9 N/m, 1e7 N m/rad); 0 removes the isolator
#: on that axis (a free block: only for momentum checks, the block then drifts with what it is given).
_MASS = dict(min=0.1, max=50.0)
_J = dict(min=-5.0, max=5.0)
_JG = dict(min=1e-6, max=1e-2)
_K_T = dict(min=0.0, max=1e9)
_K_R = dict(min=0.0, max=1e7)
_C_T = dict(min=0.0, max=1e6)
_C_R = dict(min=0.0, max=1e4)
#: A mounting offset beyond 50 mrad (3 deg) is not a misalignment but a different design.
_MISALIGN_MRAD = 50.0
#: The same bound, public: what any input-axis offset (a file's ``gyro_axes_mrad``, a study's tilt) may reach.
AXIS_OFFSET_MAX_MRAD = _MISALIGN_MRAD

BLOCK_SCHEMA = Map({
    "mass": Num(unit="kg", required=True, **_MASS, doc="the block with everything it carries"),
    "inertia_kg_m2": Map({k: Num(unit=None, required=k in ("xx", "yy", "zz"), default=None if k in ("xx", "yy", "zz")
                           else 0.0, **_J) for k in ("xx", "yy", "zz", "xy", "xz", "yz")},
                   required=True, doc="kg m^2 about the c.g. in block axes, without each gyro's inertia about its "
                                      "input axis; off-diagonal entries are products of inertia (tensor convention)"),
    "gyro_inertia": Vec(unit="kg_m2", required=True, min=_JG["min"], max=_JG["max"],
                        doc="each dithered gyro body about its input axis (x, y, z)"),
    "gyro_axes_mrad": Map({a: Vec(min=-_MISALIGN_MRAD, max=_MISALIGN_MRAD, default=[0.0, 0.0, 0.0])
                           for a in ("x", "y", "z")}, default={},
                          doc="mrad: offset of each input axis from its block axis (own component 0)"),
    "isolators": Map({
        "stiffness": Vec(unit="n_per_m", required=True, **_K_T, doc="translational, at the elastic centre"),
        "damping": Vec(unit="n_s_per_m", required=True, **_C_T),
        "rotational_stiffness": Vec(unit="n_m_per_rad", required=True, **_K_R),
        "rotational_damping": Vec(unit="n_m_s_per_rad", required=True, **_C_R),
        "elastic_centre": Vec(unit="mm", min=-500.0, max=500.0, default=[0.0, 0.0, 0.0],
                              doc="relative to the c.g.; an offset couples translation and rocking"),
    }, required=True),
}, default=None, allow_null=True, rules=(
    "inertia_kg_m2: positive definite, principal moments J1 + J2 >= J3",
    "gyro_axes_mrad.<axis>: the axis's own component is 0",
    "the block's motion comes out of the suspensions: the engine then runs the three channels side by side, "
    "with their temperature, PLL and online schedules; effects other than viscous_damping are refused with a "
    "block (docs/user-guide/combinations.md)",
), doc="the sensor block as a body on its isolators (omit: the rigid block of the nominal model)")


