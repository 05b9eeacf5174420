"""Mapping: the enhanced occupancy grid (EOG), what the robot saw fused with the plan.

Scans integrated at the estimated poses fill a log-odds occupancy grid (the native
`planicp._core.LogOddsGrid`); each cell then shows one of four states, the plan's walls always
ARCHITECTURAL. `enhanced_occupancy_grid` holds `EnhancedOccupancyGrid` (integration, states, plan
conflicts, ROS map and PNG export); `eog_state` the states (`EogState`) and their colours;
`occupancy_model` how a scan updates a cell and the thresholds between states (`OccupancyModel`);
`occupancy_grid_message` the grid laid out as `nav_msgs/OccupancyGrid` (`OccupancyGridMessage`).
Scoring a grid against a reference grid is evaluation (`planicp.evaluation.grid_agreement`). The
public names are exported by `planicp` itself; import them from there.
"""
