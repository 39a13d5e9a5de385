"""The plan's refusal: one line, the whole configuration message.

:class:`PlanError` is raised by the resolve stage (:mod:`sins_sim.plan`) when a scenario or an IMU file is right
key by key but cannot be built or run: a design that does not fit, a drive the plant cannot resolve, two keys
that do not compose. Its message is complete (the file, the key path the user wrote, the rule), as the messages
of :class:`sins_sim.config.errors.ConfigError` are; configuration sits above the plan, calls it through one entry
point and raises the same line as a ``ConfigError`` (which then locates the key in its file). A ``ValueError``:
a caller that catches those catches it. Imports nothing from the package.
"""

from __future__ import annotations

__all__ = ["PlanError"]


class PlanError(ValueError):
    """A configuration that passed its schema but cannot be planned; the message names the file, the key(s) and
    the rule (with two keys that do not compose, both)."""
