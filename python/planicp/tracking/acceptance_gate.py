"""When the `Localizer` trusts an ICP result instead of the odometry prediction."""

from __future__ import annotations

import dataclasses
import math
from typing import Annotated

from pydantic.dataclasses import dataclass

from .._settings import SETTINGS, Flag, Real, Settings, Whole
from .._validation import Pose
from ..se2 import between
from .icp_result import IcpResult


@dataclass(frozen=True, config=SETTINGS)
class AcceptanceGate(Settings):
    """When the `Localizer` trusts an ICP result instead of odometry.

    Attributes:
        require_convergence: reject results whose ICP ran out of iterations. Off by default: a
            result still creeping by more than the tolerances after `max_iterations` is almost
            always closer than the odometry prediction (on the Intel log with synthetic drift,
            requiring convergence rejected 74 % of the scans and lost track); the inlier and jump
            checks judge the fit instead.
        min_inliers: fewest scan points within `max_correspondence_distance` of the plan.
        min_inlier_ratio: smallest share of scan points that are inliers, until the track has
            learned how little of its scans this plan explains where the localizer is right:
            then the lower of this and that share (`relaxed_to`, `Recovery.explained_bar`).
        relaxes: whether `min_inlier_ratio` relaxes so (False: the bar as set, always).
        max_translation_jump: largest correction (metres) of the odometry prediction.
        max_rotation_jump: largest correction (radians) of the odometry prediction.
    """

    require_convergence: Flag = False
    min_inliers: Annotated[int, Whole(ge=0)] = 30
    min_inlier_ratio: Annotated[float, Real(ge=0.0, le=1.0)] = 0.25
    relaxes: Flag = True
    max_translation_jump: Annotated[float, Real(gt=0.0, unit="metres")] = 0.5
    max_rotation_jump: Annotated[float, Real(gt=0.0, unit="radians")] = math.radians(10.0)

    def relaxed_to(self, explained: float | None) -> AcceptanceGate:
        """This gate with `min_inlier_ratio` lowered to `explained` where that is lower (None, or
        not `relaxes`: unchanged): the share of its scan a sound fit may explain on this plan
        (`Recovery.explained_bar`). A map made with few scans (a SLAM map whose cells need
        several hits) lacks walls the robot sees: on orebro's map whose cells need 3 hits, the
        reference pose explains 10-17 % of three scans in a row (docs/benchmarks.md, "Sparser
        and denser maps"), and a fixed 25 % refused their right fits until the odometry had
        carried the track away."""
        if explained is None or not self.relaxes or explained >= self.min_inlier_ratio:
            return self
        return dataclasses.replace(self, min_inlier_ratio=explained)

    def rejection(self, result: IcpResult, predicted: Pose) -> str:
        """Why `result` is not trusted, or "" when it is."""
        return self.fit_rejection(result) or self.jump_rejection(result, predicted)

    def fit_rejection(self, result: IcpResult) -> str:
        """Why the fit itself is not trusted (convergence, inliers), or "" when it is."""
        if self.require_convergence and not result.converged:
            return f"ICP did not converge in {result.iterations} iterations"
        if result.num_inliers < self.min_inliers:
            return f"only {result.num_inliers} inliers (need {self.min_inliers})"
        if result.inlier_ratio < self.min_inlier_ratio:
            return f"inlier ratio {result.inlier_ratio:.2f} below {self.min_inlier_ratio:.2f}"
        return ""

    def jump_rejection(self, result: IcpResult, predicted: Pose) -> str:
        """Why the correction of `predicted` is too large to trust, or "" when it is not."""
        dx, dy, dyaw = between(predicted, result.pose)
        jump = math.hypot(dx, dy)
        if jump > self.max_translation_jump:
            return f"correction of {jump:.3f} m exceeds {self.max_translation_jump:.3f} m"
        if abs(dyaw) > self.max_rotation_jump:
            return (
                f"correction of {math.degrees(abs(dyaw)):.2f} deg exceeds "
                f"{math.degrees(self.max_rotation_jump):.2f} deg"
            )
        return ""
