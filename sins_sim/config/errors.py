"""The one error of configuration, and where a key sits in its file.

:class:`ConfigError` is what every bad input becomes: one line naming the file, the key path the user
wrote and the rule. :func:`sins_sim.config.yaml_io.load_yaml` registers the line and column of every
key it reads (:func:`register_marks`), so an error about a key of a file that was read locates itself
(``scenarios/x.yaml:7:3: navigation.conig: ...``). Imports nothing from the package: every room above
raises it.
"""

from __future__ import annotations

import re

__all__ = ["ConfigError", "register_marks", "alias_marks", "forget_mark", "key_position"]


class ConfigError(ValueError):
    """A configuration file broke a rule; the message names the file, the key path and the rule.

    When the message starts with a file :func:`sins_sim.config.yaml_io.load_yaml` has read
    (``scenarios/x.yaml: navigation.conig: ...``) and the key path is in that file, the error locates
    itself: the file is followed by the line and column of the key (or list item), the form editors
    and terminals turn into a link, ``scenarios/x.yaml:7:3: navigation.conig: ...``. A path the file
    does not hold (a default, a key that is missing) points at its nearest enclosing key that is there;
    a key the command line overrode points nowhere.
    """

    def __init__(self, message="", *args):
        if isinstance(message, str) and not args:
            message = _locate(message)
        super().__init__(message, *args)


# --- where a key is: file -> key path -> (line, column), filled by yaml_io.load_yaml ------------------------------
_FILE_MARKS: dict = {}
#: files whose key positions are remembered (the oldest is forgotten first)
_MAX_FILES = 256
_KEY_PATH = re.compile(r"([^\s:\[\]().]+(?:\[\d+\]|\.[^\s:\[\]().]+)*)(?=: | \()")
_PATH_PART = re.compile(r"\[(\d+)\]|\.?([^.\[\]]+)")


def register_marks(where: str, marks: dict) -> None:
    """Remember the positions of the keys of the file named ``where`` (``{key path tuple: (line, column)}``)."""
    _FILE_MARKS.pop(where, None)
    _FILE_MARKS[where] = marks
    while len(_FILE_MARKS) > _MAX_FILES:
        _FILE_MARKS.pop(next(iter(_FILE_MARKS)))


def alias_marks(alias: str, where: str) -> None:
    """Errors that name the file ``where`` as ``alias`` (``scenario.yaml -> imu.yaml``) locate themselves too."""
    if where in _FILE_MARKS:
        register_marks(alias, _FILE_MARKS[where])


def forget_mark(where: str, key: str) -> None:
    """Forget a top-level key's position (and its children's): its value no longer comes from the file."""
    marks = _FILE_MARKS.get(where)
    if marks:
        for path in [p for p in marks if p and p[0] == key]:
            del marks[path]


def key_position(where: str, path: str):
    """``(line, column)`` (1-based) of the key path ``path`` (``motion[0].amplitude_arcmin``) in the file
    ``where``, or of its nearest enclosing key the file holds; None when unknown."""
    marks = _FILE_MARKS.get(where)
    if not marks:
        return None
    parts = [int(i) if i else k for i, k in _PATH_PART.findall(path)]
    while parts:
        pos = marks.get(tuple(parts))
        if pos is not None:
            return pos
        parts.pop()
    return None


def _locate(message: str) -> str:
    for where in reversed(_FILE_MARKS):
        if message.startswith(where + ": "):
            rest = message[len(where) + 2:]
            m = _KEY_PATH.match(rest)
            pos = key_position(where, m.group(1)) if m else None
            if pos is None:
                return message
            return f"{where}:{pos[0]}:{pos[1]}: {rest}"
    return message
