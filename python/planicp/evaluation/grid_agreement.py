"""How well an occupancy grid agrees with a reference grid (e.g. one built from ground-truth poses).

Only the observation layers are compared (`EnhancedOccupancyGrid.observation_states`): the plan's
walls are the same in both grids and would only inflate the agreement. Cells are matched by their
map-frame position, so the two grids may have grown differently, but they must share resolution and
lattice (built for the same plan at the same resolution). A cell outside the reference counts as
unknown there.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from numpy.typing import NDArray

from ..mapping.enhanced_occupancy_grid import EnhancedOccupancyGrid
from ..mapping.eog_state import EogState


@dataclass(frozen=True)
class GridAgreement:
    """Agreement of a grid with a reference.

    Attributes:
        occupied_near_reference: share of the grid's occupied cells within one cell (Chebyshev,
            the 8-neighbourhood) of a reference occupied cell; NaN if the grid has none.
        free_in_reference: share of the grid's free cells that are free in the reference; NaN if
            the grid has none.
        occupied_cells, free_cells: how many occupied and free cells the grid has.
    """

    occupied_near_reference: float
    free_in_reference: float
    occupied_cells: int
    free_cells: int

    def as_dict(self) -> dict[str, float]:
        """The fields as a JSON-friendly dict."""
        return {k: float(v) for k, v in asdict(self).items()}


def compare_grids(grid: EnhancedOccupancyGrid, reference: EnhancedOccupancyGrid) -> GridAgreement:
    """Scores `grid` against `reference` (see `GridAgreement`).

    Raises:
        ValueError: the grids differ in resolution or their cells do not line up.
    """
    if not math.isclose(grid.resolution, reference.resolution, rel_tol=1e-12):
        raise ValueError(f"grids differ in resolution: {grid.resolution} m and {reference.resolution} m")
    res = grid.resolution
    shift = [(g - r) / res for g, r in zip(grid.origin, reference.origin)]
    offset = [round(s) for s in shift]
    if any(abs(s - o) > 1e-6 for s, o in zip(shift, offset)):
        raise ValueError(
            f"grid cells do not line up: origins {grid.origin} and {reference.origin} differ by a fraction of a "
            f"{res} m cell; build both grids for the same plan at the same resolution"
        )
    ours = grid.observation_states()
    ref_on_ours = _resample(reference.observation_states(), offset, ours.shape)
    occupied = ours == EogState.OCCUPIED
    free = ours == EogState.FREE
    ref_occupied = ref_on_ours == EogState.OCCUPIED
    near = _grow_one(ref_occupied)
    n_occ, n_free = int(occupied.sum()), int(free.sum())
    return GridAgreement(
        occupied_near_reference=float((occupied & near).sum() / n_occ) if n_occ else math.nan,
        free_in_reference=float((free & (ref_on_ours == EogState.FREE)).sum() / n_free) if n_free else math.nan,
        occupied_cells=n_occ,
        free_cells=n_free,
    )


def _resample(states: NDArray[np.uint8], offset: list[int], shape: tuple[int, ...]) -> NDArray[np.uint8]:
    """`states` of the reference placed on the other grid's cells (UNKNOWN where it has none).
    `offset` is (cols, rows) of the other grid's cell (0, 0) in the reference's cells."""
    out = np.full(shape, EogState.UNKNOWN, dtype=np.uint8)
    dc, dr = offset
    rows, cols = shape
    r0, r1 = max(0, -dr), min(rows, states.shape[0] - dr)
    c0, c1 = max(0, -dc), min(cols, states.shape[1] - dc)
    if r0 < r1 and c0 < c1:
        out[r0:r1, c0:c1] = states[r0 + dr : r1 + dr, c0 + dc : c1 + dc]
    return out


def _grow_one(mask: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """`mask` or any of its 8 neighbours."""
    padded = np.pad(mask, 1)
    out = np.zeros_like(mask)
    rows, cols = mask.shape
    for dr in (0, 1, 2):
        for dc in (0, 1, 2):
            out |= padded[dr : dr + rows, dc : dc + cols]
    return out
