"""Deprecated alias: the code lives in :mod:`sins_sim.config.sweep` (issue 23); import it from there."""

from sins_sim.jobs._moved import alias

alias(__name__, "sins_sim.config.sweep")
