"""``replay``: run a rosbag2 bag through the propagation node's code, offline, into a new bag.

``replay BAG [-o OUT] [--scene NAME|FILE] [--ground-truth TOPIC] [--csv FILE] ...`` reads a
bag (sqlite3 or MCAP, through :mod:`rigid_body_attitude.bag`; no ROS install needed), feeds its
gyro and command messages through the same stream rules
(:mod:`rigid_body_attitude.session.stream`), propagator and published values
(:mod:`rigid_body_attitude.session.outputs`) as the node (:mod:`rigid_body_attitude.ros.node`), and
writes the node's output topics, types and stamps to an output bag. It prints what it read, used
and rejected, the final attitude and the drift of energy and momentum; with ``--ground-truth`` also
the attitude error (statistics and a PNG).

What happens when, on the bag's time axis (bag time = the recorder's receive time), as the
node does it when a player publishes ``/clock`` with the bag times (``use_sim_time``):

* **Clock ticks** at the multiples ``k P`` (``k ≥ 1``) of the timer period
  ``P = settings.timer_period_ns(publish_rate)`` that lie within the bag's time span. A tick at
  ``T`` happens before the messages recorded at ``T`` (the player publishes ``/clock = T``
  first). Dynamics scenes integrate to each tick (``ClockDriver``) and publish
  ``orientation``, ``pose``, ``twist``, ``energy`` and ``angular_momentum`` stamped with the
  propagated time; gyro scenes publish ``energy`` and ``angular_momentum`` at a tick when an
  attitude was published since the last one (stamped like that attitude), and once more at
  the first tick after the last gyro message.
* **Gyro messages** (gyro scenes): each goes to ``GyroStream.add`` with its header stamp (or
  its bag time with ``--no-header-stamps``); unless rejected (a gap or time jump still
  publishes) ``orientation``, ``pose`` and, for ``sensor_msgs/Imu`` input, ``imu/data`` are
  written, stamped with the gyro's header stamp.
* **Commands** (``torque``: WrenchStamped → the scene's ``torque``/``force`` inputs;
  ``rotor_torque``: Vector3Stamped) go to ``CommandStream.add`` with their header stamps (the
  bag time when the stamp is zero or ``--no-header-stamps``), in bag-time order.
* ``set_pose`` (PoseStamped) re-initialises the attitude (and position) when it comes, as in
  the node.
* ``/diagnostics`` every second of bag time from the first message, as the node's report, and
  once more at the next second after the end.

Stamps are converted with :class:`rigid_body_attitude.session.reports.TimeBase` as in the node.
Output messages are written at the bag time of the input (or tick) that caused them. The output bag
keeps the input bag's ``custom_data`` (e.g. a dataset's citation and licence) and adds the
replay settings.
"""

from __future__ import annotations

import argparse
import array
import csv
import math
import shutil
import sys
import time
from collections import Counter
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rigid_body_attitude.core import quaternion
from rigid_body_attitude.bag import (
    ATTITUDE_DECODERS, IMU, POSE_STAMPED, RATE_SAMPLE_DECODERS, STORAGES, VECTOR3_STAMPED,
    WRENCH_STAMPED, BagError, BagReader, BagWriter, DiagnosticStatus, Record, SampleDecoder,
    encode_diagnostic_array, encode_float64, encode_pose_stamped, encode_quaternion_stamped,
    encode_twist_stamped, encode_vector3_stamped, header_stamp_ns, imu_with_orientation,
    pose_orientation, pose_position, pose_stamped_encoder, quaternion_stamped_encoder,
    vector3_stamped, wrench_force, wrench_torque)
from rigid_body_attitude.core.errors import AttitudeError, InputError
from rigid_body_attitude.session.reports import (
    NANOSECONDS_PER_SECOND, TimeBase, body_frame_velocity, diagnostic_report,
    stale_command_count)
from rigid_body_attitude.session.outputs import OutputTracker
from rigid_body_attitude.core.propagator import (
    DynamicsPropagator, GyroPropagator, build_propagator)
from rigid_body_attitude.core.scene import Scene
from rigid_body_attitude.session.settings import (
    DIAGNOSTICS_PERIOD, DIAGNOSTICS_TOPIC, GYRO_TOPICS, NODE_DEFAULTS, NODE_NAME,
    OUTPUT_TOPICS, ROTOR_TORQUE_TOPIC, SET_POSE_TOPIC, TORQUE_TOPIC, load_node_scene, publishes,
    timer_period_ns)
from rigid_body_attitude.session.stream import ClockDriver, CommandStream, GyroStream

__all__ = ['ErrorStatistics', 'OutputSeries', 'ReplayOptions', 'ReplayResult',
           'attitude_errors', 'main', 'replay_bag']

FloatArray = NDArray[np.float64]
Quaternion = tuple[float, float, float, float]

#: Progress-bar updates and output flushes every this many messages (a tqdm update costs
#: about a microsecond).
PROGRESS_CHUNK = 4096
#: Output records buffered at most before they are written (about 3 MB of messages).
FLUSH_RECORDS = 4 * PROGRESS_CHUNK
#: Output topics of each scene kind, in the order they are listed.
_GYRO_OUTPUTS = ('orientation', 'pose', 'imu/data', 'energy', 'angular_momentum',
                 DIAGNOSTICS_TOPIC)
_DYNAMICS_OUTPUTS = ('orientation', 'pose', 'twist', 'energy', 'angular_momentum',
                     DIAGNOSTICS_TOPIC)
_ZERO = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class ReplayOptions:
    """Replay settings; the node's parameters keep the node's names and defaults.

    Attributes:
        scene: built-in scene name or scene YAML path.
        integrator: integrator / strapdown method overriding the scene's (``''``: the scene's).
        step: integration step of dynamics scenes [s] (0: the scene's).
        max_dt: a longer gap between gyro samples is not integrated across [s].
        time_jump_threshold: a larger backward jump resets to the initial state [s].
        publish_rate: clock ticks per second (dynamics outputs; energy and momentum) [Hz].
        constant_dt: integrate each gyro sample over this step (0: the stamps) [s].
        use_header_stamps: input times from header stamps (else the bag times).
        torque_timeout: command hold time overriding the scene's (0: the scene's) [s].
        world_frame: frame id of orientation, pose and angular momentum.
        body_frame: frame id of twist.
        gyro_topic: gyro topic (``''``: ``imu`` or else ``angular_velocity``, as the node).
        torque_topic: WrenchStamped commands.
        rotor_torque_topic: Vector3Stamped rotor motor torque commands.
        set_pose_topic: PoseStamped re-initialisations of the attitude (and position).
        ground_truth_topic: QuaternionStamped or PoseStamped attitude to compare with.
        start_from_ground_truth: stamp [s] from which on the attitude starts from the ground
            truth (at the first gyro sample or tick at or after it); ``None``: the scene's.
        outputs: output topics to write (empty: all the node publishes for the scene).
        storage: storage plugin of the output bag (``sqlite3`` or ``mcap``).
    """

    scene: str = NODE_DEFAULTS['scene']
    integrator: str = NODE_DEFAULTS['integrator']
    step: float = NODE_DEFAULTS['step']
    max_dt: float = NODE_DEFAULTS['max_dt']
    time_jump_threshold: float = NODE_DEFAULTS['time_jump_threshold']
    publish_rate: float = NODE_DEFAULTS['publish_rate']
    constant_dt: float = NODE_DEFAULTS['constant_dt']
    use_header_stamps: bool = NODE_DEFAULTS['use_header_stamps']
    torque_timeout: float = NODE_DEFAULTS['torque_timeout']
    world_frame: str = NODE_DEFAULTS['world_frame']
    body_frame: str = NODE_DEFAULTS['body_frame']
    gyro_topic: str = ''
    torque_topic: str = TORQUE_TOPIC
    rotor_torque_topic: str = ROTOR_TORQUE_TOPIC
    set_pose_topic: str = SET_POSE_TOPIC
    ground_truth_topic: str = ''
    start_from_ground_truth: float | None = None
    outputs: tuple[str, ...] = ()
    storage: str = 'sqlite3'


def _check_options(options: ReplayOptions) -> None:
    """The node's parameter checks (and the replay's own); raises :class:`InputError`."""
    for name in ('publish_rate', 'max_dt', 'time_jump_threshold'):
        value = getattr(options, name)
        if not (math.isfinite(value) and value > 0.0):
            raise InputError(f'Expected `{name}` to be a finite number > 0, got {value!r}')
    if options.publish_rate > 1000.0:
        raise InputError(f'Expected `publish_rate` ≤ 1000 Hz (the node\'s limit), got '
                         f'{options.publish_rate!r}')
    for name in ('constant_dt', 'torque_timeout', 'step'):
        value = getattr(options, name)
        if not (math.isfinite(value) and value >= 0.0):
            raise InputError(f'Expected `{name}` to be a finite number >= 0, got {value!r}')
    if options.world_frame == options.body_frame or not options.world_frame.strip():
        raise InputError(f'Expected `world_frame` and `body_frame` to be distinct non-empty '
                         f'names, got {options.world_frame!r} and {options.body_frame!r}')
    if options.storage not in STORAGES:
        raise InputError(f'Expected `storage` to be one of {sorted(STORAGES)}, got '
                         f'{options.storage!r}')
    if options.start_from_ground_truth is not None:
        if not options.ground_truth_topic:
            raise InputError('Expected a ground-truth topic with `start_from_ground_truth`, '
                             'got none (use --ground-truth TOPIC)')
        if not math.isfinite(options.start_from_ground_truth):
            raise InputError(f'Expected `start_from_ground_truth` to be a finite stamp [s], '
                             f'got {options.start_from_ground_truth!r}')
    unknown = sorted(set(options.outputs) - set(OUTPUT_TOPICS))
    if unknown:
        raise InputError(f'Unknown output topic {unknown[0]!r}; valid choices: '
                         f'{", ".join(OUTPUT_TOPICS)}')


@dataclass
class OutputSeries:
    """The published values kept in memory (for statistics, CSV and plots).

    ``attitude_*``: one row per ``orientation`` output; ``invariant_*``: one row per
    ``energy``/``angular_momentum`` output. Stamps are integer nanoseconds.
    """

    attitude_stamps_ns: array.array = field(default_factory=lambda: array.array('q'))
    attitudes: array.array = field(default_factory=lambda: array.array('d'))
    positions: array.array = field(default_factory=lambda: array.array('d'))
    invariant_stamps_ns: array.array = field(default_factory=lambda: array.array('q'))
    energies: array.array = field(default_factory=lambda: array.array('d'))
    momenta: array.array = field(default_factory=lambda: array.array('d'))

    def attitude_array(self) -> tuple[NDArray[np.int64], FloatArray, FloatArray]:
        """Stamps (ns), attitudes (N, 4) (w, x, y, z) and positions (N, 3) as arrays."""
        return (np.frombuffer(self.attitude_stamps_ns, dtype=np.int64).copy(),
                np.frombuffer(self.attitudes, dtype=np.float64).reshape(-1, 4).copy(),
                np.frombuffer(self.positions, dtype=np.float64).reshape(-1, 3).copy())

    def invariant_array(self) -> tuple[NDArray[np.int64], FloatArray, FloatArray]:
        """Stamps (ns), energies (M,) and world momenta (M, 3) as arrays."""
        return (np.frombuffer(self.invariant_stamps_ns, dtype=np.int64).copy(),
                np.frombuffer(self.energies, dtype=np.float64).copy(),
                np.frombuffer(self.momenta, dtype=np.float64).reshape(-1, 3).copy())


@dataclass(frozen=True)
class ErrorStatistics:
    """Attitude error against the ground truth (see :func:`attitude_errors`).

    Attributes:
        stamps_ns: stamps compared [ns].
        errors: attitude error at each [rad]
            (:func:`~rigid_body_attitude.core.quaternion.attitude_error`).
    """

    stamps_ns: NDArray[np.int64]
    errors: FloatArray

    @property
    def count(self) -> int:
        """Ground-truth samples compared."""
        return int(self.errors.size)

    def within(self, start_ns: int, end_ns: int) -> ErrorStatistics:
        """The errors with stamps in ``[start_ns, end_ns]``."""
        mask = (self.stamps_ns >= start_ns) & (self.stamps_ns <= end_ns)
        return ErrorStatistics(self.stamps_ns[mask], self.errors[mask])

    def text(self) -> str:
        """One line: max (and when), mean, RMS and final error in degrees."""
        if not self.count:
            return 'no ground-truth sample within the replayed outputs'
        degrees = np.degrees(self.errors)
        worst = int(np.argmax(degrees))
        return (f'max {degrees[worst]:.4g} deg at stamp {self.stamps_ns[worst] * 1e-9:.3f} s, '
                f'mean {degrees.mean():.4g}, rms {math.sqrt(np.mean(degrees ** 2)):.4g}, '
                f'final {degrees[-1]:.4g} deg ({self.count} samples)')


@dataclass
class ReplayResult:
    """What a replay read, used, rejected and published.

    Attributes:
        input_path, output_path: the bags.
        scene: the scene replayed (with the overrides).
        read: messages read per input topic.
        used: inputs used (gyro samples, commands) and clock ticks accepted.
        rejected: rejections by reason (stream reasons and ``stale_torque``).
        written: messages written per output topic.
        final_stamp_ns: stamp of the last attitude output [ns] (``None``: no output).
        final_attitude: the last published attitude (w, x, y, z).
        diagnostics: the propagator's final diagnostics (energy, momentum, drift).
        series: the published values (empty unless kept, see :func:`replay_bag`).
        errors: attitude error against the ground truth (``None`` without ground truth);
            from the alignment on when the attitude was set from the ground truth.
        alignment_stamp_ns: where the attitude was set from the ground truth, if it was.
        gyro_messages: gyro messages processed (for the throughput).
        elapsed: seconds spent in the replay loop.
        notes: remarks for the user (ignored topics and the like).
    """

    input_path: Path
    output_path: Path
    scene: Scene
    read: dict[str, int]
    used: int
    rejected: Counter[str]
    written: dict[str, int]
    final_stamp_ns: int | None
    final_attitude: Quaternion | None
    diagnostics: Any
    series: OutputSeries
    errors: ErrorStatistics | None
    alignment_stamp_ns: int | None
    gyro_messages: int
    elapsed: float
    notes: list[str]


@dataclass(frozen=True)
class _Plan:
    """Topics resolved against the bag, with their decoders."""

    gyro_topic: str
    gyro_decoder: SampleDecoder | None
    gyro_is_imu: bool
    torque_topic: str
    rotor_torque_topic: str
    set_pose_topic: str
    ground_truth_topic: str
    outputs: tuple[str, ...]
    notes: tuple[str, ...]


def _resolve(topics: Iterable[str], name: str) -> str:
    """The bag's spelling of topic ``name`` (with or without the leading slash), or ``''``."""
    names = set(topics)
    for candidate in (name, '/' + name.lstrip('/'), name.lstrip('/')):
        if candidate in names:
            return candidate
    return ''


def _listing(reader: BagReader) -> str:
    topics = reader.topics
    if not topics:
        return 'the bag has no topics'
    return 'the bag has: ' + ', '.join(f'{name} ({msgtype})' for name, msgtype in topics.items())


def _required(reader: BagReader, name: str, what: str) -> str:
    found = _resolve(reader.topics, name)
    if not found:
        raise BagError(f'{what} topic {name!r} is not in bag {str(reader.path)!r}; '
                       f'{_listing(reader)}')
    return found


def _gyro_plan(reader: BagReader, options: ReplayOptions
               ) -> tuple[str, Callable[..., Any], bool]:
    if options.gyro_topic:
        topic = _required(reader, options.gyro_topic, 'Gyro')
    else:
        topic = next((found for found in (_resolve(reader.topics, name) for name in GYRO_TOPICS)
                      if found), '')
        if not topic:
            raise BagError(f'No gyro topic in bag {str(reader.path)!r}: expected '
                           f'{" or ".join(repr(name) for name in GYRO_TOPICS)} (or name one '
                           f'with --gyro-topic); {_listing(reader)}')
    decoder = reader.decoder(topic, RATE_SAMPLE_DECODERS)
    return topic, decoder, reader.topics[topic] == IMU


def _command_topic(reader: BagReader, name: str, default: str, needed: bool,
                   accepted: Sequence[str], notes: list[str]) -> str:
    """The resolved command topic, ``''`` when absent; type-checked when present."""
    found = _resolve(reader.topics, name)
    if not found:
        if name != default:
            _required(reader, name, 'Command')
        if needed:
            notes.append(f'no {name!r} topic in the bag: the scene gets no such commands')
        return ''
    if not needed:
        notes.append(f'topic {found!r} ignored: the scene takes no commands from it')
        return ''
    reader.connections({found: accepted})
    return found


def _plan(reader: BagReader, propagator: DynamicsPropagator | GyroPropagator,
          options: ReplayOptions, scene_given: bool) -> _Plan:
    """Check the bag's topics against the scene and options; raise BagError if unusable."""
    notes: list[str] = []
    inputs = propagator.input_names
    is_gyro = isinstance(propagator, GyroPropagator)
    gyro_topic, gyro_decoder, is_imu = '', None, False
    if is_gyro:
        gyro_topic, gyro_decoder, is_imu = _gyro_plan(reader, options)
    elif options.gyro_topic:
        _required(reader, options.gyro_topic, 'Gyro')
        notes.append(f'gyro topic {options.gyro_topic!r} ignored: scene '
                     f'{propagator.scene.name!r} integrates its own dynamics')
    elif not scene_given and any(_resolve(reader.topics, name) for name in GYRO_TOPICS):
        notes.append(f'the bag has gyro data but the default scene {propagator.scene.name!r} '
                     f'is a dynamics scene: use --scene strapdown to integrate the gyro')
    torque_topic = _command_topic(reader, options.torque_topic, TORQUE_TOPIC,
                                  bool(inputs & {'torque', 'force'}),
                                  (WRENCH_STAMPED,), notes)
    rotor_topic = _command_topic(reader, options.rotor_torque_topic, ROTOR_TORQUE_TOPIC,
                                 'rotor_torque' in inputs, (VECTOR3_STAMPED,), notes)
    set_pose_topic = _command_topic(reader, options.set_pose_topic, SET_POSE_TOPIC, True,
                                    (POSE_STAMPED,), [])
    truth_topic = ''
    if options.ground_truth_topic:
        truth_topic = _required(reader, options.ground_truth_topic, 'Ground-truth')
        reader.decoder(truth_topic, ATTITUDE_DECODERS)
    available = _GYRO_OUTPUTS if is_gyro else _DYNAMICS_OUTPUTS
    if is_gyro and not is_imu:
        available = tuple(name for name in available if name != 'imu/data')
    outputs = options.outputs or available
    missing = [name for name in outputs if name not in available]
    if missing:
        raise InputError(f'Output {missing[0]!r} is not published for scene '
                         f'{propagator.scene.name!r} with this input; valid choices: '
                         f'{", ".join(available)}')
    return _Plan(gyro_topic, gyro_decoder, is_imu, torque_topic, rotor_topic, set_pose_topic,
                 truth_topic, tuple(outputs), tuple(notes))


def _read_ground_truth(reader: BagReader, topic: str
                       ) -> tuple[NDArray[np.int64], FloatArray]:
    """Header stamps (ns, sorted) and unit attitudes (w, x, y, z) of the ground-truth topic."""
    decoder = reader.decoder(topic, ATTITUDE_DECODERS)
    stamps, attitudes = [], []
    for _, _, _, data in reader.messages([topic]):
        stamps.append(header_stamp_ns(data))
        attitudes.append(decoder(data)[1])
    if not stamps:
        raise BagError(f'Ground-truth topic {topic!r} has no messages')
    stamp_array = np.array(stamps, dtype=np.int64)
    attitude_array = np.array(attitudes, dtype=np.float64)
    order = np.argsort(stamp_array, kind='stable')
    norms = np.linalg.norm(attitude_array, axis=1)
    if not np.all(np.isfinite(norms)) or np.any(norms == 0.0):
        raise BagError(f'Expected ground-truth topic {topic!r} to hold finite non-zero '
                       f'quaternions, got {int(np.sum(~(np.isfinite(norms) & (norms > 0))))} '
                       f'that are not')
    return stamp_array[order], (attitude_array / norms[:, None])[order]


def _interpolate(stamps_ns: NDArray[np.int64], attitudes: FloatArray,
                 at_ns: NDArray[np.int64]) -> FloatArray:
    """Attitudes at ``at_ns`` (within the stamps) by slerp ``q_a ⊗ exp(s log(q_a* ⊗ q_b))``."""
    upper = np.clip(np.searchsorted(stamps_ns, at_ns, side='left'), 0, len(stamps_ns) - 1)
    exact = stamps_ns[upper] == at_ns
    lower = np.maximum(upper - 1, 0)
    span = (stamps_ns[upper] - stamps_ns[lower]).astype(np.float64)
    fraction = np.where(exact | (span == 0), 1.0,
                        (at_ns - stamps_ns[lower]) / np.where(span == 0, 1.0, span))
    start = np.where(exact[:, None], attitudes[upper], attitudes[lower])
    relative = quaternion.multiply(quaternion.conjugate(start), attitudes[upper])
    step = quaternion.exp(fraction[:, None] * quaternion.log(quaternion.normalize(relative)))
    return np.where(exact[:, None], attitudes[upper], quaternion.multiply(start, step))


def attitude_errors(output_stamps_ns: NDArray[np.int64], output_attitudes: FloatArray,
                    truth_stamps_ns: NDArray[np.int64], truth_attitudes: FloatArray
                    ) -> ErrorStatistics:
    """Error of the outputs against the ground truth where both are defined.

    Compared at the stamps of the sparser of the two series within their common time span,
    the denser one interpolated there (slerp between its neighbouring samples; an equal stamp
    is used directly), so a 50 Hz output is not blamed for interpolating a 1 kHz truth.
    """
    empty = ErrorStatistics(np.zeros(0, dtype=np.int64), np.zeros(0))
    if output_stamps_ns.size == 0 or truth_stamps_ns.size == 0:
        return empty
    order = np.argsort(output_stamps_ns, kind='stable')
    stamps, attitudes = output_stamps_ns[order], output_attitudes[order]
    start = max(stamps[0], truth_stamps_ns[0])
    end = min(stamps[-1], truth_stamps_ns[-1])
    truth_inside = (truth_stamps_ns >= start) & (truth_stamps_ns <= end)
    outputs_inside = (stamps >= start) & (stamps <= end)
    if not truth_inside.any() or not outputs_inside.any():
        return empty
    if truth_inside.sum() <= outputs_inside.sum():
        at = truth_stamps_ns[truth_inside]
        estimated = _interpolate(stamps, attitudes, at)
        truth = truth_attitudes[truth_inside]
    else:
        at = stamps[outputs_inside]
        estimated = attitudes[outputs_inside]
        truth = _interpolate(truth_stamps_ns, truth_attitudes, at)
    errors = quaternion.attitude_error(estimated, truth)
    return ErrorStatistics(at, np.atleast_1d(np.asarray(errors, dtype=np.float64)))


class _Writer:
    """The output bag's connections, counts, the series kept in memory and a record buffer.

    Every output goes into one buffer in write order (so the bag is the one single writes
    would make) and reaches the bag in :meth:`BagWriter.write_many` batches: :meth:`write`
    flushes at :data:`FLUSH_RECORDS`, the gyro loop every :data:`PROGRESS_CHUNK` messages,
    :func:`replay_bag` at the end.
    """

    def __init__(self, writer: BagWriter, outputs: Sequence[str], keep_series: bool) -> None:
        self.bag = writer
        self.connections = {name: writer.add_topic(name, OUTPUT_TOPICS[name])
                            for name in outputs}
        self.ids = {name: connection.id for name, connection in self.connections.items()}
        self.counts = {name: 0 for name in outputs}
        self.records: list[Record] = []
        self.invariants = 'energy' in outputs or 'angular_momentum' in outputs
        self.series = OutputSeries()
        self.keep_series = keep_series

    def write(self, topic: str, bag_time_ns: int, data: bytes) -> None:
        """Write ``data`` on ``topic`` (if selected) at ``bag_time_ns``."""
        connection_id = self.ids.get(topic)
        if connection_id is not None:
            self.records.append((connection_id, bag_time_ns, data))
            self.counts[topic] += 1
            if len(self.records) >= FLUSH_RECORDS:
                self.flush()

    def flush(self) -> None:
        """Write the buffered records to the bag (the buffer is emptied in place)."""
        self.bag.write_many(self.records)
        self.records.clear()


class _Replay:
    """The node's callbacks without rclpy: inputs and ticks in, output messages out."""

    def __init__(self, scene: Scene, options: ReplayOptions, plan: _Plan, writer: _Writer,
                 truth: tuple[NDArray[np.int64], FloatArray] | None) -> None:
        self.scene = scene
        self.options = options
        self.plan = plan
        self.writer = writer
        self.truth = truth
        self.propagator = build_propagator(scene)
        self.is_dynamics = isinstance(self.propagator, DynamicsPropagator)
        self.time_base = TimeBase()
        self.tracker = OutputTracker()
        self.command_stream = CommandStream(self.propagator)
        self.gyro_stream: GyroStream | None = None
        self.clock_driver: ClockDriver | None = None
        if self.is_dynamics:
            self.clock_driver = ClockDriver(self.propagator, options.time_jump_threshold)
        else:
            self.gyro_stream = GyroStream(self.propagator, options.max_dt,
                                          options.time_jump_threshold, options.constant_dt)
        self.wrench_inputs = tuple(name for name in ('torque', 'force')
                                   if name in self.propagator.input_names)
        self.period_ns = timer_period_ns(options.publish_rate)
        self.read: Counter[str] = Counter()
        self.input_messages = 0
        self.period_rejections: Counter[str] = Counter()
        self.pose_rejections: Counter[str] = Counter()
        self.alignment_ns: int | None = (
            None if options.start_from_ground_truth is None
            else _seconds_to_ns(options.start_from_ground_truth))
        self.aligned_at_ns: int | None = None
        self.next_tick_ns = 0
        self.next_diagnostics_ns = 0
        self.period_start_inputs = 0
        self.fresh_output = False
        self.last_output_ns: int | None = None
        self.started = False

    # -- time events --------------------------------------------------------------------

    def start(self, bag_time_ns: int) -> None:
        """First message at ``bag_time_ns``: schedule the first tick and diagnostics."""
        period = self.period_ns
        self.next_tick_ns = max(-(-bag_time_ns // period), 1) * period
        self.next_diagnostics_ns = bag_time_ns + round(DIAGNOSTICS_PERIOD * 1e9)
        self.started = True

    def events_until(self, bag_time_ns: int) -> None:
        """Run the ticks and diagnostics due at or before ``bag_time_ns``, in time order."""
        while True:
            tick, diagnostics = self.next_tick_ns, self.next_diagnostics_ns
            if min(tick, diagnostics) > bag_time_ns:
                return
            if tick <= diagnostics:
                self.tick(tick)
                self.next_tick_ns = tick + self.period_ns
            else:
                self.publish_diagnostics(diagnostics)
                self.next_diagnostics_ns = diagnostics + round(DIAGNOSTICS_PERIOD * 1e9)

    def next_event_ns(self) -> int:
        """Bag time of the next tick or diagnostics message."""
        return min(self.next_tick_ns, self.next_diagnostics_ns)

    def tick(self, now_ns: int) -> None:
        """The output timer at clock time ``now_ns`` (the node's ``tick_callback``)."""
        if self.clock_driver is None:
            if self.fresh_output:
                self.publish_invariants(now_ns, self.last_output_ns)
            return
        outcome = self.clock_driver.tick(self.time_base.seconds_from_nanoseconds(now_ns))
        if outcome.reason:
            self.period_rejections[outcome.reason] += 1
            if outcome.reset:
                self.command_stream.reset()
            if not publishes(outcome):
                return
        self.align(now_ns)
        self.publish_dynamics(now_ns)

    def finish(self) -> None:
        """After the last message: pending energy and momentum (gyro), a last diagnostics."""
        if not self.started:
            return
        if self.clock_driver is None and self.fresh_output:
            self.publish_invariants(self.next_tick_ns, self.last_output_ns)
        self.publish_diagnostics(max(self.next_diagnostics_ns, self.next_tick_ns))

    # -- inputs -------------------------------------------------------------------------

    def align(self, stamp_ns: int) -> None:
        """Set the attitude from the ground truth at the first output at/after the stamp."""
        if self.alignment_ns is None or stamp_ns < self.alignment_ns:
            return
        truth_stamps, truth_attitudes = self.truth
        if not truth_stamps[0] <= stamp_ns <= truth_stamps[-1]:
            raise InputError(f'Expected ground truth at stamp {stamp_ns * 1e-9:.9f} s to start '
                             f'from, but it covers [{truth_stamps[0] * 1e-9:.9f}, '
                             f'{truth_stamps[-1] * 1e-9:.9f}] s')
        attitude = _interpolate(truth_stamps, truth_attitudes,
                                np.array([stamp_ns], dtype=np.int64))[0]
        self.propagator.set_attitude(attitude)
        if isinstance(self.propagator, GyroPropagator):
            # A new start: group methods (simpson_coning, delta_two_sample, ...) would
            # otherwise finish their group from the attitude they remembered before.
            self.propagator.method.reset()
        self.aligned_at_ns = stamp_ns
        self.alignment_ns = None

    def gyro_messages(self, messages: Iterator[Any], progress: Any) -> int:
        """The gyro scene's loop (hot path): returns the gyro messages processed.

        Per message: one decoder call (header stamp as integers and rate), the stream rules
        and propagator, the attitude, one ``struct`` call per output with the header bytes
        precomputed, and a record appended to the writer's buffer. The stamp of the last
        output is kept in locals and handed over before anything else can read it (clock
        ticks, the end).
        """
        plan, writer = self.plan, self.writer
        gyro_topic, decode = plan.gyro_topic, plan.gyro_decoder
        add = self.gyro_stream.add
        time_base = self.time_base
        attitude_of = self.tracker.attitude
        propagator = self.propagator
        use_header = self.options.use_header_stamps
        encode_orientation = quaternion_stamped_encoder(self.options.world_frame)
        encode_pose = pose_stamped_encoder(self.options.world_frame)
        ids = writer.ids
        record = writer.records.append
        orientation = ids.get('orientation')
        pose = ids.get('pose')
        imu_data = ids.get('imu/data') if plan.gyro_is_imu else None
        series = writer.series if writer.keep_series else None
        rejections = self.period_rejections
        aligning = self.alignment_ns is not None
        next_event = self.next_event_ns() if self.started else -1
        gyro_count = published = chunk = 0
        pending = False  # an output whose stamp (last_sec, last_nanosec) is not handed over
        last_sec = last_nanosec = 0
        for topic, bag_time_ns, _, data in messages:
            if bag_time_ns >= next_event:
                if pending:
                    self.output_published(last_sec, last_nanosec)
                    pending = False
                if not self.started:
                    self.start(bag_time_ns)
                self.events_until(bag_time_ns)
                next_event = self.next_event_ns()
            chunk += 1
            if chunk == PROGRESS_CHUNK:
                progress.update(chunk)
                writer.flush()
                chunk = 0
            if topic != gyro_topic:
                self.command(topic, bag_time_ns, data)
                continue
            gyro_count += 1
            sec, nanosec, rate = decode(data)
            if not use_header:
                sec, nanosec = divmod(bag_time_ns, NANOSECONDS_PER_SECOND)
            elif nanosec >= NANOSECONDS_PER_SECOND:
                sec, nanosec = divmod(sec * NANOSECONDS_PER_SECOND + nanosec,
                                      NANOSECONDS_PER_SECOND)
            epoch = time_base.epoch_sec
            if epoch is None:
                outcome = add(time_base.seconds(sec, nanosec), rate)
            else:  # TimeBase.seconds inlined: the epoch never changes once set
                outcome = add((sec - epoch) + nanosec * 1e-9, rate)
            if outcome.reason:
                rejections[outcome.reason] += 1
                if not publishes(outcome):
                    continue
            if aligning:
                self.align(sec * NANOSECONDS_PER_SECOND + nanosec)
                aligning = self.alignment_ns is not None
            q = attitude_of(propagator)
            if orientation is not None:
                record((orientation, bag_time_ns, encode_orientation(sec, nanosec, q)))
            if pose is not None:
                record((pose, bag_time_ns, encode_pose(sec, nanosec, _ZERO, q)))
            if imu_data is not None:
                record((imu_data, bag_time_ns, imu_with_orientation(data, q)))
            if series is not None:
                series.attitude_stamps_ns.append(sec * NANOSECONDS_PER_SECOND + nanosec)
                series.attitudes.extend(q)
                series.positions.extend(_ZERO)
            published += 1
            pending, last_sec, last_nanosec = True, sec, nanosec
        if pending:
            self.output_published(last_sec, last_nanosec)
        progress.update(chunk)
        self.read[gyro_topic] += gyro_count
        self.input_messages += gyro_count
        for name, connection_id in (('orientation', orientation), ('pose', pose),
                                    ('imu/data', imu_data)):
            if connection_id is not None:
                writer.counts[name] += published
        return gyro_count

    def output_published(self, sec: int, nanosec: int) -> None:
        """An attitude was published with stamp ``(sec, nanosec)`` (for the next tick)."""
        self.last_output_ns = sec * NANOSECONDS_PER_SECOND + nanosec
        self.fresh_output = True

    def dynamics_messages(self, messages: Iterator[Any], progress: Any) -> None:
        """The dynamics scene's loop: every message advances the clock; commands are used."""
        chunk = 0
        for topic, bag_time_ns, _, data in messages:
            if not self.started:
                self.start(bag_time_ns)
            if bag_time_ns >= self.next_event_ns():
                self.events_until(bag_time_ns)
            self.command(topic, bag_time_ns, data)
            chunk += 1
            if chunk == PROGRESS_CHUNK:
                progress.update(chunk)
                self.writer.flush()
                chunk = 0
        progress.update(chunk)

    def command(self, topic: str, bag_time_ns: int, data: bytes) -> None:
        """A command message (torque/force or rotor torque); other topics only count."""
        if topic == self.plan.torque_topic and self.wrench_inputs:
            stamp, torque = wrench_torque(data)
            vectors = {'torque': torque, 'force': wrench_force(data)[1]}
            self.apply_command(self.wrench_inputs, self.command_time(data, bag_time_ns), vectors)
        elif topic == self.plan.rotor_torque_topic:
            vectors = {'rotor_torque': vector3_stamped(data)[1]}
            self.apply_command(('rotor_torque',), self.command_time(data, bag_time_ns),
                               vectors)
        elif topic == self.plan.set_pose_topic:
            self.set_pose(data)
        else:
            self.read[topic] += 1
            return
        self.read[topic] += 1

    def set_pose(self, data: bytes) -> None:
        """The node's ``set_pose_callback``: re-initialise the attitude (and position)."""
        self.input_messages += 1
        attitude, position = pose_orientation(data)[1], pose_position(data)[1]
        if not all(math.isfinite(value) for value in attitude + position):
            self.reject_pose('non_finite')
            return
        try:
            self.propagator.set_attitude(
                attitude, position if self.propagator.has_translation else None)
        except InputError:
            self.reject_pose('invalid_pose')

    def reject_pose(self, reason: str) -> None:
        """Count a rejected ``set_pose`` (separately from the streams, as the node)."""
        self.pose_rejections[reason] += 1
        self.period_rejections[reason] += 1

    def command_time(self, data: bytes, bag_time_ns: int) -> float:
        """The node's ``_command_time``: the header stamp, or the bag time if zero or unused."""
        stamp_ns = header_stamp_ns(data)
        if not self.options.use_header_stamps or stamp_ns == 0:
            stamp_ns = bag_time_ns
        return self.time_base.seconds_from_nanoseconds(stamp_ns)

    def apply_command(self, names: tuple[str, ...], t: float,
                      vectors: dict[str, tuple[float, ...]]) -> None:
        """The node's ``_command``: a non-finite field rejects the whole message."""
        self.input_messages += 1
        bad = [name for name in names if not all(math.isfinite(v) for v in vectors[name])]
        for name in bad[:1] or names:
            outcome = self.command_stream.add(name, t, vectors[name])
            if outcome.reason:
                self.period_rejections[outcome.reason] += 1
                return

    # -- outputs ------------------------------------------------------------------------

    def publish_dynamics(self, now_ns: int) -> None:
        """Every output of a dynamics scene at the propagated time (the node's)."""
        sample = self.tracker.sample(self.propagator)
        sec, nanosec = self.time_base.stamp(sample.stamp)
        stamp_ns = sec * NANOSECONDS_PER_SECOND + nanosec
        world, write = self.options.world_frame, self.writer.write
        write('orientation', now_ns,
              encode_quaternion_stamped(stamp_ns, world, sample.attitude))
        write('pose', now_ns, encode_pose_stamped(stamp_ns, world, sample.position,
                                                  sample.attitude))
        write('twist', now_ns, encode_twist_stamped(
            stamp_ns, self.options.body_frame, body_frame_velocity(self.propagator),
            sample.omega_body))
        series = self.writer.series if self.writer.keep_series else None
        if series is not None:
            series.attitude_stamps_ns.append(stamp_ns)
            series.attitudes.extend(sample.attitude)
            series.positions.extend(sample.position)
        self.last_output_ns = stamp_ns
        self.write_invariants(now_ns, stamp_ns, sample.energy, sample.world_momentum)

    def publish_invariants(self, now_ns: int, stamp_ns: int) -> None:
        """Energy and world momentum of the current state (gyro scenes, at a tick).

        Not computed when neither ``energy`` nor ``angular_momentum`` is written.
        """
        self.fresh_output = False
        if not self.writer.invariants:
            return
        self.write_invariants(now_ns, stamp_ns, self.propagator.energy(),
                              tuple(self.propagator.world_momentum().tolist()))

    def write_invariants(self, now_ns: int, stamp_ns: int, energy: float,
                         world_momentum: Sequence[float]) -> None:
        """Write ``energy`` (Float64) and ``angular_momentum`` (stamped like the attitude)."""
        self.writer.write('energy', now_ns, encode_float64(energy))
        self.writer.write('angular_momentum', now_ns, encode_vector3_stamped(
            stamp_ns, self.options.world_frame, world_momentum))
        if self.writer.keep_series:
            series = self.writer.series
            series.invariant_stamps_ns.append(stamp_ns)
            series.energies.append(energy)
            series.momenta.extend(world_momentum)

    def rejection_counts(self) -> Counter[str]:
        """Rejections so far by reason, with ``stale_torque`` (the node's counters)."""
        counts: Counter[str] = Counter()
        for stream in (self.gyro_stream, self.clock_driver, self.command_stream):
            if stream is not None:
                counts.update(stream.rejected)
        counts.update(self.pose_rejections)
        stale = stale_command_count(self.propagator.counters())
        if stale:
            counts['stale_torque'] = stale
        return counts

    def accepted_count(self) -> int:
        """Inputs used and ticks accepted so far."""
        return sum(stream.accepted for stream in (self.gyro_stream, self.clock_driver,
                                                  self.command_stream) if stream is not None)

    def step_text(self) -> str:
        """The step description of the diagnostics (as the node's)."""
        if self.is_dynamics:
            return f'{self.scene.step:g}'
        constant_dt = self.options.constant_dt
        return f'{constant_dt:g} (constant_dt)' if constant_dt > 0.0 else 'gyro stamps'

    def publish_diagnostics(self, now_ns: int) -> None:
        """The node's ``/diagnostics`` report at bag time ``now_ns``."""
        inputs = self.input_messages
        rate = (inputs - self.period_start_inputs) / DIAGNOSTICS_PERIOD
        self.period_start_inputs = inputs
        report = diagnostic_report(self.propagator, self.rejection_counts(),
                                   self.period_rejections, self.accepted_count(), rate,
                                   self.step_text())
        self.period_rejections.clear()  # in place: the gyro loop holds a reference
        status = DiagnosticStatus(level=report.level, name='/' + NODE_NAME,
                                  message=report.message, hardware_id=self.scene.name,
                                  values=dict(report.values))
        self.writer.write(DIAGNOSTICS_TOPIC, now_ns,
                          encode_diagnostic_array(now_ns, '', [status]))


def _seconds_to_ns(seconds: float) -> int:
    whole = math.floor(seconds)
    return whole * NANOSECONDS_PER_SECOND + round((seconds - whole) * NANOSECONDS_PER_SECOND)


class _NoProgress:
    """Stands in for a tqdm bar when progress is off."""

    def update(self, count: int) -> None:
        """Ignore the count."""

    def close(self) -> None:
        """Nothing to close."""


def _progress_bar(enabled: bool | None, total: int) -> Any:
    if enabled is False:
        return _NoProgress()
    from tqdm import tqdm
    return tqdm(total=total, unit='msg', unit_scale=True, mininterval=0.5, file=sys.stderr,
                disable=None if enabled is None else False, leave=False)


def _output_custom_data(reader: BagReader, scene: Scene, options: ReplayOptions,
                        input_path: Path) -> dict[str, str]:
    custom = dict(reader.custom_data)
    custom.update({
        'replay_source_bag': str(input_path),
        'replay_scene': scene.name,
        'replay_integrator': scene.integrator,
        'replay_settings': ', '.join(f'{item.name}={getattr(options, item.name)!r}'
                                     for item in fields(options)),
    })
    return custom


def replay_bag(input_path: str | Path, output_path: str | Path,
               options: ReplayOptions = ReplayOptions(), *, progress: bool | None = False,
               keep_series: bool = True, scene_given: bool = True) -> ReplayResult:
    """Replay the bag at ``input_path`` into a new bag at ``output_path`` (must not exist).

    Raises :class:`~rigid_body_attitude.bag.BagError` for a missing or unreadable bag, a
    topic not in it (the message lists the bag's topics) or one of an unusable type;
    :class:`InputError` or :class:`~rigid_body_attitude.core.errors.SceneError` for bad options or
    scene. On any error no output bag is left behind. ``progress``: ``None`` shows a bar on
    a terminal only. ``keep_series``: keep the published values in memory (``series``; always
    with a ground-truth topic, whose error statistics need them). ``scene_given=False`` adds
    a note when the default dynamics scene meets a gyro bag.
    """
    _check_options(options)
    input_path, output_path = Path(input_path), Path(output_path)
    scene = load_node_scene(options.scene, options.integrator, options.step,
                            options.torque_timeout)
    if output_path.exists():
        raise BagError(f'Output bag {str(output_path)!r} already exists; choose another '
                       f'with -o/--output or remove it')
    with BagReader(input_path) as reader:
        plan = _plan(reader, build_propagator(scene), options, scene_given)
        truth = (_read_ground_truth(reader, plan.ground_truth_topic)
                 if plan.ground_truth_topic else None)
        if plan.gyro_topic:
            selected = [plan.gyro_topic] + [t for t in (plan.torque_topic,
                                                        plan.rotor_torque_topic,
                                                        plan.set_pose_topic) if t]
        else:
            selected = list(reader.topics)
        total = sum(reader.message_counts.get(topic, 0) for topic in selected)
        custom = _output_custom_data(reader, scene, options, input_path)
        try:
            with BagWriter(output_path, storage=options.storage, custom_data=custom) as bag:
                writer = _Writer(bag, plan.outputs,
                                 keep_series or bool(plan.ground_truth_topic))
                replay = _Replay(scene, options, plan, writer, truth)
                bar = _progress_bar(progress, total)
                begin = time.perf_counter()
                try:
                    messages = reader.messages(selected)
                    if plan.gyro_topic:
                        gyro_count = replay.gyro_messages(messages, bar)
                    else:
                        gyro_count = 0
                        replay.dynamics_messages(messages, bar)
                    replay.finish()
                    writer.flush()
                finally:
                    bar.close()
                elapsed = time.perf_counter() - begin
        except BaseException:
            if output_path.exists():
                shutil.rmtree(output_path)
            raise
        if replay.alignment_ns is not None:
            shutil.rmtree(output_path)
            last = ('none' if replay.last_output_ns is None
                    else f'{replay.last_output_ns * 1e-9:.9f} s')
            raise InputError(f'Expected an output at or after stamp '
                             f'{replay.alignment_ns * 1e-9:.9f} s to start from the ground '
                             f'truth; the last is at {last}')
    return _result(input_path, output_path, replay, writer, truth, gyro_count, elapsed)


def _result(input_path: Path, output_path: Path, replay: _Replay, writer: _Writer,
            truth: tuple[NDArray[np.int64], FloatArray] | None, gyro_count: int,
            elapsed: float) -> ReplayResult:
    stamps, attitudes, _ = writer.series.attitude_array()
    errors = None
    if truth is not None:
        errors = attitude_errors(stamps, attitudes, *truth)
        if replay.aligned_at_ns is not None:
            errors = errors.within(replay.aligned_at_ns, int(stamps[-1]))
    notes = list(replay.plan.notes)
    if replay.is_dynamics and not replay.clock_driver.total:
        notes.append(f'no clock tick within the bag\'s time span at publish_rate '
                     f'{replay.options.publish_rate:g} Hz (ticks at multiples of '
                     f'{replay.period_ns * 1e-9:g} s): nothing propagated')
    return ReplayResult(
        input_path=input_path, output_path=output_path, scene=replay.scene,
        read=dict(replay.read), used=replay.accepted_count(),
        rejected=replay.rejection_counts(), written=dict(writer.counts),
        final_stamp_ns=replay.last_output_ns, final_attitude=replay.tracker.previous,
        diagnostics=replay.propagator.diagnostics(), series=writer.series, errors=errors,
        alignment_stamp_ns=replay.aligned_at_ns, gyro_messages=gyro_count, elapsed=elapsed,
        notes=notes)


# -- reporting ------------------------------------------------------------------------------


def summary(result: ReplayResult) -> str:
    """The printed summary: read, used, rejected, written, final state, drift, error."""
    scene = result.scene
    lines = [f'replayed {str(result.input_path)!r} -> {str(result.output_path)!r}: scene '
             f'{scene.name!r} ({scene.rate_source}, {scene.integrator}'
             f'{f", step {scene.step:g} s" if scene.rate_source == "dynamics" else ""})']
    lines += [f'note: {note}' for note in result.notes]
    read = ', '.join(f'{topic} {count}' for topic, count in sorted(result.read.items()))
    lines.append(f'read: {read or "nothing"}')
    rejected = ', '.join(f'{reason} {count}' for reason, count in sorted(result.rejected.items())
                         if count)
    lines.append(f'used: {result.used}; rejected: {rejected or "none"}')
    written = ', '.join(f'{topic} {count}' for topic, count in result.written.items())
    lines.append(f'written: {written}')
    if result.final_attitude is not None:
        w, x, y, z = result.final_attitude
        lines.append(f'final attitude (w, x, y, z) at stamp {result.final_stamp_ns * 1e-9:.9f} '
                     f's: {w:.12f} {x:.12f} {y:.12f} {z:.12f}')
    diagnostics = result.diagnostics
    measured = ' (gyro scene: from measured rates, not conserved)' if (
        scene.rate_source == 'gyro') else ''
    lines.append(f'energy {diagnostics.kinetic_energy:.9g} J, drift '
                 f'{diagnostics.energy_drift:.3e}, balance residual '
                 f'{diagnostics.energy_balance_residual:.3e} J; momentum drift '
                 f'{diagnostics.momentum_drift:.3e}{measured}')
    if result.alignment_stamp_ns is not None:
        lines.append(f'attitude set from the ground truth at stamp '
                     f'{result.alignment_stamp_ns * 1e-9:.9f} s')
    if result.errors is not None:
        lines.append(f'attitude error vs ground truth: {result.errors.text()}')
    if result.elapsed > 0.0 and result.gyro_messages:
        lines.append(f'{result.gyro_messages} gyro messages in {result.elapsed:.3f} s '
                     f'({result.gyro_messages / result.elapsed:,.0f} per second)')
    return '\n'.join(lines)


def write_csv(result: ReplayResult, path: Path) -> None:
    """One row per attitude output; energy and momentum where published at that stamp."""
    stamps, attitudes, positions = result.series.attitude_array()
    invariant_stamps, energies, momenta = result.series.invariant_array()
    invariants = {int(s): (e, m) for s, e, m in zip(invariant_stamps.tolist(),
                                                    energies.tolist(), momenta.tolist())}
    with open(path, 'w', newline='', encoding='utf-8') as stream:
        out = csv.writer(stream)
        out.writerow(['stamp_s', 'qw', 'qx', 'qy', 'qz', 'px', 'py', 'pz', 'energy_J',
                      'Hx', 'Hy', 'Hz'])
        for stamp, q, p in zip(stamps.tolist(), attitudes.tolist(), positions.tolist()):
            energy, momentum = invariants.get(stamp, ('', ('', '', '')))
            out.writerow([_stamp_text(stamp), *map(repr, q), *map(repr, p),
                          repr(energy) if energy != '' else '',
                          *(repr(v) if v != '' else '' for v in momentum)])


def write_error_csv(errors: ErrorStatistics, path: Path) -> None:
    """The attitude error at each ground-truth stamp compared."""
    with open(path, 'w', newline='', encoding='utf-8') as stream:
        out = csv.writer(stream)
        out.writerow(['stamp_s', 'attitude_error_rad'])
        for stamp, error in zip(errors.stamps_ns.tolist(), errors.errors.tolist()):
            out.writerow([_stamp_text(stamp), repr(error)])


def _stamp_text(stamp_ns: int) -> str:
    sec, nanosec = divmod(stamp_ns, NANOSECONDS_PER_SECOND)
    return f'{sec}.{nanosec:09d}'


def write_plot(result: ReplayResult, path: Path) -> None:
    """PNG: attitude error [deg] and energy [J] against time [s]."""
    import matplotlib
    matplotlib.use('Agg')
    from matplotlib import pyplot
    invariant_stamps, energies, _ = result.series.invariant_array()
    origin = (result.errors.stamps_ns[0] if result.errors is not None and result.errors.count
              else (invariant_stamps[0] if invariant_stamps.size else 0))
    figure, (error_axes, energy_axes) = pyplot.subplots(2, 1, sharex=True, figsize=(9, 6))
    if result.errors is not None and result.errors.count:
        error_axes.plot((result.errors.stamps_ns - origin) * 1e-9,
                        np.degrees(result.errors.errors), linewidth=0.8)
    error_axes.set_ylabel('attitude error [deg]')
    error_axes.set_title(f'{result.input_path.name}: scene {result.scene.name}, '
                         f'{result.scene.integrator}')
    error_axes.grid(True, alpha=0.3)
    energy_axes.plot((invariant_stamps - origin) * 1e-9, energies, linewidth=0.8)
    energy_axes.set_ylabel('kinetic energy [J]')
    energy_axes.set_xlabel(f'time since stamp {origin * 1e-9:.3f} s [s]')
    energy_axes.grid(True, alpha=0.3)
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    pyplot.close(figure)


# -- command line ---------------------------------------------------------------------------


def _parser() -> argparse.ArgumentParser:
    defaults = NODE_DEFAULTS
    parser = argparse.ArgumentParser(
        prog='replay',
        description='Replay a rosbag2 bag (sqlite3 or mcap) through the propagation node\'s '
                    'code and write its outputs (orientation, pose, energy, angular_momentum, '
                    '/diagnostics, twist or imu/data) to a new bag.')
    parser.add_argument('bag', help='input bag (directory with metadata.yaml, or a .db3/.mcap '
                                    'file)')
    parser.add_argument('-o', '--output', help='output bag directory (must not exist; '
                                               'default: BAG_replayed)')
    parser.add_argument('--storage', choices=sorted(STORAGES), default='sqlite3',
                        help='storage of the output bag (default: %(default)s)')
    node = parser.add_argument_group('node parameters (same names and defaults as the node)')
    node.add_argument('--scene', help=f'built-in scene or scene YAML (default: '
                                      f'{defaults["scene"]})')
    node.add_argument('--integrator', default=defaults['integrator'],
                      help='integrator or strapdown method (default: the scene\'s)')
    node.add_argument('--step', type=float, default=defaults['step'],
                      help='dynamics step [s] (default: the scene\'s)')
    node.add_argument('--max-dt', type=float, default=defaults['max_dt'],
                      help='longest gyro interval integrated [s] (default: %(default)s)')
    node.add_argument('--time-jump-threshold', type=float,
                      default=defaults['time_jump_threshold'],
                      help='backward jump that resets [s] (default: %(default)s)')
    node.add_argument('--publish-rate', type=float, default=defaults['publish_rate'],
                      help='clock ticks per second [Hz] (default: %(default)s)')
    node.add_argument('--constant-dt', type=float, default=defaults['constant_dt'],
                      help='integrate each gyro sample over this step [s] (default: 0 = '
                           'stamps)')
    node.add_argument('--no-header-stamps', action='store_true',
                      help='use bag (receive) times instead of header stamps')
    node.add_argument('--torque-timeout', type=float, default=defaults['torque_timeout'],
                      help='command hold time [s] (default: the scene\'s)')
    node.add_argument('--world-frame', default=defaults['world_frame'],
                      help='frame of orientation, pose, angular_momentum (default: %(default)s)')
    node.add_argument('--body-frame', default=defaults['body_frame'],
                      help='frame of twist (default: %(default)s)')
    topics = parser.add_argument_group('topics')
    topics.add_argument('--gyro-topic', default='',
                        help='Imu, Vector3Stamped or TwistStamped rates (default: imu, else '
                             'angular_velocity)')
    topics.add_argument('--torque-topic', default=TORQUE_TOPIC,
                        help='WrenchStamped commands (default: %(default)s)')
    topics.add_argument('--rotor-torque-topic', default=ROTOR_TORQUE_TOPIC,
                        help='Vector3Stamped rotor torque commands (default: %(default)s)')
    topics.add_argument('--set-pose-topic', default=SET_POSE_TOPIC,
                        help='PoseStamped attitude re-initialisations (default: %(default)s)')
    topics.add_argument('--outputs', default='',
                        help='comma-separated output topics to write (default: all)')
    report = parser.add_argument_group('report')
    report.add_argument('--ground-truth', metavar='TOPIC', default='',
                        help='QuaternionStamped or PoseStamped attitude to compare with')
    report.add_argument('--start-from-ground-truth', metavar='STAMP', type=float,
                        help='set the attitude from the ground truth at the first output at '
                             'or after this header stamp [s]')
    report.add_argument('--plot', metavar='PNG',
                        help='error and energy plot (default with --ground-truth: '
                             'OUTPUT_error.png)')
    report.add_argument('--csv', metavar='FILE',
                        help='outputs as CSV (and FILE_error.csv with --ground-truth)')
    report.add_argument('--progress', action=argparse.BooleanOptionalAction, default=None,
                        help='progress bar (default: on a terminal)')
    return parser


def _options(args: argparse.Namespace) -> ReplayOptions:
    outputs = tuple(name.strip() for name in args.outputs.split(',') if name.strip())
    return ReplayOptions(
        scene=args.scene or NODE_DEFAULTS['scene'], integrator=args.integrator,
        step=args.step, max_dt=args.max_dt, time_jump_threshold=args.time_jump_threshold,
        publish_rate=args.publish_rate, constant_dt=args.constant_dt,
        use_header_stamps=not args.no_header_stamps, torque_timeout=args.torque_timeout,
        world_frame=args.world_frame, body_frame=args.body_frame, gyro_topic=args.gyro_topic,
        torque_topic=args.torque_topic, rotor_torque_topic=args.rotor_torque_topic,
        set_pose_topic=args.set_pose_topic,
        ground_truth_topic=args.ground_truth,
        start_from_ground_truth=args.start_from_ground_truth, outputs=outputs,
        storage=args.storage)


def _default_output(bag: str) -> Path:
    path = Path(bag)
    if path.is_file():
        path = path.parent if path.parent.joinpath('metadata.yaml').is_file() else path
        return path.with_name(path.stem + '_replayed')
    return path.with_name(path.name + '_replayed')


def main(argv: Sequence[str] | None = None) -> int:
    """Command-line entry point: 0 on success, 1 with ``error: ...`` for unusable input."""
    args = _parser().parse_args(argv)
    output = Path(args.output) if args.output else _default_output(args.bag)
    try:
        options = _options(args)
        result = replay_bag(args.bag, output, options, progress=args.progress,
                            keep_series=bool(args.csv or args.plot),
                            scene_given=args.scene is not None)
        print(summary(result))
        if args.csv:
            write_csv(result, Path(args.csv))
            print(f'wrote {args.csv}')
            if result.errors is not None:
                error_csv = Path(args.csv).with_name(Path(args.csv).stem + '_error.csv')
                write_error_csv(result.errors, error_csv)
                print(f'wrote {error_csv}')
        plot = args.plot or (str(output) + '_error.png' if result.errors is not None else '')
        if plot:
            write_plot(result, Path(plot))
            print(f'wrote {plot}')
    except AttitudeError as err:
        print(f'error: {err}', file=sys.stderr)
        return 1
    except OSError as err:
        print(f'error: {err}', file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print('error: interrupted; no output bag written', file=sys.stderr)
        return 130
    return 0


if __name__ == '__main__':
    sys.exit(main())
