"""The plan and rules one `Localizer.update` reads (`Rules`), which every stage is given."""

from __future__ import annotations

from dataclasses import dataclass

from ...plans.plan_map import PlanMap
from ..acceptance_gate import AcceptanceGate
from ..continuity_rule import ContinuityRule
from ..degeneracy_rule import DegeneracyRule
from ..fusion_rule import FusionRule
from ..icp_config import IcpConfig
from ..icp_result import IcpResult
from ..lost_rule import LostRule
from ..motion_noise import MotionNoise
from ..occlusion_rule import OcclusionFilter
from ..posterior_refinement import PosteriorRefinement
from ..recovery import RecoveryConfig


@dataclass(frozen=True)
class Rules:
    """The `Localizer`'s plan and rules as one update reads them.

    Attributes:
        plan: the plan.
        config: ICP settings.
        wide_config: `config` with the KD-tree search: the retry of a poor fit with the index,
            and the fits at pending places.
        gate: the acceptance gate this update applies: the `Localizer`'s, its inlier-ratio bar
            relaxed to what the track has learned of the plan (`AcceptanceGate.relaxed_to`).
        motion_noise, degeneracy, continuity, fusion: the rules of those names.
        occlusion: the occlusion filter; None: every return is aligned.
        lost: the lost rule this update applies, relaxed as `gate` (`LostRule.relaxed_to`).
        recovery: the recovery's settings (its `local_radius`, `margin`, `min_inlier_ratio` and
            search serve the searches around the prediction too).
        refinement: how a corrected pose is refined in the plan's likelihood field.
        gate_as_set, lost_as_set: the gate and the lost rule as set, not relaxed: a fit is
            recorded as sound (and so teaches what the plan explains) only when it passes them.
    """

    plan: PlanMap
    config: IcpConfig
    wide_config: IcpConfig
    gate: AcceptanceGate
    motion_noise: MotionNoise
    degeneracy: DegeneracyRule
    continuity: ContinuityRule
    fusion: FusionRule
    occlusion: OcclusionFilter | None
    lost: LostRule
    recovery: RecoveryConfig
    refinement: PosteriorRefinement
    gate_as_set: AcceptanceGate
    lost_as_set: LostRule

    def passes_as_set(self, result: IcpResult, score: float) -> bool:
        """Whether the fit `result`, whose scan the plan explains `score` of, passes the gate's and
        the lost rule's bars as set, not only as relaxed (`gate_as_set`, `lost_as_set`): a sound
        fit, which teaches what the plan explains and may claim an odometry fault."""
        return self.gate_as_set.fit_rejection(result) == "" and score >= self.lost_as_set.min_score
