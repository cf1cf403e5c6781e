"""Topic planning: the bag's topics checked against the scene and the options.

Finds the gyro topic (gyro scenes), the command and ``set_pose`` topics the scene takes, the
ground truth, and the output topics (the node's replayed inputs and outputs of
:data:`~rigid_body_attitude.session.interface.NODE_INTERFACE`); checks their types; and says in
notes what is ignored.
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
from rigid_body_attitude.msgs import ATTITUDE_DECODERS, IMU, RATE_DECODERS
from rigid_body_attitude.session.interface import NODE_INTERFACE, Situation
from rigid_body_attitude.tools.replay.options import REPLAYED_OUTPUTS, ReplayOptions

__all__ = ['Plan', 'make_plan']

Decoder = Callable[[bytes], tuple[Any, ...]]

#: The node's gyro topics, in the order the replay looks for them.
GYRO_TOPICS = tuple(endpoint.name for endpoint in NODE_INTERFACE.inputs_of_quantity(
    'angular_rate'))
#: The roles of the outputs a replay writes: the session's, the simulated sensors' and their
#: mounts.
_WRITTEN = ('output', 'diagnostics', 'simulated_sensor', 'tf_static')


@dataclass(frozen=True)
class Plan:
    """Topics resolved against the bag.

    Attributes:
        gyro_topic: the bag's gyro topic (``''`` for dynamics scenes).
        gyro_type: its message type (its decoder: the rate registry's), or ``''``.
        inputs: bag topic → the node's input topic it feeds (``torque``, ``rotor_torque``,
            ``set_pose``, ``imu/mag``, ``attitude_measurement``), besides the gyro.
        ground_truth_topic: the bag's ground-truth topic, or ``''``.
        outputs: output topic → its message type, in the node's order (a simulated
            sensor's topic as the scene names it).
        notes: remarks for the user (ignored topics and the like).
    """

    gyro_topic: str
    gyro_type: str
    inputs: dict[str, str]
    ground_truth_topic: str
    outputs: dict[str, str]
    notes: tuple[str, ...]

    @property
    def gyro_is_imu(self) -> bool:
        """Whether the gyro topic carries ``sensor_msgs/Imu`` (so ``imu/data`` is written)."""
        return self.gyro_type == IMU

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


def _gyro_topic(reader: BagReader, options: ReplayOptions) -> tuple[str, str]:
    if options.gyro_topic:
        topic = _required(reader, options.gyro_topic, 'Gyro')
    else:
        topic = next((found for found in (_resolve(reader.topics, name) for name in GYRO_TOPICS)
                      if found), '')
        if not topic:
            raise BagError(f'No gyro topic in bag {str(reader.path)!r}: expected '
                           f'{" or ".join(repr(name) for name in GYRO_TOPICS)} (or name one '
                           f'with --gyro-topic); {_listing(reader)}')
    _typed_decoder(reader, topic, RATE_DECODERS)
    return topic, reader.topics[topic]


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


def _bag_name(options: ReplayOptions, node_topic: str) -> str:
    """The bag topic the options give for the node's input ``node_topic``."""
    return {'torque': options.torque_topic, 'rotor_torque': options.rotor_torque_topic,
            'set_pose': options.set_pose_topic}.get(node_topic, node_topic)


def make_plan(reader: BagReader, scene: Scene, input_names: frozenset[str],
              options: ReplayOptions, scene_given: bool) -> Plan:
    """Check the bag's topics against the scene (whose propagator takes ``input_names``) and
    the options; raise BagError (or InputError for an output the scene lacks)."""
    notes: list[str] = []
    is_gyro = scene.rate_source == 'gyro'
    gyro_topic, gyro_type = '', ''
    if is_gyro:
        gyro_topic, gyro_type = _gyro_topic(reader, options)
    elif options.gyro_topic:
        _required(reader, options.gyro_topic, 'Gyro')
        notes.append(f'gyro topic {options.gyro_topic!r} ignored: scene {scene.name!r} '
                     f'integrates its own dynamics')
    elif not scene_given and any(_resolve(reader.topics, name) for name in GYRO_TOPICS):
        notes.append(f'the bag has gyro data but the default scene {scene.name!r} is a '
                     f'dynamics scene: use --scene strapdown to integrate the gyro')
    situation = Situation(scene, options.parameters(), input_names, gyro_type == IMU)
    inputs = {}
    for endpoint in NODE_INTERFACE:
        sample_input = endpoint.role == 'sensor' and endpoint.name not in GYRO_TOPICS
        if endpoint.direction != 'in' or not (
                endpoint.role in ('command', 'reset') or sample_input):
            continue
        command = endpoint.role == 'command' or sample_input
        found = _command_topic(reader, _bag_name(options, endpoint.name), endpoint.name,
                               endpoint.present(situation), (endpoint.type,),
                               notes if command else [])
        if found:
            inputs[found] = endpoint.name
    truth_topic = ''
    if options.ground_truth_topic:
        truth_topic = _required(reader, options.ground_truth_topic, 'Ground-truth')
        reader.decoder(truth_topic, ATTITUDE_DECODERS)
    outputs = _outputs(scene, situation, options.outputs)
    return Plan(gyro_topic, gyro_type, inputs, truth_topic, outputs, tuple(notes))


def _outputs(scene: Scene, situation: Situation, selected: Sequence[str]) -> dict[str, str]:
    """The output topics (all those replayed for ``situation``, or the ``selected`` ones)
    and their types; InputError for a topic the node does not have or not for this scene."""
    available = {endpoint.topic(scene): endpoint.type
                 for endpoint in NODE_INTERFACE.outputs(situation, _WRITTEN)
                 if endpoint.replayed}
    unknown = [name for name in selected
               if name not in REPLAYED_OUTPUTS and name not in available]
    if unknown:
        raise InputError(f'Unknown output topic {unknown[0]!r}; valid choices: '
                         f'{", ".join(REPLAYED_OUTPUTS)} and the scene\'s sensor topics')
    missing = [name for name in selected if name not in available]
    if missing:
        raise InputError(f'Output {missing[0]!r} is not published for scene {scene.name!r} '
                         f'with this input; valid choices: {", ".join(available)}')
    if not selected:
        return available
    return {name: msgtype for name, msgtype in available.items() if name in selected}
