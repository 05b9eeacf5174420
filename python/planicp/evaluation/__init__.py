"""Evaluation: how well a run went, measured against a reference, and the figures that show it.

A run is the localizer's poses over a drive or a recorded log; the reference is ground truth (the
simulator's) or the poses a log carries. `trajectory_metrics` holds the pose errors and their
summary (RMS, max) against a reference; `log_replay` tracks every scan of a recorded log through a
`Localizer` (`track_log`, `TrackedLog`); `log_evaluation` the `planicp evaluate-log` protocol (a
plan drawn from the even scans, the odd ones tracked with synthesised drifting odometry:
`evaluate_log`); `replay_outputs` what `planicp replay` and `evaluate-log` write (trajectory,
figures, grid, metrics.json) and print; `grid_agreement` how well an occupancy grid agrees with a
reference grid (`compare_grids`, `GridAgreement`); `figures` the figures of a run (errors over time,
paths, a scan's match, grids). The names `planicp` exports (`compare_grids`, `GridAgreement`) are
re-exported there.
"""
