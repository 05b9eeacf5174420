"""Plan images read within a budget: their size is read from the file's header before any pixel is.

A 0.95 MB PNG can hold 30000 x 30000 pixels (decoded: 5.2 GB, and more in the conversions after),
and a sparse file can claim gigabytes. `check_image_file` reads the width and height from the
header of PNG, JPEG, PGM/PPM/PBM, BMP, GIF and TIFF files and refuses more than
`MAX_IMAGE_PIXELS`, or a file larger than `MAX_IMAGE_BYTES`, before the image is decoded or its
bytes are read for the cache key. Other formats are left to OpenCV, which refuses more than 2^30
pixels itself.
"""

from __future__ import annotations

import stat
import struct
from pathlib import Path
from typing import BinaryIO

MAX_IMAGE_PIXELS = 200_000_000
"""Most pixels of a plan image: a 14,000 x 14,000 raster, 700 m square at 5 cm (about 200 MB grey)."""

MAX_IMAGE_BYTES = 1 << 30
"""Largest plan image file, bytes (1 GiB)."""


def image_dimensions(path: Path) -> tuple[int, int] | None:
    """(width, height) in pixels from the header of a PNG, JPEG, PGM/PPM/PBM, BMP, GIF or TIFF
    file; None for another format or a header that cannot be read (the decoder then decides)."""
    with open(path, "rb") as f:
        head = f.read(64)
        if head.startswith(b"\x89PNG\r\n\x1a\n") and len(head) >= 24 and head[12:16] == b"IHDR":
            width, height = struct.unpack(">II", head[16:24])
            return int(width), int(height)
        if head[:6] in (b"GIF87a", b"GIF89a") and len(head) >= 10:
            width, height = struct.unpack("<HH", head[6:10])
            return int(width), int(height)
        if head[:2] == b"BM" and len(head) >= 26:
            width, height = struct.unpack("<ii", head[18:26])
            return abs(int(width)), abs(int(height))
        if head[:2] in (b"P1", b"P2", b"P3", b"P4", b"P5", b"P6"):
            return _netpbm_dimensions(head + f.read(4096))
        if head[:2] == b"\xff\xd8":
            f.seek(2)
            return _jpeg_dimensions(f)
        if head[:4] in (b"II*\x00", b"MM\x00*"):
            f.seek(0)
            return _tiff_dimensions(f.read(1 << 16))
    return None


def require_regular_file(path: Path, what: str) -> None:
    """Raises FileNotFoundError when nothing is at `path`, and ValueError when what is there is no
    regular file (a folder, a device such as /dev/zero, a pipe) or cannot be reached (a symlink
    loop); each names `what` and `path`."""
    try:
        mode = path.stat().st_mode
    except FileNotFoundError:
        raise FileNotFoundError(f"{what} {path} does not exist") from None
    except (OSError, RuntimeError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise ValueError(f"{what} {path} cannot be opened: {reason}") from None
    if not stat.S_ISREG(mode):
        kind = "a folder" if stat.S_ISDIR(mode) else "not a regular file (a device or a pipe)"
        raise ValueError(f"{what} {path} is {kind}: give the image file itself")


def check_image_file(path: Path, what: str) -> None:
    """Raises ValueError when the image file at `path` is larger than `MAX_IMAGE_BYTES` or its
    header gives more than `MAX_IMAGE_PIXELS` pixels; the message names the file and the fix."""
    size = path.stat().st_size
    if size > MAX_IMAGE_BYTES:
        raise ValueError(
            f"{what} {path} is {size / 2**20:.0f} MiB; plan images are read up to "
            f"{MAX_IMAGE_BYTES >> 20} MiB: crop or scale the image down"
        )
    dimensions = image_dimensions(path)
    if dimensions is None:
        return
    width, height = dimensions
    if width * height > MAX_IMAGE_PIXELS:
        raise ValueError(
            f"{what} {path} is {_count(width)} x {_count(height)} pixels "
            f"({_count(width * height // 10**6)} million); plan images are read up to "
            f"{MAX_IMAGE_PIXELS / 1e6:.0f} million pixels: crop the image or scale it down (and its "
            f"resolution up by the same factor)"
        )


def _count(n: int) -> str:
    """`n` written out, or its first digits and length when it has more than 15 (a PGM header may
    give a width of any number of digits)."""
    text = str(n)
    return text if len(text) <= 15 else f"{text[:3]}...({len(text)} digits)"


def _netpbm_dimensions(data: bytes) -> tuple[int, int] | None:
    tokens: list[bytes] = []
    for line in data[2:].split(b"\n"):
        tokens.extend(line.split(b"#", 1)[0].split())
        if len(tokens) >= 2:
            break
    try:
        return int(tokens[0]), int(tokens[1])
    except (IndexError, ValueError):
        return None


def _jpeg_dimensions(f: BinaryIO) -> tuple[int, int] | None:
    read = f.read
    for _ in range(10_000):  # markers before the frame header
        marker = read(2)
        if len(marker) < 2 or marker[0] != 0xFF:
            return None
        kind = marker[1]
        if kind in (0xD8, 0x01) or 0xD0 <= kind <= 0xD7:
            continue
        length_bytes = read(2)
        if len(length_bytes) < 2:
            return None
        length = struct.unpack(">H", length_bytes)[0]
        if 0xC0 <= kind <= 0xCF and kind not in (0xC4, 0xC8, 0xCC):
            frame = read(5)
            if len(frame) < 5:
                return None
            height, width = struct.unpack(">HH", frame[1:5])
            return int(width), int(height)
        if length < 2:
            return None
        read(length - 2)
    return None


def _tiff_dimensions(data: bytes) -> tuple[int, int] | None:
    order = "<" if data[:2] == b"II" else ">"
    try:
        (offset,) = struct.unpack(order + "I", data[4:8])
        (count,) = struct.unpack(order + "H", data[offset : offset + 2])
        found: dict[int, int] = {}
        for i in range(count):
            entry = data[offset + 2 + 12 * i : offset + 14 + 12 * i]
            tag, kind = struct.unpack(order + "HH", entry[:4])
            if tag in (256, 257):
                value = struct.unpack(order + ("H" if kind == 3 else "I"), entry[8:10] if kind == 3 else entry[8:12])
                found[tag] = int(value[0])
        return found[256], found[257]
    except (struct.error, KeyError):
        return None
