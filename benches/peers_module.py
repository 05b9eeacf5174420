"""`../shared/bench/peers.py`, the peer benchmark (a script, not a package), loaded as a module by
the benches that compare planicp with it (`peers_ratio.py`, `intel_harder.py`). Nothing of it is
copied into the project, and nothing in the project's tests needs it."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from typing import Any

DEFAULT_PEERS_FILE = Path(__file__).resolve().parent.parent.parent / "shared" / "bench" / "peers.py"
"""Where `../shared` puts it, next to the project's checkout."""


def load_peers_module(path: Path = DEFAULT_PEERS_FILE) -> Any:
    """The peer benchmark at `path` as a module; SystemExit naming the path when it is missing."""
    if not path.is_file():
        raise SystemExit(f"peers.py not found at {path}; pass --peers-file")
    spec = importlib.util.spec_from_file_location("shared_bench_peers", path)
    if spec is None or spec.loader is None:
        raise SystemExit(f"cannot load {path} as a module")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
