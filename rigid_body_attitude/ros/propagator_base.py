"""The attitude propagator's behaviour over any rclpy node: :class:`PropagatorMixin`.

The plain node (:class:`~.node.AttitudePropagatorNode`, executable ``propagation_node``) builds
it all when it starts; the managed node (:class:`~.managed_node.ManagedPropagatorNode`,
executable ``managed_propagation_node``) builds it on ``configure`` and releases it on
``cleanup``. What is built (scene, session, outputs, subscriptions, timers, services) is one
:class:`NodeParts`, the node's :attr:`~PropagatorMixin.parts`: releasing it is one
assignment, so nothing built can outlive a cleanup. Both declare the parameters of
:data:`rigid_body_attitude.session.parameters.PARAMETERS` and serve the same topics, services
and timers with the same callbacks (:mod:`~.node` describes them).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.parameter import Parameter as RosParameter
from rclpy.service import Service
from rclpy.subscription import Subscription
from rclpy.timer import Timer
from rcl_interfaces.msg import SetParametersResult
from std_srvs.srv import Trigger

from rigid_body_attitude.core.dynamics.scene import Scene
from rigid_body_attitude.core.errors import InputError
from rigid_body_attitude.session.base import LEVEL_INFO
from rigid_body_attitude.session.decoding import (
    ANGULAR_RATE, decoder, input_handler, MALFORMED)
from rigid_body_attitude.ros.raw_take_loop import DedicatedGroup, DRAINED
from rigid_body_attitude.ros.interface import create_service, create_subscription
from rigid_body_attitude.ros.outputs import RawOutput, RosOutputs
from rigid_body_attitude.ros.parameters import (
    declare_table_parameter, parameter_values, ros_value)
from rigid_body_attitude.ros.rclpy_internals import clock_nanoseconds, raw_taker
from rigid_body_attitude.session.dynamics import DynamicsSession
from rigid_body_attitude.session.filtered_gyro import FilteredGyroSession
from rigid_body_attitude.session.gyro import GyroSession
from rigid_body_attitude.session.interface import Endpoint, NODE_INTERFACE, Situation
from rigid_body_attitude.session.mount_gate import MountGate
from rigid_body_attitude.session.parameters import Parameter, PARAMETERS, check_values
from rigid_body_attitude.session.settings import (
    DIAGNOSTICS_PERIOD, load_node_scene, open_session, AnySession, timer_period_ns)
from rigid_body_attitude.session.sim_clock import SimClock, sim_clock_for, sim_clock_problem

__all__ = ['LOG_EVERY_PERIODS', 'NodeParts', 'PropagatorMixin']

#: Diagnostics periods between INFO log lines.
LOG_EVERY_PERIODS = 5


@dataclass
class NodeParts:
    """Everything a propagator node builds from its parameters, held as one object.

    Attributes:
        state_lock: held by every callback that touches the session.
        clock_ns: the node clock in nanoseconds (receive times; ``use_sim_time`` makes it the
            ``/clock``).
        scene: the scene with the node's overrides.
        publish_rate: the output timer's rate [Hz] (dynamics scenes).
        outputs: the session's sink over the publishers.
        sim_clock: the scene's own clock (``publish_clock``, ``lockstep``), or ``None``.
        session: the session of the scene's rate source.
        situation: what decides the node's endpoints (:data:`NODE_INTERFACE`).
        loop_group: the callback group of the sensor inputs and timers, which the raw-take
            loop claims.
        clock_output: ``/clock`` (``publish_clock``), or ``None``.
        subscriptions_by_topic, takers, handlers: per input topic, its raw subscription, its
            take function and its callback.
        mount_gate: the gyro samples' mount gate (gyro scenes), or ``None``.
        tf_static_subscription: ``/tf_static`` (gyro scenes), or ``None``.
        output_timer, diagnostics_timer, reset_service: the timers and ``~/reset``.
        diagnostics_count: diagnostics periods so far.
    """

    state_lock: threading.Lock
    clock_ns: Callable[[], int]
    scene: Scene
    publish_rate: float
    outputs: RosOutputs
    sim_clock: SimClock | None
    session: AnySession
    situation: Situation
    loop_group: DedicatedGroup = field(default_factory=DedicatedGroup)
    clock_output: RawOutput | None = None
    subscriptions_by_topic: dict[str, Subscription] = field(default_factory=dict)
    takers: dict[str, Callable[[], bytes | None]] = field(default_factory=dict)
    handlers: dict[str, Callable[[bytes], object]] = field(default_factory=dict)
    mount_gate: MountGate | None = None
    tf_static_subscription: Subscription | None = None
    output_timer: Timer | None = None
    diagnostics_timer: Timer | None = None
    reset_service: Service | None = None
    diagnostics_count: int = 0

    @property
    def is_dynamics(self) -> bool:
        """Whether the scene integrates Euler's equations (else gyro samples)."""
        return isinstance(self.session, DynamicsSession)


class PropagatorMixin(Node):
    """The node's parameters, scene, session, topics, timers and callbacks, on a node of the
    class it is mixed into (no ``__init__`` of its own).

    :meth:`declare_parameters_of_table` declares the parameters; :meth:`build` loads the
    scene and creates the session, publishers, subscriptions, timers and ``~/reset``, all held
    by :attr:`parts` (bad parameters or a bad scene raise :class:`InputError` or
    :class:`~rigid_body_attitude.core.errors.SceneError`). Every callback that touches the
    session holds the parts' ``state_lock``.
    """

    #: What :meth:`build` made (``None``: nothing built, or released).
    parts: NodeParts | None = None

    @property
    def configured(self) -> bool:
        """Whether :meth:`build` made the session and its entities."""
        return self.parts is not None

    @property
    def built(self) -> NodeParts:
        """:attr:`parts`, which must exist (the node was built)."""
        parts = self.parts
        if parts is None:
            raise RuntimeError('Expected a built node, got one not configured')
        return parts

    def build(self, values: dict[str, Any]) -> None:
        """Load the scene of the parameter ``values`` and create the session, topics, timers
        and services: :attr:`parts`."""
        problem = check_values(values)
        if problem:
            raise InputError(problem)
        clock_ns = clock_nanoseconds(self.get_clock())
        scene = load_node_scene(values['scene'], values['integrator'], values['step'],
                                values['torque_timeout'])
        publish_rate: float = values['publish_rate']
        outputs = RosOutputs(self, Situation(scene, values))
        outputs.diagnostics_publisher.hardware_id = scene.name
        sim_clock = sim_clock_for(values, timer_period_ns(publish_rate), time.monotonic)
        session: AnySession = open_session(scene, values, outputs, (
            clock_ns if sim_clock is None else sim_clock.now), time.monotonic)
        problem = session.check(values) or sim_clock_problem(
            values, scene, getattr(session, 'command_inputs', ()))
        if problem:
            raise InputError(problem)
        if isinstance(session, DynamicsSession):
            session.sim_clock = sim_clock
        parts = self.parts = NodeParts(
            threading.Lock(), clock_ns, scene, publish_rate, outputs, sim_clock, session,
            Situation(scene, values, session.propagator.input_names))
        parts.clock_output = next(
            (RawOutput.of(self, endpoint)
             for endpoint in NODE_INTERFACE.outputs(parts.situation, ('clock',))), None)
        outputs.set_frames(values['world_frame'], values['body_frame'])
        outputs.log_queue.start()
        if values['publish_tf']:
            outputs.enable_tf(values['tf_rate'])
        outputs.enable_simulated_sensors(values['body_frame'])
        self._create_inputs(parts)
        self._create_timers(parts)
        parts.reset_service = create_service(
            self, NODE_INTERFACE.endpoint('~/reset', 'service'), self.reset_callback)
        self.get_logger().info(
            f'scene {scene.name!r} ({scene.rate_source}, {scene.integrator}'
            f'{", step %g s" % scene.step if parts.is_dynamics else ""}): {scene.description}')

    # -- set-up -----------------------------------------------------------------------------

    def declare_parameters_of_table(self) -> dict[str, Any]:
        """Declare every parameter of the table; their values by name (a bad one raises
        :class:`InputError`)."""
        return {parameter.name: self.declare_table_parameter(parameter)
                for parameter in PARAMETERS}

    def declare_table_parameter(self, parameter: Parameter, ignore_override: bool = False
                                ) -> Any:
        """Declare ``parameter`` (:func:`declare_table_parameter`)."""
        return declare_table_parameter(self, parameter, ignore_override)

    def _create_inputs(self, parts: NodeParts) -> None:
        """Raw subscriptions for the inputs of :data:`NODE_INTERFACE` present for the scene
        (``/tf_static`` for gyro scenes: the mount).

        The sensor subscriptions (and, on the scene's own sim clock, the commands) share the
        parts' :class:`DedicatedGroup`, so :func:`~.serve.main`'s raw-take loop can take them
        over (:meth:`~.node.AttitudePropagatorNode.serving_loop`).
        """
        session = parts.session
        for endpoint in NODE_INTERFACE.inputs(parts.situation, ('transforms',)):
            if isinstance(session, GyroSession):
                parts.mount_gate = MountGate(session, self.get_parameter('tf_timeout').value,
                                             time.monotonic)
                if isinstance(session, FilteredGyroSession):
                    session.frame_mount = parts.mount_gate.mount_of
                parts.tf_static_subscription = create_subscription(
                    self, endpoint, self.tf_static_callback)
        for endpoint in NODE_INTERFACE.inputs(parts.situation):
            topic, sensor = endpoint.name, endpoint.role == 'sensor'
            handler = self.gated(self._sensor_handler(parts, endpoint) if sensor
                                 else self._command_callback(parts, endpoint))
            parts.handlers[topic] = handler
            subscription = create_subscription(
                self, endpoint, handler,
                parts.loop_group if sensor or parts.sim_clock else None)
            parts.subscriptions_by_topic[topic] = subscription
            parts.takers[topic] = raw_taker(subscription)

    def gated(self, handler: Callable[[bytes], object]) -> Callable[[bytes], object]:
        """The callback of an input topic around the session's ``handler``: ``handler``
        itself (the managed node lets it through only while active)."""
        return handler

    def _sensor_handler(self, parts: NodeParts, endpoint: Endpoint) -> Callable[[bytes], None]:
        """The session's handler of a sensor topic (:func:`input_handler`) under the state
        lock; a gyro topic's behind the mount gate until it opens."""
        gate, lock = parts.mount_gate, parts.state_lock
        handle = input_handler(parts.session, endpoint.name)
        if endpoint.quantity == ANGULAR_RATE and gate is not None:
            handle = gate.gated(handle)

        def locked(data: bytes) -> None:
            with lock:
                handle(data)
        return locked

    def _command_callback(self, parts: NodeParts, endpoint: Endpoint
                          ) -> Callable[[bytes], object]:
        """The callback of a command topic: it also takes every message queued behind the
        one it was given and hands only the newest decodable one to the session (the others
        are counted ``superseded``; malformed ones ``malformed``), and returns
        :data:`~.raw_take_loop.DRAINED`. On rclpy's stock path nothing more is taken: each
        message comes to the callback."""
        topic = endpoint.name
        decode, handle = decoder(topic), input_handler(parts.session, topic)
        session, lock, takers = parts.session, parts.state_lock, parts.takers

        def coalesce(data: bytes) -> object:
            take = takers[topic]
            newest: bytes | None = None
            superseded = 0
            taken: bytes | None = data
            while taken is not None:
                try:
                    decode(taken)
                except MALFORMED:
                    with lock:
                        handle(taken)  # counted as malformed
                else:
                    superseded += newest is not None
                    newest = taken
                taken = take()
            with lock:
                if superseded:
                    session.rejections['superseded'] += superseded
                if newest is not None:
                    handle(newest)
            return DRAINED
        return coalesce

    def tf_static_callback(self, data: bytes) -> None:
        """Static transforms for the mount
        (:meth:`~rigid_body_attitude.session.mount_gate.MountGate.tf_static`)."""
        parts = self.built
        gate = parts.mount_gate
        if gate is not None and not gate.open:
            gate.tf_static(data, parts.state_lock)

    def _create_timers(self, parts: NodeParts) -> None:
        """The output timer (node clock; dynamics scenes only) and the diagnostics timer
        (steady clock), in the loop group, so :func:`~.serve.main`'s raw-take loop serves them (an
        executor rebuilds its wait set of every entity per tick: about 2.8 % of a core at
        50 Hz)."""
        parts.output_timer = (
            self.create_timer(1.0 / parts.publish_rate, self.tick_callback, parts.loop_group)
            if parts.is_dynamics and parts.sim_clock is None else None)
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        parts.diagnostics_timer = self.create_timer(
            DIAGNOSTICS_PERIOD, self.diagnostics_callback, parts.loop_group, clock=steady)

    # -- parameters -------------------------------------------------------------------------

    def get_parameters_values(self) -> dict[str, Any]:
        """Current values of the node's own parameters by name."""
        return parameter_values(self)

    def parameters_callback(self, parameters: list[RosParameter]) -> SetParametersResult:
        """Refuse run-time values that the parameter table or the session finds unusable."""
        values = self.get_parameters_values()
        by_name = {p.name: p for p in PARAMETERS}
        values.update({p.name: ros_value(by_name[p.name], p.value) for p in parameters
                       if p.name in values})
        parts = self.parts
        reason = parts.session.check(values) if parts is not None else check_values(values)
        return SetParametersResult(successful=not reason, reason=reason)

    def parameters_set_callback(self, parameters: list[RosParameter]) -> None:
        """Apply accepted run-time changes (frames, stamps, max_dt, thresholds)."""
        parts = self.parts
        if parts is None:  # taken by the next build
            return
        values = self.get_parameters_values()
        with parts.state_lock:
            parts.session.apply(values)
            parts.outputs.set_frames(values['world_frame'], values['body_frame'])

    # -- services and timers ----------------------------------------------------------------

    def reset_callback(self, request: Trigger.Request,
                       response: Trigger.Response) -> Trigger.Response:
        """Back to the scene's initial state (gyro: the next sample is a new baseline)."""
        parts = self.built
        with parts.state_lock:
            parts.session.reset()
        response.success = True
        response.message = f'reset to the initial state of scene {parts.scene.name!r}'
        parts.outputs.log(LEVEL_INFO, response.message)
        return response

    def tick_callback(self) -> None:
        """The output timer of a dynamics scene: integrate up to the node clock, publish."""
        parts = self.built
        with parts.state_lock:
            session = parts.session
            if isinstance(session, DynamicsSession):
                session.tick(parts.clock_ns())

    def diagnostics_callback(self) -> None:
        """Publish ``/diagnostics``; every :data:`LOG_EVERY_PERIODS` periods log a summary."""
        parts = self.built
        with parts.state_lock:
            parts.session.publish_diagnostics()
            parts.diagnostics_count += 1
            if parts.diagnostics_count % LOG_EVERY_PERIODS == 0:
                parts.outputs.log(LEVEL_INFO, parts.session.summary())
