"""On-disk cache of prepared plans, keyed by the input's content and every parameter.

An entry is one `.npz` file named by the SHA-256 of (planicp's version, the cache format, the kind
of source, its parameters, its bytes). A changed file or parameter gives another key, so it is
prepared again. Each entry holds a checksum of its key and its arrays (names, types, shapes and
bytes); an entry that does not load, or whose arrays do not match it (a truncated, edited or
swapped file), is deleted and rebuilt, never trusted. Entries are written to a temporary file and
renamed into place, so an interrupted write leaves nothing behind. A folder that cannot be written
(read-only, full) is skipped with a warning: the plan is prepared without the cache.

The folder is `$PLANICP_CACHE_DIR`, else the platform's user cache folder for planicp (platformdirs:
`$XDG_CACHE_HOME/planicp` or `~/.cache/planicp` on Linux, `~/Library/Caches/planicp` on macOS).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import tempfile
import warnings
import zipfile
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import numpy as np
import platformdirs
from numpy.typing import NDArray

from .. import _core

FORMAT = 6
"""Bumped whenever what an entry holds, or how a plan is prepared, changes (5: points thinned when far
denser than useful; 6: normals fitted to the six nearest points and every point as near as the
sixth)."""


def default_cache_dir() -> Path:
    """Where entries go when no folder is given."""
    explicit = os.environ.get("PLANICP_CACHE_DIR")
    if explicit:
        return Path(explicit)
    return platformdirs.user_cache_path("planicp")


def cache_key(kind: str, params: dict[str, Any], contents: Iterable[bytes]) -> str:
    """Hex SHA-256 over planicp's version, the format, `kind`, `params` (JSON) and `contents`."""
    h = hashlib.sha256()
    h.update(f"planicp {_core.__version__} format {FORMAT} {kind}\n".encode())
    h.update(json.dumps(params, sort_keys=True, default=str).encode())
    for chunk in contents:
        h.update(len(chunk).to_bytes(8, "little"))
        h.update(chunk)
    return h.hexdigest()


Arrays = dict[str, NDArray[Any]]


def cached(folder: Path | None, key: str, build: Callable[[], Arrays]) -> tuple[Arrays, bool]:
    """The arrays stored under `key` in `folder`, or `build()`'s, stored there. Returns them and
    whether they came from the cache. `folder=None` disables caching."""
    if folder is None:
        return build(), False
    path = folder / f"{key}.npz"
    if path.exists():
        arrays = _verified(path, key)
        if arrays is not None:
            return arrays, True
        try:
            path.unlink(missing_ok=True)  # corrupt or tampered with: rebuilt rather than trusted
        except OSError:
            pass
    arrays = build()
    try:
        folder.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=f".{key}.", suffix=".npz.tmp")
    except OSError as exc:
        warnings.warn(
            f"plan cache {folder} cannot be written ({exc.strerror or exc}); the plan was prepared "
            f"without it (set PLANICP_CACHE_DIR to a writable folder, or pass cache=False)",
            stacklevel=3,
        )
        return arrays, False
    try:
        with os.fdopen(fd, "wb") as f:
            np.savez(f, **arrays, **{CHECKSUM: np.frombuffer(_checksum(key, arrays), dtype=np.uint8)})  # type: ignore[arg-type]
        os.replace(tmp, path)
    except OSError as exc:
        Path(tmp).unlink(missing_ok=True)
        warnings.warn(
            f"plan cache {folder} cannot be written ({exc.strerror or exc}); the plan was prepared without it",
            stacklevel=3,
        )
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return arrays, False


CHECKSUM = "_checksum"
"""The array of an entry that holds the SHA-256 of its key and its other arrays."""


def _checksum(key: str, arrays: Arrays) -> bytes:
    """SHA-256 over `key` and every array's name, type, shape and bytes, in name order."""
    h = hashlib.sha256(key.encode())
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(f"\n{name} {a.dtype.str} {a.shape}\n".encode())
        h.update(a.tobytes())
    return h.digest()


def _verified(path: Path, key: str) -> Arrays | None:
    """The arrays of the entry at `path` when it loads and its checksum matches them and `key`;
    None otherwise (whatever is wrong with the file: an entry is an optimisation, never an error)."""
    try:
        if not _sizes_fit(path):
            return None
        with np.load(path, allow_pickle=False) as data:
            arrays = {name: data[name] for name in data.files}
    except Exception:  # noqa: BLE001 - numpy and zipfile raise a dozen types on a damaged file
        return None
    stored = arrays.pop(CHECKSUM, None)
    if stored is None or stored.dtype != np.uint8 or stored.tobytes() != _checksum(key, arrays):
        return None
    return arrays


def _sizes_fit(path: Path) -> bool:
    """Whether every member of the entry is an uncompressed .npy whose header claims exactly the
    bytes the member holds. numpy allocates the array a header claims before reading it, so a
    damaged header (a shape of 10^12) would otherwise ask for terabytes; checked this way, loading
    an entry takes no more memory than its size on disk."""
    limit = path.stat().st_size
    with zipfile.ZipFile(path) as archive:
        for info in archive.infolist():
            if info.compress_type != zipfile.ZIP_STORED or info.file_size > limit:
                return False
            with archive.open(info) as member:
                version = np.lib.format.read_magic(member)
                if version == (1, 0):
                    shape, _, dtype = np.lib.format.read_array_header_1_0(member)
                elif version == (2, 0):
                    shape, _, dtype = np.lib.format.read_array_header_2_0(member)
                else:
                    return False
                if dtype.hasobject or member.tell() + math.prod(shape) * dtype.itemsize != info.file_size:
                    return False
    return True
