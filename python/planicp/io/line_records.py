"""The records of a line-based text log, and the tally of what a reader could not use."""

from __future__ import annotations

import re
import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from .scan_log import BadLine
from .text_source import TruncatedStream, read_lines

_RECORD_NAME = re.compile(r"[A-Z][A-Z0-9_]{1,39}(?: \(.{1,80}\))?")
"""A record kind (FLASER, ODOM, ROBOTLASER1, ...), optionally with a note in brackets."""


def skipped_summary(skipped: dict[str, int], most: int = 6) -> str:
    """`skipped` for a message: the `most` most frequent kinds and how many more there were."""
    if not skipped:
        return "nothing"
    kinds = sorted(skipped.items(), key=lambda item: -item[1])
    text = ", ".join(f"{kind}: {count}" for kind, count in kinds[:most])
    return text if len(kinds) <= most else f"{text} and {len(kinds) - most} more kinds"


@dataclass
class LineTally:
    """What a reader skipped: record kinds it does not read (counted) and malformed lines (counted
    and kept with their line numbers), or, with `errors="raise"`, the first malformed line as an error."""

    source: Path
    errors: str
    skipped: dict[str, int] = field(default_factory=dict)
    bad: list[BadLine] = field(default_factory=list)

    def __post_init__(self) -> None:
        if self.errors not in ("skip", "raise"):
            raise ValueError(f"errors must be 'skip' or 'raise', got {self.errors!r}")

    def skip(self, kind: str, count: int = 1) -> None:
        """Counts `count` records of `kind` left out. A first field that is no record name (binary
        bytes, a stray number) is counted as "(not a record)", so that a binary file gives one key,
        not thousands."""
        if not _RECORD_NAME.fullmatch(kind):
            kind = "(not a record)"
        self.skipped[kind] = self.skipped.get(kind, 0) + count

    def reject(self, line: int, kind: str, reason: str) -> None:
        """A malformed line: recorded and counted, or raised with `errors="raise"`."""
        if self.errors == "raise":
            raise ValueError(f"{self.source}, line {line}: bad {kind} line: {reason}")
        self.bad.append(BadLine(line, kind, reason))
        self.skip(f"{kind} (malformed)")

    def warn(self, stacklevel: int) -> None:
        """One warning naming the first malformed line, when there was any."""
        if self.bad:
            first = self.bad[0]
            warnings.warn(
                f"{self.source}: skipped {len(self.bad)} malformed line(s); first at line {first.line} "
                f"({first.kind}): {first.reason}",
                stacklevel=stacklevel + 1,
            )


MAX_KIND_CHARS = 40
"""Longest record kind kept (in `skipped`, bad lines and messages): a longer first token is cut."""


def records(tally: LineTally) -> Iterator[tuple[int, str, list[str]]]:
    """(1-based line number, record kind, whitespace-split fields) of every line of `tally.source`
    that is not empty or a `#` comment. The kind is the first field, cut to `MAX_KIND_CHARS`. A
    compressed stream that ends early ends the records (the lines before the break are kept and the
    break is tallied), or raises with `errors="raise"`."""
    try:
        for line, text in read_lines(tally.source):
            fields = text.split()
            if fields and not fields[0].startswith("#"):
                kind = fields[0] if len(fields[0]) <= MAX_KIND_CHARS else fields[0][: MAX_KIND_CHARS - 3] + "..."
                yield line, kind, fields
    except TruncatedStream as exc:
        if tally.errors == "raise":
            raise
        tally.bad.append(BadLine(exc.line + 1, "(compressed stream)", str(exc)))
        tally.skipped["(compressed stream ends early)"] = 1
