"""Settings of one scan-to-plan alignment."""

from __future__ import annotations

from functools import cached_property
from typing import TYPE_CHECKING, Annotated, Any, Literal

from pydantic.dataclasses import dataclass

from .. import _core
from .._settings import SETTINGS, Flag, Items, Real, Settings, Whole, non_empty

if TYPE_CHECKING:
    from ..plans.plan_map import PlanMap

CorrespondenceSearch = Literal["wall_index", "kd_tree"]


@dataclass(frozen=True, config=SETTINGS)
class IcpConfig(Settings):
    """How `localize` aligns a scan to the plan. Distances in metres, angles in radians.

    Attributes:
        max_correspondence_distance: a scan point farther than this from every (visible) plan
            point is an outlier: furniture, people and robots are not in the plan. The thesis used
            0.25 m. It is also the distance at which the final inliers are counted.
        max_iterations: most ICP iterations, over all stages of the schedule.
        trim_ratio: share (0, 1] of the in-range pairs, the closest ones, that each update uses
            (trimmed ICP). 1 keeps every pair within the stage's distance. With `auto_trim`, the
            most that may be kept.
        auto_trim: at every iteration, drop the pairs farther than 3 robust standard deviations
            (1.4826 times the median pair distance) from the plan, keeping at least 60 % of the
            in-range pairs before the last stage and 20 % in it. Wall pairs dominate the median,
            so people and furniture near the walls are cut while clean scans keep nearly every
            pair. On by default for tracking (`for_tracking()`, the `Localizer`'s settings): with
            half of the returns from a crowd it kept the error at 1.3 cm where plain ICP erred
            9 cm; from guesses 0.2 m and 3 degrees off, single alignments succeeded in 95-100 %
            of the cases, against 97-100 % without.
        translation_tolerance: a stage ends when an update moves the pose less than this...
        rotation_tolerance: ...and turns it less than this. 0 for both: always run
            `max_iterations` (the stages then split them evenly).
        subsample: use every k-th scan point for the iterations (the thesis used 2); every point is
            still scored for `inlier_mask`, `num_inliers` and `rmse`.
        correspondence_schedule: coarse-to-fine stages, as factors of
            `max_correspondence_distance`: stage k rejects pairs beyond
            `factor_k * max_correspondence_distance`.
        use_visibility: match only against the wall faces visible from the initial guess (ray
            cast through the plan), so that scan points cannot lock onto the far face of a wall.
        accelerate: when successive updates keep moving the same way by shrinking amounts, jump
            ahead along that series (Besl and McKay's accelerated ICP); a jump that makes the fit
            worse is undone at the next iteration.
        visibility_range: range of that ray casting; None: the scan's farthest point plus the
            largest stage distance.
        covariance_scale: factor applied to the point-to-wall covariance (the sandwich
            `H^-1 S H^-1`, `S` the Newey-West estimate over neighbouring beams, which counts the
            error a stretch of wall gives all the returns on it once, not once per return; see
            docs/design.md, "Covariance that means something"). What it leaves out is the plan's
            own lattice and the pairing's choices. Single alignments use 3; tracking
            (`for_tracking()`, whose trimming and the `Localizer`'s occlusion rule leave cleaner
            residuals) uses 4, which leaves the simulated floors' mean normalised estimation error
            squared a little under the chi-square's (docs/benchmarks.md, "Covariance calibration
            (NEES)").
        correspondence_search: how the nearest wall point of a scan point is found.
            "wall_index" (the default for single alignments): the plan's precomputed nearest-wall
            index, a raster whose every cell lists the one or two wall points that can be nearest
            to a point inside it (exact; 7-8 ns per look-up in a scan's batched pass, against
            150-200 ns for the KD-tree; built at the plan's first alignment and kept, see
            `PlanMap.prepare_index`).
            There `use_visibility` refuses a pair whose wall point cannot be seen from the robot
            (its 16-sector visibility mask, marched through the plan once), and offers the cell's
            near face instead, rather than ray casting from the guess. Schedules reaching beyond
            the index's reach (0.5 m) use the KD-tree. "kd_tree" (the default for tracking,
            `for_tracking`): the exact nearest of the wall points visible from the initial guess
            (ray cast through the plan). Within the index's reach the index answers every look-up
            whose nearest wall point is visible (the same pairs), the KD-tree the rest.
    """

    max_correspondence_distance: Annotated[float, Real(gt=0.0, unit="metres")] = 0.25
    max_iterations: Annotated[int, Whole(ge=1)] = 30
    trim_ratio: Annotated[float, Real(gt=0.0, le=1.0)] = 1.0
    auto_trim: Flag = False
    translation_tolerance: Annotated[float, Real(ge=0.0, note="(0 disables it)")] = 1e-4
    rotation_tolerance: Annotated[float, Real(ge=0.0, note="(0 disables it)")] = 1e-4
    subsample: Annotated[int, Whole(ge=1)] = 1
    correspondence_schedule: Annotated[
        tuple[Annotated[float, Real(gt=0.0, name="correspondence_schedule factor")], ...], Items, non_empty("stage")
    ] = (1.0, 0.5, 0.25)
    use_visibility: Flag = True
    accelerate: Flag = True
    visibility_range: Annotated[float, Real(gt=0.0, unit="metres")] | None = None
    covariance_scale: Annotated[float, Real(gt=0.0)] = 3.0
    correspondence_search: CorrespondenceSearch = "wall_index"

    def __post_init__(self) -> None:
        _ = self._native  # made now: the core checks the settings when they are made

    @cached_property
    def _native(self) -> _core.IcpSettings:
        """These settings as the core takes them: read by field name, and checked again by the core
        (`IcpConfig::validate`), which never runs with settings it has not checked. The checks here
        are those a user gets, naming the field; the core's guard its own callers."""
        return _core.IcpSettings(self)

    @classmethod
    def for_tracking(cls, plan: PlanMap | None = None, **changes: Any) -> IcpConfig:
        """The settings the `Localizer` uses by default for `plan`: these defaults with `auto_trim`
        on, since the odometry prediction is close, the covariance scale calibrated for tracking
        (4), and the visibility that suits how the plan's walls were read (`changes` override
        fields):

        - walls drawn as material (a drawing, an image, vector walls, or None): the KD-tree over
          the walls the ray cast from the prediction shows (`"kd_tree"`, through the plan's index,
          so at about the index's speed). A drawn wall stops every beam, and its far face, a
          wall's thickness behind the near one, must stay hidden however far the robot is.
        - an occupancy grid's occupied cell centres (`plan.cells_mark_returns`: a map_server map
          made by SLAM): the nearest-wall index's masks (`"wall_index"`), where a
          wall point is hidden only by another wall within 0.6 m of it. A SLAM map marks where
          returns ended, from every pose the map was made from: trees, posts and parked cars are
          specks that beams from other poses pass, and a cast from the prediction stops at them
          and hides the walls behind: on freiburg-campus ICP from the reference pose through the
          cast drifted to places the scan's likelihood rejects, and stayed at the reference
          through the masks, which also take a fraction of the cast's time
          (docs/benchmarks.md, "Visibility of a SLAM map: the cast or the masks")."""
        search = "wall_index" if plan is not None and plan.cells_mark_returns else "kd_tree"
        return cls(**{"auto_trim": True, "covariance_scale": 4.0, "correspondence_search": search, **changes})

    @property
    def stage_distances(self) -> tuple[float, ...]:
        """The rejection distance of each stage, metres."""
        return tuple(f * self.max_correspondence_distance for f in self.correspondence_schedule)
