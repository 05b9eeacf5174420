"""What each stage of a `Localizer.update` decided, and why: the typed records of the pipeline.

`Localizer.update` runs the stages of `planicp.tracking.stages` in order; each returns one of these
frozen records, and `Estimate.decisions` lists them in that order:

1. `Prediction`: the odometry motion applied to the last pose, and the grown covariance.
2. `FitDecision`: the scan aligned from the prediction (occlusion rule, ICP, KD-tree retry) and
   the acceptance gate's verdict.
3. `PendingDecision`: whether this scan confirms a place a rejected jump left pending.
4. `SearchDecision`: whether the plan was searched around the prediction, why, and what was found.
5. `ScoreDecision`: how much of the whole scan the plan explains, and whether a poor fit
   continues the last well explained scan.
6. `Correction`: the pose and covariance the fit leads to (fusion, weak axis, fit alone), or the
   prediction's.
7. `LeftPlaceDecision`: whether this scan prefers the place an adopted jump left behind.
8. `LostDecision`: what the lost rule concluded.
9. `RecoveryDecision`: what the recovery did (searched, coasted, cleared) and the place it
   adopted, if any.
10. `Bookkeeping`: what the update remembers for the next ones.

Each record has a `why` property: one sentence for a person reading a log.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, NamedTuple

import numpy as np
from numpy.typing import NDArray

from .._validation import Pose
from .degeneracy_rule import Degeneracy
from .icp_result import IcpResult
from .odometry_fault import FaultSweep
from .posterior_refinement import Refinement
from .recovery import Hypothesis

SearchCause = Literal["jump", "uncertain", "fault"]
"""Why the plan is searched around the prediction: "jump", a good fit rejected only for the size of
its correction; "uncertain", a prediction whose 3-sigma position uncertainty exceeds the gate's
translation limit; "fault", a scan the update's pose explains so much worse than the track's
recent scans that the odometry may have strayed far beyond its noise, and the heading sweep in the
plan's likelihood field found a place of higher posterior (`planicp.tracking.odometry_fault`)."""


class PendingPlace(NamedTuple):
    """A place a scan put the robot at that the localizer has not taken: left pending after a
    rejected jump or a suspected odometry fault, until a scan confirms or refutes it.

    Attributes:
        pose: the place at the scan of `odom` (T_map_base).
        odom: the odometry pose (T_odom_base) of that scan.
        silent: scans since that said nothing of it (0 for a place this scan left pending).
    """

    pose: Pose
    odom: Pose
    silent: int = 0


class LeftPlace(NamedTuple):
    """The place an adopted jump left behind, followed with the odometry (stage 7).

    Attributes:
        pose: the place at the scan of `odom` (T_map_base).
        odom: the odometry pose (T_odom_base) of that scan.
        evidence: what the scans judged since it was left prefer it by, in total: the sum of
            the scan's cost at the update's pose less its cost at the place (the fault cost `F`
            added where the update's pose needed a fault of its own); it is taken back above
            `F`, forgotten below `-F`.
    """

    pose: Pose
    odom: Pose
    evidence: float = 0.0


CorrectionKind = Literal["fused", "weak_axis", "fit", "prediction_mode", "prediction"]
"""How `Correction.pose` was made: "fused", the Kalman update of the prediction with the fit
(`FusionRule`); "weak_axis", the fit, except along a degenerate axis where the prediction is
corrected as far as the variances say (`fuse_along_weak_axis`); "fit", the fit alone;
"prediction_mode", a fit that disagrees with the prediction, which the scan does not prefer to the
prediction's surroundings by the fault cost: the mode of the scan's likelihood times the
prediction's Gaussian; "prediction", no accepted fit: the prediction."""

RecoveryAction = Literal["step", "coast", "verify", "clear"]
"""What the recovery did: "step", it searched or followed its places with the scan; "coast", the
scan was too small to align and its places followed the odometry; "verify", a place it adopted
before the whole plan was searched is on trial, and that search went on (`Recovery.verify`);
"clear", not lost: it forgot its places and any search in progress."""


@dataclass(frozen=True)
class Prediction:
    """Stage 1: the last pose moved by the odometry motion since the previous update.

    Attributes:
        odom: the odometry pose (T_odom_base) this update received.
        motion: the odometry motion since the previous update (base frame at its start); the
            identity at the first update after a start or reset (`first`).
        pose: the predicted pose (T_map_base): ICP's initial guess.
        covariance: 3x3 covariance of `pose`: the last one propagated through `motion` by
            `MotionNoise`.
        first: no odometry pose came before this one.
    """

    odom: Pose
    motion: Pose
    pose: Pose
    covariance: NDArray[np.float64]
    first: bool

    @property
    def why(self) -> str:
        """One sentence on this decision."""
        if self.first:
            return "first update: the prediction is the last pose"
        dx, dy, dyaw = self.motion
        return f"the odometry moved the robot by ({dx:.3f} m, {dy:.3f} m, {math.degrees(dyaw):.2f} deg)"


@dataclass(frozen=True)
class FitDecision:
    """Stage 2: the scan aligned from the prediction and judged by the acceptance gate.

    Attributes:
        result: the ICP result; None when the scan had too few usable points to align.
        kept: (N,) bool over the scan's points aligned after `OcclusionRule` left out the returns
            in front of the plan's walls; None when every point was aligned.
        beyond: (N,) bool over the scan's points beyond the walls seen from the prediction; None
            when the occlusion rule did not apply.
        occluded: the occlusion rule left fewer than its `min_points`, so every point was aligned.
        reason: the gate's rejection ("" when the fit passes), or why the scan was not aligned.
        usable: the scan had enough points to align.
        realigned: the fit landed more than a quarter of the occlusion rule's margin from the
            prediction, so every return was aligned again from the prediction.
        retried: the nearest-wall index's fit explained the scan poorly and the KD-tree's fit,
            which paired more points, replaced it.
    """

    result: IcpResult | None
    kept: NDArray[np.bool_] | None
    beyond: NDArray[np.bool_] | None
    occluded: bool
    reason: str
    usable: bool
    realigned: bool = False
    retried: bool = False

    @property
    def passed(self) -> bool:
        """The fit exists and the gate passed it."""
        return self.result is not None and self.reason == ""

    @property
    def why(self) -> str:
        """One sentence on this decision."""
        if self.result is None:
            return f"not aligned: {self.reason}"
        how = " (KD-tree retry)" if self.retried else (" (every return, again)" if self.realigned else "")
        verdict = "passed the gate" if self.reason == "" else f"rejected: {self.reason}"
        return (
            f"fit from the prediction{how} explains {100 * self.result.inlier_ratio:.0f} % of the aligned points, "
            f"{verdict}"
        )


@dataclass(frozen=True)
class PendingDecision:
    """Stage 3: the places rejected jumps left pending, checked against this scan.

    Attributes:
        place: the pending place this scan confirms, followed with the odometry to it (T_map_base);
            without one, the first pending place followed to it; None when no place was pending.
        confirmed: the fit at `place` when this scan confirms it (a sound fit there that explains
            the scan better than the prediction's fit by the recovery's `margin`, or the
            prediction's was rejected, or that the scan's likelihood prefers by the fault cost);
            the update goes on with it. None otherwise.
        kept: the places, followed to this scan's odometry pose, still pending for the next scan
            because this scan says nothing of them: it could not be aligned, or it explains
            neither the place nor the prediction (the gate rejects both fits, or its cost in the
            plan's likelihood field exceeds the track's typical cost by the fault cost at both).
            Empty when a place was confirmed.
        checked: how many places were pending.
    """

    place: Pose | None
    confirmed: IcpResult | None
    kept: tuple[PendingPlace, ...] = ()
    checked: int = 0

    @property
    def why(self) -> str:
        """One sentence on this decision."""
        if self.checked == 0:
            return "no place pending"
        of = "the pending place" if self.checked == 1 else f"{self.checked} pending places"
        if self.confirmed is not None:
            return f"this scan confirms {of if self.checked == 1 else 'one of ' + of}: taken"
        if len(self.kept) == self.checked:
            return f"this scan says nothing of {of}: still pending"
        if self.kept:
            return f"this scan refutes {self.checked - len(self.kept)} of {of} and says nothing of the rest"
        return f"this scan does not confirm {of}: forgotten"


@dataclass(frozen=True)
class SearchDecision:
    """Stage 4: the search around the prediction when the gate cannot vouch for this update.

    Attributes:
        cause: why the plan was searched (see `SearchCause`); None: no search.
        found: the refined fit at the unambiguous place the search found, when one passed its
            checks; None otherwise.
        result: the fit the update goes on with: the search's place for an uncertain prediction,
            the place an odometry fault leaves the robot at, the confirmed pending place (stage 3),
            else the fit from the prediction.
        reason: why `result` is not accepted ("" when it is, so far); after a rejected jump, the
            gate's reason and where the pending place is.
        searched: `result` is a search's, a fault's or a confirmed place's fit, over the whole
            scan (not fused with the prediction; adopted as `Estimate.relocalized`).
        pending: the place the next scan is to confirm, after a rejected jump; None otherwise.
        fault: the heading sweep for an odometry fault, when it ran (`cause` is "fault" when
            it found a place of higher posterior that ICP fits soundly, taken as `result`); None
            otherwise.
        left: after a place the fault sweep found, or a jump's place an odometry fault explains,
            was taken, the pose it leaves: the prediction
            (T_map_base; were the scan corrupted, it would say nothing, and the robot would be
            where the odometry puts it), which the next scans weigh (stage 7); None otherwise.
    """

    cause: SearchCause | None
    found: IcpResult | None
    result: IcpResult | None
    reason: str
    searched: bool
    pending: PendingPlace | None = None
    fault: FaultSweep | None = None
    left: Pose | None = None

    @property
    def why(self) -> str:
        """One sentence on this decision."""
        if self.cause is None:
            if self.searched:
                return "the place a pending jump led to was confirmed"
            return "no search" if self.fault is None else self._no_fault_found(self.fault)
        if self.cause == "fault":
            assert self.fault is not None
            return (
                f"odometry fault: the scan's cost {self.fault.current_cost:.1f} against a typical "
                f"{self.fault.typical:.1f}; a place within the fault model costing {self.fault.cost:.1f} is "
                "taken, the track's own pose left behind for the next scans to weigh"
            )
        if self.cause == "uncertain":
            if self.found is not None:
                return "uncertain prediction: the search found a place, taken"
            found_none = "uncertain prediction: the search found no place that passes"
            return found_none if self.fault is None else f"{found_none}; {self._no_fault_found(self.fault)}"
        if self.searched:
            return (
                "jump beyond the gate to a place an odometry fault explains: taken, the prediction left "
                "behind for the next scans to weigh"
            )
        return f"jump rejected: {self.reason}"

    @staticmethod
    def _no_fault_found(sweep: FaultSweep) -> str:
        """What a sweep for an odometry fault that found no more probable place says."""
        return (
            f"the scan's cost {sweep.current_cost:.1f} exceeds the track's typical {sweep.typical:.1f} by over "
            f"{sweep.threshold:.1f}: the sweep for an odometry fault found no place better by that "
            f"(best {sweep.cost:.1f})"
        )


@dataclass(frozen=True)
class ScoreDecision:
    """Stage 5: how much of the whole scan the plan explains, and what a poor fit means.

    Attributes:
        score: the share of the whole scan the plan explains: returns the occlusion rule left out,
            and returns beyond the walls seen from the prediction, count as unexplained (0 when the
            scan was not aligned).
        poor: the plan explains the fit poorly: rejected for its fit, or accepted with a `score`
            below the lost rule's `min_score`.
        continues: for a poor fit while not lost, whether the scan is clutter or a crowd
            (continues the last well explained scan, or the plan explains the kept returns well):
            True, it does not count towards being lost; False, the fit is not trusted. None: not
            checked. A fit not poor by the learned bars but below the lost rule's as set is
            checked for a crowd only (True, or None).
        reason: why the fit is not accepted ("" when it is): the search stage's, or, for an
            accepted poor fit that does not continue the last well explained scan, that.
    """

    score: float
    poor: bool
    continues: bool | None
    reason: str

    @property
    def why(self) -> str:
        """One sentence on this decision."""
        text = f"the plan explains {100 * self.score:.0f} % of the scan"
        if self.continues is True:
            text += (
                ", poorly, but the scan is clutter (it continues the last well explained scan or a crowd hides "
                "the walls)"
            )
        elif self.continues is False:
            text += ", poorly, and the scan does not continue the last well explained one"
        elif self.poor:
            text += ", poorly"
        return text


@dataclass(frozen=True)
class Correction:
    """Stage 6: the pose and covariance this update leads to, before the recovery.

    Attributes:
        pose: (x, y, yaw), T_map_base.
        covariance: 3x3 covariance of `pose`.
        accepted: a fit was accepted (`kind` is not "prediction").
        degeneracy: the weak axis of the accepted fit, or None.
        kind: how `pose` was made (see `CorrectionKind`).
        refinement: how `pose` was refined in the plan's likelihood field after it was made
            (`planicp.tracking.posterior_refinement`), or None.
        refused: why a fit the gate and the score accepted is not used ("" when it is, or
            when there was none to refuse): it disagrees with the prediction beyond their
            covariances and explains the scan far worse than the track's scans are explained.
    """

    pose: Pose
    covariance: NDArray[np.float64]
    accepted: bool
    degeneracy: Degeneracy | None
    kind: CorrectionKind
    refinement: Refinement | None = None
    refused: str = ""

    @property
    def why(self) -> str:
        """One sentence on this decision."""
        text = {
            "fused": "the fit fused with the prediction",
            "weak_axis": "the fit, with the prediction kept along its degenerate axis as far as the variances say",
            "fit": "the fit alone",
            "prediction_mode": (
                "the fit disagrees with the prediction, but the scan does not prefer it to the prediction's "
                "surroundings by the fault cost: the scan's most likely pose near the prediction"
            ),
            "prediction": "no accepted fit: the prediction",
        }[self.kind]
        if self.refused:
            text += f" ({self.refused})"
        refinement = self.refinement
        if refinement is not None and refinement.other is not None:
            text += (
                f", moved {100 * refinement.moved:.1f} cm to the posterior's mean over two modes "
                f"(the less likely one weighed {100 * min(refinement.other_share, 1 - refinement.other_share):.0f} %)"
            )
        elif refinement is not None and refinement.moved >= 0.005:
            text += f", moved {100 * refinement.moved:.1f} cm to the scan's most likely pose"
        return text


@dataclass(frozen=True)
class LeftPlaceDecision:
    """Stage 7: the place an adopted jump left behind, weighed against this scan.

    A place an odometry fault led to is taken at once, one a pending jump led to once the next
    scan confirms it; the place the track would have been at instead (that update's fit from the
    prediction, or the prediction) is then followed with the odometry, climbed to the mode of each
    scan's likelihood in the plan's field, for as long as the scans cannot rule it out by the
    fault cost (`planicp.tracking.odometry_fault`): a fault, a scan turned within the fault
    window and a map whose passes disagree look alike on one scan.

    Attributes:
        place: the place left behind, followed to this scan and climbed (T_map_base); None when
            none is followed (or while lost).
        cost: the scan's cost at `place` (no prior); NaN when `place` is None.
        current_cost: the scan's cost at the corrected pose; without an accepted fit, the lowest
            of the prediction's and those of the places the scan offered the track (the fit from
            the prediction, a place left pending); NaN when `place` is None.
        returned: ICP from `place` when the scans since it was left prefer it by more than the
            fault cost (and, without an accepted fit, ICP from it passes the gate): the update
            takes `place`, and follows the pose it leaves instead. None otherwise.
        evidence: what the scans judged since the place was left prefer it by, this one's
            included (see `LeftPlace.evidence`); NaN when `place` is None.
        kept: the place at this scan (unclimbed, without an accepted fit), still followed;
            None when it is taken back, ruled out, merged, or none was followed.
        merged: the place's mode is the corrected pose's (within the 99.9 % bound of its
            covariance): one hypothesis again, and the place is forgotten.
    """

    place: Pose | None
    cost: float = math.nan
    current_cost: float = math.nan
    returned: IcpResult | None = None
    evidence: float = math.nan
    kept: LeftPlace | None = None
    merged: bool = False

    @property
    def why(self) -> str:
        """One sentence on this decision."""
        if self.place is None:
            return "no place left behind is followed"
        costs = (
            f"cost {self.cost:.1f} there against {self.current_cost:.1f} here; "
            f"{self.evidence:+.1f} for it since it was left"
        )
        if self.merged:
            return "the place left behind has the track's own mode again: forgotten"
        if self.returned is not None:
            return f"this scan prefers the place left behind ({costs}): taken back"
        if self.kept is None:
            return f"this scan rules out the place left behind ({costs}): forgotten"
        return f"the place left behind is still followed ({costs})"


@dataclass(frozen=True)
class LostDecision:
    """Stage 8: the lost rule's verdict on this update.

    Attributes:
        lost: the lost rule says the plan no longer explains the scans.
        held: the scan tells nothing about being lost (clutter or a crowd): the state was kept
            and the scan not counted.
        counted_accepted: the lost rule counted the scan as accepted (an accepted fit that, while
            lost, explains as much of the scan as the recovery asks of a place it adopts).
        window_score: the mean score over the lost rule's window after this scan.
        rejections: scans in a row the lost rule counts as rejected.
        doubted: not lost only because the rule's bar is relaxed to what the track has learned of
            the plan (`LostRule.relaxed_to`): the rule as set would say lost. The recovery then
            searches the whole plan beside the track, and a place that explains the scans better
            replaces it (`Recovery.doubt`).
        regained: the lost state ended with this scan, on the fit from the prediction: the track
            is a place near where it was lost, judged as one the recovery finds there
            (`Recovery.regain`): on trial while the search of the whole plan goes on.
    """

    lost: bool
    held: bool
    counted_accepted: bool
    window_score: float
    rejections: int
    doubted: bool = False
    regained: bool = False

    @property
    def why(self) -> str:
        """One sentence on this decision."""
        state = "lost" if self.lost else "tracking"
        if self.held:
            return f"{state}: the scan is not counted (clutter)"
        doubt = "; lost by the bar as set: the whole plan is searched beside the track" if self.doubted else ""
        if self.regained:
            doubt = "; regained on the fit from the prediction" + doubt
        return f"{state}: mean score {self.window_score:.2f}, {self.rejections} rejection(s) in a row{doubt}"


@dataclass(frozen=True)
class RecoveryDecision:
    """Stage 9: what the recovery did with this update.

    Attributes:
        action: see `RecoveryAction`.
        adopted: the place the recovery confirmed and the update adopts (its pose and fit); None
            when none.
        covariance: the covariance of the adopted place (its fit's, or the prediction's when that
            is not finite); None when none was adopted.
        hypotheses: the places the recovery is following after this update (while lost), or
            the places that rival the one on trial.
        on_trial: after this update the pose follows a place adopted before the search of the
            whole plan ended, which goes on (`Estimate.provisional`).
        lost_at: the pose the localizer lost track at, when it was not the prediction: the place
            an adopted jump left behind, which the scans since preferred to the track
            (`LeftPlaceDecision.evidence` above zero); the lost pose coasts from it and the
            recovery searches around it. None otherwise.
    """

    action: RecoveryAction
    adopted: Hypothesis | None
    covariance: NDArray[np.float64] | None
    hypotheses: tuple[Pose, ...]
    on_trial: bool = False
    lost_at: Pose | None = None

    @property
    def why(self) -> str:
        """One sentence on this decision."""
        if self.adopted is not None:
            trial = ", on trial while the search of the whole plan goes on" if self.on_trial else ""
            if self.action == "verify":
                return (
                    f"a place the search of the whole plan found explained {self.adopted.streak} scans "
                    f"better than the one on trial: adopted"
                )
            return f"the recovery confirmed a place over {self.adopted.streak} scans: adopted{trial}"
        if self.action == "verify":
            return (
                f"the pose is on trial: the search of the whole plan goes on, "
                f"{len(self.hypotheses)} rival place(s) followed"
            )
        if self.action == "clear":
            return "not lost: the recovery is idle"
        if self.action == "coast":
            return "lost, scan too small to align: the recovery's places follow the odometry"
        if self.lost_at is not None:
            return (
                f"lost where the scans preferred the place left behind to the track: the pose coasts from that "
                f"place, and the recovery searches around it and follows {len(self.hypotheses)} place(s)"
            )
        return f"lost: the recovery follows {len(self.hypotheses)} place(s)"


@dataclass(frozen=True)
class Bookkeeping:
    """Stage 10: what this update leaves for the next ones (besides pose, covariance, odometry, the
    pending place of `SearchDecision.pending` and the place left behind of `LeftPlaceDecision`).

    Attributes:
        anchored: the scan becomes the one later scans are checked against for continuity (an
            accepted fit the plan explains well, or clutter that continues the last one).
        beyond_share: the share of the scan's returns beyond the walls seen from the prediction
            (from the fit's pose when the prediction was too uncertain to classify them), recorded
            for `Recovery.beyond_limit` (a soundly tracked scan); None when not recorded.
        explained_share: the share of the scan's returns its fit explained, recorded for
            `Recovery.explained_seen` (a soundly tracked scan); None when not recorded.
        vouched: the scan vouches for the pose: soundly tracked, and its fit explained at least
            the share of its returns the track's sound fits make likely (`Recovery.explained_seen`
            before this one). A track lost later is searched for from the last such pose
            (`Recovery.note_tracked`).
    """

    anchored: bool
    beyond_share: float | None
    explained_share: float | None = None
    vouched: bool = False

    @property
    def why(self) -> str:
        """One sentence on this decision."""
        parts = ["the scan is the new continuity anchor" if self.anchored else "the continuity anchor is kept"]
        if self.beyond_share is not None:
            parts.append(f"{100 * self.beyond_share:.0f} % of its returns beyond the walls recorded")
        if self.explained_share is not None:
            parts.append(f"{100 * self.explained_share:.0f} % of its returns explained recorded")
        if self.vouched:
            parts.append("the pose is vouched for")
        return "; ".join(parts)


Decision = (
    Prediction
    | FitDecision
    | PendingDecision
    | SearchDecision
    | ScoreDecision
    | Correction
    | LeftPlaceDecision
    | LostDecision
    | RecoveryDecision
    | Bookkeeping
)
"""Any stage's decision (the items of `Estimate.decisions`)."""
