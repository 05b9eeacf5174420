"""YAML documents read safely: bounded in size, aliases included, and quoted briefly in errors.

A YAML file can be small and still expand to an enormous document: anchors and aliases
(`&a [*b, *b, *b, ...]`) nest references, and a 437-byte map_server YAML grew to 4.7 GB when a
value was turned into text for an error message. `load_yaml` refuses a document whose values,
with every alias expanded, number more than `MAX_EXPANDED_VALUES` (counted without expanding
anything), and messages quote values with `planicp._validation.brief`, at a bounded length.

A large document is slow as well: PyYAML's pure-Python parser takes about 20 microseconds a byte
(a 1.3 MB study took minutes), its C parser (libyaml, in PyYAML's wheels) about a tenth of that.
The C parser is used when PyYAML has it, and documents are read up to `MAX_DOCUMENT_BYTES`, checked
before the file is read.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from .._validation import brief

MAX_EXPANDED_VALUES = 100_000
"""Most values (scalars, lists and mappings, every alias expanded) a document may hold. A
map_server YAML holds about a dozen, a study a few hundred."""

MAX_DOCUMENT_BYTES = 256 * 1024
"""Largest YAML document read (256 KiB; a map_server YAML is about 200 bytes, a study a few
kilobytes). Parsing the largest takes about 0.7 s with the C parser, 6 s without it."""


def read_yaml_file(path: Path, source: str) -> Any:
    """The document in the file at `path` (`source` names it in errors), as `load_yaml` reads it.

    Raises:
        ValueError: larger than `MAX_DOCUMENT_BYTES` (refused before it is read), not UTF-8, or
            refused by `load_yaml`; the message names `source`.
        OSError: the file cannot be read.
    """
    size = path.stat().st_size
    if size > MAX_DOCUMENT_BYTES:
        raise ValueError(f"{source} is {size} bytes long; a YAML document here is at most {MAX_DOCUMENT_BYTES} bytes")
    with path.open("rb") as f:
        raw = f.read(MAX_DOCUMENT_BYTES + 1)  # a file that grew since: still bounded
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ValueError(f"{source} is not valid YAML: it is not UTF-8 text (byte {exc.start})") from None
    return load_yaml(text, source)


def load_yaml(text: str, source: str) -> Any:
    """The document in `text` (`source` names it in errors), parsed by PyYAML's safe loader (its
    C version when PyYAML has one).

    Raises:
        ValueError: not valid YAML, longer than `MAX_DOCUMENT_BYTES`, nested too deeply, or more
            than `MAX_EXPANDED_VALUES` values once its aliases are expanded; the message names
            `source`.
    """
    import yaml

    if len(text) > MAX_DOCUMENT_BYTES:
        raise ValueError(
            f"{source} is {len(text)} characters long; a YAML document here is at most {MAX_DOCUMENT_BYTES}"
        )
    loader = yaml.CSafeLoader if getattr(yaml, "__with_libyaml__", False) else yaml.SafeLoader
    try:
        data = yaml.load(text, Loader=loader)
    except yaml.YAMLError as exc:
        if "maximum nesting depth" in str(exc):  # libyaml's limit (1000 levels)
            raise ValueError(f"{source} nests its values too deeply to be read") from None
        raise ValueError(f"{source} is not valid YAML: {brief(' '.join(str(exc).split()))}") from None
    except RecursionError:
        raise ValueError(f"{source} nests its values too deeply to be read") from None
    size = expanded_size(data)
    if size > MAX_EXPANDED_VALUES:
        raise ValueError(
            f"{source} expands to more than {MAX_EXPANDED_VALUES} values through its aliases "
            f"(&anchor / *alias); write the values out without them"
        )
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
