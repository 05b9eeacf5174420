"""Fuzzing every file reader with mutated real files (issue 19, "Hostile input and faults").

Each reader (a *target*) gets small real or real-like seed files, which are mutated case by case:
generic byte mutations (bit flips, bytes set, inserted and deleted, chunks duplicated and swapped,
truncation, splicing from another seed, tokens such as 1e400, NaN, -1, 2^63, a line of 1.1 MB,
5000 brackets, invalid UTF-8) and mutations that know the format (a YAML or JSON value replaced by
a huge number, NaN, a wrong type, a deep nest, an alias bomb or a long string aliased thousands of
times; a CARMEN or g2o token, count, time stamp, line or line type; a DXF group code or value, or a
whole entity; a PGM, PNG or BMP header field, with the PNG checksums recomputed so the decoder goes
on; an .npy header's shape or dtype inside a rebuilt .npz, and its zip layout). The mutated input
of case i is a function of (target, seed, i) alone, so any case can be replayed.

The contract checked on every case:

* the reader returns a well-formed result, or raises one of the target's documented exceptions
  (`Target.documented`; ValueError covers `planicp.PlanicpError` and `StudyError`) whose message
  is one line of at most `MAX_MESSAGE_CHARS` characters naming the file it was given;
* warnings are at most `MAX_MESSAGE_CHARS` characters;
* no case runs longer than `CASE_SECONDS` (a per-case timer raises inside Python; a case stuck in
  native code is killed by the parent after `KILL_GRACE_SECONDS` more);
* no crash: each target runs in a worker process, so a segfault or abort is caught and reported
  with its case, and the worker goes on from the next case;
* memory: the worker runs under an address-space limit of `ADDRESS_SPACE_BYTES` (so a bomb becomes
  a MemoryError, which is a failure); no case may take more than `MAX_CASE_MEMORY_BYTES` (its peak
  resident set, reset before the case through /proc/self/clear_refs, above its resident set at the
  start), and the reader calls may not leave the worker's resident set more than
  `MAX_RSS_DRIFT_BYTES` larger over all the cases. The time and memory bounds hold with the
  readers' work budgets scaled down (`SCALED_BUDGETS`): at their real values a few kilobytes may
  rightly describe a plan that takes minutes and gigabytes to prepare; scaled down, a case over a
  bound is work no budget guards.

A failing case's input files are saved with a `failure.txt` (what failed, the traceback, the
command that replays it) under the failures folder. `benches/fuzz_readers.py` runs 10^4 cases per
target; `tests/test_fuzz_readers.py` a short fixed-seed profile of every target.

The worker is this file run as a script: `python tests/reader_fuzzing.py --worker TARGET ...`.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import dataclasses
import faulthandler
import gzip
import io
import json
import math
import queue
import random
import re
import resource
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import threading
import time
import traceback
import warnings
import zipfile
import zlib
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from types import FrameType
from typing import Any, Literal

HERE = Path(__file__).resolve().parent
DATA = HERE / "data"

CASE_SECONDS = 5.0
"""Longest a case may run, seconds (the readers take milliseconds on these inputs)."""

KILL_GRACE_SECONDS = 15.0
"""How much longer than `CASE_SECONDS` the parent waits for a worker stuck in native code."""

ADDRESS_SPACE_BYTES = 2 << 30
"""RLIMIT_AS of a worker (2 GiB; a worker that has imported planicp, OpenCV and ezdxf maps about
0.5 GiB)."""

MAX_CASE_MEMORY_BYTES = 256 << 20
"""Most memory one case may take (256 MiB): its peak resident set above the resident set at its start."""

MAX_RSS_DRIFT_BYTES = 128 << 20
"""Largest growth of a worker's resident set over its cases' reader calls (128 MiB; the resident set
after each call minus the one before it, summed)."""

MAX_MESSAGE_CHARS = 1000
"""Longest error or warning message accepted."""

MAX_CASE_BYTES = 3 << 19
"""Largest mutated file (1.5 MiB): big enough for a line over `text_source.MAX_LINE_BYTES` (1 MiB).
Reading time grows with the size (a CARMEN log takes about 1.5 s a MB here): a larger case would
measure the machine, not the reader."""

SCALED_BUDGETS: dict[tuple[str, str], int] = {
    ("planicp.plans.image_files", "MAX_IMAGE_PIXELS"): 2_000_000,
    ("planicp.plans.plan_raster", "MAX_IMAGE_PIXELS"): 2_000_000,
    ("planicp.plans.vector_plan", "_MAX_SAMPLES"): 200_000,
    ("planicp.plans.vector_plan", "MAX_ARC_POINTS"): 20_000,
    ("planicp.plans.plan_map", "VISIBILITY_RASTER_CELLS"): 4_000_000,
    ("planicp.io.text_source", "MAX_EXPANSION"): 1,
    ("planicp.io.text_source", "EXPANSION_FLOOR"): 1 << 20,
}
"""The readers' work budgets as the fuzz sets them (module, name): value. At their real values (200
million pixels, 50 million wall points, 2^28 raster cells, a compressed log expanding 100 times) a
file of a few kilobytes may rightly ask for minutes and gigabytes: a plan or log of that size takes
them. Scaled down 16 to 250 times, every input within them is read in well under `CASE_SECONDS` and
`MAX_CASE_MEMORY_BYTES`, so a case over either is work that no budget check guards (the fuzz found
two: a HouseExpo vertex 260 km away had 26 million points sampled before the visibility raster's
limit refused them, and a 1.5 MB gzip log expanded to 1.2 GB of text)."""


def scale_budgets() -> None:
    """Sets `SCALED_BUDGETS` in the modules (in this process only)."""
    import importlib

    for (module, name), value in SCALED_BUDGETS.items():
        target = importlib.import_module(module)
        if not hasattr(target, name):
            raise AttributeError(f"{module}.{name} is gone: update SCALED_BUDGETS")
        setattr(target, name, value)


Files = dict[str, bytes]


class WrongResult(Exception):
    """A reader returned something its documentation rules out."""


class CaseTimeout(BaseException):
    """A case ran past `CASE_SECONDS` (a BaseException, so no reader's `except Exception` eats it)."""


@dataclasses.dataclass(frozen=True)
class Seed:
    """One valid input: its files by name (relative paths), and the one the mutators change."""

    name: str
    files: Files
    target: str


@dataclasses.dataclass(frozen=True)
class Target:
    """A reader under test.

    Attributes:
        name: the target's name (`--reader NAME`).
        call: what is called, for the report.
        documented: the exceptions the reader documents for bad file content.
        seeds: builds the seed inputs.
        mutate: the format-aware mutator of a target file (bytes in, bytes out).
        run: reads the case folder's input (the seed says which file is the entry); raises what the
            reader raises, or WrongResult.
        entry: the file the reader is given, which its messages must name.
        max_bytes: largest mutated file (`MAX_CASE_BYTES` unless the reader is slow per byte).
    """

    name: str
    call: str
    documented: tuple[type[BaseException], ...]
    seeds: Callable[[], list[Seed]]
    mutate: Callable[[random.Random, bytes, list[bytes]], bytes]
    run: Callable[[Path, Seed, int], None]
    entry: Callable[[Seed], str]
    max_bytes: int = MAX_CASE_BYTES


# ---------------------------------------------------------------------------------------------
# Interesting values
# ---------------------------------------------------------------------------------------------

NUMBER_TOKENS = [
    "0",
    "-0",
    "-1",
    "1",
    "2",
    "3",
    "-0.0",
    "0.5",
    "1e9",
    "-1e9",
    "1e10",
    "1e15",
    "1e300",
    "-1e300",
    "1e308",
    "1.8e308",
    "1e400",
    "-1e400",
    "5e-324",
    "1e-320",
    "1e-300",
    "nan",
    "NaN",
    "-nan",
    "inf",
    "-inf",
    "Infinity",
    "2147483647",
    "2147483648",
    "-2147483649",
    "4294967296",
    "9223372036854775807",
    "9223372036854775808",
    "18446744073709551616",
    "1000000",
    "1000001",
    "99999999",
    "9" * 400,
    "1" * 5000,
    "0x10",
    "1_000",
    "\uff11",
    "1,5",
    "+",
    "-",
    ".",
    "e",
    ".5e",
    "1e",
    "--1",
    "1e-4",
    "5e-2",
    "00",
    "007",
    "1.5",
    "3.14159",
]
TEXT_TOKENS = [
    "",
    " ",
    "\t",
    "\r",
    "\x00",
    "#",
    "%",
    "\u00e9",
    "\u202e",
    '"',
    "'",
    "\\",
    "{",
    "}",
    "[",
    "]",
    ":",
    ",",
    "- ",
    "&a",
    "*a",
    "!!binary",
    "!!python/object/apply:os.system ['true']",
    "<<: *a",
    "~",
    "null",
    "true",
    "yes",
    "0o777",
    "?",
    "|",
    ">",
    "@",
    "`",
    "---",
    "...",
    "\u2028",
    "\ufeff",
]
RAW_TOKENS = [b"\xff\xfe", b"\x80", b"\xc3", b"\xed\xa0\x80", b"\x00" * 8, b"\r\n", b"\n" * 50]
INTERESTING_BYTES = [0x00, 0x01, 0x7F, 0x80, 0xFF, 0x0A, 0x0D, 0x20, 0x2D, 0x2E, 0x30, 0x39, 0x65, 0x22, 0x27]


def long_line() -> bytes:
    """One line longer than `planicp.io.text_source.MAX_LINE_BYTES`."""
    return b"9" * ((1 << 20) + 4096)


def token(rng: random.Random) -> bytes:
    """An interesting token (mostly numbers), as bytes."""
    r = rng.random()
    if r < 0.6:
        return rng.choice(NUMBER_TOKENS).encode()
    if r < 0.85:
        return rng.choice(TEXT_TOKENS).encode()
    if r < 0.97:
        return rng.choice(RAW_TOKENS)
    return rng.choice([long_line(), b"[" * 5000 + b"]" * 5000, b"{" * 3000, b"x" * 100_000])


def tweak_number(rng: random.Random, text: bytes) -> bytes:
    """A token near `text` when it is a number (a count one off, a value scaled), else a token."""
    try:
        value = float(text)
    except ValueError:
        return token(rng)
    if not math.isfinite(value):
        return token(rng)
    if value.is_integer() and abs(value) < 1e15 and rng.random() < 0.5:
        return str(int(value) + rng.choice((-1, 1, -2, 2, 1000, -int(value)))).encode()
    factor = rng.choice((-1.0, 0.0, 1e-3, 1e3, 1e6, 1e12, 1e300, 1.0 + 1e-12))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = value * factor
    return repr(out).encode() if math.isfinite(out) else token(rng)


# ---------------------------------------------------------------------------------------------
# Generic byte mutations
# ---------------------------------------------------------------------------------------------


def capped(data: bytes) -> bytes:
    return data[:MAX_CASE_BYTES]


def mutate_bytes(rng: random.Random, data: bytes, others: list[bytes]) -> bytes:
    """One generic mutation of `data`; `others` are the seeds to splice from."""
    n = len(data)
    op = rng.randrange(10)
    if n == 0 or op == 9:
        return capped(data + token(rng))
    if op == 0:  # bit flips
        out = bytearray(data)
        for _ in range(rng.choice((1, 1, 2, 4, 8, 32))):
            out[rng.randrange(n)] ^= 1 << rng.randrange(8)
        return bytes(out)
    if op == 1:  # bytes set to edge values
        out = bytearray(data)
        for _ in range(rng.choice((1, 2, 4))):
            out[rng.randrange(n)] = rng.choice(INTERESTING_BYTES)
        return bytes(out)
    if op == 2:  # random bytes inserted
        at = rng.randrange(n + 1)
        length = rng.choice((1, 2, 4, 16, 256))
        if rng.random() < 0.5:
            chunk = bytes(rng.randrange(256) for _ in range(length))
        else:
            chunk = bytes([rng.randrange(256)]) * length
        return capped(data[:at] + chunk + data[at:])
    if op == 3:  # a range deleted
        at = rng.randrange(n)
        length = min(n - at, rng.choice((1, 4, 64, 1024, n)))
        return data[:at] + data[at + length :]
    if op == 4:  # a chunk duplicated, up to a thousand times
        a = rng.randrange(n)
        b = min(n, a + rng.choice((1, 8, 64, 512, 4096)))
        times = rng.choice((1, 2, 10, 1000))
        at = rng.randrange(n + 1)
        return capped(data[:at] + data[a:b] * times + data[at:])
    if op == 5:  # truncated
        return data[: rng.randrange(n)]
    if op == 6:  # a token spliced in at, or over, a token boundary
        bounds = [m.start() for m in re.finditer(rb"[\s,:\[\]{}]", data)] or [0]
        at = rng.choice(bounds) + 1
        if rng.random() < 0.5:
            end = at
            while end < n and data[end : end + 1] not in b" \t\r\n,:[]{}":
                end += 1
            return capped(data[:at] + token(rng) + data[end:])
        return capped(data[:at] + token(rng) + data[at:])
    if op == 7:  # spliced with another seed
        other = rng.choice(others) if others else data
        return capped(data[: rng.randrange(n + 1)] + other[rng.randrange(len(other) + 1) :])
    # op == 8: two chunks swapped
    a, b = sorted(rng.randrange(n + 1) for _ in range(2))
    c, d = sorted(rng.randrange(n + 1) for _ in range(2))
    if b <= c:
        return data[:a] + data[c:d] + data[b:c] + data[a:b] + data[d:]
    return data[::-1] if rng.random() < 0.1 else data[:a] + data[a:b][::-1] + data[b:]


# ---------------------------------------------------------------------------------------------
# Line and token mutations (CARMEN, g2o)
# ---------------------------------------------------------------------------------------------


def decompressed(data: bytes) -> tuple[bytes, str]:
    """(`data` decompressed, "gz" / "zip" / ""), or the bytes as they are when that fails."""
    try:
        if data[:2] == b"\x1f\x8b":
            return gzip.decompress(data), "gz"
        if data[:4] == b"PK\x03\x04":
            with zipfile.ZipFile(io.BytesIO(data)) as archive:
                names = archive.namelist()
                return archive.read(names[0]), "zip"
    except (OSError, EOFError, zlib.error, zipfile.BadZipFile, IndexError, KeyError, ValueError, NotImplementedError):
        pass
    return data, ""


def compressed(rng: random.Random, data: bytes, kind: str) -> bytes:
    """`data` as a gzip stream or a zip archive (sometimes one with two members, or cut short)."""
    if kind == "gz":
        out = gzip.compress(data, mtime=0)
        return out[: rng.randrange(10, len(out))] if rng.random() < 0.2 and len(out) > 10 else out
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED if rng.random() < 0.5 else zipfile.ZIP_STORED) as archive:
        archive.writestr(zipfile.ZipInfo("log.txt", (2000, 1, 1, 0, 0, 0)), data)
        extra = rng.random()
        if extra < 0.1:
            archive.writestr(zipfile.ZipInfo("second.txt", (2000, 1, 1, 0, 0, 0)), data[:100])
        elif extra < 0.2:
            archive.writestr(zipfile.ZipInfo("__MACOSX/._log.txt", (2000, 1, 1, 0, 0, 0)), b"\x00\x05\x16\x07")
    return buffer.getvalue()


COUNT_FIELDS = {b"FLASER": (1,), b"RLASER": (1,), b"ROBOTLASER1": (8,), b"VERTEX_SE2": (1,), b"EDGE_SE2": (1, 2)}


def mutate_records(rng: random.Random, data: bytes, kinds: list[bytes]) -> bytes:
    """One mutation of a line-based log that knows its record kinds, counts and time stamps."""
    raw, packing = decompressed(data)
    lines = raw.split(b"\n")
    if not lines:
        return data
    useful = [k for k, line in enumerate(lines) if line.split()] or [0]
    k = rng.choice(useful)
    fields = lines[k].split()
    op = rng.randrange(12)
    if op in (0, 1) and fields:  # a token replaced: a neighbouring number or an interesting token
        j = rng.randrange(len(fields))
        fields[j] = tweak_number(rng, fields[j]) if op == 0 else token(rng)
        lines[k] = b" ".join(fields)
    elif op == 2 and fields:  # tokens deleted
        j = rng.randrange(len(fields))
        del fields[j : j + rng.choice((1, 1, 2, 10))]
        lines[k] = b" ".join(fields)
    elif op == 3:  # a token inserted
        fields.insert(
            rng.randrange(len(fields) + 1), token(rng) if rng.random() < 0.5 else rng.choice(fields or [b"1"])
        )
        lines[k] = b" ".join(fields)
    elif op == 4:  # a line repeated
        times = rng.choice((1, 2, 100, 3000))
        lines[k:k] = [lines[k]] * min(times, MAX_CASE_BYTES // (len(lines[k]) + 1))
    elif op == 5:  # lines deleted
        del lines[k : k + rng.choice((1, 1, 5, len(lines)))]
    elif op == 6:  # lines swapped or the order shuffled
        if rng.random() < 0.8:
            j = rng.randrange(len(lines))
            lines[k], lines[j] = lines[j], lines[k]
        else:
            rng.shuffle(lines)
    elif op == 7 and fields:  # the record kind changed
        fields[0] = rng.choice(kinds + [b"#", b"PARAM", b"NEFF", b"SYNC", b"", fields[0].lower()])
        lines[k] = b" ".join(fields)
    elif op == 8 and fields and fields[0] in COUNT_FIELDS:  # a count field changed
        j = rng.choice(COUNT_FIELDS[fields[0]])
        if j < len(fields):
            fields[j] = rng.choice(
                [
                    b"0",
                    b"1",
                    b"2",
                    b"-1",
                    b"2.5",
                    b"1000000",
                    b"1000001",
                    b"10000000",
                    b"1e6",
                    tweak_number(rng, fields[j]),
                ]
            )
            lines[k] = b" ".join(fields)
    elif op == 9:  # time stamps (third last field) made equal, backwards, huge or NaN
        stamp = rng.choice([b"0", b"1e300", b"nan", b"-5", b"1e9", None])
        for m, line in enumerate(lines):
            parts = line.split()
            if len(parts) > 4 and parts[0] in (b"FLASER", b"RLASER", b"ROBOTLASER1", b"ODOM"):
                parts[-3] = stamp if stamp is not None else str(1000.0 - m).encode()
                lines[m] = b" ".join(parts)
    elif op == 10:  # a PARAM that the reader uses
        name = rng.choice(
            [
                b"robot_front_laser_max",
                b"robot_rear_laser_max",
                b"robot_frontlaser_offset",
                b"robot_frontlaser_side_offset",
                b"robot_frontlaser_angular_offset",
                b"robot_rearlaser_offset",
            ]
        )
        lines.insert(rng.randrange(len(lines) + 1), b"PARAM " + name + b" " + token(rng) + b" nohost 0")
    else:  # a very long line, or a line of a single byte
        lines.insert(rng.randrange(len(lines) + 1), long_line() if rng.random() < 0.3 else token(rng))
    out = capped(b"\n".join(lines))
    if packing or rng.random() < 0.1:
        return compressed(rng, out, packing or rng.choice(("gz", "zip")))
    return out


# ---------------------------------------------------------------------------------------------
# YAML and JSON tree mutations
# ---------------------------------------------------------------------------------------------

SPLICE = "@@SPLICE@@"


def yaml_values(rng: random.Random) -> Any:
    """A value of an unexpected kind or size for a YAML or JSON document."""
    choices: list[Any] = [
        0,
        -1,
        1,
        2,
        10**30,
        -(10**30),
        2**63,
        2**31,
        1e308,
        float("inf"),
        float("-inf"),
        float("nan"),
        1e-320,
        -0.0,
        0.5,
        1e9,
        1e10,
        "",
        "x" * 5000,
        "1e-4",
        "-5e-2",
        "nan",
        ".inf",
        "-",
        "default",
        None,
        True,
        False,
        [],
        {},
        [0, 0, 0],
        [0, [1], 0],
        [1e308, 1e308, 0],
        {"a": 1},
        "map.pgm",
        "../map.pgm",
        "/dev/zero",
        "/",
        ".",
        "a\x00b",
        "\u00e9\u202e",
        [[0, 0], [1, 0]],
        [[0, 0]] * 3,
        list(range(50)),
    ]
    value = rng.choice(choices)
    if rng.random() < 0.05:
        for _ in range(rng.choice((10, 100, 300))):
            value = [value]
    return value


def tree_paths(tree: Any, limit: int = 5000) -> list[tuple[Any, ...]]:
    """Paths (keys and indices) to the values of a parsed document, the root first: at most
    `limit`, each shared list or mapping (a YAML alias) entered once, at most 50 levels deep."""
    paths: list[tuple[Any, ...]] = []
    seen: set[int] = set()
    stack: list[tuple[Any, tuple[Any, ...]]] = [(tree, ())]
    while stack and len(paths) < limit:
        value, prefix = stack.pop()
        paths.append(prefix)
        if not isinstance(value, (dict, list)) or id(value) in seen or len(prefix) > 50:
            continue
        seen.add(id(value))
        items = value.items() if isinstance(value, dict) else enumerate(value)
        stack.extend((child, prefix + (key,)) for key, child in list(items)[:limit])
    return paths


def mutate_tree(rng: random.Random, tree: Any, splice: bool) -> Any:
    """One change to a parsed document (in place where possible; returns the new root)."""
    paths = tree_paths(tree)
    path = rng.choice(paths)
    if rng.random() < 0.3:  # a number changed to another number: deeper into the reader than a wrong type
        numbers = [p for p in paths if p and _is_number(_at_path(tree, p))]
        if numbers:
            path = rng.choice(numbers)
            parent = _at_path(tree, path[:-1])
            value = parent[path[-1]]
            parent[path[-1]] = _as_value(tweak_number(rng, repr(value).encode()))
            return tree
    if not path:
        return yaml_values(rng) if rng.random() < 0.3 else tree
    parent = tree
    for key in path[:-1]:
        parent = parent[key]
    last = path[-1]
    op = rng.randrange(9)
    if op <= 2:
        parent[last] = yaml_values(rng)
    elif op == 3:
        parent[last] = SPLICE if splice else yaml_values(rng)
    elif op == 4:
        del parent[last]
    elif op == 5 and isinstance(parent, dict):  # a key renamed (a typo) or an unknown key added
        value = parent.pop(last)
        new = str(last)[:-1] if rng.random() < 0.5 and str(last) else str(last).upper() + "_x"
        parent[new] = value
    elif op == 6:  # a value duplicated elsewhere, or a list made long
        value = parent[last]
        if isinstance(parent, list):
            parent[last:last] = [value] * rng.choice((1, 10, 1000, 20000))
        else:
            other = rng.choice(paths[1:])
            holder = tree
            for key in other[:-1]:
                holder = holder[key]
            holder[other[-1]] = value
    elif op == 7 and isinstance(parent[last], (int, float)) and not isinstance(parent[last], bool):
        parent[last] = (
            _as_value(tweak_number(rng, repr(parent[last]).encode())) if rng.random() < 0.7 else -parent[last]
        )
    else:
        parent[last] = str(parent[last]) if rng.random() < 0.5 else [parent[last]]
    return tree


def text_size(tree: Any, limit: int) -> int:
    """About how many characters a YAML dump of `tree` takes: each list or mapping once (the dumper
    writes a shared one as an alias), each scalar every time it occurs; past `limit`, `limit + 1`."""
    total = 0
    seen: set[int] = set()
    stack = [tree]
    while stack:
        value = stack.pop()
        if isinstance(value, (dict, list)):
            if id(value) in seen:
                total += 8
                continue
            seen.add(id(value))
            stack.extend(value.values() if isinstance(value, dict) else value)
            if isinstance(value, dict):
                stack.extend(value.keys())
        else:
            total += len(str(value)) + 4
        if total > limit:
            return limit + 1
    return total


def _as_value(text: bytes) -> Any:
    """A token as the int, float or (when it is no number) text a document would hold."""
    try:
        return int(text)
    except ValueError:
        pass
    try:
        return float(text)
    except ValueError:
        return text.decode("utf-8", errors="replace")


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _at_path(tree: Any, path: tuple[Any, ...]) -> Any:
    for key in path:
        tree = tree[key]
    return tree


def alias_bomb(levels: int) -> str:
    """A flow-style YAML value whose aliases expand to 9^levels values."""
    parts = ['&l0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    for i in range(1, levels):
        parts.append(f"&l{i} [" + ", ".join([f"*l{i - 1}"] * 9) + "]")
    return "[" + ", ".join(parts) + f", *l{levels - 1}]"


def yaml_snippet(rng: random.Random) -> str:
    """Raw YAML for a value: bombs, deep nests, tags, anchors."""
    r = rng.randrange(9)
    if r == 0:
        return alias_bomb(rng.choice((3, 6, 9, 12)))
    if r == 1:  # a long string referred to thousands of times: few values, a huge text when printed
        text = "x" * rng.choice((1000, 100_000))
        return f'[&s "{text}", ' + ", ".join(["*s"] * rng.choice((10, 5000, 30_000))) + "]"
    if r == 2:
        depth = rng.choice((100, 1000, 5000, 50_000))
        return "[" * depth + "]" * depth
    if r == 3:
        depth = rng.choice((100, 1000, 10_000))
        return "{a: " * depth + "1" + "}" * depth
    if r == 4:
        return rng.choice(
            [
                "!!python/tuple [1, 2]",
                "!!set {a, b}",
                "!!timestamp 2001-12-14",
                "!!binary aGVsbG8=",
                "!!float nan",
                "!!int 0x1F",
                "!!str 5",
                "!!omap [a: 1]",
                "!!python/name:os.system",
                "!<tag:yaml.org,2002:int> '7'",
                "!!null ''",
                "!custom 1",
            ]
        )
    if r == 5:
        return rng.choice(
            [
                "*undefined",
                "&a *a",
                "&a [*a]",
                "{<<: [1]}",
                "{? [1, 2] : 3}",
                "[1, 2",
                "'unterminated",
                '"\\uD800"',
                "{a: 1, a: 2}",
                "|\n  block\n",
                ">-\n folded",
            ]
        )
    if r == 6:
        return "[" + ", ".join(["0"] * rng.choice((3, 1000, 200_000))) + "]"
    if r == 7:
        return rng.choice(
            [
                "1e-4",
                "5e-2",
                "-.inf",
                ".NaN",
                "0o17",
                "0b101",
                "1_000",
                "1:30",
                "0x_1F",
                "+1",
                "190:20:30",
                "~",
                "Null",
                "Yes",
                "Off",
            ]
        )
    return repr(rng.choice(["", "x" * 1000, "a\tb", "\u00e9"]))


def mutate_yaml(rng: random.Random, data: bytes, others: list[bytes]) -> bytes:
    """One change to a YAML document: in its parsed tree (dumped back), or a raw snippet spliced in."""
    import yaml

    if len(data) > 256 * 1024:  # past the readers' limit: parsing and dumping it again would be slow
        return mutate_bytes(rng, data, others)
    loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
    dumper = getattr(yaml, "CSafeDumper", yaml.SafeDumper)
    try:
        tree = yaml.load(data.decode("utf-8"), Loader=loader)
    except (yaml.YAMLError, UnicodeDecodeError, RecursionError, ValueError):
        return mutate_bytes(rng, data, others)
    splice = rng.random() < 0.4
    for _ in range(rng.choice((1, 1, 2, 3))):
        tree = mutate_tree(rng, tree, splice)
    style = rng.choice((None, True, False))
    text = None
    if text_size(tree, MAX_CASE_BYTES) <= MAX_CASE_BYTES:  # the dumper writes scalars out each time they occur
        try:
            text = yaml.dump(
                tree,
                Dumper=dumper,
                sort_keys=False,
                default_flow_style=style,
                allow_unicode=rng.random() < 0.5,
                width=rng.choice((80, 10**6)),
            )
        except Exception:  # noqa: BLE001 - a tree the dumper refuses
            pass
    if text is None:  # (outside the handler: its traceback would keep the dumper's buffers alive)
        return mutate_bytes(rng, data, others)
    if SPLICE in text:
        snippet = yaml_snippet(rng)
        text = text.replace(f"'{SPLICE}'", snippet, 1).replace(SPLICE, snippet, 1)
    if rng.random() < 0.05:
        text = "\ufeff" + text if rng.random() < 0.5 else text.replace("\n", "\r\n")
    return capped(text.encode("utf-8", errors="surrogatepass"))


def mutate_json(rng: random.Random, data: bytes, others: list[bytes]) -> bytes:
    """One change to a JSON document: in its parsed tree, or a raw snippet spliced in."""
    try:
        tree = json.loads(data.decode("utf-8"))
    except (ValueError, RecursionError):
        return mutate_bytes(rng, data, others)
    splice = rng.random() < 0.3
    for _ in range(rng.choice((1, 1, 2, 3))):
        tree = mutate_tree(rng, tree, splice)
    from planicp.io.yaml_documents import expanded_size

    if expanded_size(tree, 200_000) > 200_000:  # JSON writes shared values out: a list of lists could be gigabytes
        return mutate_bytes(rng, data, others)
    try:
        text = json.dumps(tree, indent=rng.choice((None, 1)))
    except (ValueError, RecursionError):
        return mutate_bytes(rng, data, others)
    if SPLICE in text:
        depth = rng.choice((10, 1000, 100_000))
        snippet = rng.choice(
            [
                "[" * depth + "]" * depth,
                '{"a":' * depth + "1" + "}" * depth,
                "1" * 5000,
                "1e400",
                "-1e400",
                "NaN",
                "-Infinity",
                '"\\ud800"',
                "[" + ",".join(["[0,0]"] * 100_000) + "]",
                "tru",
                '"\\u0000"',
                "0" * 100,
            ]
        )
        text = text.replace(f'"{SPLICE}"', snippet, 1)
    return capped(text.encode("utf-8", errors="surrogatepass"))


# ---------------------------------------------------------------------------------------------
# DXF mutations: group code / value pairs
# ---------------------------------------------------------------------------------------------

DXF_CODES = [
    b"0",
    b"2",
    b"5",
    b"8",
    b"9",
    b"10",
    b"11",
    b"20",
    b"21",
    b"30",
    b"31",
    b"39",
    b"40",
    b"41",
    b"42",
    b"43",
    b"50",
    b"51",
    b"62",
    b"66",
    b"70",
    b"90",
    b"100",
    b"210",
    b"220",
    b"230",
    b"330",
    b"1001",
    b"1071",
    b"999",
    b"-1",
    b"abc",
    b"",
    b"  10",
    b"1e3",
    b"5000",
]
DXF_NAMES = [
    b"LINE",
    b"ARC",
    b"CIRCLE",
    b"LWPOLYLINE",
    b"POLYLINE",
    b"VERTEX",
    b"SEQEND",
    b"INSERT",
    b"TEXT",
    b"SECTION",
    b"ENDSEC",
    b"EOF",
    b"ENTITIES",
    b"HEADER",
    b"BLOCK",
    b"ENDBLK",
    b"TABLE",
    b"LAYER",
    b"HATCH",
    b"SPLINE",
    b"ELLIPSE",
    b"3DFACE",
    b"line",
    b"",
]


def mutate_dxf(rng: random.Random, data: bytes, others: list[bytes]) -> bytes:
    """One change to a DXF file's (group code, value) pairs: a value, a code, a pair, an entity."""
    lines = data.split(b"\n")
    pairs = len(lines) // 2
    if pairs < 2:
        return mutate_bytes(rng, data, others)
    k = rng.randrange(pairs)
    op = rng.randrange(9)
    if op <= 2:  # a value: a neighbouring number or an interesting token
        value = lines[2 * k + 1].strip()
        lines[2 * k + 1] = tweak_number(rng, value) if op < 2 else token(rng)
    elif op == 3:
        lines[2 * k] = rng.choice(DXF_CODES)
    elif op == 4:  # a pair deleted or repeated
        if rng.random() < 0.5:
            del lines[2 * k : 2 * k + 2]
        else:
            lines[2 * k : 2 * k] = lines[2 * k : 2 * k + 2] * rng.choice((1, 2, 1000))
    elif op == 5:  # an entity (from one code 0 to the next) repeated, or deleted
        starts = [2 * j for j in range(pairs) if lines[2 * j].strip() == b"0"]
        if len(starts) >= 2:
            i = rng.randrange(len(starts) - 1)
            a, b = starts[i], starts[i + 1]
            if rng.random() < 0.6:
                lines[a:a] = lines[a:b] * rng.choice((1, 2, 100, 3000))
            else:
                del lines[a:b]
    elif op == 6:  # an entity's or section's name changed
        names = [2 * j + 1 for j in range(pairs) if lines[2 * j].strip() in (b"0", b"2")]
        if names:
            lines[rng.choice(names)] = rng.choice(DXF_NAMES)
    elif op == 7:  # a header variable or geometry value that the reader uses
        wanted = rng.choice([b"$INSUNITS", b"42", b"40", b"50", b"51", b"70", b"90", b"230", b"10"])
        spots = [2 * j for j in range(pairs) if lines[2 * j + 1].strip() == wanted or lines[2 * j].strip() == wanted]
        if spots:
            at = rng.choice(spots)
            target = at + 3 if wanted.startswith(b"$") else at + 1
            if target < len(lines):
                lines[target] = rng.choice(
                    [
                        b"-1",
                        b"0",
                        b"25",
                        b"1e300",
                        b"nan",
                        b"1e-15",
                        b"1e15",
                        b"-1e15",
                        b"1e17",
                        b"360",
                        b"-720",
                        b"1",
                        b"4",
                        b"2147483648",
                        tweak_number(rng, lines[target].strip()),
                    ]
                )
    else:  # cut at a pair boundary
        del lines[2 * k :]
    return capped(b"\n".join(lines))


# ---------------------------------------------------------------------------------------------
# Image mutations: header fields of PGM, PNG and BMP
# ---------------------------------------------------------------------------------------------


def png_chunks(data: bytes) -> list[tuple[bytes, bytes]] | None:
    """(type, data) of each chunk of a PNG, None when it is not one."""
    if not data.startswith(b"\x89PNG\r\n\x1a\n"):
        return None
    chunks, at = [], 8
    while at + 8 <= len(data):
        (length,) = struct.unpack(">I", data[at : at + 4])
        kind = data[at + 4 : at + 8]
        chunks.append((kind, data[at + 8 : at + 8 + length]))
        at += 12 + length
    return chunks


def png_bytes(chunks: list[tuple[bytes, bytes]]) -> bytes:
    """A PNG from its chunks, every checksum right."""
    out = [b"\x89PNG\r\n\x1a\n"]
    for kind, body in chunks:
        out.append(struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body)))
    return b"".join(out)


def mutate_image(rng: random.Random, data: bytes, others: list[bytes]) -> bytes:
    """One change to an image's header fields or content, keeping PNG checksums right."""
    chunks = png_chunks(data)
    if chunks:
        k = rng.randrange(len(chunks))
        kind, body = chunks[k]
        op = rng.randrange(6)
        if op == 0 and kind == b"IHDR" and len(body) == 13:  # width, height, depth, colour type, interlace
            fields = list(struct.unpack(">IIBBBBB", body))
            j = rng.randrange(7)
            fields[j] = (
                rng.choice([0, 1, 2, 3, 4, 6, 8, 16, 255, 14000, 65535, 2**31 - 1, 2**32 - 1])
                if j < 2
                else rng.choice([0, 1, 2, 3, 4, 6, 7, 8, 16, 255])
            )
            chunks[k] = (kind, struct.pack(">IIBBBBB", *fields))
        elif op == 1 and kind == b"IDAT":  # compressed pixels changed (decompressing, editing, recompressing)
            try:
                pixels = bytearray(zlib.decompress(body))
                for _ in range(rng.choice((1, 8, 64))):
                    if pixels:
                        pixels[rng.randrange(len(pixels))] = rng.randrange(256)
                if rng.random() < 0.3:
                    pixels = pixels[: rng.randrange(len(pixels) + 1)]
                chunks[k] = (kind, zlib.compress(bytes(pixels)))
            except zlib.error:
                chunks[k] = (kind, mutate_bytes(rng, body, []))
        elif op == 2:  # a chunk's body mutated
            chunks[k] = (kind, mutate_bytes(rng, body, []))
        elif op == 3:  # a chunk dropped or repeated
            if rng.random() < 0.5:
                del chunks[k]
            else:
                chunks[k:k] = [chunks[k]] * rng.choice((1, 2, 50))
        elif op == 4:  # an ancillary chunk added: a palette, a huge text, a gamma, transparency
            extra = rng.choice(
                [
                    (b"PLTE", bytes(range(256)) * 3),
                    (b"tEXt", b"k\x00" + b"v" * 100_000),
                    (b"gAMA", b"\x00\x00\x00\x00"),
                    (b"tRNS", b"\x00" * 256),
                    (b"zTXt", b"k\x00\x00" + zlib.compress(b"z" * 10_000_000)),
                ]
            )
            chunks.insert(rng.randrange(1, len(chunks) + 1), extra)
        else:
            return mutate_bytes(rng, data, others)
        return png_bytes(chunks)
    if data[:1] == b"P" and data[1:2] in b"123456":
        match = re.match(rb"(P[1-6])(\s+(?:#[^\n]*\n\s*)*)(\d+)(\s+)(\d+)(\s+)(\d+)?(\s)?", data)
        if match and rng.random() < 0.7:
            parts = [match.group(i) or b"" for i in range(1, 9)]
            j = rng.choice((0, 2, 4, 6))
            if j == 0:
                parts[0] = rng.choice([b"P1", b"P2", b"P3", b"P4", b"P5", b"P6", b"P7", b"P0"])
            else:
                parts[j] = rng.choice(
                    [
                        b"0",
                        b"1",
                        b"2",
                        b"255",
                        b"256",
                        b"65535",
                        b"65536",
                        b"14000",
                        b"99999999",
                        b"-1",
                        b"4294967297",
                        tweak_number(rng, parts[j]),
                    ]
                )
            return b"".join(parts) + data[match.end() :]
    if data[:2] == b"BM" and len(data) >= 54:
        out = bytearray(data)
        field = rng.choice(
            [
                (2, "<I"),
                (10, "<I"),
                (14, "<I"),
                (18, "<i"),
                (22, "<i"),
                (26, "<H"),
                (28, "<H"),
                (30, "<I"),
                (34, "<I"),
                (46, "<I"),
            ]
        )
        value = rng.choice([0, 1, 8, 24, 32, 2, 3, 14000, -14000, 2**31 - 1, -(2**31), 65535])
        try:
            struct.pack_into(field[1], out, field[0], value)
        except struct.error:
            struct.pack_into(field[1], out, field[0], 1)
        return bytes(out)
    return mutate_bytes(rng, data, others)


# ---------------------------------------------------------------------------------------------
# .npz mutations (plan cache entries)
# ---------------------------------------------------------------------------------------------


def npz_bytes(members: list[tuple[str, bytes]], method: int = zipfile.ZIP_STORED) -> bytes:
    """A zip archive of `members` with fixed time stamps (so a case's bytes depend on its seed only)."""
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", method) as archive:
        for name, body in members:
            archive.writestr(zipfile.ZipInfo(name, (2000, 1, 1, 0, 0, 0)), body, compress_type=method)
    return buffer.getvalue()


def mutate_npy(rng: random.Random, body: bytes) -> bytes:
    """One change to an .npy file: its header's shape, dtype or order, its version, or its data."""
    match = re.match(rb"(\x93NUMPY)(..)(..)(\{.*?\})(\s*\n)", body, re.S)
    if not match or rng.random() < 0.2:
        return mutate_bytes(rng, body, [])
    header = match.group(4)
    op = rng.randrange(5)
    if op == 0:
        shape = rng.choice(
            [
                b"()",
                b"(0,)",
                b"(-1,)",
                b"(3,)",
                b"(300000000,)",
                b"(100000, 100000)",
                b"(2, 3, 4)",
                b"(9223372036854775807,)",
                b"(1.5,)",
                b"('a',)",
                b"(1, -1)",
                b"(65536, 65536, 2)",
            ]
        )
        header = re.sub(rb"'shape': \([^)]*\)", b"'shape': " + shape, header)
    elif op == 1:
        descr = rng.choice(
            [
                b"'|O'",
                b"'<U10'",
                b"'|b1'",
                b"'>f8'",
                b"'<f4'",
                b"'V8'",
                b"'<i8'",
                b"'|u1'",
                b"'<c16'",
                b"'S0'",
                b"[('a', '<f8')]",
                b"'<M8[s]'",
                b"'xyz'",
                b"'<f8",
                b"1",
            ]
        )
        header = re.sub(rb"'descr': '[^']*'", b"'descr': " + descr, header)
    elif op == 2:
        header = header.replace(b"False", b"True") if b"False" in header else header.replace(b"True", b"False")
    elif op == 3:
        header = mutate_bytes(rng, header, [])
    else:
        data = bytearray(body[match.end() :])
        for _ in range(rng.choice((1, 8))):
            if data:
                data[rng.randrange(len(data))] = rng.randrange(256)
        return body[: match.end()] + bytes(data[: rng.randrange(len(data) + 1)] if rng.random() < 0.2 else data)
    pad = 64 - (10 + len(header) + 1) % 64
    version = match.group(2) if rng.random() < 0.9 else rng.choice([b"\x02\x00", b"\x03\x00", b"\x09\x00"])
    size = len(header) + pad + 1
    if version == b"\x01\x00" and size > 0xFFFF:
        version = b"\x02\x00"
    length = struct.pack("<H", size) if version == b"\x01\x00" else struct.pack("<I", size)
    return match.group(1) + version + length + header + b" " * pad + b"\n" + body[match.end() :]


def mutate_npz(rng: random.Random, data: bytes, others: list[bytes]) -> bytes:
    """One change to an .npz: a member's .npy (in a rebuilt archive, so checksums are right), the
    members, the compression, or the archive's bytes."""
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as archive:
            members = [(info.filename, archive.read(info)) for info in archive.infolist()]
    except (zipfile.BadZipFile, OSError, EOFError, zlib.error, NotImplementedError, ValueError, KeyError):
        return mutate_bytes(rng, data, others)
    if not members or rng.random() < 0.25:
        return mutate_bytes(rng, data, others)
    k = rng.randrange(len(members))
    name, body = members[k]
    op = rng.randrange(5)
    if op <= 1:
        members[k] = (name, mutate_npy(rng, body))
    elif op == 2:
        if rng.random() < 0.5:
            del members[k]
        else:
            members.append((rng.choice(["extra.npy", name, "points", "../x.npy"]), body))
    elif op == 3:
        members[k] = (rng.choice(["points.npy", "walls.npy", "_checksum.npy", "shape.npy", "x.npy"]), body)
    else:
        return npz_bytes(members, zipfile.ZIP_DEFLATED)
    return npz_bytes(members)


# ---------------------------------------------------------------------------------------------
# Seeds
# ---------------------------------------------------------------------------------------------


def small_map_image() -> Any:
    """A 120 x 140 px crop of tests/data/tb3_sandbox.pgm (real SLAM map content: walls, free space
    and unknown), as a uint8 array."""
    import cv2

    image: Any = cv2.imread(str(DATA / "tb3_sandbox.pgm"), cv2.IMREAD_UNCHANGED)
    return image[130:250, 120:260].copy()


def encoded(image: Any, ext: str, params: list[int] | None = None) -> bytes:
    import cv2

    ok, buffer = cv2.imencode(ext, image, params or [])
    assert ok, ext
    return bytes(buffer.tobytes())


def map_yaml(image: str, **changes: Any) -> bytes:
    values: dict[str, Any] = {
        "image": image,
        "mode": "trinary",
        "resolution": 0.05,
        "origin": [-10.0, -10.0, 0.0],
        "negate": 0,
        "occupied_thresh": 0.65,
        "free_thresh": 0.196,
    }
    values.update(changes)
    lines = [f"{k}: {json.dumps(v)}" if not isinstance(v, str) else f"{k}: {v}" for k, v in values.items()]
    return ("\n".join(lines) + "\n").encode()


def image_files() -> list[tuple[str, bytes]]:
    """(extension, bytes) of small plan images in the formats plans come in."""
    import cv2

    grey = small_map_image()
    colour = cv2.cvtColor(grey, cv2.COLOR_GRAY2BGRA)
    colour[:10, :, 3] = 0
    office = (HERE.parent / "python" / "planicp" / "data" / "office_plan.png").read_bytes()
    return [
        (".pgm", encoded(grey, ".pgm")),
        (".pgm", encoded(grey[:40, :60], ".pgm", [cv2.IMWRITE_PXM_BINARY, 0])),
        (".png", encoded(grey, ".png")),
        (".png", encoded(colour, ".png")),
        (".png", encoded((grey.astype("uint16") * 257), ".png")),
        (".bmp", encoded(grey, ".bmp")),
        (".jpg", encoded(grey, ".jpg")),
        (".tif", encoded(grey, ".tif")),
        (".png", office),
    ]


def ros_map_yaml_seeds() -> list[Seed]:
    import numpy as np

    grey = small_map_image()
    pgm = encoded(grey, ".pgm")
    raw = np.where(grey < 50, 100, np.where(grey > 250, 0, 255)).astype(np.uint8)  # mode raw: occupancy 0..100
    yamls = {
        "trinary": map_yaml("map.pgm"),
        "scale-negate": map_yaml("map.pgm", mode="scale", negate=1, origin=[1.5, -2.0, 0.3]),
        "raw": map_yaml("raw.pgm", mode="raw", occupied_thresh=0.2, free_thresh=0.1),
        "edge-detector": map_yaml("map.pgm", planicp_edge_detector="auto", resolution=0.1),
        "tb3": (DATA / "tb3_sandbox.yaml").read_bytes().replace(b"tb3_sandbox.pgm", b"map.pgm"),
        "office": (HERE.parent / "python" / "planicp" / "data" / "office_plan.yaml")
        .read_bytes()
        .replace(b"office_plan.png", b"map.pgm"),
    }
    images = {"map.pgm": pgm, "raw.pgm": encoded(raw, ".pgm")}
    return [Seed(name, {"map.yaml": text, **images}, "map.yaml") for name, text in yamls.items()]


def ros_map_image_seeds() -> list[Seed]:
    seeds = []
    for k, (ext, body) in enumerate(image_files()):
        seeds.append(Seed(f"{ext[1:]}-{k}", {"map.yaml": map_yaml(f"map{ext}"), f"map{ext}": body}, f"map{ext}"))
    return seeds


def plan_image_seeds() -> list[Seed]:
    return [Seed(f"{ext[1:]}-{k}", {f"plan{ext}": body}, f"plan{ext}") for k, (ext, body) in enumerate(image_files())]


def house_expo_seeds() -> list[Seed]:
    real = (DATA / "house_expo_room_0000.json").read_bytes()
    square = json.dumps({"verts": [[0, 0], [6, 0], [6, 4], [0, 4]], "bbox": {"min": [0, 0], "max": [6, 4]}}).encode()
    closed = json.dumps(
        {
            "id": "x",
            "room_num": 2,
            "verts": [[1.0, 1.0], [9.5, 1.0], [9.5, 7.25], [5, 7.25], [5, 4], [1.0, 4.0], [1.0, 1.0]],
            "bbox": {"min": [1.0, 1.0], "max": [9.5, 7.25]},
            "room_category": {"bedroom": [[1, 1, 5, 4]]},
        },
        indent=1,
    ).encode()
    return [
        Seed("room_0000", {"plan.json": real}, "plan.json"),
        Seed("square", {"plan.json": square}, "plan.json"),
        Seed("closed", {"plan.json": closed}, "plan.json"),
    ]


R12_DXF = """0
SECTION
2
HEADER
9
$ACADVER
1
AC1009
9
$INSUNITS
70
6
0
ENDSEC
0
SECTION
2
ENTITIES
0
LINE
8
WALLS
10
0.0
20
0.0
30
0.0
11
8.0
21
0.0
31
0.0
0
ARC
8
WALLS
10
8.0
20
3.0
30
0.0
40
3.0
50
270.0
51
90.0
0
CIRCLE
8
COLUMNS
10
4.0
20
3.0
30
0.0
40
0.25
0
POLYLINE
8
WALLS
66
1
70
1
10
0.0
20
0.0
30
0.0
0
VERTEX
8
WALLS
10
0.0
20
6.0
30
0.0
42
0.0
0
VERTEX
8
WALLS
10
8.0
20
6.0
30
0.0
42
0.5
0
VERTEX
8
WALLS
10
0.0
20
0.0
30
0.0
0
SEQEND
8
WALLS
0
ENDSEC
0
EOF
"""


DXF_MAX_BYTES = 256 * 1024
"""Largest mutated DXF file: ezdxf's recovery reads about 0.2 MB a second here (a 4 MB case took
11 s, as a real drawing of that size does: no hostile input), so DXF cases stay at 256 KiB."""


def dxf_seeds() -> list[Seed]:
    import ezdxf.document
    from ezdxf import options  # type: ignore[attr-defined]

    options.write_fixed_meta_data_for_testing = True  # no time stamps or GUIDs: a case depends on its seed only
    seeds = [Seed("r12-hand", {"plan.dxf": R12_DXF.encode()}, "plan.dxf")]
    for version, units in (("R2010", 4), ("R2000", 6)):
        doc = ezdxf.document.Drawing.new(version)
        doc.header["$INSUNITS"] = units
        scale = 1000.0 if units == 4 else 1.0
        doc.layers.add("WALLS")
        msp = doc.modelspace()
        msp.add_lwpolyline(
            [(0, 0, 0, 0, 0.0), (8 * scale, 0, 0, 0, 0.4), (8 * scale, 5 * scale), (0, 5 * scale)],
            format="xyseb",
            close=True,
            dxfattribs={"layer": "WALLS"},
        )
        msp.add_line((2 * scale, 0), (2 * scale, 3 * scale), dxfattribs={"layer": "WALLS"})
        msp.add_arc(
            (4 * scale, 2.5 * scale), 1 * scale, 30, 300, dxfattribs={"layer": "WALLS", "extrusion": (0, 0, -1)}
        )
        msp.add_circle((6 * scale, 2.5 * scale), 0.3 * scale, dxfattribs={"layer": "COLUMNS"})
        msp.add_polyline2d(
            [(1 * scale, 1 * scale), (3 * scale, 1 * scale), (3 * scale, 2 * scale)], dxfattribs={"layer": "WALLS"}
        )
        msp.add_text("Room 1", dxfattribs={"layer": "TEXT"})
        block = doc.blocks.new("DOOR")
        block.add_line((0, 0), (1 * scale, 0))
        msp.add_blockref("DOOR", (5 * scale, 0))
        stream = io.StringIO()
        doc.write(stream)
        seeds.append(Seed(version, {"plan.dxf": stream.getvalue().replace("\r\n", "\n").encode()}, "plan.dxf"))
    return seeds


def carmen_seeds() -> list[Seed]:
    import carmen_excerpt as ex

    excerpt = ("\n".join(ex.log_lines()[:24]) + "\n").encode()
    robotlaser = (
        "\n".join(
            [
                "# ROBOTLASER1 log with remissions",
                "PARAM robot_frontlaser_offset 0.1 nohost 0",
                "ODOM 0.0 0.0 0.0 0 0 0 1.0 nohost 1.0",
                "ROBOTLASER1 0 -1.570796 3.141593 0.5236 50.0 0.1 0 7 1.0 1.1 1.2 1.3 1.2 1.1 1.0 2 0.5 0.5 "
                "0.1 0.0 0.0 0.0 0.0 0.0 0.3 0.1 0.5 0.5 0.5 1.05 nohost 1.05",
                "ODOM 0.1 0.0 0.01 0 0 0 1.1 nohost 1.1",
                "ROBOTLASER1 0 -1.570796 3.141593 0.5236 50.0 0.1 0 7 1.0 1.1 1.2 81.9 1.2 1.1 -1 0 "
                "0.2 0.0 0.01 0.1 0.0 0.01 0.3 0.1 0.5 0.5 0.5 1.15 nohost 1.15",
                "ODOM 0.2 0.0 0.02 0 0 0 1.2 nohost 1.2",
            ]
        ).encode()
        + b"\n"
    )
    two_lasers = (
        "\n".join(
            [
                "PARAM robot_front_laser_max 30.0",
                "PARAM robot_rearlaser_offset -0.2 nohost 0",
                "FLASER 5 1.0 2.0 3.0 40.0 0.0 1.0 2.0 0.5 1.0 2.0 0.5 2.0 nohost 2.0",
                "RLASER 5 1.0 2.0 3.0 4.0 5.0 1.0 2.0 0.5 1.0 2.0 0.5 2.0 nohost 2.0",
                "FLASER 5 1.0 2.0 3.0 4.0 5.0 1.1 2.0 0.5 1.1 2.0 0.5 2.1 nohost 2.1",
                "TRUEPOS 1 2 3 1 2 3 2.1 nohost 2.1",
            ]
        ).encode()
        + b"\n"
    )
    return [
        Seed("excerpt", {"robot.log": excerpt}, "robot.log"),
        Seed("excerpt-gz", {"robot.log": gzip.compress(excerpt, mtime=0)}, "robot.log"),
        Seed("robotlaser1", {"robot.log": robotlaser}, "robot.log"),
        Seed("two-lasers", {"robot.log": two_lasers}, "robot.log"),
    ]


def g2o_seeds() -> list[Seed]:
    lines = (DATA / "killian-excerpt.g2o").read_bytes().split(b"\n")
    vertices = lines[:6]  # three vertices, each with its scan
    edges = [line for line in lines if line.startswith((b"EDGE_SE2 0 1", b"EDGE_SE2 1 2"))]
    excerpt = b"\n".join(vertices + [b"#SEQUENTIAL EDGES"] + edges) + b"\n"
    tiny = (
        "\n".join(
            [
                "VERTEX_SE2 0 0.0 0.0 0.0",
                "ROBOTLASER1 0 -1.570796 3.141593 0.785398 50.0 0.1 0 5 1.0 1.1 1.2 1.1 1.0 0 0.2 0.0 0.0 0.0 0.0 0.0 "
                "0 0 0.5 0.5 0.5 10.0 nohost 10.0",
                "VERTEX_SE2 1 0.5 0.0 0.1",
                "ROBOTLASER1 0 -1.570796 3.141593 0.785398 50.0 0.1 0 5 1.0 1.1 51.0 1.1 1.0 0 0.7 0.0 0.1 0.5 0.0 0.1 "
                "0 0 0.5 0.5 0.5 10.2 nohost 10.2",
                "EDGE_SE2 0 1 0.5 0.0 0.1 500.0 0.0 0.0 500.0 0.0 2000.0",
            ]
        ).encode()
        + b"\n"
    )
    zipped = compressed(random.Random(0), excerpt, "zip")
    return [
        Seed("killian", {"graph.g2o": excerpt}, "graph.g2o"),
        Seed("tiny", {"graph.g2o": tiny}, "graph.g2o"),
        Seed("killian-zip", {"graph.g2o": zipped}, "graph.g2o"),
    ]


STUDY_DOC_EXAMPLE = """name: clutter-and-drift
duration_s: 40              # simulated seconds per run
plans:
  - default                 # the office plan that ships with planicp
  - path: plans/house.json
  - path: maps/floor.yaml
  - {path: scans/hall.png, resolution: 0.05, origin: [0, 0, 0]}
seeds: [0, 1, 2]
furniture: [0, 1, 2]
people: [0, 2]
sensors:
  utm30: {}
  budget: {fov_deg: 240, beams: 240, range_max: 8, range_sigma: 0.03}
odometry:
  thesis: {}
  double-drift: {translation_per_message: 1.0e-4, rotation_per_message: 1e-4}
icp:
  tracking: {}
  no-trim: {auto_trim: false}
success:
  max_position_error_m: 0.3
"""


def study_seeds() -> list[Seed]:
    rich = """name: rich
duration_s: 12.5
plans:
  - default
  - {path: room.json, resolution: 0.1}
  - {path: hall.png, resolution: 0.05, origin: [1.0, -2.0, 0.5]}
seeds: {start: 100, count: 4}
furniture: [0.0, 1.5]
people: 2
sensors:
  narrow: {fov_deg: 180, beams: 181, range_min: 0.1, range_max: 20, range_sigma: 0.01, dropout: 0.05,
           rate_hz: 10, mount: [0.2, 0.0, 0.0]}
odometry:
  noisy: {translation_fraction: 0.05, rotation_fraction: 0.05, rotation_sigma_min: 1e-4, rate_hz: 50}
icp:
  scheduled: {correspondence_schedule: [1.0, 0.5, 0.25]}
success:
  max_position_error_m: 0.5
  allow_lost_at_end: true
"""
    return [
        Seed("doc-example", {"study.yaml": STUDY_DOC_EXAMPLE.encode()}, "study.yaml"),
        Seed("rich", {"study.yaml": rich.encode()}, "study.yaml"),
        Seed("minimal", {"study.yaml": b"name: m\nplans: [default]\n"}, "study.yaml"),
    ]


CACHE_IMAGE = "plan.png"
CACHE_RESOLUTION = 0.05


def cache_seeds() -> list[Seed]:
    """A real cache entry of a small plan image, rewritten with fixed zip time stamps."""
    import numpy as np

    from planicp import PlanMap

    image = encoded(small_map_image(), ".png")
    with tempfile.TemporaryDirectory() as folder:
        (Path(folder) / CACHE_IMAGE).write_bytes(image)
        PlanMap.from_image(Path(folder) / CACHE_IMAGE, CACHE_RESOLUTION, walls="all-dark", cache=Path(folder) / "cache")
        (entry,) = (Path(folder) / "cache").glob("*.npz")
        members = []
        with np.load(entry) as data:
            for name in data.files:
                buffer = io.BytesIO()
                np.lib.format.write_array(buffer, data[name], allow_pickle=False)
                members.append((f"{name}.npy", buffer.getvalue()))
    name = f"cache/{entry.name}"
    return [Seed("entry", {CACHE_IMAGE: image, name: npz_bytes(members)}, name)]


# ---------------------------------------------------------------------------------------------
# What each target calls, and what a good result is
# ---------------------------------------------------------------------------------------------


def check_plan(plan: Any) -> None:
    import numpy as np

    points = plan.points
    if len(plan) == 0 or points.ndim != 2 or points.shape[1] != 2 or not np.isfinite(points).all():
        raise WrongResult(f"a plan of {len(plan)} points, shape {points.shape}, not all finite")


def run_ros_map(folder: Path, seed: Seed, index: int) -> None:
    from planicp import PlanMap

    check_plan(PlanMap.from_ros_map(folder / "map.yaml", cache=False))


WALLS = "all-dark"
"""How the cache fuzz reads its image, a map: every dark pixel a wall."""


def run_plan_image(folder: Path, seed: Seed, index: int) -> None:
    from planicp import PlanMap

    # The seeds are maps (every dark pixel a wall) and the office plan; every other case is read as
    # a drawing, whose extraction may find no walls in a map (a ValueError naming the file).
    walls = "drawing" if index % 2 else "all-dark"  # the seeds' start-up reading (index 0): all-dark
    check_plan(PlanMap.from_image(folder / seed.target, 0.05, walls=walls, cache=False))


def run_house_expo(folder: Path, seed: Seed, index: int) -> None:
    from planicp import PlanMap

    if index % 2:
        check_plan(PlanMap.from_house_expo(folder / "plan.json", resolution=0.1))
    else:
        check_plan(PlanMap.from_house_expo(folder / "plan.json"))


def run_dxf(folder: Path, seed: Seed, index: int) -> None:
    from planicp import PlanMap

    check_plan(PlanMap.from_dxf(folder / "plan.dxf", layers=["walls"] if index % 3 == 2 else None))


def check_log(log: Any) -> None:
    import numpy as np

    if len(log) == 0:
        raise WrongResult("a log of no scans")
    times = log.times()
    if not np.isfinite(times).all():
        raise WrongResult("scan times not all finite")
    for frame in log.frames[:3]:
        frame.points()
    if log.has_reference:
        log.reference_poses()
    if log.has_odometry:
        log.odometry_at_scans()


def run_carmen(folder: Path, seed: Seed, index: int) -> None:
    from planicp.io import read_carmen

    check_log(read_carmen(folder / "robot.log", errors="raise" if index % 4 == 3 else "skip"))


def run_g2o(folder: Path, seed: Seed, index: int) -> None:
    from planicp.io import read_g2o, read_g2o_graph

    errors: Literal["skip", "raise"] = "raise" if index % 4 == 3 else "skip"
    if index % 2:
        graph = read_g2o_graph(folder / "graph.g2o", errors=errors)
        if len(graph.vertex_ids) == 0 or graph.poses.shape != (len(graph.vertex_ids), 3):
            raise WrongResult(f"a graph of {len(graph.vertex_ids)} vertices, poses {graph.poses.shape}")
    else:
        log = read_g2o(folder / "graph.g2o", errors=errors)
        if len(log):
            check_log(log)


def run_study(folder: Path, seed: Seed, index: int) -> None:
    import yaml

    from planicp.sweep import Study, load_study

    study, _ = load_study(folder / "study.yaml")
    if (folder / "study.yaml").stat().st_size > 32 * 1024:  # to_yaml() is pure Python: seconds for a large study
        return
    again = Study.from_dict(yaml.load(study.to_yaml(), Loader=getattr(yaml, "CSafeLoader", yaml.SafeLoader)))
    if again != study:
        raise WrongResult("the study does not read back from its own to_yaml()")


_CACHE_EXPECTED: list[Any] = []


def run_cache(folder: Path, seed: Seed, index: int) -> None:
    import numpy as np

    from planicp import PlanMap

    if not _CACHE_EXPECTED:
        _CACHE_EXPECTED.append(
            PlanMap.from_image(folder / CACHE_IMAGE, CACHE_RESOLUTION, walls=WALLS, cache=False).points
        )
    plan = PlanMap.from_image(folder / CACHE_IMAGE, CACHE_RESOLUTION, walls=WALLS, cache=folder / "cache")
    if not np.array_equal(plan.points, _CACHE_EXPECTED[0]):
        raise WrongResult(f"the plan differs from the uncached one (from_cache={plan.from_cache})")


def run_control(folder: Path, seed: Seed, index: int) -> None:
    """The harness's own check (target "_control"): case 0 reads, 1 raises an undocumented KeyError,
    2 crashes the worker (SIGSEGV), 3 never returns, 4 takes 300 MiB."""
    kind = index % 5
    if kind == 1:
        raise KeyError("an undocumented exception")
    if kind == 2:
        import ctypes

        ctypes.string_at(0)  # reads address 0: SIGSEGV
    if kind == 3:
        while True:
            time.sleep(0.01)
    if kind == 4:
        block = bytearray(300 << 20)
        block[::4096] = b"x" * len(block[::4096])  # touched, so resident


def _study_error() -> type[BaseException]:
    from planicp.sweep import StudyError

    return StudyError


def targets() -> dict[str, Target]:
    """Every target by name."""
    io_errors = (ValueError, FileNotFoundError)
    return {
        t.name: t
        for t in [
            Target(
                "ros_map_yaml",
                "PlanMap.from_ros_map (map YAML mutated)",
                io_errors,
                ros_map_yaml_seeds,
                mutate_yaml,
                run_ros_map,
                lambda s: "map.yaml",
            ),
            Target(
                "ros_map_image",
                "PlanMap.from_ros_map (map image mutated)",
                io_errors,
                ros_map_image_seeds,
                mutate_image,
                run_ros_map,
                lambda s: "map.yaml",
            ),
            Target(
                "plan_image",
                "PlanMap.from_image (walls='all-dark' every other case)",
                io_errors,
                plan_image_seeds,
                mutate_image,
                run_plan_image,
                lambda s: s.target,
            ),
            Target(
                "house_expo",
                "PlanMap.from_house_expo (points; resolution=0.1 every other case)",
                io_errors,
                house_expo_seeds,
                mutate_json,
                run_house_expo,
                lambda s: "plan.json",
            ),
            Target(
                "dxf",
                "PlanMap.from_dxf (all layers; layers=['walls'] every third case)",
                io_errors,
                dxf_seeds,
                mutate_dxf,
                run_dxf,
                lambda s: "plan.dxf",
                DXF_MAX_BYTES,
            ),
            Target(
                "carmen",
                "io.read_carmen (errors='raise' every fourth case)",
                io_errors,
                carmen_seeds,
                lambda rng, data, others: mutate_records(rng, data, [b"FLASER", b"RLASER", b"ROBOTLASER1", b"ODOM"]),
                run_carmen,
                lambda s: "robot.log",
            ),
            Target(
                "g2o",
                "io.read_g2o / read_g2o_graph (errors='raise' every fourth case)",
                io_errors,
                g2o_seeds,
                lambda rng, data, others: mutate_records(rng, data, [b"VERTEX_SE2", b"EDGE_SE2", b"ROBOTLASER1"]),
                run_g2o,
                lambda s: "graph.g2o",
            ),
            Target(
                "study",
                "sweep.load_study (and its to_yaml round trip)",
                (_study_error(),),
                study_seeds,
                mutate_yaml,
                run_study,
                lambda s: "study.yaml",
            ),
            Target(
                "plan_cache",
                "PlanMap.from_image with a mutated cache entry (.npz): rebuilt, never an error",
                (),
                cache_seeds,
                mutate_npz,
                run_cache,
                lambda s: s.target,
            ),
            Target(
                "_control",
                "the harness's check: a reader that breaks the contract on purpose",
                (ValueError,),
                lambda: [Seed("x", {"x.txt": b"x"}, "x.txt")],
                lambda rng, data, others: data,
                run_control,
                lambda s: "x.txt",
            ),
        ]
    }


READERS = ["ros_map_yaml", "ros_map_image", "plan_image", "house_expo", "dxf", "carmen", "g2o", "study", "plan_cache"]
"""The targets fuzzed by default (every file reader; "_control" is the harness's self-check)."""


# ---------------------------------------------------------------------------------------------
# Cases
# ---------------------------------------------------------------------------------------------


def make_case(target: Target, seeds: list[Seed], seed: int, index: int) -> tuple[Seed, Files]:
    """The seed case `index` starts from and its mutated files: a function of (target, seed, index)."""
    rng = random.Random(f"{target.name}/{seed}/{index}")
    base = rng.choice(seeds)
    data = base.files[base.target]
    others = [s.files[s.target] for s in seeds]
    mix = rng.random()  # the format-aware mutators alone, the generic ones alone, or both
    aware = 1.0 if mix < 0.45 else 0.0 if mix < 0.75 else 0.5
    for _ in range(rng.choice((1, 1, 1, 1, 2, 2, 3, 5))):
        data = target.mutate(rng, data, others) if rng.random() < aware else mutate_bytes(rng, data, others)
        data = data[: target.max_bytes]
    files = dict(base.files)
    files[base.target] = data
    return base, files


def write_files(folder: Path, files: Files) -> None:
    if folder.exists():
        shutil.rmtree(folder)
    for name, body in files.items():
        path = folder / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(body)


def outcome_class(exc: BaseException, folder: Path) -> str:
    """The exception's type and its message with paths, quoted text and numbers blanked out."""
    text = str(exc).replace(str(folder), "<dir>")
    text = re.sub(r"'[^']*'|\"[^\"]*\"", "'~'", text)
    text = re.sub(r"0x[0-9a-f]+|[-+]?\d[\d.e+-]*", "N", text)
    return f"{type(exc).__name__}: {text[:72]}"


def contract_breach(target: Target, seed: Seed, exc: BaseException | None, caught: list[str]) -> str | None:
    """What about a case's outcome breaks the contract (see the module doc), None when nothing."""
    for message in caught:
        if len(message) > MAX_MESSAGE_CHARS:
            return f"a warning of {len(message)} characters: {message[:200]}..."
    if exc is None:
        return None
    if isinstance(exc, CaseTimeout):
        return f"no result after {CASE_SECONDS} s"
    if isinstance(exc, WrongResult):
        return f"wrong result: {exc}"
    if not isinstance(exc, target.documented):
        return f"undocumented {type(exc).__module__}.{type(exc).__qualname__}: {str(exc)[:300]}"
    message = str(exc)
    if not message.strip():
        return f"{type(exc).__name__} with an empty message"
    if len(message) > MAX_MESSAGE_CHARS:
        return f"{type(exc).__name__} message of {len(message)} characters: {message[:200]}..."
    if "\n" in message:
        return f"{type(exc).__name__} message of several lines: {message[:300]!r}"
    if target.entry(seed) not in message:
        return f"{type(exc).__name__} message does not name {target.entry(seed)}: {message[:300]}"
    return None


def replay_command(target: str, seed: int, index: int) -> str:
    return f"python benches/fuzz_readers.py --reader {target} --seed {seed} --replay {index}"


def save_failure(failures: Path, target: str, seed: int, index: int, files: Files, text: str) -> Path:
    folder = failures / f"{target}-s{seed}-c{index}"
    write_files(folder / "input", files)
    (folder / "failure.txt").write_text(f"{text}\n\nreplay: {replay_command(target, seed, index)}\n")
    return folder


def _timeout(signum: int, frame: FrameType | None) -> None:
    raise CaseTimeout()


def run_case(target: Target, seed_entry: Seed, folder: Path, index: int) -> tuple[BaseException | None, list[str], str]:
    """Runs case `index`, whose files are in `folder`: (exception or None, warning texts, traceback)."""
    caught: list[str] = []
    exc: BaseException | None = None
    trace = ""
    signal.setitimer(signal.ITIMER_REAL, CASE_SECONDS)
    try:
        with warnings.catch_warnings(record=True) as records:
            warnings.simplefilter("always")
            try:
                target.run(folder, seed_entry, index)
            finally:
                caught = [str(w.message) for w in records]
    except (Exception, CaseTimeout) as error:
        exc = error
        trace = traceback.format_exc()
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
    return exc, caught, trace


def memory_kib(field: str) -> int:
    """A memory figure of this process from /proc/self/status ("VmRSS", "VmHWM"), KiB; 0 where
    there is no /proc."""
    try:
        with open("/proc/self/status") as status:
            for line in status:
                if line.startswith(field + ":"):
                    return int(line.split()[1])
    except OSError:
        pass
    return 0


def reset_peak() -> bool:
    """Resets this process's peak resident set (VmHWM) to its current one (Linux >= 4.0)."""
    try:
        with open("/proc/self/clear_refs", "w") as clear:
            clear.write("5")
        return True
    except OSError:
        return False


def worker(
    name: str, seed: int, first: int, count: int, failures: Path, work: Path, case_seconds: float = CASE_SECONDS
) -> int:
    """Runs cases first .. first + count - 1 of a target, writing one line per event to stdout:
    `B {json}` after start-up (its resident set), `G i` before case i is made, `S i` before it
    runs (its files are then in `work`/case, where the parent finds them after a crash or hang),
    `D {json}` after it."""
    global CASE_SECONDS
    CASE_SECONDS = case_seconds  # this process is the worker: its one setting
    faulthandler.enable()
    signal.signal(signal.SIGALRM, _timeout)
    scale_budgets()
    target = targets()[name]
    seeds = target.seeds()
    folder = work / "case"
    for entry in seeds:  # every seed must read: a fuzz of a reader that refuses its seeds tests nothing
        write_files(folder, entry.files)
        exc, caught, trace = run_case(target, entry, folder, 0)
        if exc is not None:
            print(f"seed {entry.name} of {name} does not read: {trace}", file=sys.stderr, flush=True)
            return 3
    resource.setrlimit(resource.RLIMIT_AS, (ADDRESS_SPACE_BYTES, ADDRESS_SPACE_BYTES))
    print("B " + json.dumps({"rss": memory_kib("VmRSS") * 1024}), flush=True)
    for index in range(first, first + count):
        print(f"G {index}", flush=True)
        try:
            entry, files = make_case(target, seeds, seed, index)
        except Exception:  # noqa: BLE001 - a harness error: reported as one, and the next case made
            print(
                "D "
                + json.dumps(
                    {
                        "i": index,
                        "class": "HARNESS",
                        "s": 0.0,
                        "mem": 0,
                        "kept": 0,
                        "seed": "",
                        "failure": f"harness: making the case failed: {traceback.format_exc()}",
                    }
                ),
                flush=True,
            )
            continue
        write_files(folder, files)
        print(f"S {index}", flush=True)
        before = memory_kib("VmRSS")
        measured = reset_peak()
        faulthandler.dump_traceback_later(CASE_SECONDS + 2.0)
        started = time.perf_counter()
        exc, caught, trace = run_case(target, entry, folder, index)
        seconds = time.perf_counter() - started
        faulthandler.cancel_dump_traceback_later()
        memory = max(0, memory_kib("VmHWM") - before) * 1024 if measured else 0
        breach = contract_breach(target, entry, exc, caught)
        if breach is None and seconds > CASE_SECONDS:
            breach = f"took {seconds:.1f} s (bound {CASE_SECONDS} s)"
        if breach is None and memory > MAX_CASE_MEMORY_BYTES:
            breach = f"took {memory / 2**20:.0f} MiB of memory (bound {MAX_CASE_MEMORY_BYTES >> 20} MiB)"
        kind = "ok" if exc is None else outcome_class(exc, folder)
        if breach is not None:
            save_failure(failures, name, seed, index, files, f"{breach}\n\n{trace}")
        kept = (memory_kib("VmRSS") - before) * 1024  # what the reader left resident (a leak adds up here)
        print(
            "D "
            + json.dumps(
                {
                    "i": index,
                    "class": kind,
                    "s": seconds,
                    "mem": memory,
                    "kept": kept,
                    "seed": entry.name,
                    "failure": breach,
                }
            ),
            flush=True,
        )
    return 0


# ---------------------------------------------------------------------------------------------
# The parent: workers in subprocesses, crashes and hangs caught
# ---------------------------------------------------------------------------------------------


@dataclasses.dataclass
class Report:
    """What fuzzing one target gave.

    Attributes:
        target: the target's name.
        cases: cases run to an outcome (crashes and hangs included).
        classes: outcome classes ("ok" or the exception type and message shape) and their counts.
        max_case_seconds: the slowest case, seconds, and its index in `slowest`.
        max_case_memory: the most memory a case took (peak resident set during the case above the
            resident set at its start), bytes, and its index in `hungriest`.
        rss_drift: the growth of the worker's resident set over the cases' reader calls, summed
            over the cases, bytes (a leak shows here; what making the cases takes does not).
        failures: (case index, what broke the contract).
        seconds: wall time, seconds.
    """

    target: str
    cases: int = 0
    classes: Counter[str] = dataclasses.field(default_factory=Counter)
    max_case_seconds: float = 0.0
    slowest: int = -1
    max_case_memory: int = 0
    hungriest: int = -1
    rss_drift: int = 0
    failures: list[tuple[int, str]] = dataclasses.field(default_factory=list)
    seconds: float = 0.0


def _lines(stream: Any, out: queue.Queue[str | None]) -> None:
    for line in stream:
        out.put(line.rstrip("\n"))
    out.put(None)


def run_target(
    name: str, cases: int, seed: int, failures: Path, python: str = sys.executable, case_seconds: float = CASE_SECONDS
) -> Report:
    """Fuzzes target `name` for `cases` cases in worker processes (one more after each crash or
    hang), each case bounded to `case_seconds`."""
    report = Report(name)
    started = time.perf_counter()
    next_case = 0
    failures.mkdir(parents=True, exist_ok=True)
    while next_case < cases:
        work = Path(tempfile.mkdtemp(prefix=f"planicp-fuzz-{name}-"))
        log = work / "worker.stderr"
        with open(log, "w") as errors:
            proc = subprocess.Popen(
                [
                    python,
                    str(Path(__file__).resolve()),
                    "--worker",
                    name,
                    "--seed",
                    str(seed),
                    "--first",
                    str(next_case),
                    "--count",
                    str(cases - next_case),
                    "--failures",
                    str(failures),
                    "--work",
                    str(work),
                    "--case-seconds",
                    str(case_seconds),
                ],
                stdout=subprocess.PIPE,
                stderr=errors,
                text=True,
            )
            lines: queue.Queue[str | None] = queue.Queue()
            threading.Thread(target=_lines, args=(proc.stdout, lines), daemon=True).start()
            current, done = -1, next_case
            hung = running = False
            while True:
                try:  # a case runs for CASE_SECONDS at most; start-up and making a case may take longer
                    line = lines.get(timeout=case_seconds + KILL_GRACE_SECONDS if running else 120.0)
                except queue.Empty:
                    hung = True
                    proc.kill()  # this worker only, by its handle
                    proc.wait()
                    break
                if line is None:
                    break
                running = line.startswith("S ")
                if line.startswith(("G ", "S ")):
                    current = int(line[2:])
                elif line.startswith("D "):
                    event = json.loads(line[2:])
                    report.cases += 1
                    report.classes[event["class"]] += 1
                    if event["s"] > report.max_case_seconds:
                        report.max_case_seconds, report.slowest = event["s"], event["i"]
                    if event["mem"] > report.max_case_memory:
                        report.max_case_memory, report.hungriest = event["mem"], event["i"]
                    report.rss_drift += event["kept"]
                    if event["failure"]:
                        report.failures.append((event["i"], event["failure"]))
                    done = event["i"] + 1
            code = proc.wait()
        stderr = log.read_text(errors="replace")[-4000:]
        if done >= cases and not hung:
            shutil.rmtree(work, ignore_errors=True)
            break
        if current < done:  # died before its first case: the seeds or the start-up failed
            report.failures.append((-1, f"worker failed at start-up (exit {code}): {stderr[-2000:]}"))
            shutil.rmtree(work, ignore_errors=True)
            break
        if hung and not running:
            what = f"harness: making case {current} took over 120 s"
        elif hung:
            what = f"hang: killed after {case_seconds + KILL_GRACE_SECONDS:.0f} s"
        else:
            what = f"crash: worker exit {code} ({_signal_name(code)})"
        # The case's files, as the worker wrote them before running it (never made again here: a
        # case can take gigabytes to make, and only the worker runs under a memory limit).
        case = work / "case"
        files = {str(f.relative_to(case)): f.read_bytes() for f in case.rglob("*") if f.is_file()} if running else {}
        save_failure(failures, name, seed, current, files, f"{what}\n\nworker stderr (tail):\n{stderr}")
        shutil.rmtree(work, ignore_errors=True)
        report.failures.append((current, what))
        report.cases += 1
        report.classes["CRASH" if not hung else "HANG"] += 1
        next_case = current + 1
    if report.rss_drift > MAX_RSS_DRIFT_BYTES:
        report.failures.append(
            (
                -1,
                f"the worker's resident set grew by {report.rss_drift / 2**20:.0f} MiB over "
                f"its cases (bound {MAX_RSS_DRIFT_BYTES >> 20} MiB): a leak",
            )
        )
    report.seconds = time.perf_counter() - started
    return report


def _signal_name(code: int) -> str:
    if code < 0:
        try:
            return signal.Signals(-code).name
        except ValueError:
            return f"signal {-code}"
    return "no signal"


def replay(name: str, seed: int, index: int) -> int:
    """Runs one case in this process and prints its outcome (and traceback)."""
    scale_budgets()
    target = targets()[name]
    seeds = target.seeds()
    resource.setrlimit(resource.RLIMIT_AS, (ADDRESS_SPACE_BYTES, ADDRESS_SPACE_BYTES))  # as in the worker
    entry, files = make_case(target, seeds, seed, index)
    with tempfile.TemporaryDirectory() as work:
        folder = Path(work) / "case"
        write_files(folder, files)
        signal.signal(signal.SIGALRM, _timeout)
        exc, caught, trace = run_case(target, entry, folder, index)
        breach = contract_breach(target, entry, exc, caught)
        print(
            f"case {index} of {name} (seed {seed}, from seed file {entry.name}): "
            f"{'ok' if exc is None else outcome_class(exc, folder)}"
        )
        for message in caught:
            print(f"warning: {message[:500]}")
        if trace:
            print(trace)
        print("contract:", breach or "kept")
        return 1 if breach else 0


def format_reports(reports: list[Report]) -> str:
    """A table of the reports."""
    rows = [
        "| reader | cases | outcome classes | read (ok) | max case (s) | max case memory (MiB) | RSS drift (MiB) "
        "| failures | wall (s) |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in reports:
        rows.append(
            f"| {r.target} | {r.cases} | {len(r.classes)} | {r.classes.get('ok', 0)} | {r.max_case_seconds:.3f} | "
            f"{r.max_case_memory / 2**20:.1f} | {r.rss_drift / 2**20:.1f} | {len(r.failures)} | {r.seconds:.0f} |"
        )
    return "\n".join(rows)


def main(argv: list[str] | None = None) -> int:
    """The command line of `benches/fuzz_readers.py` (and of the worker)."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cases", type=int, default=10_000, help="cases per reader (default 10000)")
    parser.add_argument("--reader", action="append", help="a reader (repeatable); default: all of them")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--failures",
        type=Path,
        default=Path("fuzz-failures"),
        help="folder for failing inputs (default ./fuzz-failures)",
    )
    parser.add_argument("--replay", type=int, metavar="CASE", help="run one case in this process and print it")
    parser.add_argument("--verbose", action="store_true", help="list every outcome class")
    parser.add_argument("--jobs", type=int, default=1, help="readers fuzzed at once (default 1)")
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    parser.add_argument("--first", type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument("--count", type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument("--work", type=Path, help=argparse.SUPPRESS)
    parser.add_argument(
        "--case-seconds", type=float, default=CASE_SECONDS, help=f"bound of a case (default {CASE_SECONDS})"
    )
    args = parser.parse_args(argv)
    if args.worker:
        return worker(args.worker, args.seed, args.first, args.count, args.failures, args.work, args.case_seconds)
    names = args.reader or READERS
    unknown = [n for n in names if n not in targets()]
    if unknown:
        parser.error(f"unknown reader(s) {unknown}; readers: {', '.join(targets())}")
    if args.replay is not None:
        return sum(replay(n, args.seed, args.replay) for n in names)
    reports = []
    with concurrent.futures.ThreadPoolExecutor(max(1, args.jobs)) as pool:
        running = [
            pool.submit(run_target, name, args.cases, args.seed, args.failures, sys.executable, args.case_seconds)
            for name in names
        ]
        for future in running:
            report = future.result()
            reports.append(report)
            print(
                f"{report.target}: {report.cases} cases, {len(report.classes)} outcome classes, max case "
                f"{report.max_case_seconds:.3f} s (case {report.slowest}), max case memory "
                f"{report.max_case_memory / 2**20:.1f} MiB (case {report.hungriest}), RSS drift "
                f"{report.rss_drift / 2**20:.1f} MiB, {len(report.failures)} failures, {report.seconds:.0f} s",
                flush=True,
            )
            if args.verbose:
                for kind, count in report.classes.most_common():
                    print(f"    {count:6d}  {kind}")
            for index, what in report.failures[:20]:
                print(f"    FAIL case {index}: {what[:300]}")
    print()
    print(format_reports(reports))
    failed = sum(len(r.failures) for r in reports)
    if failed:
        print(f"\n{failed} failures; inputs and tracebacks in {args.failures}/")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
