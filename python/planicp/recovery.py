"""Finding the robot again after the localizer is lost: global search, then confirmation.

While the `Localizer` is lost, every scan goes to a `Recovery`:

1. Without hypotheses, the scan is searched for around the last pose (within `local_radius`, any
   heading: a slip or a bad odometry step) and over the whole plan (`relocalize`: the robot was
   carried elsewhere); every distinct candidate of either that explains at least
   `min_inlier_ratio` of the scan becomes a hypothesis. (Searching only near the last pose first
   was tried: in an office some partial fit nearby always explains 60 % of a scan, and it kept
   the localizer from finding a robot carried to another room.)
2. On each next scan every hypothesis moves with the odometry and is aligned again (ICP from its
   prediction). A hypothesis whose fit explains less than `min_inlier_ratio` of the scan, or needs
   a correction beyond the acceptance gate, is dropped; so is one whose mean inlier ratio over the
   scans it has explained falls more than `margin` below the best hypothesis's, and one through
   whose walls more than `max_beyond` of the scan's returns pass (candidates of the search too).
3. When a single hypothesis has survived `confirmations` scans in a row, it is adopted. While
   several survive (a symmetric building), none is: the localizer stays lost and says so. When all
   are dropped, the next scan searches again.

Poses are T_map_base; scans are base-frame points (metres).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ._validation import Pose, real_number, whole_number
from .icp_config import IcpConfig
from .icp_result import IcpResult
from .localize import localize
from .occlusion_rule import OcclusionFilter
from .acceptance_gate import AcceptanceGate
from .plan_map import PlanMap
from .relocalize import RelocalizationConfig, SearchRegion, relocalize
from .se2 import compose, wrap_angle


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
    """

    search: RelocalizationConfig = field(default_factory=RelocalizationConfig)
    min_inlier_ratio: float = 0.6
    confirmations: int = 3
    max_hypotheses: int = 5
    margin: float = 0.05
    local_radius: float = 3.0
    max_beyond: float = 0.15

    def __post_init__(self) -> None:
        if not isinstance(self.search, RelocalizationConfig):
            raise TypeError(f"search must be a RelocalizationConfig, got {type(self.search).__name__}")
        ratio = real_number(self.min_inlier_ratio, "min_inlier_ratio")
        if not 0.0 < ratio <= 1.0:
            raise ValueError(f"min_inlier_ratio must be in (0, 1], got {self.min_inlier_ratio!r}")
        whole_number(self.confirmations, "confirmations", 1, 1000)
        whole_number(self.max_hypotheses, "max_hypotheses", 1, 100)
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
    hypotheses: list[Hypothesis] = field(default_factory=list)
    searches: int = 0

    def step(self, scan: NDArray[np.float64], motion: Pose, last_pose: Pose) -> Hypothesis | None:
        """Feeds one scan, the odometry motion since the previous one and the pose the localizer
        predicts (T_map_base); returns the hypothesis to adopt, or None while the robot is not
        found yet."""
        if self.hypotheses:
            self.hypotheses = [h for h in (self._follow(h, scan, motion) for h in self.hypotheses) if h is not None]
        else:
            self._search(scan, last_pose)
        if self.hypotheses:
            best = max(h.mean_inlier_ratio for h in self.hypotheses)
            self.hypotheses = [h for h in self.hypotheses if h.mean_inlier_ratio >= best - self.config.margin]
        if len(self.hypotheses) == 1 and self.hypotheses[0].streak >= self.config.confirmations:
            found = self.hypotheses[0]
            self.hypotheses = []
            return found
        return None

    def clear(self) -> None:
        """Forgets every hypothesis (the pose was given or found)."""
        self.hypotheses = []

    def _search(self, scan: NDArray[np.float64], last_pose: Pose) -> None:
        regions: list[SearchRegion | None] = [None]
        if self.config.local_radius > 0.0:
            regions.insert(0, SearchRegion(last_pose, self.config.local_radius, math.pi))
        found: list[Hypothesis] = []
        for region in regions:
            self.searches += 1
            search = relocalize(scan, self.plan, region=region, config=self.config.search,
                                max_candidates=self.config.max_hypotheses)
            for c in search.candidates:
                if (c.inlier_ratio >= self.config.min_inlier_ratio
                        and not any(_same(c.pose, h.pose) for h in found)
                        and not self._contradicted(scan, c.pose)):
                    found.append(Hypothesis(c.pose, c.result, 1, c.inlier_ratio))
        found.sort(key=lambda h: -h.total)
        self.hypotheses = found[:self.config.max_hypotheses]

    def _follow(self, hypothesis: Hypothesis, scan: NDArray[np.float64], motion: Pose) -> Hypothesis | None:
        predicted = compose(hypothesis.pose, motion)
        result = localize(scan, self.plan, predicted, self.icp)
        if (result.inlier_ratio < self.config.min_inlier_ratio or self.gate.rejection(result, predicted)
                or self._contradicted(scan, result.pose)):
            return None
        return Hypothesis(result.pose, result, hypothesis.streak + 1, hypothesis.total + result.inlier_ratio)


    def _contradicted(self, scan: NDArray[np.float64], pose: Pose) -> bool:
        """Whether more than `max_beyond` of the scan's returns lie beyond the walls seen from
        `pose` (False without an occlusion filter)."""
        if self.occlusion is None or self.config.max_beyond >= 1.0:
            return False
        _, beyond = self.occlusion.classify(scan, pose)
        return float(np.mean(beyond)) > self.config.max_beyond


def _same(a: Pose, b: Pose) -> bool:
    """Whether two hypotheses are one place (within 0.2 m and 5 degrees)."""
    return math.hypot(a[0] - b[0], a[1] - b[1]) < 0.2 and abs(wrap_angle(a[2] - b[2])) < math.radians(5.0)
