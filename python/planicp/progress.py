"""Progress of a long command (log replay, evaluation, sweeps) on the command line.

On a terminal the bar is tqdm's, redrawn in place. Written to a file or a pipe (a CI log, `| tee`),
a bar redrawn with carriage returns would be one long line of frames, so a plain line is printed at
every tenth of the work instead.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TextIO

from tqdm import tqdm


def progress_bar(stream: TextIO | None, total: float, unit: str) -> Callable[[float], None]:
    """A function to call with the amount done so far (in `unit`s, out of `total`); it shows the
    progress on `stream` (see the module documentation). Does nothing when `stream` is None."""
    if stream is None:
        return lambda done: None
    isatty = getattr(stream, "isatty", None)
    if callable(isatty) and isatty():
        return _terminal_bar(stream, total, unit)
    return _plain_lines(stream, total, unit)


def _terminal_bar(stream: TextIO, total: float, unit: str) -> Callable[[float], None]:
    bar = tqdm(total=total, unit=f" {unit}", file=stream, leave=True, dynamic_ncols=True, mininterval=0.2)

    def report(done: float) -> None:
        if bar.disable:  # closed: the work is done
            return
        bar.update(max(0.0, min(done, total)) - bar.n)
        if done >= total:
            bar.close()

    return report


def _plain_lines(stream: TextIO, total: float, unit: str) -> Callable[[float], None]:
    started = time.perf_counter()
    last = [0]  # the last tenth printed

    def report(done: float) -> None:
        share = min(max(done / total, 0.0), 1.0) if total > 0 else 1.0
        tenth = int(10 * share)
        if tenth <= last[0]:
            return
        last[0] = tenth
        print(
            f"  {10 * tenth:3d} %  {done:,.0f} / {total:,.0f} {unit}, {time.perf_counter() - started:.1f} s",
            file=stream,
            flush=True,
        )

    return report
