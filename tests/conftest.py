"""Shared pytest set-up."""

from __future__ import annotations

import os
from pathlib import Path

import planicp


def pytest_report_header() -> str:
    return f"planicp {planicp.__version__} from {Path(planicp.__file__).parent}"


def pytest_sessionstart() -> None:
    """In CI the tests must exercise the installed wheel, never the source tree."""
    if os.environ.get("PLANICP_EXPECT_INSTALLED") == "1":
        location = Path(planicp.__file__).resolve()
        source = (Path(__file__).resolve().parents[1] / "python").resolve()
        if source in location.parents:
            raise RuntimeError(f"planicp was imported from the source tree ({location}), not the wheel")
