"""The ROS 2 node's parameters: nav2_amcl's names where they mean the same, planicp's own otherwise, read
into the one `NodeSettings` both ROS nodes use. No ROS import.

nav2_amcl's names (and its defaults, so that a Nav2 parameter file's `amcl:` section works unchanged):
`global_frame_id`, `odom_frame_id`, `base_frame_id`, `scan_topic`, `map_topic`, `tf_broadcast`,
`transform_tolerance`, `laser_min_range`, `laser_max_range`, `set_initial_pose`, `initial_pose.x`,
`initial_pose.y`, `initial_pose.z` (ignored: planar), `initial_pose.yaw`. nav2_amcl's particle filter and
sensor model parameters (`alpha1`, `max_particles`, `z_hit`, ...) mean nothing to planicp: they are
accepted and listed as ignored. planicp's own (`NodeSettings` fields): `plan` ("" takes the plan from
`map_topic`), `resolution` (0: none), `origin`, `pose_topic`, `initial_pose_topic`, `plan_topic`,
`eog_topic`, `initial_std`, `laser_pose` ([]: from tf), `odometry_span`, `eog_rate`, `eog_resolution`,
`plan_resolution`, `diagnostics_rate`, `icp.<IcpConfig field>`, `gate.<AcceptanceGate field>`,
`lost.<LostRule field>`; and `autostart` (configure and activate at start, without a lifecycle manager).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from .node_settings import NodeSettings

NAV2_NAMES: dict[str, str] = {
    "global_frame_id": "map_frame",
    "odom_frame_id": "odom_frame",
    "base_frame_id": "base_frame",
    "scan_topic": "scan_topic",
    "map_topic": "map_topic",
    "tf_broadcast": "publish_tf",
    "transform_tolerance": "transform_tolerance",
    "laser_min_range": "laser_min_range",
    "laser_max_range": "laser_max_range",
}
"""nav2_amcl's parameter -> the `NodeSettings` field it sets."""

INITIAL_POSE = ("set_initial_pose", "initial_pose.x", "initial_pose.y", "initial_pose.z", "initial_pose.yaw")
"""nav2_amcl's initial pose parameters (metres, radians in `global_frame_id`)."""

NAV2_DEFAULTS: dict[str, Any] = {
    "global_frame_id": "map",
    "odom_frame_id": "odom",
    "base_frame_id": "base_footprint",
    "scan_topic": "scan",
    "map_topic": "map",
    "tf_broadcast": True,
    "transform_tolerance": 1.0,
    "laser_min_range": -1.0,
    "laser_max_range": 100.0,
    "set_initial_pose": False,
    "initial_pose.x": 0.0,
    "initial_pose.y": 0.0,
    "initial_pose.z": 0.0,
    "initial_pose.yaw": 0.0,
}
"""nav2_amcl's defaults of the names above (Jazzy)."""

PLANICP_DEFAULTS: dict[str, Any] = {
    "plan": "",
    "resolution": 0.0,
    "origin": [0.0, 0.0, 0.0],
    "pose_topic": "amcl_pose",
    "initial_pose_topic": "initialpose",
    "plan_topic": "",
    "eog_topic": "planicp/eog",
    "initial_std": list(NodeSettings().initial_std),
    "laser_pose": [],
    "odometry_span": NodeSettings().odometry_span,
    "eog_rate": NodeSettings().eog_rate,
    "eog_resolution": NodeSettings().eog_resolution,
    "plan_resolution": NodeSettings().plan_resolution,
    "diagnostics_rate": NodeSettings().diagnostics_rate,
    "autostart": False,
}
"""planicp's own parameters of the ROS 2 node and their defaults. They differ from `NodeSettings`'
where ROS 2 or Nav2 asks it: the plan comes from `map_topic` (map_server's) unless `plan` names a file,
the pose goes out on nav2_amcl's `amcl_pose`, and the plan is not published again (map_server does);
0 and [] stand for "none", which a ROS 2 parameter cannot hold."""

NESTED = ("icp", "gate", "lost")
"""Groups of parameters (`icp.max_iterations`, `gate.min_inliers`, `lost.min_score`) that fill a
`NodeSettings` mapping."""

NAV2_IGNORED = frozenset(
    {
        "alpha1",
        "alpha2",
        "alpha3",
        "alpha4",
        "alpha5",
        "always_reset_initial_pose",
        "beam_skip_distance",
        "beam_skip_error_threshold",
        "beam_skip_threshold",
        "do_beamskip",
        "first_map_only",
        "freespace_downsampling",
        "lambda_short",
        "laser_likelihood_max_dist",
        "laser_model_type",
        "max_beams",
        "max_particles",
        "min_particles",
        "pf_err",
        "pf_z",
        "recovery_alpha_fast",
        "recovery_alpha_slow",
        "resample_interval",
        "robot_model_type",
        "save_pose_rate",
        "sigma_hit",
        "update_min_a",
        "update_min_d",
        "z_hit",
        "z_max",
        "z_rand",
        "z_short",
        "introspection_mode",
        "bond_heartbeat_period",
        "bond_disable_heartbeat_timeout",
    }
)
"""nav2_amcl's (and nav2's lifecycle) parameters without a meaning for planicp: accepted, ignored."""

ROS_OWN_PREFIXES = ("qos_overrides.", "use_sim_time", "start_type_description_service")
"""Parameters every rclpy node has."""


def declared_defaults() -> dict[str, Any]:
    """Every parameter the node declares, with its default."""
    return {**NAV2_DEFAULTS, **PLANICP_DEFAULTS}


def settings_from_ros2(values: Mapping[str, Any]) -> tuple[NodeSettings, list[str]]:
    """`NodeSettings` from the node's parameter values ({name: value}; missing names take the
    defaults above), and the names it ignored (nav2_amcl's particle filter parameters).

    Raises:
        ValueError: an unknown name (a typo would otherwise be ignored silently; the message lists the
            known ones), a bad value, or neither a plan file nor a map topic.
    """
    merged = {**declared_defaults(), **values}
    known = set(declared_defaults())
    ignored, unknown = [], []
    params: dict[str, Any] = {}
    nested: dict[str, dict[str, Any]] = {group: {} for group in NESTED}
    for name, value in merged.items():
        group, _, field = name.partition(".")
        if name in known:
            continue
        if group in NESTED and field:
            nested[group][field] = value
        elif name in NAV2_IGNORED:
            ignored.append(name)
        elif not name.startswith(ROS_OWN_PREFIXES):
            unknown.append(name)
    if unknown:
        raise ValueError(
            f"unknown parameters {sorted(unknown)}; known: {sorted(known)}, and icp.<field>, gate.<field>, "
            "lost.<field> (nav2_amcl's particle filter parameters are accepted and ignored)"
        )
    for nav2, field in NAV2_NAMES.items():
        params[field] = merged[nav2]
    plan = merged["plan"]
    if plan:
        params["plan"] = plan
        params["map_topic"] = ""
    elif not merged["map_topic"]:
        raise ValueError(
            "no plan: set plan (a map_server YAML, a plan image, a HouseExpo JSON, a DXF, or 'default') or "
            "map_topic (an OccupancyGrid topic, as map_server publishes)"
        )
    resolution = merged["resolution"]
    params["resolution"] = None if isinstance(resolution, (int, float)) and resolution == 0 else resolution
    laser_pose = merged["laser_pose"]
    params["laser_pose"] = None if isinstance(laser_pose, (list, tuple)) and len(laser_pose) == 0 else laser_pose
    for name in (
        "origin",
        "pose_topic",
        "initial_pose_topic",
        "plan_topic",
        "eog_topic",
        "initial_std",
        "odometry_span",
        "eog_rate",
        "eog_resolution",
        "plan_resolution",
        "diagnostics_rate",
    ):
        value = merged[name]
        params[name] = tuple(value) if isinstance(value, list) else value
    if isinstance(params["laser_pose"], list):
        params["laser_pose"] = tuple(params["laser_pose"])
    set_pose = merged["set_initial_pose"]
    if not isinstance(set_pose, bool):
        raise ValueError(f"set_initial_pose must be true or false, got {set_pose!r}")
    params["wait_for_initial_pose"] = not set_pose
    params["initial_pose"] = (merged["initial_pose.x"], merged["initial_pose.y"], merged["initial_pose.yaw"])
    params["icp"], params["gate"], params["lost"] = nested["icp"], nested["gate"], nested["lost"]
    return NodeSettings.from_params(params), sorted(ignored)
