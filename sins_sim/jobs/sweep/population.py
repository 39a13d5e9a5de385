"""A population of units: seeded draws around the IMU file's values, and the unit applied to an IMU file.

Unit ``i``'s draws depend only on ``(sweep seed, i)``: every parameter has its own random stream,
``numpy.random.SeedSequence([seed, i, crc32(parameter name)])``, so the draws do not depend on the
number of workers, the order in which tasks run, or on which other parameters the sweep spreads
(adding a spread of k3 leaves every unit's f0 as it was).

The draws are stored as offsets from the IMU file (ppm, Hz, percent, K, ppm/K, and for the sensor
errors standard-normal scores), so one unit is the same unit in every scenario of the sweep, whatever
IMU file the scenario names. :func:`apply_unit` turns them into the unit's true parameters:

* ``f0 = f0_file (1 + f0_ppm 1e-6)`` (or ``f0_file + f0_hz``), then ``f0 (1 + tc 1e-6 temperature_k)``;
* ``k = k_file (1 + k_percent / 100)`` for k1..k5, where ``k_file`` is the channel's own value, else the
  shared ``suspension:`` value, else the IMU schema's default;
* a sensor error with 1-sigma value ``sigma`` (per axis) becomes ``sigma z`` with the unit's score ``z``;
* a block quantity (``population.block``, :data:`~sins_sim.config.sweep.BLOCK_SPREADS`) becomes
  ``v_file (1 + p / 100)``, the elastic centre ``c_file + offset_mm``.

The sweep's table (``param.*`` columns) holds every draw in the unit its name carries: the sensor errors as the
values the run used (:func:`sensor_values`, ``param.gyro.bias_deg_h.x`` in deg/h), not the scores, and the block's
as the values the run used under the IMU file's own key (:func:`block_values`,
``param.block.isolators.stiffness_n_per_m.x`` in N/m, ``param.block.mass_kg`` in kg), not the percent drawn.
"""

from __future__ import annotations

import copy
import zlib

import numpy as np

from sins_sim.config.sweep import BLOCK_SPREADS, SUSPENSION_KEYS

__all__ = ["AXES", "SENSOR_SIGMA_KEYS", "sigma_values", "draw_unit", "apply_unit", "sensor_values", "block_values",
           "table_parameters", "parameter_columns", "grid_size"]

AXES = ("x", "y", "z")
_MISALIGNMENT = ("xy", "xz", "yx", "yz", "zx", "zy")
#: Sensor-error keys whose datasheet value is a 1-sigma spread over units (drawn per unit), by section.
#: Noise densities (random walks, bias instability) stay as they are: the run's seed draws their noise.
SENSOR_SIGMA_KEYS = {
    "gyro": ("bias_deg_h", "scale_factor_ppm", "scale_factor_asymmetry_ppm", "misalignment_arcsec"),
    "accelerometer": ("bias_ug", "scale_factor_ppm", "scale_factor_asymmetry_ppm", "nonlinearity_ug_g2",
                      "misalignment_arcsec"),
}
#: Spreads drawn once per unit (the others once per channel).
_PER_UNIT = ("temperature_k", "block.mass_percent")
#: The block spreads drawn once per unit (their key in :data:`~sins_sim.config.sweep.BLOCK_SPREADS`).
_PER_UNIT_BLOCK = ("mass_percent",)
#: The inertia tensor's entries a per-axis draw of ``block.inertia_percent`` scales.
_MOMENTS = ("xx", "yy", "zz")


def _rng(seed: int, i: int, name: str) -> np.random.Generator:
    return np.random.default_rng(np.random.SeedSequence([seed, i, zlib.crc32(name.encode())]))


def grid_size(sweep) -> int:
    """Rows of the full factorial of the sweep's grids (1 without a grid)."""
    n = 1
    for key in sweep.grid_keys:
        n *= len(sweep.spreads[key]["values"])
    return n


def _grid_value(sweep, key: str, i: int) -> float:
    """Unit ``i``'s value of grid ``key``: digit of ``i`` in the mixed radix of the grids (first fastest)."""
    stride = 1
    for k in sweep.grid_keys:
        values = sweep.spreads[k]["values"]
        if k == key:
            return float(values[(i // stride) % len(values)])
        stride *= len(values)
    raise KeyError(key)  # pragma: no cover - only called for grid keys


def _draw(spec: dict, rng: np.random.Generator, n: int) -> list:
    if spec["distribution"] == "normal":
        z = rng.standard_normal(n)
    else:
        z = rng.uniform(-1.0, 1.0, n)
    return [float(spec["mean"] + spec["width"] * x) for x in z]


def parameter_columns(sweep) -> list:
    """The columns :func:`draw_unit` returns for this sweep, in order."""
    return list(draw_unit(sweep, 0))


def draw_unit(sweep, i: int) -> dict:
    """Unit ``i``'s draws as a flat mapping (``f0_ppm.x``, ``k3_percent.y``, ``temperature_k``,
    ``gyro.bias_deg_h.x`` scores, ``run_seed``), a function of ``(sweep.seed, i)`` only.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> s = SimpleNamespace(seed=1, spreads={"temperature_k": {"distribution": "grid", "values": [0, 10]}},
    ...                     grid_keys=["temperature_k"], sensors={"draw": False}, run_seed="scenario")
    >>> [draw_unit(s, i)["temperature_k"] for i in range(3)]
    [0.0, 10.0, 0.0]
    """
    out: dict = {}
    for key, spec in sweep.spreads.items():
        per_unit = key in _PER_UNIT
        if spec["distribution"] == "grid":
            v = _grid_value(sweep, key, i)
            values = [v] if per_unit else [v, v, v]
        else:
            values = _draw(spec, _rng(sweep.seed, i, key), 1 if per_unit else 3)
        if per_unit:
            out[key] = values[0]
        else:
            out.update({f"{key}.{ax}": v for ax, v in zip(AXES, values)})
    if sweep.sensors["draw"]:
        for section, keys in SENSOR_SIGMA_KEYS.items():
            for key in keys:
                labels = _MISALIGNMENT if key == "misalignment_arcsec" else AXES
                z = _rng(sweep.seed, i, f"{section}.{key}").standard_normal(len(labels))
                out.update({f"{section}.{key}.{lab}": float(x) for lab, x in zip(labels, z)})
    if sweep.run_seed == "per_unit":
        out["run_seed"] = int(_rng(sweep.seed, i, "run_seed").integers(0, 2 ** 32 - 1))
    return out


def _suspension_default(field: str) -> float:
    from sins_sim.config.imu import IMU_SCHEMA

    return IMU_SCHEMA.fields["suspension"].fields[field].default


def _per_axis(value, n: int) -> list:
    """A sensor value as a list of ``n`` (a number for all axes; a 3x3 misalignment matrix as 6 angles)."""
    if value is None:
        return [0.0] * n
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return [float(value)] * n
    if n == 6 and len(value) == 3 and all(isinstance(r, (list, tuple)) for r in value):
        return [float(value[r][c]) for r, c in ((0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1))]
    return [float(x) for x in value]


def sigma_values(section: dict, key: str) -> list:
    """The 1-sigma values of sensor key ``key`` of a ``sensors.<section>`` mapping, per axis (or per angle)."""
    return _per_axis(section.get(key), 6 if key == "misalignment_arcsec" else 3)


def _draw_sensors(base: dict | None, unit: dict) -> dict | None:
    if not base:
        return base
    out = copy.deepcopy(base)
    for section, keys in SENSOR_SIGMA_KEYS.items():
        sec = out.get(section)
        if not isinstance(sec, dict):
            continue
        for key in keys:
            if key not in sec:
                continue
            labels = _MISALIGNMENT if key == "misalignment_arcsec" else AXES
            sigma = _per_axis(sec[key], len(labels))
            sec[key] = [abs(s) * unit[f"{section}.{key}.{lab}"] for s, lab in zip(sigma, labels)]
    return out


def sensor_values(imu_doc: dict, unit: dict) -> dict:
    """The drawn sensor errors of a unit's IMU mapping in the units their names carry (``gyro.bias_deg_h.x`` in
    deg/h, ``accelerometer.bias_ug.y`` in ug, ...), for each sensor score in ``unit``.

    ``imu_doc`` is :func:`apply_unit`'s result with ``draw_sensors``: each value is the 1-sigma value times the
    unit's score; a key the mapping does not hold draws nothing, so its value is 0.
    """
    sensors = imu_doc.get("sensors") if isinstance(imu_doc.get("sensors"), dict) else {}
    out = {}
    for section, keys in SENSOR_SIGMA_KEYS.items():
        sec = sensors.get(section) if isinstance(sensors.get(section), dict) else {}
        for key in keys:
            labels = _MISALIGNMENT if key == "misalignment_arcsec" else AXES
            values = _per_axis(sec.get(key), len(labels))
            for lab, v in zip(labels, values):
                if f"{section}.{key}.{lab}" in unit:
                    out[f"{section}.{key}.{lab}"] = float(v)
    return out


def _block_entry(block: dict, path: str):
    """``(container, key)`` of the IMU block key ``path`` (``mass_kg``, ``isolators.stiffness_n_per_m``)."""
    *parents, key = path.split(".")
    node = block
    for part in parents:
        node = node.get(part) if isinstance(node, dict) else None
    return (node, key) if isinstance(node, dict) else (None, key)


def _block_draws(block: dict, unit: dict):
    """``(spread key, IMU path, draw name, container, leaf key)`` of every block spread that ``unit`` draws and the
    ``block:`` mapping holds (:data:`~sins_sim.config.sweep.BLOCK_SPREADS`)."""
    for key, (path, _) in BLOCK_SPREADS.items():
        name = f"block.{key}"
        node, leaf = _block_entry(block, path)
        drawn = name in unit if key in _PER_UNIT_BLOCK else any(f"{name}.{ax}" in unit for ax in AXES)
        if node is not None and drawn:
            yield key, path, name, node, leaf


def _draw_block(block: dict, unit: dict) -> None:
    """Apply the unit's block draws to the IMU file's ``block:`` mapping in place (module docstring). A key the
    mapping does not hold, or holds as something other than numbers, is left for the IMU schema to name."""
    for key, path, name, node, leaf in _block_draws(block, unit):
        if key == "mass_percent":
            if isinstance(node.get(leaf), (int, float)):
                node[leaf] = float(node[leaf]) * (1.0 + 0.01 * unit[name])
            continue
        if key == "inertia_percent":
            j = node.get(leaf)
            if isinstance(j, dict):
                for ax, m in zip(AXES, _MOMENTS):
                    if isinstance(j.get(m), (int, float)):
                        j[m] = float(j[m]) * (1.0 + 0.01 * unit[f"{name}.{ax}"])
            continue
        value = node.get(leaf, [0.0, 0.0, 0.0] if key == "elastic_centre_mm" else None)
        try:
            base = _per_axis(value, 3)
        except (TypeError, ValueError):
            continue
        if key == "elastic_centre_mm":
            node[leaf] = [b + unit[f"{name}.{ax}"] for b, ax in zip(base, AXES)]
        else:
            node[leaf] = [b * (1.0 + 0.01 * unit[f"{name}.{ax}"]) for b, ax in zip(base, AXES)]


def block_values(imu_doc: dict, unit: dict) -> dict:
    """The drawn block quantities of a unit's IMU mapping (:func:`apply_unit`'s result) in SI under the IMU file's
    keys with their units: ``block.mass_kg``, ``block.inertia_kg_m2.xx``, ``block.gyro_inertia_kg_m2.x``,
    ``block.isolators.stiffness_n_per_m.x``, ..., ``block.isolators.elastic_centre_mm.x``, for every block draw in
    ``unit``."""
    block = imu_doc.get("block") if isinstance(imu_doc.get("block"), dict) else {}
    out = {}
    for key, path, name, node, leaf in _block_draws(block, unit):
        if key == "mass_percent":
            out[f"block.{path}"] = float(node[leaf])
            continue
        if key == "inertia_percent":
            out.update({f"block.{path}.{m}": float(node[leaf][m]) for ax, m in zip(AXES, _MOMENTS)
                        if f"{name}.{ax}" in unit})
            continue
        values = _per_axis(node.get(leaf), 3)
        out.update({f"block.{path}.{ax}": float(v) for ax, v in zip(AXES, values) if f"{name}.{ax}" in unit})
    return out


def table_parameters(imu_doc: dict, unit: dict) -> dict:
    """The ``param.*`` values of a unit's run (without the prefix), each in the unit its name carries: the draws
    stored as offsets in their own units (``f0_ppm.x``, ``k3_percent.y``, ``temperature_k``), the sensor errors
    (:func:`sensor_values`) and the block's quantities (:func:`block_values`) as the values the run used."""
    params = {k: v for k, v in unit.items() if k != "run_seed" and not k.startswith("block.")}
    if any(k.startswith(("gyro.", "accelerometer.")) for k in unit):
        params.update(sensor_values(imu_doc, unit))
    params.update(block_values(imu_doc, unit))
    return params


def apply_unit(imu_doc: dict, unit: dict, filter_parameters="true", sensors: dict | None = None,
               draw_sensors: bool = False) -> dict:
    """The IMU mapping of one unit: ``imu_doc`` (as read from the IMU file) with the unit's draws applied.

    Parameters
    ----------
    imu_doc : dict
        The IMU file's mapping (not changed).
    unit : dict
        :func:`draw_unit`'s draws.
    filter_parameters : str or dict
        ``"true"``: the file's own choice (without one: the unit's true parameters); otherwise the value
        is passed as the IMU key ``filter_parameters``. The draws go into ``channels.<axis>`` (``f0_hz``,
        ``suspension``), never into the shared ``suspension:`` block, which ``nominal`` filters use.
    sensors : dict or None
        A preset ``sensors:`` mapping replacing the file's (None: the file's own).
    draw_sensors : bool
        Draw the preset's 1-sigma sensor errors with the unit's scores.
    """
    doc = copy.deepcopy(imu_doc)
    shared = doc.get("suspension") or {}
    channels = doc.get("channels")
    if isinstance(channels, dict):
        for ax in AXES:
            ch = channels.get(ax)
            if not isinstance(ch, dict) or not isinstance(ch.get("f0_hz"), (int, float)):
                continue  # the IMU schema names what is missing when the unit is validated
            f0 = float(ch["f0_hz"])
            if f"f0_ppm.{ax}" in unit:
                f0 *= 1.0 + 1e-6 * unit[f"f0_ppm.{ax}"]
            if f"f0_hz.{ax}" in unit:
                f0 += unit[f"f0_hz.{ax}"]
            if f"temperature_coefficient_ppm_per_k.{ax}" in unit and "temperature_k" in unit:
                f0 *= 1.0 + 1e-6 * unit[f"temperature_coefficient_ppm_per_k.{ax}"] * unit["temperature_k"]
            ch["f0_hz"] = f0
            sus = dict(ch.get("suspension") or {})
            for key, yaml_key in SUSPENSION_KEYS.items():
                if f"{key}.{ax}" not in unit:
                    continue
                base = sus.get(yaml_key, shared.get(yaml_key))
                if base is None:
                    base = _suspension_default(yaml_key.split("_", 1)[0])
                sus[yaml_key] = float(base) * (1.0 + 0.01 * unit[f"{key}.{ax}"])
            if sus:
                ch["suspension"] = sus
    if isinstance(doc.get("block"), dict) and any(k.startswith("block.") for k in unit):
        _draw_block(doc["block"], unit)
    if sensors is not None:
        doc["sensors"] = copy.deepcopy(sensors)
    if draw_sensors:
        doc["sensors"] = _draw_sensors(doc.get("sensors"), unit)
    if filter_parameters != "true":
        doc["filter_parameters"] = copy.deepcopy(filter_parameters)
    return doc

