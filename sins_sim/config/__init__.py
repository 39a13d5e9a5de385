"""Configuration: YAML files checked key by key, below the commands (``jobs/``) and above the plan and the engine.

A scenario file's path reads top to bottom::

    scenarios/x.yaml
      -> yaml_io.load_yaml          the mapping, strict (no duplicate keys, no YAML 1.1 surprises), and the
                                    line and column of every key (errors.register_marks)
      -> schema.validate            types, ranges, units in the key names converted to SI and rad
                                    (SCENARIO_SCHEMA); a broken rule is one errors.ConfigError line
                                    naming the file, the line, the key path and the rule
      -> scenario.Scenario          the validated scenario: its keys, units and ranges, and
           imu.parse_imu            the unit's (``imu:`` a file or a mapping; no model imported)
             -> filter_params       what the filters believe (source, f0, tracking), and
                effects_schema      the catalogue effects
      -> sins_sim.plan.resolve_plan the one entry point into the physics: the unit built, the rates, the
                                    designs, the vehicle, alignment and aiding; pairs that do not compose
                                    refused naming both keys (a PlanError, raised here as a ConfigError)
      -> sins_sim.plan.run_plan     the engine runs the plan (Scenario.plan), from the commands in ``jobs/``

A sweep file (``sweep.load_sweep``) takes the same path, yaml_io then schema (``SWEEP_SCHEMA``); each
of the scenarios it names is a scenario file as above. An experiment file
(``experiment.experiment_from_dict``, for ``sins-sim simulate-recording``) is validated against
``EXPERIMENT_SCHEMA``; the plan (sins_sim.plan.experiment.resolve_experiment) builds the recording
simulator's inputs (sins_sim.simulation.experiment). A log
description (``log.load_log_description``, for ``sins-sim import-log``) is validated against ``LOG_SCHEMA``
and becomes the plain layout the log reader takes (sins_sim.io.unitlog.LogLayout).

Modules, each importing only the ones below it (import-linter contract in ``pyproject.toml``)::

    reference -> {scenario, sweep, experiment, log} -> imu -> {filter_params, effects_schema, block_schema} -> yaml_io
        -> schema -> errors

``reference`` renders every format's reference and JSON Schema from these schemas (``sins-sim
schema``). Nothing here imports ``jobs``, ``bench`` or ``cli``; a scenario's and an IMU file's modules import
no engine module (``simulation``, ``_kernels``, ``navigation``, ``io``): they call the plan, once.
"""
