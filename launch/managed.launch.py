"""managed.launch.py: the managed (lifecycle) node, configured and activated.

Starts managed_propagation_node (lifecycle node attitude_propagator), which comes up
unconfigured. With ``autostart`` (the default) this file then drives it as a lifecycle manager
would: the ``configure`` transition once the process runs, ``activate`` once it reached
``inactive``. A ``configure`` that fails (a bad parameter or scene: one ``error`` log line
naming it) leaves the node unconfigured and nothing is activated. ``autostart:=false`` leaves
the transitions to your lifecycle manager, or to the command line::

    ros2 launch rigid_body_attitude managed.launch.py autostart:=false
    ros2 lifecycle set /attitude_propagator configure
    ros2 lifecycle set /attitude_propagator activate

The node is ``propagation_node``'s (README.md, "Topics" and "Parameters"; docs/node.md,
"Managed (lifecycle) node") without ``publish_clock`` and ``lockstep``; here with the
``strapdown`` scene on a live IMU, whose mount ``body_frame`` -> the Imu's frame comes from
``/tf_static`` (robot_state_publisher, or ``imu.launch.xml``'s static_transform_publisher).
Launch arguments override the parameters file (``params_file``, the installed defaults unless
given)::

    ros2 launch rigid_body_attitude managed.launch.py imu_topic:=/camera/imu
"""

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, EmitEvent, RegisterEventHandler
from launch.conditions import IfCondition
from launch.events import matches_action
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import LifecycleNode
from launch_ros.event_handlers import OnStateTransition
from launch_ros.events.lifecycle import ChangeState
from launch_ros.substitutions import FindPackageShare
from lifecycle_msgs.msg import Transition


def generate_launch_description():
    """The node, its launch arguments and, with autostart, its two transitions."""
    node = LifecycleNode(
        package='rigid_body_attitude', executable='managed_propagation_node',
        name='attitude_propagator', namespace=LaunchConfiguration('namespace'),
        output='screen',
        parameters=[
            LaunchConfiguration('params_file'),
            {
                'scene': LaunchConfiguration('scene'),
                'world_frame': LaunchConfiguration('world_frame'),
                'body_frame': LaunchConfiguration('body_frame'),
                'publish_tf': LaunchConfiguration('publish_tf'),
                'use_sim_time': LaunchConfiguration('use_sim_time'),
            },
        ],
        remappings=[('imu', LaunchConfiguration('imu_topic'))])
    configure = EmitEvent(
        event=ChangeState(lifecycle_node_matcher=matches_action(node),
                          transition_id=Transition.TRANSITION_CONFIGURE),
        condition=IfCondition(LaunchConfiguration('autostart')))
    activate_when_inactive = RegisterEventHandler(
        OnStateTransition(
            target_lifecycle_node=node, start_state='configuring', goal_state='inactive',
            entities=[EmitEvent(event=ChangeState(
                lifecycle_node_matcher=matches_action(node),
                transition_id=Transition.TRANSITION_ACTIVATE))]),
        condition=IfCondition(LaunchConfiguration('autostart')))
    return LaunchDescription([
        DeclareLaunchArgument('namespace', default_value='',
                              description='namespace of the node and its relative topics'),
        DeclareLaunchArgument('scene', default_value='strapdown',
                              description='a gyro scene: built-in name or path to a YAML file'),
        DeclareLaunchArgument('imu_topic', default_value='imu',
                              description="the driver's sensor_msgs/Imu topic"),
        DeclareLaunchArgument('world_frame', default_value='world',
                              description='frame of the published attitude'),
        DeclareLaunchArgument('body_frame', default_value='base_link',
                              description="the body's frame"),
        DeclareLaunchArgument('publish_tf', default_value='false',
                              description='world_frame -> body_frame on /tf'),
        DeclareLaunchArgument('use_sim_time', default_value='false',
                              description='true: the node clock follows /clock'),
        DeclareLaunchArgument('autostart', default_value='true',
                              description='configure and activate the node once it runs'),
        DeclareLaunchArgument(
            'params_file',
            default_value=PathJoinSubstitution(
                [FindPackageShare('rigid_body_attitude'), 'config', 'params.yaml']),
            description='parameters file of attitude_propagator'),
        activate_when_inactive,
        node,
        configure,
    ])
