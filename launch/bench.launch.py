"""Launch the nodes of a bench: many drives in one JointState stream, one node of each kind.

    ros2 launch gear_phm bench.launch.py                         # config/bench_nodes.yaml
    ros2 launch gear_phm bench.launch.py transmissions_file:=my_bench.yaml \
        use_publisher:=false namespace:=bench_1 record_path:=/data/bench_1_run1

transmissions_file is a node parameters file (config/bench_nodes.yaml) or a transmissions
file of the CLI (config/bench.yaml): each node reads it (README "Bench: many drives in one
stream"). This file includes gear_phm.launch.py, whose other arguments (namespace,
use_sim_time, use_publisher, record_path) apply as given on the command line.
"""
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, IncludeLaunchDescription
from launch.launch_description_sources import PythonLaunchDescriptionSource
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.substitutions import FindPackageShare

PACKAGE = 'gear_phm'
#: The nodes, each reading the transmissions file as its parameters file.
NODES = ('publisher', 'estimator', 'diagnostics')


def generate_launch_description():
    """Declare the transmissions file; include gear_phm.launch.py with it for every node."""
    share = FindPackageShare(PACKAGE)
    transmissions = LaunchConfiguration('transmissions_file')
    return LaunchDescription([
        DeclareLaunchArgument('transmissions_file', default_value=PathJoinSubstitution(
            [share, 'config', 'bench_nodes.yaml']),
            description='the drives: a node parameters file or a CLI transmissions file'),
        IncludeLaunchDescription(
            PythonLaunchDescriptionSource(
                PathJoinSubstitution([share, 'launch', 'gear_phm.launch.py'])),
            launch_arguments=[(f'{node}_params_file', transmissions) for node in NODES]),
    ])
