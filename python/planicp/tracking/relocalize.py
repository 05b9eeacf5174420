"""Global relocalization: where is the robot on the plan, with no initial guess?

A correlative scan matcher with branch and bound (Olson 2009; Cartographer's
`FastCorrelativeScanMatcher2D`) searches every heading and every position of the plan (or of a
region) for the poses that best explain the scan against a likelihood field of the walls; the best
distinct hypotheses are refined by ICP and ranked by their inlier ratio. A symmetric building gives
several candidates that explain the scan equally well: they are all returned, ranked, and the result
says it is `ambiguous` instead of pretending certainty.

Frames follow REP-103/105: the scan is in the robot (base) frame, poses are T_map_base; metres,
radians, yaw counter-clockwise.
"""

from __future__ import annotations

import math
import threading
import time
from collections import OrderedDict
from dataclasses import dataclass, field
from typing import Annotated, Any

import numpy as np
from numpy.typing import NDArray
from pydantic.dataclasses import dataclass as pydantic_dataclass

from .. import _core
from .._settings import SETTINGS, Real, Settings, Whole, instance_of
from .._validation import Pose, as_points, as_pose, real_number, whole_number
from ..plans.plan_map import PlanMap
from .icp_config import IcpConfig
from .icp_result import IcpResult


@pydantic_dataclass(frozen=True, config=SETTINGS)
class RelocalizationConfig(Settings):
    """How `relocalize` searches. Distances in metres, angles in radians.

    Attributes:
        resolution: cell size of the likelihood field and step of the position lattice. The
            search only has to land within ICP's reach (a few cells), so 0.2 m is enough (0.1 m
            found no more places on the real logs, with about twice the nodes; docs/benchmarks.md).
        sigma: width of the Gaussian likelihood around each wall (`exp(-d^2 / (2 sigma^2))`).
        levels: levels of the max-pooled pyramid of branch and bound; the coarsest block is
            `2^(levels-1)` cells wide (6.4 m at the defaults).
        angular_step: heading step. 2 degrees: ICP refines a heading from far wider, and a finer
            step multiplies the nodes (on the real logs' plans a whole-plan search at the step
            that moves the far points by one cell scored 1.5-4 times as many, and on the outdoor
            log ran out of `max_nodes`, docs/benchmarks.md). None: that step, at most
            `max_angular_step`.
        max_angular_step: largest automatic heading step.
        search_candidates: distinct hypotheses the search hands to ICP (more than are returned,
            since refined hypotheses may merge).
        min_score: hypotheses explaining less than this share of the scan are dropped (0..1).
        relative_score: hypotheses scoring below this share of the best hypothesis's score are
            dropped too: they are no rivals, and pruning them early keeps large plans fast.
        nms_distance, nms_angle: two poses closer than both are one candidate.
        max_scan_points: the scan is thinned to one point per cell, then to at most this many.
        max_nodes: budget of scored search nodes; beyond it the search stops and the result says
            `complete=False`.
        ambiguity_margin: a runner-up whose inlier ratio is within this share of the best's makes
            the result ambiguous.
        icp: settings of the ICP refinement of each hypothesis (default: `IcpConfig()`, the
            nearest-wall index with its visibility masks, made once for the plan: from guesses
            as far off as a candidate it converges as often as the KD-tree search over the walls
            ray cast from each guess, at a fraction of the time; docs/benchmarks.md).
    """

    resolution: Annotated[float, Real(gt=0.0, unit="metres")] = 0.2
    sigma: Annotated[float, Real(gt=0.0, unit="metres")] = 0.2
    levels: Annotated[int, Whole(ge=1, le=12)] = 6
    angular_step: Annotated[float, Real(gt=0.0, unit="radians")] | None = math.radians(2.0)
    max_angular_step: Annotated[float, Real(gt=0.0, unit="radians")] = math.radians(2.0)
    search_candidates: Annotated[int, Whole(ge=1, le=1000)] = 8
    min_score: Annotated[float, Real(ge=0.0, lt=1.0)] = 0.2
    relative_score: Annotated[float, Real(ge=0.0, le=1.0)] = 0.8
    nms_distance: Annotated[float, Real(gt=0.0, unit="metres")] = 1.0
    nms_angle: Annotated[float, Real(gt=0.0, unit="radians")] = math.radians(20.0)
    max_scan_points: Annotated[int, Whole(ge=10, le=1 << 24)] = 100
    max_nodes: Annotated[int, Whole(ge=1, le=2**62)] = 4_000_000
    ambiguity_margin: Annotated[float, Real(ge=0.0, lt=1.0)] = 0.05
    icp: Annotated[IcpConfig, instance_of(IcpConfig, "planicp.IcpConfig")] = field(default_factory=IcpConfig)

    @property
    def heading_step(self) -> float:
        """The largest heading step of a search, radians: `angular_step`, or `max_angular_step`
        when the step is chosen from the scan."""
        return self.max_angular_step if self.angular_step is None else min(self.angular_step, math.pi)

    def _matcher_key(self) -> tuple[Any, ...]:
        return (
            self.resolution,
            self.sigma,
            self.levels,
            self.angular_step,
            self.max_angular_step,
            self.search_candidates,
            self.min_score,
            self.relative_score,
            self.nms_distance,
            self.nms_angle,
            self.max_scan_points,
            self.max_nodes,
        )


@dataclass(frozen=True)
class SearchRegion:
    """A part of the plan to search: headings within `yaw_tolerance` radians of `center`'s yaw
    (pi or more: any heading) and, at each heading, positions within `radius` metres (a square of
    side 2 `radius`) of `center`'s (x, y) plus `lever` turned by the heading's difference from
    `center`'s yaw. `center` is a T_map_base pose (x, y, yaw); `lever` is (x, y) in the map frame,
    metres.

    With the default zero `lever` the positions are one square at every heading. A nonzero one
    ties position to heading, for a robot that drove `lever` from `center`'s position while its
    heading there was unknown (an odometry fault): at heading `center` yaw + d it is near
    `center` + R(d) `lever`, on a ring around `center`, rather than anywhere within the lever's
    length; `center`'s yaw is then the heading the drive ends at when d is 0."""

    center: Pose
    radius: float = 2.0
    yaw_tolerance: float = math.pi
    lever: tuple[float, float] = (0.0, 0.0)

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", as_pose(self.center, "region center"))
        r = real_number(self.radius, "region radius")
        if not (math.isfinite(r) and r >= 0.0):
            raise ValueError(f"region radius must be a finite number >= 0 metres, got {self.radius!r}")
        t = real_number(self.yaw_tolerance, "region yaw_tolerance")
        if not (math.isfinite(t) and t >= 0.0):
            raise ValueError(f"region yaw_tolerance must be a finite number >= 0 radians, got {self.yaw_tolerance!r}")
        try:
            lx, ly = self.lever
        except (TypeError, ValueError):
            raise ValueError(f"region lever must be two numbers (x, y) in metres, got {self.lever!r}") from None
        lever = (real_number(lx, "region lever x"), real_number(ly, "region lever y"))
        if not (math.isfinite(lever[0]) and math.isfinite(lever[1])):
            raise ValueError(f"region lever must be finite, got {self.lever!r}")
        object.__setattr__(self, "lever", lever)


@dataclass(frozen=True, repr=False)
class Candidate:
    """One place on the plan that explains the scan.

    Attributes:
        pose: (x, y, yaw) of the robot in the map after ICP (T_map_base): metres, radians.
        score: the ranking score, the ICP inlier ratio (share of ALL scan points within
            `max_correspondence_distance` of a visible wall at `pose`), 0..1.
        inlier_ratio: the same as `score`, by its ICP name.
        rmse: root mean square distance of the inliers to the plan, metres.
        search_score: the global search's score of the lattice pose it came from: mean likelihood
            of the thinned scan's points, 0..1.
        search_pose: that lattice pose, before ICP.
        result: the ICP alignment from `search_pose` (covariance, inlier mask, ...).
    """

    pose: Pose
    score: float
    inlier_ratio: float
    rmse: float
    search_score: float
    search_pose: Pose
    result: IcpResult

    def __repr__(self) -> str:
        x, y, yaw = self.pose
        return (
            f"Candidate(pose=(x={x:.3f} m, y={y:.3f} m, yaw={math.degrees(yaw):.2f} deg), "
            f"score={self.score:.3f}, rmse={self.rmse * 100:.2f} cm, search_score={self.search_score:.3f})"
        )


@dataclass(frozen=True, repr=False)
class Relocalization:
    """Outcome of `relocalize`.

    Attributes:
        candidates: distinct places that explain the scan, best first (empty when nothing
            explains at least `min_score` of it).
        ambiguity: the runner-up's score over the best's, 0..1 (0 with fewer than two
            candidates); near 1, the scan alone cannot tell the places apart.
        ambiguous: `ambiguity >= 1 - ambiguity_margin`: trust `best` only with other evidence
            (odometry, a previous pose, more scans).
        complete: False when the search stopped on its node budget before proving its candidates
            the best on the lattice.
        rotations: headings swept; angular_step: their spacing, radians.
        nodes: search nodes scored; scan_points: scan points used by the search after thinning.
        seconds: wall-clock time of the call.
    """

    candidates: tuple[Candidate, ...]
    ambiguity: float
    ambiguous: bool
    complete: bool
    rotations: int
    angular_step: float
    nodes: int
    scan_points: int
    seconds: float

    @property
    def best(self) -> Candidate | None:
        """The top-ranked candidate, or None when there is none."""
        return self.candidates[0] if self.candidates else None

    def __repr__(self) -> str:
        best = self.best
        where = "none" if best is None else repr(best)
        return (
            f"Relocalization(best={where}, candidates={len(self.candidates)}, "
            f"ambiguity={self.ambiguity:.3f}, ambiguous={self.ambiguous}, complete={self.complete}, "
            f"{self.seconds * 1000:.0f} ms)"
        )


def relocalize(
    scan_xy: Any,
    plan: PlanMap,
    *,
    region: SearchRegion | None = None,
    config: RelocalizationConfig | None = None,
    max_candidates: int = 5,
) -> Relocalization:
    """Finds the robot on the plan from one scan, with no initial guess.

    Args:
        scan_xy: (N, 2) scan points in the robot (base) frame, metres; see `scan_to_points`.
            A scan covering a wide angle (a 270- or 360-degree LIDAR) is what makes a place unique.
        plan: the plan to search.
        region: search only there (e.g. around the last known pose); None: the whole plan, every
            heading.
        config: search settings; None uses `RelocalizationConfig()`.
        max_candidates: most candidates returned (>= 1).

    Returns:
        The candidates, ranked, with their ambiguity. The likelihood pyramid of a plan is built on
        the first call and reused for the next calls with the same plan and settings.

    Raises:
        TypeError: an argument of the wrong type.
        ValueError: a malformed scan (shape, NaN/inf, fewer than 10 distinct points), region or
            setting.

    The GIL is released while the search runs; it looks for Python signals every 50 ms, so that
    Ctrl-C stops it with KeyboardInterrupt.
    """
    start = time.perf_counter()
    config, count, points, window = _search_arguments(scan_xy, plan, region, config, max_candidates)
    raw = _core.relocalize(
        _matcher(plan, config), points, window, config.icp._native, count, float(config.ambiguity_margin)
    )
    return _relocalization(raw, config, time.perf_counter() - start)


def _relocalization(raw: _core.Relocalization, config: RelocalizationConfig, seconds: float) -> Relocalization:
    candidates = tuple(_candidate(c, config.icp.covariance_scale) for c in raw.candidates)
    return Relocalization(
        candidates=candidates,
        ambiguity=raw.ambiguity,
        ambiguous=raw.ambiguous,
        complete=raw.complete,
        rotations=raw.rotations,
        angular_step=raw.angular_step,
        nodes=raw.nodes,
        scan_points=raw.scan_points,
        seconds=seconds,
    )


class SearchInSteps:
    """A `relocalize` spread over calls, for a loop that must not stall (a tracker's updates).

    Made with the scan and settings of `relocalize`; each `advance(budget)` scores up to `budget`
    nodes of the branch and bound (about a microsecond each for a scan thinned to 120 points, on
    the real logs' plans) and returns None until the search has ended, then the `Relocalization`
    of the scan it was made with: the same one `relocalize` returns for it. The result's
    `seconds` is the time spent in the calls. The GIL is released while a call works.
    """

    def __init__(
        self,
        scan_xy: Any,
        plan: PlanMap,
        *,
        region: SearchRegion | None = None,
        config: RelocalizationConfig | None = None,
        max_candidates: int = 5,
    ) -> None:
        """Arguments as for `relocalize`; no node is scored yet.

        Raises:
            TypeError, ValueError: as `relocalize`.
        """
        start = time.perf_counter()
        self._config, self._count, self.scan, window = _search_arguments(scan_xy, plan, region, config, max_candidates)
        """`scan`: the scan searched for, (N, 2) robot-frame metres."""
        self.region = region
        """`region`: where the search looks (None: the whole plan)."""
        self._run = _matcher(plan, self._config).start(self.scan, window)
        self._seconds = time.perf_counter() - start

    @property
    def nodes(self) -> int:
        """Search nodes scored so far."""
        return self._run.nodes

    def advance(self, budget: int, seconds: float | None = None) -> Relocalization | None:
        """Scores up to `budget` (>= 1) more nodes, and with `seconds` stops as well where it is
        once that long has passed (checked every 1024 nodes, so it may run over by the time of
        that many: a tenth of a millisecond to a millisecond); the result once the search has
        ended, else None. Ctrl-C stops it between nodes with KeyboardInterrupt; advanced again,
        the search goes on from there."""
        nodes = whole_number(budget, "budget", 1, 2**62)
        start = time.perf_counter()
        if not self._run.advance(nodes, seconds):  # the native call checks `seconds`
            self._seconds += time.perf_counter() - start
            return None
        config = self._config
        raw = self._run.finish(config.icp._native, self._count, float(config.ambiguity_margin))
        self._seconds += time.perf_counter() - start
        return _relocalization(raw, config, self._seconds)


_Window = tuple[float, float, float, float, float, float, float]
"""A native search window: (x, y, yaw, half_width, half_angle, lever_x, lever_y)."""


def _search_arguments(
    scan_xy: Any, plan: PlanMap, region: SearchRegion | None, config: RelocalizationConfig | None, max_candidates: int
) -> tuple[RelocalizationConfig, int, NDArray[np.float64], _Window | None]:
    """The checked arguments of a search: (config, candidate count, scan points, native window)."""
    if not isinstance(plan, PlanMap):
        raise TypeError(f"plan must be a planicp.PlanMap, got {type(plan).__name__}")
    if config is None:
        config = _default_config()
    elif not isinstance(config, RelocalizationConfig):
        raise TypeError(f"config must be a planicp.RelocalizationConfig, got {type(config).__name__}")
    if region is not None and not isinstance(region, SearchRegion):
        raise TypeError(f"region must be a planicp.SearchRegion or None, got {type(region).__name__}")
    count = whole_number(max_candidates, "max_candidates", 1, 1000)
    points = as_points(scan_xy, "scan_xy")
    window = (
        None if region is None else (*region.center, float(region.radius), float(region.yaw_tolerance), *region.lever)
    )
    return config, count, points, window


def prepare_search(plan: PlanMap, config: RelocalizationConfig | None = None) -> None:
    """Builds the plan's likelihood pyramid for `relocalize` with `config` now, rather than in the
    first search (30 ms on the real logs' plans of 70 x 60 m); it is kept for the next searches."""
    if not isinstance(plan, PlanMap):
        raise TypeError(f"plan must be a planicp.PlanMap, got {type(plan).__name__}")
    _matcher(plan, _default_config() if config is None else config)


def _candidate(raw: _core.RelocalizationCandidate, covariance_scale: float) -> Candidate:
    a = raw.alignment
    result = IcpResult.from_alignment(a, covariance_scale)
    return Candidate(
        pose=raw.pose,
        score=raw.score,
        inlier_ratio=a.inlier_ratio,
        rmse=a.rmse,
        search_score=raw.search_score,
        search_pose=raw.search_pose,
        result=result,
    )


_CACHE_SIZE = 2
"""Matchers kept (each holds its plan alive): the last plans and settings used."""

_MATCHERS: OrderedDict[tuple[Any, ...], tuple[_core.PointMap, _core.GlobalMatcher]] = OrderedDict()
_MATCHERS_LOCK = threading.Lock()


def _matcher(plan: PlanMap, config: RelocalizationConfig) -> _core.GlobalMatcher:
    """The cached matcher of (plan, settings); the entry holds the native plan, so its id stays valid."""
    key = (id(plan._native), config._matcher_key())
    with _MATCHERS_LOCK:
        hit = _MATCHERS.get(key)
        if hit is not None and hit[0] is plan._native:
            _MATCHERS.move_to_end(key)
            return hit[1]
    matcher = _core.GlobalMatcher(plan._native, config)
    with _MATCHERS_LOCK:
        _MATCHERS[key] = (plan._native, matcher)
        while len(_MATCHERS) > _CACHE_SIZE:
            _MATCHERS.popitem(last=False)
    return matcher


_DEFAULT: RelocalizationConfig | None = None


def _default_config() -> RelocalizationConfig:
    global _DEFAULT
    if _DEFAULT is None:
        _DEFAULT = RelocalizationConfig()
    return _DEFAULT
