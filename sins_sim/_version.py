"""sins-sim's version, in a foundation module of its own: the package root imports the rooms, so a room
(``jobs.manifest``, the sweep's run keys) reads the version here rather than from the root."""

__version__ = "0.3.0.dev0"

#: Where a user finds what changed between versions (``sins-sim --version`` prints it).
CHANGELOG = "CHANGELOG.md"
