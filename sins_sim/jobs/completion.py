"""Shell completion scripts generated from the command line's own parser.

``sins-sim completion bash`` prints a bash completion script, ``sins-sim completion zsh`` the same
for zsh (through zsh's ``bashcompinit``, the route argcomplete takes too). The script is written
from the :class:`argparse.ArgumentParser` that ``sins-sim`` parses with, so a new command, flag or
choice is completed without anyone editing the script; there is no run-time dependency and
nothing is executed at completion time (the script is static, so completing is instant).

Install, for the current shell or in ``~/.bashrc`` / ``~/.zshrc``::

    eval "$(sins-sim completion bash)"     # bash
    eval "$(sins-sim completion zsh)"      # zsh

What it completes: the subcommands; each subcommand's flags; the values of flags and positionals
that have ``choices`` (``--filter-parameters true|nominal``, ``schema scenario|imu|...``); file
names for every other positional and for flags that take a path; nothing for numeric flags
(``--seed``, ``--duration``), where a file name would only mislead.
"""

from __future__ import annotations

import argparse

__all__ = ["SHELLS", "completion_script"]

#: shells a script can be generated for
SHELLS = ("bash", "zsh")

#: argparse ``type=`` callables whose values are numbers (no file-name completion); matched by name so the
#: CLI's private converters (``_positive``, ``_seed``...) need not be imported here
_NUMERIC_TYPES = {"int", "float", "_number", "_positive", "_non_negative", "_seed", "_count"}


def _subparsers(parser: argparse.ArgumentParser) -> dict:
    for action in parser._actions:  # argparse has no public accessor for its subcommands
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def _flags(parser: argparse.ArgumentParser) -> list:
    return [s for a in parser._actions for s in a.option_strings]


def _value_kind(action: argparse.Action):
    """What follows a flag: ``None`` (nothing: a switch), ``("words", [...])``, ``("files",)`` or ``("none",)``."""
    if action.nargs == 0:
        return None
    if action.choices:
        return ("words", [str(c) for c in action.choices])
    if getattr(action.type, "__name__", None) in _NUMERIC_TYPES:
        return ("none",)
    return ("files",)


def _quote_words(words) -> str:
    return " ".join(words).replace("'", "")


def _case_for_values(actions, indent: str) -> list:
    """``case "$prev" in`` arms completing the value after each flag that takes one."""
    lines = []
    for action in actions:
        if not action.option_strings:
            continue
        kind = _value_kind(action)
        if kind is None:
            continue
        pattern = "|".join(action.option_strings)
        if kind[0] == "words":
            body = f"COMPREPLY=($(compgen -W '{_quote_words(kind[1])}' -- \"$cur\")); return 0;;"
        elif kind[0] == "files":
            body = "COMPREPLY=($(compgen -f -- \"$cur\")); return 0;;"
        else:
            body = "return 0;;"
        lines.append(f"{indent}{pattern}) {body}")
    return lines


def _bash(parser: argparse.ArgumentParser, prog: str) -> str:
    fn = "_" + "".join(c if c.isalnum() else "_" for c in prog)
    subs = _subparsers(parser)
    top_words = _quote_words([*subs, *_flags(parser)])
    lines = [
        f"# {prog} bash completion, generated from its argument parser by `{prog} completion bash`.",
        f'# Install: eval "$({prog} completion bash)"  (e.g. in ~/.bashrc)',
        f"{fn}() {{",
        "    local cur prev cmd i",
        "    cur=\"${COMP_WORDS[COMP_CWORD]}\"",
        "    prev=\"${COMP_WORDS[COMP_CWORD-1]}\"",
        "    cmd=\"\"",
        "    for ((i = 1; i < COMP_CWORD; i++)); do",
        "        case \"${COMP_WORDS[i]}\" in",
        f"            {'|'.join(subs)}) cmd=\"${{COMP_WORDS[i]}}\"; break;;",
        "        esac",
        "    done",
        "    case \"$cmd\" in",
        f"        \"\") COMPREPLY=($(compgen -W '{top_words}' -- \"$cur\")); return 0;;",
    ]
    for name, sub in subs.items():
        lines.append(f"        {name})")
        lines.append("            case \"$prev\" in")
        lines += _case_for_values(sub._actions, "                ")
        lines.append("            esac")
        flags = _quote_words(_flags(sub))
        positional_choices = [str(c) for a in sub._actions if not a.option_strings and a.choices for c in a.choices]
        lines.append("            if [[ \"$cur\" == -* ]]; then")
        lines.append(f"                COMPREPLY=($(compgen -W '{flags}' -- \"$cur\"))")
        if positional_choices:
            lines.append("            else")
            lines.append(f"                COMPREPLY=($(compgen -W '{_quote_words(positional_choices)}' -- \"$cur\"))")
        elif any(not a.option_strings for a in sub._actions):
            lines.append("            else")
            lines.append("                COMPREPLY=($(compgen -f -- \"$cur\"))")
        lines.append("            fi")
        lines.append("            return 0;;")
    lines += ["    esac", "}", f"complete -o filenames -o bashdefault -F {fn} {prog}", ""]
    return "\n".join(lines)


def completion_script(parser: argparse.ArgumentParser, shell: str, prog: str = "sins-sim") -> str:
    """The completion script of ``parser`` for ``shell`` (``"bash"`` or ``"zsh"``).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The command line's parser (``sins_sim.cli.build_parser()``): subcommands, flags and choices are
        read from it.
    shell : {"bash", "zsh"}
    prog : str
        The command the script completes.

    Returns
    -------
    str
        A script to ``eval`` in that shell.

    Examples
    --------
    >>> p = argparse.ArgumentParser(prog="demo")
    >>> sub = p.add_subparsers()
    >>> _ = sub.add_parser("go").add_argument("--speed", choices=["slow", "fast"])
    >>> "--speed) COMPREPLY=($(compgen -W 'slow fast'" in completion_script(p, "bash", prog="demo")
    True
    """
    if shell not in SHELLS:
        raise ValueError(f"shell: must be one of {list(SHELLS)}, got {shell!r}")
    script = _bash(parser, prog)
    if shell == "zsh":  # zsh runs bash completion functions through bashcompinit
        script = (f"# {prog} zsh completion, generated by `{prog} completion zsh` (bash completion through zsh's "
                  f"bashcompinit).\n# Install: eval \"$({prog} completion zsh)\"  (e.g. in ~/.zshrc, after compinit)\n"
                  "autoload -U +X compinit && { (( $+functions[compdef] )) || compinit; }\n"
                  "autoload -U +X bashcompinit && bashcompinit\n" + script)
    return script
