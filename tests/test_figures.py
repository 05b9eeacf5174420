"""Figures return matplotlib Figures holding the data they were given."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from matplotlib.figure import Figure

from planicp import PlanMap
from planicp.evaluation import figures


@pytest.fixture(scope="module")
def plan() -> PlanMap:
    t = np.linspace(0.0, 6.0, 121)
    return PlanMap.from_points(np.concatenate([np.column_stack([t, 0 * t]), np.column_stack([0 * t, t])]))


def test_error_figures_plot_each_series(tmp_path: Path) -> None:
    times = np.linspace(0.0, 10.0, 101)
    fig = figures.plot_position_error(times, {"odometry": times * 0.1, "planicp": np.full(101, 0.02)})
    assert isinstance(fig, Figure)
    lines = fig.axes[0].get_lines()
    assert [line.get_label() for line in lines] == ["odometry", "planicp"]
    np.testing.assert_allclose(lines[0].get_ydata(), times * 0.1)
    heading = figures.plot_heading_error(times, {"odometry": -np.full(101, math.radians(2.0))})
    np.testing.assert_allclose(heading.axes[0].get_lines()[0].get_ydata(), 2.0)
    fig.savefig(tmp_path / "e.png")
    assert (tmp_path / "e.png").stat().st_size > 1000
    with pytest.raises(ValueError, match="series 'planicp' has shape"):
        figures.plot_position_error(times, {"planicp": np.zeros(3)})


def test_scan_match_splits_inliers_and_outliers(plan: PlanMap) -> None:
    scan = np.array([[1.0, 0.0], [2.0, 0.0], [1.0, 1.0]])
    fig = figures.plot_scan_match(
        plan, scan, (1.0, 1.0, -math.pi / 2), np.array([True, True, False]), initial_pose=(1.1, 1.0, -1.5)
    )
    ax = fig.axes[0]
    offsets = [c.get_offsets() for c in ax.collections]
    assert [len(o) for o in offsets] == [len(plan), 2, 1]
    np.testing.assert_allclose(offsets[1], [[1.0, 0.0], [1.0, -1.0]], atol=1e-12)  # scan placed at the pose
    with pytest.raises(ValueError, match="inlier_mask has shape"):
        figures.plot_scan_match(plan, scan, (0.0, 0.0, 0.0), np.array([True]))


def test_paths(plan: PlanMap) -> None:
    path = np.column_stack([np.linspace(0, 5, 50), np.linspace(0, 3, 50), np.zeros(50)])
    fig = figures.plot_paths(plan, {"truth": path, "odometry": path[:, :2] + 0.1})
    assert [line.get_label() for line in fig.axes[0].get_lines()] == ["truth", "odometry"]
    with pytest.raises(ValueError, match="must be"):
        figures.plot_paths(plan, {"truth": np.zeros(5)})
