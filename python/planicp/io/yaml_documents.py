"""YAML documents read safely: bounded in size, aliases included, and quoted briefly in errors.

A YAML file can be small and still expand to an enormous document: anchors and aliases
(`&a [*b, *b, *b, ...]`) nest references, and a 437-byte map_server YAML grew to 4.7 GB when a
value was turned into text for an error message. `load_yaml` refuses a document whose values,
with every alias expanded, number more than `MAX_EXPANDED_VALUES` (counted without expanding
anything), and messages quote values with `planicp._validation.brief`, at a bounded length.
"""

from __future__ import annotations

from typing import Any

from .._validation import brief

MAX_EXPANDED_VALUES = 100_000
"""Most values (scalars, lists and mappings, every alias expanded) a document may hold. A
map_server YAML holds about a dozen, a study a few hundred."""

MAX_DOCUMENT_BYTES = 10_000_000
"""Largest YAML file read (10 MB)."""

def load_yaml(text: str, source: str) -> Any:
    """The document in `text` (`source` names it in errors), parsed by PyYAML's safe loader.

    Raises:
        ValueError: not valid YAML, longer than `MAX_DOCUMENT_BYTES`, or more than
            `MAX_EXPANDED_VALUES` values once its aliases are expanded; the message names `source`.
    """
    import yaml

    if len(text) > MAX_DOCUMENT_BYTES:
        raise ValueError(f"{source} is {len(text)} characters long; a YAML document here is at most "
                         f"{MAX_DOCUMENT_BYTES}")
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ValueError(f"{source} is not valid YAML: {brief(str(exc))}") from None
    except RecursionError:
        raise ValueError(f"{source} nests its values too deeply to be read") from None
    size = expanded_size(data)
    if size > MAX_EXPANDED_VALUES:
        raise ValueError(f"{source} expands to more than {MAX_EXPANDED_VALUES} values through its aliases "
                         f"(&anchor / *alias); write the values out without them")
    return data


def expanded_size(data: Any, limit: int = MAX_EXPANDED_VALUES) -> int:
    """How many values `data` holds with every shared list or mapping counted each time it is
    referred to (as a YAML alias expands), counted in time proportional to the distinct ones;
    a count past `limit` is returned as `limit + 1`."""
    known: dict[int, int] = {}
    done: set[int] = set()
    stack: list[tuple[Any, bool]] = [(data, False)]
    while stack:
        value, children_counted = stack.pop()
        key = id(value)
        if not isinstance(value, (list, dict)) or key in done:
            continue
        children = list(value.values()) + list(value.keys()) if isinstance(value, dict) else value
        if not children_counted:
            if key in known:  # a cycle (PyYAML builds recursive aliases as such)
                return limit + 1
            known[key] = 0
            stack.append((value, True))
            stack.extend((c, False) for c in children if isinstance(c, (list, dict)) and id(c) not in done)
            continue
        total = 1
        for child in children:
            total += known.get(id(child), 1) if isinstance(child, (list, dict)) else 1
            if total > limit:
                total = limit + 1
                break
        known[key] = total
        done.add(key)
    if isinstance(data, (list, dict)):
        return known[id(data)]
    return 1
