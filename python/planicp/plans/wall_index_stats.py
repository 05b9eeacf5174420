"""Sizes of a plan's nearest-wall index (see `PlanMap.prepare_index`)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class WallIndexStats:
    """The nearest-wall index of a plan: a raster over the plan's extent whose every cell lists the
    one or two wall points that can be nearest to a point inside it (exact look-ups; see
    `IcpConfig.correspondence_search`).

    Attributes:
        cell: cell size, metres.
        reach: largest distance from the walls at which look-ups are answered, metres; alignments
            whose largest stage distance exceeds it use the KD-tree.
        memory_bytes: bytes the index holds.
        stored_blocks: 8 x 8-cell blocks stored (those within reach of a wall)...
        blocks: ...of all blocks over the plan's extent.
        candidates: wall points listed over all stored cells.
    """

    cell: float
    reach: float
    memory_bytes: int
    stored_blocks: int
    blocks: int
    candidates: int
