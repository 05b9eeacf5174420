"""How well the node is localizing, as a diagnostic status (`diagnostic_msgs/DiagnosticStatus`)."""

from __future__ import annotations

from dataclasses import dataclass

OK, WARN, ERROR = 0, 1, 2
"""Levels of `diagnostic_msgs/DiagnosticStatus`."""


@dataclass(frozen=True)
class NodeDiagnostics:
    """A snapshot of the node's counters and of the quality of its recent estimates.

    Attributes:
        level: OK (0), WARN (1) or ERROR (2), as `DiagnosticStatus.level`.
        message: one line saying why.
        scans_received: LaserScan messages that reached the node.
        scans_processed: scans that went through the localizer.
        accepted, rejected: processed scans whose ICP result the acceptance gate took or refused
            (a refused scan leaves the pose on the odometry prediction).
        malformed_scans, malformed_odometry, malformed_initial_poses: messages refused as malformed
            (each logged with its reason); none of them changes the pose.
        scans_without_odometry: scans dropped because no odometry covered their stamp.
        scans_without_laser_pose: scans dropped because tf had no transform from the base frame to
            their laser frame (and no `laser_pose` parameter was set).
        out_of_order: scans older than the last processed scan, dropped.
        inlier_ratio: share of the last processed scan's points within the correspondence
            distance of the plan (NaN before the first alignment).
        recent_accepted_share: share of accepted scans over the last `window` processed scans.
        recent_inlier_ratio: mean inlier ratio over them.
        lost: the plan no longer explains the scans (`planicp.Estimate.lost`).
        provisional: the pose follows a place adopted before the search of the whole plan ended,
            which may still replace it (`planicp.Estimate.provisional`).
        last_reason: why the last rejected scan was rejected ("" if none was).
        last_problem: the last malformed message or internal error ("" if none).
        failed_updates: scans the localizer refused although each message was well formed (the
            pose they led to lay beyond what it works with, such as odometry that jumped by 1e9 m);
            none changes the pose.
        scans_before_initial_pose: scans dropped while the node waited for a pose
            (`NodeSettings.wait_for_initial_pose`).
    """

    level: int
    message: str
    scans_received: int
    scans_processed: int
    accepted: int
    rejected: int
    malformed_scans: int
    malformed_odometry: int
    malformed_initial_poses: int
    scans_without_odometry: int
    scans_without_laser_pose: int
    out_of_order: int
    inlier_ratio: float
    recent_accepted_share: float
    recent_inlier_ratio: float
    lost: bool
    provisional: bool
    last_reason: str
    last_problem: str
    failed_updates: int = 0
    scans_before_initial_pose: int = 0

    def values(self) -> dict[str, str]:
        """Every field but level and message as text (`DiagnosticStatus.values` key/value pairs)."""
        out: dict[str, str] = {}
        for name, value in vars(self).items():
            if name in ("level", "message"):
                continue
            out[name] = f"{value:.3f}" if isinstance(value, float) else str(value)
        return out
