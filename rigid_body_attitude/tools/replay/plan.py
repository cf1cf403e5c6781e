"""Topic planning: the bag's topics checked against the scene and the options.

Finds the gyro topic (gyro scenes), the command and ``set_pose`` topics the scene takes, the
ground truth, and the output topics; checks their types; and says in notes what is ignored.
A topic named in the options but missing from the bag, or of a type the replay cannot use,
is a :class:`~rigid_body_attitude.bag.BagError` that lists the bag's topics.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from rigid_body_attitude.bag import BagError, BagReader
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.core.dynamics.scene import Scene
from rigid_body_attitude.msgs import (
    ATTITUDE_DECODERS, IMU, POSE_STAMPED, POSE_WITH_COVARIANCE_STAMPED, VECTOR3_STAMPED,
    WRENCH_STAMPED)
from rigid_body_attitude.session.decoding import RATE_DECODERS
from rigid_body_attitude.session.settings import (
    GYRO_TOPICS, ROTOR_TORQUE_TOPIC, SET_POSE_TOPIC, SET_POSE_WITH_COVARIANCE_TOPIC,
    TORQUE_TOPIC, input_topics, output_topics)
from rigid_body_attitude.tools.replay.options import ReplayOptions

__all__ = ['Plan', 'make_plan']

Decoder = Callable[[bytes], tuple[Any, ...]]


@dataclass(frozen=True)
class Plan:
    """Topics resolved against the bag.

    Attributes:
        gyro_topic: the bag's gyro topic (``''`` for dynamics scenes).
        gyro_decoder: its decoder (by message type), or None.
        gyro_is_imu: the gyro topic carries ``sensor_msgs/Imu`` (so ``imu/data`` is written).
        inputs: bag topic → the node's input topic it feeds (``torque``, ``rotor_torque``,
            ``set_pose``), besides the gyro.
        ground_truth_topic: the bag's ground-truth topic, or ``''``.
        outputs: output topics to write, in the node's order.
        notes: remarks for the user (ignored topics and the like).
    """

    gyro_topic: str
    gyro_decoder: Decoder | None
    gyro_is_imu: bool
    inputs: dict[str, str]
    ground_truth_topic: str
    outputs: tuple[str, ...]
    notes: tuple[str, ...]

    def read_topics(self, all_topics: Iterable[str]) -> list[str]:
        """The topics to read: the inputs for gyro scenes; every topic for dynamics scenes
        (any message advances their clock)."""
        if self.gyro_topic:
            return [self.gyro_topic, *self.inputs]
        return list(all_topics)


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


def _typed_decoder(reader: BagReader, topic: str, decoders: Mapping[str, Decoder]) -> Decoder:
    """The decoder of ``topic``'s one message type, or BagError."""
    reader.connections({topic: decoders.keys()})
    msgtype = reader.topics[topic]
    if msgtype not in decoders:
        raise BagError(f'Expected topic {topic!r} to carry one message type, got {msgtype!r}')
    return decoders[msgtype]


def _gyro_topic(reader: BagReader, options: ReplayOptions) -> tuple[str, Decoder, bool]:
    if options.gyro_topic:
        topic = _required(reader, options.gyro_topic, 'Gyro')
    else:
        topic = next((found for found in (_resolve(reader.topics, name) for name in GYRO_TOPICS)
                      if found), '')
        if not topic:
            raise BagError(f'No gyro topic in bag {str(reader.path)!r}: expected '
                           f'{" or ".join(repr(name) for name in GYRO_TOPICS)} (or name one '
                           f'with --gyro-topic); {_listing(reader)}')
    decoder = _typed_decoder(reader, topic, RATE_DECODERS)
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


def make_plan(reader: BagReader, scene: Scene, input_names: frozenset[str],
              options: ReplayOptions, scene_given: bool) -> Plan:
    """Check the bag's topics against the scene (whose propagator takes ``input_names``) and
    the options; raise BagError (or InputError for an output the scene lacks)."""
    notes: list[str] = []
    is_gyro = scene.rate_source == 'gyro'
    gyro_topic, gyro_decoder, is_imu = '', None, False
    if is_gyro:
        gyro_topic, gyro_decoder, is_imu = _gyro_topic(reader, options)
    elif options.gyro_topic:
        _required(reader, options.gyro_topic, 'Gyro')
        notes.append(f'gyro topic {options.gyro_topic!r} ignored: scene {scene.name!r} '
                     f'integrates its own dynamics')
    elif not scene_given and any(_resolve(reader.topics, name) for name in GYRO_TOPICS):
        notes.append(f'the bag has gyro data but the default scene {scene.name!r} is a '
                     f'dynamics scene: use --scene strapdown to integrate the gyro')
    node_inputs = input_topics(scene, input_names)  # what the node subscribes to
    inputs = {}
    for name, default, accepted in (
            (options.torque_topic, TORQUE_TOPIC, (WRENCH_STAMPED,)),
            (options.rotor_torque_topic, ROTOR_TORQUE_TOPIC, (VECTOR3_STAMPED,))):
        found = _command_topic(reader, name, default, default in node_inputs, accepted, notes)
        if found:
            inputs[found] = default
    found = _command_topic(reader, options.set_pose_topic, SET_POSE_TOPIC, True,
                           (POSE_STAMPED,), [])
    if found:
        inputs[found] = SET_POSE_TOPIC
    found = _command_topic(reader, SET_POSE_WITH_COVARIANCE_TOPIC,
                           SET_POSE_WITH_COVARIANCE_TOPIC, True, (POSE_WITH_COVARIANCE_STAMPED,),
                           [])
    if found:
        inputs[found] = SET_POSE_WITH_COVARIANCE_TOPIC
    truth_topic = ''
    if options.ground_truth_topic:
        truth_topic = _required(reader, options.ground_truth_topic, 'Ground-truth')
        reader.decoder(truth_topic, ATTITUDE_DECODERS)
    available = output_topics(scene, imu_input=is_imu, covariance=options.covariance)
    outputs = options.outputs or available
    missing = [name for name in outputs if name not in available]
    if missing:
        raise InputError(f'Output {missing[0]!r} is not published for scene {scene.name!r} '
                         f'with this input; valid choices: {", ".join(available)}')
    return Plan(gyro_topic, gyro_decoder, is_imu, inputs, truth_topic, tuple(outputs),
                tuple(notes))
