"""How scans update a cell of the occupancy grid, and how its probability becomes a state."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from .._validation import real_number


def _probability(name: str, value: Any) -> float:
    v = real_number(value, name)
    if not 0.0 < v < 1.0:
        raise ValueError(f"{name} must be a probability strictly between 0 and 1, got {value!r}")
    return v


@dataclass(frozen=True)
class OccupancyModel:
    """How scans update a cell and how a cell's probability becomes a state.

    Attributes:
        p_hit: probability of occupancy after one return ends in a cell (> 0.5).
        p_miss: probability after one beam passes through a cell (< 0.5).
        p_min, p_max: clamping bounds, so that a cell can change state after the world changes.
        free_threshold: a cell is FREE at or below this probability (default: one net miss).
        occupied_threshold: a cell is OCCUPIED at or above it (default: one net hit).

    Defaults are OctoMap's sensor model (0.7, 0.4, clamped to [0.12, 0.97]).
    """

    p_hit: float = 0.7
    p_miss: float = 0.4
    p_min: float = 0.12
    p_max: float = 0.97
    free_threshold: float = 0.45
    occupied_threshold: float = 0.55

    def __post_init__(self) -> None:
        for name in ("p_hit", "p_miss", "p_min", "p_max", "free_threshold", "occupied_threshold"):
            _probability(name, getattr(self, name))
        if not self.p_miss < 0.5 < self.p_hit:
            raise ValueError(f"need p_miss < 0.5 < p_hit, got p_miss={self.p_miss}, p_hit={self.p_hit}")
        if not self.p_min < 0.5 < self.p_max:
            raise ValueError(f"need p_min < 0.5 < p_max, got p_min={self.p_min}, p_max={self.p_max}")
        if not self.free_threshold < self.occupied_threshold:
            raise ValueError(
                f"need free_threshold < occupied_threshold, got {self.free_threshold}, {self.occupied_threshold}"
            )
