"""The short version of `benches/long_run.py`: memory stays flat over 2000 `Localizer.update` calls.

The bound must be one a real leak exceeds: keeping one scan's points per update (360 x 2 float64,
5.8 KB) adds ~8.6 MB over the 1500 measured updates; the control run does exactly that and must
exceed the bound, so the measurement is shown to be able to fail.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from typing import Any

import pytest

BENCH = Path(__file__).resolve().parents[1] / "benches" / "long_run.py"
BOUND_MB = 3.0


def _long_run() -> Any:
    spec = importlib.util.spec_from_file_location("planicp_long_run", BENCH)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="needs Linux /proc for the current RSS")
def test_memory_is_flat_over_2000_updates_and_a_leak_would_show() -> None:
    lr = _long_run()
    r = lr.run(2000, sample_every=250, seed=1)
    assert r["accepted"] > 1000, r  # the run tracks (not a run of refused updates)
    assert r["growth_mb"] < BOUND_MB, r["samples"]
    kept: list[Any] = []
    leak = lr.run(2000, sample_every=250, seed=1, keep=kept)
    assert leak["growth_mb"] > BOUND_MB, ("the measurement cannot see a 5.8 KB-per-update leak", leak["samples"])
