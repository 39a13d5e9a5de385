"""Deprecated alias: the code lives in :mod:`sins_sim.config.yaml_io` (issue 23); import it from there."""

from sins_sim.jobs._moved import alias

alias(__name__)
