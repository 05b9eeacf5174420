"""The plan that ships with planicp, so that `planicp demo` runs with no arguments."""

from __future__ import annotations

from importlib.resources import as_file, files
from pathlib import Path

from .plan_map import PlanMap

DEFAULT_PLAN_YAML = "office_plan.yaml"
"""A 30 x 20 m office floor at 5 cm/px: corridor, eight rooms, doors (scripts/make_default_plan.py)."""


def default_plan_path() -> Path:
    """Path of the shipped ROS map YAML (its PNG is beside it)."""
    resource = files("planicp") / "data" / DEFAULT_PLAN_YAML
    with as_file(resource) as path:
        return Path(path)


def load_default_plan() -> PlanMap:
    """The shipped office plan as a `PlanMap` (map frame: its lower-left corner is the origin)."""
    return PlanMap.from_ros_map(default_plan_path(), cache=False)
