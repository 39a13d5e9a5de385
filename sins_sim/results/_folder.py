"""Reading a result folder's JSON files with one clear line on failure."""

from __future__ import annotations

import json
from pathlib import Path

from sins_sim.config.errors import ConfigError

__all__ = ["read_json"]


def read_json(path: Path, what: str) -> dict:
    """The JSON of ``path``; a :class:`ConfigError` naming the file when it is missing or unreadable."""
    try:
        return json.loads(path.read_text())
    except FileNotFoundError:
        raise ConfigError(f"load: {path.parent} has no {path.name} (not a {what} result)") from None
    except (OSError, ValueError) as exc:
        raise ConfigError(f"load: {path} cannot be read ({type(exc).__name__})") from None
