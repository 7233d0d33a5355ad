"""Field paths: a key of a scenario file named as its tables joined by dots, with ``[i]`` for an
element of an array (``controller.kp``, ``simulation.q0[1]``, ``environment.stiffness[1]``), and
the writing of a value at one into a scenario's tables (:func:`assign`), which copies on the
way the tables and arrays it would otherwise change in a table shared with other runs.
"""

from __future__ import annotations

import re

from armlab.errors import FieldPathError

_NAME = r"[A-Za-z_][A-Za-z0-9_]*"
_PATH = re.compile(rf"^{_NAME}(\[\d+\])*(\.{_NAME}(\[\d+\])*)*$")
_SEGMENT = re.compile(rf"({_NAME})((?:\[\d+\])*)")


def _is_field(key: str) -> bool:
    return "." in key or "[" in key


def _segments(path: str) -> list[str | int]:
    """``"environment.stiffness[1]"`` → ["environment", "stiffness", 1]."""
    parts: list[str | int] = []
    for segment in path.split("."):
        match = _SEGMENT.fullmatch(segment)
        parts.append(match.group(1))
        parts.extend(int(i) for i in re.findall(r"\[(\d+)\]", match.group(2)))
    return parts


def assign(data: dict, path: str, value, copied: set[int] | None = None) -> None:
    """Write ``value`` at ``path`` into the nested tables ``data``; missing tables are made
    (``controller.model_link_mass``), the final key is left to the scenario loader to judge.

    With ``copied`` (ids of the containers that are already private copies), every table or
    array on the way is first replaced by a copy, so that containers ``data`` shares with
    another table are never written."""
    parts = _segments(path)
    node = data

    def private(parent, key, child):
        if copied is None or id(child) in copied:
            return child
        child = dict(child) if isinstance(child, dict) else list(child)
        parent[key] = child
        copied.add(id(child))
        return child

    for depth, part in enumerate(parts[:-1]):
        following = parts[depth + 1]
        where = ".".join(str(p) for p in parts[:depth + 1])
        if isinstance(part, int):
            if not isinstance(node, list) or part >= len(node):
                raise FieldPathError(f"{where}: no element {part}")
            child = node[part]
        else:
            if not isinstance(node, dict):
                raise FieldPathError(f"{where}: is not inside a table")
            if part not in node:
                if isinstance(following, int):
                    raise FieldPathError(f"{where}: the scenario has no such array")
                node[part] = {}
            child = node[part]
        if isinstance(following, int) and not isinstance(child, list):
            raise FieldPathError(f"{where}: is {child!r} in the scenario, not an array "
                              "(sweep the whole field)")
        if isinstance(following, str) and not isinstance(child, dict):
            raise FieldPathError(f"{where}: is {child!r} in the scenario, not a table")
        node = private(node, part, child)
    last = parts[-1]
    if isinstance(last, int):
        if last >= len(node):
            raise FieldPathError(f"{path}: the array has {len(node)} elements")
        node[last] = value
    else:
        node[last] = value
