"""Deprecated alias: the code lives in :mod:`sins_sim.plan.advisories` (issue 23, then issue 38: the advisories need
the physics, so they belong to the plan); import it from there."""

from sins_sim.jobs._moved import alias

alias(__name__, "sins_sim.plan.advisories")
