"""The logic of `planicp_node` without ROS: scans, odometry and initial poses in; poses, the
map -> odom correction, the enhanced occupancy grid and diagnostics out.

`rospy_node` is a thin wrapper that converts messages to these calls and the results back to
messages; everything that decides something lives here and is tested without ROS.

Frames (REP-105): the localizer tracks T_map_base; odometry gives T_odom_base; the node publishes
T_map_odom = T_map_base * inv(T_odom_base), so that map -> odom -> base gives the estimate while
odom -> base stays continuous. Stamps are seconds (ROS time), distances metres, angles radians.
"""

from __future__ import annotations

import math
import threading
from collections import deque
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .. import _core
from .._validation import Pose, as_pose
from ..laser_scan import scan_to_points
from ..mapping.enhanced_occupancy_grid import EnhancedOccupancyGrid
from ..mapping.occupancy_grid_message import OccupancyGridMessage
from ..plans.plan_map import PlanMap
from ..se2 import between, compose, matrix_to_pose
from ..tracking.localizer import Localizer
from ..tracking.localizer import _covariance as validated_covariance
from .message_layout import covariance_from_6x6
from .node_diagnostics import ERROR, OK, WARN, NodeDiagnostics
from .node_io import PoseOutput, ScanInput, as_stamp
from .node_settings import NodeSettings
from .odometry_buffer import OdometryBuffer
from .plan_grid import plan_occupancy_grid

TIME_JUMP_BACK = 1.0
"""Seconds by which odometry may go back in time before the node takes it as a restart of the clock
(a bag played again, a simulator reset) and forgets its odometry and pending scan."""

DIAGNOSTIC_WINDOW = 50
"""Processed scans over which the recent accepted share and inlier ratio are taken."""

MIN_ACCEPTED_SHARE = 0.5
"""Below this recent accepted share the diagnostic is a warning."""


class PlanicpNodeCore:
    """Localizes a robot in a plan from a stream of scans and odometry, as `planicp_node` does.

    Each scan is paired with the odometry pose at its stamp (interpolated; a scan newer than the
    newest odometry waits for it, one scan at a time) and goes to a `planicp.Localizer`. A scan that
    is malformed, out of order, or older than the odometry kept is refused with a clear error or
    dropped, is counted in the diagnostics, and leaves the pose as it was.

    Thread-safe: every method takes one lock (ROS delivers each topic on its own thread).
    """

    def __init__(self, plan: PlanMap, settings: NodeSettings | None = None) -> None:
        """
        Args:
            plan: the plan the robot localizes in (map frame).
            settings: the node's parameters (None: `NodeSettings()`; its `plan` is not read here).
        """
        if not isinstance(plan, PlanMap):
            raise TypeError(f"plan must be a planicp.PlanMap, got {type(plan).__name__}")
        self.settings = settings if settings is not None else NodeSettings()
        if not isinstance(self.settings, NodeSettings):
            raise TypeError(f"settings must be NodeSettings, got {type(self.settings).__name__}")
        s = self.settings
        self.plan = plan
        self.localizer = Localizer(
            plan,
            s.initial_pose,
            s.icp_config(plan),
            gate=s.acceptance_gate(),
            lost_rule=s.lost_rule(),
            initial_covariance=s.initial_covariance(),
        )
        self._odometry = OdometryBuffer(s.odometry_span)
        self._eog = EnhancedOccupancyGrid(plan, s.eog_resolution) if s.eog_topic else None
        self._pending: ScanInput | None = None
        self._reset: tuple[Pose, NDArray[np.float64], Pose | None] | None = None
        self._last_stamp: float | None = None
        self._last: PoseOutput | None = None
        self._recent: deque[tuple[bool, float]] = deque(maxlen=DIAGNOSTIC_WINDOW)
        self._counts = dict.fromkeys(
            (
                "scans_received",
                "scans_processed",
                "accepted",
                "rejected",
                "malformed_scans",
                "malformed_odometry",
                "malformed_initial_poses",
                "scans_without_odometry",
                "scans_without_laser_pose",
                "out_of_order",
                "failed_updates",
                "scans_before_initial_pose",
            ),
            0,
        )
        self._last_reason = ""
        self._last_problem = ""
        self._last_failed = False  # the localizer refused the last scan it was given
        self._pose_known = not self.settings.wait_for_initial_pose
        self._global_localization = False  # search the whole plan with the next scan
        self._lock = threading.RLock()

    @classmethod
    def from_settings(cls, settings: NodeSettings) -> PlanicpNodeCore:
        """A core with the plan that `settings.plan` names loaded."""
        return cls(settings.load_plan(), settings)

    # --- inputs ----------------------------------------------------------------------------------

    def add_odometry(self, stamp: float, pose: Any) -> list[PoseOutput]:
        """One odometry message: T_odom_base (x, y, yaw) at `stamp` seconds.

        Returns the outputs of a waiting scan that this message lets the node process (at most one).

        Raises:
            TypeError, ValueError: a malformed message (non-finite, or older than the previous one
                by less than `TIME_JUMP_BACK`); it is counted and changes nothing.
        """
        with self._lock:
            try:
                t = as_stamp(stamp, "odometry stamp")
                odom = as_pose(pose, "odometry pose")
                newest = self._odometry.newest
                if newest is not None and t < newest - TIME_JUMP_BACK:
                    self._restart_clock()
                self._odometry.add(t, odom)
            except (TypeError, ValueError) as exc:
                self._problem("malformed_odometry", f"odometry refused: {exc}")
                raise
            pending = self._pending
            if pending is not None and self._odometry.covers(pending.stamp):
                self._pending = None
                return [self._process(pending)]
            return []

    def add_scan_message(self, stamp: float, msg: Any, mount: tuple[Any, bool]) -> list[PoseOutput]:
        """`add_scan` for a `sensor_msgs/LaserScan` (ROS 1 or 2: the fields are named alike) stamped
        `stamp` (seconds), from a laser mounted at `mount`: (T_base_laser, whether the laser is
        upside down, which mirrors its angles)."""
        laser_pose, flipped = mount
        sign = -1.0 if flipped else 1.0
        return self.add_scan(
            stamp,
            msg.ranges,
            sign * msg.angle_min,
            sign * msg.angle_increment,
            msg.range_min,
            msg.range_max,
            angle_max=sign * msg.angle_max,
            laser_pose=laser_pose,
        )

    def add_scan(
        self,
        stamp: float,
        ranges: Any,
        angle_min: float,
        angle_increment: float,
        range_min: float,
        range_max: float,
        *,
        angle_max: float | None = None,
        laser_pose: Any = (0.0, 0.0, 0.0),
    ) -> list[PoseOutput]:
        """One LaserScan (fields as in `ScanInput`; `laser_pose` is T_base_laser).

        Returns the output for this scan when the odometry already covers its stamp; an empty list
        when it waits for odometry (it is processed by the `add_odometry` that covers it, unless a
        newer scan replaces it first) or was dropped (out of order, older than the odometry kept).

        Raises:
            TypeError, ValueError: a malformed scan (empty, wrong beam count for its angles,
                non-finite angles or limits, ...); it is counted and changes nothing.
        """
        with self._lock:
            self._counts["scans_received"] += 1
            s = self.settings
            try:
                if s.laser_min_range > 0.0:
                    range_min = s.laser_min_range
                if s.laser_max_range > 0.0:
                    range_max = s.laser_max_range
                scan = ScanInput(stamp, ranges, angle_min, angle_increment, range_min, range_max, laser_pose, angle_max)
            except (TypeError, ValueError) as exc:
                self._problem("malformed_scans", f"scan refused: {exc}")
                raise
            if not self._pose_known:
                self._problem(
                    "scans_before_initial_pose",
                    "waiting for an initial pose (initialpose, or global localization) before localizing",
                )
                return []
            if self._last_stamp is not None and scan.stamp <= self._last_stamp:
                self._problem(
                    "out_of_order",
                    f"scan at {scan.stamp:.3f} s is not newer than the last one ({self._last_stamp:.3f} s): dropped",
                )
                return []
            oldest, newest = self._odometry.oldest, self._odometry.newest
            if oldest is not None and scan.stamp < oldest:
                self._problem(
                    "scans_without_odometry",
                    f"scan at {scan.stamp:.3f} s is older than the odometry kept (from {oldest:.3f} s): dropped",
                )
                return []
            if newest is None or scan.stamp > newest:
                if self._pending is not None:
                    self._problem(
                        "scans_without_odometry",
                        f"no odometry reached the scan at {self._pending.stamp:.3f} s before the next scan: dropped",
                    )
                self._pending = scan
                return []
            return [self._process(scan)]

    def drop_scan_without_laser_pose(self, frame_id: str, why: str) -> None:
        """Counts a scan the wrapper could not place: no transform from the base to its laser frame."""
        with self._lock:
            self._counts["scans_received"] += 1
            self._problem("scans_without_laser_pose", f"scan in frame {frame_id!r} dropped: {why}")

    def set_initial_pose(self, stamp: float, pose: Any, covariance: Any = None) -> None:
        """An initial pose (RViz's "2D Pose Estimate"): T_map_base at `stamp` seconds.

        The next processed scan starts from it, moved by the odometry between `stamp` (or the
        newest odometry, when the buffer does not reach back to it) and that scan.

        Args:
            covariance: 3x3 over (x, y, yaw), or the 36 values of a 6x6 message covariance;
                None, or all zeros (RViz sends fixed values, some tools zeros): the settings'
                `initial_std`.

        Raises:
            TypeError, ValueError: a malformed pose or covariance; counted, changes nothing.
        """
        with self._lock:
            try:
                t = as_stamp(stamp, "initial pose stamp")
                start = as_pose(pose, "initial pose")
                cov = validated_covariance(self._covariance(covariance))
            except (TypeError, ValueError) as exc:
                self._problem("malformed_initial_poses", f"initial pose refused: {exc}")
                raise
            odom_ref = self._odometry.at(t) if t > 0.0 else None
            self._reset = (start, cov, odom_ref if odom_ref is not None else self._odometry.latest_pose)
            self._global_localization = False
            self._pose_known = True

    def request_global_localization(self) -> None:
        """Searches the whole plan for the robot with the next processed scan (nav2_amcl's
        `reinitialize_global_localization`): the pose jumps to an unambiguous place that explains
        the scan, else the localizer is lost and follows the candidates with the next scans until
        one is confirmed. An initial pose given before that scan cancels the search."""
        with self._lock:
            self._global_localization = True
            self._reset = None
            self._pose_known = True

    # --- outputs ---------------------------------------------------------------------------------

    @property
    def last_output(self) -> PoseOutput | None:
        """The output of the last processed scan (None before the first)."""
        return self._last

    def plan_grid(self) -> OccupancyGridMessage:
        """The plan as occupancy grid data (walls 100, else 0), for the latched plan topic."""
        return plan_occupancy_grid(self.plan, self.settings.plan_resolution)

    def eog(self) -> OccupancyGridMessage | None:
        """The enhanced occupancy grid so far, as `nav_msgs/OccupancyGrid` data (None when the
        settings' `eog_topic` is empty: no grid is built)."""
        with self._lock:
            return self._eog.to_occupancy_grid() if self._eog is not None else None

    def diagnostics(self) -> NodeDiagnostics:
        """The counters and the quality of the recent estimates, with a level and a message."""
        with self._lock:
            c = self._counts
            last = self._last
            recent = list(self._recent)
            share = sum(a for a, _ in recent) / len(recent) if recent else math.nan
            ratios = [r for _, r in recent if math.isfinite(r)]
            mean_ratio = sum(ratios) / len(ratios) if ratios else math.nan
            lost = last is not None and last.estimate.lost
            provisional = last is not None and last.estimate.provisional
            if lost:
                level, message = ERROR, "lost: the plan no longer explains the scans; searching the plan"
            elif provisional:
                level, message = (
                    WARN,
                    (
                        "provisional: tracking a place found near where track was lost, "
                        "while the search of the whole plan goes on"
                    ),
                )
            elif self._last_failed:
                level, message = WARN, f"the last scan was refused: {self._last_problem}"
            elif not self._pose_known:
                level, message = WARN, "waiting for an initial pose (initialpose, or global localization)"
            elif last is None:
                level, message = WARN, "waiting for scans and odometry"
            elif share < MIN_ACCEPTED_SHARE:
                level, message = (
                    WARN,
                    (f"only {100 * share:.0f} % of the last {len(recent)} scans accepted (last: {self._last_reason})"),
                )
            else:
                level, message = (
                    OK,
                    (
                        f"tracking: {100 * share:.0f} % of the last {len(recent)} scans "
                        f"accepted, inlier ratio {mean_ratio:.2f}"
                    ),
                )
            return NodeDiagnostics(
                level,
                message,
                c["scans_received"],
                c["scans_processed"],
                c["accepted"],
                c["rejected"],
                c["malformed_scans"],
                c["malformed_odometry"],
                c["malformed_initial_poses"],
                c["scans_without_odometry"],
                c["scans_without_laser_pose"],
                c["out_of_order"],
                last.inlier_ratio if last is not None else math.nan,
                share,
                mean_ratio,
                lost,
                provisional,
                self._last_reason,
                self._last_problem,
                c["failed_updates"],
                c["scans_before_initial_pose"],
            )

    # --- internals -------------------------------------------------------------------------------

    def _process(self, scan: ScanInput) -> PoseOutput:
        """Localizes one scan whose stamp the odometry covers."""
        odom = self._odometry.at(scan.stamp)
        assert odom is not None, "the caller checked that the odometry covers the scan"
        points = scan_to_points(
            scan.ranges,
            scan.angle_min,
            scan.angle_increment,
            scan.range_min,
            scan.range_max,
            sensor_pose=scan.laser_pose,
        )
        if self._reset is not None:
            start, cov, odom_ref = self._reset
            self._reset = None
            self.localizer.reset(start if odom_ref is None else compose(start, between(odom_ref, odom)), cov)
        if self._global_localization:
            self._global_localization = False
            try:
                found = self.localizer.relocalize(points)
            except (TypeError, ValueError, _core.PlanicpError) as exc:
                self._last_problem = f"global localization failed: {exc}"
            else:
                if not self.localizer.lost:  # found: this scan's odometry pairs with the place
                    self.localizer.reset(self.localizer.pose, self.localizer.covariance)
                best = found.best
                self._last_problem = (
                    f"global localization: {'found' if not self.localizer.lost else 'searching near'} "
                    + (f"x={best.pose[0]:.2f} y={best.pose[1]:.2f}" if best is not None else "no place")
                )
        try:
            estimate = self.localizer.update(points, odom)
        except (TypeError, ValueError) as exc:  # the localizer changed nothing
            self._last_stamp = scan.stamp
            self._last_failed = True
            self._problem("failed_updates", f"scan at {scan.stamp:.3f} s refused by the localizer: {exc}")
            raise
        self._last_failed = False
        self._last_stamp = scan.stamp
        self._counts["scans_processed"] += 1
        self._counts["accepted" if estimate.accepted else "rejected"] += 1
        if not estimate.accepted:
            self._last_reason = estimate.reason
        output = PoseOutput(
            scan.stamp, estimate.pose, estimate.covariance, matrix_to_pose(estimate.T_map_odom), odom, estimate
        )
        self._recent.append((estimate.accepted, output.inlier_ratio))
        self._last = output
        if self._eog is not None and not estimate.lost:
            try:
                self._eog.integrate_ranges(
                    scan.ranges,
                    scan.angle_min,
                    scan.angle_increment,
                    estimate.pose,
                    range_min=scan.range_min,
                    range_max=scan.range_max,
                    laser_pose=scan.laser_pose,
                )
            except _core.PlanicpError as exc:  # the grid would outgrow its cell limit
                self._last_problem = f"scan not added to the enhanced occupancy grid: {exc}"
        return output

    def _covariance(self, covariance: Any) -> Any:
        """A 3x3 covariance from None, a 3x3 or a 6x6 message covariance; zeros mean "not given"
        (checked by the caller)."""
        if covariance is None:
            return self.settings.initial_covariance()
        cov = np.asarray(covariance, dtype=np.float64)
        if cov.size == 36:
            cov = covariance_from_6x6(cov)
        if cov.shape == (3, 3) and not cov.any():
            return self.settings.initial_covariance()
        return cov

    def _restart_clock(self) -> None:
        """Time went back (a bag restarted): forget odometry, the waiting scan and the last stamp."""
        self._odometry.clear()
        self._pending = None
        self._last_stamp = None
        self._last_problem = "time went back: odometry and the waiting scan were forgotten"

    def _problem(self, counter: str, message: str) -> None:
        self._counts[counter] += 1
        self._last_problem = message
