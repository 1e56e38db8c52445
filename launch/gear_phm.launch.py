"""Launch the gear_phm nodes: the publisher (optional), the estimator and the diagnostics node.

    ros2 launch gear_phm gear_phm.launch.py                      # simulated gearbox, defaults
    ros2 launch gear_phm gear_phm.launch.py use_publisher:=false namespace:=rig_a \
        estimator_params_file:=my_estimator.yaml record_path:=/data/rig_a_run1
    ros2 launch gear_phm gear_phm.launch.py --show-args           # the arguments below

Each node reads its parameters file (default: the installed config/<node>.yaml), valid in
any namespace (gear_phm.launching.namespaced_copy), then use_sim_time; the diagnostics node
records to record_path when it is given.
"""
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.substitutions import FindPackageShare

from gear_phm.launching import namespaced_copy

PACKAGE = 'gear_phm'
#: The nodes, in start order: each is the executable of the same name (ros2 run gear_phm X).
NODES = ('publisher', 'estimator', 'diagnostics')
#: The node whose parameter record_path the argument of that name sets.
RECORDER = 'diagnostics'


def _nodes(context):
    """Return the three Node actions, their parameters files made valid in any namespace."""
    record_path = LaunchConfiguration('record_path').perform(context)
    actions = []
    for name in NODES:
        params_file = LaunchConfiguration(f'{name}_params_file').perform(context)
        parameters = [namespaced_copy(params_file),
                      {'use_sim_time': LaunchConfiguration('use_sim_time')}]
        if name == RECORDER and record_path:
            parameters.append({'record_path': record_path})
        actions.append(Node(
            package=PACKAGE, executable=name, name=name,
            namespace=LaunchConfiguration('namespace'), parameters=parameters,
            output='screen',
            condition=IfCondition(LaunchConfiguration('use_publisher'))
            if name == 'publisher' else None))
    return actions


def generate_launch_description():
    """Declare the arguments; start the nodes."""
    config = PathJoinSubstitution([FindPackageShare(PACKAGE), 'config'])
    return LaunchDescription([
        DeclareLaunchArgument('namespace', default_value='',
                              description='namespace of the three nodes and their topics'),
        DeclareLaunchArgument('use_sim_time', default_value='false',
                              choices=['true', 'false'],
                              description='use /clock (ros2 bag play --clock)'),
        DeclareLaunchArgument('use_publisher', default_value='true', choices=['true', 'false'],
                              description='start the publisher (simulate or replay); false '
                              'for a rig that publishes joint_states itself'),
        DeclareLaunchArgument('publisher_params_file',
                              default_value=PathJoinSubstitution([config, 'publisher.yaml']),
                              description='parameters file of the publisher'),
        DeclareLaunchArgument('estimator_params_file',
                              default_value=PathJoinSubstitution([config, 'estimator.yaml']),
                              description='parameters file of the estimator'),
        DeclareLaunchArgument('diagnostics_params_file',
                              default_value=PathJoinSubstitution([config, 'diagnostics.yaml']),
                              description='parameters file of the diagnostics node'),
        DeclareLaunchArgument('record_path', default_value='',
                              description='rosbag2 MCAP directory the diagnostics node '
                              'records to (empty: the parameters file decides)'),
        OpaqueFunction(function=_nodes),
    ])
