"""Scan-by-scan tracking: odometry predicts, ICP against the plan corrects, a gate decides."""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from .. import _core
from .._validation import Pose, as_pose, as_points
from ..plan_map import PlanMap
from ..se2 import between, compose, inverse, pose_to_matrix, wrap_angle
from .acceptance_gate import AcceptanceGate
from .degeneracy_rule import Degeneracy, DegeneracyRule, fuse_along_weak_axis
from .icp_config import IcpConfig
from .icp_result import IcpResult
from .localize import localize
from .lost_rule import LostDetector, LostRule
from .motion_noise import MotionNoise, largest_position_std
from .recovery import Hypothesis, Recovery, RecoveryConfig
from .occlusion_rule import OcclusionFilter, OcclusionRule
from .fusion_rule import CHI2_3_999, FusionRule
from .continuity_rule import ContinuityRule
from .relocalize import Relocalization, SearchRegion, prepare_search, relocalize


@dataclass(frozen=True)
class Estimate:
    """The outcome of one `Localizer.update`.

    Attributes:
        pose: (x, y, yaw) of the robot in the map (T_map_base) after this update.
        accepted: the ICP result passed the gate, and `pose` is its fusion with the odometry
            prediction (see `FusionRule`); otherwise `pose` is the odometry prediction.
        result: the ICP result (None when the scan had too few points to align at all).
        predicted_pose: last pose plus the odometry motion since then: ICP's initial guess.
        odom_pose: the odometry pose (T_odom_base) this update received.
        reason: why the result was not accepted ("" when it was).
        covariance: 3x3 over (x, y, yaw) of `pose` (m^2, m rad, rad^2): the fusion of ICP's and
            the odometry prediction's when accepted (ICP's alone after an odometry fault), the
            prediction's otherwise.
        degeneracy: the weak axis of an accepted fit that does not fix the position along it
            (along which `pose` kept the odometry motion, corrected only as far as ICP's variance
            there allows: the fusion does so), or None.
        lost: the plan no longer explains the scans (see `LostRule`); while lost, the
            `Recovery` searches the plan for the robot.
        score: mean match score over the `LostRule` window: the share of the scan the plan
            explains (see `LostRule`).
        kept: (N,) bool over the scan's points: those aligned to the plan, after `OcclusionRule`
            left out the returns in front of the plan's walls (people, furniture); None when every
            point was aligned. `result.inlier_mask` is over the kept points.
        relocalized: this update adopted a pose found by a search of the plan (`pose` is it): by
            the recovery while lost, or around a prediction the acceptance gate cannot vouch for.
        hypotheses: places the recovery is following while lost (more than one: the building is
            symmetric there and the localizer does not pretend to know which).
    """

    pose: Pose
    accepted: bool
    result: IcpResult | None
    predicted_pose: Pose
    odom_pose: Pose
    reason: str
    covariance: NDArray[np.float64]
    degeneracy: Degeneracy | None
    lost: bool
    score: float
    relocalized: bool = False
    hypotheses: tuple[Pose, ...] = ()
    kept: NDArray[np.bool_] | None = None

    @property
    def T_map_base(self) -> NDArray[np.float64]:  # noqa: N802
        """3x3 transform of `pose`."""
        return pose_to_matrix(self.pose)

    @property
    def T_map_odom(self) -> NDArray[np.float64]:  # noqa: N802
        """The map -> odom correction a ROS node publishes (REP-105): T_map_base * inv(T_odom_base)."""
        return pose_to_matrix(compose(self.pose, inverse(self.odom_pose)))


class Localizer:
    """Tracks the robot's pose in the plan from scans and odometry.

    Each `update` applies the odometry motion since the previous update to the last pose (the
    prediction), aligns the scan from there, and accepts the result only if it passes the
    `AcceptanceGate`; otherwise the pose follows odometry and the estimate says why. A scan
    that is malformed raises and changes nothing; a scan with too few points is not aligned.

    Along the weak axis of a degenerate fit (`DegeneracyRule`: a long corridor) the pose keeps the
    odometry motion. A covariance is carried along: propagated through each motion with
    `MotionNoise`, replaced by ICP's when a fit is accepted. `LostRule` decides when the scans no
    longer match the plan (`Estimate.lost`); a scan rejected because the plan explains too little of
    it does not count towards that while it continues the previous scan (`ContinuityRule`: clutter,
    not a kidnapped robot). While lost, a `Recovery` searches the whole plan and
    confirms a place over several scans before the pose jumps there (`Estimate.relocalized`).

    The gate's jump limits are the span ICP is trusted to correct from the prediction. Beyond it,
    a fit is neither taken nor dismissed on ICP's word alone: when the gate rejects a good fit only
    for the size of its correction (a bad odometry step), or when the prediction's own 3-sigma
    position uncertainty exceeds the translation limit (odometry integrated over a long gap in the
    scans: ICP's position basin is about its correspondence distance, while its heading converges
    from well beyond the rotation limit, so position is what makes a prediction a poor start), the
    plan is searched around the prediction (the recovery's `local_radius`, any heading; for an
    uncertain prediction, only the places its covariance allows) and an unambiguous place that
    explains at least the recovery's `min_inlier_ratio` of the scan, and the scan better than the
    fit from the prediction, is adopted: at once for an uncertain prediction. After a rejected jump
    the place (or, when the search finds none, the fit's) is taken only when the next scan, aligned
    from it moved by the odometry, fits there soundly and better than from the prediction, since a
    corrupted scan fits some place beyond the gate too.

    Thread-safe: updates are serialised by a lock.
    """

    def __init__(
        self,
        plan: PlanMap,
        initial_pose: Any,
        config: IcpConfig | None = None,
        *,
        gate: AcceptanceGate | None = None,
        motion_noise: MotionNoise | None = None,
        degeneracy: DegeneracyRule | None = None,
        lost_rule: LostRule | None = None,
        initial_covariance: Any = None,
        recovery: RecoveryConfig | None = None,
        continuity: ContinuityRule | None = None,
        occlusion: OcclusionRule | Literal[False] | None = None,
        fusion: FusionRule | None = None,
    ) -> None:
        """
        Args:
            plan: the plan to localize in.
            initial_pose: (x, y, yaw) of the robot in the map at the first update.
            config: ICP settings (None: `IcpConfig.for_tracking()`).
            gate: acceptance rules (None: `AcceptanceGate()`).
            motion_noise: odometry uncertainty for the covariance (None: `MotionNoise()`).
            degeneracy: when a fit is degenerate (None: `DegeneracyRule()`).
            lost_rule: when the localizer is lost (None: `LostRule()`).
            initial_covariance: 3x3 covariance of `initial_pose` (None: 10 cm and 5 degrees).
            recovery: how to find the robot again when lost (None: `RecoveryConfig()`).
            continuity: when a scan the plan explains too little of still continues the previous
                scan (clutter, not a kidnapped robot: it does not count towards `lost`; None:
                `ContinuityRule()`).
            occlusion: which returns stand in front of the plan's walls and are left out of the
                alignment (None: `OcclusionRule()`; False: align every return).
            fusion: when an accepted fit is fused with the odometry prediction (a Kalman update;
                None: `FusionRule()`).
        """
        if not isinstance(plan, PlanMap):
            raise TypeError(f"plan must be a planicp.PlanMap, got {type(plan).__name__}")
        if config is not None and not isinstance(config, IcpConfig):
            raise TypeError(f"config must be a planicp.IcpConfig, got {type(config).__name__}")
        if gate is not None and not isinstance(gate, AcceptanceGate):
            raise TypeError(f"gate must be a planicp.AcceptanceGate, got {type(gate).__name__}")
        self.plan = plan
        self.config = config if config is not None else IcpConfig.for_tracking()
        self.gate = gate if gate is not None else AcceptanceGate()
        self.motion_noise = motion_noise if motion_noise is not None else MotionNoise()
        self.degeneracy = degeneracy if degeneracy is not None else DegeneracyRule()
        self.continuity = continuity if continuity is not None else ContinuityRule()
        if fusion is not None and not isinstance(fusion, FusionRule):
            raise TypeError(f"fusion must be a planicp.FusionRule or None, got {type(fusion).__name__}")
        self.fusion = fusion if fusion is not None else FusionRule()
        if occlusion is not False and occlusion is not None and not isinstance(occlusion, OcclusionRule):
            raise TypeError(f"occlusion must be an OcclusionRule, False or None, got {type(occlusion).__name__}")
        self._occlusion = None if occlusion is False else OcclusionFilter(plan, occlusion or OcclusionRule())
        self._detector = LostDetector(lost_rule if lost_rule is not None else LostRule())
        # The nearest-wall index refuses pairs with hidden wall faces where the KD-tree finds the
        # nearest visible one, so its basin is narrower from a poor start (a 15-degree odometry
        # step, a candidate place): fits it cannot make are tried again with the KD-tree, and the
        # recovery refines its candidates with it.
        self._wide_config = self.config.replace(correspondence_search="kd_tree")
        self._recovery = Recovery(plan, recovery if recovery is not None else RecoveryConfig(), self._wide_config,
                                  self.gate, self._occlusion, self.motion_noise)
        # The searches' likelihood pyramid is part of preparing the plan, not of the first update
        # that needs a search.
        prepare_search(plan, self._recovery.config.search)
        self._pose: Pose = _wrapped(as_pose(initial_pose, "initial_pose"))
        self._covariance = _covariance(initial_covariance)
        self._last_odom: Pose | None = None
        # The last scan the plan explained, with its odometry pose.
        self._anchor: tuple[NDArray[np.float64], Pose] | None = None
        # The place a scan put the robot at after a rejected jump (a search's, or the sound fit's),
        # with the odometry pose of that scan: taken only when the next scan confirms it (see
        # `update`).
        self._pending: tuple[Pose, Pose] | None = None
        self._lock = threading.Lock()

    @property
    def pose(self) -> Pose:
        """Current (x, y, yaw) of the robot in the map."""
        return self._pose

    @property
    def covariance(self) -> NDArray[np.float64]:
        """Current 3x3 covariance of `pose` (m^2, m rad, rad^2)."""
        return self._covariance.copy()

    @property
    def lost(self) -> bool:
        """Whether the last updates say the plan no longer explains the scans."""
        return self._detector.lost

    def reset(self, pose: Any, covariance: Any = None) -> None:
        """Sets the pose (e.g. from RViz's initial pose) and its covariance (None: 10 cm and 5
        degrees); the next update's odometry pairs with it, and the lost state is cleared."""
        new_pose = _wrapped(as_pose(pose, "pose"))
        new_covariance = _covariance(covariance)
        with self._lock:
            self._pose = new_pose
            self._covariance = new_covariance
            self._last_odom = None
            self._anchor = None
            self._pending = None
            self._detector.reset()
            self._recovery.clear()

    def relocalize(self, scan_xy: Any) -> Relocalization:
        """Searches the whole plan for the robot from one scan (base-frame points, metres), now.

        When the best place is unambiguous and explains at least the recovery's
        `min_inlier_ratio` of the scan, the pose and covariance jump there and the lost state is
        cleared. Otherwise the localizer becomes lost and follows the candidates with the next
        scans until one is confirmed (`Estimate.relocalized`). Returns the search's result.
        """
        points = as_points(scan_xy, "scan_xy")
        config = self._recovery.config
        with self._lock:
            found = relocalize(points, self.plan, config=config.search, max_candidates=config.max_hypotheses)
            best = found.best
            self._recovery.clear()
            if best is not None and not found.ambiguous and best.inlier_ratio >= config.min_inlier_ratio:
                self._pose = best.pose
                self._covariance = _finite_or(best.result.covariance, self._covariance)
                self._detector.reset()
            else:
                self._recovery.hypotheses = [Hypothesis(c.pose, c.result, 1, c.inlier_ratio) for c in found.candidates
                                             if c.inlier_ratio >= config.min_inlier_ratio]
                self._detector.declare_lost()
            return found

    def update(self, scan_xy: Any, odom_pose: Any) -> Estimate:
        """One tracking step.

        Args:
            scan_xy: (N, 2) scan points in the robot frame, metres (see `scan_to_points`).
            odom_pose: (x, y, yaw) of the robot in the odom frame at the scan's time.

        Raises:
            TypeError, ValueError: a malformed scan or odometry pose; the state is unchanged.
        """
        points = as_points(scan_xy, "scan_xy", allow_empty=True)
        odom = as_pose(odom_pose, "odom_pose")
        with self._lock:
            was_lost = self._detector.lost
            motion = (0.0, 0.0, 0.0) if self._last_odom is None else between(self._last_odom, odom)
            predicted = compose(self._pose, motion)
            predicted_covariance = self.motion_noise.propagate_checked(self._covariance, self._pose, motion)
            fit = self._fit(points, predicted, predicted_covariance)
            result, kept, reason = fit.result, fit.kept, fit.reason
            searched = False
            pending, self._pending = self._pending, None
            if pending is not None and result is not None:
                confirmed = self._confirmed(points, odom, pending, result, reason)
                if confirmed is not None:
                    result, reason, searched = confirmed, "", True
            search = None if result is None or searched or self._detector.lost else self._search_cause(
                result, reason, predicted_covariance)
            if result is not None and search is not None:
                result, reason, searched = self._searched(points, predicted, predicted_covariance, odom, result,
                                                          reason, search)
            score = 0.0 if result is None else (self._score(result, None, None, len(points)) if searched else
                                                self._score(result, kept, fit.beyond, len(points)))
            poor = result is not None and self._poor_fit(score, reason, result)
            continues: bool | None = None
            if poor and result is not None and not self._detector.lost:
                continues, reason = self._continuity(points, odom, fit, result, reason, searched, score)
            degeneracy: Degeneracy | None = None
            if result is not None and reason == "":
                degeneracy = self.degeneracy.check(result)
                pose, covariance = self._corrected(result, degeneracy, searched, predicted, predicted_covariance)
            else:
                pose, covariance = predicted, predicted_covariance
            accepted = result is not None and reason == ""
            if continues:
                lost = self._detector.hold()
            else:
                # While lost, a fit from the prediction (the place the localizer lost track at)
                # ends the lost state only when it explains as much of the scan as the recovery
                # asks of a place it adopts: a wrong place may explain a third of the scan and
                # pass the gate. (Otherwise the recovery ends it; in a symmetric room it cannot
                # choose, and a sound track would stay lost.)
                clears = not was_lost or searched or score >= self._recovery.config.min_inlier_ratio
                lost = self._detector.update(score, accepted and clears)
            relocalized = searched
            if lost and fit.usable:
                found = self._recovery.step(points, motion, predicted)
                if found is not None:
                    pose, result, accepted, relocalized, lost = found.pose, found.result, True, True, False
                    covariance = _finite_or(found.result.covariance, predicted_covariance)
                    reason = ""
                    self._detector.reset()
            elif lost:
                self._recovery.coast(motion)
            else:
                self._recovery.clear()
            self._pose = pose
            self._covariance = covariance
            self._last_odom = odom
            if accepted and (continues or not poor):
                self._anchor = (points, odom)
            if accepted and not poor and not relocalized and fit.beyond is not None and not lost:
                self._recovery.observe_beyond(float(np.mean(fit.beyond)))
            hypotheses = tuple(h.pose for h in self._recovery.hypotheses)
            if relocalized and result is not None and kept is not None and len(result.inlier_mask) == len(points):
                kept = None  # a search's result is over the whole scan
            return Estimate(pose, accepted, result, predicted, odom, reason, covariance.copy(), degeneracy, lost,
                            self._detector.score, relocalized, hypotheses, kept)

    def _confirmed(self, points: NDArray[np.float64], odom: Pose, pending: tuple[Pose, Pose], result: IcpResult,
                   reason: str) -> IcpResult | None:
        """The fit at the place the last scan put the robot at after a rejected jump (`pending`:
        the place and that scan's odometry pose), followed with the odometry, when this scan
        confirms it: a sound fit there that explains the scan better than the prediction's fit
        `result` by the recovery's `margin` (or the prediction's was rejected, `reason`); else None."""
        there = compose(pending[0], between(pending[1], odom))
        follow = localize(points, self.plan, there, self._wide_config)
        if self.gate.rejection(follow, there) or (
                reason == "" and follow.inlier_ratio <= result.inlier_ratio + self._recovery.config.margin):
            return None
        return follow

    def _searched(self, points: NDArray[np.float64], predicted: Pose, predicted_covariance: NDArray[np.float64],
                  odom: Pose, result: IcpResult, reason: str, search: Literal["jump", "uncertain"]
                  ) -> tuple[IcpResult, str, bool]:
        """(result, reason, searched) after a search around the prediction (see `_search_near`).

        A place found for an uncertain prediction agrees with it and is taken at once. After a fit
        rejected for its jump, odometry may have faulted and the prediction says nothing; but a
        corrupted scan (turned, shifted) fits some place beyond the gate too. So the place (the
        search's, or the sound fit's where the search finds none) is not taken on one scan's word:
        it waits for the next scan (`_confirmed`), which after a fault fits that place again and
        after a corrupted scan fits the prediction better."""
        found_near = self._search_near(points, predicted, result if reason == "" else None,
                                       predicted_covariance if search == "uncertain" else None)
        if search == "uncertain":
            return (found_near, "", True) if found_near is not None else (result, reason, False)
        place = found_near if found_near is not None else result
        self._pending = (place.pose, odom)
        found = "a search found" if found_near is not None else "the fit puts the robot at"
        return result, (f"{reason}; {found} a place {_distance(predicted, place.pose):.2f} m away, taken if the "
                        f"next scan confirms it"), False

    def _fit(self, points: NDArray[np.float64], predicted: Pose, predicted_covariance: NDArray[np.float64]) -> _Fit:
        """The scan aligned from `predicted` (see `_aligned`) and judged by the gate; with the
        index, a fit that explains little of the scan is tried again with the KD-tree. A scan
        with too few usable points is not aligned."""
        usable = -(-len(points) // self.config.subsample)
        if usable < _core.MIN_SCAN_POINTS:
            return _Fit(None, None, None, False, f"scan has {usable} usable points (need {_core.MIN_SCAN_POINTS})",
                        usable=False)
        result, kept, beyond, occluded = self._aligned(points, predicted, predicted_covariance)
        reason = self.gate.rejection(result, predicted)
        # A fit that explains little of the whole scan may have started outside the index's
        # narrower basin (a bad odometry step also misleads the occlusion rule): the KD-tree
        # tries again.
        if (self._poor_fit(result.num_inliers / len(points), reason, result)
                and self.config.correspondence_search == "wall_index"):
            used = points if kept is None else points[kept]
            wide = localize(used, self.plan, predicted, self._wide_config)
            if wide.num_inliers > result.num_inliers:
                result, reason = wide, self.gate.rejection(wide, predicted)
        return _Fit(result, kept, beyond, occluded, reason, usable=True)

    def _continuity(self, points: NDArray[np.float64], odom: Pose, fit: _Fit, result: IcpResult, reason: str,
                    searched: bool, score: float) -> tuple[bool, str]:
        """(continues, reason) for a fit the plan explains poorly (rejected for its fit, or
        accepted with a score below the lost rule's), checked against the last scan the plan
        explained well: if the scan continues it, the robot is among clutter and nothing is
        concluded; if not, the fit is not trusted (an accepted one gets a `reason`) and counts
        towards being lost. (Against the last well explained scan, not simply the previous one:
        after a kidnap the second scan continues the first one elsewhere.)

        A crowd hides most walls, and its people move between scans: the plan explains little of
        the scan and the scan does not continue the last one. If the plan explains the returns the
        occlusion rule kept (those on or beyond its walls) as well as a continuation must overlap,
        the scan is sound where it sees the plan; if the rule kept too few to align, the scan says
        nothing either way. Otherwise only the kept returns need to continue the last scan: a
        return short of the plan's walls says nothing about where the robot is."""
        kept = fit.kept
        continues = fit.occluded or (kept is not None and not searched and reason == ""
                                     and result.inlier_ratio >= self.continuity.min_overlap)
        if not continues and self._anchor is not None:
            continues = self.continuity.continues(points if kept is None else points[kept], self._anchor[0],
                                                  between(self._anchor[1], odom))
            if not continues and reason == "":
                reason = (f"the plan explains only {100 * score:.0f} % of the scan and it does not "
                          f"continue the last scan the plan explained")
        return continues, reason

    def _corrected(self, result: IcpResult, degeneracy: Degeneracy | None, searched: bool, predicted: Pose,
                   predicted_covariance: NDArray[np.float64]) -> tuple[Pose, NDArray[np.float64]]:
        """The pose and covariance after an accepted fit: its fusion with the prediction; after
        an odometry fault (not fused) or a search, the fit alone, except along a degenerate axis,
        where the prediction is corrected only as far as the variances say."""
        fused = None if searched else self.fusion.fuse(result, predicted, predicted_covariance)
        if fused is not None:
            return fused
        if degeneracy is not None:
            return fuse_along_weak_axis(degeneracy, result, predicted, predicted_covariance)
        return result.pose, _finite_or(result.covariance, predicted_covariance)

    def _poor_fit(self, score: float, reason: str, result: IcpResult) -> bool:
        """Whether the plan explains `result` poorly: rejected for its fit, or accepted with a
        `score` (see `_score`) below the lost rule's."""
        return (reason != "" and self.gate.fit_rejection(result) != "") or (
            reason == "" and score < self._detector.rule.min_score)

    @staticmethod
    def _score(result: IcpResult, kept: NDArray[np.bool_] | None, beyond: NDArray[np.bool_] | None,
               scan_points: int) -> float:
        """How much of the WHOLE scan of `scan_points` the plan explains: returns the occlusion rule
        left out (`kept` False) count as unexplained, so that a wrong prediction cannot hide the
        evidence against it, and so do returns `beyond` the walls seen from the prediction even
        when paired (the nearest-wall index's masks see occluders within 0.6 m only, so from a
        wrong place, a kidnapped robot, it pairs returns that came through walls)."""
        if beyond is None:
            return result.num_inliers / scan_points
        inliers = np.zeros(scan_points, dtype=bool)
        if kept is None:
            inliers[:] = result.inlier_mask
        else:
            inliers[kept] = result.inlier_mask
        return float(np.count_nonzero(inliers & ~beyond)) / scan_points

    def _aligned(self, points: NDArray[np.float64], predicted: Pose, predicted_covariance: NDArray[np.float64]
                 ) -> tuple[IcpResult, NDArray[np.bool_] | None, NDArray[np.bool_] | None, bool]:
        """The fit of the scan from `predicted`, with the occlusion rule's (kept, beyond,
        occluded) (see `_unoccluded`). The rule judges the returns from the prediction. When the
        fit lands more than a quarter of the rule's margin away, the prediction was off by a good
        part of the margin, which makes returns on the plan's walls look short of them: every
        return is aligned again from the prediction, and none counts as left out. (In
        `tests/test_localizer.py::test_gate_rejects_a_correction_beyond_max_translation_jump`, a
        prediction 25 cm off left 400 of 1080 returns out and the fit of the rest stopped 15 cm
        from the truth; judging the returns again from that fit and aligning from there stayed
        there too, while all returns from the prediction reach the truth.)"""
        kept, beyond, occluded, view = self._unoccluded(points, predicted, predicted_covariance)
        result = localize(points if kept is None else points[kept], self.plan, predicted, self.config, view=view)
        if beyond is not None and self._occlusion is not None:
            shift = math.hypot(result.pose[0] - predicted[0], result.pose[1] - predicted[1])
            if shift > self._occlusion.rule.margin / 4.0:
                kept, occluded = None, False
                result = localize(points, self.plan, predicted, self.config, view=view)
        return result, kept, beyond, occluded

    def _unoccluded(self, points: NDArray[np.float64], predicted: Pose, predicted_covariance: NDArray[np.float64]
                    ) -> tuple[NDArray[np.bool_] | None, NDArray[np.bool_] | None, bool, _core.WallView | None]:
        """(kept, beyond, occluded, view) when the occlusion rule applies (a trusted prediction,
        not lost): the points not in front of the plan's walls (None when too few would remain, or
        all: align them all), the points beyond the walls seen from the prediction, whether fewer
        than the rule's `min_points` remain, and, for the KD-tree search, the view from the
        prediction over the arc the whole scan spans, whose visible points it matches against.
        (None, None, False, None) otherwise."""
        if self._occlusion is None or self._detector.lost:
            return None, None, False, None
        rule = self._occlusion.rule
        if 3.0 * largest_position_std(predicted_covariance) >= rule.margin:
            return None, None, False, None
        uses_view = self.config.correspondence_search == "kd_tree" and self.config.use_visibility
        view = self._occlusion.view(points, predicted, self.config) if uses_view else None
        in_front, beyond = self._occlusion.classify(points, predicted)
        kept: NDArray[np.bool_] = ~in_front
        remaining = int(np.count_nonzero(kept))
        if remaining < rule.min_points:
            return None, beyond, True, view
        if remaining == len(points):
            return None, beyond, False, view
        return kept, beyond, False, view

    def _search_cause(self, result: IcpResult, reason: str, predicted_covariance: NDArray[np.float64]
                      ) -> Literal["jump", "uncertain"] | None:
        """Why the gate cannot vouch for this update, if it cannot: "jump", a good fit rejected
        only for its jump; "uncertain", a prediction whose 3-sigma position uncertainty exceeds
        the translation limit. None: no search (or the recovery searches no neighbourhood)."""
        if self._recovery.config.local_radius <= 0.0:
            return None
        if reason != "" and self.gate.fit_rejection(result) == "":
            return "jump"
        if 3.0 * largest_position_std(predicted_covariance) > self.gate.max_translation_jump:
            return "uncertain"
        return None

    def _search_near(self, points: NDArray[np.float64], predicted: Pose, accepted: IcpResult | None,
                     consistent_with: NDArray[np.float64] | None = None) -> IcpResult | None:
        """The fit at the unambiguous best place around `predicted`, when it explains at least the
        recovery's `min_inlier_ratio` of the scan, (if the fit from the prediction was acceptable,
        `accepted`) more of it than that fit by the recovery's `margin`, and (given the
        prediction's covariance, `consistent_with`) lies within the chi-square bound of the
        fusion (`CHI2_3_999`, 99.9 %) of the prediction; else None.

        With `consistent_with`, only the places that can pass that bound are searched: positions
        within `sqrt(CHI2_3_999)` standard deviations of the prediction along its widest axis and
        headings within as many of its heading's, each widened by the reach of the refinement from
        a lattice pose (the ICP's correspondence distance, two heading steps), inside the
        recovery's `local_radius`. A search of every heading around the prediction took 35-120 ms
        on a real log whose scans were 2 m apart, and then refused every place outside that region."""
        config = self._recovery.config
        radius, yaw_tolerance = config.local_radius, math.pi
        if consistent_with is not None:
            k = math.sqrt(CHI2_3_999)
            reach = self.config.max_correspondence_distance
            radius = min(radius, k * largest_position_std(consistent_with) + reach)
            yaw_std = math.sqrt(max(float(consistent_with[2, 2]), 0.0))
            yaw_tolerance = min(math.pi, k * yaw_std + 2.0 * config.search.max_angular_step)
        found = relocalize(points, self.plan, region=SearchRegion(predicted, radius, yaw_tolerance),
                           config=config.search, max_candidates=config.max_hypotheses)
        best = found.best
        if best is None or found.ambiguous or best.inlier_ratio < config.min_inlier_ratio:
            return None
        refined = localize(points, self.plan, best.pose, self.config)
        if self.gate.rejection(refined, best.pose) or refined.inlier_ratio < config.min_inlier_ratio:
            return None
        if accepted is not None and refined.inlier_ratio <= accepted.inlier_ratio + config.margin:
            return None
        if consistent_with is not None and not self.fusion.innovation(refined, predicted, consistent_with) <= CHI2_3_999:
            # A place the prediction's own uncertainty rules out: with a short-range scanner a
            # wrong place can explain more of a scan than the right one.
            return None
        return refined


@dataclass(frozen=True)
class _Fit:
    """One scan's fit from the prediction, as `Localizer._fit` makes it.

    Attributes:
        result: the ICP result, None when the scan had too few usable points.
        kept, beyond, occluded: the occlusion rule's findings (see `Localizer._unoccluded`).
        reason: the gate's rejection ("" when accepted).
        usable: the scan had enough points to align.
    """

    result: IcpResult | None
    kept: NDArray[np.bool_] | None
    beyond: NDArray[np.bool_] | None
    occluded: bool
    reason: str
    usable: bool


def _distance(a: Pose, b: Pose) -> float:
    """Metres between the positions of two poses."""
    return math.hypot(a[0] - b[0], a[1] - b[1])


DEFAULT_INITIAL_STD = (0.1, 0.1, math.radians(5.0))
"""Standard deviations (m, m, rad) of a start or reset pose given without a covariance."""


def _covariance(value: Any) -> NDArray[np.float64]:
    """A validated 3x3 covariance (None: `DEFAULT_INITIAL_STD` squared on the diagonal)."""
    if value is None:
        return np.diag(np.square(DEFAULT_INITIAL_STD))
    cov = np.asarray(value)
    if cov.dtype.kind not in "fiu":
        raise TypeError(f"covariance must hold real numbers, got dtype {cov.dtype}")
    cov = cov.astype(np.float64)
    if cov.shape != (3, 3):
        raise ValueError(f"covariance must be 3x3 over (x, y, yaw), got shape {cov.shape}")
    if not np.isfinite(cov).all() or not np.allclose(cov, cov.T, atol=1e-12) or np.linalg.eigvalsh(cov).min() < 0:
        raise ValueError(f"covariance must be finite, symmetric and positive semi-definite, got {cov.tolist()}")
    return cov


def _finite_or(covariance: NDArray[np.float64], fallback: NDArray[np.float64]) -> NDArray[np.float64]:
    """`covariance` as float64 when it is finite, else `fallback`."""
    cov = np.asarray(covariance, dtype=np.float64)
    return cov.copy() if np.isfinite(cov).all() else fallback


def _wrapped(pose: Pose) -> Pose:
    """`pose` with its yaw wrapped to (-pi, pi], as every pose the localizer reports (a yaw already
    in range is kept exactly)."""
    yaw = pose[2]
    return (pose[0], pose[1], yaw if -math.pi < yaw <= math.pi else wrap_angle(yaw))
