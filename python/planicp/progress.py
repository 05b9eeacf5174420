"""A one-line progress bar for the command line (no dependency; silent without a stream)."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TextIO


def progress_bar(stream: TextIO | None, total: float, unit: str, width: int = 20) -> Callable[[float], None]:
    """A function to call with the amount done so far (in `unit`s, out of `total`); it redraws the
    bar on `stream` with the elapsed time when the percentage has changed, at most 5 times a
    second. Does nothing when `stream` is None."""
    started = time.perf_counter()
    last = [-1.0, -1.0]  # percent and time of the last redraw

    def report(done: float) -> None:
        if stream is None:
            return
        share = min(max(done / total, 0.0), 1.0) if total > 0 else 1.0
        percent = int(100 * share)
        now = time.perf_counter()
        # Redraw at most 5 times a second (and always at the end) so that the bar costs nothing.
        if percent == last[0] or (now - last[1] < 0.2 and percent < 100):
            return
        last[0], last[1] = percent, now
        filled = int(width * share)
        bar = "#" * filled + "." * (width - filled)
        print(f"\r  [{bar}] {percent:3d} %  {done:,.0f} / {total:,.0f} {unit}, {now - started:5.1f} s",
              end="", file=stream, flush=True)

    return report
