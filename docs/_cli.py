"""The command-line parser for sphinx-argparse, with its help text made safe for reStructuredText.

sphinx-argparse renders help strings as reStructuredText, where a ``*`` in ``scenarios/sweep-*.yaml``
opens an emphasis; the parser itself (:func:`sins_sim.cli.build_parser`) stays as the terminal shows it.
"""

from __future__ import annotations

import argparse

from sins_sim.cli import build_parser


def _escape(parser: argparse.ArgumentParser) -> None:
    for action in parser._actions:
        if action.help and action.help is not argparse.SUPPRESS:
            action.help = action.help.replace("*", r"\*")
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                _escape(sub)
            for choice in action._choices_actions:
                if choice.help:
                    choice.help = choice.help.replace("*", r"\*")


def parser() -> argparse.ArgumentParser:
    """:func:`sins_sim.cli.build_parser` with ``*`` escaped in every help string."""
    p = build_parser()
    _escape(p)
    return p
