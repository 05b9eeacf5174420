#!/usr/bin/env python3
"""Fuzz every file reader with mutated real files (issue 19): ROS map YAML and image, plan images,
HouseExpo JSON, DXF, CARMEN logs, g2o graphs, study YAML (planicp.sweep) and plan cache entries.

    python benches/fuzz_readers.py --cases 10000 [--reader NAME] [--seed N] [--verbose]
    python benches/fuzz_readers.py --reader NAME --seed N --replay CASE     # one case, in this process

Prints per reader: cases, distinct outcome classes, the slowest case, the growth of the worker's
peak resident set; exits 1 on any undocumented exception, crash, hang, case over 5 s or memory
over its bound, with the failing inputs under ./fuzz-failures (`--failures DIR`). The engine and
the contract are in tests/reader_fuzzing.py; tests/test_fuzz_readers.py runs a short profile.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from reader_fuzzing import main  # noqa: E402  (tests/ is put on sys.path above)

if __name__ == "__main__":
    sys.exit(main())
