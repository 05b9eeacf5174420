"""The real-log studies' command line refuses bad options before it looks for the harness."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

STUDIES = Path(__file__).resolve().parents[1] / "benches" / "real_log_studies.py"


def test_a_stride_below_one_is_refused_with_the_fix() -> None:
    done = subprocess.run(
        [sys.executable, str(STUDIES), "seeds", "--stride", "0", "--harness", "/no/harness.py"],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 2
    assert "--stride must be 1 or more" in done.stderr
    assert "no harness" not in done.stderr
