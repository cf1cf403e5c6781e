"""Attack the installed ``propagation_node`` as a hostile peer would; report what it did.

Every attack class is sent to a running node (a subprocess started as a user would, through
real rclpy publishers in this process) or given to it at start (scene files, parameters).
Each input under attack is one entry of :data:`SURFACES` (topic, message type, parameters,
its classes of cases and the reasons they must be counted under): a new input is attacked
the same way by adding an entry.
For each class the report says how many cases were tried and whether the node survived,
counted every case in ``/diagnostics`` under the expected reason, kept every output finite, and
ended with exactly the state the good inputs alone give. ``docs/robustness.md`` quotes the
table this prints (or writes to ``--out``)::

    .venv/bin/python studies/hostile_inputs.py            # about five minutes
    .venv/bin/python studies/hostile_inputs.py --surface /tf_static   # one surface
    .venv/bin/python studies/hostile_inputs.py --start 'sensors sections'  # one start class
    .venv/bin/python studies/hostile_inputs.py --domain 91 --out /tmp/hostile.md
"""

from __future__ import annotations

import argparse
import math
import os
import random
import signal
import struct
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

REPO_ROOT = Path(__file__).resolve().parents[1]
MS = 1_000_000
BASE_NS = 1_700_000_000 * 10**9 + 123_456_789
OMEGA = (0.3, -0.2, 1.1)


@dataclass
class Result:
    """One attack class: cases tried and what was checked."""

    name: str
    cases: int
    reason: str
    outcome: str
    seconds: float
    rss_growth_mib: float | None = None


def node_command(*arguments: str) -> list[str]:
    return [str(Path(sys.prefix) / 'bin' / 'propagation_node'), '--ros-args', *arguments]


def deep_inputs(*topics: str) -> list[str]:
    """Reliable, 10 000-deep input queues: this bench tests rejection, not loss."""
    arguments = []
    for topic in topics:
        prefix = f'qos_overrides./{topic}.subscription'
        arguments += ['-p', f'{prefix}.reliability:=reliable', '-p', f'{prefix}.depth:=10000']
    return arguments


# -- payloads ---------------------------------------------------------------------------------

def stamp(nanoseconds: int) -> Any:
    from builtin_interfaces.msg import Time
    sec, nanosec = divmod(nanoseconds, 10**9)
    return Time(sec=sec, nanosec=nanosec)


def imu(at_ns: int, rate: tuple[float, float, float] = OMEGA, frame: str = 'base_link') -> Any:
    from sensor_msgs.msg import Imu
    message = Imu()
    message.header.stamp, message.header.frame_id = stamp(at_ns), frame
    message.angular_velocity.x, message.angular_velocity.y, message.angular_velocity.z = rate
    return message


def malformed_cases(good: bytes, seed: int) -> dict[str, list[bytes]]:
    """Malformed variants of a serialized message, by class."""
    generator = random.Random(seed)
    valid_ids = {0x0000, 0x0001}
    encapsulations = [bytes([high, low]) + good[2:] for high in range(256)
                      for low in (0, 1, 2, 3) if (high << 8 | low) not in valid_ids]
    lengths = []
    for value in (0, 2, 3, 100, len(good), 2**16, 2**31, 2**32 - 1):
        data = bytearray(good)
        struct.pack_into('<I', data, 12, value)
        lengths.append(bytes(data))
    return {
        # From 1 byte: an empty payload never reaches the node (rmw_fastrtps drops it; on a
        # reliable connection it stalls that writer's later samples: docs/robustness.md).
        'truncated at every length': [good[:n] for n in range(1, len(good))],
        'encapsulation id other than CDR_BE, CDR_LE': encapsulations,
        'frame_id length absurd or wrong': lengths,
        'random bytes': [generator.randbytes(generator.randrange(1, 600)) for _ in range(200)],
    }


# -- a running node ---------------------------------------------------------------------------

class RunningNode:
    """The installed node in a subprocess and a harness node publishing to it."""

    def __init__(self, domain: int, arguments: list[str]) -> None:
        import rclpy
        from rclpy.executors import SingleThreadedExecutor
        env = dict(os.environ, ROS_DOMAIN_ID=str(domain),
                   ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST', PYTHONFAULTHANDLER='1')
        self.process = subprocess.Popen(node_command(*arguments), env=env,
                                        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                        text=True)
        os.environ['ROS_DOMAIN_ID'] = str(domain)
        os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = rclpy.create_node('hostile_harness', context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.publishers: dict[str, Any] = {}
        self.received: dict[str, list[Any]] = {}

    def publisher(self, message_type: Any, topic: str, latched: bool = False) -> Any:
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        qos = QoSProfile(depth=10000, reliability=ReliabilityPolicy.RELIABLE,
                         durability=(DurabilityPolicy.TRANSIENT_LOCAL if latched
                                     else DurabilityPolicy.VOLATILE))
        self.publishers[topic] = self.node.create_publisher(message_type, topic, qos)
        return self.publishers[topic]

    def record(self, message_type: Any, topic: str) -> list[Any]:
        from rclpy.qos import QoSProfile
        messages = self.received.setdefault(topic, [])
        self.node.create_subscription(message_type, topic, messages.append,
                                      QoSProfile(depth=10000))
        return messages

    def spin_until(self, condition: Callable[[], bool], timeout: float) -> bool:
        deadline = time.monotonic() + timeout
        while not condition():
            if time.monotonic() > deadline or self.process.poll() is not None:
                return condition()
            self.executor.spin_once(timeout_sec=0.01)
        return True

    def connected(self) -> bool:
        return self.spin_until(lambda: all(
            p.get_subscription_count() > 0 for p in self.publishers.values()), 20.0)

    def diagnostics(self) -> dict[str, str]:
        statuses = [m for m in self.received.get('/diagnostics', [])
                    if m.status and m.status[0].name == '/attitude_propagator']
        return {p.key: p.value for p in statuses[-1].status[0].values} if statuses else {}

    def wait_received(self, count: int) -> dict[str, str]:
        self.spin_until(lambda: self.diagnostics().get('received') == str(count), 30.0)
        return self.diagnostics()

    def rss_mib(self) -> float:
        """The node process's resident memory [MiB] (Linux ``/proc``)."""
        try:
            status = Path(f'/proc/{self.process.pid}/status').read_text()
        except OSError:
            return math.nan
        kib = next(int(line.split()[1]) for line in status.splitlines()
                   if line.startswith('VmRSS:'))
        return kib / 1024.0

    def stop(self) -> tuple[int, str]:
        """SIGINT; the exit code and stderr."""
        alive = self.process.poll() is None
        if alive:
            self.process.send_signal(signal.SIGINT)
        try:
            _, stderr = self.process.communicate(timeout=15)
        except subprocess.TimeoutExpired:
            self.process.kill()
            _, stderr = self.process.communicate()
        self.executor.shutdown()
        self.node.destroy_node()
        import rclpy
        rclpy.shutdown(context=self.context)
        return (self.process.returncode if alive else -999), stderr


# -- the surfaces under attack ----------------------------------------------------------------

@dataclass
class AttackClass:
    """One class of hostile cases sent to one surface.

    ``reasons``: the rejection reasons the cases may be counted under (``a|b``); ``counted``:
    the rejections expected in all (default: one per payload).
    """

    name: str
    payloads: list[Any]
    reasons: str
    counted: int | None = None


@dataclass
class Surface:
    """One input of the running node, attacked class by class.

    Attributes:
        name: the prefix of its rows in the table.
        topic: where the cases are published.
        message_type: the rclpy message class of ``topic`` (a function: imported lazily).
        classes: ``classes(seed)``: the hostile classes.
        parameters: node parameters the surface needs (``name:=value``).
        imu_frame: the frame of the good gyro stream.
        latched: publish as ``/tf_static`` is published (transient local).
        before_last: called before the last good sample (e.g. publishes the mount).
        at_rest: the good stream is :data:`GOOD_AT_REST` samples of a body at rest tilted
            by :data:`TILT_RPY` (the node levels from them), not a constant rate.
    """

    name: str
    topic: str
    message_type: Callable[[], Any]
    classes: Callable[[int], Iterator[AttackClass]]
    parameters: tuple[str, ...] = ()
    imu_frame: str = 'base_link'
    latched: bool = False
    before_last: Callable[['RunningNode'], None] | None = None
    at_rest: bool = False


def attack(domain: int, surface: Surface, hostile: AttackClass) -> Result:
    """Good Imu samples at 1 kHz with one case after each; the node must end at the good
    stream's attitude, with every case counted under ``hostile.reasons``, short log lines
    and no traceback."""
    from diagnostic_msgs.msg import DiagnosticArray
    from geometry_msgs.msg import QuaternionStamped
    from sensor_msgs.msg import Imu
    name, attacks = f'{surface.name}: {hostile.name}', hostile.payloads
    expected = len(attacks) if hostile.counted is None else hostile.counted
    started = time.monotonic()
    running = RunningNode(domain, ['-p', 'scene:=strapdown', *deep_inputs('imu', surface.topic),
                                   *(a for p in surface.parameters for a in ('-p', p))])
    running.publisher(Imu, 'imu')
    running.publisher(surface.message_type(), surface.topic, surface.latched)
    orientations = running.record(QuaternionStamped, 'orientation')
    running.record(DiagnosticArray, '/diagnostics')
    if not running.connected():
        running.stop()
        return Result(name, len(attacks), hostile.reasons, 'node did not connect', 0.0, 0.0)
    rss_start = running.rss_mib()
    good = max(len(attacks) + 1, GOOD_AT_REST if surface.at_rest else 0)
    for k in range(good):
        if k == good - 1 and surface.before_last is not None:
            surface.before_last(running)
        running.publishers['imu'].publish(
            imu_at_rest(BASE_NS + k * MS) if surface.at_rest
            else imu(BASE_NS + k * MS, frame=surface.imu_frame))
        if k < len(attacks):
            running.publishers[surface.topic].publish(attacks[k])
        if k % 200 == 0 or surface.latched:  # /tf_static is read 100 deep (as tf2_ros)
            running.spin_until(lambda: False, 0.01)
    reasons = hostile.reasons.split('|')

    def counted() -> int:
        values = running.diagnostics()
        return sum(int(values.get(f'rejected {key}', 0)) for key in reasons)
    # Levelling: the rest window's samples are accepted, not integrated (no output).
    running.spin_until(lambda: counted() >= expected and (
        running.diagnostics().get('accepted') == str(good) if surface.at_rest
        else len(orientations) >= good), 60.0)
    running.spin_until(lambda: False, 1.5)  # a last diagnostics period
    rss_growth = running.rss_mib() - rss_start
    found = counted()
    code, stderr = running.stop()
    problems = []
    if code != 0 or 'Traceback' in stderr:
        problems.append(f'exit {code}')
        print(stderr[-4000:], file=sys.stderr)  # the crash's traces (faulthandler)
    longest = max((len(line) for line in stderr.splitlines()), default=0)
    if longest > 1000:
        problems.append(f'a log line of {longest} characters')
    if found != expected:
        problems.append(f'rejected {hostile.reasons} = {found}')
    attitudes = [(m.quaternion.w, m.quaternion.x, m.quaternion.y, m.quaternion.z)
                 for m in orientations]
    if not all(math.isfinite(v) for q in attitudes for v in q):
        problems.append('non-finite output')
    problems += _state_problems(attitudes, good, surface.at_rest)
    outcome = ('survived; all counted; outputs finite; '
               + ('levelled tilt within 0.05 deg' if surface.at_rest else 'state unchanged')
               if not problems else 'FAILED: ' + '; '.join(problems))
    return Result(name, len(attacks), hostile.reasons, outcome, time.monotonic() - started,
                  rss_growth)


def _state_problems(attitudes: list[tuple[float, ...]], good: int, at_rest: bool
                    ) -> list[str]:
    """What is wrong with the outputs of ``good`` samples: a constant rate's must end at
    exp(ω t); a body at rest's must be levelled to the true tilt (within 0.05 deg)."""
    if at_rest:
        if not attitudes:
            return ['not levelled (no output)']
        tilt = _tilt_deg(attitudes[-1])
        return [f'levelled {tilt:.3g} deg off in tilt'] if not tilt < 0.05 else []
    if len(attitudes) != good or _error(attitudes[-1], (good - 1) * 1e-3) > 1e-12:
        return [f'state changed ({len(attitudes)} outputs of {good})']
    return []


def _error(attitude: tuple[float, ...], seconds: float) -> float:
    """Distance from exp(ω t), the good constant-rate stream alone."""
    norm = math.sqrt(sum(w * w for w in OMEGA))
    half = 0.5 * norm * seconds
    expected = (math.cos(half), *(math.sin(half) * w / norm for w in OMEGA))
    return max(abs(a - b) for a, b in zip(attitude, expected))


#: The tilt of the body at rest (roll, pitch [rad]) and its samples: 0.6 s at 1 kHz, past
#: ``align_seconds`` 0.3 s of rest.
TILT_RPY = (0.3, -0.2)
GOOD_AT_REST = 600
GRAVITY = 9.80665


def _up_in_body(roll: float, pitch: float) -> tuple[float, float, float]:
    """The world's up (ENU z) in the body frame of a body at ``roll``, ``pitch``, no yaw
    (R = Rz Ry Rx: the third row of R)."""
    return (-math.sin(pitch), math.cos(pitch) * math.sin(roll),
            math.cos(pitch) * math.cos(roll))


def imu_at_rest(at_ns: int, accel: tuple[float, float, float] | None = None) -> Any:
    """An Imu of the body at rest tilted by TILT_RPY (zero rate, the specific force of
    gravity), or with the specific force ``accel``."""
    message = imu(at_ns, (0.0, 0.0, 0.0))
    f = message.linear_acceleration
    f.x, f.y, f.z = accel or tuple(GRAVITY * u for u in _up_in_body(*TILT_RPY))
    return message


def _tilt_deg(attitude: tuple[float, ...]) -> float:
    """Angle [deg] between the world's up seen in the body by ``attitude`` (w, x, y, z) and
    the true one (TILT_RPY)."""
    w, x, y, z = attitude
    seen = (2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y))
    true = _up_in_body(*TILT_RPY)
    dot = sum(a * b for a, b in zip(seen, true))
    cross = (seen[1] * true[2] - seen[2] * true[1], seen[2] * true[0] - seen[0] * true[2],
             seen[0] * true[1] - seen[1] * true[0])
    return math.degrees(math.atan2(math.sqrt(sum(c * c for c in cross)), dot))


def accel_classes(seed: int) -> Iterator[AttackClass]:
    """The accelerometer while the node levels: specific forces beyond any accelerometer
    (squares that overflow, or just above the limit of 1e4 m/s²), NaN and Inf."""
    absurd = [(1e200, 0.0, 0.0), (0.0, -1e155, 0.0), (0.0, 0.0, 1e154), (1e308, 1e308, 1e308),
              (-1e308, 0.0, 0.0), (0.0, 0.0, 1.5e4)]
    yield AttackClass('specific force finite but absurd, while levelling', [
        imu_at_rest(BASE_NS + k * MS + MS // 2, f) for k, f in enumerate(absurd)],
        'accel_out_of_range')
    non_finite = [(math.nan, 0.0, 9.8), (0.0, math.inf, 0.0), (0.0, 0.0, -math.inf)] * 4
    yield AttackClass('NaN and Inf specific force, while levelling', [
        imu_at_rest(BASE_NS + k * MS + MS // 2, f) for k, f in enumerate(non_finite)],
        'non_finite')


def imu_classes(seed: int) -> Iterator[AttackClass]:
    """The gyro input: malformed bytes, absurd and non-finite rates, bad stamps, samples in
    a frame other than the IMU's."""
    from rclpy.serialization import serialize_message
    # A length field that still fits may decode as another, well-formed frame_id: then the
    # message is judged as such (the first stamp again: stale; another frame: foreign).
    for name, payloads in malformed_cases(serialize_message(imu(BASE_NS)), seed).items():
        yield AttackClass(name, payloads, 'malformed|stale_stamp|foreign_frame')
    absurd = [(1e200, 0.0, 0.0), (1e308, 1e308, 1e308), (-1e308, 0.0, 0.0), (1e10, 0.0, 0.0),
              (0.0, 0.0, 1000.1), (600.0, 600.0, 600.0)]
    yield AttackClass('rates finite but absurd', [
        imu(BASE_NS + k * MS + MS // 2, rate) for k, rate in enumerate(absurd)], 'out_of_range')
    non_finite = [(math.nan, 0.0, 0.0), (0.0, math.inf, 0.0), (0.0, 0.0, -math.inf)] * 4
    yield AttackClass('NaN and Inf rates', [
        imu(BASE_NS + k * MS + MS // 2, rate) for k, rate in enumerate(non_finite)],
        'non_finite')
    nanosecs = [10**9, 10**9 + 1, 2**31, 2**32 - 1] * 3
    yield AttackClass('nanosec >= 1e9', [
        _bad_stamp(BASE_NS // 10**9 + k, nanosec) for k, nanosec in enumerate(nanosecs)],
        'invalid_stamp')
    yield AttackClass('lone stamps far off the time line', [
        imu(at) for at in [(2**31 - 1) * 10**9, 10**9, BASE_NS + 10**12, BASE_NS - 10**12,
                           BASE_NS + 500 * MS] * 2], 'outlier_stamp')
    frames = ['other_imu', '', 'imu_link', '\x1b[2J\x07', 'x' * 2**20, 'base_link ']
    yield AttackClass('samples in another frame (1 MiB and escape sequences included)', [
        imu(BASE_NS + k * MS + MS // 2, frame=frame) for k, frame in enumerate(frames)],
        'foreign_frame')


def set_pose_classes(seed: int) -> Iterator[AttackClass]:
    """``set_pose``: malformed bytes, wrong frames, a zero quaternion."""
    from geometry_msgs.msg import PoseStamped
    from rclpy.serialization import serialize_message
    # Decodable set_pose messages queued behind a newer one are counted superseded.
    for name, payloads in malformed_cases(serialize_message(PoseStamped()), seed + 1).items():
        yield AttackClass(name, payloads, 'malformed|wrong_frame|superseded')
    poses = []
    for frame, w in (('map', 1.0), ('', 1.0), ('world', 0.0), ('x' * 2**20, 1.0)):
        pose = PoseStamped()
        pose.header.frame_id, pose.pose.orientation.w = frame, w
        poses.append(pose)
    yield AttackClass('wrong frame (1 MiB included) or zero quaternion', poses,
                      'wrong_frame|invalid_pose|superseded')


def set_pose_with_covariance_classes(seed: int) -> Iterator[AttackClass]:
    """``set_pose_with_covariance``: orientation blocks that are huge, unphysical or not
    positive semi-definite (the attitude is never changed by them)."""
    yield AttackClass('orientation blocks huge, unphysical or not PSD',
                      [_covariance_pose(block) for block in _hostile_orientation_blocks()],
                      'invalid_covariance|superseded')


def _hostile_orientation_blocks() -> list[list[float]]:
    """Row-major 3×3 orientation blocks: finite but huge (symmetrising or an
    eigen-decomposition would overflow), above pi^2 rad^2, asymmetric, not PSD, NaN."""
    big, largest = 1e308, 1.7976931348623157e308
    return [[big, 0, 0, 0, big, 0, 0, 0, big], [big] * 9, [largest, 0, 0, 0, 1, 0, 0, 0, 1],
            [big, -big, 0, -big, big, 0, 0, 0, 1], [1e-4, 0, 0, 0, 1e-4, 0, 0, 0, 1e300],
            [1e-4, 0, 0, 0, 1e-4, 0, 0, 0, 10.0], [1, big, 0, -big, 1, 0, 0, 0, 1],
            [1, 0.5, 0, 0, 1, 0, 0, 0, 1], [1, 0, 0, 0, -1, 0, 0, 0, 1],
            [math.nan, 0, 0, 0, 1, 0, 0, 0, 1], [1, 0, 0, 0, math.inf, 0, 0, 0, 1]]


def _covariance_pose(block: list[float]) -> Any:
    from geometry_msgs.msg import PoseWithCovarianceStamped
    message = PoseWithCovarianceStamped()
    message.header.frame_id, message.pose.pose.orientation.x = 'world', 1.0
    covariance = [0.0] * 36
    for row in range(3):
        covariance[7 * row] = 1.0
        covariance[21 + 6 * row:24 + 6 * row] = [float(v) for v in block[3 * row:3 * row + 3]]
    message.pose.covariance = covariance
    return message


def tf_message(*transforms: tuple[str, str, tuple[float, ...], tuple[float, ...]]) -> Any:
    """A TFMessage of (parent, child, rotation (w, x, y, z), translation)."""
    from geometry_msgs.msg import TransformStamped
    from tf2_msgs.msg import TFMessage
    message = TFMessage()
    for parent, child, (w, x, y, z), (tx, ty, tz) in transforms:
        t = TransformStamped()
        t.header.frame_id, t.child_frame_id = parent, child
        r, v = t.transform.rotation, t.transform.translation
        r.w, r.x, r.y, r.z, v.x, v.y, v.z = w, x, y, z, tx, ty, tz
        message.transforms.append(t)
    return message


def tf_static_classes(seed: int) -> Iterator[AttackClass]:
    """``/tf_static`` while the IMU's mount is awaited: invalid transforms, malformed bytes,
    a flood of irrelevant transforms; the mount arrives last."""
    from rclpy.serialization import serialize_message
    unit, zero = (1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    rotations = [(0.0, 0.0, 0.0, 0.0), (1e-8, 0.0, 0.0, 0.0), (0.9, 0.0, 0.0, 0.0),
                 (1e300, 1e300, 0.0, 0.0), (math.nan, 0.0, 0.0, 1.0), (math.inf, 0.0, 0.0, 0.0)]
    cases = [tf_message(('base_link', 'imu_link', q, zero)) for q in rotations]
    cases += [tf_message(('base_link', 'imu_link', unit, v))
              for v in ((math.inf, 0.0, 0.0), (0.0, math.nan, 0.0))]
    cases += [tf_message((parent, child, unit, zero)) for parent, child in (
        ('', 'imu_link'), ('imu_link', 'imu_link'), ('base_link', 'x' * 2**20))]
    yield AttackClass('zero, near-zero, non-unit, NaN, Inf rotations; Inf translations; '
                      'empty, equal, 1 MiB frames', cases,
                      'tf_denormalized|tf_non_finite|tf_bad_frames')
    good = serialize_message(tf_message(('base_link', 'torso', unit, zero)))
    cases_by_class = malformed_cases(good, seed + 2)
    # The transport pads a payload to a multiple of 4 bytes with zeros: a message cut inside
    # its last number can arrive as a whole one with a zeroed w, refused as denormalized.
    for name in ('truncated at every length', 'random bytes'):
        yield AttackClass(name, cases_by_class[name], 'malformed|tf_denormalized')
    flood = [tf_message(*((f'junk_{m}_{k}', f'leaf_{m}_{k}', unit, zero)
                          for k in range(10_000))) for m in range(3)]
    # The mount, sent last, makes room too: 20 001 dropped.
    yield AttackClass('3 messages of 10 000 irrelevant transforms', flood, 'tf_evicted',
                      counted=20_001)


def field_message(at_ns: int, field: tuple[float, float, float], frame: str = 'base_link',
                  sec_nanosec: tuple[int, int] | None = None) -> Any:
    """A MagneticField [T] stamped ``at_ns`` (or the raw ``sec_nanosec``)."""
    from sensor_msgs.msg import MagneticField
    message = MagneticField()
    message.header.stamp, message.header.frame_id = stamp(at_ns), frame
    if sec_nanosec is not None:
        message.header.stamp.sec, message.header.stamp.nanosec = sec_nanosec
    f = message.magnetic_field
    f.x, f.y, f.z = field
    return message


def magnetometer_classes(seed: int) -> Iterator[AttackClass]:
    """``imu/mag`` of the attitude filter: malformed bytes, absurd and non-finite fields,
    frames without a mount, zero and invalid stamps."""
    from rclpy.serialization import serialize_message
    earth = (2e-5, 0.0, -4e-5)
    # In a frame without a mount: a variant that still decodes (the transport pads a cut
    # payload with zeros) is refused as such, never taken.
    good = serialize_message(field_message(BASE_NS, earth, 'elsewhere'))
    for name, payloads in malformed_cases(good, seed + 3).items():
        yield AttackClass(name, payloads, 'malformed|magnetometer_no_mount|'
                          'magnetometer_invalid_stamp|magnetometer_stale_stamp|'
                          'magnetometer_out_of_range|magnetometer_non_finite')
    fields = [(math.nan, 0.0, 0.0), (0.0, math.inf, 0.0), (0.0, 0.0, 0.0), (1.0, 0.0, 0.0),
              (1e308, 1e308, 1e308), (0.0, -1e200, 0.0)] * 2
    yield AttackClass('fields NaN, Inf, zero or beyond any magnetometer', [
        field_message(BASE_NS + k * MS + MS // 2, f) for k, f in enumerate(fields)],
        'magnetometer_non_finite|magnetometer_out_of_range')
    frames = ['elsewhere', '', '\x1b[2J\x07', 'x' * 2**20, 'imu_link', 'base_link ']
    frames = [frame for frame in frames if frame != '']  # '' is the body's: a good field
    yield AttackClass('fields in a frame without a mount (1 MiB and escapes included)', [
        field_message(BASE_NS + k * MS + MS // 2, earth, frame)
        for k, frame in enumerate(frames)], 'magnetometer_no_mount')
    yield AttackClass('zero and invalid stamps', [
        field_message(BASE_NS, earth, sec_nanosec=pair) for pair in
        [(0, 0), (BASE_NS // 10**9, 10**9), (BASE_NS // 10**9, 2**32 - 1), (-5, 0)] * 3],
        'magnetometer_invalid_stamp')


def measurement_message(at_ns: int, q: tuple[float, ...], frame: str = 'world',
                        block: list[float] | None = None) -> Any:
    """An attitude measurement (PoseWithCovarianceStamped) with its orientation block."""
    message = _covariance_pose(block or [1e-4, 0, 0, 0, 1e-4, 0, 0, 0, 1e-4])
    message.header.stamp, message.header.frame_id = stamp(at_ns), frame
    o = message.pose.pose.orientation
    o.w, o.x, o.y, o.z = q
    return message


def measurement_classes(seed: int) -> Iterator[AttackClass]:
    """``attitude_measurement``: malformed bytes, wrong frames, zero or NaN quaternions,
    hostile covariance blocks, stamps far from the gyro's."""
    from rclpy.serialization import serialize_message
    unit = (1.0, 0.0, 0.0, 0.0)
    good = serialize_message(measurement_message(BASE_NS, unit, 'map'))  # decodable: refused
    reasons = 'attitude_measurement_wrong_frame|attitude_measurement_stale_measurement'
    for name, payloads in malformed_cases(good, seed + 4).items():
        yield AttackClass(name, payloads, f'malformed|{reasons}|'
                          'attitude_measurement_invalid_covariance|'
                          'attitude_measurement_invalid_pose|attitude_measurement_non_finite')
    at = BASE_NS + MS // 2
    yield AttackClass('another frame (1 MiB included), zero or NaN quaternion', [
        measurement_message(at, unit, frame) for frame in ('map', '', 'x' * 2**20)] + [
        measurement_message(at, (0.0, 0.0, 0.0, 0.0)),
        measurement_message(at, (math.nan, 0.0, 0.0, 1.0))],
        'attitude_measurement_wrong_frame|attitude_measurement_invalid_pose|'
        'attitude_measurement_non_finite')
    yield AttackClass('orientation blocks huge, unphysical or not PSD', [
        measurement_message(at, unit, block=block) for block in _hostile_orientation_blocks()],
        'attitude_measurement_invalid_covariance')
    yield AttackClass('stamps far from the gyro\'s', [
        measurement_message(at + sign * 10**10, unit) for sign in (1, -1) * 3],
        'attitude_measurement_stale_measurement')


def _field_type() -> Any:
    from sensor_msgs.msg import MagneticField
    return MagneticField


def send_mount(running: 'RunningNode') -> None:
    """The IMU's mount ``base_link`` -> ``imu_link`` (identity), then a moment to read it."""
    running.publishers['/tf_static'].publish(tf_message(
        ('base_link', 'imu_link', (1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0))))
    running.spin_until(lambda: False, 0.5)


def _imu_type() -> Any:
    from sensor_msgs.msg import Imu
    return Imu


def _pose_type() -> Any:
    from geometry_msgs.msg import PoseStamped
    return PoseStamped


def _pose_covariance_type() -> Any:
    from geometry_msgs.msg import PoseWithCovarianceStamped
    return PoseWithCovarianceStamped


def _tf_type() -> Any:
    from tf2_msgs.msg import TFMessage
    return TFMessage


#: Every surface of the running node under attack: add one entry (and its classes) to attack
#: a new input the same way.
SURFACES = [
    Surface('imu', 'imu', _imu_type, imu_classes),
    Surface('set_pose', 'set_pose', _pose_type, set_pose_classes),
    Surface('set_pose_with_covariance', 'set_pose_with_covariance', _pose_covariance_type,
            set_pose_with_covariance_classes),
    Surface('/tf_static', '/tf_static', _tf_type, tf_static_classes,
            parameters=('tf_timeout:=60.0',), imu_frame='imu_link', latched=True,
            before_last=send_mount),
    Surface('imu accelerometer', 'imu', _imu_type, accel_classes,
            parameters=('align_seconds:=0.3',), at_rest=True),
    Surface('imu/mag', 'imu/mag', _field_type, magnetometer_classes,
            parameters=('scene:=imu_filter',)),
    Surface('attitude_measurement', 'attitude_measurement', _pose_covariance_type,
            measurement_classes, parameters=('scene:=imu_filter',)),
]


# -- dynamics scenes: the command surfaces of a spacecraft in lockstep ------------------------

#: The plant of the command attacks: four wheels on ``wheels/command``, rods on ``dipole``.
COMMAND_SCENE = 'wheel_slew_commanded'
WHEELS = ('wheel_a', 'wheel_b', 'wheel_c', 'wheel_d')
TICK_NS = 50 * MS  # 20 Hz
GOOD_EFFORTS = (0.001, -0.002, 0.0015, 0.0)  # N m
GOOD_DIPOLE = (0.5, -0.3, 0.2)  # A m²
#: Wall seconds the node waits for a tick's command before it advances (a tick whose
#: attacked command is only the hostile case): long enough for the other topic's good
#: command to arrive on a loaded machine.
LOCKSTEP_TIMEOUT = 0.5


def joint_state(stamp_ns: int, names: Any = WHEELS, position: Any = (), velocity: Any = (),
                effort: Any = ()) -> Any:
    from sensor_msgs.msg import JointState
    message = JointState()
    message.header.stamp = stamp(stamp_ns)
    message.name = list(names)
    message.position, message.velocity, message.effort = (
        [float(v) for v in position], [float(v) for v in velocity],
        [float(v) for v in effort])
    return message


def dipole(stamp_ns: int, vector: tuple[float, float, float] = GOOD_DIPOLE) -> Any:
    from geometry_msgs.msg import Vector3Stamped
    message = Vector3Stamped()
    message.header.stamp, message.header.frame_id = stamp(stamp_ns), 'base_link'
    message.vector.x, message.vector.y, message.vector.z = vector
    return message


def good_command(topic: str, stamp_ns: int) -> Any:
    """The good command of ``topic`` answering the tick ``stamp_ns``."""
    if topic == 'wheels/command':
        return joint_state(stamp_ns, effort=GOOD_EFFORTS)
    return dipole(stamp_ns)


@dataclass
class CommandClass:
    """One class of hostile commands. ``cases[j](k)``: the ``j``-th case, sent at tick
    ``k = j + 1`` (stamped with it where a stamp applies; tick 0, which the node waits for
    without a timeout, gets the good commands only). ``alone``: each case is the attacked
    topic's only message of its tick (the node then advances after ``lockstep_timeout``,
    holding the last command), so a decodable case is judged by its own reason; otherwise
    each case goes just after the tick's good command, so whatever it decodes to is a second
    answer to the tick (or an answer to a tick already past): ``stale_stamp``."""

    name: str
    cases: list[Callable[[int], Any]]
    reasons: str
    alone: bool = False


@dataclass
class CommandSurface:
    """A command topic of a dynamics scene in lockstep, attacked class by class while the
    study answers each tick as a controller would (:func:`attack_commands`)."""

    name: str
    topic: str
    message_type: Callable[[], Any]
    classes: Callable[[int], Iterator[CommandClass]]


#: What a decodable mutation of a good command may be refused as, by topic.
DECODED_REASONS = {
    'wheels/command': 'stale_stamp|future_stamp|invalid_stamp|unknown_wheel|missing_wheel|'
                      'wheel_fields|wheel_lengths|non_finite|out_of_range',
    'dipole': 'stale_stamp|future_stamp|invalid_stamp|non_finite|out_of_range'}


def _malformed_command_classes(topic: str, seed: int) -> Iterator[CommandClass]:
    from rclpy.serialization import serialize_message
    good = serialize_message(good_command(topic, 0))
    for name, payloads in malformed_cases(good, seed).items():
        # A length field that still fits may decode as a command of its own: judged as such.
        yield CommandClass(name, [(lambda k, data=data: data) for data in payloads],
                           'malformed|' + DECODED_REASONS[topic])


def _stamp_classes(topic: str) -> Iterator[CommandClass]:
    def at(stamp_ns: Callable[[int], int], sec_nanosec: tuple[int, int] | None = None
           ) -> Callable[[int], Any]:
        def case(k: int) -> Any:
            message = good_command(topic, stamp_ns(k))
            if sec_nanosec is not None:
                message.header.stamp.sec, message.header.stamp.nanosec = sec_nanosec
            return message
        return case
    yield CommandClass('stamps: nanosec >= 1e9, negative sec', [
        at(lambda k: 0, (k, nanosec)) for k, nanosec in enumerate([10**9, 2**32 - 1] * 3)
    ] + [at(lambda k: 0, (-1, 0)), at(lambda k: 0, (-(2**31), 5))], 'invalid_stamp',
        alone=True)
    off_the_tick = [
        at(lambda k: BASE_NS), at(lambda k: (2**31 - 1) * 10**9),
        at(lambda k: k * TICK_NS + 1), at(lambda k: (k + 1) * TICK_NS),
        at(lambda k: k * TICK_NS - 1), at(lambda k: 1)]
    yield CommandClass('stamps off the tick: wall time, 2^31 - 1 s, 1 ns either side, the next '
                       'tick, 1 ns', off_the_tick * 2, 'future_stamp|stale_stamp', alone=True)


def wheel_command_classes(seed: int) -> Iterator[CommandClass]:
    """``wheels/command``: malformed bytes, JointStates the array refuses, bad stamps."""
    yield from _malformed_command_classes('wheels/command', seed + 3)
    refused = [
        (WHEELS[:3] + ('wheel_x',), (), (), (0.01,) * 4, 'unknown_wheel'),
        (WHEELS[:2] * 2, (), (), (0.01,) * 4, 'unknown_wheel'),
        (('x' * 200,) * 1000, (), (), (0.01,) * 1000, 'unknown_wheel'),
        (('\x1b[2J\x07',) + WHEELS[1:], (), (), (0.01,) * 4, 'unknown_wheel'),
        (WHEELS[:3], (), (), (0.01,) * 3, 'missing_wheel'),
        ((), (), (), (), 'missing_wheel'),
        (WHEELS, (), (1.0,) * 4, (0.01,) * 4, 'wheel_fields'),
        (WHEELS, (), (), (), 'wheel_fields'),
        (WHEELS, (0.0,) * 4, (), (0.01,) * 4, 'wheel_fields'),
        (WHEELS, (), (), (0.01,) * 3, 'wheel_lengths'),
        (WHEELS, (), (1.0,) * 1000, (), 'wheel_lengths'),
        (WHEELS, (), (), (math.nan, 0.0, 0.0, 0.0), 'non_finite'),
        (WHEELS, (), (math.inf, 0.0, 0.0, 0.0), (), 'non_finite'),
        (WHEELS, (), (), (1e13, 0.0, 0.0, 0.0), 'out_of_range'),
        (WHEELS, (), (-1e300,) * 4, (), 'out_of_range')]
    yield CommandClass(
        'unknown (1 000 and escape sequences included), repeated, missing names; both fields, '
        'neither, positions; wrong lengths; NaN, Inf, 1e13, 1e300', [
            (lambda k, c=case: joint_state(k * TICK_NS, *c[:4])) for case in refused],
        'unknown_wheel|missing_wheel|wheel_fields|wheel_lengths|non_finite|out_of_range',
        alone=True)
    yield from _stamp_classes('wheels/command')


def dipole_command_classes(seed: int) -> Iterator[CommandClass]:
    """``dipole``: malformed bytes, non-finite and absurd dipoles, bad stamps."""
    yield from _malformed_command_classes('dipole', seed + 4)
    vectors = [(math.nan, 0.0, 0.0), (0.0, math.inf, 0.0), (0.0, 0.0, -math.inf),
               (1e13, 0.0, 0.0), (-1e308, 1e308, 1e308), (0.0, 1e200, 0.0)]
    yield CommandClass('NaN, Inf, 1e13 and 1e308 dipoles', [
        (lambda k, v=v: dipole(k * TICK_NS, v)) for v in vectors * 2],
        'non_finite|out_of_range', alone=True)
    yield from _stamp_classes('dipole')


def _joint_state_type() -> Any:
    from sensor_msgs.msg import JointState
    return JointState


def _vector3_type() -> Any:
    from geometry_msgs.msg import Vector3Stamped
    return Vector3Stamped


#: The command surfaces of a dynamics scene (lockstep): add one entry to attack another.
COMMAND_SURFACES = [
    CommandSurface('wheels/command', 'wheels/command', _joint_state_type,
                   wheel_command_classes),
    CommandSurface('dipole', 'dipole', _vector3_type, dipole_command_classes),
]


def attack_commands(domain: int, surface: CommandSurface, hostile: CommandClass) -> Result:
    """The node in lockstep on :data:`COMMAND_SCENE`, the study its controller: tick
    ``j + 1`` gets the hostile case ``j`` and the good commands (:class:`CommandClass` says
    which); the node must count every case under ``hostile.reasons`` and end with the
    attitude and wheel speeds, bit for bit, of the session fed the good commands alone."""
    from geometry_msgs.msg import QuaternionStamped
    from diagnostic_msgs.msg import DiagnosticArray
    from sensor_msgs.msg import JointState
    name, cases = f'{surface.name}: {hostile.name}', hostile.cases
    started = time.monotonic()
    topics = [s.topic for s in COMMAND_SURFACES]
    running = RunningNode(domain, [
        '-p', f'scene:={COMMAND_SCENE}', '-p', 'lockstep:=true', '-p', 'publish_rate:=20.0',
        '-p', 'real_time_factor:=0.0', '-p', f'lockstep_timeout:={LOCKSTEP_TIMEOUT}',
        *deep_inputs(*topics)])
    for other in COMMAND_SURFACES:
        running.publisher(other.message_type(), other.topic)
    orientations = running.record(QuaternionStamped, 'orientation')
    wheel_states = running.record(JointState, 'wheels/state')
    running.record(DiagnosticArray, '/diagnostics')
    if not running.connected():
        running.stop()
        return Result(name, len(cases), hostile.reasons, 'node did not connect', 0.0, 0.0)
    rss_start = running.rss_mib()
    ticks, sent = len(cases) + 1, []  # sent: (tick, topic) of each good command
    for k in range(ticks):
        if not running.spin_until(lambda: _ticked(orientations, wheel_states, k), 30.0):
            break
        attacked = 1 <= k <= len(cases)
        for topic in topics:
            if topic != surface.topic or not attacked or not hostile.alone:
                running.publishers[topic].publish(good_command(topic, k * TICK_NS))
                sent.append((k, topic))
        if attacked:
            running.publishers[surface.topic].publish(cases[k - 1](k))
    running.spin_until(lambda: _ticked(orientations, wheel_states, ticks), 30.0)
    reasons = hostile.reasons.split('|')

    def counted() -> int:
        values = running.diagnostics()
        return sum(int(values.get(f'rejected {key}', 0)) for key in reasons)
    running.spin_until(lambda: counted() >= len(cases), 10.0)
    running.spin_until(lambda: False, 1.5)  # a last diagnostics period
    rss_growth, found = running.rss_mib() - rss_start, counted()
    code, stderr = running.stop()
    problems = _command_problems(code, stderr, found, len(cases), hostile.reasons)
    problems += _command_state_problems(orientations, wheel_states, ticks, sent)
    outcome = ('survived; all counted; attitude and wheels bit for bit as with the good '
               'commands alone' if not problems else 'FAILED: ' + '; '.join(problems))
    return Result(name, len(cases), hostile.reasons, outcome, time.monotonic() - started,
                  rss_growth)


def _ticked(orientations: list[Any], wheel_states: list[Any], k: int) -> bool:
    """Whether the node's outputs of tick ``k`` arrived."""
    at = k * TICK_NS
    return (any(_stamp_ns(m) == at for m in orientations[-3:])
            and any(_stamp_ns(m) == at for m in wheel_states[-3:]))


def _stamp_ns(message: Any) -> int:
    return message.header.stamp.sec * 10**9 + message.header.stamp.nanosec


def _command_problems(code: int, stderr: str, found: int, expected: int, reasons: str
                      ) -> list[str]:
    problems = []
    if code != 0 or 'Traceback' in stderr:
        problems.append(f'exit {code}')
        print(stderr[-4000:], file=sys.stderr)
    longest = max((len(line) for line in stderr.splitlines()), default=0)
    if longest > 1000:
        problems.append(f'a log line of {longest} characters')
    if found != expected:
        problems.append(f'rejected {reasons} = {found} of {expected}')
    return problems


def _command_state_problems(orientations: list[Any], wheel_states: list[Any], ticks: int,
                            sent: list[tuple[int, str]]) -> list[str]:
    """The node's last tick against the session fed only the good commands ``sent``."""
    attitude, speeds = reference_state(ticks, sent)
    last = [m for m in orientations if _stamp_ns(m) == ticks * TICK_NS]
    wheels = [m for m in wheel_states if _stamp_ns(m) == ticks * TICK_NS]
    if not last or not wheels:
        return [f'the node did not reach tick {ticks}']
    q = last[-1].quaternion
    values = [q.w, q.x, q.y, q.z, *wheels[-1].velocity]
    if not all(math.isfinite(v) for v in values):
        return ['non-finite output']
    if (q.w, q.x, q.y, q.z) != attitude or tuple(wheels[-1].velocity) != speeds:
        return ['state changed']
    return []


def reference_state(ticks: int, sent: list[tuple[int, str]]
                    ) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """The attitude (w, x, y, z) and wheel speeds at tick ``ticks`` of the node's own session
    in lockstep, fed the good commands ``sent`` ((tick, topic) each) and nothing else."""
    from rigid_body_attitude.msgs.joint_state import decode_joint_state
    from rigid_body_attitude.session.parameters import defaults
    from rigid_body_attitude.session.settings import load_node_scene, open_session

    class Sink:
        use_header_stamps = True
        attitude: tuple[float, ...] = ()
        speeds: tuple[float, ...] = ()

        def dynamics(self, sec: int, nanosec: int, sample: Any, velocity: Any) -> None:
            self.attitude = tuple(sample.attitude)

        def wheel_state(self, data: bytes) -> None:
            self.speeds = tuple(decode_joint_state(data).velocity)

        def __getattr__(self, name: str) -> Callable[..., Any]:
            return lambda *args: True  # every other output: wanted, and dropped
    sink = Sink()
    values = defaults() | {'scene': COMMAND_SCENE, 'lockstep': True, 'publish_rate': 20.0,
                           'real_time_factor': 0.0}
    session = open_session(load_node_scene(COMMAND_SCENE), values, sink, lambda: 0,
                           lambda: 0.0)
    by_tick: dict[int, list[str]] = {}
    for k, topic in sent:
        by_tick.setdefault(k, []).append(topic)
    for k in range(ticks + 1):
        session.lockstep_tick(k * TICK_NS)
        for topic in by_tick.get(k, []):
            sec, nanosec = divmod(k * TICK_NS, 10**9)
            if topic == 'wheels/command':
                session.wheel_command(sec, nanosec, WHEELS, (), (), GOOD_EFFORTS)
            else:
                session.dipole(sec, nanosec, GOOD_DIPOLE)
    return sink.attitude, sink.speeds


def _bad_stamp(sec: int, nanosec: int) -> Any:
    """An Imu whose stamp is not a normalised time (the message type allows any uint32)."""
    message = imu(BASE_NS)
    message.header.stamp.sec, message.header.stamp.nanosec = sec, nanosec
    return message


# -- start-time attacks -----------------------------------------------------------------------

def scene_files(folder: Path) -> dict[str, Path]:
    """Hostile scene files."""
    files = {
        'not UTF-8': b'name: \xff\xfe\nrate_source: dynamics\n',
        '400-digit mass': ('body: {mass: ' + '9' * 400 + ', inertia: {moments: [1, 2, 3]}}\n'
                           ).encode(),
        '400-digit moment': ('body: {inertia: {moments: [' + '9' * 400 + ', 2, 3]}}\n').encode(),
        'nested 500 levels': ('a: ' + '[' * 500 + ']' * 500 + '\n').encode(),
        'omega_body 1e308': b'body: {inertia: {moments: [1, 2, 3]}}\n'
                            b'initial_state: {omega_body: [1e308, 1e308, 1e308]}\n',
        'moments 1e308': b'body: {inertia: {moments: [1e308, 1e308, 1e308]}}\n'
                         b'initial_state: {omega_body: [1, 1, 1]}\n',
        'attitude 1e308': b'body: {inertia: {moments: [1, 2, 3]}}\n'
                          b'initial_state: {attitude: [1e308, 1e308, 1e308, 1e308]}\n',
        'alias bomb (name)': _alias_bomb(b'name'),
        'alias bomb (error text)': _alias_bomb(b'rate_source'),
        'YAML syntax error': b'body: {inertia: [1, 2\n',
        '20 MB file': b'# ' + b'x' * (20 * 2**20) + b'\n',
        'estimation section not a mapping': b'rate_source: gyro\n'
                                            b'body: {inertia: {moments: [1, 2, 3]}}\n'
                                            b'estimation: [gravity]\n',
        'estimation on a dynamics scene': b'rate_source: dynamics\n'
                                          b'body: {inertia: {moments: [1, 2, 3]}}\n'
                                          b'estimation: {magnetometer: true}\n',
        'estimation settings NaN, negative, unknown': (
            b'rate_source: gyro\nbody: {inertia: {moments: [1, 2, 3]}}\n'
            b'estimation: {settings: {gravity_gate: .nan, update_interval: -1, wind: 3}}\n'),
        **spacecraft_scene_files(),
    }
    paths = {}
    for name, content in files.items():
        path = folder / (name.replace(' ', '_').replace('(', '').replace(')', '') + '.yaml')
        path.write_bytes(content)
        paths[name] = path
    return paths


#: A dynamics scene the ``sensors`` cases complete (YAML flow mappings, one line each).
_SENSED_SCENE = 'rate_source: dynamics\nstep: 0.001\nbody: {inertia: {moments: [1, 2, 3]}}\n'
_MAGNETOMETER = 'rate: 100.0, noise_density: 1.0e-8, intensity: 5.0e-5'


def _magnetometer(extra: str) -> str:
    return f'sensors: {{magnetometer: {{{_MAGNETOMETER}, {extra}}}}}\n'


def _star_tracker(extra: str) -> str:
    return f'sensors: {{star_tracker: {{rate: 10.0, {extra}}}}}\n'


#: The ``sensors`` (and ``sun``) sections of a scene, hostile: one key each.
SENSOR_SECTIONS = {
    'magnetometer rate 1e308': _magnetometer('rate: 1.0e+308'),
    'magnetometer noise density NaN': _magnetometer('noise_density: .nan'),
    'magnetometer without a field': 'sensors: {magnetometer: {rate: 100.0, '
                                    'noise_density: 1.0e-8}}\n',
    'magnetometer soft iron singular': _magnetometer('soft_iron: [[1, 0, 0], [0, 1, 0], '
                                                     '[0, 0, 0]]'),
    'magnetometer soft iron mirrored': _magnetometer('soft_iron: [[-1, 0, 0], [0, 1, 0], '
                                                     '[0, 0, 1]]'),
    'magnetometer hard iron 1e308': _magnetometer('hard_iron: [1.0e+308, 0, 0]'),
    "magnetometer on the node's own topic": _magnetometer('topic: pose'),
    'magnetometer topic of 5000 characters': _magnetometer('topic: ' + 'x' * 5000),
    'magnetometer frame with escape sequences': _magnetometer('frame_id: "\\e[2J\\a"'),
    'magnetometer unknown key': _magnetometer('noise: 1.0'),
    'magnetometer seed 2^63': _magnetometer('seed: 9223372036854775808'),
    'star tracker rate 1e4': _star_tracker('rate: 1.0e+4'),
    'star tracker period off the step': _star_tracker('rate: 300.0'),
    'star tracker zero boresight': _star_tracker('boresight: [0, 0, 0]'),
    'star tracker boresight and mount': _star_tracker('boresight: [1, 0, 0], '
                                                      'mount_rpy: [0, 0, 1]'),
    'star tracker zero noise': _star_tracker('cross_boresight_noise: 0.0'),
    'star tracker Sun exclusion without a Sun': _star_tracker('sun_exclusion_angle: 0.5'),
    'star tracker section a list': 'sensors: {star_tracker: [1, 2, 3]}\n',
    'two sensors on one topic': f'sensors: {{magnetometer: {{{_MAGNETOMETER}, topic: att}}, '
                                f'star_tracker: {{rate: 10.0, topic: att}}}}\n',
    'one frame, two mounts': f'sensors: {{magnetometer: {{{_MAGNETOMETER}, frame_id: f}}, '
                             f'star_tracker: {{rate: 10.0, frame_id: f, '
                             f'boresight: [1, 0, 0]}}}}\n',
    'zero Sun direction': (_star_tracker('sun_exclusion_angle: 0.5')
                           + 'sun: {direction: [0, 0, 0]}\n'),
}


def sensor_scene_files(folder: Path) -> dict[str, Path]:
    """Dynamics scenes with a hostile ``sensors`` section each (and a gyro scene with
    sensors)."""
    files = {name: _SENSED_SCENE + section for name, section in SENSOR_SECTIONS.items()}
    files['sensors in a gyro scene'] = ('rate_source: gyro\nbody: {inertia: {moments: [1, 2, '
                                        '3]}}\n' + _magnetometer('seed: 1'))
    paths = {}
    for index, (name, content) in enumerate(files.items()):
        path = folder / f'sensors_{index}.yaml'
        path.write_text(content)
        paths[name] = path
    return paths


_SPACECRAFT = (b'rate_source: dynamics\nbody: {inertia: {moments: [8, 10, 6]}}\n'
               b'orbit: {altitude: 500000.0, inclination_deg: 97.4}\n')


def spacecraft_scene_files() -> dict[str, bytes]:
    """Hostile reaction_wheels, magnetorquers, residual_dipole, bdot, orbit and
    magnetic_field sections of a spacecraft scene."""
    field = b'magnetic_field: {model: tilted_dipole}\n'
    wheels = b'{axes: [[1, 0, 0]], spin_inertia: 0.01, max_torque: 0.02, max_speed: 600'
    return {
        'reaction_wheels 17 wheels': _SPACECRAFT + b'effects: [reaction_wheels: {axes: ['
        + b', '.join([b'[1, 0, 0]'] * 17) + b'], spin_inertia: 1, max_torque: 1, '
        b'max_speed: 1}]\n',
        'reaction_wheels zero axis': _SPACECRAFT + b'effects: [reaction_wheels: {axes: '
        b'[[0, 0, 0]], spin_inertia: 0.01, max_torque: 0.02, max_speed: 600}]\n',
        'reaction_wheels spin inertia 1e308': _SPACECRAFT + b'effects: [reaction_wheels: '
        b'{axes: [[1, 0, 0]], spin_inertia: 1e308, max_torque: 0.02, max_speed: 600}]\n',
        'reaction_wheels names twice': _SPACECRAFT + b'effects: [reaction_wheels: {axes: '
        b'[[1, 0, 0], [0, 1, 0]], spin_inertia: 0.01, max_torque: 0.02, max_speed: 600, '
        b'names: [a, a]}]\n',
        'reaction_wheels speed gain too high for the step': _SPACECRAFT + b'step: 0.1\n'
        b'effects: [reaction_wheels: ' + wheels + b', speed_gain: 100}]\n',
        'reaction_wheels commanded "yes"': _SPACECRAFT + b'effects: [reaction_wheels: '
        + wheels + b', commanded: "yes"}]\n',
        'magnetorquers without a field': _SPACECRAFT + b'effects: [magnetorquers: '
        b'{max_dipole: 1}]\n',
        'magnetorquers max_dipole -1': _SPACECRAFT + field + b'effects: [magnetorquers: '
        b'{max_dipole: -1}]\n',
        'magnetorquers dumping without wheels': _SPACECRAFT + field + b'effects: '
        b'[magnetorquers: {max_dipole: 1, dumping_gain: 0.001}]\n',
        'residual_dipole NaN': _SPACECRAFT + field + b'effects: [residual_dipole: '
        b'{dipole: [.nan, 0, 0]}]\n',
        'bdot without magnetorquers': _SPACECRAFT + field + b'effects: [bdot: '
        b'{gain: 1, control_period: 1.0}]\n',
        'bdot period not a whole number of steps': _SPACECRAFT + field + b'step: 0.1\n'
        b'effects: [magnetorquers: {max_dipole: 1}, bdot: {gain: 1, control_period: 0.15}]\n',
        'orbit altitude -1 km': b'rate_source: dynamics\nbody: {inertia: {moments: [1, 2, 3]}}'
        b'\norbit: {altitude: -1000.0}\n',
        'orbit epoch 1e308': b'rate_source: dynamics\nbody: {inertia: {moments: [1, 2, 3]}}'
        b'\norbit: {altitude: 500000.0, epoch: 1e308}\n',
        'magnetic_field igrf in 2200': b'rate_source: dynamics\nbody: {inertia: {moments: '
        b'[1, 2, 3]}}\norbit: {altitude: 500000.0, epoch: 2200-01-01T00:00:00Z}\n'
        b'magnetic_field: {model: igrf}\n',
        'magnetic_field without an orbit': b'rate_source: dynamics\nbody: {inertia: '
        b'{moments: [1, 2, 3]}}\nmagnetic_field: {model: tilted_dipole}\n',
        'magnetic_field unknown model': _SPACECRAFT + b'magnetic_field: {model: wmm}\n',
    }


def _alias_bomb(key: bytes) -> bytes:
    lines = [b'a0: &a0 "lol lol lol lol lol lol lol lol"']
    for level in range(1, 10):
        refs = b', '.join([b'*a%d' % (level - 1)] * 9)
        lines.append(b'a%d: &a%d [%s]' % (level, level, refs))
    lines.append(key + b': *a9')
    return b'\n'.join(lines) + b'\n'


def magnetometer_files(folder: Path) -> dict[str, Path]:
    """Hostile magnetometer calibration files."""
    files = {
        'not UTF-8': b'hard_iron: [\xff, 0, 0]\n',
        'hard_iron 1e308': b'hard_iron: [1e308, 0, 0]\n',
        'soft_iron singular': b'soft_iron: [[1, 0, 0], [1, 0, 0], [0, 0, 1]]\n',
        'soft_iron a mirror': b'soft_iron: [[-1, 0, 0], [0, 1, 0], [0, 0, 1]]\n',
        'soft_iron NaN': b'soft_iron: [[.nan, 0, 0], [0, 1, 0], [0, 0, 1]]\n',
        'alias bomb': _alias_bomb(b'hard_iron'),
        '20 MB file': b'# ' + b'x' * (20 * 2**20) + b'\n',
        'unknown key': b'scale: 2\n',
    }
    paths = {}
    for name, content in files.items():
        path = folder / ('mag_' + name.replace(' ', '_') + '.yaml')
        path.write_bytes(content)
        paths[name] = path
    paths['missing file'] = folder / 'no_such_magnetometer.yaml'
    return paths


def start_attack(name: str, cases: dict[str, list[str]], domain: int) -> Result:
    """Each case must end at start with one ``error:`` line, exit 2, within a second."""
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    started, problems, slowest = time.monotonic(), [], 0.0
    for case, arguments in cases.items():
        began = time.monotonic()
        try:
            done = subprocess.run(node_command(*arguments), env=env, capture_output=True,
                                  text=True, errors='replace', timeout=30)
        except subprocess.TimeoutExpired:
            problems.append(f'{case}: hung')
            continue
        took = time.monotonic() - began
        lines = [line for line in done.stderr.splitlines() if line.startswith('error:')]
        slowest = max(slowest, took)
        if (done.returncode != 2 or len(lines) != 1 or 'Traceback' in done.stderr
                or len(lines[0]) > 1000):
            problems.append(f'{case}: exit {done.returncode}, {len(lines)} error lines, '
                            f'{len(done.stderr)} chars')
    outcome = (f'one error: line, exit 2 each (slowest {slowest:.2f} s incl. start-up)'
               if not problems else 'FAILED: ' + '; '.join(problems))
    return Result(name, len(cases), 'error: exit 2', outcome, time.monotonic() - started)


def parameter_cases() -> dict[str, list[str]]:
    return {f'{name}:={value}': ['-p', f'{name}:={value}'] for name, value in [
        ('publish_rate', '50'), ('publish_rate', '0.0'), ('publish_rate', '.nan'),
        ('max_dt', '-1.0'), ('max_angular_rate', '0.0'), ('time_jump_threshold', '1e300'),
        ('constant_dt', 'true'), ('use_header_stamps', '2.0'), ('step', '.inf'),
        ('world_frame', "''"), ('body_frame', 'world'), ('integrator', 'no_such'),
        ('scene', 'no_such_scene'), ('scene', 'x' * 5000), ('step', '-0.001'),
        ('magnetic_declination', '4.0'), ('magnetometer_noise_density', '-1.0'),
        ('accelerometer_noise_density', '.inf'), ('accelerometer_random_walk', 'true')]}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--domain', type=int, default=91)
    parser.add_argument('--seed', type=int, default=7)
    parser.add_argument('--surface', action='append', default=None,
                        choices=[surface.name for surface in (*SURFACES, *COMMAND_SURFACES)],
                        help='attack only this surface (repeatable); no start-time attacks '
                             'unless --start names some')
    parser.add_argument('--start', action='append', default=None, choices=START_CLASSES,
                        help='only this start-time class (repeatable); no surface unless '
                             '--surface names some')
    parser.add_argument('--out', type=Path, default=None,
                        help='write the table here instead of printing it')
    args = parser.parse_args(argv)
    results = []
    for surface in SURFACES:
        if (args.surface or args.start) and surface.name not in (args.surface or ()):
            continue
        for hostile in surface.classes(args.seed):
            results.append(_said(attack(args.domain, surface, hostile)))
    for command_surface in COMMAND_SURFACES:
        if (args.surface or args.start) and command_surface.name not in (args.surface or ()):
            continue
        for command_class in command_surface.classes(args.seed):
            results.append(_said(attack_commands(args.domain, command_surface,
                                                 command_class)))
    if args.start or not args.surface:
        results += start_attacks(args.domain, args.start or START_CLASSES)
    write_report(results, args.out, args.seed)
    return 0 if all(not r.outcome.startswith('FAILED') for r in results) else 1


def _said(result: Result) -> Result:
    print(f'{result.name}: {result.cases} cases: {result.outcome} '
          f'(RSS {result.rss_growth_mib:+.1f} MiB)', flush=True)
    return result


#: The start-time classes: what a user gives at start.
START_CLASSES = ('scene files', 'sensors sections', 'parameters',
                 'magnetometer calibration files')


def start_attacks(domain: int, classes: tuple[str, ...] | list[str]) -> list[Result]:
    """The scene files and parameters a user may give (the ``classes`` of
    :data:`START_CLASSES`)."""
    results = []
    with tempfile.TemporaryDirectory() as folder:
        cases_of = {
            'scene files': {name: ['-p', f'scene:={path}']
                            for name, path in scene_files(Path(folder)).items()},
            'sensors sections': {name: ['-p', f'scene:={path}']
                                 for name, path in sensor_scene_files(Path(folder)).items()},
            'parameters': parameter_cases(),
            'magnetometer calibration files': {
                name: ['-p', 'scene:=imu_filter', '-p', f'magnetometer_calibration_file:={path}']
                for name, path in magnetometer_files(Path(folder)).items()}}
        for name in START_CLASSES:
            if name not in classes:
                continue
            result = start_attack(name, cases_of[name], domain)
            print(f'{result.name}: {result.cases} cases: {result.outcome}', flush=True)
            results.append(result)
    return results


def write_report(results: list[Result], path: Path | None, seed: int) -> None:
    """Print the table of ``results``, or write it to ``path``."""
    lines = ['| attack class | cases | counted as | result | node RSS growth |',
             '|---|---|---|---|---|']
    lines += [f'| {r.name} | {r.cases} | {", ".join(f"`{x}`" for x in r.reason.split("|"))} '
              f'| {r.outcome} | '
              f'{"" if r.rss_growth_mib is None else f"{r.rss_growth_mib:+.1f} MiB"} |'
              for r in results]
    total = sum(r.cases for r in results)
    lines += ['', f'{total} cases in {sum(r.seconds for r in results):.0f} s '
                  f'(`studies/hostile_inputs.py --seed {seed}`).']
    if path is None:
        print('\n'.join(lines))
        return
    path.write_text('\n'.join(lines) + '\n')
    print(f'wrote {path}')


if __name__ == '__main__':
    sys.exit(main())
