"""Dotted paths into a scenario's dict: where a campaign's ``[set]`` and sweeps write.

``a.b`` is a table's field, ``a.b[0]`` one item of an array of tables and ``a.b[*]`` every item
(``mission.legs[*].depth_m``).
"""

from __future__ import annotations

import copy
import re
from typing import Any

_PATH_PART = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)((?:\[(?:\d+|\*)\])*)")


def parse_path(path: str) -> list[tuple[str, list[str]]] | None:
    """The parts of a dotted path, each (name, indices); None when it is not one."""
    parts = []
    for chunk in path.split("."):
        m = _PATH_PART.fullmatch(chunk)
        if m is None:
            return None
        parts.append((m.group(1), re.findall(r"\[(\d+|\*)\]", m.group(2))))
    return parts


def set_path(data: dict[str, Any], path: str, value: Any) -> None:
    """Set ``value`` at a dotted path (``a.b[0].c``, ``legs[*].depth_m``) in a scenario dict.

    Raises:
        KeyError: The path does not fit the scenario (tables and arrays must exist; the last
            field may be new, so that defaults left out of a file can be set).
    """
    parts = parse_path(path)
    if parts is None:
        raise KeyError(f"{path!r} is not a dotted path (a.b, a.b[0], a.b[*])")
    _set(data, parts, value, path)


def _set(node: Any, parts: list[tuple[str, list[str]]], value: Any, path: str) -> None:
    (key, idx), rest = parts[0], parts[1:]
    if not isinstance(node, dict):
        raise KeyError(f"{path!r}: {key!r} is inside a value, not a table")
    if not idx and not rest:
        node[key] = copy.deepcopy(value)
        return
    if key not in node:
        raise KeyError(f"{path!r}: no field {key!r} in the scenario")
    _descend(node, key, idx, rest, value, path)


def _descend(parent: Any, key: Any, idx: list[str], rest: list, value: Any, path: str) -> None:
    if not idx:
        _set(parent[key], rest, value, path)
        return
    arr = parent[key]
    if not isinstance(arr, list):
        raise KeyError(f"{path!r}: {key!r} is not an array")
    ks = range(len(arr)) if idx[0] == "*" else [int(idx[0])]
    for k in ks:
        if k >= len(arr):
            raise KeyError(f"{path!r}: index {k} out of range ({len(arr)} items)")
        if len(idx) == 1 and not rest:
            arr[k] = copy.deepcopy(value)
        else:
            _descend(arr, k, idx[1:], rest, value, path)
