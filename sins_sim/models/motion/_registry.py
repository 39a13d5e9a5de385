"""Building motion parts from ``{"type": NAME, ...}`` dictionaries (shared by the motion builders)."""

from __future__ import annotations

import inspect
from collections.abc import Mapping

__all__ = ["build_typed"]


def build_typed(entry, registry: dict, where: str, kind: str):
    """Instantiate ``registry[entry["type"]]`` with the entry's other keys.

    Every failure is a ``ValueError`` naming ``where`` and the key: an entry that is not a
    mapping, a missing or unknown ``type``, an unknown key, or a required key left out.
    ``kind`` names the family in messages (``"motion type"``, ``"segment type"``).
    """
    if not isinstance(entry, Mapping):
        raise ValueError(f"{where}: must be a dict with a 'type' key, got {type(entry).__name__}")
    if "type" not in entry:
        raise ValueError(f"{where}.type: missing; one of {sorted(registry)}")
    name = entry["type"]
    if name not in registry:
        raise ValueError(f"{where}.type: unknown {kind} {name!r}; one of {sorted(registry)}")
    cls = registry[name]
    params = inspect.signature(cls).parameters
    kwargs = {k: val for k, val in entry.items() if k != "type"}
    for key in kwargs:
        if key not in params:
            raise ValueError(f"{where}.{key}: unknown key for {kind} {name!r}; allowed: {sorted(params)}")
    for key, par in params.items():
        if par.default is inspect.Parameter.empty and key not in kwargs:
            raise ValueError(f"{where}.{key}: required for {kind} {name!r}")
    return cls(**kwargs)
