"""tf2_msgs as the set-up builds it from ``interfaces/tf2_msgs``: upstream's type, over real DDS.

No wheel of tf2_msgs exists, so ``make`` generates it from its interface definition with the
ROS 2 Jazzy wheels and installs it into the venv prefix. These tests check that the result is the
type ROS 2 Jazzy's own ``tf2_msgs`` defines: the same type hash (stock ``tf2_ros`` listeners,
RViz and ``ros2 topic echo /tf`` match endpoints by it), installed where ament finds it, and a
``TFMessage`` published by one process and received by another.
"""

from __future__ import annotations

from collections.abc import Iterator
import json
import os
from pathlib import Path
import subprocess
import sys
import textwrap
import xml.etree.ElementTree as ElementTree

from ament_index_python.packages import get_package_prefix, get_package_share_directory
from geometry_msgs.msg import TransformStamped
import pytest
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from ros_helpers import Harness, ros_session, RosContext, unique_namespace
from tf2_msgs.msg import TFMessage

TYPE_NAME = 'tf2_msgs/msg/TFMessage'
#: ``type_hashes[0].hash_string`` of ``share/tf2_msgs/msg/TFMessage.json`` of ROS 2 Jazzy's
#: tf2_msgs (ros2/geometry2).
UPSTREAM_JAZZY_TYPE_HASH = (
    'RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087')
PREFIX = Path(sys.prefix).resolve()
REPO_ROOT = Path(__file__).resolve().parents[1]

#: The QoS tf2_ros publishes /tf with (reliable, volatile, keep last 100).
TF_QOS = QoSProfile(depth=100, history=HistoryPolicy.KEEP_LAST,
                    reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)

# Run in another process: publishes a TFMessage of two transforms on argv[1] every 50 ms, the
# index of the message in the first transform's stamp, for at most argv[2] seconds.
PUBLISHER = textwrap.dedent('''
    import sys, time
    import rclpy
    from geometry_msgs.msg import TransformStamped
    from tf2_msgs.msg import TFMessage

    rclpy.init()
    node = rclpy.create_node('tf_publisher')
    publisher = node.create_publisher(TFMessage, sys.argv[1], 100)
    deadline = time.monotonic() + float(sys.argv[2])
    index = 0
    while time.monotonic() < deadline:
        body = TransformStamped()
        body.header.stamp.sec = index
        body.header.frame_id = 'odom'
        body.child_frame_id = 'base_link'
        body.transform.translation.x = 1.5
        body.transform.rotation.x = 0.6
        body.transform.rotation.w = 0.8
        imu = TransformStamped()
        imu.header.frame_id = 'base_link'
        imu.child_frame_id = 'imu_link'
        imu.transform.translation.z = -0.25
        publisher.publish(TFMessage(transforms=[body, imu]))
        index += 1
        time.sleep(0.05)
    node.destroy_node()
    rclpy.try_shutdown()
''')
PUBLISH_SECONDS = 30.0


@pytest.fixture
def ros(ros_domain_id: int) -> Iterator[RosContext]:
    """A context and executor of the test's own on the test run's domain."""
    with ros_session(ros_domain_id) as session:
        yield session


def test_generated_type_hash_equals_upstream_jazzy():
    description = Path(get_package_share_directory('tf2_msgs')) / 'msg' / 'TFMessage.json'
    hashes = json.loads(description.read_text())['type_hashes']
    own = [entry['hash_string'] for entry in hashes if entry['type_name'] == TYPE_NAME]
    assert own == [UPSTREAM_JAZZY_TYPE_HASH]


def test_installed_into_the_venv_prefix():
    import tf2_msgs
    assert Path(tf2_msgs.__file__).resolve().is_relative_to(PREFIX)
    assert Path(get_package_prefix('tf2_msgs')).resolve() == PREFIX
    assert TFMessage.__module__.startswith('tf2_msgs.msg')


def test_a_ros_install_uses_its_own_tf2_msgs():
    assert (REPO_ROOT / 'interfaces' / 'COLCON_IGNORE').is_file()  # colcon skips interfaces/
    manifest = ElementTree.parse(REPO_ROOT / 'package.xml').getroot()
    assert 'tf2_msgs' in {element.text for element in manifest.findall('depend')}
    definition = (REPO_ROOT / 'interfaces' / 'tf2_msgs' / 'msg' / 'TFMessage.msg').read_text()
    fields = [line for line in definition.splitlines() if line and not line.startswith('#')]
    assert fields == ['geometry_msgs/TransformStamped[] transforms']


def test_tf_message_from_another_process_arrives_with_upstream_type_hash(ros, request):
    harness = Harness(ros, unique_namespace(request))
    topic = harness.node.get_namespace() + '/tf'
    received = harness.record(TFMessage, topic, TF_QOS)
    publisher = subprocess.Popen(
        [sys.executable, '-c', PUBLISHER, topic, str(PUBLISH_SECONDS)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=dict(os.environ))
    try:
        arrived = harness.spin_until(lambda: len(received) >= 5, timeout=PUBLISH_SECONDS - 5)
        endpoints = harness.node.get_publishers_info_by_topic(topic)
    finally:
        publisher.terminate()
        _, stderr = publisher.communicate(timeout=15)
    assert arrived, f'{len(received)} TFMessages received; publisher stderr:\n{stderr}'
    assert [endpoint.topic_type for endpoint in endpoints] == [TYPE_NAME]
    assert [str(endpoint.topic_type_hash) for endpoint in endpoints] == [
        UPSTREAM_JAZZY_TYPE_HASH]
    indices = [message.transforms[0].header.stamp.sec for message in received]
    assert indices == list(range(indices[0], indices[0] + len(indices)))
    body, imu = received[-1].transforms
    assert isinstance(body, TransformStamped)
    assert (body.header.frame_id, body.child_frame_id) == ('odom', 'base_link')
    assert (body.transform.translation.x, body.transform.rotation.x,
            body.transform.rotation.w) == (1.5, 0.6, 0.8)
    assert (imu.header.frame_id, imu.child_frame_id) == ('base_link', 'imu_link')
    assert imu.transform.translation.z == -0.25
