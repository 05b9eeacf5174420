"""planicp in place of nav2_amcl: include this launch description in a Nav2 bringup instead of amcl's.

    from launch.actions import IncludeLaunchDescription
    from launch.launch_description_sources import PythonLaunchDescriptionSource
    from planicp.ros import ros2_launch_path

    IncludeLaunchDescription(
        PythonLaunchDescriptionSource(str(ros2_launch_path() / "planicp.launch.py")),
        launch_arguments={"params_file": params_file, "use_sim_time": use_sim_time}.items(),
    )

It starts `planicp-ros2-node` (the console script of `pip install 'planicp[ros2]'`, found on PATH) as a
lifecycle node named `amcl` by default, so that Nav2's lifecycle manager (`node_names: [map_server, amcl]`)
configures and activates it as it did nav2_amcl, and the `amcl:` section of a Nav2 parameter file applies
(nav2_amcl's particle filter parameters are accepted and ignored). Without a lifecycle manager, pass
`autostart:=true`.
"""

from pathlib import Path

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node
from launch_ros.parameter_descriptions import ParameterValue

SHARE = Path(__file__).resolve().parent


def generate_launch_description() -> LaunchDescription:
    """The node, its launch arguments and nav2's tf remappings (`/tf` -> `tf` under a namespace)."""
    return LaunchDescription(
        [
            DeclareLaunchArgument("node_name", default_value="amcl", description="the node's name"),
            DeclareLaunchArgument("namespace", default_value="", description="the robot's namespace"),
            DeclareLaunchArgument(
                "params_file",
                default_value=str(SHARE / "planicp.yaml"),
                description="ROS 2 parameter file (a Nav2 parameter file with an amcl: section works)",
            ),
            DeclareLaunchArgument("use_sim_time", default_value="false", description="use /clock"),
            DeclareLaunchArgument(
                "autostart", default_value="false", description="configure and activate without a lifecycle manager"
            ),
            Node(
                executable="planicp-ros2-node",
                name=LaunchConfiguration("node_name"),
                namespace=LaunchConfiguration("namespace"),
                output="screen",
                parameters=[
                    LaunchConfiguration("params_file"),
                    {
                        "use_sim_time": ParameterValue(LaunchConfiguration("use_sim_time"), value_type=bool),
                        "autostart": ParameterValue(LaunchConfiguration("autostart"), value_type=bool),
                    },
                ],
                remappings=[("/tf", "tf"), ("/tf_static", "tf_static")],
            ),
        ]
    )
