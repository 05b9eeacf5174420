"""planicp: localize a 2D-LIDAR robot against the architectural floor plan of its building.

Quick start:

    import planicp
    plan = planicp.PlanMap.from_points(wall_xy)                  # (N, 2) metres, map frame
    result = planicp.localize(scan_xy, plan, (x, y, yaw))        # scan in the robot frame
    print(result.pose, result.inlier_ratio, result.covariance)
    found = planicp.relocalize(scan_xy, plan)                     # no guess: ranked candidates
    print(found.best, found.ambiguous)

Frames follow REP-103/105: metres, radians, yaw counter-clockwise; poses are T_map_base.

One subpackage per concept, each `__init__` saying which file holds what: `plans` (floor plans in,
wall points out), `tracking` (alignment, the `Localizer`, global localization), `mapping` (the
enhanced occupancy grid), `evaluation` (metrics, logs replayed, figures), `sim` (synthetic floors,
simulated LIDAR, drives), `io` (logs and trajectory files), `ros` (the ROS 1 node), `sweep`
(studies of many runs). The names below are the public API; docs/layout.md maps every concept to
its file.
"""

from __future__ import annotations

from . import se2
from ._core import PlanicpError, PlanicpInternalError, WallView
from ._core import __version__ as __version__
from .laser_scan import scan_to_points

# plans: a floor plan becoming wall points
from .plans import vector_plan
from .plans.plan_map import PlanMap
from .plans.plan_raster import PlanRaster, resolution_from_pixels
from .plans.ros_map import RosMap, read_ros_map
from .plans.wall_extraction import WallExtraction

# tracking: alignment, the Localizer and its rules, global localization
from .tracking.acceptance_gate import AcceptanceGate
from .tracking.continuity_rule import ContinuityRule
from .tracking.degeneracy_rule import Degeneracy, DegeneracyRule
from .tracking.fusion_rule import FusionRule
from .tracking.icp_config import IcpConfig
from .tracking.icp_result import IcpResult
from .tracking.localize import localize
from .tracking.localizer import Estimate, Localizer
from .tracking.lost_rule import LostRule
from .tracking.motion_noise import MotionNoise
from .tracking.occlusion_rule import OcclusionRule
from .tracking.posterior_refinement import PosteriorRefinement
from .tracking.recovery import RecoveryConfig
from .tracking.scale_check import PlanScaleWarning, ScaleEstimate, ScaleRule
from .tracking.scale_estimation import ScaleCandidate, ScaleSearch, estimate_scale
from .tracking.relocalize import (
    Candidate,
    Relocalization,
    RelocalizationConfig,
    SearchInSteps,
    SearchRegion,
    relocalize,
)

# mapping: the enhanced occupancy grid
from .mapping.enhanced_occupancy_grid import EnhancedOccupancyGrid
from .mapping.eog_state import EogState
from .mapping.occupancy_grid_message import OccupancyGridMessage
from .mapping.occupancy_model import OccupancyModel

# evaluation: a grid scored against a reference
from .evaluation.grid_agreement import GridAgreement, compare_grids

# simulation: planicp.synthetic is planicp.sim (the synthetic floors and LIDAR moved there)
from . import sim as synthetic

__all__ = [
    "AcceptanceGate",
    "Candidate",
    "ContinuityRule",
    "Degeneracy",
    "DegeneracyRule",
    "EnhancedOccupancyGrid",
    "EogState",
    "GridAgreement",
    "OccupancyGridMessage",
    "OccupancyModel",
    "OcclusionRule",
    "Estimate",
    "FusionRule",
    "IcpConfig",
    "IcpResult",
    "Localizer",
    "LostRule",
    "MotionNoise",
    "PlanMap",
    "PlanScaleWarning",
    "PosteriorRefinement",
    "PlanRaster",
    "RosMap",
    "PlanicpError",
    "PlanicpInternalError",
    "RecoveryConfig",
    "Relocalization",
    "RelocalizationConfig",
    "ScaleCandidate",
    "ScaleEstimate",
    "ScaleRule",
    "ScaleSearch",
    "SearchInSteps",
    "SearchRegion",
    "WallExtraction",
    "WallView",
    "__version__",
    "compare_grids",
    "estimate_scale",
    "localize",
    "read_ros_map",
    "relocalize",
    "resolution_from_pixels",
    "scan_to_points",
    "se2",
    "synthetic",
    "vector_plan",
]
