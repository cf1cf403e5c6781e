"""Hostile input on every input topic of the running node, through real rclpy publishers.

Each malformed payload is published raw (serialized bytes) between good messages. The node must
count it per topic (``rejected malformed``, ``malformed <topic>`` in /diagnostics), keep going,
and end with exactly the attitude the good messages alone give: the malformed ones changed
nothing.

Decodable but hostile messages are declared per surface in :data:`SURFACES` (topic, message
type, the hostile cases, the reasons they are counted under): each class is sent between the
samples of a good 1 kHz gyro stream to the node in this process, and must be counted in full
while the attitude ends where the good stream alone takes it. A new input gets the same
treatment by adding one entry. The issue-sized cases (a 200 Hz stream behind a foreign frame
or thousands of junk transforms, 4 MB frame ids) run against the installed node in a process
of its own, whose log and resident memory are measured.

A scene's ``sensors`` sections are given at start: each hostile one in
:data:`SENSOR_SECTIONS` must stop the node with one short error line that names the key.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
import math
from pathlib import Path
import struct
import time
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import (
    PoseStamped, PoseWithCovarianceStamped, QuaternionStamped, Vector3Stamped, WrenchStamped)
import numpy as np
import pytest
from geometry_msgs.msg import TransformStamped
from rclpy.duration import Duration
from rclpy.parameter import Parameter
from rclpy.qos import (
    DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy, qos_profile_sensor_data)
from rclpy.serialization import serialize_message
from ros_helpers import Harness, stamp, unique_namespace
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState, MagneticField
from tf2_msgs.msg import TFMessage
from test_input_qos import connect, missing_stamps, receive_all, RECORD_QOS
from test_input_qos import start_node as start_node_process
from test_node_subprocess import start as start_installed, stop_with_sigint
import yaml

from rigid_body_attitude.core.attitude import quaternion
from rigid_body_attitude.core.estimation.alignment import tilt_angle, world_up
from rigid_body_attitude.core.errors import SceneError
from rigid_body_attitude.core.estimation.rest import SPECIFIC_FORCE_LIMIT
from rigid_body_attitude.msgs.joint_state import joint_state_encoder
from rigid_body_attitude.ros.node import AttitudePropagatorNode
from rigid_body_attitude.ros.serve import error_text
from rigid_body_attitude.core.attitude.quaternion import from_rpy


def rpy(*angles):
    """``from_rpy`` of roll, pitch, yaw as a (w, x, y, z) tuple."""
    return tuple(from_rpy(angles).tolist())


BASE_NS = 1_700_000_000 * 10**9 + 123_456_789
MS = 1_000_000
OMEGA = (0.3, -0.2, 1.1)


def malformed_variants(good: bytes) -> list[bytes]:
    """Bytes no decoder may accept: truncations, bad encapsulation, absurd string lengths,
    garbage, nothing."""
    frame_length_at = 12  # after the encapsulation header (4) and the stamp (8)
    absurd_length = bytearray(good)
    struct.pack_into('<I', absurd_length, frame_length_at, 0xFFFFFFFF)
    unterminated = bytearray(good)
    unterminated[16 + struct.unpack_from('<I', good, frame_length_at)[0] - 1] = ord('x')
    return [
        good[:20], good[:len(good) // 2], good[:-1], good[:3], b'',
        b'\x01\x05' + good[2:],                      # encapsulation 0x0105
        b'\x00\x0a' + good[2:],                      # encapsulation 0x000a
        bytes(absurd_length), bytes(unterminated),
        bytes(range(256)) * 2,
    ]


def start_node(harness: Harness, **parameters: Any) -> AttitudePropagatorNode:
    node = AttitudePropagatorNode(
        context=harness.ros.context, namespace=harness.node.get_namespace(),
        parameter_overrides=[Parameter(name, value=value) for name, value in parameters.items()])
    return harness.add_node(node)


def send(harness: Harness, node: AttitudePropagatorNode, topic: str, payload: Any) -> None:
    """Publish one message (a message or raw bytes); spin until the node has taken it."""
    expected = node.built.session.received_count() + 1
    harness.publishers[topic].publish(payload)
    assert harness.spin_until(lambda: node.built.session.received_count() >= expected, 5.0), topic


def gyro_message(topic: str, at_ns: int, frame: str = 'base_link') -> Any:
    if topic == 'imu':
        message = Imu()
        message.angular_velocity.x, message.angular_velocity.y, message.angular_velocity.z = OMEGA
    else:
        message = Vector3Stamped()
        message.vector.x, message.vector.y, message.vector.z = OMEGA
    message.header.stamp = stamp(at_ns)
    message.header.frame_id = frame  # base_link: in the body frame, no mount to look up
    return message


def own_values(diagnostics: list[DiagnosticArray], node: AttitudePropagatorNode
               ) -> dict[str, str]:
    name = node.get_fully_qualified_name()
    mine = [m for m in diagnostics if m.status and m.status[0].name == name]
    return {pair.key: pair.value for pair in mine[-1].status[0].values} if mine else {}


@pytest.mark.parametrize('topic, message_type', [('imu', Imu),
                                                 ('angular_velocity', Vector3Stamped)])
def test_malformed_gyro_bytes_change_nothing(ros, request, topic, message_type):
    harness = Harness(ros, unique_namespace(request))
    node = start_node(harness, scene='strapdown')
    harness.publisher(message_type, topic)
    harness.publisher(PoseStamped, 'set_pose')
    orientations = harness.record(QuaternionStamped, 'orientation')
    diagnostics = harness.record(DiagnosticArray, '/diagnostics')
    harness.wait_for_connections()
    bad = malformed_variants(serialize_message(gyro_message(topic, BASE_NS)))
    good_count = 2 * len(bad) + 1
    for k in range(good_count):
        send(harness, node, topic, gyro_message(topic, BASE_NS + k * MS))
        if k < len(bad):
            send(harness, node, topic, bad[k])
            pose = malformed_variants(serialize_message(PoseStamped()))[k]
            send(harness, node, 'set_pose', pose)
    assert harness.spin_until(lambda: len(orientations) == good_count, 5.0)
    # The good stream alone: a constant rate, so exp((n − 1) h ω) to round-off (20 steps).
    expected = _exp((good_count - 1) * 1e-3 * np.array(OMEGA))
    last = orientations[-1].quaternion
    assert np.max(np.abs(np.array([last.w, last.x, last.y, last.z]) - expected)) <= 1e-14
    session = node.built.session
    assert session.malformed_by_topic == {topic: len(bad), 'set_pose': len(bad)}
    assert session.accepted_count() == good_count
    assert harness.spin_until(
        lambda: own_values(diagnostics, node).get('rejected malformed') == str(2 * len(bad)),
        3.0)
    values = own_values(diagnostics, node)
    assert values[f'malformed {topic}'] == str(len(bad))
    assert values['malformed set_pose'] == str(len(bad))


def _exp(rotation_vector: np.ndarray) -> np.ndarray:
    angle = float(np.linalg.norm(rotation_vector))
    return np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * rotation_vector / angle])


@pytest.mark.parametrize('scene, topic, message_type', [
    ('commanded_torque', 'torque', WrenchStamped),
    ('gyrostat', 'rotor_torque', Vector3Stamped),
    ('wheel_slew_commanded', 'wheels/command', JointState),
    ('wheel_slew_commanded', 'dipole', Vector3Stamped),
])
def test_malformed_command_bytes_change_nothing(ros, request, scene, topic, message_type):
    """On sim time: a node fed only malformed commands ticks exactly like one fed nothing."""
    outputs = {}
    for role in ('hostile', 'quiet'):
        harness = Harness(ros, unique_namespace(request) + '_' + role)
        node = start_node(harness, scene=scene, use_sim_time=True)
        harness.publisher(Clock, '/clock')
        harness.publisher(message_type, topic)
        poses = harness.record(QuaternionStamped, 'orientation')
        harness.wait_for_connections()
        if role == 'hostile':
            good = message_type()
            good.header.stamp = stamp(BASE_NS)
            good_bytes = serialize_message(good)
            if message_type is JointState:  # exactly the message (rclpy pads after it)
                good_bytes = joint_state_encoder('', ['wheel_a'])(
                    good.header.stamp.sec, good.header.stamp.nanosec, (), (), (0.01,))
            for payload in malformed_variants(good_bytes):
                send(harness, node, topic, payload)
            assert node.built.session.malformed_by_topic == {topic: 10}
        for k in range(1, 6):
            clock = Clock()
            clock.clock = stamp(1000 * 10**9 + k * 20 * MS)
            harness.publishers['/clock'].publish(clock)
            assert harness.spin_until(lambda: len(poses) >= k, 5.0)
        outputs[role] = [(m.quaternion.w, m.quaternion.x, m.quaternion.y, m.quaternion.z)
                         for m in poses[:5]]
        ros.executor.remove_node(node)
        node.destroy_node()
    assert outputs['hostile'] == outputs['quiet']


WHEELS = ['wheel_a', 'wheel_b', 'wheel_c', 'wheel_d']


SIM_NS = 1000 * 10**9  # the sim clock's ticks: 1000 s + k 50 ms


def joint_state(names, position=(), velocity=(), effort=()) -> JointState:
    message = JointState()
    message.header.stamp = stamp(SIM_NS)
    message.name = list(names)
    message.position, message.velocity, message.effort = (
        list(position), list(velocity), list(effort))
    return message


def dipole(vector) -> Vector3Stamped:
    message = Vector3Stamped()
    message.header.stamp = stamp(SIM_NS)
    message.header.frame_id = 'base_link'
    message.vector.x, message.vector.y, message.vector.z = vector
    return message


def restamped(message, sec: int, nanosec: int):
    """``message`` with the header stamp ``(sec, nanosec)`` (any int32, uint32)."""
    message.header.stamp.sec, message.header.stamp.nanosec = sec, nanosec
    return message


#: (topic, message, the reason it is counted under): decodable commands the node refuses.
HOSTILE_ACTUATOR_COMMANDS = [
    ('wheels/command', joint_state(WHEELS[:3] + ['wheel_x'], effort=[0.01] * 4),
     'unknown_wheel'),
    ('wheels/command', joint_state(WHEELS[:2] + WHEELS[:2], effort=[0.01] * 4),
     'unknown_wheel'),
    ('wheels/command', joint_state(['x' * 200] * 1000, effort=[0.01] * 1000), 'unknown_wheel'),
    ('wheels/command', joint_state(WHEELS[:3], effort=[0.01] * 3), 'missing_wheel'),
    ('wheels/command', joint_state([], effort=[]), 'missing_wheel'),
    ('wheels/command', joint_state(WHEELS, velocity=[1.0] * 4, effort=[0.01] * 4),
     'wheel_fields'),
    ('wheels/command', joint_state(WHEELS), 'wheel_fields'),
    ('wheels/command', joint_state(WHEELS, position=[0.0] * 4, effort=[0.01] * 4),
     'wheel_fields'),
    ('wheels/command', joint_state(WHEELS, effort=[0.01] * 3), 'wheel_lengths'),
    ('wheels/command', joint_state(WHEELS, velocity=[1.0] * 1000), 'wheel_lengths'),
    ('wheels/command', joint_state(WHEELS, effort=[math.nan, 0.0, 0.0, 0.0]), 'non_finite'),
    ('wheels/command', joint_state(WHEELS, velocity=[math.inf, 0.0, 0.0, 0.0]), 'non_finite'),
    ('wheels/command', joint_state(WHEELS, effort=[1e13, 0.0, 0.0, 0.0]), 'out_of_range'),
    ('wheels/command', joint_state(WHEELS, velocity=[-1e300] * 4), 'out_of_range'),
    ('dipole', dipole((math.nan, 0.0, 0.0)), 'non_finite'),
    ('dipole', dipole((0.0, 1e13, 0.0)), 'out_of_range'),
    ('dipole', dipole((-1e308, 1e308, 1e308)), 'out_of_range'),
    ('dipole', restamped(dipole((0.1, 0.0, 0.0)), 1000, 10**9), 'invalid_stamp'),
    ('wheels/command', restamped(joint_state(WHEELS, effort=[0.01] * 4), -1, 0),
     'invalid_stamp'),
    # Good values before the scene's first tick: they would set no epoch, they are refused.
    ('dipole', restamped(dipole((0.1, 0.0, 0.0)), 2**31 - 1, 0), 'not_started'),
    ('wheels/command', joint_state(WHEELS, effort=[0.01] * 4), 'not_started'),
]


def test_hostile_wheel_and_dipole_commands_are_counted_and_change_nothing(ros, request):
    """On sim time: a node sent every refused command ticks exactly like one sent nothing,
    its attitude and its wheels alike, and counts each by its reason."""
    outputs = {}
    for role in ('hostile', 'quiet'):
        harness = Harness(ros, unique_namespace(request) + '_' + role)
        node = start_node(harness, scene='wheel_slew_commanded', use_sim_time=True)
        harness.publisher(Clock, '/clock')
        harness.publisher(JointState, 'wheels/command')
        harness.publisher(Vector3Stamped, 'dipole')
        poses = harness.record(QuaternionStamped, 'orientation')
        wheels = harness.record(JointState, 'wheels/state')
        harness.wait_for_connections()
        if role == 'hostile':
            for topic, payload, _ in HOSTILE_ACTUATOR_COMMANDS:
                send(harness, node, topic, payload)
            counts = node.built.session.rejection_counts()
            expected: dict[str, int] = {}
            for _, _, reason in HOSTILE_ACTUATOR_COMMANDS:
                expected[reason] = expected.get(reason, 0) + 1
            assert {reason: counts[reason] for reason in expected} == expected
            assert node.built.session.commands_accepted == 0
        for k in range(1, 6):
            clock = Clock()
            clock.clock = stamp(SIM_NS + k * 50 * MS)
            harness.publishers['/clock'].publish(clock)
            assert harness.spin_until(lambda: len(poses) >= k and len(wheels) >= k, 5.0)
        outputs[role] = ([(m.quaternion.w, m.quaternion.x, m.quaternion.y, m.quaternion.z)
                          for m in poses[:5]],
                         [(tuple(m.velocity), tuple(m.effort)) for m in wheels[:5]])
        if role == 'hostile':  # the counts so far (the message: the last period's only)
            values = dict(node.built.session.report().values)
            assert values['rejected unknown_wheel'] == str(expected['unknown_wheel'])
            assert values['rejected wheel_fields'] == str(expected['wheel_fields'])
        ros.executor.remove_node(node)
        node.destroy_node()
    assert outputs['hostile'] == outputs['quiet']


def test_huge_covariances_on_set_pose_with_covariance_change_nothing(ros, request):
    """Finite but huge, or unphysical, orientation blocks on ``set_pose_with_covariance``
    between good gyro samples: each refused and counted as ``invalid_covariance`` in
    /diagnostics, the attitude the good stream alone gives, every ``imu/data`` and
    ``pose_with_covariance`` covariance finite, no internal error."""
    harness = Harness(ros, unique_namespace(request))
    node = start_node(harness, scene='strapdown')
    harness.publisher(Imu, 'imu')
    harness.publisher(PoseWithCovarianceStamped, 'set_pose_with_covariance')
    orientations = harness.record(QuaternionStamped, 'orientation')
    imu_outputs = harness.record(Imu, 'imu/data')
    poses = harness.record(PoseWithCovarianceStamped, 'pose_with_covariance')
    diagnostics = harness.record(DiagnosticArray, '/diagnostics')
    harness.wait_for_connections()
    blocks = [np.diag([1e308] * 3), np.full((3, 3), 1e308), np.diag([1e-4, 1e-4, 1e300]),
              np.diag([1e-4, 1e-4, 10.0])]
    good_count = 2 * len(blocks) + 1
    for k in range(good_count):
        send(harness, node, 'imu', gyro_message('imu', BASE_NS + k * MS))
        if k < len(blocks):
            pose = PoseWithCovarianceStamped()
            pose.header.frame_id = 'world'
            pose.pose.pose.orientation.x = 1.0
            covariance = np.eye(6)
            covariance[3:, 3:] = blocks[k]
            pose.pose.covariance = covariance.reshape(36).tolist()
            send(harness, node, 'set_pose_with_covariance', pose)
    assert harness.spin_until(lambda: min(len(orientations), len(imu_outputs), len(poses))
                              == good_count, 5.0)
    expected = _exp((good_count - 1) * 1e-3 * np.array(OMEGA))
    last = orientations[-1].quaternion
    assert np.max(np.abs(np.array([last.w, last.x, last.y, last.z]) - expected)) <= 1e-14
    assert all(np.all(np.isfinite(m.orientation_covariance)) for m in imu_outputs)
    assert all(np.all(np.isfinite(m.pose.covariance)) and max(m.pose.covariance[21::7]) < 10.0
               for m in poses)
    assert harness.spin_until(
        lambda: own_values(diagnostics, node).get('rejected invalid_covariance')
        == str(len(blocks)), 3.0)
    assert own_values(diagnostics, node)['rejected internal_error'] == '0'


# -- declared surfaces: decodable but hostile messages ----------------------------------------

#: /tf_static as a test publishes it: transient local, deep enough that nothing is replaced
#: before the node read it.
LATCHED_QOS = QoSProfile(depth=1000, history=HistoryPolicy.KEEP_LAST,
                         reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
DEEP_QOS = QoSProfile(depth=5000, history=HistoryPolicy.KEEP_LAST,
                      reliability=ReliabilityPolicy.RELIABLE)
UNIT = (1.0, 0.0, 0.0, 0.0)
ZERO = (0.0, 0.0, 0.0)


@dataclass
class Surface:
    """One input of the node and a class of hostile cases for it.

    ``cases()`` builds the messages (or raw bytes) sent on ``topic``, one after each good
    ``imu`` sample in ``imu_frame``; all must be counted under ``reasons`` (``counted`` in
    all, default one each). ``before_last(harness)`` runs before the last good sample (the
    mount, when the stream waits for one); ``parameters`` go to the node. The good stream is
    a constant rate, ending at ``exp(ω t)``; or, with ``at_rest``, :data:`GOOD_AT_REST`
    samples of a body at rest tilted by :data:`TILT` (the node levels from them).
    """

    name: str
    topic: str
    message_type: Any
    cases: Callable[[], list[Any]]
    reasons: tuple[str, ...]
    counted: int | None = None
    imu_frame: str = 'base_link'
    latched: bool = False
    before_last: Callable[[Harness], None] | None = None
    parameters: dict[str, Any] = field(default_factory=dict)
    at_rest: bool = False


def tf_message(*transforms: tuple[str, str, tuple[float, ...], tuple[float, ...]]
               ) -> TFMessage:
    """A TFMessage of (parent, child, rotation (w, x, y, z), translation)."""
    message = TFMessage()
    for parent, child, (w, x, y, z), (tx, ty, tz) in transforms:
        t = TransformStamped()
        t.header.frame_id, t.child_frame_id = parent, child
        r, v = t.transform.rotation, t.transform.translation
        r.w, r.x, r.y, r.z, v.x, v.y, v.z = w, x, y, z, tx, ty, tz
        message.transforms.append(t)
    return message


def send_mount(harness: Harness) -> None:
    """``base_link`` -> ``imu_link`` (identity) on /tf_static; a moment to read it."""
    harness.publishers['/tf_static'].publish(tf_message(('base_link', 'imu_link', UNIT, ZERO)))
    harness.spin_for(0.3)


def invalid_transforms() -> list[TFMessage]:
    rotations = [(0.0, 0.0, 0.0, 0.0), (1e-8, 0.0, 0.0, 0.0), (0.9, 0.0, 0.0, 0.0),
                 (1e300, 1e300, 0.0, 0.0), (math.nan, 0.0, 0.0, 1.0), (math.inf, 0.0, 0.0, 0.0)]
    cases = [tf_message(('base_link', 'imu_link', q, ZERO)) for q in rotations]
    cases += [tf_message(('base_link', 'imu_link', UNIT, v))
              for v in ((math.inf, 0.0, 0.0), (0.0, math.nan, 0.0))]
    return cases + [tf_message((parent, child, UNIT, ZERO)) for parent, child in (
        ('', 'imu_link'), ('imu_link', 'imu_link'), ('base_link', 'x' * 2**20))]


def junk_transforms() -> list[TFMessage]:
    """Three messages of 10 000 transforms hanging off ``base_link`` (every one on a chain
    from the body frame a search would walk), none leading to the IMU."""
    return [tf_message(*(('base_link', f'junk_{m}_{k}', UNIT, ZERO) for k in range(10_000)))
            for m in range(3)]


def malformed_transforms() -> list[bytes]:
    good = serialize_message(tf_message(('base_link', 'torso', UNIT, ZERO)))
    return [good[:n] for n in (3, 8, 12, 20, len(good) // 2, len(good) - 1)] + [
        b'\x01\x05' + good[2:], b'\x00\x0a' + good[2:], bytes(range(256)) * 2]


def foreign_frames() -> list[Imu]:
    frames = ['other_imu', '', 'imu_link', '\x1b[2J\x07', 'x' * 2**20, 'base_link ']
    return [gyro_message('imu', BASE_NS + k * MS + MS // 2, frame)
            for k, frame in enumerate(frames)]


#: The tilt of the body at rest (levelling surfaces), roll and pitch [rad].
TILT = rpy(0.3, -0.2, 0.0)
#: Samples of the body at rest: 0.6 s at 1 kHz, past ``align_seconds`` 0.3 s of rest.
GOOD_AT_REST = 600


def at_rest_message(at_ns: int, accel: tuple[float, float, float] | None = None) -> Imu:
    """An Imu of the body at rest tilted by TILT (zero rate, gravity's specific force), or
    with the specific force ``accel``."""
    message = gyro_message('imu', at_ns)
    message.angular_velocity.x = message.angular_velocity.y = message.angular_velocity.z = 0.0
    up = quaternion.rotate_inverse(TILT, np.array(world_up('enu')) * 9.80665)
    f = message.linear_acceleration
    f.x, f.y, f.z = up.tolist() if accel is None else accel
    return message


def at_rest_cases(forces: list[tuple[float, float, float]]) -> list[Imu]:
    """Imu samples at rest with the specific ``forces``, between those of the good stream."""
    return [at_rest_message(BASE_NS + k * MS + MS // 2, force) for k, force in enumerate(forces)]


def absurd_specific_forces() -> list[Imu]:
    """Specific forces far beyond any accelerometer (squares or sums that overflow, or just
    above the limit), while the node levels."""
    return at_rest_cases([(1e200, 0.0, 0.0), (0.0, -1e155, 0.0), (0.0, 0.0, 1e154),
                          (1e308, 1e308, 1e308), (0.0, 0.0, 1.5 * SPECIFIC_FORCE_LIMIT)])


def non_finite_specific_forces() -> list[Imu]:
    return at_rest_cases([(math.nan, 0.0, 9.8), (0.0, math.inf, 0.0), (0.0, 0.0, -math.inf)])


def _field(at_ns: int, field: tuple[float, float, float], frame: str = 'base_link',
           sec_nanosec: tuple[int, int] | None = None) -> MagneticField:
    message = MagneticField()
    message.header.stamp = stamp(at_ns)
    if sec_nanosec is not None:
        message.header.stamp.sec, message.header.stamp.nanosec = sec_nanosec
    message.header.frame_id = frame
    f = message.magnetic_field
    f.x, f.y, f.z = field
    return message


def hostile_fields() -> list[MagneticField]:
    """Fields NaN, Inf, zero or beyond any magnetometer; frames without a mount (1 MiB and an
    escape sequence included); zero and invalid stamps: none may reach the filter."""
    earth = (2e-5, 0.0, -4e-5)
    at = [BASE_NS + k * MS + MS // 2 for k in range(12)]
    return [_field(at[0], (math.nan, 0.0, 0.0)), _field(at[1], (0.0, math.inf, 0.0)),
            _field(at[2], (0.0, 0.0, 0.0)), _field(at[3], (1.0, 0.0, 0.0)),
            _field(at[4], (1e308, 1e308, 1e308)), _field(at[5], earth, 'elsewhere'),
            _field(at[6], earth, 'x' * 2**20), _field(at[7], earth, '\x1b[2J\x07'),
            _field(at[8], earth, sec_nanosec=(0, 0)),
            _field(at[9], earth, sec_nanosec=(BASE_NS // 10**9, 10**9))]


def malformed_fields() -> list[bytes]:
    return malformed_variants(serialize_message(_field(BASE_NS, (2e-5, 0.0, -4e-5))))


def _measurement(at_ns: int, q: tuple[float, ...], frame: str = 'world',
                 block: list[float] | None = None) -> PoseWithCovarianceStamped:
    message = PoseWithCovarianceStamped()
    message.header.stamp, message.header.frame_id = stamp(at_ns), frame
    o = message.pose.pose.orientation
    o.w, o.x, o.y, o.z = q
    covariance = [0.0] * 36
    block = block or [1e-4, 0, 0, 0, 1e-4, 0, 0, 0, 1e-4]
    for row in range(3):
        covariance[7 * row] = 1e9
        covariance[21 + 6 * row:24 + 6 * row] = [float(v) for v in block[3 * row:3 * row + 3]]
    message.pose.covariance = covariance
    return message


def hostile_measurements() -> list[PoseWithCovarianceStamped]:
    """Attitude measurements in another frame, zero or NaN quaternions, covariance blocks
    huge, unphysical or not PSD, stamps far from the gyro's: none may correct the attitude."""
    at = BASE_NS + MS // 2
    blocks = [[1e308, 0, 0, 0, 1e308, 0, 0, 0, 1e308], [1, 0, 0, 0, -1, 0, 0, 0, 1],
              [1, 0.5, 0, 0, 1, 0, 0, 0, 1], [math.nan, 0, 0, 0, 1, 0, 0, 0, 1],
              [1e-4, 0, 0, 0, 1e-4, 0, 0, 0, 10.0]]
    return ([_measurement(at, UNIT, frame) for frame in ('map', '', 'x' * 2**20)]
            + [_measurement(at, (0.0, 0.0, 0.0, 0.0)), _measurement(at, (math.nan, 0, 0, 1))]
            + [_measurement(at, UNIT, block=block) for block in blocks]
            + [_measurement(at + 10**10, UNIT), _measurement(at - 10**10, UNIT)])


def malformed_measurements() -> list[bytes]:
    return malformed_variants(serialize_message(_measurement(BASE_NS, UNIT)))


_FILTER = dict(parameters=dict(scene='imu_filter'))
_MEASUREMENT_REASONS = tuple(f'attitude_measurement_{reason}' for reason in (
    'wrong_frame', 'invalid_pose', 'non_finite', 'invalid_covariance', 'stale_measurement'))
_TF = dict(imu_frame='imu_link', latched=True, before_last=send_mount)
#: Every surface and hostile class the in-process node is fed. Add an entry to cover a new
#: input (its topic, message type, cases and the reasons they must be counted under).
SURFACES = [
    Surface('imu: samples in another frame', 'imu', Imu, foreign_frames, ('foreign_frame',)),
    Surface('/tf_static: invalid transforms', '/tf_static', TFMessage, invalid_transforms,
            ('tf_denormalized', 'tf_non_finite', 'tf_bad_frames'), **_TF),
    Surface('/tf_static: malformed bytes', '/tf_static', TFMessage, malformed_transforms,
            ('malformed',), **_TF),
    Surface('/tf_static: 30 000 junk transforms', '/tf_static', TFMessage, junk_transforms,
            ('tf_evicted',), counted=20_001, **_TF),  # the mount makes room too
    Surface('imu: specific force absurd while levelling', 'imu', Imu, absurd_specific_forces,
            ('accel_out_of_range',), at_rest=True, parameters=dict(align_seconds=0.3)),
    Surface('imu: specific force NaN or Inf while levelling', 'imu', Imu,
            non_finite_specific_forces, ('non_finite',), at_rest=True,
            parameters=dict(align_seconds=0.3)),
    Surface('imu/mag: hostile fields', 'imu/mag', MagneticField, hostile_fields,
            ('magnetometer_non_finite', 'magnetometer_out_of_range', 'magnetometer_no_mount',
             'magnetometer_invalid_stamp'), **_FILTER),
    Surface('imu/mag: malformed bytes', 'imu/mag', MagneticField, malformed_fields,
            ('malformed',), **_FILTER),
    Surface('attitude_measurement: hostile measurements', 'attitude_measurement',
            PoseWithCovarianceStamped, hostile_measurements, _MEASUREMENT_REASONS, **_FILTER),
    Surface('attitude_measurement: malformed bytes', 'attitude_measurement',
            PoseWithCovarianceStamped, malformed_measurements, ('malformed',), **_FILTER),
]


@pytest.mark.parametrize('surface', SURFACES, ids=[s.name for s in SURFACES])
def test_hostile_cases_are_counted_and_change_nothing(ros, request, surface):
    """Each case after a good sample: all counted under the surface's reasons, every log line
    short, and the attitude exactly the good stream's."""
    harness = Harness(ros, unique_namespace(request))
    node = start_node(harness, **{'scene': 'strapdown', **surface.parameters})
    lines: list[str] = []
    log = node.built.outputs.log

    def logged(level: int, text: str) -> None:  # every line the node logs, also kept here
        lines.append(text)
        log(level, text)
    node.built.outputs.log = logged  # type: ignore[method-assign]
    harness.publisher(Imu, 'imu')
    harness.publisher(surface.message_type, surface.topic,
                      LATCHED_QOS if surface.latched else DEEP_QOS)
    orientations = harness.record(QuaternionStamped, 'orientation')
    harness.wait_for_connections()
    cases = surface.cases()
    good = max(len(cases) + 1, GOOD_AT_REST if surface.at_rest else 0)
    for k in range(good):
        if k == good - 1 and surface.before_last is not None:
            surface.before_last(harness)
        harness.publishers['imu'].publish(
            at_rest_message(BASE_NS + k * MS) if surface.at_rest
            else gyro_message('imu', BASE_NS + k * MS, surface.imu_frame))
        if k < len(cases):
            harness.publishers[surface.topic].publish(cases[k])
        harness.spin_for(0.01 if k < len(cases) + 1 or k % 50 == 0 else 0.0)
    counts = node.built.session.rejection_counts
    expected = len(cases) if surface.counted is None else surface.counted
    # Levelling: the samples of the rest window are accepted, not integrated (no output).
    session = node.built.session
    assert harness.spin_until(
        lambda: sum(counts()[reason] for reason in surface.reasons) >= expected
        and session.accepted_count() >= good
        and len(orientations) >= max(session.stream.accepted, 1), 30.0), (
            counts(), len(orientations))
    harness.spin_for(0.2)
    assert sum(counts()[reason] for reason in surface.reasons) == expected
    assert counts()['internal_error'] == 0 and session.accepted_count() == good
    assert len(orientations) == session.stream.accepted
    assert (0 < session.stream.accepted < good) if surface.at_rest else (
        session.stream.accepted == good)
    last = orientations[-1].quaternion
    q = np.array([last.w, last.x, last.y, last.z])
    if surface.at_rest:  # levelled from the clean samples: the true tilt, up to round-off
        assert node.built.session.alignment.at_rest
        assert math.degrees(tilt_angle(tuple(q.tolist()), TILT)) < 0.05
    else:
        assert np.max(np.abs(q - _exp((good - 1) * 1e-3 * np.array(OMEGA)))) <= 1e-14
    assert lines and max(len(line) for line in lines) < 600
    assert not any('\x1b' in line or '\n' in line for line in lines)


# -- the scene's sensors sections: refused at start ----------------------------------------------

_MAGNETOMETER = {'rate': 100.0, 'noise_density': 1e-8, 'intensity': 5e-5}


def _magnetometer(**keys: Any) -> dict[str, Any]:
    return {'sensors': {'magnetometer': {**_MAGNETOMETER, **keys}}}


def _star_tracker(**keys: Any) -> dict[str, Any]:
    return {'sensors': {'star_tracker': {'rate': 10.0, **keys}}}


#: Hostile ``sensors`` (and ``sun``) sections of a dynamics scene, one key each (the cases of
#: studies/hostile_inputs.py's ``sensors sections``) → what the one error line must name.
SENSOR_SECTIONS: dict[str, tuple[dict[str, Any], str]] = {
    'magnetometer rate 1e308': (_magnetometer(rate=1e308), 'sensors.magnetometer.rate'),
    'magnetometer noise density NaN': (_magnetometer(noise_density=math.nan),
                                       'sensors.magnetometer.noise_density'),
    'magnetometer without a field': ({'sensors': {'magnetometer': {
        'rate': 100.0, 'noise_density': 1e-8}}}, 'sensors.magnetometer needs the local field'),
    'magnetometer soft iron singular': (_magnetometer(soft_iron=[[1, 0, 0], [0, 1, 0],
                                                                 [0, 0, 0]]),
                                        'sensors.magnetometer.soft_iron'),
    'magnetometer soft iron mirrored': (_magnetometer(soft_iron=[[-1, 0, 0], [0, 1, 0],
                                                                 [0, 0, 1]]),
                                        'sensors.magnetometer.soft_iron'),
    'magnetometer hard iron 1e308': (_magnetometer(hard_iron=[1e308, 0, 0]),
                                     'sensors.magnetometer.hard_iron'),
    "magnetometer on the node's own topic": (_magnetometer(topic='pose'),
                                             'sensors.magnetometer.topic'),
    'magnetometer topic of 5000 characters': (_magnetometer(topic='x' * 5000),
                                              'sensors.magnetometer.topic'),
    'magnetometer frame with escape sequences': (_magnetometer(frame_id='\x1b[2J\x07'),
                                                 'sensors.magnetometer.frame_id'),
    'magnetometer unknown key': (_magnetometer(noise=1.0), "'noise' in sensors.magnetometer"),
    'magnetometer seed 2^63': (_magnetometer(seed=2**63), 'sensors.magnetometer.seed'),
    'star tracker rate 1e4': (_star_tracker(rate=1e4), 'sensors.star_tracker.rate'),
    'star tracker period off the step': (_star_tracker(rate=300.0),
                                         'sensors.star_tracker.rate'),
    'star tracker zero boresight': (_star_tracker(boresight=[0, 0, 0]),
                                    'sensors.star_tracker.boresight'),
    'star tracker boresight and mount': (_star_tracker(boresight=[1, 0, 0], mount_rpy=[0, 0, 1]),
                                         'sensors.star_tracker takes mount_rpy or boresight'),
    'star tracker zero noise': (_star_tracker(cross_boresight_noise=0.0),
                                'sensors.star_tracker.cross_boresight_noise'),
    'star tracker Sun exclusion without a Sun': (_star_tracker(sun_exclusion_angle=0.5),
                                                 'sensors.star_tracker.sun_exclusion_angle'),
    'star tracker section a list': ({'sensors': {'star_tracker': [1, 2, 3]}},
                                    'sensors.star_tracker to be a mapping'),
    'two sensors on one topic': ({'sensors': {'magnetometer': {**_MAGNETOMETER, 'topic': 'att'},
                                              'star_tracker': {'rate': 10.0, 'topic': 'att'}}},
                                 'sensors.star_tracker.topic'),
    'one frame, two mounts': ({'sensors': {
        'magnetometer': {**_MAGNETOMETER, 'frame_id': 'f'},
        'star_tracker': {'rate': 10.0, 'frame_id': 'f', 'boresight': [1, 0, 0]}}},
        "name the same frame_id 'f'"),
    'zero Sun direction': ({**_star_tracker(sun_exclusion_angle=0.5),
                            'sun': {'direction': [0, 0, 0]}}, 'sun.direction'),
    'sensors in a gyro scene': ({'rate_source': 'gyro', **_magnetometer()},
                                'simulated sensors need a dynamics scene'),
}


def sensed_scene(path: Path, section: dict[str, Any]) -> str:
    path.write_text(yaml.safe_dump({'rate_source': 'dynamics', 'step': 0.001,
                                    'body': {'inertia': {'moments': [1, 2, 3]}}, **section}))
    return str(path)


@pytest.mark.parametrize('name', SENSOR_SECTIONS)
def test_a_hostile_sensors_section_is_refused_in_one_line_naming_the_key(
        ros, request, name, tmp_path):
    """The node in this process refuses the scene: one SceneError, its first line all there
    is, at most 600 characters, without control characters, naming the key."""
    section, key = SENSOR_SECTIONS[name]
    path = sensed_scene(tmp_path / 'sensed.yaml', section)
    harness = Harness(ros, unique_namespace(request))
    with pytest.raises(SceneError) as refused:
        start_node(harness, scene=path)
    text = str(refused.value)
    assert error_text(refused.value) == text and len(text) <= 600, text
    assert text.startswith(f'Scene file {path!r}: ') and key in text, text
    assert not any(ord(character) < 32 for character in text), text


def test_the_installed_node_gives_one_error_line_for_a_hostile_sensors_section(processes,
                                                                               tmp_path):
    section, key = SENSOR_SECTIONS['magnetometer frame with escape sequences']
    process = start_installed('--ros-args', '-p',
                              f'scene:={sensed_scene(tmp_path / "sensed.yaml", section)}')
    processes.append(process)
    _, stderr = process.communicate(timeout=30.0)
    assert process.returncode == 2
    assert stderr.startswith('error: Scene file ') and key in stderr
    assert stderr.count('\n') == 1 and '\x1b' not in stderr and 'Traceback' not in stderr


# -- the installed node in a process of its own -------------------------------------------------

def values_of(statuses: list[DiagnosticArray], key: str) -> int:
    return int({v.key: v.value for v in statuses[-1].status[0].values}[key])


def test_a_foreign_frame_never_holds_up_a_mounted_200hz_stream(ros, request, processes):
    """One Imu in ``other_imu`` before 1000 at 200 Hz in the IMU's frame, whose mount is
    latched on /tf_static: all 1000 integrated, the other counted ``foreign_frame``."""
    namespace = unique_namespace(request)
    sensor = f'{namespace[1:]}_imu'
    node = start_node_process(processes, namespace)
    harness, sender, poses = connect(ros, namespace, qos_profile_sensor_data, sensor)
    statuses = harness.record(DiagnosticArray, '/diagnostics', RECORD_QOS)
    tf_static = harness.node.create_publisher(TFMessage, '/tf_static', LATCHED_QOS)
    tf_static.publish(tf_message(('base_link', sensor, UNIT, ZERO)))
    harness.wait_for_connections()
    harness.spin_for(0.5)
    sender.publish(serialize_message(gyro_message('imu', BASE_NS - MS, 'other_imu')))
    sender.paced(200.0, 1000)
    receive_all(harness, poses, 1000, 10.0)
    harness.spin_for(1.5)
    code, stderr = stop_with_sigint(node)
    assert code == 0, stderr
    assert missing_stamps(poses, 1000) == []
    assert values_of(statuses, 'rejected foreign_frame') == 1
    assert values_of(statuses, 'accepted') == 1000
    assert "'other_imu'" in stderr and 'Traceback' not in stderr


def test_junk_transforms_never_starve_diagnostics_nor_lock_the_mount_out(
        ros, request, processes):
    """30 000 transforms hanging off ``base_link`` and 1000 invalid ones, then a 200 Hz
    stream in the IMU's frame whose mount comes 1 s later: /diagnostics keeps its 1 Hz
    throughout, every sample is integrated once the mount arrives, every transform counted."""
    namespace = unique_namespace(request)
    sensor = f'{namespace[1:]}_imu'
    node = start_node_process(processes, namespace, 'tf_timeout:=30.0')
    harness, sender, poses = connect(ros, namespace, qos_profile_sensor_data, sensor)
    arrivals: list[float] = []
    statuses: list[DiagnosticArray] = []

    def diagnostics(message: DiagnosticArray) -> None:
        if message.status and message.status[0].name == f'{namespace}/attitude_propagator':
            arrivals.append(message.header.stamp.sec + message.header.stamp.nanosec * 1e-9)
            statuses.append(message)
    harness.node.create_subscription(DiagnosticArray, '/diagnostics', diagnostics, RECORD_QOS)
    tf_static = harness.node.create_publisher(TFMessage, '/tf_static', LATCHED_QOS)
    harness.wait_for_connections()
    for message in junk_transforms():
        tf_static.publish(message)
        harness.spin_for(0.3)
    tf_static.publish(tf_message(*((f'bad_{k}', sensor, (0.0, 0.0, 0.0, 0.0), ZERO)
                                   for k in range(1000))))
    started = time.time()  # the node stamps its diagnostics with the system time
    sender.paced(200.0, 200)
    tf_static.publish(tf_message(('base_link', sensor, UNIT, ZERO)))
    sender.paced(200.0, 1000)
    receive_all(harness, poses, 1000, 10.0)
    harness.spin_for(1.5)
    code, stderr = stop_with_sigint(node)
    assert code == 0, stderr
    assert missing_stamps(poses, 1000) == []
    during = [t for t in arrivals if t >= started]
    assert len(during) >= 4 and max(np.diff([started, *during])) < 1.6, np.diff(during)
    assert values_of(statuses, 'rejected tf_evicted') == 20_001  # the mount made room too
    assert values_of(statuses, 'rejected tf_denormalized') == 1000
    assert 'Traceback' not in stderr


def rss_mib(pid: int) -> float:
    status = Path(f'/proc/{pid}/status').read_text()
    return int(next(line for line in status.splitlines()
                    if line.startswith('VmRSS:')).split()[1]) / 1024.0


def test_4mb_frame_ids_give_short_log_lines_and_bounded_memory(ros, request, processes):
    """A hundred Imu messages with a 4 MB ``frame_id`` (escape sequences in it), before and
    after the IMU's frame is known: each counted (``no_mount``, ``foreign_frame``), the log
    under 20 kB with no line over 1000 characters, the node's RSS up by at most 50 MiB."""
    namespace = unique_namespace(request)
    node = start_node_process(processes, namespace, 'tf_timeout:=0.5',
                              f'qos_overrides.{namespace}/imu.subscription.reliability:='
                              'reliable')
    harness, sender, poses = connect(ros, namespace, DEEP_QOS, 'base_link')
    statuses = harness.record(DiagnosticArray, '/diagnostics', RECORD_QOS)
    harness.wait_for_connections()
    harness.spin_for(1.5)
    before = rss_mib(node.pid)
    huge = serialize_message(gyro_message('imu', BASE_NS - MS, '\x1b[31m' + 'x' * 4 * 2**20))
    shallow = harness.node.create_publisher(Imu, 'imu', QoSProfile(  # 10 x 4 MB kept at most
        depth=10, history=HistoryPolicy.KEEP_LAST, reliability=ReliabilityPolicy.RELIABLE))
    harness.spin_until(lambda: shallow.get_subscription_count() > 0)
    for k in range(100):
        if k == 50:  # the IMU's frame becomes known: the rest are foreign
            sender.paced(1000.0, 100)
            receive_all(harness, poses, 100, 10.0)
        shallow.publish(huge)  # one at a time: the transport's queue is not measured here
        assert shallow.wait_for_all_acked(Duration(seconds=5.0))
        harness.spin_for(0.02)
    harness.spin_until(lambda: bool(statuses) and values_of(statuses, 'rejected foreign_frame')
                       + values_of(statuses, 'rejected no_mount') >= 100, 20.0)
    harness.spin_for(1.0)  # the last messages' buffers released: what stays is growth
    growth = rss_mib(node.pid) - before
    code, stderr = stop_with_sigint(node)
    assert code == 0, stderr
    assert values_of(statuses, 'rejected no_mount') == 50
    assert values_of(statuses, 'rejected foreign_frame') == 50
    assert len(stderr) < 20_000 and max(len(line) for line in stderr.splitlines()) < 1000
    assert '\x1b' not in stderr and 'Traceback' not in stderr
    assert growth <= 50.0, growth
