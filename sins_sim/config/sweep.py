"""Sweep files (``scenarios/sweep-*.yaml``): the schema and the loader.

A sweep names one or more scenarios, a population of units drawn around the IMU file each
scenario names, the number of units, the filters' knowledge of the unit and a seed::

    name: smoke
    seed: 7
    units: 4
    filter_parameters: true          # true | nominal: what the dither filters know of the unit
    scenarios:
      - {path: stationary.yaml, duration_s: 20}
    population:
      f0_ppm: {distribution: normal, width: 2000}        # each channel's f0, ppm of the file's
      k3_percent: {distribution: uniform, width: 10}     # each channel's k3, percent of the file's
      temperature_k: {distribution: grid, values: [-20, 0, 20]}
      temperature_coefficient_ppm_per_k: {mean: -30, width: 5}
      sensors: {draw: true}          # bias, scale factor, misalignment drawn around the preset (1 sigma)
      block:                         # the sensor block and its isolators (an IMU file with a block: section)
        mass_percent: {width: 2}                # the block's mass, percent of the file's, one per unit
        stiffness_percent: {width: 10}          # each isolator stiffness, percent of the file's, per axis
        elastic_centre_mm: {width: 1}           # the elastic centre's offset added per axis (mm)

Everything is checked before any task starts: the sweep file against :data:`SWEEP_SCHEMA`, each
scenario file, and every unit's IMU with its drawn parameters (:mod:`sins_sim.jobs.sweep.population`), so a bad
value is one line naming the file, the unit and the key.
"""

from __future__ import annotations

from pathlib import Path

from sins_sim.config.schema import Bool, ConfigError, ListOf, Map, Num, Str, validate

__all__ = ["SWEEP_SCHEMA", "SPREAD_PARAMETERS", "SUSPENSION_KEYS", "BLOCK_SPREADS", "Sweep", "load_sweep",
           "MAX_UNITS"]

#: At most this many units per sweep (times the scenarios: the tasks). 100 000 units of a 5 min flight are
#: ~ 300 core-days: beyond that a sweep is a mistake in the file, not a plan.
MAX_UNITS = 100_000
#: Largest relative spread of f0 (ppm): 20 % moves the default unit's 352-421 Hz channels over each other and
#: outside the usual resonances; the IMU schema refuses what leaves the physical range.
MAX_F0_PPM = 200_000.0
#: Largest relative spread of k1..k5 (percent of the file's value): 100 % may flip a sign (k5), which the
#: IMU schema then refuses with the unit named.
MAX_K_PERCENT = 100.0

#: The IMU file's suspension keys (``channels.<axis>.suspension``) the population spreads, by their spread key.
SUSPENSION_KEYS = {"k1_percent": "k1", "k2_percent": "k2_rad", "k3_percent": "k3", "k4_percent": "k4_per_rad",
                   "k5_percent": "k5_rad_per_v"}


def _spread(unit: str, width_max: float, mean_range: float, what: str) -> Map:
    """A distribution of one parameter: ``normal`` (mean, standard deviation), ``uniform`` (mean +- width)
    or ``grid`` (the listed values, all grids of the sweep combined as a full factorial)."""
    return Map({
        "distribution": Str(choices=("normal", "uniform", "grid"), default="normal",
                            doc="normal: mean + width N(0, 1); uniform: mean + width U(-1, 1); grid: the values, "
                                "unit i takes its row of the full factorial of every grid (i mod its size)"),
        "mean": Num(min=-mean_range, max=mean_range, default=0.0,
                    doc=f"centre ({unit}); normal and uniform: mean and width not both 0 (that draws nothing)"),
        "width": Num(min=0.0, max=width_max, default=0.0,
                     doc=f"normal: standard deviation; uniform: half-width ({unit}); mean and width not both 0 "
                         "(that draws nothing)"),
        "values": ListOf(Num(min=-mean_range, max=mean_range), default=[], max_len=1000,
                         doc=f"grid: the values ({unit}); at least one"),
    }, default=None, doc=what, rules=("grid needs values; normal and uniform take no values",
                                      "normal and uniform need a non-zero mean or width: mean 0 and width 0 (the "
                                      "defaults) draw nothing and are refused"))


SPREAD_PARAMETERS = {
    "f0_ppm": _spread("ppm", MAX_F0_PPM, MAX_F0_PPM,
                      "each channel's f0, relative to the IMU file's f0_hz (ppm), drawn per channel"),
    "f0_hz": _spread("Hz", 100.0, 100.0, "each channel's f0, offset from the IMU file's f0_hz (Hz), drawn per "
                                         "channel; not together with f0_ppm"),
    **{key: _spread("percent", MAX_K_PERCENT, MAX_K_PERCENT,
                    f"each channel's {name}, relative to the IMU file's value (its channel's or the shared one), "
                    f"percent, drawn per channel")
       for key, name in SUSPENSION_KEYS.items()},
    "temperature_coefficient_ppm_per_k": _spread(
        "ppm/K", 1000.0, 1000.0, "each channel's temperature coefficient of f0 (ppm/K), drawn per channel"),
    "temperature_k": _spread("K", 100.0, 100.0, "the unit's temperature offset from the calibration temperature "
                                                "(K), one per unit and constant over the run: f0 moves by "
                                                "coefficient x offset"),
}

#: The block's spreads (``population.block.<key>``, an IMU file with a ``block:`` section): spread key -> (the IMU
#: file's key under ``block:``, what is drawn). Percent spreads scale the file's value, ``(1 + p / 100)``, of a
#: quantity that must stay positive: a spread that lets it reach zero or below is refused, naming the key.
#: ``elastic_centre_mm`` adds an offset in mm (a position, any sign). Per axis unless said (the mass: one per unit).
BLOCK_SPREADS = {
    "mass_percent": ("mass_kg", "the block's mass, percent of the IMU file's, one per unit"),
    "inertia_percent": ("inertia_kg_m2", "the block's moments of inertia xx, yy, zz, percent of the file's, per axis "
                                         "(the products of inertia kept)"),
    "gyro_inertia_percent": ("gyro_inertia_kg_m2", "each gyro body's inertia about its input axis, percent of the "
                                                   "file's, per axis"),
    "stiffness_percent": ("isolators.stiffness_n_per_m", "the isolators' translational stiffness, percent of the "
                                                         "file's, per axis"),
    "damping_percent": ("isolators.damping_n_s_per_m", "the isolators' translational damping, percent of the file's, "
                                                       "per axis"),
    "rotational_stiffness_percent": ("isolators.rotational_stiffness_n_m_per_rad",
                                     "the isolators' rotational stiffness, percent of the file's, per axis"),
    "rotational_damping_percent": ("isolators.rotational_damping_n_m_s_per_rad",
                                   "the isolators' rotational damping, percent of the file's, per axis"),
    "elastic_centre_mm": ("isolators.elastic_centre_mm", "the isolators' elastic centre, an offset added to the "
                                                         "file's position (mm, block axes), per axis"),
}
#: Largest spread of the elastic centre (mm): the IMU schema's range of the position itself.
MAX_CENTRE_MM = 500.0

_BLOCK = Map({key: (_spread("mm", MAX_CENTRE_MM, MAX_CENTRE_MM, what) if key.endswith("_mm") else
                    _spread("percent", MAX_K_PERCENT, MAX_K_PERCENT, what))
              for key, (_, what) in BLOCK_SPREADS.items()},
             default={}, doc="the sensor block and its isolators (an IMU file with a block: section; sins-sim schema imu)",
             rules=("a percent spread must keep its quantity positive: uniform mean - width > -100, every grid value "
                    "> -100, and every unit's normal draw (checked per unit)",
                    "needs each scenario's IMU file to have a block: section"))

_SENSORS = Map({
    "draw": Bool(default=False, doc="true: the preset's 1-sigma values (gyro and accelerometer bias, scale factor, "
                                    "asymmetry, accelerometer nonlinearity, misalignment) become per-axis "
                                    "N(0, sigma^2) draws of each unit; the noise densities stay as they are"),
    "preset": Str(default="", doc="an IMU file whose sensors: block is the preset (relative to the sweep file); "
                                  "empty: each scenario's IMU file's own"),
}, default={}, doc="the unit's sensor errors (sins-sim schema imu, sensors)")


class _FilterParameters:
    """``filter_parameters``: ``true`` (YAML boolean or string), ``nominal``, or an IMU ``filter_parameters`` mapping."""

    unit = None
    default = "true"
    required = False
    doc = ("what the dither filters know of each unit: true (its drawn parameters), nominal (the IMU file's shared "
           "suspension, f0 from the PLL), or a mapping; passed to every unit's IMU as filter_parameters "
           "(sins-sim schema imu), checked there")

    def describe_rows(self, path):
        return [{"key": path, "kind": "string, bool or mapping", "unit": "", "range": "true, nominal or a mapping",
                 "default": "true", "doc": self.doc}]

    def json_schema(self):
        from sins_sim.config.schema import json_schema
        from sins_sim.config.filter_params import FILTER_PARAMETERS_SCHEMA

        return {**json_schema(FILTER_PARAMETERS_SCHEMA), "description": self.doc}

    def check(self, value, ctx, path):
        if value is True or value == "true":
            return "true"
        if value == "nominal" or isinstance(value, dict):
            return value
        raise ConfigError(f"{ctx}: {path}: must be true, nominal or a mapping (sins-sim schema imu), got {value!r}")


SWEEP_SCHEMA = Map({
    "name": Str(required=True),
    "description": Str(default=""),
    "seed": Num(integer=True, min=0, max=2 ** 32 - 1, required=True,
                doc="seed of the population; unit i's draws and run seed depend only on (seed, i)"),
    "units": Num(integer=True, min=1, max=MAX_UNITS, required=True, doc="number of units drawn"),
    "run_seed": Str(choices=("per_unit", "scenario"), default="per_unit",
                    doc="per_unit: each unit's runs get a seed drawn from (seed, i) (its own noise); scenario: the "
                        "scenario file's seed for every unit (only the parameters differ)"),
    "filter_parameters": _FilterParameters(),
    "scenarios": ListOf(Map({
        "path": Str(required=True, doc="scenario file, relative to the sweep file"),
        "duration": Num(unit="s", min=0.0, min_exclusive=True, max=1.0e7, default=None,
                        doc="replaces the scenario's duration_s"),
        "label": Str(default="", doc="the name in the results (default: the scenario's name); unique"),
    }), required=True, min_len=1, max_len=100, doc="every unit runs every scenario"),
    "population": Map({**SPREAD_PARAMETERS, "sensors": _SENSORS, "block": _BLOCK}, default={},
                      doc="distributions of the units' true parameters around the IMU files' values"),
}, rules=("population: f0_ppm and f0_hz not both",
          "population: a normal or uniform spread needs a non-zero mean or width (else it draws nothing)",
          "population: temperature_k and temperature_coefficient_ppm_per_k together (one alone draws nothing)",
          "population.sensors.draw: the preset (else each scenario's IMU file) needs a sensors: block with a "
          "non-zero 1-sigma value",
          "scenarios: labels unique",
          "every unit's drawn parameters must pass the IMU schema (checked for every unit before any task starts)"))


def _check_positive(spec: dict, ctx: str, where: str) -> None:
    """A percent spread of a positive block quantity may not reach -100 % (zero) or below where its range is known:
    a uniform spread's low end and a grid's values (a normal draw is checked per unit)."""
    if spec["distribution"] == "grid":
        low = min(spec["values"])
        if low <= -100.0:
            raise ConfigError(f"{ctx}: {where}.values: {low:g} % makes the quantity zero or negative, which no block "
                              f"has (every value must be > -100)")
    elif spec["distribution"] == "uniform" and spec["mean"] - spec["width"] <= -100.0:
        raise ConfigError(f"{ctx}: {where}: mean - width = {spec['mean'] - spec['width']:g} % lets a unit's value "
                          f"reach zero or below, which no block has (mean - width must be > -100)")
    elif spec["distribution"] == "normal" and spec["mean"] <= -100.0:
        raise ConfigError(f"{ctx}: {where}.mean: {spec['mean']:g} % centres the draws at zero or below, which no "
                          f"block has (must be > -100)")


class Sweep:
    """A validated sweep file: scenarios (resolved paths), population spec, units, seed."""

    def __init__(self, doc: dict, ctx: str, base_dir: Path):
        c = validate(doc, SWEEP_SCHEMA, ctx)
        self.ctx = ctx
        self.base_dir = base_dir
        self.name = c["name"]
        self.description = c["description"]
        self.seed = int(c["seed"])
        self.units = int(c["units"])
        self.run_seed = c["run_seed"]
        self.filter_parameters = c["filter_parameters"]
        pop = c["population"]
        self.spreads = {}
        block = pop.get("block") or {}
        items = [(key, pop[key]) for key in SPREAD_PARAMETERS] + [(f"block.{key}", block.get(key))
                                                                  for key in BLOCK_SPREADS]
        for key, spec in items:
            if spec is None:
                continue
            where = f"population.{key}"
            if spec["distribution"] == "grid":
                if not spec["values"]:
                    raise ConfigError(f"{ctx}: {where}.values: a grid needs at least one value")
                if spec["width"] or spec["mean"]:
                    raise ConfigError(f"{ctx}: {where}: a grid takes values only, not mean or width")
            elif spec["values"]:
                raise ConfigError(f"{ctx}: {where}.values: only a grid takes values (distribution "
                                  f"{spec['distribution']} takes mean and width)")
            elif not spec["width"] and not spec["mean"]:
                raise ConfigError(f"{ctx}: {where}: mean 0 and width 0 draw nothing (every unit keeps the IMU file's "
                                  f"value): give a width or a mean, or remove the key")
            if key.startswith("block.") and key.endswith("_percent"):
                _check_positive(spec, ctx, where)
            self.spreads[key] = spec
        if "f0_ppm" in self.spreads and "f0_hz" in self.spreads:
            raise ConfigError(f"{ctx}: population.f0_hz: give f0_ppm or f0_hz, not both")
        for key, other in (("temperature_k", "temperature_coefficient_ppm_per_k"),
                           ("temperature_coefficient_ppm_per_k", "temperature_k")):
            if key in self.spreads and other not in self.spreads:
                # f0 (1 + 1e-6 coefficient x offset): the IMU file has no coefficient nor temperature of its own
                raise ConfigError(f"{ctx}: population.{key}: draws nothing without population.{other} (f0 moves by "
                                  f"coefficient x temperature offset; the IMU file has neither): add {other} or "
                                  f"remove {key}")
        self.sensors = pop["sensors"]
        self.sensor_preset = None
        if self.sensors["preset"]:
            p = (base_dir / self.sensors["preset"]).resolve()
            if not p.is_file():
                raise ConfigError(f"{ctx}: population.sensors.preset: file not found: {p}")
            self.sensor_preset = p
        self.scenarios = []
        for i, sc in enumerate(c["scenarios"]):
            p = (base_dir / sc["path"]).resolve()
            if not p.is_file():
                raise ConfigError(f"{ctx}: scenarios[{i}].path: file not found: {p}")
            # the label defaults to the scenario's name: set (and checked unique) when the tasks are built
            self.scenarios.append({"path": p, "duration_s": sc["duration_s"], "label": sc["label"], "index": i})

    @property
    def grid_keys(self) -> list:
        """The grid parameters in file order (the full factorial's digits, the first varying fastest)."""
        return [k for k, s in self.spreads.items() if s["distribution"] == "grid"]


def load_sweep(path) -> Sweep:
    """Read and validate a sweep file (errors: one line naming the file, the key path and the rule)."""
    from sins_sim.config.yaml_io import load_yaml

    path = Path(path)
    return Sweep(load_yaml(path), str(path), path.parent.resolve())
