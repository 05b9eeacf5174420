"""On-disk cache of prepared plans, keyed by the input's content and every parameter.

An entry is one `.npz` file named by the SHA-256 of (planicp's version, the cache format, the kind
of source, its parameters, its bytes). A changed file or parameter gives another key, so it is
prepared again. A corrupt or unreadable entry is deleted and rebuilt, never trusted. Entries are
written to a temporary file and renamed into place, so an interrupted write leaves nothing behind.

The folder is `$PLANICP_CACHE_DIR`, else `$XDG_CACHE_HOME/planicp`, else `~/.cache/planicp`.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
import zipfile
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from . import _core

FORMAT = 3
"""Bumped whenever what an entry holds, or how a plan is prepared, changes."""


def default_cache_dir() -> Path:
    """Where entries go when no folder is given."""
    explicit = os.environ.get("PLANICP_CACHE_DIR")
    if explicit:
        return Path(explicit)
    base = os.environ.get("XDG_CACHE_HOME")
    return (Path(base) if base else Path.home() / ".cache") / "planicp"


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
        try:
            with np.load(path, allow_pickle=False) as data:
                arrays = {name: data[name] for name in data.files}
            return arrays, True
        except (OSError, ValueError, EOFError, zipfile.BadZipFile, KeyError):
            path.unlink(missing_ok=True)  # corrupt: rebuild rather than trust it
    arrays = build()
    folder.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=folder, prefix=f".{key}.", suffix=".npz.tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            np.savez(f, **arrays)  # type: ignore[arg-type]
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return arrays, False
