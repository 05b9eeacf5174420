"""The short version of `benches/long_run.py`: memory stays flat over 2000 `Localizer.update` calls.

The bound must be one a real leak exceeds: keeping one scan's points per update (360 x 2 float64,
5.8 KB) adds ~8.6 MB over the 1500 measured updates; the control run does exactly that and must
exceed the bound, so the measurement is shown to be able to fail.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

BENCH = Path(__file__).resolve().parents[1] / "benches" / "long_run.py"
BOUND_MB = 3.0


def _measure(leak: bool) -> dict[str, Any]:
    """`run(2000)` of the bench in a fresh interpreter, so that the resident memory of the test
    session (other tests' arrays, caches) cannot blur the measurement."""
    code = (
        "import importlib.util, json, sys\n"
        f"spec = importlib.util.spec_from_file_location('planicp_long_run', {str(BENCH)!r})\n"
        "module = importlib.util.module_from_spec(spec); sys.modules[spec.name] = module\n"
        "spec.loader.exec_module(module)\n"
        f"r = module.run(2000, sample_every=250, seed=1, keep=[] if {leak} else None)\n"
        "print(json.dumps({'accepted': r['accepted'], 'growth_mb': r['growth_mb'], 'samples': r['samples']}))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    result: dict[str, Any] = json.loads(done.stdout.strip().splitlines()[-1])
    return result


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="needs Linux /proc for the current RSS")
def test_memory_is_flat_over_2000_updates_and_a_leak_would_show() -> None:
    r = _measure(leak=False)
    assert r["accepted"] > 1000, r  # the run tracks (not a run of refused updates)
    assert r["growth_mb"] < BOUND_MB, r["samples"]
    leak = _measure(leak=True)
    assert leak["growth_mb"] > BOUND_MB, ("the measurement cannot see a 5.8 KB-per-update leak", leak["samples"])
