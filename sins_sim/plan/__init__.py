"""The resolve stage between configuration and the engine: where composition is decided.

The path from a file to the engine reads top-down::

    load_scenario (sins_sim.config)  ->  resolve_plan (sins_sim.plan)  ->  run_plan (the engine)

:mod:`sins_sim.config` checks keys, units and ranges and calls :func:`resolve_plan` once; the plan resolves the
drives, rates, filter designs, coning coefficients, the block, the alignment and the aiding, and refuses the
pairs that do not compose, naming both keys (:class:`PlanError`, which configuration raises as its own
``ConfigError``). A command that varies the unit re-resolves through
:func:`with_unit`. The engine (:mod:`sins_sim.simulation`) never imports the plan: it runs what the plan built.

Importing this package is light (numpy): the models and the engine are imported while a plan is resolved.
"""

from sins_sim.plan.errors import PlanError
from sins_sim.plan.scenario import ALIGNMENT_REST_SPEED_M_S, Plan, resolve_plan, run_plan, with_unit

__all__ = ["PlanError", "Plan", "resolve_plan", "run_plan", "with_unit", "ALIGNMENT_REST_SPEED_M_S"]
