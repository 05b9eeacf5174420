"""The parameters of `planicp_node`, validated, with the names a ROS parameter server uses."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import field
from typing import Annotated, Any

from pydantic import AfterValidator, BeforeValidator, ValidationError, ValidationInfo
from pydantic.dataclasses import dataclass

from .._settings import SETTINGS, Flag, Pose3, Real, Settings, first_error, read, refuse_type, refuse_value
from .._validation import brief
from ..plans.plan_loading import load_plan
from ..plans.plan_map import PlanMap
from ..tracking.acceptance_gate import AcceptanceGate
from ..tracking.icp_config import IcpConfig
from ..tracking.lost_rule import LostRule

OCCUPIED = 65
"""Cells of an occupancy grid from `map_topic` at or above this value are walls (map_server's
occupied threshold 0.65; its trinary maps say 100 for occupied, 0 free, -1 unknown)."""

DEFAULT_PLAN = "default"
"""The `plan` value that selects the office plan shipped with planicp (`planicp.plans.default_plan`)."""


def _plan(value: Any) -> str:
    if not isinstance(value, str) or not value:
        refuse_value(f"plan must be a file path or 'default', got {brief(value)}")
    return value


def _name(value: Any, info: ValidationInfo) -> str:
    if not isinstance(value, str) or not value.strip():
        refuse_value(f"{info.field_name} must be a non-empty name, got {brief(value)}")
    return value


def _topic(value: Any, info: ValidationInfo) -> str:
    if not isinstance(value, str):
        refuse_type(info, f"{info.field_name} must be a topic name or '', got {brief(value)}")
    return value


def _std(value: tuple[float, float, float]) -> tuple[float, float, float]:
    if min(value) < 0.0:
        refuse_value(f"initial_std must be >= 0 (m, m, rad), got {value}")
    return value


def _icp_config(overrides: Mapping[str, Any], plan: PlanMap | None = None) -> IcpConfig:
    try:
        return IcpConfig.from_dict({**IcpConfig.for_tracking(plan).to_dict(), **overrides})
    except ValidationError as exc:
        raise ValueError(f"icp: {first_error(exc)}") from None


def _acceptance_gate(overrides: Mapping[str, Any]) -> AcceptanceGate:
    try:
        return read(AcceptanceGate, overrides, what="gate fields")
    except ValidationError as exc:
        raise ValueError(f"gate: {first_error(exc)}") from None


def _lost_rule(overrides: Mapping[str, Any]) -> LostRule:
    try:
        return read(LostRule, overrides, what="lost rule fields")
    except ValidationError as exc:
        raise ValueError(f"lost: {first_error(exc)}") from None


def _overrides(make: Callable[[Mapping[str, Any]], Any]) -> Callable[[Mapping[str, Any]], Mapping[str, Any]]:
    """A validator of a group of overrides ("icp", "gate", "lost"): `make` must make its settings
    object from them (`_icp_config`, `_acceptance_gate`, `_lost_rule`)."""

    def check(overrides: Mapping[str, Any]) -> Mapping[str, Any]:
        try:
            make(overrides)
        except ValueError as exc:  # an unknown field, or a value refused
            refuse_value(str(exc))
        return overrides

    return check


Name = Annotated[str, BeforeValidator(_name)]
"""A topic or frame name: a non-empty string."""
Topic = Annotated[str, BeforeValidator(_topic)]
"""A topic name, or "" for a topic not published."""
Rate = Annotated[float, Real(ge=0.0, says=">= 0 per second (0: off)")]


@dataclass(frozen=True, config=SETTINGS)
class NodeSettings(Settings):
    """Everything `planicp_node` is configured with (private ROS parameters `~name`).

    Frames follow REP-105: `map_frame` is the plan's frame, `odom_frame` the continuous odometry
    frame, `base_frame` the robot's. Poses are (x, y, yaw) in metres and radians.

    Attributes:
        plan: the plan: a map_server YAML (its own resolution and origin), a plan image (needs
            `resolution`, takes `origin`), a HouseExpo JSON or a DXF drawing (see
            `planicp.plans.plan_loading.load_plan`), or "default" for the plan shipped with planicp.
        resolution: metres per pixel of a plan image (None for the other kinds).
        origin: (x, y, yaw) of a plan image's lower-left corner in the map frame.
        scan_topic, odom_topic: the inputs (`sensor_msgs/LaserScan`, `nav_msgs/Odometry`).
        initial_pose_topic: where RViz's "2D Pose Estimate" arrives
            (`geometry_msgs/PoseWithCovarianceStamped`, in `map_frame`).
        pose_topic: the output `geometry_msgs/PoseWithCovarianceStamped` (T_map_base).
        plan_topic: the plan as a latched `nav_msgs/OccupancyGrid` ("" to not publish it).
        eog_topic: the enhanced occupancy grid as `nav_msgs/OccupancyGrid` ("" to not build it).
        map_frame, odom_frame, base_frame: the tf frames.
        initial_pose: T_map_base at start-up, until an initial pose arrives.
        initial_std: standard deviations (m, m, rad) of `initial_pose`.
        laser_pose: T_base_laser (x, y, yaw) to use instead of looking the laser's frame up in tf
            (None: look it up once per frame id).
        publish_tf: broadcast map -> odom (off to run beside AMCL and compare).
        transform_tolerance: seconds added to the scan's stamp on the map -> odom transform, as
            AMCL does, so that the transform is valid until the next scan.
        odometry_span: seconds of odometry kept to interpolate at scan stamps.
        eog_rate: publications of the enhanced occupancy grid per second (0: never).
        eog_resolution: its cell size, metres.
        plan_resolution: cell size (metres) of the published plan when the plan has no raster of its
            own (plans from points, HouseExpo, DXF); plans from images or maps use their pixels.
        diagnostics_rate: publications of the diagnostic status per second.
        icp: `IcpConfig` fields that differ from `IcpConfig.for_tracking()`.
        gate: `AcceptanceGate` fields that differ from its defaults.
        lost: `LostRule` fields that differ from its defaults (when the node says it is lost).
        laser_min_range, laser_max_range: metres, in place of each scan's own `range_min` and
            `range_max` when > 0 (nav2_amcl's parameters of these names; <= 0: the scan's).
        map_topic: take the plan from this `nav_msgs/OccupancyGrid` topic (transient local, as
            map_server publishes it; occupied cells >= `OCCUPIED` are walls) instead of from `plan`;
            "" to read `plan`. Only the ROS 2 node (`rclpy_node`) reads a plan from a topic.
        wait_for_initial_pose: scans are dropped until a pose is given (an initial pose message, or
            global localization), as nav2_amcl does without `set_initial_pose`; False: the robot
            starts at `initial_pose`.
    """

    plan: Annotated[str, BeforeValidator(_plan)] = DEFAULT_PLAN
    resolution: Annotated[float, Real(gt=0.0, unit="metres per pixel")] | None = None
    origin: Pose3 = (0.0, 0.0, 0.0)
    scan_topic: Name = "scan"
    odom_topic: Name = "odom"
    initial_pose_topic: Name = "initialpose"
    pose_topic: Name = "planicp/pose"
    plan_topic: Topic = "map"
    eog_topic: Topic = "planicp/eog"
    map_frame: Name = "map"
    odom_frame: Name = "odom"
    base_frame: Name = "base_link"
    initial_pose: Pose3 = (0.0, 0.0, 0.0)
    initial_std: Annotated[Pose3, AfterValidator(_std)] = (0.1, 0.1, math.radians(5.0))
    laser_pose: Pose3 | None = None
    publish_tf: Flag = True
    transform_tolerance: Annotated[float, Real(ge=0.0, says=">= 0 seconds")] = 0.1
    odometry_span: Annotated[float, Real(gt=0.0, unit="seconds")] = 5.0
    eog_rate: Rate = 1.0
    eog_resolution: Annotated[float, Real(gt=0.0, unit="metres")] = 0.05
    plan_resolution: Annotated[float, Real(gt=0.0, unit="metres")] = 0.05
    diagnostics_rate: Rate = 1.0
    icp: Annotated[Mapping[str, Any], AfterValidator(_overrides(_icp_config))] = field(default_factory=dict)
    gate: Annotated[Mapping[str, Any], AfterValidator(_overrides(_acceptance_gate))] = field(default_factory=dict)
    lost: Annotated[Mapping[str, Any], AfterValidator(_overrides(_lost_rule))] = field(default_factory=dict)
    laser_min_range: Annotated[float, Real(says="a number of metres (<= 0: each scan's range_min)")] = -1.0
    laser_max_range: Annotated[float, Real(says="a number of metres (<= 0: each scan's range_max)")] = -1.0
    map_topic: Topic = ""
    wait_for_initial_pose: Flag = False

    def __post_init__(self) -> None:
        if len({self.map_frame, self.odom_frame, self.base_frame}) != 3:
            refuse_value(
                f"map_frame, odom_frame and base_frame must differ, got {self.map_frame!r}, "
                f"{self.odom_frame!r}, {self.base_frame!r}"
            )
        if self.map_topic and self.map_topic.lstrip("/") == self.plan_topic.lstrip("/"):
            refuse_value(
                f"map_topic and plan_topic are both {self.map_topic!r}: the node would read back the plan it "
                "publishes; set plan_topic to '' (or another topic) to take the plan from map_topic"
            )
        if 0.0 < self.laser_max_range <= self.laser_min_range:
            refuse_value(
                f"laser_max_range ({self.laser_max_range} m) must exceed laser_min_range "
                f"({self.laser_min_range} m); <= 0 leaves either to each scan"
            )

    @classmethod
    def from_params(cls, params: Mapping[str, Any]) -> NodeSettings:
        """Settings from a parameter dictionary (e.g. `rospy.get_param("~")`); missing names keep
        their defaults.

        Raises:
            ValueError: an unknown name (a typo would otherwise be ignored silently), or a bad value.
        """
        if not isinstance(params, Mapping):
            raise TypeError(f"params must be a mapping, got {type(params).__name__}")
        return read(cls, params, what="planicp_node parameters")

    def icp_config(self, plan: PlanMap | None = None) -> IcpConfig:
        """`IcpConfig.for_tracking(plan)` (the `Localizer`'s default for `plan`) with the `icp`
        overrides (unknown fields: ValueError)."""
        return _icp_config(self.icp, plan)

    def acceptance_gate(self) -> AcceptanceGate:
        """`AcceptanceGate()` with the `gate` overrides (unknown fields: ValueError)."""
        return _acceptance_gate(self.gate)

    def lost_rule(self) -> LostRule:
        """`LostRule()` with the `lost` overrides (unknown fields: ValueError)."""
        return _lost_rule(self.lost)

    def initial_covariance(self) -> list[list[float]]:
        """3x3 covariance of `initial_pose` from `initial_std`."""
        sx, sy, syaw = self.initial_std
        return [[sx * sx, 0.0, 0.0], [0.0, sy * sy, 0.0], [0.0, 0.0, syaw * syaw]]

    def load_plan(self) -> PlanMap:
        """The plan named by `plan` (FileNotFoundError, ValueError: it cannot be read)."""
        if self.plan == DEFAULT_PLAN:
            from ..plans.default_plan import load_default_plan

            return load_default_plan()
        return load_plan(self.plan, resolution=self.resolution, origin=self.origin)
