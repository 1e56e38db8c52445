"""Launch the nodes of a bench: many drives in one JointState stream, one node of each kind.

    ros2 launch gear_phm bench.launch.py                         # config/bench_nodes.yaml
    ros2 launch gear_phm bench.launch.py transmissions_file:=my_bench.yaml \
        use_publisher:=false namespace:=bench_1 record_path:=/data/bench_1_run1

transmissions_file is a node parameters file (config/bench_nodes.yaml) or a transmissions
file of the CLI (config/bench.yaml): each node reads it (README "Bench: many drives in one
stream"). The other arguments are those of gear_phm.launch.py, which this file includes.
"""
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, IncludeLaunchDescription
from launch.launch_description_sources import PythonLaunchDescriptionSource
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.substitutions import FindPackageShare

PACKAGE = 'gear_phm'
#: Arguments handed on to gear_phm.launch.py as they are.
PASSED_ON = ('namespace', 'use_sim_time', 'use_publisher', 'record_path')


def generate_launch_description():
    """Declare the arguments; include gear_phm.launch.py with the transmissions file."""
    share = FindPackageShare(PACKAGE)
    transmissions = LaunchConfiguration('transmissions_file')
    return LaunchDescription([
        DeclareLaunchArgument('transmissions_file', default_value=PathJoinSubstitution(
            [share, 'config', 'bench_nodes.yaml']),
            description='the drives: a node parameters file or a CLI transmissions file'),
        DeclareLaunchArgument('namespace', default_value='',
                              description='namespace of the three nodes and their topics'),
        DeclareLaunchArgument('use_sim_time', default_value='false',
                              choices=['true', 'false'],
                              description='use /clock (ros2 bag play --clock)'),
        DeclareLaunchArgument('use_publisher', default_value='true', choices=['true', 'false'],
                              description='start the publisher simulating every drive'),
        DeclareLaunchArgument('record_path', default_value='',
                              description='rosbag2 MCAP directory the diagnostics node '
                              'records to (empty: no recording)'),
        IncludeLaunchDescription(
            PythonLaunchDescriptionSource(
                PathJoinSubstitution([share, 'launch', 'gear_phm.launch.py'])),
            launch_arguments={
                **{name: LaunchConfiguration(name) for name in PASSED_ON},
                'publisher_params_file': transmissions,
                'estimator_params_file': transmissions,
                'diagnostics_params_file': transmissions,
            }.items()),
    ])
