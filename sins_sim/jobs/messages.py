"""Warnings a person can read: one line each, no file paths, no repeats.

Python prints a warning as ``/abs/path/module.py:351: Category: message``
followed by the source line that raised it. That is for developers; a run's
user needs the message. :func:`format_warning_lines` turns what
``warnings.catch_warnings(record=True)`` collected (or plain strings, such as
a job's own ``metrics["warnings"]``) into ``warning: <message>`` lines: the
first line of each message, paths of Python source files cut to the file
name, duplicates dropped (first occurrence kept, order preserved).
:func:`capture_warnings` is the context manager the CLI wraps each job in.

Examples
--------
>>> format_warning_lines(["plant: 3 half-cycle(s) ...\\nmore detail", "plant: 3 half-cycle(s) ..."])
['warning: plant: 3 half-cycle(s) ...']
>>> format_warning_lines(["bad value in /home/me/src/sins_sim/models/plant.py:163"])
['warning: bad value in plant.py:163']
"""

from __future__ import annotations

import re
import warnings
from contextlib import contextmanager

__all__ = ["warning_text", "format_warning_lines", "capture_warnings"]

#: a path to a Python source file (absolute or relative, with directories): kept as its file name
_SOURCE_PATH = re.compile(r"(?:[A-Za-z]:)?(?:[\\/]?[\w.\-~]*[\\/])+([\w.\-]+\.pyc?\b)")


def warning_text(item) -> str:
    """The readable one-line text of a warning.

    Parameters
    ----------
    item : warnings.WarningMessage, Warning or str
        A recorded warning, the warning object itself, or its message.

    Returns
    -------
    str
        The message's first non-empty line, paths of ``.py`` files reduced to the file
        name, white space collapsed; ``""`` when nothing is left.
    """
    message = getattr(item, "message", item)  # WarningMessage -> the Warning instance
    text = str(message)
    first = next((ln for ln in text.splitlines() if ln.strip()), "")
    first = _SOURCE_PATH.sub(r"\1", first)
    return " ".join(first.split())


def format_warning_lines(items, prefix: str = "warning: ") -> list[str]:
    """One ``warning: <message>`` line per distinct warning, in order of first occurrence.

    Parameters
    ----------
    items : iterable of warnings.WarningMessage, Warning or str
        What ``warnings.catch_warnings(record=True)`` recorded, warning objects, or strings.
    prefix : str
        Put before each message.

    Returns
    -------
    list of str
    """
    seen = set()
    lines = []
    for item in items:
        text = warning_text(item)
        if text and text not in seen:
            seen.add(text)
            lines.append(prefix + text)
    return lines


@contextmanager
def capture_warnings():
    """Record every warning raised inside the block into the yielded list.

    The warning filters in force are kept (a warning that a job or the user
    silences stays silent); Python's once-per-location registry starts afresh
    for the block, so a warning already seen in this process is reported
    again. Nothing is printed: pass the list to :func:`format_warning_lines`.
    """
    with warnings.catch_warnings(record=True) as caught:
        yield caught
