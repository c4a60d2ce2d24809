"""Object types from names: the rule that turns a body, geom or node name into an object type.

Shared by :class:`perception.mujoco.MujocoScene` and :meth:`WorldModel.from_file
<worldgraph.WorldModel.from_file>` (:mod:`worldgraph.importers` re-exports these names), so that
a simulated camera and the world model read from the same file type the same bodies.

``type_of`` (see :func:`type_rule`):

* ``None``: :func:`default_type_of`, the leading word of the name (the letters before the first
  character that is not a letter, lower-cased) when it is one of :data:`KNOWN_TYPES`;
* a callable ``name -> type or None`` (``None``: not an object);
* a mapping ``regex pattern -> type``: the first pattern (in mapping order) that
  :func:`re.search` finds in the name gives the type; no match: not an object.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from typing import Any

from ._checks import _short, name_string
from .errors import PerceptionError

__all__ = ["KNOWN_TYPES", "default_type_of", "type_rule"]

#: Types the default rule (:func:`default_type_of`) recognises as the leading word of a name.
KNOWN_TYPES = (
    "appliance", "burner", "button", "cabinet", "chair", "dishwasher", "door", "drawer", "faucet",
    "fridge", "handle", "hood", "kettle", "knob", "lamp", "microwave", "oven", "panel", "radiator",
    "shelf", "sink", "socket", "stove", "switch", "table", "window",
)

_LEADING_WORD = re.compile(r"[^\W\d_]+")


def default_type_of(name: str) -> str | None:
    """The type of a name by the default rule: its leading word if that is a known type.

    Parameters
    ----------
    name : str
        A node, body or geom name.

    Returns
    -------
    str or None
        The letters of ``name`` before the first character that is not a letter, lower-cased,
        when they are one of :data:`KNOWN_TYPES`; else ``None``.

    Examples
    --------
    >>> default_type_of("door_3"), default_type_of("Knob 1"), default_type_of("hingeleftdoor")
    ('door', 'knob', None)
    """
    match = _LEADING_WORD.match(str(name))
    if match is None:
        return None
    word = match.group(0).lower()
    return word if word in KNOWN_TYPES else None


def type_rule(type_of: Any) -> Callable[[str], str | None]:
    """The callable ``name -> type or None`` that a ``type_of`` argument stands for.

    Parameters
    ----------
    type_of : None, callable or mapping
        ``None`` gives :func:`default_type_of`; a callable is returned as is; a mapping of
        regex patterns (``str`` or compiled) to type names gives the rule "first pattern that
        :func:`re.search` finds in the name".

    Returns
    -------
    callable
        ``name -> type or None``.

    Raises
    ------
    PerceptionError
        ``type_of`` of another kind, an empty mapping, a pattern that does not compile (naming
        it) or a type that is not a non-empty string.
    """
    if type_of is None:
        return default_type_of
    if isinstance(type_of, Mapping):
        if not type_of:
            raise PerceptionError("type_of must map at least one regex pattern to a type, got {}")
        rules: list[tuple[re.Pattern[str], str]] = []
        for pattern, typ in type_of.items():
            if isinstance(pattern, re.Pattern):
                compiled = pattern
            elif isinstance(pattern, str):
                try:
                    compiled = re.compile(pattern)
                except re.error as exc:
                    raise PerceptionError(f"type_of pattern {pattern!r} is not a valid regular "
                                          f"expression: {exc}") from exc
            else:
                raise PerceptionError(f"type_of keys must be regex patterns (str or re.Pattern), got "
                                      f"{_short(pattern)}")
            name_string(f"type_of[{pattern!r}]", typ)
            rules.append((compiled, typ))

        def by_pattern(name: str) -> str | None:
            for compiled, typ in rules:
                if compiled.search(name):
                    return typ
            return None

        return by_pattern
    if callable(type_of):
        return type_of
    raise PerceptionError("type_of must be None, a callable name -> type or None, or a mapping of regex "
                          f"patterns to types, got {_short(type_of)}")
