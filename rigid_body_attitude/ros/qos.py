"""The node's default QoS profiles, and why (users override them with ``qos_overrides``).

The profiles are declared by name, without rclpy, in
:data:`rigid_body_attitude.session.interface.QOS_PROFILES` (each endpoint of the interface
names its profile); :func:`qos_profile` makes the rclpy profile of a name. The constants below
are those profiles under the names the package's modules and tests use.

**Gyro inputs** (:data:`GYRO_QOS`: ``imu``, ``angular_velocity``): BEST_EFFORT, VOLATILE,
KEEP_LAST :data:`INPUT_DEPTH` (5 000).

* *Best effort*, because that is how IMU drivers publish (the sensor-data profile of
  realsense-ros, ouster-ros and most others) and how REP-2003 asks sensor consumers to
  subscribe: a best-effort subscription matches best-effort and reliable publishers alike, so
  the node hears every driver out of the box. A reliable subscription would hear no
  best-effort driver at all.
* *A deep queue*, because the raw-take loop drains the queue at every wake-up and the depth only
  has to cover the samples that arrive while the node cannot run (a scheduler delay on a
  loaded machine). 5 000 holds 5 s at 1 kHz. Measured (``test/ros/test_input_qos.py``): a
  sensor-data publisher paced at 1 kHz for 10 s beside two CPU-bound processes loses nothing.
* What best effort gives up: the middleware does not resend what its transport dropped. A
  burst of thousands of samples published at full speed (a bag player far behind) can
  overflow Fast DDS's shared-memory port; such losses show as gaps in the stamps, counted as
  ``missed_samples`` in ``/diagnostics``. For a reliable source that bursts, make the input
  reliable: ``-p qos_overrides./imu.subscription.reliability:=reliable`` (the reader then asks
  for the samples it missed and the writer resends them from its history; it then matches
  reliable publishers only).

**Commands** (:data:`COMMAND_QOS`: ``torque``, ``rotor_torque``, ``set_pose``,
``set_pose_with_covariance``): RELIABLE, VOLATILE, KEEP_LAST :data:`INPUT_DEPTH`. A command is sent
once and must arrive: a lost ``set_pose`` leaves the attitude where it was, a lost torque command
leaves the old torque applied until ``torque_timeout``. Command publishers (a controller, ``ros2
topic pub``) are reliable by default.

**Outputs** (:data:`OUTPUT_QOS`): RELIABLE, VOLATILE, KEEP_LAST :data:`OUTPUT_DEPTH` (5 000,
as deep as the inputs). A reliable publisher matches reliable and best-effort subscribers; the
depth is the history from which a reliable subscriber's missing samples are resent. The node's
RSS 4 s after start was 96.0 MiB with a depth of 1 000 and 96.1 MiB with 5 000 (one start
each).

**TF** (:data:`TF_QOS`, ``/tf`` with ``publish_tf``): RELIABLE, VOLATILE, KEEP_LAST 100, as
tf2_ros's broadcaster. **Static TF** (:data:`TF_STATIC_QOS`, ``/tf_static``, read for the
mount): RELIABLE, TRANSIENT_LOCAL, KEEP_LAST 1, as robot_state_publisher and
``static_transform_publisher`` publish it, so transforms published before the node started
still arrive; read keeping the last 100 (:data:`TF_STATIC_LISTENER_QOS`, tf2_ros's
``StaticListenerQoS``), so the latched messages of many publishers, delivered at once, are all
read.
"""

from __future__ import annotations

from rclpy.qos import (
    DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy)

from rigid_body_attitude.session.interface import INPUT_DEPTH, OUTPUT_DEPTH, QOS_PROFILES

__all__ = ['CLOCK_QOS', 'COMMAND_QOS', 'CONTROLLER_OUTPUT_QOS', 'GYRO_QOS', 'INPUT_DEPTH',
           'OUTPUT_DEPTH', 'OUTPUT_QOS', 'TF_QOS', 'TF_STATIC_LISTENER_QOS', 'TF_STATIC_QOS',
           'qos_profile']

_RELIABILITY = {'reliable': ReliabilityPolicy.RELIABLE,
                'best_effort': ReliabilityPolicy.BEST_EFFORT}
_DURABILITY = {'volatile': DurabilityPolicy.VOLATILE,
               'transient_local': DurabilityPolicy.TRANSIENT_LOCAL}


def qos_profile(name: str) -> QoSProfile:
    """The rclpy profile of the interface's QoS profile ``name`` (keep last)."""
    profile = QOS_PROFILES[name]
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=profile.depth,
                      reliability=_RELIABILITY[profile.reliability],
                      durability=_DURABILITY[profile.durability])


#: Gyro inputs: best effort (matches every publisher), keep last 5 000.
GYRO_QOS = qos_profile('sensor_input')
#: Commands (torque, rotor torque, set_pose): reliable, keep last 5 000.
COMMAND_QOS = qos_profile('command')
#: Outputs: reliable (reaches reliable and best-effort subscribers), keep last 5 000.
OUTPUT_QOS = qos_profile('output')
#: A controller's commands (``attitude_controller``'s ``torque``): as :data:`OUTPUT_QOS` but
#: transient local, so a recorder that matches the controller late (a transient-local
#: subscription, as ``ros2 bag record`` makes for such a writer) still gets every command
#: from the first tick on; volatile subscribers (the propagation node) are served as before.
CONTROLLER_OUTPUT_QOS = qos_profile('latched_output')
#: ``/tf``: as tf2_ros's TransformBroadcaster (reliable, volatile, keep last 100).
TF_QOS = qos_profile('tf')
#: ``/tf_static``: as robot_state_publisher publishes it (reliable, transient local, keep
#: last 1), so a transform published before the node started is delivered to it.
TF_STATIC_QOS = qos_profile('tf_static')
#: Reading ``/tf_static``: as tf2_ros's StaticListenerQoS (reliable, transient local, keep
#: last 100).
TF_STATIC_LISTENER_QOS = qos_profile('tf_static_listener')
#: ``/clock``: reliable, volatile, keep last 1. rclpy's and rclcpp's time sources subscribe
#: best effort with depth 1 (``rclcpp::ClockQoS``); a reliable writer serves them and reliable
#: readers (a recorder) alike.
CLOCK_QOS = qos_profile('clock')
