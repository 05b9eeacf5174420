"""Type stubs of the native core (crates/planicp_py). See the Python wrappers for full docs."""

from collections.abc import Sequence
from typing import Literal, Protocol, final

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "MAX_RASTER_CELLS",
    "MIN_SCAN_POINTS",
    "MIN_SEARCH_POINTS",
    "Alignment",
    "GlobalMatcher",
    "IcpSettings",
    "LikelihoodGrid",
    "LogOddsGrid",
    "OccupancyGrid",
    "PlanicpError",
    "PlanicpInternalError",
    "PointMap",
    "Relocalization",
    "RelocalizationCandidate",
    "SearchRun",
    "WallView",
    "__version__",
    "_panic_for_tests",
    "align",
    "largest_pair_distance",
    "relocalize",
    "visibility_range",
]

__version__: str
MAX_RASTER_CELLS: int
"""Most cells of a plan's visibility raster (a plan whose raster would need more is refused)."""
MIN_SCAN_POINTS: int
MIN_SEARCH_POINTS: int
"""Fewest search cells (of `RelocalizationConfig.resolution`) a scan must occupy to be searched."""

class PlanicpError(ValueError):
    """An input planicp cannot work with; the message names the problem."""

class PlanicpInternalError(RuntimeError):
    """A bug inside planicp's native core (a Rust panic, caught at the boundary)."""

@final
class PointMap:
    """Wall points of a plan (metres, map frame) with their KD-tree, normals and visibility raster;
    points denser than two per 5 mm square on average are thinned to one per square."""

    def __new__(
        cls,
        points: NDArray[np.float64],
        raster_resolution: float | None = None,
        normals: NDArray[np.float64] | None = None,
    ) -> PointMap: ...
    def __len__(self) -> int: ...
    @property
    def points(self) -> NDArray[np.float64]: ...
    @property
    def normals(self) -> NDArray[np.float64]: ...
    @property
    def raster_resolution(self) -> float: ...
    @property
    def spacing(self) -> float: ...
    def wall_index_stats(self) -> tuple[float, float, int, int, int, int]: ...
    def visible_indices(self, x: float, y: float, max_range: float) -> NDArray[np.uint32]: ...
    def view_from(
        self,
        pose: tuple[float, float, float],
        max_range: float,
        directions: int,
        scan: NDArray[np.float64] | None = None,
        ranges: bool = True,
        pair_distance: float | None = None,
    ) -> WallView: ...

@final
class WallView:
    """What a range sensor at a pose sees of the plan: the visible wall points and the range to the
    first wall in each of `directions` evenly spaced directions (base-frame angle -pi + j 2 pi / n)."""

    @property
    def pose(self) -> tuple[float, float, float]: ...
    @property
    def visible_indices(self) -> NDArray[np.uint32]: ...
    @property
    def ranges(self) -> NDArray[np.float64]: ...
    def classify(self, points: NDArray[np.float64], margin: float) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]: ...

class _IcpFields(Protocol):
    """What `IcpSettings` reads off a `planicp.IcpConfig`, by name."""

    @property
    def max_correspondence_distance(self) -> float: ...
    @property
    def max_iterations(self) -> int: ...
    @property
    def trim_ratio(self) -> float: ...
    @property
    def auto_trim(self) -> bool: ...
    @property
    def translation_tolerance(self) -> float: ...
    @property
    def rotation_tolerance(self) -> float: ...
    @property
    def subsample(self) -> int: ...
    @property
    def correspondence_schedule(self) -> Sequence[float]: ...
    @property
    def use_visibility(self) -> bool: ...
    @property
    def accelerate(self) -> bool: ...
    @property
    def visibility_range(self) -> float | None: ...
    @property
    def correspondence_search(self) -> Literal["wall_index", "kd_tree"]: ...

@final
class IcpSettings:
    """ICP settings checked by the core, read off a `planicp.IcpConfig` (its fields, by name)."""

    def __new__(cls, config: _IcpFields) -> IcpSettings: ...

@final
class Alignment:
    """The raw outcome of `align`."""

    @property
    def pose(self) -> tuple[float, float, float]: ...
    @property
    def converged(self) -> bool: ...
    @property
    def iterations(self) -> int: ...
    @property
    def num_inliers(self) -> int: ...
    @property
    def inlier_ratio(self) -> float: ...
    @property
    def rmse(self) -> float: ...
    @property
    def num_target_points(self) -> int: ...
    @property
    def covariance(self) -> NDArray[np.float64]: ...
    @property
    def constraint(self) -> NDArray[np.float64]: ...
    @property
    def inlier_mask(self) -> NDArray[np.bool_]: ...

@final
class OccupancyGrid:
    """An occupancy grid to simulate LIDAR scans in; rows grow with +y (row 0 is the lowest y)."""

    def __new__(cls, cells: NDArray[np.bool_], resolution: float, origin: tuple[float, float]) -> OccupancyGrid: ...
    @property
    def shape(self) -> tuple[int, int]: ...
    @property
    def resolution(self) -> float: ...
    @property
    def origin(self) -> tuple[float, float]: ...
    def classify_returns(
        self, pose: tuple[float, float, float], points: NDArray[np.float64], margin: float, directions: int
    ) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]: ...
    def cast(
        self,
        sensor_pose: tuple[float, float, float],
        angle_min: float,
        angle_increment: float,
        beams: int,
        range_min: float,
        range_max: float,
        range_sigma: float = 0.0,
        dropout: float = 0.0,
        seed: int | None = None,
        discs: ArrayLike | None = None,
    ) -> NDArray[np.float64]: ...

@final
class LikelihoodGrid:
    """The plan's likelihood field at cell centres `resolution` metres apart, bilinear between
    them: exp(-d^2 / (2 sigma^2)) of the distance d to the nearest of the points (metres, map
    frame) (`profile="nearest"`: wall surfaces), or the points' summed Gaussians over the largest
    sum within 3 sigma, at least 1 (`profile="density"`: an occupancy grid's occupied cells, a
    wall drawn as a band of cells peaking in its middle)."""

    def __new__(
        cls,
        points: NDArray[np.float64],
        resolution: float,
        sigma: float,
        profile: Literal["nearest", "density"] = "nearest",
    ) -> LikelihoodGrid: ...
    @staticmethod
    def within_budget(
        points: NDArray[np.float64],
        resolution: float,
        sigma: float,
        profile: Literal["nearest", "density"] = "nearest",
    ) -> LikelihoodGrid: ...
    @property
    def resolution(self) -> float: ...
    @property
    def sigma(self) -> float: ...
    @property
    def shape(self) -> tuple[int, int]: ...
    def value_and_gradient(self, x: float, y: float) -> tuple[float, tuple[float, float]]: ...
    def cost(
        self,
        scan: NDArray[np.float64],
        pose: tuple[float, float, float],
        prior_pose: tuple[float, float, float],
        prior_covariance: Sequence[Sequence[float]],
        weight: float,
    ) -> float: ...
    def refine(
        self,
        scan: NDArray[np.float64],
        start: tuple[float, float, float],
        prior_pose: tuple[float, float, float],
        prior_covariance: Sequence[Sequence[float]],
        weight: float,
        max_iterations: int = 30,
    ) -> tuple[tuple[float, float, float], float, float, list[list[float]], int]: ...

@final
class LogOddsGrid:
    """A growing log-odds occupancy grid updated by scans; rows grow with +y."""

    def __new__(
        cls,
        rows: int,
        cols: int,
        resolution: float,
        origin: tuple[float, float],
        hit: float,
        miss: float,
        min: float,
        max: float,
        max_cells: int,
    ) -> LogOddsGrid: ...
    def integrate(
        self,
        sensor: tuple[float, float],
        hits: NDArray[np.float64],
        misses: NDArray[np.float64],
        max_range: float,
    ) -> None: ...
    @property
    def shape(self) -> tuple[int, int]: ...
    @property
    def resolution(self) -> float: ...
    @property
    def origin(self) -> tuple[float, float]: ...
    @property
    def scans(self) -> int: ...
    @property
    def max_cells(self) -> int: ...
    def log_odds(self) -> NDArray[np.float32]: ...
    def observed(self) -> NDArray[np.bool_]: ...

def align(
    map: PointMap,
    scan: NDArray[np.float64],
    initial: tuple[float, float, float],
    settings: IcpSettings,
    view: WallView | None = None,
) -> Alignment: ...
def visibility_range(scan: NDArray[np.float64], settings: IcpSettings) -> float: ...
def largest_pair_distance(settings: IcpSettings) -> float: ...
def _panic_for_tests() -> None: ...

class _SearchFields(Protocol):
    """What `GlobalMatcher` reads off a `planicp.RelocalizationConfig`, by name."""

    @property
    def resolution(self) -> float: ...
    @property
    def sigma(self) -> float: ...
    @property
    def levels(self) -> int: ...
    @property
    def angular_step(self) -> float | None: ...
    @property
    def max_angular_step(self) -> float: ...
    @property
    def search_candidates(self) -> int: ...
    @property
    def min_score(self) -> float: ...
    @property
    def relative_score(self) -> float: ...
    @property
    def nms_distance(self) -> float: ...
    @property
    def nms_angle(self) -> float: ...
    @property
    def max_scan_points(self) -> int: ...
    @property
    def max_nodes(self) -> int: ...

@final
class GlobalMatcher:
    """The likelihood pyramid of a plan with the global search settings."""

    def __new__(cls, map: PointMap, config: _SearchFields) -> GlobalMatcher: ...
    @property
    def shape(self) -> tuple[int, int]: ...
    @property
    def resolution(self) -> float: ...
    @property
    def levels(self) -> int: ...
    def score_at(self, scan: NDArray[np.float64], pose: tuple[float, float, float]) -> float: ...
    def start(
        self, scan: NDArray[np.float64], window: tuple[float, float, float, float, float, float, float] | None
    ) -> SearchRun: ...

@final
class SearchRun:
    """A global search in progress: `advance` a budget of nodes at a time, then `finish`."""

    def advance(self, budget: int, seconds: float | None = None) -> bool: ...
    @property
    def finished(self) -> bool: ...
    @property
    def nodes(self) -> int: ...
    def finish(self, settings: IcpSettings, max_candidates: int, ambiguity_margin: float) -> Relocalization: ...

@final
class RelocalizationCandidate:
    """One refined hypothesis of `relocalize`."""

    @property
    def pose(self) -> tuple[float, float, float]: ...
    @property
    def score(self) -> float: ...
    @property
    def search_score(self) -> float: ...
    @property
    def search_pose(self) -> tuple[float, float, float]: ...
    @property
    def alignment(self) -> Alignment: ...

@final
class Relocalization:
    """The raw outcome of `relocalize`."""

    @property
    def candidates(self) -> list[RelocalizationCandidate]: ...
    @property
    def ambiguity(self) -> float: ...
    @property
    def ambiguous(self) -> bool: ...
    @property
    def rotations(self) -> int: ...
    @property
    def angular_step(self) -> float: ...
    @property
    def nodes(self) -> int: ...
    @property
    def complete(self) -> bool: ...
    @property
    def scan_points(self) -> int: ...

def relocalize(
    matcher: GlobalMatcher,
    scan: NDArray[np.float64],
    window: tuple[float, float, float, float, float, float, float] | None,
    settings: IcpSettings,
    max_candidates: int,
    ambiguity_margin: float,
) -> Relocalization: ...
