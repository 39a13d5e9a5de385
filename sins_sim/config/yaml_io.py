"""Reading YAML configuration files the way people write them.

:func:`load_yaml` is the one entry point for every YAML file sins-sim reads
(IMU configurations, scenarios, experiment descriptions, nominal parameters).
It differs from ``yaml.safe_load`` in two ways, both on a private loader
(:class:`StrictLoader`; PyYAML's global ``SafeLoader`` is left untouched):

- **YAML 1.2 numbers.** PyYAML resolves floats by the YAML 1.1 rules, under
  which ``1e-3``, ``3e0`` and ``1E+9`` (no dot, or no sign in the exponent)
  are *strings*; a person means numbers. The loader's float resolver takes
  the YAML 1.2 core-schema forms (``3e0``, ``1e-3``, ``1E+9``, ``.5``,
  ``-2.5e-3``, ``.inf``, ``.nan``) besides the 1.1 ones it already knew
  (``1_000.5``, ``190:20:30.15``). Plain integers stay integers, and a quoted
  ``"3e0"`` stays a string.
- **Duplicate keys are errors** at any nesting level (YAML forbids them;
  PyYAML silently keeps the last one). Keys brought in by a merge (``<<``)
  may still be overridden by the mapping's own keys.

Every failure is one :class:`~sins_sim.config.schema.ConfigError` line that
names the file: a missing file, a directory, an unreadable or non-UTF-8 file,
malformed YAML (with line and column), a duplicate key (with both lines), or
a top level that is not a mapping.

Examples
--------
>>> import yaml
>>> yaml.load("a: 1e-3\\nb: '3e0'\\nc: 7", Loader=StrictLoader)
{'a': 0.001, 'b': '3e0', 'c': 7}
"""

from __future__ import annotations

import re
from pathlib import Path

import yaml

from sins_sim.config.errors import ConfigError, register_marks

__all__ = ["StrictLoader", "DuplicateKeyError", "FLOAT_PATTERN", "load_yaml", "parse_yaml", "key_marks"]

_FLOAT_TAG = "tag:yaml.org,2002:float"
_MERGE_TAG = "tag:yaml.org,2002:merge"

#: Plain scalars resolved as floats: YAML 1.2 core schema plus the YAML 1.1 forms PyYAML knew.
#: An integer (no dot, no exponent) does not match and stays an ``int``.
FLOAT_PATTERN = re.compile(r"""^(?:
      [-+]?[0-9][0-9_]*\.[0-9_]*(?:[eE][-+]?[0-9]+)?   # 1.  1.5  1.5e3  1.5E-3  1_000.5
    | [-+]?[0-9][0-9_]*[eE][-+]?[0-9]+                 # 3e0  1e-3  1E+9
    | [-+]?\.[0-9][0-9_]*(?:[eE][-+]?[0-9]+)?          # .5  -.5e-3
    | [-+]?[0-9][0-9_]*(?::[0-5]?[0-9])+\.[0-9_]*      # 190:20:30.15 (YAML 1.1 sexagesimal)
    | [-+]?\.(?:inf|Inf|INF)
    | \.(?:nan|NaN|NAN)
    )$""", re.X)


class DuplicateKeyError(yaml.YAMLError):
    """A mapping holds the same key twice (``key``, 1-based ``first_line`` and ``line``)."""

    def __init__(self, key, first_line: int, line: int):
        super().__init__(f"duplicate key {key!r} at lines {first_line} and {line}")
        self.key = key
        self.first_line = first_line
        self.line = line


class StrictLoader(yaml.SafeLoader):
    """``SafeLoader`` with YAML 1.2 floats and duplicate keys rejected (see the module docstring)."""

    def construct_mapping(self, node, deep=False):
        if isinstance(node, yaml.MappingNode):
            seen = {}
            for key_node, _ in node.value:
                if key_node.tag == _MERGE_TAG:  # merged keys may be overridden by the mapping's own
                    continue
                key = self.construct_object(key_node, deep=True)
                line = key_node.start_mark.line + 1
                try:
                    first = seen.get(key)
                except TypeError:  # an unhashable key: the base class reports it with its position
                    continue
                if first is not None:
                    raise DuplicateKeyError(key, first, line)
                seen[key] = line
        return super().construct_mapping(node, deep=deep)


# a private copy of the resolver table: the 1.1 float resolver replaced by FLOAT_PATTERN
StrictLoader.yaml_implicit_resolvers = {
    first: [(tag, regexp) for tag, regexp in resolvers if tag != _FLOAT_TAG]
    for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()
}
StrictLoader.add_implicit_resolver(_FLOAT_TAG, FLOAT_PATTERN, list("-+0123456789."))


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def parse_yaml(text: str, where: str = "<string>"):
    """Parse YAML text with :class:`StrictLoader`; any failure is one ConfigError naming ``where``.

    The top level may be anything here (:func:`load_yaml` requires a mapping).
    """
    return _parse(text, where)[0]


def _parse(text: str, where: str):
    """``(document, root node)``: what ``yaml.load`` does, keeping the node tree for the key positions."""
    try:
        loader = StrictLoader(text)
        try:
            node = loader.get_single_node()
            return (loader.construct_document(node) if node is not None else None), node
        finally:
            loader.dispose()
    except DuplicateKeyError as exc:
        raise ConfigError(f"{where}: duplicate key {exc.key!r} at lines {exc.first_line} and {exc.line}") from None
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        at = f" line {mark.line + 1}, column {mark.column + 1}:" if mark is not None else ""
        problem = exc.problem or exc.context or str(exc)
        raise ConfigError(f"{where}:{at} malformed YAML: {_one_line(problem)}") from None
    except yaml.YAMLError as exc:  # reader errors (control characters, ...): no mark
        raise ConfigError(f"{where}: malformed YAML: {_one_line(exc)}") from None
    except RecursionError:
        raise ConfigError(f"{where}: malformed YAML: nested too deeply") from None


def key_marks(node) -> dict:
    """Where each key and list item of a composed document starts: ``{("motion", 0, "type"): (line, column)}``.

    Lines and columns are 1-based (PyYAML's marks are 0-based). Keys brought in by a merge (``<<``)
    point at the anchored mapping they come from, unless the mapping overrides them. A node reached
    twice through an alias is walked once (so an alias bomb costs nothing here).
    """
    out: dict = {}
    seen: set = set()
    stack = [((), node)]
    while stack:
        path, n = stack.pop()
        if n is None or id(n) in seen:
            continue
        seen.add(id(n))
        if isinstance(n, yaml.MappingNode):
            children = [((*path, k.value), k, v) for k, v in n.value
                        if isinstance(k, yaml.ScalarNode) and k.tag != _MERGE_TAG]
        elif isinstance(n, yaml.SequenceNode):
            children = [((*path, i), v, v) for i, v in enumerate(n.value)]
        else:
            continue
        for p, mark_node, value in children:
            out[p] = (mark_node.start_mark.line + 1, mark_node.start_mark.column + 1)
            stack.append((p, value))
    return out


def load_yaml(path) -> dict:
    """Parse a YAML file whose top level is a mapping.

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    dict

    Raises
    ------
    ConfigError
        One line naming the file: cannot be read (missing, a directory, no
        permission, not UTF-8), malformed YAML (line and column), a duplicate
        key (both lines), or a top level that is not a mapping.
    """
    path = Path(path)
    try:
        raw = path.read_bytes()
    except IsADirectoryError:
        raise ConfigError(f"{path}: cannot read: is a directory, not a YAML file") from None
    except FileNotFoundError:
        raise ConfigError(f"{path}: cannot read: no such file") from None
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read: {exc.strerror or exc}") from None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{path}: cannot read: not UTF-8 text (byte {exc.start})") from None
    doc, node = _parse(text, str(path))
    if isinstance(doc, dict):
        register_marks(str(path), key_marks(node))
    if not isinstance(doc, dict):
        got = "an empty file" if doc is None else type(doc).__name__
        raise ConfigError(f"{path}: the top level must be a mapping, got {got}")
    return doc
