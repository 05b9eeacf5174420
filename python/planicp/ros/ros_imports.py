"""The ROS 1 Python modules the nodes use, imported with an error that says how to get them."""

from __future__ import annotations

import importlib
import sys
from collections.abc import Sequence
from types import ModuleType
from typing import Any

ROS_INSTALL_HINT = (
    "planicp's ROS nodes need ROS 1's rospy and message packages. On Debian: apt-get install ros-base "
    "python3-rospy python3-sensor-msgs python3-nav-msgs python3-geometry-msgs python3-tf2-ros "
    "python3-diagnostic-msgs, then run the node with Debian's /usr/bin/python3 and planicp installed "
    "for it (e.g. /usr/bin/python3 -m venv --system-site-packages VENV; VENV/bin/pip install planicp)"
)

MODULES = ("rospy", "tf2_ros", "sensor_msgs.msg", "nav_msgs.msg", "geometry_msgs.msg", "diagnostic_msgs.msg")


def import_ros() -> dict[str, ModuleType]:
    """{module name: module} for `MODULES`.

    Raises:
        ImportError: one is missing; the message names it and says how to install ROS.
    """
    modules: dict[str, ModuleType] = {}
    for name in MODULES:
        try:
            modules[name] = importlib.import_module(name)
        except ImportError as exc:
            raise ImportError(f"cannot import {name} ({exc}). {ROS_INSTALL_HINT}") from exc
    return modules


def start_node(name: str, argv: Sequence[str] | None) -> tuple[dict[str, ModuleType], Any] | None:
    """Imports ROS and registers the node `name` with the master: `(modules, rospy)`, or None when
    ROS is missing (the reason and how to install it are printed to stderr)."""
    try:
        ros = import_ros()
    except ImportError as exc:
        print(f"{name}: {exc}", file=sys.stderr)
        return None
    rospy = ros["rospy"]
    rospy.init_node(name, argv=list(argv) if argv is not None else sys.argv)
    return ros, rospy
