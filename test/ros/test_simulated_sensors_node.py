"""A dynamics node with a simulated IMU, magnetometer and star tracker, over ROS: the installed
``propagation_node`` in a process of its own, and subscribers in this process that receive
each sensor at its rate (every sample instant a whole multiple of its period, none missing),
in its frame, and the mounts in one transient-local ``/tf_static`` message."""

from __future__ import annotations

import math

from geometry_msgs.msg import PoseWithCovarianceStamped
import numpy as np
import pytest
from ros_helpers import Harness, unique_namespace
from sensor_msgs.msg import Imu, MagneticField
from tf2_msgs.msg import TFMessage
import yaml

from rigid_body_attitude.core.attitude.quaternion import from_rpy
from rigid_body_attitude.ros.qos import TF_STATIC_LISTENER_QOS
from rigid_body_attitude.ros.serve import SERVING_LINE

from test_node_subprocess import read_until, start, stop_with_sigint

#: topic → (message type, period [ns], header frame)
SENSORS = {'imu': (Imu, 5_000_000, 'imu_link'),
           'imu/mag': (MagneticField, 10_000_000, 'mag_link'),
           'star_tracker': (PoseWithCovarianceStamped, 100_000_000, 'world')}
RECEIVED_SECONDS = 2.0


def scene_file(tmp_path):
    path = tmp_path / 'sensed.yaml'
    path.write_text(yaml.safe_dump({
        'name': 'sensed', 'rate_source': 'dynamics', 'step': 0.001,
        'body': {'inertia': {'moments': [1.0, 2.0, 3.0]}},
        'initial_state': {'omega_body': [0.3, 0.5, -0.4]},
        'sensors': {
            'imu': {'rate': 200.0, 'frame_id': 'imu_link', 'mount_rpy': [0.0, 0.0, 1.0]},
            'magnetometer': {'rate': 100.0, 'noise_density': 1e-8, 'intensity': 5e-5,
                             'inclination': 1.2, 'frame_id': 'mag_link',
                             'mount_rpy': [0.5, 0.0, 0.0]},
            'star_tracker': {'rate': 10.0, 'boresight': [0.0, 1.0, 0.0]}}}))
    return str(path)


def stamp_ns(message):
    return message.header.stamp.sec * 10**9 + message.header.stamp.nanosec


def test_each_sensor_arrives_at_its_rate_in_its_frame_with_the_mounts(ros, request, processes,
                                                                      tmp_path):
    namespace = unique_namespace(request)
    process = start('--ros-args', '-p', f'scene:={scene_file(tmp_path)}',
                    '-r', f'__ns:={namespace}')
    processes.append(process)
    read_until(process, SERVING_LINE, 60.0)
    harness = Harness(ros, namespace)
    received = {topic: harness.record(message_type, topic)
                for topic, (message_type, _, _) in SENSORS.items()}
    mounts = harness.record(TFMessage, '/tf_static', TF_STATIC_LISTENER_QOS)
    harness.wait_for_connections(30.0)
    assert harness.spin_until(lambda: all(
        len(messages) >= RECEIVED_SECONDS * 1e9 / SENSORS[topic][1]
        for topic, messages in received.items()), 30.0), {
            topic: len(messages) for topic, messages in received.items()}
    code, stderr = stop_with_sigint(process)
    assert code == 0 and 'Traceback' not in stderr, stderr
    for topic, (_, period, frame) in SENSORS.items():
        stamps = np.array([stamp_ns(message) for message in received[topic]])
        assert stamps[0] % period == 0, topic
        assert np.all(np.diff(stamps) == period), (topic, np.diff(stamps))
        assert {message.header.frame_id for message in received[topic]} == {frame}, topic
    field = [message.magnetic_field for message in received['imu/mag']]
    assert all(math.isclose(math.hypot(b.x, b.y, b.z), 5e-5, rel_tol=0.01) for b in field)
    covariances = [np.reshape(m.pose.covariance, (6, 6)) for m in received['star_tracker']]
    assert all(c[0, 0] == c[1, 1] == c[2, 2] == 1e9 and c[3:, 3:].trace() > 0.0
               for c in covariances)
    assert len(mounts) == 1
    transforms = {t.child_frame_id: t for t in mounts[0].transforms}
    assert sorted(transforms) == ['imu_link', 'mag_link', 'star_tracker_link']
    assert {t.header.frame_id for t in transforms.values()} == {'base_link'}
    for child, rpy in (('imu_link', [0.0, 0.0, 1.0]), ('mag_link', [0.5, 0.0, 0.0]),
                       ('star_tracker_link', [-math.pi / 2, 0.0, 0.0])):
        r = transforms[child].transform.rotation
        expected = from_rpy(rpy)
        assert abs(float(np.dot([r.w, r.x, r.y, r.z], expected))) == pytest.approx(1.0), child
