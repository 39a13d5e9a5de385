"""Configuration: YAML files to the engine's inputs, below the commands (``jobs/``) and above the engine.

A scenario file's path reads top to bottom::

    scenarios/x.yaml
      -> yaml_io.load_yaml          the mapping, strict (no duplicate keys, no YAML 1.1 surprises), and the
                                    line and column of every key (errors.register_marks)
      -> schema.validate            types, ranges, units in the key names converted to SI and rad
                                    (SCENARIO_SCHEMA); a broken rule is one errors.ConfigError line
                                    naming the file, the line, the key path and the rule
      -> scenario.Scenario          the validated scenario:
           imu.imu_from_dict        the unit (``imu:`` a file, read by imu.load_imu, or a mapping)
             -> filter_params       what the filters believe (f0, Q, tracking), and
                effects_schema      the catalogue effects
           advisories               vibration against the filters' stop bands and the dithers
      -> engine inputs              ImuConfig, NavSettings, motion, filters, seed
                                    (sins_sim.simulation.sins), run by the commands in ``jobs/``

A sweep file (``sweep.load_sweep``) takes the same path, yaml_io then schema (``SWEEP_SCHEMA``); each
of the scenarios it names is a scenario file as above. An experiment file
(``experiment.experiment_from_dict``, for ``sins-sim simulate-recording``) is validated against
``EXPERIMENT_SCHEMA`` and becomes the recording simulator's inputs (sins_sim.simulation.experiment). A log
description (``log.load_log_description``, for ``sins-sim import-log``) is validated against ``LOG_SCHEMA``
and becomes the plain layout the log reader takes (sins_sim.io.unitlog.LogLayout).

Modules, each importing only the ones below it (import-linter contract in ``pyproject.toml``)::

    reference -> {scenario, sweep, experiment, log} -> imu -> {filter_params, effects_schema, advisories} -> yaml_io
        -> schema -> errors

``reference`` renders every format's reference and JSON Schema from these schemas (``sins-sim
schema``). Nothing here imports ``jobs``, ``bench`` or ``cli``.
"""
