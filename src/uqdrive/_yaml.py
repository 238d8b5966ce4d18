"""The one YAML reader of every file uqdrive reads (configs, vehicle files, model.yaml, sweeps):
YAML 1.2 numbers (``1.573e3`` is a float) and a key given twice in one mapping refused by name.
"""

from __future__ import annotations

import re

import yaml

__all__ = ["load_yaml", "DuplicateKeyError", "YAMLSyntaxError"]

_Base = getattr(yaml, "CSafeLoader", yaml.SafeLoader)  # libyaml parses 20x faster; the resolver stays Python's

#: YAML 1.2 (core schema) floats: the exponent's sign is optional and a float needs no dot
#: (``1e3``, ``1.573e3``); PyYAML's YAML 1.1 pattern reads both as text. The 1.1 forms stay
#: (``1_000.5``, sexagesimal ``1:30.5``). A plain integer stays an int: the int resolver follows.
_FLOAT = re.compile(r"""^(?:[-+]?(?:[0-9][0-9_]*)\.[0-9_]*(?:[eE][-+]?[0-9]+)?
                    |[-+]?(?:[0-9][0-9_]*)[eE][-+]?[0-9]+
                    |[-+]?\.[0-9][0-9_]*(?:[eE][-+]?[0-9]+)?
                    |[-+]?[0-9][0-9_]*(?::[0-5]?[0-9])+\.[0-9_]*
                    |[-+]?\.(?:inf|Inf|INF)
                    |\.(?:nan|NaN|NAN))$""", re.X)
_FLOAT_TAG = "tag:yaml.org,2002:float"


class DuplicateKeyError(yaml.YAMLError):
    """A mapping gives the same key twice (YAML requires unique keys; PyYAML keeps the last silently)."""


class YAMLSyntaxError(yaml.YAMLError):
    """Text that is not YAML: the problem, where it is, and what to check there, on one line."""


class _Loader(_Base):
    """Safe loader with the YAML 1.2 float pattern and unique mapping keys."""

    def construct_mapping(self, node, deep=False):  # noqa: D102 (PyYAML API)
        if isinstance(node, yaml.MappingNode):
            seen: dict = {}
            for key_node, _ in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":
                    continue
                key = self.construct_object(key_node, deep=True)
                mark = key_node.start_mark
                try:
                    first = seen.setdefault(key, mark)
                except TypeError:
                    continue  # an unhashable key: the base class says what is wrong with it
                if first is not mark:  # a flow mapping ({a: 1, a: 2}) gives both on one line
                    where = (f"lines {first.line + 1} and {mark.line + 1}" if first.line != mark.line else
                             f"line {mark.line + 1}, columns {first.column + 1} and {mark.column + 1}")
                    raise DuplicateKeyError(f"key '{key}' is given twice ({where}); keep one of them")
        return super().construct_mapping(node, deep=deep)


_Loader.yaml_implicit_resolvers = {first: [(tag, _FLOAT if tag == _FLOAT_TAG else regexp) for tag, regexp in resolvers]
                                   for first, resolvers in _Base.yaml_implicit_resolvers.items()}
for _first in "-+0123456789.":
    if not any(tag == _FLOAT_TAG for tag, _ in _Loader.yaml_implicit_resolvers.get(_first, [])):
        _Loader.yaml_implicit_resolvers.setdefault(_first, []).insert(0, (_FLOAT_TAG, _FLOAT))


def load_yaml(text: str):
    """The value of the YAML document ``text``.

    Raises
    ------
    yaml.YAMLError
        For text that is not YAML (:class:`YAMLSyntaxError`, one line naming the line and column),
        or a mapping that gives a key twice (:class:`DuplicateKeyError`).
    """
    try:
        return yaml.load(text, Loader=_Loader)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = " ".join(str(exc.problem or exc.context or exc).split())
        raise YAMLSyntaxError(f"{problem}{where}; fix the YAML there (closing brackets and quotes, indentation by spaces, "
                              "not tabs)") from None
