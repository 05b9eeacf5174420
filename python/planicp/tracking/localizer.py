"""Scan-by-scan tracking: odometry predicts, ICP against the plan corrects, a gate decides."""

from __future__ import annotations

import contextlib
import math
import threading
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from .. import _core
from .._validation import Pose, as_points, as_pose
from ..plans.plan_map import PlanMap
from ..se2 import compose, inverse, pose_to_matrix, wrap_angle
from .acceptance_gate import AcceptanceGate
from .continuity_rule import ContinuityRule
from .decisions import Decision, LeftPlace, PendingPlace
from .degeneracy_rule import Degeneracy, DegeneracyRule
from .fusion_rule import FusionRule
from .icp_config import IcpConfig
from .icp_result import IcpResult
from .lost_rule import LostDetector, LostRule
from .motion_noise import MotionNoise
from .occlusion_rule import OcclusionFilter, OcclusionRule
from .odometry_fault import CostHistory, fault_cost, scan_cost
from .posterior_refinement import PosteriorRefinement
from .recovery import Hypothesis, Recovery, RecoveryConfig
from .relocalize import Relocalization, prepare_search, relocalize
from .scale_check import ScaleEstimate, ScaleMonitor, ScaleRule
from .stages import (
    Rules,
    confirm_pending,
    correct,
    finite_or,
    fit_from_prediction,
    judge_lost,
    judge_score,
    keep_records,
    predict,
    recover,
    search_near_prediction,
    spread_over_pending,
    weigh_left_place,
)


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
            prediction's otherwise; while a place is pending for the next scan to confirm (after
            a rejected jump), or the place an adopted one left behind is not yet ruled out (after
            an odometry fault), widened towards it (see
            `planicp.tracking.stages.pending.spread_over_pending`).
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
            the recovery while lost, or around a prediction the acceptance gate cannot vouch for;
            or took back the place an adopted jump left behind (`LeftPlaceDecision`).
        hypotheses: places the recovery is following while lost (more than one: the building is
            symmetric there and the localizer does not pretend to know which), or, while `pose`
            is `provisional`, the places that rival it.
        provisional: `pose` follows a place the recovery adopted before its search of the whole
            plan had ended (a place near where the localizer lost track that explains the scans
            as well as sound tracking did), the lost track regained by a fit from its prediction
            while that search went on (`LostDecision.regained`), or a track kept only because the
            lost rule's bar is relaxed to what the track has learned of the plan
            (`LostDecision.doubted`); a search of the whole plan goes on, and a place it finds
            that explains the next scans better replaces it (see `Recovery.verify`).
        decisions: why the pose is what it is: the typed decision of each stage of this update, in
            the order `update` runs them (`planicp.tracking.decisions`): `Prediction`,
            `FitDecision`, `PendingDecision`, `SearchDecision`, `ScoreDecision`, `Correction`,
            `LostDecision`, `RecoveryDecision`, `Bookkeeping`; each has a `why` sentence. Empty for an
            `Estimate` made by hand. (Not part of the estimate's repr or equality.)
        scale: what the accepted fits so far say about the plan's scale (`ScaleEstimate`: the
            factor that would make the plan true to the building, and whether the plan is
            `suspect` of being off by more than `ScaleRule.tolerance`); None before the
            `ScaleRule`'s `min_fits` fits (or with the check off). It only observes: the pose
            is the same with it or without it. (Not part of the estimate's equality.)
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
    provisional: bool = False
    decisions: tuple[Decision, ...] = field(default=(), repr=False, compare=False)
    scale: ScaleEstimate | None = field(default=None, compare=False)

    @property
    def scale_suspect(self) -> bool:
        """The plan's scale looks off by more than `ScaleRule.tolerance` (see `scale`): the
        `Localizer` has also warned once (`PlanScaleWarning`)."""
        return self.scale is not None and self.scale.suspect

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
    corrupted scan fits some place beyond the gate too. Where the refinement runs, a scan far worse
    explained than the track's recent ones may mean the odometry strayed beyond its noise (a
    heading fault ICP cannot climb out of): the plan's likelihood field is swept for such a fault
    (`planicp.tracking.odometry_fault`), and a place found is taken at once. The place such a
    jump left behind is followed with the odometry and taken back when the scans since prefer it,
    in total, by as much as a fault's place must be preferred, since one scan cannot tell a fault
    from a turned scan or a map whose passes disagree (`LeftPlaceDecision`).

    `update` runs these steps as an ordered pipeline of stages (`planicp.tracking.stages`: predict,
    fit, confirm a pending place, search, score, correct, weigh the place left behind, judge lost,
    recover, keep records), and
    `Estimate.decisions` holds what each stage decided and why.

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
        scale: ScaleRule | None = None,
        refinement: PosteriorRefinement | None = None,
    ) -> None:
        """
        Args:
            plan: the plan to localize in.
            initial_pose: (x, y, yaw) of the robot in the map at the first update.
            config: ICP settings (None: `IcpConfig.for_tracking(plan)`: the visibility of a drawn
                plan's walls is cast from the prediction, a SLAM map's is its index's masks).
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
            scale: when the plan's scale is reported as off (`Estimate.scale`; None:
                `ScaleRule()` for a plan whose scale may be off (a drawing, an image), and no
                check for a map_server map (`PlanMap.metric`: made by SLAM in metres, its scale
                is right; on the real logs' maps the check cost a third more time per scan and
                flagged a correct map 2.6 % off); `ScaleRule(enabled=False)` turns it off).
            refinement: how a corrected pose is refined to the pose of highest posterior in the
                plan's likelihood field (None: `PosteriorRefinement()` where the plan's points are
                an occupancy grid's cell centres (`PlanMap.cells_mark_returns`: a
                map_server map made by SLAM, whose cells are where returns ended), none on walls
                drawn as material, which ICP places more finely than the field;
                `PosteriorRefinement(enabled=False)` keeps the fusion's pose).
        """
        if not isinstance(plan, PlanMap):
            raise TypeError(f"plan must be a planicp.PlanMap, got {type(plan).__name__}")
        if config is not None and not isinstance(config, IcpConfig):
            raise TypeError(f"config must be a planicp.IcpConfig, got {type(config).__name__}")
        if gate is not None and not isinstance(gate, AcceptanceGate):
            raise TypeError(f"gate must be a planicp.AcceptanceGate, got {type(gate).__name__}")
        self.plan = plan
        self.config = config if config is not None else IcpConfig.for_tracking(plan)
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
        if refinement is not None and not isinstance(refinement, PosteriorRefinement):
            raise TypeError(
                f"refinement must be a planicp.PosteriorRefinement or None, got {type(refinement).__name__}"
            )
        # Refined by default where the plan's points are an occupancy grid's occupied cell centres
        # (a map_server map read as `from_ros_map` reads a SLAM map): where returns ended, a
        # likelihood, which ICP's nearest centres read as exact walls and slide along
        # (docs/design.md, "The pose of highest posterior"). Walls drawn as material (a drawing,
        # a map that says so) are exact: ICP places them to the millimetre, the field (sampled
        # every point spacing) to half a centimetre.
        self.refinement = refinement if refinement is not None else PosteriorRefinement(enabled=plan.cells_mark_returns)
        self._detector = LostDetector(lost_rule if lost_rule is not None else LostRule())
        # The bar, gate and lost rule `_relaxed_rules` last relaxed, and the relaxed pair.
        self._relaxed: tuple[float | None, AcceptanceGate, LostRule, AcceptanceGate, LostRule] | None = None
        if scale is not None and not isinstance(scale, ScaleRule):
            raise TypeError(f"scale must be a planicp.ScaleRule or None, got {type(scale).__name__}")
        # Observes the accepted fits for a plan whose scale is off; never changes a pose.
        self._scale = ScaleMonitor(plan, scale if scale is not None else ScaleRule(enabled=not plan.metric))
        # The nearest-wall index refuses pairs with hidden wall faces where the KD-tree finds the
        # nearest visible one, so its basin is narrower from a poor start (a 15-degree odometry
        # step): fits it cannot make are tried again with the KD-tree.
        self._wide_config = self.config.replace(correspondence_search="kd_tree")
        # The recovery aligns every place it follows, often several per update: with the index and
        # its visibility masks, made once for the plan, instead of a ray cast from each place
        # (docs/design.md, "Recovery and relocalization use the index").
        self._recovery = Recovery(
            plan,
            recovery if recovery is not None else RecoveryConfig(),
            self.config.replace(correspondence_search="wall_index"),
            self.gate,
            self._occlusion,
            self.motion_noise,
            self.continuity,
            self.refinement,
        )
        # The searches' likelihood pyramid is part of preparing the plan, not of the first update
        # that needs a search.
        prepare_search(plan, self._recovery.config.search)
        # And its likelihood field, which every tracking update climbs.
        if self.refinement.enabled:
            plan.likelihood_field()
        # So is the nearest-wall index the recovery and the searches align with (seconds on a
        # large plan; the KD-tree search of tracking goes through it too). A plan it cannot be
        # built for (more wall points than it holds) is aligned through the KD-tree there instead.
        with contextlib.suppress(_core.PlanicpError):
            plan.prepare_index()
        self._pose: Pose = _wrapped(as_pose(initial_pose, "initial_pose"))
        self._covariance = _covariance(initial_covariance)
        self._recovery.note_tracked((0.0, 0.0, 0.0), self._pose, vouched=True)  # the pose given
        self._last_odom: Pose | None = None
        # The last scan the plan explained, with its odometry pose.
        self._anchor: tuple[NDArray[np.float64], Pose] | None = None
        # The places scans put the robot at after rejected jumps (a search's, or the sound fit's),
        # with the odometry poses of those scans: one is taken only when a later scan confirms it
        # (see `update` and `confirm_pending`).
        self._pending: tuple[PendingPlace, ...] = ()
        self._left: LeftPlace | None = None
        # The scan's cost in the likelihood field at the last accepted poses: how well this
        # track's scans are explained, against which a suspected odometry fault is judged.
        self._costs = CostHistory()
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
            self._pending = ()
            self._left = None
            self._costs.clear()
            self._detector.reset()
            self._recovery.clear()
            self._recovery.note_tracked((0.0, 0.0, 0.0), new_pose, vouched=True)  # the pose given

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
            self._left = None
            if best is not None and not found.ambiguous and best.inlier_ratio >= config.min_inlier_ratio:
                self._pose = best.pose
                self._covariance = finite_or(best.result.covariance, self._covariance)
                self._detector.reset()
                self._recovery.note_tracked((0.0, 0.0, 0.0), best.pose, vouched=True)
            else:
                self._recovery.hypotheses = [
                    Hypothesis(c.pose, c.result, 1, c.inlier_ratio)
                    for c in found.candidates
                    if c.inlier_ratio >= config.min_inlier_ratio
                ]
                self._detector.declare_lost()
            return found

    def update(self, scan_xy: Any, odom_pose: Any) -> Estimate:
        """One tracking step: the stages of `planicp.tracking.stages`, in order (each returns the
        decision `Estimate.decisions` lists).

        Args:
            scan_xy: (N, 2) scan points in the robot frame, metres (see `scan_to_points`).
            odom_pose: (x, y, yaw) of the robot in the odom frame at the scan's time.

        Raises:
            TypeError, ValueError: a malformed scan or odometry pose; the state is unchanged.
        """
        points = as_points(scan_xy, "scan_xy", allow_empty=True)
        odom = as_pose(odom_pose, "odom_pose")
        with self._lock:
            rules = self._rules()
            budget = self._recovery.new_update()  # the search nodes this update may score
            was_lost = self._detector.lost
            # 1. Odometry predicts. 2. ICP from the prediction, judged by the gate.
            prediction = predict(self._pose, self._covariance, self._last_odom, odom, rules.motion_noise)
            fit = fit_from_prediction(points, prediction, rules, was_lost)
            # 3. A place rejected jumps left pending is taken if this scan confirms it; 4. else the
            # plan is searched around a prediction the gate cannot vouch for (which may leave a
            # place pending for the next scan).
            pending, self._pending = self._pending, ()
            confirmation = confirm_pending(points, prediction, pending, fit, rules, self._costs)
            search = search_near_prediction(points, prediction, fit, confirmation, rules, was_lost, budget, self._costs)
            self._pending = confirmation.kept + ((search.pending,) if search.pending is not None else ())
            # 5. How much of the scan the plan explains; clutter or not. 6. The corrected pose.
            score = judge_score(points, prediction, fit, search, rules, was_lost, self._anchor)
            correction = correct(points, prediction, search, score, rules)
            # 7. The place an adopted jump left behind, taken back if this scan prefers it.
            faulted = search.left is not None  # this update took a place an odometry fault explains
            offered = tuple(x.pose for x in (fit.result, search.pending) if x is not None)
            left = weigh_left_place(
                points, self._left, odom, correction, rules, was_lost, faulted, prediction.covariance, offered
            )
            # 8. Lost or not. 9. While lost, the recovery, which may adopt a place.
            lost = judge_lost(self._detector, score, correction, search, was_lost, rules, left)
            # A track lost while the scans preferred the place it left behind: the robot is more
            # likely there, and the lost pose coasts from it.
            likelier = left.kept if lost.lost and left.kept is not None and left.evidence > 0.0 else None
            lost_at = None if likelier is None else likelier.pose
            recovery = recover(self._recovery, self._detector, points, prediction, fit, correction, lost, lost_at)
            adopted = recovery.adopted
            if lost.lost:
                self._pending = ()  # the recovery looks for the robot now
            returned = left.returned is not None and adopted is None and not lost.lost
            result: IcpResult | None
            if adopted is not None:
                assert recovery.covariance is not None  # given with every adopted place
                pose, covariance, result, reason = adopted.pose, recovery.covariance, adopted.result, ""
                accepted, now_lost = True, False
            elif returned:
                assert left.place is not None and left.returned is not None
                pose, result, reason = left.place, left.returned, ""
                covariance = finite_or(left.returned.covariance, correction.covariance)
                accepted, now_lost = True, False
            else:
                pose, covariance, result = correction.pose, correction.covariance, search.result
                if recovery.lost_at is not None:
                    pose = recovery.lost_at
                reason = score.reason or correction.refused
                accepted, now_lost = correction.accepted, lost.lost
            # The place this update leaves, followed while the scans cannot rule it out: the
            # track's own when a pending place is taken, the corrected pose when it is taken back.
            if now_lost or adopted is not None:
                self._left = None
            elif returned:
                self._left = LeftPlace(correction.pose, odom)
            elif confirmation.confirmed is not None and correction.accepted:
                own = fit.result.pose if fit.passed and fit.result is not None else prediction.pose
                self._left = LeftPlace(own, odom)
            elif search.left is not None and correction.accepted:
                self._left = LeftPlace(search.left, odom)
            else:
                self._left = left.kept
            relocalized = search.searched or adopted is not None or returned
            # 10. What the next updates need.
            records = keep_records(
                self._recovery, fit, score, result, len(points), accepted, relocalized, now_lost, rules, points=points
            )
            if not now_lost:
                self._recovery.note_tracked(prediction.motion, pose, vouched=records.vouched or adopted is not None)
            self._pose = pose
            self._covariance = covariance.copy()  # the decisions hold `covariance`: a caller may change them
            self._last_odom = odom
            if records.anchored:
                self._anchor = (points, odom)
            if accepted and not now_lost and rules.refinement.weighs_faults:
                # Stage 7 costed the corrected pose already when it weighed a followed place.
                weighed = left.place is not None and pose is correction.pose
                cost = left.current_cost if weighed else scan_cost(points, pose, self.plan, rules.refinement)
                self._costs.record(cost, odom, fault_cost(rules.refinement.fault_probability))
            # The scale check observes the fit from the prediction when it stays where the
            # odometry says the robot is (a plan off in scale explains too little of the scans
            # for the gate long before its fits jump: it is rejected, but in the right place).
            scale = self._scale.last
            fitted = fit.result
            if (
                self._scale.rule.enabled
                and fitted is not None
                and fitted.num_inliers >= rules.gate.min_inliers
                and not rules.gate.jump_rejection(fitted, prediction.pose)
            ):
                scale = self._scale.observe(points, fitted.pose)
            kept = fit.kept
            if relocalized and result is not None and kept is not None and len(result.inlier_mask) == len(points):
                kept = None  # a search's result is over the whole scan
            # What the places still pending, and the place left behind, leave open of the pose
            # (reported only).
            followed = () if self._left is None else (PendingPlace(self._left.pose, self._left.odom),)
            reported = spread_over_pending(pose, covariance, self._pending + followed)
            return Estimate(
                pose,
                accepted,
                result,
                prediction.pose,
                odom,
                reason,
                reported.copy(),
                correction.degeneracy,
                now_lost,
                self._detector.score,
                relocalized,
                recovery.hypotheses,
                kept,
                recovery.on_trial,
                decisions=(prediction, fit, confirmation, search, score, correction, left, lost, recovery, records),
                scale=scale,
            )

    def _relaxed_rules(self) -> tuple[AcceptanceGate, LostRule]:
        """The gate and the lost rule relaxed to `Recovery.explained_bar`, made again only when
        the bar or either rule changed (a validated copy costs 25 us, an update about 1 ms)."""
        explained, gate, rule = self._recovery.explained_bar, self.gate, self._detector.rule
        made = self._relaxed
        if made is None or made[0] != explained or made[1] is not gate or made[2] is not rule:
            made = (explained, gate, rule, gate.relaxed_to(explained), rule.relaxed_to(explained))
            self._relaxed = made
        return made[3], made[4]

    def _rules(self) -> Rules:
        """The plan and rules as this update reads them (a caller may replace `gate` and the
        others between updates): the gate's and the lost rule's bars on the share of a scan a
        fit explains relaxed to what the track has learned of this plan (`Recovery.explained_bar`)."""
        gate, lost = self._relaxed_rules()
        return Rules(
            self.plan,
            self.config,
            self._wide_config,
            gate,
            self.motion_noise,
            self.degeneracy,
            self.continuity,
            self.fusion,
            self._occlusion,
            lost,
            self._recovery.config,
            self.refinement,
            self.gate,
            self._detector.rule,
        )


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


def _wrapped(pose: Pose) -> Pose:
    """`pose` with its yaw wrapped to (-pi, pi], as every pose the localizer reports (a yaw already
    in range is kept exactly)."""
    yaw = pose[2]
    return (pose[0], pose[1], yaw if -math.pi < yaw <= math.pi else wrap_angle(yaw))
