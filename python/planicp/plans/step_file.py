"""The instances of an ISO 10303-21 (STEP) file, the text form of IFC building models, read lazily.

A STEP file's DATA section is a list of records `#12=IFCWALL('guid',#5,'Wall 1',$,$,#40,#52,$);`:
an instance number, an entity type, and its attributes (strings, numbers, enumerations `.T.`,
references `#n`, `$` for unset, `*` for derived, lists in parentheses, typed values such as
`IFCLENGTHMEASURE(2.5)`). `StepFile` finds every record once (a regular expression over the
text) and parses an instance's attributes only when they are asked for. Complex instances
(`#1=(A()B());`, rare in IFC) are not read.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

__all__ = ["Enum", "Ref", "StepFile"]

MAX_STEP_BYTES = 1 << 30
"""Largest STEP file read, bytes (1 GiB)."""


@dataclass(frozen=True)
class Ref:
    """A reference to instance `#id`."""

    id: int


@dataclass(frozen=True)
class Enum:
    """An enumeration value (`.ELEMENT.` is Enum("ELEMENT")); booleans are Enum("T") and Enum("F")."""

    name: str


_RECORD = re.compile(rb"#(\d+)\s*=\s*([A-Za-z_][A-Za-z0-9_]*)\s*\(((?:[^;']|'(?:[^']|'')*')*)\)\s*;")
_TOKEN = re.compile(
    r"\s*(?:"
    r"'((?:[^']|'')*)'"  # 1 string
    r"|#(\d+)"  # 2 reference
    r"|\.([A-Za-z0-9_]+)\."  # 3 enumeration
    r"|([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)"  # 4 number
    r"|(\$|\*)"  # 5 unset / derived
    r"|([A-Za-z_][A-Za-z0-9_]*)\s*\("  # 6 typed value
    r"|(\()"  # 7 list
    r"|(\))"  # 8 end
    r"|(,)"  # 9 separator
    r'|"([0-9A-Fa-f]*)"'  # 10 binary
    r")"
)
_X2 = re.compile(r"\\X2\\((?:[0-9A-Fa-f]{4})+)\\X0\\")


def _decode(text: str) -> str:
    text = text.replace("''", "'")
    return _X2.sub(lambda m: bytes.fromhex(m.group(1)).decode("utf-16-be", "replace"), text)


def _parse(text: str) -> list[Any]:
    """The attributes of one record (the text between its outer parentheses)."""
    stack: list[list[Any]] = [[]]
    pos, end = 0, len(text)
    while pos < end:
        m = _TOKEN.match(text, pos)
        if m is None:
            if text[pos:].strip() == "":
                break
            raise ValueError(f"unexpected text {text[pos : pos + 30]!r}")
        pos = m.end()
        kind = m.lastindex
        if kind == 1:
            stack[-1].append(_decode(m.group(1)))
        elif kind == 2:
            stack[-1].append(Ref(int(m.group(2))))
        elif kind == 3:
            stack[-1].append(Enum(m.group(3).upper()))
        elif kind == 4:
            number = m.group(4)
            stack[-1].append(float(number) if any(c in number for c in ".eE") else int(number))
        elif kind == 5:
            stack[-1].append(None)
        elif kind in (6, 7):  # a typed value keeps only its value: a one-element list unwrapped on close
            stack.append([] if kind == 7 else ["__typed__"])
        elif kind == 8:
            if len(stack) < 2:
                raise ValueError("unbalanced parentheses")
            done = stack.pop()
            if done and done[0] == "__typed__":
                stack[-1].append(done[1] if len(done) == 2 else done[1:])
            else:
                stack[-1].append(done)
        elif kind == 10:
            stack[-1].append(m.group(10))
    if len(stack) != 1:
        raise ValueError("unbalanced parentheses")
    return stack[0]


class StepFile:
    """The records of a STEP file: `types[name]` the instance numbers of each entity type
    (upper case), `attributes(id)` an instance's parsed attributes, `type_of(id)` its type."""

    def __init__(self, path: Path) -> None:
        size = path.stat().st_size
        if size > MAX_STEP_BYTES:
            raise ValueError(
                f"IFC file {str(path)!r} is {size >> 20} MiB; IFC files are read up to {MAX_STEP_BYTES >> 20} MiB"
            )
        data = path.read_bytes()
        if not data.lstrip(b"\xef\xbb\xbf \t\r\n").startswith(b"ISO-10303-21"):
            raise ValueError(f"IFC file {str(path)!r} is not a STEP file (it does not start with ISO-10303-21;)")
        head_end = data.find(b"ENDSEC;")
        header = data[: head_end if head_end > 0 else 4096].decode("latin-1")
        schema = re.search(r"FILE_SCHEMA\s*\(\s*\(\s*'([^']*)'", header)
        self.schema = schema.group(1).upper() if schema else ""
        """The schema the header names (IFC2X3, IFC4, IFC4X3, ...; "" when none)."""
        start = data.find(b"DATA;")
        body = data[start:] if start >= 0 else data
        self._records: dict[int, tuple[str, bytes]] = {}
        self.types: dict[str, list[int]] = {}
        for m in _RECORD.finditer(body):
            number, kind = int(m.group(1)), m.group(2).decode("ascii").upper()
            self._records[number] = (kind, m.group(3))
            self.types.setdefault(kind, []).append(number)
        self._parsed: dict[int, list[Any]] = {}

    def __len__(self) -> int:
        return len(self._records)

    def __contains__(self, number: int) -> bool:
        return number in self._records

    def type_of(self, ref: Ref | int) -> str:
        """The entity type of an instance (upper case); "" for a missing one."""
        number = ref.id if isinstance(ref, Ref) else ref
        record = self._records.get(number)
        return record[0] if record else ""

    def attributes(self, ref: Ref | int) -> list[Any]:
        """The attributes of an instance: str, int, float, `Ref`, `Enum`, None, lists of these.

        Raises:
            KeyError: no such instance. ValueError: its attributes cannot be parsed.
        """
        number = ref.id if isinstance(ref, Ref) else ref
        parsed = self._parsed.get(number)
        if parsed is None:
            kind, raw = self._records[number]
            try:
                parsed = _parse(raw.decode("latin-1"))
            except ValueError as exc:
                raise ValueError(f"instance #{number} ({kind}): {exc}") from None
            self._parsed[number] = parsed
        return parsed
