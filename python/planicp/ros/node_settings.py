"""The parameters of `planicp_node`, validated, with the names a ROS parameter server uses."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from .._validation import Pose, as_pose, positive, real_number, unknown_fields
from ..plans.plan_loading import load_plan
from ..plans.plan_map import PlanMap
from ..tracking.acceptance_gate import AcceptanceGate
from ..tracking.icp_config import IcpConfig

DEFAULT_PLAN = "default"
"""The `plan` value that selects the office plan shipped with planicp (`planicp.plans.default_plan`)."""


@dataclass(frozen=True)
class NodeSettings:
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
    """

    plan: str = DEFAULT_PLAN
    resolution: float | None = None
    origin: Pose = (0.0, 0.0, 0.0)
    scan_topic: str = "scan"
    odom_topic: str = "odom"
    initial_pose_topic: str = "initialpose"
    pose_topic: str = "planicp/pose"
    plan_topic: str = "map"
    eog_topic: str = "planicp/eog"
    map_frame: str = "map"
    odom_frame: str = "odom"
    base_frame: str = "base_link"
    initial_pose: Pose = (0.0, 0.0, 0.0)
    initial_std: tuple[float, float, float] = (0.1, 0.1, math.radians(5.0))
    laser_pose: Pose | None = None
    publish_tf: bool = True
    transform_tolerance: float = 0.1
    odometry_span: float = 5.0
    eog_rate: float = 1.0
    eog_resolution: float = 0.05
    plan_resolution: float = 0.05
    diagnostics_rate: float = 1.0
    icp: Mapping[str, Any] = field(default_factory=dict)
    gate: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not isinstance(self.plan, str) or not self.plan:
            raise ValueError(f"plan must be a file path or 'default', got {self.plan!r}")
        if self.resolution is not None:
            object.__setattr__(self, "resolution", positive(self.resolution, "resolution", "metres per pixel"))
        object.__setattr__(self, "origin", as_pose(self.origin, "origin"))
        for name in (
            "scan_topic",
            "odom_topic",
            "initial_pose_topic",
            "pose_topic",
            "map_frame",
            "odom_frame",
            "base_frame",
        ):
            value = getattr(self, name)
            if not isinstance(value, str) or not value.strip():
                raise ValueError(f"{name} must be a non-empty name, got {value!r}")
        for name in ("plan_topic", "eog_topic"):
            if not isinstance(getattr(self, name), str):
                raise TypeError(f"{name} must be a topic name or '', got {getattr(self, name)!r}")
        if len({self.map_frame, self.odom_frame, self.base_frame}) != 3:
            raise ValueError(
                f"map_frame, odom_frame and base_frame must differ, got {self.map_frame!r}, "
                f"{self.odom_frame!r}, {self.base_frame!r}"
            )
        object.__setattr__(self, "initial_pose", as_pose(self.initial_pose, "initial_pose"))
        std = as_pose(self.initial_std, "initial_std")
        if min(std) < 0.0:
            raise ValueError(f"initial_std must be >= 0 (m, m, rad), got {std}")
        object.__setattr__(self, "initial_std", std)
        if self.laser_pose is not None:
            object.__setattr__(self, "laser_pose", as_pose(self.laser_pose, "laser_pose"))
        if not isinstance(self.publish_tf, bool):
            raise TypeError(f"publish_tf must be true or false, got {self.publish_tf!r}")
        tolerance = real_number(self.transform_tolerance, "transform_tolerance")
        if not (math.isfinite(tolerance) and tolerance >= 0.0):
            raise ValueError(f"transform_tolerance must be >= 0 seconds, got {self.transform_tolerance!r}")
        object.__setattr__(self, "transform_tolerance", tolerance)
        object.__setattr__(self, "odometry_span", positive(self.odometry_span, "odometry_span", "seconds"))
        for name in ("eog_rate", "diagnostics_rate"):
            rate = real_number(getattr(self, name), name)
            if not (math.isfinite(rate) and rate >= 0.0):
                raise ValueError(f"{name} must be >= 0 per second (0: off), got {getattr(self, name)!r}")
            object.__setattr__(self, name, rate)
        for name in ("eog_resolution", "plan_resolution"):
            object.__setattr__(self, name, positive(getattr(self, name), name, "metres"))
        for name in ("icp", "gate"):
            if not isinstance(getattr(self, name), Mapping):
                raise TypeError(f"{name} must be a mapping of field names to values, got {getattr(self, name)!r}")
        self.icp_config()
        self.acceptance_gate()

    @classmethod
    def from_params(cls, params: Mapping[str, Any]) -> NodeSettings:
        """Settings from a parameter dictionary (e.g. `rospy.get_param("~")`); missing names keep
        their defaults. Lists become tuples.

        Raises:
            ValueError: an unknown name (a typo would otherwise be ignored silently), or a bad value.
        """
        if not isinstance(params, Mapping):
            raise TypeError(f"params must be a mapping, got {type(params).__name__}")
        unknown, known = unknown_fields(cls, params)
        if unknown:
            raise ValueError(f"unknown planicp_node parameters {unknown}; known: {known}")
        values: dict[str, Any] = {k: tuple(v) if isinstance(v, list) else v for k, v in params.items()}
        return cls(**values)

    def icp_config(self) -> IcpConfig:
        """`IcpConfig.for_tracking()` with the `icp` overrides (unknown fields: ValueError)."""
        return IcpConfig.from_dict({**IcpConfig.for_tracking().to_dict(), **dict(self.icp)})

    def acceptance_gate(self) -> AcceptanceGate:
        """`AcceptanceGate()` with the `gate` overrides (unknown fields: ValueError)."""
        unknown, known = unknown_fields(AcceptanceGate, self.gate)
        if unknown:
            raise ValueError(f"unknown gate fields {unknown}; known: {known}")
        return AcceptanceGate(**dict(self.gate))

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
