"""sins-sim's version, in a foundation module of its own: the package root imports the rooms, so a room
(``jobs.manifest``, the sweep's run keys) reads the version here rather than from the root."""

__version__ = "0.2.0"
