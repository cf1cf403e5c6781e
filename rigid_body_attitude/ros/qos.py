"""The node's default QoS profiles, and why (users override them with ``qos_overrides``).

**Inputs** (:data:`INPUT_QOS`: ``imu``, ``angular_velocity``, ``torque``, ``rotor_torque``,
``set_pose``): RELIABLE, VOLATILE, KEEP_LAST :data:`INPUT_DEPTH` (5 000).

* *Reliable*, because it is the only setting under which the middleware repairs what it
  dropped, and a strapdown integrator that misses samples silently returns a wrong attitude.
  Between processes on one host Fast DDS hands samples over through a shared-memory port of
  512 descriptors and the sender's 512 KiB segment; when the receiving node cannot keep up
  with a burst they overflow. Measured with a 2 000-sample burst from a Python publisher
  (``test/ros/test_input_qos.py``): a best-effort input lost 11–511 samples at the transport
  even with a 5 000-deep queue (the former sensor-data profile, depth 5, kept 236), a
  reliable one lost none: the reader asks for the missing samples and the writer resends
  them from its history.
* *A deep queue*, because the gyro loop drains the queue at every wake-up and the depth only
  has to cover the samples that arrive while the node cannot run (a scheduler delay on a
  loaded machine, a burst). 5 000 holds 5 s at 1 kHz and 0.25 s at 20 kHz; it fills only
  while the node falls behind.
* The price: a reliable subscription does not match a best-effort publisher, and IMU drivers
  that publish with the sensor-data profile are best effort. The node then receives nothing
  from them, and rclpy logs, for every input topic, ``New publisher discovered on topic
  '/imu', offering incompatible QoS. No messages will be received from it. Last incompatible
  policy: RELIABILITY`` (the gyro loop serves the gyro subscriptions' QoS events itself, at
  least once a second, :mod:`rigid_body_attitude.ros.gyro_loop`; the executor thread those of
  the other inputs). Start the node with
  ``-p qos_overrides./imu.subscription.reliability:=best_effort`` for such a driver: samples
  a transport drops are then lost, as they would be anyway with a best-effort writer.

**Outputs** (:data:`OUTPUT_QOS`): RELIABLE, VOLATILE, KEEP_LAST :data:`OUTPUT_DEPTH` (5 000,
as deep as the inputs). A reliable publisher matches reliable and best-effort subscribers; the
depth is the history from which a reliable subscriber's missing samples are resent (10, the
ROS default, is 10 ms at 1 kHz: a repair after a burst found the sample gone). A burst the
input queue takes is published as a burst too: with 1 000, a 2 000-sample burst lost two
``pose`` samples to a subscriber slowed by the full test suite (``test/ros/test_input_qos.py``);
the node's RSS 4 s after start was 96.0 MiB with 1 000 and 96.1 MiB with 5 000 (one start
each).
"""

from __future__ import annotations

from rclpy.qos import (
    DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy)

__all__ = ['INPUT_DEPTH', 'INPUT_QOS', 'OUTPUT_DEPTH', 'OUTPUT_QOS']

#: Samples an input queue holds while the node cannot take them (5 s at 1 kHz).
INPUT_DEPTH = 5000

#: Samples an output writer keeps for repairs: as many as an input queue holds.
OUTPUT_DEPTH = INPUT_DEPTH

#: Inputs: reliable (repairs; matches reliable publishers only), keep last 5 000.
INPUT_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST, depth=INPUT_DEPTH,
    reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)

#: Outputs: reliable (reaches reliable and best-effort subscribers), keep last 5 000.
OUTPUT_QOS = QoSProfile(
    history=HistoryPolicy.KEEP_LAST, depth=OUTPUT_DEPTH,
    reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
