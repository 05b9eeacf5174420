"""The four states of an enhanced occupancy grid cell, and the colour each is drawn in."""

from __future__ import annotations

import enum


class EogState(enum.IntEnum):
    """Cell states of the enhanced occupancy grid (the codes `states()` returns)."""

    UNKNOWN = 0
    FREE = 1
    OCCUPIED = 2
    ARCHITECTURAL = 3


STATE_COLOURS: dict[EogState, tuple[int, int, int]] = {
    EogState.UNKNOWN: (160, 160, 160),
    EogState.FREE: (255, 255, 255),
    EogState.OCCUPIED: (0, 0, 0),
    EogState.ARCHITECTURAL: (30, 90, 230),
}
"""RGB colour of each state (the thesis's table 5.1: grey, white, black, blue)."""
