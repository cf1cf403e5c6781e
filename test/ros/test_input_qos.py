"""The installed node's input QoS: every IMU driver connects, nothing lost at real rates.

Each test starts ``propagation_node`` (``scene:=strapdown``, default parameters otherwise) in a
namespace of its own and talks to it from a harness node (this process) over real topics. Loss
is counted end to end: every gyro sample has its own stamp (1 ms apart, so none is a gap or
stale) and produces one ``pose`` with that stamp; the harness records ``pose`` reliably with a
20 000-deep queue, so a missing stamp is a sample the node never integrated.
"""

from __future__ import annotations

from collections.abc import Iterator
import subprocess
import sys
import threading
import time

import pytest
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from rclpy.qos import (
    HistoryPolicy, QoSProfile, qos_profile_sensor_data, ReliabilityPolicy)
from rclpy.serialization import serialize_message
from ros_helpers import Harness, ros_session, RosContext, unique_namespace
from sensor_msgs.msg import Imu
from test_node_subprocess import read_until, SERVING, start, START_TIMEOUT, stop_with_sigint

from rigid_body_attitude.ros.qos import INPUT_DEPTH

#: The harness's pose recorder: reliable, deep enough for every pose of a test.
RECORD_QOS = QoSProfile(depth=20000, history=HistoryPolicy.KEEP_LAST,
                        reliability=ReliabilityPolicy.RELIABLE)
#: A publisher like a bag player or most nodes: reliable, and deep for bursts.
RELIABLE_PUBLISHER_QOS = QoSProfile(depth=5000, history=HistoryPolicy.KEEP_LAST,
                                    reliability=ReliabilityPolicy.RELIABLE)
BASE_NS = 1_700_000_000 * 10**9
PERIOD_NS = 1_000_000  # stamps 1 ms apart (1 kHz)


@pytest.fixture
def ros(ros_domain_id: int) -> Iterator[RosContext]:
    """A context and executor of the test's own on the test run's domain."""
    with ros_session(ros_domain_id) as session:
        yield session


@pytest.fixture
def busy_processes() -> Iterator[list[subprocess.Popen]]:
    """Two processes that keep one core each busy (this machine has two) until the end."""
    started = [subprocess.Popen([sys.executable, '-c', 'while True: pass']) for _ in range(2)]
    yield started
    for process in started:
        process.kill()
        process.wait()


class ImuSender:
    """Publishes serialized Imu messages stamped ``BASE_NS + k ms`` (k = 0, 1, ...)."""

    def __init__(self, publisher, frame_id: str = '') -> None:
        """Serialize one Imu of ``frame_id``; only its stamp changes per message."""
        imu = Imu()
        imu.header.frame_id = frame_id
        imu.angular_velocity.x, imu.angular_velocity.z = 0.3, -0.2
        self.template = bytearray(serialize_message(imu))
        self.publish = publisher.publish
        self.sent = 0

    def send(self) -> None:
        """Publish the next sample."""
        sec, nanosec = divmod(BASE_NS + self.sent * PERIOD_NS, 10**9)
        self.template[4:8] = sec.to_bytes(4, 'little', signed=True)
        self.template[8:12] = nanosec.to_bytes(4, 'little')
        self.publish(bytes(self.template))
        self.sent += 1

    def paced(self, rate: float, count: int) -> None:
        """Publish ``count`` samples at ``rate`` Hz against absolute due times (a late
        thread catches up in a burst, as a driver reading its FIFO would)."""
        start_s = time.monotonic()
        while self.sent < count:
            delay = start_s + self.sent / rate - time.monotonic()
            if delay > 0.0:
                time.sleep(delay)
            self.send()


def start_node(processes: list, namespace: str, *parameters: str) -> subprocess.Popen:
    """The installed node on scene strapdown in ``namespace``, serving (log line read)."""
    arguments = ['--ros-args', '-p', 'scene:=strapdown', '-r', f'__ns:={namespace}']
    for parameter in parameters:
        arguments += ['-p', parameter]
    process = start(*arguments)
    processes.append(process)
    read_until(process, SERVING)
    return process


def connect(ros: RosContext, namespace: str, publisher_qos: QoSProfile, frame_id: str = ''
            ) -> tuple[Harness, ImuSender, list]:
    """Harness publishing ``imu`` (of ``frame_id``) with ``publisher_qos`` and recording
    ``pose``."""
    harness = Harness(ros, namespace)
    sender = ImuSender(harness.publisher(Imu, 'imu', publisher_qos), frame_id)
    poses = harness.record(PoseStamped, 'pose', RECORD_QOS)
    harness.wait_for_connections(START_TIMEOUT)
    harness.spin_for(0.5)  # discovery settles before the first sample
    return harness, sender, poses


def missing_stamps(poses: list, count: int) -> list[int]:
    """Indices 0 < k < ``count`` of samples without a pose stamped ``BASE_NS + k ms`` (the
    first sample only sets the baseline: no pose)."""
    seen = {(m.header.stamp.sec * 10**9 + m.header.stamp.nanosec - BASE_NS) // PERIOD_NS
            for m in poses}
    return [k for k in range(1, count) if k not in seen]


def receive_all(harness: Harness, poses: list, count: int, timeout: float) -> None:
    """Spin until ``count`` poses arrived or ``timeout`` s passed (then a little longer)."""
    harness.spin_until(lambda: len(poses) >= count - 1, timeout)
    harness.spin_for(0.2)


def paced_run(ros, request, processes, publisher_qos: QoSProfile, rate: float, count: int,
              timeout: float, *parameters: str) -> list[int]:
    """``count`` samples paced at ``rate`` Hz to a node started with ``parameters``: the
    node stops cleanly and integrated every sample (checked here; returns the missing: [])."""
    namespace = unique_namespace(request)
    node = start_node(processes, namespace, *parameters)
    harness, sender, poses = connect(ros, namespace, publisher_qos)
    statuses = harness.record(DiagnosticArray, '/diagnostics', RECORD_QOS)
    harness.wait_for_connections(START_TIMEOUT)
    pacer = threading.Thread(target=sender.paced, args=(rate, count))
    pacer.start()
    try:
        receive_all(harness, poses, count, timeout)
    finally:
        pacer.join()
    receive_all(harness, poses, count, 5.0)
    harness.spin_for(1.5)
    code, stderr = stop_with_sigint(node)
    assert code == 0, stderr
    assert 'incompatible QoS' not in stderr
    assert sender.sent == count
    missing = missing_stamps(poses, count)
    assert missing == [], (
        f'{len(missing)} samples not integrated (first {missing[:5]}); the node received '
        f'{diagnostics_value(statuses, "received")}, missed '
        f'{diagnostics_value(statuses, "missed_samples")}; poses {len(poses)}; node log:\n'
        f'{stderr}')
    return missing


def test_a_sensor_data_publisher_connects_and_every_sample_is_integrated(
        ros, request, processes):
    """An IMU driver's profile (``qos_profile_sensor_data``: best effort, keep last 5) reaches
    the node with its default QoS: every one of 2 000 samples at 500 Hz is integrated."""
    assert paced_run(ros, request, processes, qos_profile_sensor_data, 500.0, 2000, 20.0) == []


def test_a_reliable_publisher_connects_and_every_sample_is_integrated(ros, request, processes):
    """A reliable publisher (a bag player, most nodes) reaches the best-effort input too."""
    assert paced_run(ros, request, processes, RELIABLE_PUBLISHER_QOS, 500.0, 2000, 20.0) == []


def test_1khz_for_10_s_beside_two_busy_processes_loses_nothing(
        ros, request, processes, busy_processes):
    """10 000 sensor-data samples paced at 1 kHz while two busy loops load both cores: every
    one integrated."""
    assert paced_run(ros, request, processes, qos_profile_sensor_data, 1000.0, 10_000,
                     30.0) == []


def diagnostics_value(statuses: list, key: str) -> int:
    """The value of ``key`` in the last ``/diagnostics`` status received."""
    return int(next(v.value for v in statuses[-1].status[0].values if v.key == key))


def test_samples_a_burst_loses_at_the_transport_are_counted_as_missed(ros, request, processes):
    """2 000 samples published back to back between two paced stretches: whatever best effort
    loses in the burst is counted in ``missed_samples`` (received + missed = sent)."""
    namespace = unique_namespace(request)
    node = start_node(processes, namespace)
    harness, sender, poses = connect(ros, namespace, qos_profile_sensor_data)
    statuses = harness.record(DiagnosticArray, '/diagnostics', RECORD_QOS)
    harness.wait_for_connections(START_TIMEOUT)
    sender.paced(500.0, 100)
    for _ in range(2000):
        sender.send()
    time.sleep(0.5)
    start_s = time.monotonic()
    while sender.sent < 2200:
        sender.send()
        time.sleep(0.002)
    assert time.monotonic() - start_s < 5.0
    harness.spin_for(2.5)  # two diagnostics periods
    code, stderr = stop_with_sigint(node)
    assert code == 0, stderr
    received = diagnostics_value(statuses, 'received')
    missed = diagnostics_value(statuses, 'missed_samples')
    assert received + missed == sender.sent, (received, missed)
    assert len(poses) <= received


def test_reliable_is_one_qos_override_away(ros, request, processes):
    """``qos_overrides`` make the input reliable: a reliable publisher's 2 000-sample burst
    then loses nothing (the reader has the writer resend what the transport dropped)."""
    namespace = unique_namespace(request)
    node = start_node(processes, namespace,
                      f'qos_overrides.{namespace}/imu.subscription.reliability:=reliable')
    harness, sender, poses = connect(ros, namespace, RELIABLE_PUBLISHER_QOS)
    count = 2000
    assert count < INPUT_DEPTH
    for _ in range(count):
        sender.send()
    receive_all(harness, poses, count, 20.0)
    code, stderr = stop_with_sigint(node)
    assert code == 0, stderr
    assert missing_stamps(poses, count) == []


def test_an_incompatible_publisher_is_reported_on_gyro_and_typed_inputs(
        ros, request, processes):
    """Best-effort (sensor-data) publishers on reliable inputs: ``imu`` made reliable with
    ``qos_overrides`` (a raw subscription, served by the raw-take loop) and ``set_pose`` (reliable
    by default: a command must arrive) are each reported by rclpy's warning (it names the topic
    as the node created it: relative)."""
    namespace = unique_namespace(request)
    topics = {'imu': Imu, 'set_pose': PoseStamped}
    node = start_node(processes, namespace,
                      f'qos_overrides.{namespace}/imu.subscription.reliability:=reliable')
    harness = Harness(ros, namespace)
    for topic, message_type in topics.items():
        harness.publisher(message_type, topic, qos_profile_sensor_data)
    expected = {topic: f"topic '{topic}', offering incompatible QoS" for topic in topics}
    lines: list[str] = []
    while not all(any(text in line for line in lines) for text in expected.values()):
        lines += read_until(node, 'offering incompatible QoS', START_TIMEOUT)
    code, stderr = stop_with_sigint(node)
    assert code == 0, stderr
    text = ''.join(lines)
    for topic in topics:
        assert (f"New publisher discovered on topic '{topic}', offering "
                f'incompatible QoS. No messages will be received from it. Last incompatible '
                f'policy: RELIABILITY') in text
