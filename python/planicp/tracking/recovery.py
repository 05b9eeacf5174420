"""Finding the robot again after the localizer is lost: global search, then confirmation.

While the `Localizer` is lost, every scan goes to a `Recovery`:

1. Without hypotheses, a scan is searched for around the last pose (within `local_radius`, any
   heading: a slip or a bad odometry step), then the scan of the update where that search ends
   over the whole plan (`relocalize`: the robot was carried elsewhere). A search takes seconds on
   a large plan, so each update scores at most `search_nodes` of its branch and bound
   (`SearchInSteps`) and the searches run over as many updates as they need: an update never
   stalls. Every distinct candidate of a search that explains at least `min_inlier_ratio` of its
   scan, moved with the odometry since that scan, becomes a hypothesis when the search ends.
   (Searching only near the last pose first was tried: in an office some partial fit nearby
   always explains 60 % of a scan, and it kept the localizer from finding a robot carried to
   another room; so nothing is adopted before both searches have ended.)
2. On each next scan every hypothesis moves with the odometry and is aligned again (ICP from its
   prediction). A hypothesis whose fit explains less than `min_inlier_ratio` of the scan, or needs
   a correction beyond the acceptance gate, is dropped; so is one whose mean inlier ratio over the
   scans it has explained falls more than `margin` below the best hypothesis's, and one through
   whose walls more of the scan's returns pass than `Recovery.beyond_limit` allows (`max_beyond`,
   or what soundly tracked scans showed, when more; candidates of the search too).
3. When both searches have ended and a single hypothesis has survived `confirmations` scans in a
   row, it is adopted. While several survive (a symmetric building), none is: the localizer stays
   lost and says so. When all are dropped, a new pair of searches starts.

Poses are T_map_base; scans are base-frame points (metres).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from .._validation import Pose, real_number, whole_number
from ..plan_map import PlanMap
from ..se2 import compose, wrap_angle
from .icp_config import IcpConfig
from .icp_result import IcpResult
from .localize import localize
from .occlusion_rule import OcclusionFilter
from .acceptance_gate import AcceptanceGate
from .motion_noise import MotionNoise, largest_position_std
from .fusion_rule import CHI2_3_999
from .relocalize import Candidate, RelocalizationConfig, SearchInSteps, SearchRegion, relocalize


@dataclass(frozen=True)
class RecoveryConfig:
    """How a lost `Localizer` finds itself again.

    Attributes:
        search: settings of the global search.
        min_inlier_ratio: a hypothesis must explain at least this share of every scan (0..1].
        confirmations: scans in a row a single surviving hypothesis must explain before it is
            adopted (>= 1).
        max_hypotheses: most hypotheses followed at once (>= 1).
        margin: a hypothesis whose mean inlier ratio is more than this below the best's is
            dropped; closer ones are rivals and keep the localizer from choosing (0..1).
        local_radius: metres around the last pose searched before the whole plan (0: none).
        max_beyond: largest share of a scan's returns that may lie beyond the walls a
            hypothesis's place shows (a beam does not pass a wall) for it to be kept, in (0, 1]
            (1: no check). In a crowd most returns are people, and some far place fits them to
            its walls while the walls behind them show through it: with 40 people around the
            robot a recovery adopted a place 21 m away before this check. Needs the occlusion
            rule's ray casting (the `Localizer`'s default).
        search_nodes: most branch-and-bound nodes of a search scored in one update (>= 1), so
            that an update never stalls: about a microsecond each on the real logs' plans (a
            whole-plan search of a 30 x 100 m building scores one to four million). None (the
            default): each search runs to its end within the update that starts it. Spread over
            updates, a search ends with an older scan, and its places, followed with the odometry
            to the present, are aligned again with the current scan (`_found_again`); on a log
            whose scans are metres apart that is one chance per minute of driving where a search
            per update has one per scan (docs/benchmarks.md measures both on the real logs).
    """

    search: RelocalizationConfig = field(default_factory=RelocalizationConfig)
    min_inlier_ratio: float = 0.6
    confirmations: int = 3
    max_hypotheses: int = 5
    margin: float = 0.05
    local_radius: float = 3.0
    max_beyond: float = 0.15
    search_nodes: int | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.search, RelocalizationConfig):
            raise TypeError(f"search must be a RelocalizationConfig, got {type(self.search).__name__}")
        ratio = real_number(self.min_inlier_ratio, "min_inlier_ratio")
        if not 0.0 < ratio <= 1.0:
            raise ValueError(f"min_inlier_ratio must be in (0, 1], got {self.min_inlier_ratio!r}")
        whole_number(self.confirmations, "confirmations", 1, 1000)
        whole_number(self.max_hypotheses, "max_hypotheses", 1, 100)
        if self.search_nodes is not None:
            whole_number(self.search_nodes, "search_nodes", 1)
        margin = real_number(self.margin, "margin")
        if not 0.0 <= margin <= 1.0:
            raise ValueError(f"margin must be in [0, 1], got {self.margin!r}")
        beyond = real_number(self.max_beyond, "max_beyond")
        if not 0.0 < beyond <= 1.0:
            raise ValueError(f"max_beyond must be in (0, 1], got {self.max_beyond!r}")
        radius = real_number(self.local_radius, "local_radius")
        if not (math.isfinite(radius) and radius >= 0.0):
            raise ValueError(f"local_radius must be a finite number >= 0 metres, got {self.local_radius!r}")


@dataclass
class Hypothesis:
    """A place the robot may be: its latest fit, how many scans in a row it explained and the sum
    of their inlier ratios."""

    pose: Pose
    result: IcpResult
    streak: int
    total: float

    @property
    def mean_inlier_ratio(self) -> float:
        """Mean inlier ratio over the scans this hypothesis explained."""
        return self.total / self.streak


@dataclass
class Recovery:
    """The state of a recovery in progress (see the module documentation)."""

    plan: PlanMap
    config: RecoveryConfig
    icp: IcpConfig
    gate: AcceptanceGate
    occlusion: OcclusionFilter | None = None
    motion_noise: MotionNoise = field(default_factory=MotionNoise)
    hypotheses: list[Hypothesis] = field(default_factory=list)
    beyond_shares: deque[float] = field(default_factory=lambda: deque(maxlen=BEYOND_WINDOW))
    searches: int = 0
    # The search cycle in progress: the regions still to search (None: the whole plan) and the
    # search running, with the odometry motion since its scan and that motion's covariance.
    _regions: list[SearchRegion | None] | None = None
    _running: tuple[SearchInSteps, Pose, NDArray[np.float64]] | None = None

    def step(self, scan: NDArray[np.float64], motion: Pose, last_pose: Pose) -> Hypothesis | None:
        """Feeds one scan, the odometry motion since the previous one and the pose the localizer
        predicts (T_map_base); returns the hypothesis to adopt, or None while the robot is not
        found yet."""
        followed = bool(self.hypotheses)
        self.hypotheses = [h for h in (self._follow(h, scan, motion) for h in self.hypotheses) if h is not None]
        # When the last hypotheses are dropped, the next scan searches again.
        if self.searching or not followed:
            self._search(scan, motion, last_pose)
        if self.hypotheses:
            best = max(h.mean_inlier_ratio for h in self.hypotheses)
            self.hypotheses = [h for h in self.hypotheses if h.mean_inlier_ratio >= best - self.config.margin]
        if (not self.searching and len(self.hypotheses) == 1
                and self.hypotheses[0].streak >= self.config.confirmations):
            found = self.hypotheses[0]
            self.hypotheses = []
            return found
        return None

    def coast(self, motion: Pose) -> None:
        """A scan too small to align while lost: the hypotheses, and the odometry motion since
        the running search's scan, follow `motion` alone."""
        self.hypotheses = [Hypothesis(compose(h.pose, motion), h.result, h.streak, h.total) for h in self.hypotheses]
        if self._running is not None:
            steps, since, spread = self._running
            self._running = (steps, compose(since, motion), self.motion_noise.propagate(spread, since, motion))

    def clear(self) -> None:
        """Forgets every hypothesis and any search in progress (the pose was given or found)."""
        self.hypotheses = []
        self._regions, self._running = None, None

    @property
    def searching(self) -> bool:
        """Whether a search cycle is in progress (its searches spread over updates)."""
        return self._regions is not None

    def _search(self, scan: NDArray[np.float64], motion: Pose, last_pose: Pose) -> None:
        """One update's share of the search cycle (see the module documentation): the running
        search, or the next region's with this scan, scores up to `search_nodes`; the places a
        search that ends found, followed with the odometry since its scan, join the hypotheses
        (which are followed while the cycle goes on, but adopted only after it)."""
        if self._regions is None:
            self._regions = [None]
            if self.config.local_radius > 0.0:
                self._regions.insert(0, SearchRegion(last_pose, self.config.local_radius, math.pi))
        if self._running is None and self.config.search_nodes is None:
            # Every search of the cycle within this update, with this scan.
            while self._regions is not None:
                self._search_step(scan, motion)
            return
        self._search_step(scan, motion)

    def _search_step(self, scan: NDArray[np.float64], motion: Pose) -> None:
        """Advances the running search (or starts the next region's with `scan`) by
        `search_nodes`; when it ends, its places join the hypotheses, and when it was the cycle's
        last, the cycle ends."""
        assert self._regions is not None
        if self._running is None:
            self.searches += 1
            region = self._regions.pop(0)
            self._running = (SearchInSteps(scan, self.plan, region=region, config=self.config.search,
                                           max_candidates=self.config.max_hypotheses), (0.0, 0.0, 0.0),
                             np.zeros((3, 3)))
        else:
            steps, since, spread = self._running
            self._running = (steps, compose(since, motion), self.motion_noise.propagate(spread, since, motion))
        steps, since, spread = self._running
        search = steps.advance(self.config.search_nodes or _WHOLE_SEARCH)
        if search is None:
            return
        self._running = None
        for c in search.candidates:
            if c.inlier_ratio < self.config.min_inlier_ratio or self._contradicted(steps.scan, c.pose):
                continue
            found = self._found_again(scan, c, since, spread)
            if found is not None and not any(_same(found.pose, h.pose) for h in self.hypotheses):
                self.hypotheses.append(found)
        if not self._regions:
            self._regions = None
            self.hypotheses.sort(key=lambda h: (-h.streak, -h.mean_inlier_ratio))
            self.hypotheses = self.hypotheses[:self.config.max_hypotheses]

    def _found_again(self, scan: NDArray[np.float64], candidate: Candidate, since: Pose,
                     spread: NDArray[np.float64]) -> Hypothesis | None:
        """The hypothesis a search's candidate gives now: at once when the search ended with the
        scan it started with (`since` the identity); otherwise the odometry moved the robot by
        `since` in the meantime, with the covariance `spread`, which over many updates outgrows
        ICP's basin: the candidate moved by `since` is aligned with this `scan` (ICP), and where
        that fit explains less than `min_inlier_ratio` of it or lands farther than
        `sqrt(CHI2_3_999)` standard deviations of that motion (plus ICP's reach), the region
        within that bound is searched; the fit, if it explains at least `min_inlier_ratio` of the
        scan, is the hypothesis. (The candidate passed the check against returns through its
        walls on its own scan; the hypothesis meets it again when followed.)"""
        if since == (0.0, 0.0, 0.0):
            return Hypothesis(candidate.pose, candidate.result, 1, candidate.inlier_ratio)
        k = math.sqrt(CHI2_3_999)
        radius = min(self.config.local_radius, k * largest_position_std(spread) + self.icp.max_correspondence_distance)
        yaw = min(math.pi, k * math.sqrt(max(float(spread[2, 2]), 0.0)) + 2.0 * self.config.search.max_angular_step)
        here = compose(candidate.pose, since)
        fit = localize(scan, self.plan, here, self.icp)
        metres, radians = _moved(fit.pose, here)
        if fit.inlier_ratio < self.config.min_inlier_ratio or metres > radius or radians > yaw:
            again = relocalize(scan, self.plan, region=SearchRegion(here, radius, yaw), config=self.config.search,
                               max_candidates=1).best
            if again is None:
                return None
            fit = again.result
        if fit.inlier_ratio < self.config.min_inlier_ratio:
            return None
        return Hypothesis(fit.pose, fit, 1, fit.inlier_ratio)

    def _follow(self, hypothesis: Hypothesis, scan: NDArray[np.float64], motion: Pose) -> Hypothesis | None:
        predicted = compose(hypothesis.pose, motion)
        result = localize(scan, self.plan, predicted, self.icp)
        if (result.inlier_ratio < self.config.min_inlier_ratio or self.gate.rejection(result, predicted)
                or self._contradicted(scan, result.pose)):
            return None
        return Hypothesis(result.pose, result, hypothesis.streak + 1, hypothesis.total + result.inlier_ratio)


    def _contradicted(self, scan: NDArray[np.float64], pose: Pose) -> bool:
        """Whether more of the scan's returns lie beyond the walls seen from `pose` than
        `beyond_limit` allows (False without an occlusion filter)."""
        if self.occlusion is None or self.config.max_beyond >= 1.0:
            return False
        _, beyond = self.occlusion.classify(scan, pose)
        return float(np.mean(beyond)) > self.beyond_limit

    @property
    def beyond_limit(self) -> float:
        """The largest share of a scan's returns that may pass a place's walls: `max_beyond`, or
        what the scans the localizer tracked soundly showed at their own poses, when more (the
        `BEYOND_QUANTILE` of their last `BEYOND_WINDOW`). In a drawn plan beams do not pass walls;
        in a SLAM map they pass sparse cells (chair legs, noise, glass): at the reference poses of
        real logs a median of 11-38 % of the returns lay beyond the first occupied cell, and a
        fixed 15 % refused the true place on most scans."""
        return max(self.config.max_beyond, self.beyond_seen)

    @property
    def beyond_seen(self) -> float:
        """The `BEYOND_QUANTILE` of the shares of returns beyond the walls that the last
        `BEYOND_WINDOW` soundly tracked scans showed at their poses (0 before any)."""
        if not self.beyond_shares:
            return 0.0
        return float(np.quantile(np.fromiter(self.beyond_shares, dtype=np.float64), BEYOND_QUANTILE))

    def observe_beyond(self, share: float) -> None:
        """Records the share of a soundly tracked scan's returns beyond the walls seen from its pose."""
        self.beyond_shares.append(share)


BEYOND_WINDOW = 50
"""Soundly tracked scans whose share of returns beyond the walls `Recovery.beyond_limit` weighs."""
BEYOND_QUANTILE = 0.9
"""The quantile of those shares a place's own share may reach."""

_WHOLE_SEARCH = 2**62
"""A node budget no search reaches: `search_nodes=None` runs each search within one update."""


def _moved(a: Pose, b: Pose) -> tuple[float, float]:
    """(metres, radians) between two poses."""
    return math.hypot(a[0] - b[0], a[1] - b[1]), abs(wrap_angle(a[2] - b[2]))


def _same(a: Pose, b: Pose) -> bool:
    """Whether two hypotheses are one place (within 0.2 m and 5 degrees)."""
    return math.hypot(a[0] - b[0], a[1] - b[1]) < 0.2 and abs(wrap_angle(a[2] - b[2])) < math.radians(5.0)
