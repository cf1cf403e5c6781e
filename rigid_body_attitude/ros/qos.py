"""The node's default QoS profiles, and why (users override them with ``qos_overrides``).

**Inputs** (:data:`INPUT_QOS`: ``imu``, ``angular_velocity``, ``torque``, ``rotor_torque``,
``set_pose``): BEST_EFFORT, VOLATILE, KEEP_LAST :data:`INPUT_DEPTH`.

* *Best effort*, because a best-effort subscription matches best-effort **and** reliable
  publishers, while a reliable one does not match best-effort publishers at all. IMU drivers
  publish with the sensor-data profile (best effort), bag players and most nodes reliably;
  a reliable input would hear nothing from the first.
* *A deep queue*, because a strapdown integrator must not drop samples silently. The gyro
  loop drains the queue at every wake-up, so the depth only has to cover the samples that
  arrive while the node cannot run: a scheduler delay on a loaded machine, a garbage
  collection, or a burst (a bag player catching up, a driver emptying its FIFO). With the
  sensor-data profile's depth 5 a wake-up late by 5 ms lost samples: 0.3–1.4 % of a 1 kHz
  stream on an idle machine, 3–25 % with two busy processes on the two cores, and a burst of
  2 000 samples kept 236. :data:`INPUT_DEPTH` = 5 000 holds 5 s at 1 kHz and 0.25 s at
  20 kHz; ``test/ros/test_input_qos.py`` checks zero loss for a 1 kHz stream with two busy
  processes and for a 2 000-sample burst. The queue is filled only when the node falls
  behind, so its memory is used only then (``docs/performance.md``: RSS with the deep queue).
* A best-effort input gets no repair of a sample the transport dropped (Fast DDS's shared
  memory port queue): the deep reader queue keeps the reader from dropping, not the
  transport. Where a publisher is reliable and the stream must survive transport drops too,
  make the input reliable (``qos_overrides./imu.subscription.reliability:=reliable``).

**Outputs** (:data:`OUTPUT_QOS`): RELIABLE, VOLATILE, KEEP_LAST :data:`OUTPUT_DEPTH` (10, the
ROS default). A reliable publisher matches reliable and best-effort subscribers. Outputs are
VOLATILE (``qos_overrides`` does not offer durability), so a writer's history matters only for
repairs; a deeper one costs memory per topic for as long as the node runs (``/diagnostics``
shares the profile).
"""

from __future__ import annotations

from rclpy.qos import (
    DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy)

__all__ = ['INPUT_DEPTH', 'INPUT_QOS', 'OUTPUT_DEPTH', 'OUTPUT_QOS']

#: Samples an input queue holds while the node cannot take them (5 s at 1 kHz).
INPUT_DEPTH = 5000

#: Samples an output writer keeps for repairs (the ROS default).
OUTPUT_DEPTH = 10

#: Inputs: best effort (matches best-effort and reliable publishers), keep last 5 000.
INPUT_QOS = QoSProfile(  # type: ignore[no-untyped-call]
    history=HistoryPolicy.KEEP_LAST, depth=INPUT_DEPTH,
    reliability=ReliabilityPolicy.BEST_EFFORT, durability=DurabilityPolicy.VOLATILE)

#: Outputs: reliable (reaches reliable and best-effort subscribers), keep last 10.
OUTPUT_QOS = QoSProfile(  # type: ignore[no-untyped-call]
    history=HistoryPolicy.KEEP_LAST, depth=OUTPUT_DEPTH,
    reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
