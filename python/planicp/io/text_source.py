"""Line-by-line reading of text logs that may be gzip-compressed or a one-file zip archive."""

from __future__ import annotations

import gzip
import zipfile
import zlib
from collections.abc import Iterator
from pathlib import Path
from typing import IO

from .._validation import brief, one_line

GZIP_MAGIC = b"\x1f\x8b"
ZIP_MAGIC = b"PK\x03\x04"


class TruncatedStream(ValueError):
    """The compressed stream ends early or is corrupt (a bad checksum, a damaged block); the lines
    before the break were read."""

    def __init__(self, path: Path, line: int, detail: str) -> None:
        super().__init__(f"{path}: compressed data ends early or is corrupt after line {line}: {detail}")
        self.path = path
        self.line = line


def read_lines(path: Path) -> Iterator[tuple[int, str]]:
    """(1-based line number, line without its newline) of a plain, gzip or zip text file.

    The compression is recognised by content, not by suffix. A zip archive must hold exactly one
    file besides macOS `__MACOSX/` metadata. Bytes that are not UTF-8 are replaced, never fatal.

    Raises:
        FileNotFoundError: `path` does not exist.
        ValueError: a file with a zip signature that is not a readable zip archive, or whose one
            file cannot be opened (a damaged header, an unknown compression method, a password).
        TruncatedStream: a gzip or zip stream ends early or is corrupt (after yielding every
            complete line before the break).
        ValueError: a gzip or zip log that expands to more than `MAX_EXPANSION` times its size
            (and over `EXPANSION_FLOOR`): a decompression bomb.
    """
    if not path.is_file():
        raise FileNotFoundError(f"log file not found: {path}")
    with path.open("rb") as raw:
        magic = raw.read(4)
    expansion = max(EXPANSION_FLOOR, MAX_EXPANSION * path.stat().st_size)
    if magic.startswith(GZIP_MAGIC):
        yield from _lines_of(path, gzip.open(path, "rb"), expansion)
    elif magic == ZIP_MAGIC:
        try:
            archive = zipfile.ZipFile(path)
        except (zipfile.BadZipFile, OSError, EOFError, NotImplementedError) as exc:
            # OSError: offsets before the file's start; NotImplementedError: a zip version it does not read
            raise ValueError(f"{path}: starts like a zip archive but is not one ({one_line(str(exc))})") from None
        with archive:
            members = [n for n in archive.namelist() if not n.startswith("__MACOSX/") and not n.endswith("/")]
            if len(members) != 1:
                raise ValueError(f"{path}: a zip log must hold exactly one file, found {brief(members)}")
            try:
                member = archive.open(members[0])
            except (zipfile.BadZipFile, NotImplementedError, RuntimeError, OSError, EOFError, zlib.error) as exc:
                # RuntimeError: an encrypted member; NotImplementedError: an unknown compression method;
                # OSError: a member's offset before the file's start
                raise ValueError(
                    f"{path}: the file {brief(members[0])} in this zip archive cannot be read ({one_line(str(exc))})"
                ) from None
            yield from _lines_of(path, member, expansion)
    else:
        yield from _lines_of(path, path.open("rb"), None)


MAX_LINE_BYTES = 1 << 20
"""Longest line read whole (1 MiB; a CARMEN laser line of 1081 ranges is about 10 kB). A longer
one is passed on as its first `CUT_LINE_PREFIX` bytes and a note, which no reader parses: it is
skipped as malformed, and its bytes are never held at once."""

CUT_LINE_PREFIX = 60

MAX_EXPANSION = 100
"""Most a gzip or zip log may expand, times its size on disk. Real logs expand 3 to 5 times (the
eight Radish CARMEN logs: 2.9 to 4.9); a 1.5 MB gzip of 1.2 GB of text (a decompression bomb) took
15 s only to decompress."""

EXPANSION_FLOOR = 16 << 20
"""Text a compressed log may always expand to (16 MiB), whatever its size on disk."""


def _lines_of(path: Path, stream: IO[bytes] | gzip.GzipFile, expansion: int | None) -> Iterator[tuple[int, str]]:
    """The lines of `stream`; more than `expansion` bytes of them (None: no limit) is a ValueError."""
    number = 0
    total = 0
    with stream:
        try:
            while raw := stream.readline(MAX_LINE_BYTES + 1):
                number += 1
                total += len(raw)
                if expansion is not None and total > expansion:
                    raise _bomb(path, expansion)
                if len(raw) > MAX_LINE_BYTES and not raw.endswith(b"\n"):
                    length = len(raw)
                    while rest := stream.readline(MAX_LINE_BYTES):
                        length += len(rest)
                        total += len(rest)
                        if expansion is not None and total > expansion:
                            raise _bomb(path, expansion)
                        if rest.endswith(b"\n"):
                            break
                    head = raw[:CUT_LINE_PREFIX].decode("utf-8", errors="replace")
                    yield number, f"{head} ... (a line of {length} bytes, longer than {MAX_LINE_BYTES}: cut)"
                    continue
                yield number, raw.decode("utf-8", errors="replace").rstrip("\r\n")
        except (EOFError, zlib.error, gzip.BadGzipFile, zipfile.BadZipFile, OSError) as exc:  # BadZipFile: a bad CRC
            raise TruncatedStream(path, number, one_line(str(exc)) or type(exc).__name__) from None


def _bomb(path: Path, expansion: int) -> ValueError:
    return ValueError(
        f"{path}: the compressed log expands to more than {expansion} bytes, over {MAX_EXPANSION} "
        f"times its size (real logs expand 3 to 5 times): refused as a decompression bomb; "
        f"decompress it first if it is a real log"
    )
