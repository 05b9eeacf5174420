"""Finding the robot again after the localizer is lost: global search, then confirmation.

While the `Localizer` is lost, every scan goes to a `Recovery`:

1. Without hypotheses, two searches start side by side (`_search`): one around the pose where
   the localizer lost track (a slip or a bad odometry step: any heading, and at each the drive
   since turned by that heading's error, within `local_radius` plus the drive's spread,
   `_near_region`) and one of the whole plan (`relocalize`: the robot was carried elsewhere). A
   search takes up to seconds on a large plan, so all the searches of an update score at most
   `search_nodes` of their branch and bound together (`SearchBudget`, half of it kept for the
   whole plan's search while it runs, `SearchInSteps`) and a search runs over as many updates as
   it needs: an update never stalls.
   When a search ends, every distinct candidate that explains at least `min_inlier_ratio` of its
   scan is followed through the scans of the updates since (kept while the search runs), as the
   hypotheses are followed (step 2), within the updates' budgets (`_catch_up`), and joins the
   hypotheses once it has caught up, each scan it explained counted in its streak. The search
   near the pose starts again while none of its places is followed. A search begins on the
   latest of the last two lost scans that overlaps a scan before it (`_start_sound`: not on a
   corrupted one, which no place explains), the later scans in its log.
2. On each next scan every hypothesis moves with the odometry and is aligned again (ICP from its
   prediction; for one that followed the odometry over scans it was not fitted to, a search
   within the odometry's spread since where ICP fails). A hypothesis whose fit explains less than
   `min_inlier_ratio` of the scan, or needs a correction beyond the acceptance gate, is dropped;
   so is one whose mean inlier ratio over the scans it has explained falls more than `margin`
   below the best hypothesis's, and one through whose walls more of those scans' returns pass,
   on average, than `Recovery.beyond_limit` allows (`max_beyond`, or what soundly tracked scans
   showed, when more; a candidate of the search, on its one scan). A scan that no hypothesis
   explains tells none of them from another (a corrupted scan, or one the plan does not show):
   the hypotheses follow the odometry over it, unless they missed the scan before too
   (`_follow_all`).
3. When both searches have ended and a single hypothesis has survived `confirmations` scans in a
   row, it is adopted. While several survive (a symmetric building), none is: the localizer stays
   lost and says so. When all are dropped, a new pair of searches starts.
4. A single hypothesis found near the last pose that has survived `confirmations` scans is
   adopted before the search of the whole plan ends when it explained them as well as sound
   tracking does (`_sure_nearby`): a robot whose odometry broke is back as soon as the search
   around it ends (on a 100 x 120 m plan the whole-plan search, spread over updates, ends 17-66
   scans later). But in an office some partial fit near the old pose explains a scan as well as
   that (adopted for good, 5 of 10 kidnapped robots were kept at such a place), so the place is on
   trial: the search of the whole plan goes on (`verify`), its places are followed beside the
   tracked one, and one that explains the next `confirmations` scans better by `margin` replaces
   it. A place on trial that the localizer loses again is given up with its search. The lost
   track, regained by a fit from the localizer's prediction (`regain`), is judged alike: on trial
   while the search of the whole plan goes on.

Poses are T_map_base; scans are base-frame points (metres).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections import deque
from dataclasses import dataclass, field
from statistics import NormalDist
from typing import Annotated

import numpy as np
from numpy.typing import NDArray
from pydantic.dataclasses import dataclass as pydantic_dataclass

from .._settings import SETTINGS, Real, Settings, Whole, instance_of
from .._validation import Pose
from ..plans.plan_map import PlanMap
from ..se2 import compose, wrap_angle
from .acceptance_gate import AcceptanceGate
from .continuity_rule import ContinuityRule
from .fusion_rule import CHI2_3_999
from .icp_config import IcpConfig
from .icp_result import IcpResult
from .localize import localize
from .motion_noise import MotionNoise, largest_position_std
from .occlusion_rule import OcclusionFilter
from .odometry_fault import fault_cost, fault_place, holds_as_fault, scan_cost
from .posterior_refinement import PosteriorRefinement
from .relocalize import Relocalization, RelocalizationConfig, SearchInSteps, SearchRegion
from .student_t import student_t_quantile


@pydantic_dataclass(frozen=True, config=SETTINGS)
class RecoveryConfig(Settings):
    """How a lost `Localizer` finds itself again.

    Attributes:
        search: settings of the global search.
        min_inlier_ratio: a hypothesis must explain at least this share of every scan (0..1].
        confirmations: scans a single surviving hypothesis must explain before it is adopted, in a
            row but for scans no place explains (`Recovery._follow_all`) (>= 1).
        max_hypotheses: most hypotheses followed at once (>= 1).
        margin: a hypothesis whose mean inlier ratio is more than this below the best's is
            dropped; closer ones are rivals and keep the localizer from choosing (0..1).
        local_radius: metres around the pose where the localizer lost track searched before the
            whole plan, at each heading around where the odometry's drive since, turned by that
            heading's error, ends, plus the drive's spread (or around the pose itself plus the
            path length since, when that is less; `Recovery._near_region`) (0: none).
        max_beyond: largest share of a scan's returns that may lie beyond the walls a
            hypothesis's place shows (a beam does not pass a wall) for it to be kept, on average
            over the scans it has explained, in (0, 1] (1: no check). In a crowd most returns are
            people, and some far place fits them to its walls while the walls behind them show
            through it: with 40 people around the robot a recovery adopted a place 21 m away
            before this check. Needs the occlusion
            rule's ray casting (the `Localizer`'s default).
        search_nodes: most branch-and-bound nodes all the searches of one update score together
            (`SearchBudget`; >= 1), so that an update never stalls: 20,000 take 2-3 ms early in
            a search on the real logs' plans, 14-21 ms late in one on freiburg-campus's 280 x
            270 m (docs/design.md; a node's cost grows with the plan, from memory). A search
            that needs more goes on over the next updates (the recovery's), or finds nothing
            (the search around a prediction, whose fit's own place then waits for the next
            scan). A whole-plan search of a 100 x 120 m building scores 0.3-0.7 million: places
            found with an older scan are followed through the scans since (`_catch_up`, each
            alignment counted as `ALIGNMENT_NODES` nodes), and a place found near the last pose
            that explains the scans as well as sound tracking did is adopted before it ends, on
            trial (`verify`).
            None: no node limit; with `search_time` None as well, each search runs to its end
            within the update that starts it (seconds on a large plan).
        search_time: seconds from the start of an update after which all its searches stop where
            they are, at their first check (every 1024 nodes) past it, and go on in the next update:
            the update's ceiling, whatever a node costs. A node's cost grows with the plan and with
            the machine's load, from memory: on freiburg-campus's 280 x 270 m plan, with another
            process streaming through memory, the updates of a place's trial made a 99th percentile
            of 26 ms without the ceiling and 17 ms with it (docs/benchmarks.md, "Other scan sets").
            15 ms leaves the work after the searches (alignments, records: 3-5 ms there) within a
            25 ms period. On the real logs' building plans the nodes end first (20,000 take 2-5 ms):
            the ceiling binds on a large plan or a slow or loaded machine, where a search then
            spreads over more updates. None: the nodes alone bound the searches, and a run with
            `search_spare_time` None as well is the same on any machine.
        search_spare_time: seconds from the start of an update within which the recovery's
            searches go on past `search_nodes` (None: never), within `search_time`. They score
            their `search_nodes` whatever the spare time, so a slow or loaded machine searches
            as with `search_nodes` alone; where nodes are cheap (a smaller plan, a faster
            machine) the update's spare time ends a search of the whole plan in fewer updates,
            before the odometry has carried its places beyond finding again. The update then
            takes up to this long (plus the alignments after the searches), and how soon the
            robot is found depends on the machine; None, with `search_time` None, keeps a run
            the same on any machine. Only the recovery's searches (while lost, or while a place
            is on trial) use it, not the searches around a prediction. (On fhw with one scan in
            five corrupted, 10 ms took the share of scans lost from about two thirds to a sixth,
            docs/design.md.)
    """

    search: Annotated[RelocalizationConfig, instance_of(RelocalizationConfig)] = field(
        default_factory=RelocalizationConfig
    )
    min_inlier_ratio: Annotated[float, Real(gt=0.0, le=1.0)] = 0.6
    confirmations: Annotated[int, Whole(ge=1, le=1000)] = 3
    max_hypotheses: Annotated[int, Whole(ge=1, le=100)] = 5
    margin: Annotated[float, Real(ge=0.0, le=1.0)] = 0.05
    local_radius: Annotated[float, Real(ge=0.0, unit="metres")] = 3.0
    max_beyond: Annotated[float, Real(gt=0.0, le=1.0)] = 0.15
    search_nodes: Annotated[int, Whole(ge=1)] | None = 20_000
    search_time: Annotated[float, Real(gt=0.0, le=3600.0, unit="seconds")] | None = 0.015
    search_spare_time: Annotated[float, Real(gt=0.0, le=3600.0, unit="seconds")] | None = 0.010


@dataclass
class SearchBudget:
    """The search nodes an update may still score (`RecoveryConfig.search_nodes`; None: no
    limit): every search of one update, around the prediction or by the recovery, draws on it.
    (A search may score three nodes past what it is given: an expansion scores four children.)"""

    left: int | None
    reserved: int = 0
    """Nodes kept for the recovery's search of the whole plan, which no other search may take
    (so that searches around a wrong prediction cannot starve it)."""
    until: float | None = None
    """`time.perf_counter()` at which the update's searches stop where they are
    (`RecoveryConfig.search_time`; None: no time limit). The other searches may use half of
    what is left of it while nodes are reserved for the whole plan's."""
    spare_until: float | None = None
    """`time.perf_counter()` until which the recovery's searches go on past the nodes
    (`RecoveryConfig.search_spare_time`; None: never), within `until`."""

    def spare_seconds(self) -> float:
        """Seconds of the update's spare time left for the recovery's searches (0.0: none)."""
        if self.spare_until is None:
            return 0.0
        end = self.spare_until if self.until is None else min(self.spare_until, self.until)
        return max(end - time.perf_counter(), 0.0)

    @property
    def free(self) -> int | None:
        """What the other searches may still score (None: no limit)."""
        return None if self.left is None else max(self.left - self.reserved, 0)

    def seconds(self, *, whole_plan: bool) -> float | None:
        """Seconds the whole plan's search (`whole_plan`), or another, may still spend (None: no
        limit; 0.0: none)."""
        if self.until is None:
            return None
        left = max(self.until - time.perf_counter(), 0.0)
        return left if whole_plan or self.reserved == 0 else left / 2.0

    def search(
        self,
        scan: NDArray[np.float64],
        plan: PlanMap,
        region: SearchRegion,
        config: RelocalizationConfig,
        max_candidates: int,
        *,
        whole_plan: bool = False,
    ) -> Relocalization | None:
        """`relocalize` of `scan` in `region` within what is `free` (all that is left for the
        re-searches of the whole plan's places, `whole_plan`): None when the search would score
        more (a search cut short proves nothing). Spends what it scored."""
        nodes = self.left if whole_plan else self.free
        seconds = self.seconds(whole_plan=whole_plan)
        if (nodes is not None and nodes <= 0) or seconds == 0.0:
            return None
        steps = SearchInSteps(scan, plan, region=region, config=config, max_candidates=max_candidates)
        found = steps.advance(_WHOLE_SEARCH if nodes is None else nodes, seconds)
        self.spend(steps.nodes)
        return found

    def spend(self, nodes: int) -> None:
        """Takes `nodes` scored from what is left."""
        if self.left is not None:
            self.left = max(self.left - nodes, 0)


@dataclass
class Hypothesis:
    """A place the robot may be: its latest fit, how many scans in a row it explained, the sum
    of their inlier ratios, whether the search around the last pose found it (`near`), and the
    sum over those scans of the shares of their returns beyond its walls (`beyond`), and whether
    it followed the odometry over the last scan because no place explained that one (`missed`:
    see `Recovery._follow_all`), and the covariance (3x3, map-frame x, y, yaw) of the odometry
    motion it followed since it was last fitted (`spread`: zero after a fit)."""

    pose: Pose
    result: IcpResult
    streak: int
    total: float
    near: bool = False
    beyond: float = 0.0
    missed: bool = False
    spread: NDArray[np.float64] = field(default_factory=lambda: np.zeros((3, 3)))

    @property
    def mean_inlier_ratio(self) -> float:
        """Mean inlier ratio over the scans this hypothesis explained."""
        return self.total / self.streak

    @property
    def mean_beyond(self) -> float:
        """Mean share of the returns beyond its walls over the scans this hypothesis explained."""
        return self.beyond / self.streak


@dataclass
class Recovery:
    """The state of a recovery in progress (see the module documentation)."""

    plan: PlanMap
    config: RecoveryConfig
    icp: IcpConfig
    gate: AcceptanceGate
    occlusion: OcclusionFilter | None = None
    motion_noise: MotionNoise = field(default_factory=MotionNoise)
    continuity: ContinuityRule = field(default_factory=ContinuityRule)
    refinement: PosteriorRefinement | None = None
    """The localizer's refinement: with its fault component, a place whose step ICP cannot
    follow is swept for an odometry fault (`_faulted`); None: it is dropped."""
    hypotheses: list[Hypothesis] = field(default_factory=list)
    beyond_shares: deque[float] = field(default_factory=lambda: deque(maxlen=BEYOND_WINDOW))
    explained_shares: deque[float] = field(default_factory=lambda: deque(maxlen=BEYOND_WINDOW))
    # `explained_seen` of the shares recorded so far (None: to be computed): every update reads it.
    _explained_bound: float | None = None
    searches: int = 0
    # The search cycle in progress (see `_search`): the search near the last pose and the search
    # of the whole plan, each with the odometry motion since its scan and that motion's covariance.
    _cycle: bool = False
    _near: _Run | None = None
    _whole: _Run | None = None
    # A place adopted before the whole plan was searched, on trial (see `verify`), and the inlier
    # ratios of the scans since aligned at the place the localizer tracks.
    _trial: bool = False
    budget: SearchBudget = field(default_factory=lambda: SearchBudget(None))
    _incumbent: deque[float] = field(default_factory=lambda: deque(maxlen=1000))
    # Where the localizer lost track (T_map_base), and the odometry's drive since.
    _lost_at: Pose | None = None
    _drive: _Drive = field(default_factory=lambda: _Drive())
    # The last lost updates, the latest last, for a search that starts (`_start_sound`).
    _recent: deque[_Lost] = field(default_factory=lambda: deque(maxlen=START_CHOICES + 1))
    # The last pose a tracked scan vouched for (`note_tracked`), and the odometry's drive since;
    # kept across `clear`.
    _vouched_at: Pose | None = None
    _since_vouched: _Drive = field(default_factory=lambda: _Drive())
    # Whether a place followed (or the tracked one, on trial) explained this update's scan.
    _explained: bool = False

    def step(
        self, scan: NDArray[np.float64], motion: Pose, last_pose: Pose, likelier: Pose | None = None
    ) -> Hypothesis | None:
        """Feeds one scan, the odometry motion since the previous one and the pose the localizer
        predicts (T_map_base); returns the hypothesis to adopt, or None while the robot is not
        found yet. A place on trial (see `verify`) that the localizer lost again is given up with
        its search: a new cycle starts from the searches near the last pose.

        Where track was lost, for the search near it (`_near_region`): at the first lost update,
        `likelier` when given (a place the scans preferred to the track), else the last pose a
        tracked scan vouched for (`note_tracked`), with the odometry's drive since, else
        `last_pose`. The updates between the last vouched pose and the loss may have followed a
        broken odometry step with fits that explain too little to vouch for anything, and the
        pose they leave can be metres off (fhw's map at 0.1 m: 11.8 m when the loss was
        declared)."""
        if self._trial:
            self.clear()
        if self._lost_at is None:
            if likelier is not None:
                self._lost_at, self._drive = likelier, _Drive()
            elif self._vouched_at is not None:
                self._lost_at, self._drive = self._vouched_at, self._since_vouched.copy()
                self._drive.add(motion, self.motion_noise)
            else:
                self._lost_at, self._drive = last_pose, _Drive()
        else:
            self._drive.add(motion, self.motion_noise)
        kept = scan.copy()  # the caller may reuse its buffer for the next scan
        self._recent.append(_Lost(kept, motion, self._drive.copy()))
        followed = bool(self.hypotheses)
        self._follow_all(scan, motion)
        # When the last hypotheses are dropped, the next scan searches again.
        if self.searching or not followed:
            self._search(kept, motion, last_pose)
        found = self._confirmed()
        if found is not None:
            if not self.searching:
                self.clear()
                return found
            if self._sure_nearby(found):
                self._begin_trial()
                return found
        return None

    def verify(self, scan: NDArray[np.float64], motion: Pose, pose: Pose, *, begin: bool = False) -> Hypothesis | None:
        """While a place adopted before the whole plan was searched is on trial (`on_trial`): one
        update's share of that search, with the localizer tracking soundly at `pose` (T_map_base,
        after this update). The places it finds, other than `pose`, are followed as rivals; the
        place the localizer tracks is aligned again with the recovery's settings, so that both
        are judged alike. A single rival that has explained `confirmations` scans in a row, and on
        them more of the scans than the tracked place by the recovery's `margin`, is returned to
        be adopted (the trial is over: the robot had been carried away from a place that looks
        like the one adopted); when the search has ended and no rival is left, the trial is over
        and None is returned, as while it goes on. `begin`: the search of the whole plan begins with
        this scan (a tracked pose in doubt, `doubt`)."""
        incumbent = localize(scan, self.plan, pose, self.icp).inlier_ratio
        if self._follow_all(scan, motion, explained_elsewhere=incumbent >= self.config.min_inlier_ratio):
            self._incumbent.append(incumbent)
        if self.searching or begin:
            self._search(scan.copy(), motion, pose, near=False)  # the caller may reuse its buffer
        self.hypotheses = [h for h in self.hypotheses if not _same(h.pose, pose)]
        rival = self._confirmed()
        if rival is not None:
            same_scans = list(self._incumbent)[-rival.streak :]
            if rival.mean_inlier_ratio >= sum(same_scans) / len(same_scans) + self.config.margin:
                self.clear()
                return rival
        if not self.searching and not self.hypotheses:
            self.clear()
        return None

    def _follow_all(self, scan: NDArray[np.float64], motion: Pose, *, explained_elsewhere: bool = False) -> bool:
        """Every hypothesis followed to `scan` (`_follow`); those it drops are gone. A scan that
        none of them explains (nor, `explained_elsewhere`, the place the localizer tracks) tells
        them not apart: its likelihood under a mixture with a corrupted-scan component is that
        component's at every place, the same factor for all. The places then follow the odometry
        over it, their streaks unchanged (`Hypothesis.missed`), rather than end the recovery's
        work on one scan's word (on fhw with one corrupted scan in five, dropping them all kept
        the recovery searching for 98 scans); a place that missed the scan before is dropped, so
        that places the scans keep refuting do not linger. Returns whether the scan was weighed
        (False: the places followed the odometry over it); `_explained` says whether some place
        explained it (for the places a search that ends with this scan finds, `_advance`)."""
        self.hypotheses, explained, weighed = self._weighed(
            self.hypotheses, scan, motion, explained_elsewhere=explained_elsewhere
        )
        self._explained = explained_elsewhere or explained
        return weighed

    def _weighed(
        self, places: list[Hypothesis], scan: NDArray[np.float64], motion: Pose, *, explained_elsewhere: bool
    ) -> tuple[list[Hypothesis], bool, bool]:
        """`places` followed to `scan` as `_follow_all` follows the hypotheses: (the places kept,
        whether one of them explained the scan, whether the scan was weighed)."""
        followed = [self._follow(h, scan, motion) for h in places]
        explained = any(f is not None for f in followed)
        if places and not explained_elsewhere and not explained:
            return [self._coasted(h, motion, missed=True) for h in places if not h.missed], False, False
        return [f for f in followed if f is not None], explained, True

    def _coasted(self, hypothesis: Hypothesis, motion: Pose, *, missed: bool = False) -> Hypothesis:
        """`hypothesis` moved by the odometry's `motion` alone, with that motion's covariance
        added to its `spread` (`missed`: over a scan no place explained)."""
        return dataclasses.replace(
            hypothesis,
            pose=compose(hypothesis.pose, motion),
            missed=missed or hypothesis.missed,
            spread=self.motion_noise.propagate_checked(hypothesis.spread, hypothesis.pose, motion),
        )

    def _confirmed(self) -> Hypothesis | None:
        """Drops the hypotheses whose mean inlier ratio is more than `margin` below the best's;
        returns the one left when it is alone and has explained `confirmations` scans in a row."""
        self.hypotheses = _within_margin(self.hypotheses, self.config.margin)
        if len(self.hypotheses) == 1 and self.hypotheses[0].streak >= self.config.confirmations:
            return self.hypotheses[0]
        return None

    def doubt(self) -> None:
        """The track is kept only because the lost rule's bar is relaxed to what the track has
        learned of the plan (`LostDecision.doubted`): a share of the scans that a sparse map
        gives the right place and that a wrong place gives too. The tracked pose goes on trial,
        as a place adopted before the whole plan was searched does (`verify`): the whole plan is
        searched beside it, and a place that explains the next scans better by the `margin`
        replaces it; when the search ends with none, the trial is over. (On orebro's map, with the
        bars relaxed, a robot carried 8 m away was not declared lost in 25 scans, its fits at
        the old place explaining just above the relaxed bar.) The search begins with the scan
        `verify` is given next (`begin=True`)."""
        self.clear()
        self._trial = True
        self._incumbent.clear()

    def regain(self) -> None:
        """The lost state ended on the fit from the localizer's prediction
        (`LostDecision.regained`): the tracked pose is a place near where track was lost, judged
        as one the recovery finds there (`_sure_nearby`). While the search of the whole plan goes
        on, it is on trial (`verify`): a fit that explains 60 % of one scan is one scan's word, and
        a kidnapped robot's track, coasting on the odometry, finds such fits at look-alike places
        (docs/design.md). When that search has ended (or none ran), nothing is left to weigh it
        against, and the recovery forgets its places."""
        if self._whole is None:
            self.clear()
        else:
            self._begin_trial()

    def _begin_trial(self) -> None:
        """A place adopted while the search of the whole plan goes on: on trial (`verify`), that
        search's places to be weighed against it from the next scan, the places followed so far and
        the search near the last pose given up."""
        self.hypotheses, self._trial, self._near = [], True, None
        self._incumbent.clear()

    @property
    def on_trial(self) -> bool:
        """Whether a place was adopted before the search of the whole plan ended, which goes on
        (see `verify`)."""
        return self._trial

    def _sure_nearby(self, hypothesis: Hypothesis) -> bool:
        """Whether a place found near the last pose may be adopted before the search of the whole
        plan has ended: the local search has ended, and over its `confirmations` scans the place
        explained the scans as well as a soundly tracked scan is explained (its mean share is
        above the lower bound `explained_seen` of the localizer's sound fits). A partial fit
        nearby (an office's walls explain 60 % of a scan from many places) explains less, and
        waits for the whole plan's places to be weighed against it; a robot whose odometry broke
        is back as soon as the searches near it end, not when a search of the whole plan does
        (minutes of driving on a large plan with the search spread over updates)."""
        return (
            hypothesis.near
            and self._whole is not None
            and self.explained_seen > 0.0
            and hypothesis.mean_inlier_ratio >= self.explained_seen
        )

    def new_update(self) -> SearchBudget:
        """A fresh `search_nodes` budget for the searches of the update that begins (returned)."""
        nodes, seconds, spare = self.config.search_nodes, self.config.search_time, self.config.search_spare_time
        reserved = nodes // 2 if nodes is not None and self._whole is not None else 0
        now = time.perf_counter()
        until = None if seconds is None else now + seconds
        spare_until = None if spare is None or nodes is None else now + spare
        self.budget = SearchBudget(nodes, reserved, until, spare_until)
        return self.budget

    def coast(self, motion: Pose) -> None:
        """A scan too small to align while lost: the hypotheses, and the odometry motion since
        the running search's scan, follow `motion` alone."""
        self.hypotheses = [self._coasted(h, motion) for h in self.hypotheses]
        if self._lost_at is not None:
            self._drive.add(motion, self.motion_noise)
            self._recent.append(_Lost(None, motion, self._drive.copy()))
        elif self._vouched_at is not None:  # on trial: the drive since the last vouched pose
            self._since_vouched.add(motion, self.motion_noise)
        for run in (self._near, self._whole):
            if run is not None:
                run.log.append((None, motion))

    def clear(self) -> None:
        """Forgets every hypothesis and any search in progress (the pose was given or found)."""
        self.hypotheses = []
        self._cycle, self._near, self._whole, self._trial = False, None, None, False
        self._lost_at, self._drive = None, _Drive()
        self._recent.clear()

    def note_tracked(self, motion: Pose, pose: Pose, *, vouched: bool) -> None:
        """An update tracked (not lost) to `pose` (T_map_base) after the odometry moved the robot
        by `motion`: the last pose a scan vouched for when `vouched` (a sound fit that explained
        at least `explained_seen` of its scan, a place adopted, a pose given), otherwise one more
        step of the odometry's drive since that pose."""
        if vouched:
            self._vouched_at, self._since_vouched = pose, _Drive()
        elif self._vouched_at is not None:
            self._since_vouched.add(motion, self.motion_noise)

    @property
    def searching(self) -> bool:
        """Whether a search cycle is in progress (its searches spread over updates)."""
        return self._cycle

    def _search(self, scan: NDArray[np.float64], motion: Pose, last_pose: Pose, near: bool = True) -> None:
        """One update's share of the search cycle, for `scan` (a copy the recovery keeps: the
        searches and their logs hold it): two searches run side by side, one around the
        pose where the localizer lost track (`_lost_at`, see `step`), any heading, at each the
        odometry's drive since turned by the heading's error, within `local_radius` plus the drive's
        spread (a slip or a bad odometry step, `_near_region`), and one of the whole plan (the robot
        was carried elsewhere). The search near the pose is not centred on the pose coasting on the
        odometry: after a fault beyond the sweep's window (fhw, 66 degrees) that pose runs off at
        the faulted heading, 2.5 m a scan, and a search that started on a corrupted scan and found
        nothing started again beyond the robot (with one scan in five a random cloud, 62 scans lost
        instead of 4). The search near the pose has the first claim on the update's budget but for
        the half reserved to the whole plan's search while that runs (`SearchBudget.reserved`, which
        the searches around the prediction cannot take either); when it ends and none of its places
        is followed, it starts again on the soundest of the last lost scans (`_start_sound`), over
        the region the drive up to that scan gives (a search that ended updates after its scan may
        find nothing where the robot is now).
        When the whole plan's search ends and its places have caught up (`_catch_up`), the cycle
        ends; the places of a search join the hypotheses when they have. With `near=False` (a place
        on trial) only the whole plan's search goes on."""
        if not self._cycle:
            self._cycle = True
            self._whole = self._start_sound(scan, None) if near else self._start(scan, None)
        else:
            for run in (self._near, self._whole):
                if run is not None:
                    run.log.append((scan, motion))
        if near and self._near is None and self.config.local_radius > 0.0 and not any(h.near for h in self.hypotheses):
            self._near = self._start_sound(scan, last_pose if self._lost_at is None else self._lost_at)
        # The whole plan's search, once it has ended, catches its places up first: its costly part
        # is done, and at one step an update behind five places they would never catch up.
        if self._whole is not None and self._whole.places is not None:
            if self._advance(self._whole, scan, self.budget.left, whole_plan=True):
                self._end_cycle()
        if self._near is not None and self._advance(self._near, scan, self.budget.free, whole_plan=False):
            self._near = None
        if self._whole is not None and self._advance(self._whole, scan, self.budget.left, whole_plan=True):
            self._end_cycle()
        # The update's spare time (`RecoveryConfig.search_spare_time`): the search near the pose
        # first, with half of it, then the whole plan's.
        spare = self.budget.spare_seconds()
        if (
            self._near is not None
            and spare > 0.0
            and self._advance(self._near, scan, None, whole_plan=False, seconds=spare / 2)
        ):
            self._near = None
        spare = self.budget.spare_seconds()
        if (
            self._whole is not None
            and spare > 0.0
            and self._advance(self._whole, scan, None, whole_plan=True, seconds=spare)
        ):
            self._end_cycle()

    def _start_sound(self, scan: NDArray[np.float64], lost_at: Pose | None) -> _Run:
        """A search near `lost_at` (T_map_base, see `step`; None: of the whole plan), begun on
        the scan of one of the last `START_CHOICES` lost updates that is likeliest sound
        (`_soundest`), over the region where the robot may have been then (`_near_region` with
        the drive up to that update); the updates after it go into the search's log, and its
        places are followed through them when it ends (`_catch_up`). A corrupted scan (a random
        cloud, a scan turned) overlaps nothing, and a search begun on one finds no place, or a
        wrong one: on fhw with one scan in five a random cloud, a search near the pose that
        started again on a cloud ended as the next cloud came and began on that one, and the
        robot stayed lost to the end of the log in 1 of 10 runs of a draw (docs/design.md); no
        place explains a cloud, so a search's bounds prune little on one. Without kept scans (a
        first update), the search begins on `scan`, the current update's."""
        recent = list(self._recent)
        chosen = self._soundest(recent)
        start = recent[chosen] if recent else None
        if start is None or start.scan is None:
            region = None if lost_at is None else self._near_region(lost_at, self._drive)
            return self._start(scan, region)
        region = None if lost_at is None else self._near_region(lost_at, start.drive)
        run = self._start(start.scan, region)
        run.log.extend((later.scan, later.motion) for later in recent[chosen + 1 :])
        return run

    def _soundest(self, recent: list[_Lost]) -> int:
        """The index in `recent` (the last lost updates, the latest last) of the scan a search is
        likeliest to find the robot with: the latest of the last `START_CHOICES` that overlaps a
        scan kept before it by at least `SOUND_OVERLAP` (`ContinuityRule.overlap`, from the
        odometry's motion between the two: over a corrupted scan between them too), else the
        latest. A sound scan overlaps its neighbours; a random cloud or a turned scan overlaps
        none."""
        latest = len(recent) - 1
        for k in range(latest, max(latest - START_CHOICES, 0), -1):
            scan = recent[k].scan
            if scan is None:
                continue
            motion: Pose = (0.0, 0.0, 0.0)
            for j in range(k - 1, -1, -1):
                motion = compose(recent[j + 1].motion, motion)
                earlier = recent[j].scan
                if earlier is not None and self.continuity.overlap(scan, earlier, motion) >= SOUND_OVERLAP:
                    return k
        return latest

    def _near_region(self, lost_at: Pose, drive: _Drive) -> SearchRegion:
        """Where the robot may be, lost at `lost_at` (T_map_base, see `step`) and driven by the
        odometry since by `drive` (`_drive` for the current update), when what broke is the
        odometry's heading (a slip, a bad step) at or after that pose: any heading, and at each
        the drive turned by the heading's error, within `local_radius` (the slip's own
        displacement) plus `sqrt(CHI2_3_999)` standard deviations of the drive's position spread
        at that heading (`_Drive.spread_given_heading`); or anywhere within `local_radius` plus
        the path length since, when that is the smaller reach (a turn in place). A heading fault
        moves the robot along a ring around the lost pose, not anywhere within the disk of its
        path length: on fhw after 29 m of driving the squares had a half-width of 12.8 m where
        the disk's radius would have been 32 m."""
        base = self.config.local_radius
        reach = math.sqrt(CHI2_3_999) * largest_position_std(drive.spread_given_heading())
        if reach >= drive.path:
            return SearchRegion(lost_at, base + drive.path, math.pi)
        x, y, yaw = lost_at
        dx, dy, turned = drive.motion
        c, s = math.cos(yaw), math.sin(yaw)
        return SearchRegion(
            (x, y, wrap_angle(yaw + turned)), base + reach, math.pi, lever=(c * dx - s * dy, s * dx + c * dy)
        )

    def _end_cycle(self) -> None:
        """The whole plan's search has ended: so has the cycle; the best `max_hypotheses` places
        are followed."""
        self._whole = None
        self._cycle, self._near = False, None
        self.hypotheses.sort(key=lambda h: (-h.streak, -h.mean_inlier_ratio))
        self.hypotheses = self.hypotheses[: self.config.max_hypotheses]

    def _start(self, scan: NDArray[np.float64], region: SearchRegion | None) -> _Run:
        """A search of `region` (None: the whole plan) for `scan`, no node scored yet."""
        self.searches += 1
        return _Run(
            SearchInSteps(
                scan, self.plan, region=region, config=self.config.search, max_candidates=self.config.max_hypotheses
            )
        )

    def _advance(
        self,
        run: _Run,
        scan: NDArray[np.float64],
        nodes: int | None,
        *,
        whole_plan: bool,
        seconds: float | None = None,
    ) -> bool:
        """Scores up to `nodes` (None: no limit) of `run`, within the update's time for it
        (`SearchBudget.seconds`, or `seconds` of the update's spare time), drawn from the update's
        budget; once the search has ended, its places that explain at least `min_inlier_ratio`
        of its scan, without more returns beyond their walls than `beyond_limit` allows, are
        followed through the updates since its scan within what is left (`_catch_up`), and join
        the hypotheses when they have caught up with `scan`. Returns whether they have."""
        if seconds is None:
            seconds = self.budget.seconds(whole_plan=whole_plan)
        if (nodes is not None and nodes <= 0) or seconds == 0.0:
            return False
        deadline = None if seconds is None else time.perf_counter() + seconds
        if run.places is None:
            before = run.steps.nodes
            search = run.steps.advance(_WHOLE_SEARCH if nodes is None else nodes, seconds)
            scored = run.steps.nodes - before
            self.budget.spend(scored)
            if search is None:
                return False
            if nodes is not None:
                nodes -= scored
            near = run.steps.region is not None
            run.places = []
            for c in search.candidates:
                if c.inlier_ratio < self.config.min_inlier_ratio:
                    continue
                beyond = self._beyond_share(run.steps.scan, c.pose)
                if beyond <= self.beyond_limit:
                    run.places.append(Hypothesis(c.pose, c.result, 1, c.inlier_ratio, near, beyond))
        return self._catch_up(run, nodes, deadline)

    def _catch_up(self, run: _Run, nodes: int | None, deadline: float | None) -> bool:
        """Follows the places of `run`'s ended search through the updates since its scan
        (`_Run.log`), as the hypotheses are followed (`_weighed`), each alignment counted as
        `ALIGNMENT_NODES` of `nodes` (None: no limit) and of the update's budget, until
        `deadline` (`time.perf_counter()`; None: none); returns whether they have caught up with
        the current update's scan, and then they join the hypotheses. A search spread over
        updates ends after the robot drove on, on a large plan tens of metres: a place moved by
        the odometry alone over that drive lands metres from where the place is now, beyond the
        reach of ICP and of a search within the drive's spread (fed 80 updates after a kidnap, intel's
        robot was found in 3 of 5 runs so, in 5 of 5 followed; docs/benchmarks.md), while followed scan
        by scan it stays within ICP's reach of each, and each scan it explains is one more in
        its streak: confirmed by the scans it explained while its search ran, a place alone is
        adopted as soon as its search ends. The last update's scan, when a followed place or
        the tracked one explained it (`_explained`), is weighed with that (`_follow_all`)."""
        places = run.places
        assert places is not None
        while places and run.caught < len(run.log):
            cost = ALIGNMENT_NODES * len(places)
            if (nodes is not None and nodes < cost) or (deadline is not None and time.perf_counter() >= deadline):
                run.places = places
                return False
            scan, motion = run.log[run.caught]
            last = run.caught == len(run.log) - 1
            if scan is None:
                places = [self._coasted(h, motion) for h in places]
            else:
                # What the step scored: its alignments, and the searches within a place's spread
                # where ICP failed (`_follow`), which draw on the update's budget themselves.
                left = self.budget.left
                places, explained, _ = self._weighed(places, scan, motion, explained_elsewhere=last and self._explained)
                self._explained = self._explained or (last and explained)
                places = _within_margin(places, self.config.margin)
                self.budget.spend(cost)
                if nodes is not None:
                    nodes -= cost if left is None or self.budget.left is None else max(cost, left - self.budget.left)
            run.caught += 1
        run.places, run.log = [], []
        for h in places:
            if not any(_same(h.pose, other.pose) for other in self.hypotheses):
                self.hypotheses.append(h)
        return True

    def _region(self, here: Pose, spread: NDArray[np.float64]) -> SearchRegion:
        """Where a place the odometry puts at `here` with the covariance `spread` may be: within
        `sqrt(CHI2_3_999)` standard deviations of the spread plus ICP's reach (positions, within
        `local_radius`) and two of the search's heading steps (headings)."""
        k = math.sqrt(CHI2_3_999)
        radius = min(self.config.local_radius, k * largest_position_std(spread) + self.icp.max_correspondence_distance)
        yaw = min(math.pi, k * math.sqrt(max(float(spread[2, 2]), 0.0)) + 2.0 * self.config.search.heading_step)
        return SearchRegion(here, radius, yaw)

    def _searched_within(self, scan: NDArray[np.float64], region: SearchRegion, near: bool) -> IcpResult | None:
        """The best place for `scan` in `region`, searched within the update's budget (the whole
        plan's share unless `near`), if it explains at least `min_inlier_ratio` of the scan."""
        searched = self.budget.search(scan, self.plan, region, self.config.search, 1, whole_plan=not near)
        best = None if searched is None else searched.best
        if best is None or best.inlier_ratio < self.config.min_inlier_ratio:
            return None
        return best.result

    def _follow(self, hypothesis: Hypothesis, scan: NDArray[np.float64], motion: Pose) -> Hypothesis | None:
        """The hypothesis moved by `motion` and aligned with `scan`, or None when it is dropped: the
        fit from the moved place explains less than `min_inlier_ratio` of the scan or needs a
        correction beyond the gate, and no odometry fault explains the step (`_faulted`), or the
        scans it has explained, this one included, show more of their returns beyond its walls on
        average than `beyond_limit` allows. The gate bounds what one odometry step may need
        corrected; a place that followed the odometry over scans it was not fitted to
        (`Hypothesis.spread`: a scan no place explained, or one too small to align) carries the
        error of every step since, and where ICP from it fails it is searched for within that spread
        moved by `motion` (`_searched_within`), as a search's candidate is found again after updates
        (on fhw with one scan in five a random cloud, the true place, followed over a cloud, came
        out 14 degrees off; ICP from there explained 40 % of the next scan, the place was dropped,
        and the recovery searched on for 20 more scans). The evidence of returns through walls is
        pooled over the scans that are to confirm the place, as its inlier ratios are: in a SLAM map
        beams pass sparse cells at the true place too, by an amount that varies from scan to scan
        (on freiburg-campus one scan in a run of well explained ones put the true place over the
        limit, and the recovery dropped it three times before it held)."""
        predicted = compose(hypothesis.pose, motion)
        fit = localize(scan, self.plan, predicted, self.icp)
        result: IcpResult | None = fit
        if fit.inlier_ratio < self.config.min_inlier_ratio or self.gate.rejection(fit, predicted):
            if not hypothesis.spread.any():  # fitted on the last scan: the gate bounds one step
                result = self._faulted(scan, predicted, motion, fit)
            else:
                spread = self.motion_noise.propagate_checked(hypothesis.spread, hypothesis.pose, motion)
                result = self._searched_within(scan, self._region(predicted, spread), hypothesis.near)
        if result is None:
            return None
        beyond = hypothesis.beyond + self._beyond_share(scan, result.pose)
        if beyond / (hypothesis.streak + 1) > self.beyond_limit:
            return None
        return Hypothesis(
            result.pose,
            result,
            hypothesis.streak + 1,
            hypothesis.total + result.inlier_ratio,
            hypothesis.near,
            beyond,
        )

    def _faulted(self, scan: NDArray[np.float64], predicted: Pose, motion: Pose, held: IcpResult) -> IcpResult | None:
        """Where a place the odometry's `motion` moved to `predicted` (T_map_base) is if that
        step faulted, as the tracking's max-mixture motion model has it
        (`planicp.tracking.odometry_fault`): ICP from the place of lowest cost the sweep within
        the fault model reaches (`fault_place`), when the scan prefers that place to `held` (the
        fit from `predicted`) by more than the fault costs (its cost in the likelihood field plus
        `F` below `held`'s), and the fit explains at least `min_inlier_ratio` of the scan, passes
        the gate's bars on the fit and stays within the fault model. None without the
        refinement's fault component. (A place found by a search is followed through the updates
        since its scan, `_catch_up`; on fhw, whose odometry turns 50-70 degrees too far after a
        long pause, with every third scan tracked, a fault two scans on dropped the true place
        the near search had found at the first lost update, and the robot was found again 16
        updates later. Without the preference by `F`, on freiburg-campus with thrice the
        odometry noise, a place 1.4 m off that explained 62 % of a scan was kept, and on
        belgioioso a kidnapped robot was not found within 25 updates.)"""
        rule = self.refinement
        if rule is None or not rule.weighs_faults:
            return None
        tolerance = self.gate.max_translation_jump
        found = fault_place(scan, predicted, self.plan, rule, motion, tolerance)
        if found is None:
            return None
        if found[1] + fault_cost(rule.fault_probability) >= scan_cost(scan, held.pose, self.plan, rule):
            return None  # the scan does not pay for the fault
        fit = localize(scan, self.plan, found[0], self.icp)
        if fit.inlier_ratio < self.config.min_inlier_ratio or not holds_as_fault(
            fit, predicted, motion, rule, self.gate
        ):
            return None
        return fit

    def _beyond_share(self, scan: NDArray[np.float64], pose: Pose) -> float:
        """The share of the scan's returns that lie beyond the walls seen from `pose` (0 without
        an occlusion filter, or with `max_beyond` 1: no check)."""
        if self.occlusion is None or self.config.max_beyond >= 1.0:
            return 0.0
        _, beyond = self.occlusion.classify(scan, pose)
        return float(np.mean(beyond)) if len(beyond) else 0.0

    def _contradicted(self, scan: NDArray[np.float64], pose: Pose) -> bool:
        """Whether more of the scan's returns lie beyond the walls seen from `pose` than
        `beyond_limit` allows (False without an occlusion filter)."""
        return self._beyond_share(scan, pose) > self.beyond_limit

    @property
    def beyond_limit(self) -> float:
        """The largest share of a scan's returns that may pass a place's walls: `max_beyond`, or
        what the scans the localizer tracked soundly showed at their own poses, when more: the
        mean of their last `BEYOND_WINDOW` shares plus `BEYOND_SIGMAS` standard deviations (a
        place beyond that is, for a normal spread, less likely than 1 in 700 to be where they
        were). In a drawn plan beams do not pass walls; in a SLAM map they pass sparse cells
        (chair legs, noise, glass): at the reference poses of real logs a median of 11-38 % of
        the returns lay beyond the first occupied cell, and a fixed 15 % refused the true place
        on most scans."""
        return max(self.config.max_beyond, self.beyond_seen)

    @property
    def beyond_seen(self) -> float:
        """The upper bound of the prediction interval, at the one-sided level of `BEYOND_SIGMAS`
        normal standard deviations, for the share of returns beyond the walls of the next soundly
        tracked scan, from the shares the last `BEYOND_WINDOW` such scans showed at their poses:
        mean + t * s * sqrt(1 + 1/n), with `s` their sample standard deviation and `t` Student's
        quantile for n - 1 degrees of freedom (0 before two scans). Few scans say little about the
        spread, and the bound is wide: 5.9 sample deviations above the mean after 6 sound scans, 3.2
        after 50. (On fhw,
        whose odometry broke on its 7th scan, mean + 3 standard deviations of 6 scans, 34 %,
        refused the true place, found by the search with 82-93 % of its returns within 3 cm of
        the plan, for its 46 %.)"""
        interval = _prediction_interval(self.beyond_shares)
        return 0.0 if interval is None else min(1.0, interval[0] + interval[1])

    def observe_beyond(self, share: float) -> None:
        """Records the share of a soundly tracked scan's returns beyond the walls seen from its pose."""
        self.beyond_shares.append(share)

    def observe_explained(self, inlier_ratio: float) -> None:
        """Records the share of a soundly tracked scan's returns its fit explained (inliers over
        the whole scan)."""
        self.explained_shares.append(inlier_ratio)
        self._explained_bound = None

    @property
    def explained_seen(self) -> float:
        """The lower bound of the prediction interval, at the one-sided level of `BEYOND_SIGMAS`
        normal standard deviations, for the share of its returns the fit of the next soundly
        tracked scan explains, from the shares the last `BEYOND_WINDOW` such scans' fits
        explained: mean - t * s * sqrt(1 + 1/n), as `beyond_seen` (0 before two scans, and never
        below 0). How poorly the plan may explain this robot's scans where the localizer is right.
        The share varies with the part of the building the robot is in, and a place found after
        the track broke is judged by scans of another part than the sound ones: on fhw the
        window's 10th percentile (0.83), the bar before, refused the true place, followed for 11
        scans at a mean of 0.81, where sound tracking of those scans explained 0.79. In the
        simulated office the bound is 0.48-0.86 after 10 s of tracking, and kidnapped robots are
        found again as with the percentile (docs/benchmarks.md)."""
        if self._explained_bound is None:
            interval = _prediction_interval(self.explained_shares)
            self._explained_bound = 0.0 if interval is None else max(0.0, interval[0] - interval[1])
        return self._explained_bound

    @property
    def explained_bar(self) -> float | None:
        """`explained_seen` once two soundly tracked scans have been recorded (None before): the
        share of its scan below which the acceptance gate and the lost rule stop trusting a fit
        on this plan, where that is lower than theirs (`AcceptanceGate.relaxed_to`,
        `LostRule.relaxed_to`). Only fits that pass the bars as set are recorded (the
        `Localizer`'s bookkeeping), so that a fit the relaxed bars let through cannot lower them
        further. The recovery's own `min_inlier_ratio` is not relaxed: a place is adopted only
        on scans it explains well."""
        return self.explained_seen if len(self.explained_shares) >= 2 else None


@dataclass
class _Drive:
    """The odometry's drive from a pose: its path length (metres), its motion (in the frame of
    that pose) and the motion's covariance (`MotionNoise` along the drive)."""

    path: float = 0.0
    motion: Pose = (0.0, 0.0, 0.0)
    spread: NDArray[np.float64] = field(default_factory=lambda: np.zeros((3, 3)))

    def add(self, motion: Pose, noise: MotionNoise) -> None:
        """The robot moved by `motion` since the last update."""
        self.path += math.hypot(motion[0], motion[1])
        self.spread = noise.propagate_checked(self.spread, self.motion, motion)
        self.motion = compose(self.motion, motion)

    def spread_given_heading(self) -> NDArray[np.float64]:
        """The covariance of the drive's end position given its heading (the position block's
        Schur complement; heading entries zero): what is left of the position's spread at each
        heading a search sweeps. A heading error early in the drive turns the whole rest of it,
        and a search over every heading places each heading's square where that turn puts it;
        counted as position spread, one 129-degree odometry step of fhw (a 0.11 rad deviation)
        widened the square by 12 m after 26 m of driving."""
        spread = self.spread.copy()
        yaw = float(spread[2, 2])
        if yaw > 0.0:
            spread[:2, :2] -= np.outer(spread[:2, 2], spread[2, :2]) / yaw
        spread[2, :] = 0.0
        spread[:, 2] = 0.0
        return spread

    def copy(self) -> _Drive:
        """An independent copy."""
        return _Drive(self.path, self.motion, self.spread.copy())


@dataclass
class _Lost:
    """A lost update, for a search that starts (`Recovery._start_sound`): its scan (a copy;
    None: one too small to align), the odometry motion since the update before, and the drive
    from where the localizer lost track to it."""

    scan: NDArray[np.float64] | None
    motion: Pose
    drive: _Drive


@dataclass
class _Run:
    """A search spread over updates: its steps; the updates since its scan, each the scan (None:
    one too small to align) and the odometry motion since the update before (`log`, the last
    one the current update's); and once the search has ended, its places (`places`) followed
    through the first `caught` of those updates (`Recovery._catch_up`)."""

    steps: SearchInSteps
    log: list[tuple[NDArray[np.float64] | None, Pose]] = field(default_factory=list)
    places: list[Hypothesis] | None = None
    caught: int = 0


BEYOND_WINDOW = 50
"""Soundly tracked scans whose share of returns beyond the walls `Recovery.beyond_limit` weighs."""
BEYOND_SIGMAS = 3.0
"""The one-sided level of `Recovery.beyond_seen` and `Recovery.explained_seen`, in standard
deviations of a normal distribution (3: 1 in 741)."""

_NORMAL_CDF_AT_SIGMAS = NormalDist().cdf(BEYOND_SIGMAS)


def _prediction_interval(values: deque[float]) -> tuple[float, float] | None:
    """(mean, half-width) of the prediction interval for the next of `values` at the one-sided
    level of `BEYOND_SIGMAS` normal standard deviations: the half-width is t * s * sqrt(1 + 1/n),
    `s` the sample standard deviation and `t` Student's quantile for n - 1 degrees of freedom.
    None before two values."""
    n = len(values)
    if n < 2:
        return None
    a = np.fromiter(values, dtype=np.float64)
    t = student_t_quantile(_NORMAL_CDF_AT_SIGMAS, n - 1)
    return float(a.mean()), float(t * a.std(ddof=1) * math.sqrt(1.0 + 1.0 / n))


_WHOLE_SEARCH = 2**62
"""A node budget no search reaches: `search_nodes=None` runs each search within one update."""


START_CHOICES = 2
"""The last lost updates whose scan a search may begin on (`Recovery._start_sound`): one
corrupted scan among them leaves a sound one to begin on."""

SOUND_OVERLAP = 0.1
"""The share of a scan that must lie on a scan kept before it (`ContinuityRule.overlap`) for
`Recovery._soundest` to take it as sound. On the eight real logs of docs/benchmarks.md a random
cloud put in a scan's place overlaps the scan before by at most 0.03, and in 95 % of cases a
sound scan by 0.08-0.48 or more (the 5th percentile, per log); the rule's own bar for a
continuation (`min_overlap`, 0.7) is one that most sound scans two apart miss on those logs."""

ALIGNMENT_NODES = 2_000
"""Search nodes an alignment of a search's place is counted as, against an update's budget
(`Recovery._catch_up`): an alignment of a real log's scan, with its check against returns beyond
the walls, took as long as 1,600-3,700 nodes of a search of its plan (docs/benchmarks.md)."""


def _within_margin(places: list[Hypothesis], margin: float) -> list[Hypothesis]:
    """`places` but those whose mean inlier ratio is more than `margin` below the best's."""
    if not places:
        return places
    best = max(h.mean_inlier_ratio for h in places)
    return [h for h in places if h.mean_inlier_ratio >= best - margin]


def _same(a: Pose, b: Pose) -> bool:
    """Whether two hypotheses are one place (within 0.2 m and 5 degrees)."""
    return math.hypot(a[0] - b[0], a[1] - b[1]) < 0.2 and abs(wrap_angle(a[2] - b[2])) < math.radians(5.0)
